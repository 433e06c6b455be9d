//! Which controller explores a model, and where it starts: the kiosk and replays build theirs
//! here.

use super::{Acevit, AcevitSettings, Camera, Controller, IsoCam, IsoCamSettings, SceneRef, Trackball};
use crate::scene::store::NONE;
use crate::scene::{NodeId, Store};
use glam::DVec3;

/// Which controller a replay uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControllerKind {
    /// IsoCam.
    IsoCam,
    /// Virtual trackball.
    Trackball,
    /// ACeViT.
    Acevit,
}

impl ControllerKind {
    /// Its name in traces and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::IsoCam => "isocam",
            Self::Trackball => "trackball",
            Self::Acevit => "acevit",
        }
    }
}

impl std::str::FromStr for ControllerKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "isocam" => Ok(Self::IsoCam),
            "trackball" => Ok(Self::Trackball),
            "acevit" => Ok(Self::Acevit),
            other => Err(format!("unknown controller '{other}' (isocam, trackball, acevit)")),
        }
    }
}

/// The side of a model the start view looks at when its exhibit does not say: +Z (the view
/// looks along −Z), or −Y for a model standing on Z (Z the axis nearest its up), levelled to `up`
/// (perpendicular to it, so that the start view is level for a model standing tilted too; the six
/// axes keep exactly these fronts, and a small tilt turns the front by as much).
pub fn default_front(up: DVec3) -> DVec3 {
    let up = up.try_normalize().unwrap_or(DVec3::Y);
    let on_z = up.z.abs() > up.x.abs().max(up.y.abs());
    let f = if on_z { DVec3::NEG_Y } else { DVec3::Z };
    super::orthonormal_up(up, f, f)
}

/// The camera the kiosk starts with: the whole model framed from its `front` side (unit,
/// perpendicular to `up`; `None`: [`default_front`]), upright, its bounding sphere being the one
/// of [`upright_bounds`]; level, or looking down on a flat model ([`start_elevation`]).
pub fn start_camera<B: AsRef<[u8]>>(store: &Store<B>, fov_y: f64, up: DVec3, front: Option<DVec3>) -> Camera {
    let from =
        front.map(|f| f - up * f.dot(up)).and_then(DVec3::try_normalize).unwrap_or_else(|| default_front(up));
    let (center, radius) = upright_bounds(store, up, from);
    let size = store.bbox().extent().as_dvec3().abs();
    let e = start_elevation(size, up, from);
    let from = (from * e.cos() + up * e.sin()).try_normalize().unwrap_or(from);
    Camera::framing(center, radius.max(f64::MIN_POSITIVE), from, up, fov_y)
}

/// How far above the horizon (radians) the start view looks down at a model whose box has the
/// sides `size` (the store's axes), standing on `up`, seen from `from`: level for a model at
/// least a third as tall as it is wide, 45° for one at most a tenth (a terrain, a tablet lying
/// on its back: seen level, a thin strip across the screen), in between in proportion.
pub fn start_elevation(size: DVec3, up: DVec3, from: DVec3) -> f64 {
    let along = |d: DVec3| (size * d.abs()).element_sum();
    let wide = along(from).max(along(up.cross(from)));
    if wide <= 0.0 || !wide.is_finite() {
        return 0.0;
    }
    let (level, flat) = (1.0 / 3.0, 0.1);
    ((level - along(up) / wide) / (level - flat)).clamp(0.0, 1.0) * std::f64::consts::FRAC_PI_4
}

/// The centre and half diagonal of the model's bounding box in its upright frame (`up`, `front`
/// and their cross product; both unit and perpendicular), in model coordinates. When that frame's
/// axes are the file's (a model standing on an axis, seen from an axis), the box is the store's
/// own. A model turned any other way would be framed loosely by the store's box (the box of a
/// turned box is larger), so its box is found in the upright frame: its samples' extremes along
/// each of the frame's axes, both ways.
pub fn upright_bounds<B: AsRef<[u8]>>(store: &Store<B>, up: DVec3, front: DVec3) -> (DVec3, f64) {
    let b = store.bbox();
    let stored = (store.to_model(b.center()), f64::from(b.diagonal()) * 0.5);
    let on_axes = [up, front].iter().all(|v| v.to_array().iter().filter(|c| **c != 0.0).count() == 1);
    if on_axes {
        return stored;
    }
    // Relative to the store's box centre, so that a store far from its origin keeps its precision.
    let mid = b.center().as_dvec3();
    let frame = [up.cross(front), up, front];
    let hi = frame.map(|axis| farthest(store, axis, mid));
    let lo = frame.map(|axis| -farthest(store, -axis, mid));
    let (lo, hi) = (DVec3::from_array(lo), DVec3::from_array(hi));
    if !(lo.is_finite() && hi.is_finite()) {
        return stored;
    }
    let c = (lo + hi) * 0.5;
    (stored.0 + frame[0] * c.x + frame[1] * c.y + frame[2] * c.z, (hi - lo).length() * 0.5)
}

/// The largest `dir · (p − mid)` over the store's samples p (local coordinates), exactly, by
/// branch and bound: the node whose box reaches farthest along `dir` is opened first, and the
/// search stops when no box left reaches beyond the farthest sample found. Along an axis of
/// the file that is a few nodes from the root to a leaf; along a direction oblique to a flat
/// side of the model (the base of a tilted statue) every node whose box touches that side may
/// be opened, so a caller that asks often keeps the result. A sample is counted no farther than
/// its node's box reaches: the store's index is sound (it was checked when opened), its splats
/// are not read before, and a corrupted one must not make the model a speck.
fn farthest<B: AsRef<[u8]>>(store: &Store<B>, dir: DVec3, mid: DVec3) -> f64 {
    /// A node to open, ordered by how far its box reaches.
    struct Open(f64, NodeId);
    impl PartialEq for Open {
        fn eq(&self, other: &Self) -> bool {
            self.cmp(other).is_eq()
        }
    }
    impl Eq for Open {}
    impl PartialOrd for Open {
        fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(other))
        }
    }
    impl Ord for Open {
        fn cmp(&self, other: &Self) -> std::cmp::Ordering {
            self.0.total_cmp(&other.0).then(self.1.cmp(&other.1))
        }
    }
    let reach = |id: NodeId| {
        let b = store.node(id).bbox();
        let r: f64 = (0..3)
            .map(|a| (dir[a] * (f64::from(b.min[a]) - mid[a])).max(dir[a] * (f64::from(b.max[a]) - mid[a])))
            .sum();
        Open(r, id)
    };
    let mut best = f64::NEG_INFINITY;
    let mut open = std::collections::BinaryHeap::from([reach(store.root())]);
    while let Some(Open(bound, id)) = open.pop() {
        if bound <= best {
            break;
        }
        for s in store.splats(id) {
            best = best.max(dir.dot(s.position().as_dvec3() - mid).min(bound));
        }
        open.extend(store.node(id).children.iter().filter(|&&c| c != NONE).map(|&c| reach(c)));
    }
    best
}

/// How far the gallery's turntable swings to each side of the front (radians: 40°).
pub const TURNTABLE_SWING: f64 = 0.7;
/// Seconds of one swing of the gallery's turntable, there and back.
pub const TURNTABLE_PERIOD: f64 = 30.0;

/// The gallery's turntable at time `t` (seconds): the start view swung about the model's `up`
/// axis through its target, [`TURNTABLE_SWING`] to each side of the front, smoothly (a sine;
/// at most 0.15 rad/s). A passer-by sees that the model is in 3D, and mostly its front (the
/// exhibit's `front`): a full turn would show the back of a relief or a cabinet half the time.
pub fn turntable(start: Camera, up: DVec3, t: f64) -> Camera {
    let phase = if t.is_finite() { std::f64::consts::TAU * t / TURNTABLE_PERIOD } else { 0.0 };
    let turn =
        glam::DQuat::from_axis_angle(up.try_normalize().unwrap_or(DVec3::Y), TURNTABLE_SWING * phase.sin());
    Camera { eye: start.target + turn * (start.eye - start.target), up: turn * start.up, ..start }
}

/// [`start_camera`] from the default front.
pub fn initial_camera<B: AsRef<[u8]>>(store: &Store<B>, fov_y: f64, up: DVec3) -> Camera {
    start_camera(store, fov_y, up, None)
}

/// Builds the controller of a replay (or of the kiosk); `aspect` is the projection's width /
/// height.
pub fn make_controller<B: AsRef<[u8]>>(
    scene: SceneRef<'_, B>,
    cam: Camera,
    kind: ControllerKind,
    min_distance: f64,
    up: DVec3,
    aspect: f64,
) -> Controller {
    match kind {
        ControllerKind::IsoCam => {
            let mut s = IsoCamSettings::for_model(scene.diagonal());
            s.min_distance = min_distance;
            s.up = up;
            Controller::IsoCam(IsoCam::new(scene, cam, s))
        }
        ControllerKind::Trackball => Controller::Trackball(Trackball::new(cam, min_distance)),
        ControllerKind::Acevit => Controller::Acevit(Acevit::new(
            cam,
            AcevitSettings {
                samples: 256,
                sigma_xy: 0.5,
                sigma_depth: 0.5,
                min_radius: min_distance,
                aspect,
            },
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_start_view_looks_down_on_a_flat_model_only() {
        let deg = |size: DVec3, up: DVec3| start_elevation(size, up, default_front(up)).to_degrees();
        // A bust, a plaque standing upright, a cube: level.
        assert_eq!(deg(DVec3::new(0.5, 0.8, 0.4), DVec3::Y), 0.0);
        assert_eq!(deg(DVec3::new(1.0, 1.0, 0.02), DVec3::Y), 0.0);
        assert_eq!(deg(DVec3::ONE, DVec3::Z), 0.0);
        // A terrain on Z (a survey), a tablet lying on its back on Y: 45°; halfway flat, between.
        assert!((deg(DVec3::new(300.0, 200.0, 12.0), DVec3::Z) - 45.0).abs() < 1e-9);
        assert!((deg(DVec3::new(0.3, 0.01, 0.2), DVec3::Y) - 45.0).abs() < 1e-9);
        let between = deg(DVec3::new(1.0, 0.2, 1.0), DVec3::Y);
        assert!(between > 10.0 && between < 35.0, "{between}");
        // Degenerate boxes stay level.
        assert_eq!(deg(DVec3::ZERO, DVec3::Y), 0.0);
        assert_eq!(deg(DVec3::new(0.0, 1.0, 0.0), DVec3::Y), 0.0);
    }

    #[test]
    fn the_default_front_is_level_for_every_up() {
        // The axes keep their fronts exactly: +Z, or −Y for a model standing on ±Z.
        let axes = [
            (DVec3::Y, DVec3::Z),
            (DVec3::NEG_Y, DVec3::Z),
            (DVec3::X, DVec3::Z),
            (DVec3::NEG_X, DVec3::Z),
            (DVec3::Z, DVec3::NEG_Y),
            (DVec3::NEG_Z, DVec3::NEG_Y),
        ];
        for (up, front) in axes {
            assert_eq!(default_front(up), front, "up {up}");
        }
        // An up tilted from any of the six axes: the front is perpendicular to it (a level start
        // view), within the tilt of that axis's front, and a 1° turn of the up turns it by at
        // most about 1° (no jump, also from X toward Z).
        let diagonal = DVec3::new(1.0, 1.0, 1.0) * (1.0 / 3f64.sqrt());
        for (axis_up, axis_front) in axes {
            for tilt in [0.1f64, 1.0, 10.0, 30.0] {
                for about in [DVec3::X, DVec3::Y, DVec3::Z, diagonal] {
                    let turn = glam::DQuat::from_axis_angle(about, tilt.to_radians());
                    let up = turn * axis_up;
                    if up.angle_between(axis_up) < 1e-9 {
                        continue;
                    }
                    let f = default_front(up);
                    assert!(f.dot(up).abs() < 1e-12 && (f.length() - 1.0).abs() < 1e-12, "up {up}: {f}");
                    assert!(f.angle_between(axis_front) <= tilt.to_radians() + 1e-9, "up {up}: {f}");
                    let next = default_front(glam::DQuat::from_axis_angle(about, 1f64.to_radians()) * up);
                    assert!(f.angle_between(next) < 1.01f64.to_radians(), "up {up}: {f} → {next}");
                }
            }
        }
    }

    #[test]
    fn the_gallery_turntable_shows_the_front_side_and_never_the_back() {
        for up in [DVec3::Y, DVec3::Z, DVec3::new(0.1, 1.0, 0.2).normalize_or_zero()] {
            let front = default_front(up);
            let start = Camera::framing(DVec3::new(1.0, 2.0, 3.0), 0.5, front, up, 0.8);
            assert_eq!(turntable(start, up, 0.0), start, "it starts at the front");
            let (mut left, mut right) = (0.0f64, 0.0f64);
            for k in 0..=1200 {
                let cam = turntable(start, up, f64::from(k) * 0.1);
                let from = (cam.eye - cam.target).normalize_or_zero();
                assert!(
                    from.dot(up).abs() < 1e-9 + (start.eye - start.target).normalize_or_zero().dot(up).abs()
                );
                let angle = from.dot(front).clamp(-1.0, 1.0).acos();
                assert!(angle <= TURNTABLE_SWING + 1e-9, "{angle} rad from the front at {k}");
                let side = front.cross(from).dot(up);
                (left, right) = (left.max(side), right.min(side));
                assert!((cam.up.dot(up) - start.up.dot(up)).abs() < 1e-9, "it stays upright");
            }
            assert!(left > 0.6 && right < -0.6, "it swings to both sides: {left} {right}");
        }
        let still = turntable(Camera::framing(DVec3::ZERO, 1.0, DVec3::Z, DVec3::Y, 0.8), DVec3::Y, f64::NAN);
        assert!(still.eye.is_finite());
    }
}
