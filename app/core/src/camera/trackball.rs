//! The virtual trackball baseline: one finger rotates the camera about the centre of the model's
//! bounding sphere, pinch changes the distance to it, two fingers pan. No collision handling: the
//! comparison benchmarks count its collisions.

use super::{Camera, Intent, SceneRef, orthonormal_up, rotate};
use glam::DVec3;

/// The trackball.
#[derive(Clone, Debug)]
pub struct Trackball {
    cam: Camera,
    /// Closest allowed distance to the pivot (model units).
    pub min_radius: f64,
}

impl Trackball {
    /// Starts from a camera.
    pub fn new(cam: Camera, min_radius: f64) -> Self {
        Self { cam, min_radius }
    }

    /// The camera.
    pub fn camera(&self) -> Camera {
        self.cam
    }

    /// Replaces the camera.
    pub fn set_camera(&mut self, cam: Camera) {
        self.cam = cam;
    }

    /// Applies one frame's intent.
    pub fn apply<B: AsRef<[u8]>>(&mut self, scene: SceneRef<'_, B>, intent: &Intent) {
        orbit(&mut self.cam, scene.center(), intent, self.min_radius);
    }
}

/// Rotation about `pivot` (two-axis valuator: x about the up vector, y about the right vector),
/// pinch zoom toward the pivot, two-finger pan and twist; shared by both trackballs.
pub(super) fn orbit(cam: &mut Camera, pivot: DVec3, intent: &Intent, min_radius: f64) {
    let finite = |v: (f64, f64)| if v.0.is_finite() && v.1.is_finite() { v } else { (0.0, 0.0) };
    let (hx, hy) = finite(intent.hover);
    let (px, py) = finite(intent.pan);
    let up = cam.up;
    let right = cam.right();
    // Rotation: a full viewport height turns by π.
    let (ax, ay) = (-hx * std::f64::consts::PI, hy * std::f64::consts::PI);
    let rot = |v: DVec3| rotate(rotate(v, up, ax), right, ay);
    let eye = pivot + rot(cam.eye - pivot);
    let target = pivot + rot(cam.target - pivot);
    let new_up = rot(up);
    cam.eye = eye;
    cam.target = target;
    cam.up = orthonormal_up(cam.forward(), new_up, up);
    // Zoom toward the pivot.
    if intent.zoom.is_finite() && intent.zoom != 0.0 {
        let off = cam.eye - pivot;
        let d = off.length();
        let nd = (d * (-intent.zoom).exp()).max(min_radius);
        if let Some(dir) = off.try_normalize() {
            cam.eye += dir * (nd - d);
        }
    }
    // Pan: a full viewport height moves by the view's height at the pivot distance.
    let d = (cam.eye - pivot).length();
    let w = 2.0 * (cam.fov_y * 0.5).tan() * d;
    let shift = cam.right() * (-px * w) + cam.up * (-py * w);
    cam.eye += shift;
    cam.target += shift;
    if intent.twist.is_finite() && intent.twist != 0.0 {
        cam.up = rotate(cam.up, cam.forward(), intent.twist);
    }
}
