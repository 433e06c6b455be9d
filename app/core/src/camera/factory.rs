//! Which controller explores a model, and where it starts: the kiosk and replays build theirs
//! here.

use super::{Acevit, AcevitSettings, Camera, Controller, IsoCam, IsoCamSettings, SceneRef, Trackball};
use crate::scene::Store;
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
/// perpendicular to `up`; `None`: [`default_front`]), upright.
pub fn start_camera<B: AsRef<[u8]>>(store: &Store<B>, fov_y: f64, up: DVec3, front: Option<DVec3>) -> Camera {
    let center = store.to_model(store.bbox().center());
    let radius = f64::from(store.bbox().diagonal()) * 0.5;
    let from =
        front.map(|f| f - up * f.dot(up)).and_then(DVec3::try_normalize).unwrap_or_else(|| default_front(up));
    Camera::framing(center, radius.max(f64::MIN_POSITIVE), from, up, fov_y)
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
}
