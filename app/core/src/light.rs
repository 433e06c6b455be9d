//! The light (Bettio et al. 2009: users get light control; raking light is how people see
//! carved detail): a headlight (from the eye, always there) plus a movable user light, a
//! direction in model axes. The renderer mixes the two: `mix` is the user light's weight.
//!
//! - **Start of a visit** (and after the reset: each visit starts a new exploration): the user
//!   light comes from above, right and in front of the start view ([`start_dir`]: `0.4` right,
//!   `0.8` up, `0.5` toward the viewer), at [`DEFAULT_MIX`], the headlight dominating.
//! - **The visitor steers it** ([`LightPad`]): a one-finger drag moves the light on a pad
//!   relative to the view. The pad's centre is a light from the eye; its rim is a light at 90°
//!   to the view direction, grazing every surface that faces the viewer (raking light) from the
//!   side the finger went; the pad stops at the rim, so pushing a finger far to one side gives a
//!   clean raking light. [`DRAG_GAIN`] pad radii per controller height. While and after the
//!   visitor uses it, the user light dominates ([`ACTIVE_MIX`]).
//! - **A go-to** to a node with a stored light (`<view … light="x y z"/>`) turns the light to
//!   it over the go-to's duration with the same ease, and the user light dominates; a go-to to a
//!   node without one keeps the current light.
//! - **The attract loop** (nobody touching): the light eases back to the start light over
//!   [`RESTORE_SECS`] (the tour's go-tos still turn it to their nodes' lights).
//!
//! Pure: the direction is state of the exploration ([`crate::explore::Explorer`]), traced with
//! every frame, so a replayed session relights identically.

use crate::camera::{Camera, slerp_dir};
use glam::{DVec2, DVec3};

/// Weight of the user light at the start: the headlight dominates.
pub const DEFAULT_MIX: f64 = 0.35;
/// Weight of the user light once the visitor (or a node's stored light) has set it.
pub const ACTIVE_MIX: f64 = 0.85;
/// Time constant (seconds) of the mix's ease toward its target.
pub const MIX_EASE_SECS: f64 = 0.25;
/// Seconds the attract loop takes to bring the start light back.
pub const RESTORE_SECS: f64 = 2.0;
/// Pad radii per controller height of a drag (0.4 heights from the eye's light to grazing).
pub const DRAG_GAIN: f64 = 2.5;

/// The light of a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Unit direction toward the user light (model axes).
    pub dir: DVec3,
    /// Weight of the user light against the headlight, in [0, 1].
    pub mix: f64,
}

/// A direction as a light: unit, or `None` when not finite or zero (any other length is
/// normalised, however large or small). A direction already unit (within 1e-9) is kept exactly
/// as given, so a stored light reads back unchanged.
pub fn unit(v: DVec3) -> Option<DVec3> {
    if !v.is_finite() {
        return None;
    }
    if (v.length() - 1.0).abs() <= 1e-9 {
        return Some(v);
    }
    // Scaled by its largest component first, so that neither huge nor tiny lengths overflow.
    let m = v.abs().max_element();
    if m == 0.0 {
        return None;
    }
    let w = v / m;
    Some(w / w.length())
}

/// The view's axes: right, up, toward the viewer (unit, orthogonal).
fn axes(cam: &Camera) -> (DVec3, DVec3, DVec3) {
    let back = -cam.forward();
    let right = cam.right();
    let up = back.cross(right).try_normalize().unwrap_or(cam.up);
    (right, up, back)
}

/// The light a visit starts with, for its start view: above, right and in front.
pub fn start_dir(cam: &Camera) -> DVec3 {
    let (right, up, back) = axes(cam);
    unit(0.4 * right + 0.8 * up + 0.5 * back).unwrap_or(DVec3::Y)
}

/// Where a light direction is on the pad of view `cam`: the centre is a light from the eye,
/// radius 1 a light at 90° to the view direction (grazing); beyond 90° (behind the surface the
/// viewer sees) it is put on the rim.
pub fn to_pad(cam: &Camera, dir: DVec3) -> DVec2 {
    let (right, up, back) = axes(cam);
    let Some(d) = unit(dir) else { return DVec2::ZERO };
    let side = DVec2::new(d.dot(right), d.dot(up));
    let theta = d.dot(back).clamp(-1.0, 1.0).acos().min(std::f64::consts::FRAC_PI_2);
    match side.try_normalize() {
        Some(s) => s * theta / std::f64::consts::FRAC_PI_2,
        None => DVec2::ZERO,
    }
}

/// The light direction at pad point `p` of view `cam` (outside the rim: on it).
pub fn from_pad(cam: &Camera, p: DVec2) -> DVec3 {
    let (right, up, back) = axes(cam);
    let r = p.length();
    let p = if r > 1.0 { p / r } else { p };
    let theta = p.length() * std::f64::consts::FRAC_PI_2;
    let side = p.try_normalize().unwrap_or(DVec2::ZERO);
    let d = theta.sin() * (side.x * right + side.y * up) + theta.cos() * back;
    unit(d).unwrap_or(back)
}

/// A drag steering the light: the pad point it started from and where it is now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPad {
    /// Current pad point (|p| ≤ 1).
    pub p: DVec2,
}

impl LightPad {
    /// A drag starting from the current light as seen from `cam`.
    pub fn start(cam: &Camera, dir: DVec3) -> Self {
        Self { p: to_pad(cam, dir) }
    }

    /// The finger moved by `(dx, dy)` (controller widths and heights, y down) on a controller of
    /// `aspect` (width / height); returns the new direction for `cam`.
    pub fn drag(&mut self, cam: &Camera, dx: f64, dy: f64, aspect: f64) -> DVec3 {
        if dx.is_finite() && dy.is_finite() {
            let aspect = if aspect.is_finite() && aspect > 0.0 { aspect } else { 1.0 };
            let p = self.p + DRAG_GAIN * DVec2::new(dx * aspect, -dy);
            let r = p.length();
            self.p = if r > 1.0 { p / r } else { p };
        }
        from_pad(cam, self.p)
    }
}

/// An animation of the light's direction: smoothstep from `from` to `to`, like a go-to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightEase {
    /// Start direction.
    pub from: DVec3,
    /// End direction.
    pub to: DVec3,
    /// Start time.
    pub start: f64,
    /// Duration (seconds).
    pub duration: f64,
}

impl LightEase {
    /// The direction at `t` and whether the animation is over.
    pub fn at(&self, t: f64) -> (DVec3, bool) {
        let x = if self.duration > 0.0 { ((t - self.start) / self.duration).clamp(0.0, 1.0) } else { 1.0 };
        let s = x * x * (3.0 - 2.0 * x);
        if x >= 1.0 || self.from == self.to {
            (self.to, x >= 1.0)
        } else {
            (slerp_dir(self.from, self.to, s), false)
        }
    }
}

/// The mix one frame of `dt` seconds later, easing toward `target` (exactly there once within
/// 1e-6).
pub fn ease_mix(mix: f64, target: f64, dt: f64) -> f64 {
    let k = 1.0 - (-dt / MIX_EASE_SECS).exp();
    let next = mix + (target - mix) * k;
    if (next - target).abs() <= 1e-6 { target } else { next }
}

/// The light of one exploration as it changes: where it is now, the mix it eases toward, an
/// animation of its direction (a go-to's, or the attract loop's way back), a finger steering it,
/// and the light the exploration started with.
#[derive(Clone, Copy, Debug)]
pub struct Lighting {
    light: Light,
    target_mix: f64,
    ease: Option<LightEase>,
    pad: Option<LightPad>,
    start: DVec3,
}

impl Lighting {
    /// The light of an exploration starting with direction `start`, the headlight dominating.
    pub fn new(start: DVec3) -> Self {
        Self {
            light: Light { dir: start, mix: DEFAULT_MIX },
            target_mix: DEFAULT_MIX,
            ease: None,
            pad: None,
            start,
        }
    }

    /// The light now.
    pub fn light(&self) -> Light {
        self.light
    }

    /// Whether a finger steers the light.
    pub fn dragging(&self) -> bool {
        self.pad.is_some()
    }

    /// A finger starts steering the light from where it is as seen from `cam`: any animation
    /// stops and the user light comes to dominate.
    pub fn drag_start(&mut self, cam: &Camera) {
        self.pad = Some(LightPad::start(cam, self.light.dir));
        self.ease = None;
        self.target_mix = ACTIVE_MIX;
    }

    /// The steering finger moved by `(dx, dy)` (controller widths and heights, y down) on a
    /// controller of `aspect`; starts a drag if none runs.
    pub fn drag(&mut self, cam: &Camera, dx: f64, dy: f64, aspect: f64) {
        if dx == 0.0 && dy == 0.0 && self.pad.is_some() {
            return;
        }
        if self.pad.is_none() {
            self.drag_start(cam);
        }
        if let Some(pad) = self.pad.as_mut() {
            self.light.dir = pad.drag(cam, dx, dy, aspect);
        }
    }

    /// The steering finger lifted: the light stays where it is.
    pub fn drag_end(&mut self) {
        self.pad = None;
    }

    /// Eases back to the start light from `t`, the headlight dominating again.
    pub fn restore(&mut self, t: f64) {
        self.pad = None;
        self.target_mix = DEFAULT_MIX;
        self.ease =
            Some(LightEase { from: self.light.dir, to: self.start, start: t, duration: RESTORE_SECS });
    }

    /// A go-to to a view with the light `to` turns to it over `duration` from `t`, the user light
    /// dominating, unless a finger holds the light.
    pub fn turn_to(&mut self, to: DVec3, t: f64, duration: f64) {
        if self.pad.is_none() {
            self.ease = Some(LightEase { from: self.light.dir, to, start: t, duration });
            self.target_mix = ACTIVE_MIX;
        }
    }

    /// Advances the animations to `t`, one frame of `dt` after the last.
    pub fn step(&mut self, t: f64, dt: f64) {
        if let Some(e) = self.ease {
            let (dir, done) = e.at(t);
            self.light.dir = dir;
            if done {
                self.ease = None;
            }
        }
        self.light.mix = ease_mix(self.light.mix, self.target_mix, dt);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera { eye: DVec3::new(0.0, 0.0, 3.0), target: DVec3::ZERO, up: DVec3::Y, fov_y: 0.8 }
    }

    #[test]
    fn the_start_light_is_the_renderers_old_default_for_a_front_view() {
        let d = start_dir(&cam());
        let want = DVec3::new(0.4, 0.8, 0.5).normalize_or_zero();
        assert!((d - want).length() < 1e-12, "{d}");
    }

    #[test]
    fn the_pad_maps_centre_to_the_eye_and_rim_to_grazing() {
        let c = cam();
        assert!((from_pad(&c, DVec2::ZERO) - DVec3::Z).length() < 1e-12);
        let right = from_pad(&c, DVec2::new(1.0, 0.0));
        assert!((right - DVec3::X).length() < 1e-12, "{right}");
        let up = from_pad(&c, DVec2::new(0.0, 3.0));
        assert!((up - DVec3::Y).length() < 1e-12, "beyond the rim: on it ({up})");
        for p in [DVec2::new(0.3, -0.2), DVec2::new(-0.7, 0.6), DVec2::new(0.0, -1.0)] {
            let back = to_pad(&c, from_pad(&c, p));
            assert!((back - p).length() < 1e-9, "{p} → {back}");
        }
        // Behind the surface the viewer sees: on the rim, on its side.
        let p = to_pad(&c, DVec3::new(1.0, 0.0, -1.0));
        assert!((p - DVec2::new(1.0, 0.0)).length() < 1e-9, "{p}");
    }

    #[test]
    fn a_drag_sweeps_the_light_to_a_grazing_angle_and_stops_there() {
        let c = cam();
        let mut pad = LightPad::start(&c, DVec3::Z);
        // 0.4 controller heights to the right: grazing from the right.
        let d = pad.drag(&c, 0.4 / (16.0 / 9.0), 0.0, 16.0 / 9.0);
        assert!(d.dot(DVec3::Z).abs() < 1e-9 && d.x > 0.999, "{d}");
        // Further: stays grazing; back the other way responds at once.
        let d = pad.drag(&c, 0.5, 0.0, 16.0 / 9.0);
        assert!(d.x > 0.999, "{d}");
        let d = pad.drag(&c, -0.1, 0.0, 16.0 / 9.0);
        assert!(d.x < 0.999 && d.z > 0.0, "{d}");
        // Up the screen (y down): the light goes up.
        let d = pad.drag(&c, 0.0, -0.1, 16.0 / 9.0);
        assert!(d.y > 0.0, "{d}");
        // Garbage moves nothing.
        let before = pad;
        pad.drag(&c, f64::NAN, 0.1, 1.0);
        assert_eq!(pad, before);
    }

    #[test]
    fn unit_refuses_zero_and_non_finite_and_keeps_unit_vectors_exactly() {
        assert_eq!(unit(DVec3::ZERO), None);
        assert_eq!(unit(DVec3::new(f64::NAN, 0.0, 1.0)), None);
        assert_eq!(unit(DVec3::new(f64::INFINITY, 0.0, 1.0)), None);
        assert_eq!(unit(DVec3::new(0.0, 2.0, 0.0)), Some(DVec3::Y));
        assert_eq!(unit(DVec3::new(0.0, 0.0, -1e300)), Some(DVec3::NEG_Z), "no overflow");
        assert_eq!(unit(DVec3::new(1e-300, 0.0, 0.0)), Some(DVec3::X), "no underflow");
        let d = unit(DVec3::splat(1e300)).expect("a direction");
        assert!((d.length() - 1.0).abs() < 1e-15 && d.x == d.z, "{d}");
        let v = DVec3::new(0.6, 0.8, 0.0);
        assert_eq!(unit(v), Some(v));
    }

    #[test]
    fn the_ease_ends_exactly() {
        let e = LightEase { from: DVec3::X, to: DVec3::Y, start: 1.0, duration: 2.0 };
        assert_eq!(e.at(0.0), (DVec3::X, false));
        let (mid, done) = e.at(2.0);
        assert!(!done && (mid - DVec3::new(1.0, 1.0, 0.0).normalize_or_zero()).length() < 1e-9);
        assert_eq!(e.at(3.0), (DVec3::Y, true));
        let mut m = DEFAULT_MIX;
        // Within 1e-6 after ln(0.5 / 1e-6) ≈ 13 time constants: 3.3 s.
        for _ in 0..210 {
            m = ease_mix(m, ACTIVE_MIX, 1.0 / 60.0);
        }
        assert_eq!(m, ACTIVE_MIX);
    }
}
