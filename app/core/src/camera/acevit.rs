//! ACeViT, the auto-centering virtual trackball (thesis 8.3.1): rotation about a pivot that is
//! recomputed whenever an interaction ends, as the Gaussian-weighted average of a random sample
//! of the visible points, c = Σ γ(uᵢ)γ(vᵢ)γ(wᵢ) pᵢ / Σ γ, with (u, v, w) the NDC of pᵢ, the
//! Gaussian centred on the screen centre and, in depth, on the near plane (the thesis prints
//! the sum unnormalised; we normalise it so that c does not scale with the sample size).

use super::trackball::orbit;
use super::{Camera, Intent, SceneRef};
use glam::DVec3;

/// Settings of ACeViT (the thesis gives no values; these are ours).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AcevitSettings {
    /// Points sampled from the cut to recompute the pivot.
    pub samples: usize,
    /// Gaussian σ on screen (NDC units).
    pub sigma_xy: f64,
    /// Gaussian σ in depth (fraction of the visible depth range from the nearest sample).
    pub sigma_depth: f64,
    /// Closest allowed distance to the pivot.
    pub min_radius: f64,
    /// Aspect ratio (width / height) of the projection: which samples are on screen.
    pub aspect: f64,
}

/// The ACeViT controller.
#[derive(Clone, Debug)]
pub struct Acevit {
    cam: Camera,
    pivot: DVec3,
    /// Settings.
    pub settings: AcevitSettings,
    interacting: bool,
}

impl Acevit {
    /// Starts from a camera, pivoting about its target until the first interaction ends.
    pub fn new(cam: Camera, settings: AcevitSettings) -> Self {
        Self { cam, pivot: cam.target, settings, interacting: false }
    }

    /// The camera.
    pub fn camera(&self) -> Camera {
        self.cam
    }

    /// The current pivot.
    pub fn pivot(&self) -> DVec3 {
        self.pivot
    }

    /// Replaces the camera (and pivots about its target).
    pub fn set_camera(&mut self, cam: Camera) {
        self.cam = cam;
        self.pivot = cam.target;
    }

    /// Replaces the camera, keeping the pivot.
    pub fn move_camera(&mut self, cam: Camera) {
        self.cam = cam;
    }

    /// Changes the vertical field of view, keeping the view and the pivot.
    pub fn set_fov(&mut self, fov_y: f64) {
        self.cam.fov_y = fov_y;
    }

    /// Applies one frame's intent.
    pub fn apply<B: AsRef<[u8]>>(
        &mut self,
        scene: SceneRef<'_, B>,
        intent: &Intent,
        rng: &mut impl rand::Rng,
    ) {
        if !intent.is_idle() {
            self.interacting = true;
            orbit(&mut self.cam, self.pivot, intent, self.settings.min_radius);
        }
        if intent.end && self.interacting {
            self.interacting = false;
            if let Some(p) = self.recenter(scene, rng) {
                self.pivot = p;
            }
        }
    }

    /// The Gaussian-weighted pivot of visible samples, or `None` if nothing is visible.
    pub fn recenter<B: AsRef<[u8]>>(
        &self,
        scene: SceneRef<'_, B>,
        rng: &mut impl rand::Rng,
    ) -> Option<DVec3> {
        let pts = scene.store.sample_cut(scene.cut, self.settings.samples, rng);
        let aspect = if self.settings.aspect.is_finite() && self.settings.aspect > 0.0 {
            self.settings.aspect
        } else {
            1.0
        };
        let visible: Vec<(DVec3, f64, f64, f64)> = pts
            .into_iter()
            .filter_map(|p| {
                let pm = scene.store.to_model(p);
                let (x, y, z) = self.cam.ndc(pm, aspect)?;
                (x.abs() <= 1.0 && y.abs() <= 1.0).then_some((pm, x, y, z))
            })
            .collect();
        let z_near = visible.iter().map(|v| v.3).fold(f64::INFINITY, f64::min);
        let z_far = visible.iter().map(|v| v.3).fold(0.0, f64::max);
        let depth_range = (z_far - z_near).max(f64::MIN_POSITIVE);
        let g = |x: f64, s: f64| (-(x * x) / (2.0 * s * s)).exp();
        let (mut sum, mut wsum) = (DVec3::ZERO, 0.0);
        for (p, x, y, z) in visible {
            let w = g(x, self.settings.sigma_xy)
                * g(y, self.settings.sigma_xy)
                * g((z - z_near) / depth_range, self.settings.sigma_depth);
            sum += p * w;
            wsum += w;
        }
        (wsum > 1e-12).then(|| sum / wsum).filter(|p| p.is_finite())
    }
}
