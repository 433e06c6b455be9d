//! Camera controllers (thesis 9.3, 8.3.1), driven by intents (hover, zoom, twist) rather than by
//! devices, and a go-to animation. All state is `f64` model coordinates: a model at 10⁷ m
//! behaves exactly like one at the origin, because every query goes through the store's local
//! frame and every comparison is relative to the model's size.
//!
//! - [`IsoCam`]: the camera hovers on an isosurface of the distance to the model.
//! - [`Trackball`]: the classic baseline, rotation on the bounding sphere.
//! - [`Acevit`]: the auto-centering trackball of thesis 8.3.1.

mod acevit;
mod factory;
mod isocam;
mod trackball;

pub use acevit::{Acevit, AcevitSettings};
pub use factory::{
    ControllerKind, TURNTABLE_PERIOD, TURNTABLE_SWING, default_front, initial_camera, make_controller,
    start_camera, turntable, upright_bounds,
};
pub use isocam::{IsoCam, IsoCamSettings, StepStats, exceeds_tilt_limit};
pub use trackball::Trackball;

use crate::scene::{Cut, Store, ViewParams};
use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

/// A perspective camera in model coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Eye position.
    pub eye: DVec3,
    /// Point looked at.
    pub target: DVec3,
    /// Up vector (unit, orthogonal to the view direction).
    pub up: DVec3,
    /// Vertical field of view in radians.
    pub fov_y: f64,
}

impl Camera {
    /// Unit view direction.
    pub fn forward(&self) -> DVec3 {
        (self.target - self.eye).try_normalize().unwrap_or(DVec3::NEG_Z)
    }

    /// Unit right vector.
    pub fn right(&self) -> DVec3 {
        self.forward().cross(self.up).try_normalize().unwrap_or_else(|| any_perpendicular(self.forward()))
    }

    /// Whether every field is finite.
    pub fn is_finite(&self) -> bool {
        self.eye.is_finite() && self.target.is_finite() && self.up.is_finite() && self.fov_y.is_finite()
    }

    /// The view for the cut and the renderer (near/far from the model size).
    pub fn view_params<B: AsRef<[u8]>>(&self, store: &Store<B>, size_px: (u32, u32)) -> Option<ViewParams> {
        let diag = store.bbox().diagonal().max(f32::MIN_POSITIVE);
        let dist = (self.eye - store.to_model(store.bbox().center())).length() as f32;
        let near = (diag * 1e-6).max(1e-9);
        let far = (dist + diag) * 2.0;
        ViewParams::look_at(
            store.origin(),
            self.eye,
            self.target,
            self.up,
            self.fov_y as f32,
            size_px,
            (near, far),
        )
    }

    /// Normalised device coordinates (x, y in [-1, 1] on screen) of `p`, or `None` behind the eye.
    pub fn ndc(&self, p: DVec3, aspect: f64) -> Option<(f64, f64, f64)> {
        let f = self.forward();
        let r = self.right();
        let u = r.cross(f);
        let d = p - self.eye;
        let z = d.dot(f);
        if z <= 0.0 {
            return None;
        }
        let t = (self.fov_y * 0.5).tan();
        Some((d.dot(r) / (z * t * aspect), d.dot(u) / (z * t), z))
    }

    /// A camera that frames a sphere (centre, radius) from direction `from` (unit), up `up`.
    pub fn framing(center: DVec3, radius: f64, from: DVec3, up: DVec3, fov_y: f64) -> Self {
        let dist = radius / (fov_y * 0.5).sin() * 1.05;
        let eye = center + from * dist;
        let mut c = Self { eye, target: center, up, fov_y };
        c.up = orthonormal_up(c.forward(), up, c.up);
        c
    }
}

/// A unit vector perpendicular to `v` (deterministic).
pub fn any_perpendicular(v: DVec3) -> DVec3 {
    let a = if v.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    v.cross(a).try_normalize().unwrap_or(DVec3::Y)
}

/// `up` made orthogonal to `forward` (falls back to `fallback`, then to any perpendicular).
pub fn orthonormal_up(forward: DVec3, up: DVec3, fallback: DVec3) -> DVec3 {
    let ortho = |u: DVec3| (u - forward * u.dot(forward)).try_normalize();
    ortho(up).or_else(|| ortho(fallback)).unwrap_or_else(|| any_perpendicular(forward))
}

/// Rotates `v` about unit `axis` by `angle`.
pub fn rotate(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    DQuat::from_axis_angle(axis, angle) * v
}

/// What a controller is asked to do in one frame (from gestures or a script).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Intent {
    /// Hover / rotate: screen displacement this frame, in units of the viewport height
    /// (x right, y up).
    pub hover: (f64, f64),
    /// Two-finger pan (trackballs; IsoCam treats it as hover).
    pub pan: (f64, f64),
    /// Zoom: log of the distance ratio (positive = closer).
    pub zoom: f64,
    /// Twist: radians about the view direction.
    pub twist: f64,
    /// Whether the user's interaction has ended this frame (fingers lifted).
    pub end: bool,
}

impl Intent {
    /// Whether the intent moves the camera at all.
    pub fn is_idle(&self) -> bool {
        self.hover == (0.0, 0.0) && self.pan == (0.0, 0.0) && self.zoom == 0.0 && self.twist == 0.0
    }
}

/// The scene a controller queries: the store and the current cut.
pub struct SceneRef<'a, B> {
    /// The hierarchy.
    pub store: &'a Store<B>,
    /// The current (complete) cut.
    pub cut: &'a Cut,
}

impl<B> Clone for SceneRef<'_, B> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<B> Copy for SceneRef<'_, B> {}

impl<B: AsRef<[u8]>> SceneRef<'_, B> {
    /// Diagonal of the model's bounding box.
    pub fn diagonal(&self) -> f64 {
        f64::from(self.store.bbox().diagonal())
    }

    /// Centre of the model's bounding box (model coordinates).
    pub fn center(&self) -> DVec3 {
        self.store.to_model(self.store.bbox().center())
    }
}

/// The go-to animation: ease in/out from one camera to another, pushed out of the model's
/// minimum-distance shell at every frame so that it never passes through the model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GoTo {
    /// Where it starts.
    pub from: Camera,
    /// Where it ends.
    pub to: Camera,
    /// Start time (seconds, injected clock).
    pub start: f64,
    /// Duration in seconds.
    pub duration: f64,
}

impl GoTo {
    /// Smoothstep ease in/out of the progress at `now`, in [0, 1].
    pub fn progress(&self, now: f64) -> f64 {
        let x = if self.duration > 0.0 { ((now - self.start) / self.duration).clamp(0.0, 1.0) } else { 1.0 };
        x * x * (3.0 - 2.0 * x)
    }

    /// Whether the animation is over at `now`.
    pub fn done(&self, now: f64) -> bool {
        now >= self.start + self.duration
    }

    /// The camera at `now`, kept at least `min_distance` from the surface of the cut.
    pub fn camera_at<B: AsRef<[u8]>>(&self, now: f64, scene: SceneRef<'_, B>, min_distance: f64) -> Camera {
        let s = self.progress(now);
        let eye = self.from.eye.lerp(self.to.eye, s);
        let target = self.from.target.lerp(self.to.target, s);
        let up = slerp_dir(self.from.up, self.to.up, s);
        let mut eye = eye;
        // Push out of the shell (a few rounds: the nearest point changes as we move).
        for _ in 0..4 {
            let Some(f) = scene.store.fine_target(scene.cut, eye, &Default::default()) else { break };
            let d = (eye - f.point).length();
            if d >= min_distance {
                break;
            }
            let away = (eye - f.point).try_normalize().unwrap_or(-self.from.forward());
            eye = f.point + away * min_distance;
        }
        let fov_y = self.from.fov_y + (self.to.fov_y - self.from.fov_y) * s;
        let mut c = Camera { eye, target, up, fov_y };
        c.up = orthonormal_up(c.forward(), up, self.to.up);
        c
    }
}

/// Spherical interpolation of unit directions (falls back to normalised lerp).
pub fn slerp_dir(a: DVec3, b: DVec3, t: f64) -> DVec3 {
    let dot = a.dot(b).clamp(-1.0, 1.0);
    let theta = dot.acos();
    if theta < 1e-9 {
        return a;
    }
    let s = theta.sin();
    if s.abs() < 1e-9 {
        // Opposite: rotate about any perpendicular.
        return rotate(a, any_perpendicular(a), std::f64::consts::PI * t);
    }
    (a * ((1.0 - t) * theta).sin() / s + b * (t * theta).sin() / s).try_normalize().unwrap_or(a)
}

/// Which controller drives the camera.
#[derive(Clone, Debug)]
pub enum Controller {
    /// IsoCam (thesis 9.3).
    IsoCam(IsoCam),
    /// Virtual trackball on the bounding sphere.
    Trackball(Trackball),
    /// Auto-centering trackball (thesis 8.3.1).
    Acevit(Acevit),
}

impl Controller {
    /// The controller's name as used on the command line and in traces.
    pub fn name(&self) -> &'static str {
        match self {
            Self::IsoCam(_) => "isocam",
            Self::Trackball(_) => "trackball",
            Self::Acevit(_) => "acevit",
        }
    }

    /// The current camera.
    pub fn camera(&self) -> Camera {
        match self {
            Self::IsoCam(c) => c.camera(),
            Self::Trackball(c) => c.camera(),
            Self::Acevit(c) => c.camera(),
        }
    }

    /// One frame of `dt` seconds with no finger down: IsoCam eases a small twist back upright
    /// ([`IsoCam::level`]); the trackballs' roll is the visitor's to turn and stays.
    pub fn level(&mut self, dt: f64) {
        if let Self::IsoCam(c) = self {
            c.level(dt);
        }
    }

    /// The roll a small twist eases back to becomes upright (IsoCam; see [`IsoCam::level`]).
    pub fn rest_upright(&mut self) {
        if let Self::IsoCam(c) = self {
            c.rest_upright();
        }
    }

    /// Applies one frame's intent.
    pub fn apply<B: AsRef<[u8]>>(
        &mut self,
        scene: SceneRef<'_, B>,
        intent: &Intent,
        rng: &mut impl rand::Rng,
    ) {
        match self {
            Self::IsoCam(c) => c.apply(scene, intent),
            Self::Trackball(c) => c.apply(scene, intent),
            Self::Acevit(c) => c.apply(scene, intent, rng),
        }
    }

    /// Changes the vertical field of view, keeping the view.
    pub fn set_fov(&mut self, fov_y: f64) {
        if !(fov_y.is_finite() && fov_y > 0.0) {
            return;
        }
        match self {
            Self::IsoCam(c) => c.set_fov(fov_y),
            Self::Trackball(c) => c.set_camera(Camera { fov_y, ..c.camera() }),
            Self::Acevit(c) => c.set_fov(fov_y),
        }
    }

    /// Brings the eye to `distance` from `center` along the line from `center` to the eye,
    /// keeping the view direction (the bound on zooming out). `distance` must keep the eye
    /// outside the model's bounding sphere, so that no controller can enter the surface.
    pub fn pull_toward<B: AsRef<[u8]>>(&mut self, scene: SceneRef<'_, B>, center: DVec3, distance: f64) {
        let cam = self.camera();
        let Some(dir) = (cam.eye - center).try_normalize() else { return };
        if !(distance.is_finite() && distance > 0.0) {
            return;
        }
        let eye = center + dir * distance;
        let shift = eye - cam.eye;
        match self {
            Self::IsoCam(c) => c.place_eye(scene, eye),
            Self::Trackball(c) => c.set_camera(Camera { eye, target: cam.target + shift, ..cam }),
            Self::Acevit(c) => c.move_camera(Camera { eye, target: cam.target + shift, ..cam }),
        }
    }

    /// Replaces the camera (end of a go-to animation).
    pub fn set_camera<B: AsRef<[u8]>>(&mut self, scene: SceneRef<'_, B>, cam: Camera) {
        match self {
            Self::IsoCam(c) => c.reset(scene, cam),
            Self::Trackball(c) => c.set_camera(cam),
            Self::Acevit(c) => c.set_camera(cam),
        }
    }
}
