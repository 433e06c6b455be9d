//! IsoCam (thesis 9.3): the eye moves on an isosurface of the distance to the model; position
//! comes from fine targets (precise, so no collision), orientation from coarse targets (smooth).
//!
//! - Hover: the input is split into steps of at most `max_step` × isolevel; each step moves
//!   tangentially (the step unprojected with a view looking at the fine target), then re-projects
//!   the eye onto the isolevel by moving toward the fine target and recomputing it, until
//!   |d − iso| ≤ `reproject_tolerance` × iso or `reproject_max_iterations`. Then the coarse target
//!   gives the view direction, under a global up vector with a tilt limit.
//! - The tilt limit bounds what the visitor's input does, never a view set from outside: a
//!   go-to ends exactly at its node's view even when that view is steeper than the limit
//!   ([`IsoCam::reset`] keeps it). The next hovers then relax the view toward the limit at the
//!   pace of the smoothing (the limit in force is never stricter than the previous view), so
//!   nothing snaps. [`exceeds_tilt_limit`] tells an author which views are steeper.
//! - Zoom: the eye moves along the view direction (what the visitor sees stays centred), the
//!   distance to the point looked at (at the coarse target's distance along the view) scaled
//!   by the zoom; the move is accepted only if the new distances to the fine target, to the
//!   coarse target and to the point looked at are all ≥ `min_distance` (forward and backward
//!   collisions alike). A refused move is shortened by bisection to the largest safe fraction.
//! - Twist: rotates the up vector about the view direction. A pinch almost always turns the
//!   fingers a little, so a visitor who only zoomed would leave the model crooked: once the
//!   fingers lift ([`IsoCam::level`]), a roll within `level_snap` of the view's rest roll (upright,
//!   or the roll of the last view set from outside, such as a node's) eases back to it, else one
//!   within `level_snap` of upright eases upright (a visitor straightening a deliberate twist by
//!   hand); a larger, deliberate twist stays and becomes the rest roll.
//! - Temporal smoothing (9.3.3): the screen motion of the coarse target is limited to the user's
//!   input motion by interpolating the orientation (recursively, `smoothing_rounds`), then the
//!   orientation is blended with the previous one (`smoothing_blend`). Only orientation is
//!   interpolated: the position stays the collision-free one from the fine targets.

use super::{Camera, Intent, SceneRef, orthonormal_up, rotate, slerp_dir};
use crate::scene::QueryParams;
use glam::DVec3;

/// Settings of IsoCam; every tolerance, cap and limit is here, with documented defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IsoCamSettings {
    /// Closest allowed distance to the surface (model units). Default: 1 % of the diagonal.
    pub min_distance: f64,
    /// Largest hover step, as a fraction of the isolevel (default 0.05).
    pub max_step: f64,
    /// Most steps per frame; larger inputs are clamped (default 64).
    pub max_steps_per_frame: u32,
    /// Re-projection stops when |d − iso| ≤ this × iso (default 0.01).
    pub reproject_tolerance: f64,
    /// Re-projection iteration cap (default 8).
    pub reproject_max_iterations: u32,
    /// Smallest angle between the view direction and ±up, radians (default 10°).
    pub tilt_limit: f64,
    /// Smoothing accepts a screen motion of the coarse target up to (1 + this) × the input
    /// (default 0.25).
    pub smoothing_tolerance: f64,
    /// Refinements of the smoothing fraction (bisection halvings; thesis: "generally 2 or 3"
    /// rounds of its ratio rule; default 6).
    pub smoothing_rounds: u32,
    /// Weight of the new orientation in the final blend with the previous one (default 0.7).
    pub smoothing_blend: f64,
    /// Bisection steps to shorten a refused zoom (default 8).
    pub zoom_bisections: u32,
    /// The global up vector (default +Y).
    pub up: DVec3,
    /// A roll within this angle of the rest roll eases back to it once the fingers lift
    /// (radians, default 20°; 0: a twist always stays). See [`IsoCam::level`].
    pub level_snap: f64,
    /// Time constant of that easing, seconds (default 0.15: settled in about half a second).
    pub level_secs: f64,
    /// Fine and coarse target searches.
    pub query: QueryParams,
}

impl IsoCamSettings {
    /// Defaults for a model of the given diagonal.
    pub fn for_model(diagonal: f64) -> Self {
        Self {
            min_distance: 0.01 * diagonal,
            max_step: 0.05,
            max_steps_per_frame: 64,
            reproject_tolerance: 0.01,
            reproject_max_iterations: 8,
            tilt_limit: 10f64.to_radians(),
            smoothing_tolerance: 0.25,
            smoothing_rounds: 6,
            smoothing_blend: 0.7,
            zoom_bisections: 8,
            up: DVec3::Y,
            level_snap: 20f64.to_radians(),
            level_secs: 0.15,
            query: QueryParams::default(),
        }
    }
}

/// What the last hover did (for tests and benchmarks).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepStats {
    /// Steps the input was split into.
    pub steps: u32,
    /// Re-projection iterations over all steps.
    pub iterations: u32,
    /// Largest |d − iso| / iso after a step.
    pub iso_error: f64,
}

/// The IsoCam controller.
#[derive(Clone, Debug)]
pub struct IsoCam {
    /// Settings.
    pub settings: IsoCamSettings,
    eye: DVec3,
    iso: f64,
    coarse: DVec3,
    dir: DVec3,
    twist: f64,
    /// The roll a small twist eases back to ([`IsoCam::level`]).
    rest_twist: f64,
    fov_y: f64,
    /// Statistics of the last hover.
    pub last: StepStats,
}

impl IsoCam {
    /// Starts from a camera (its eye; the isolevel is the eye's distance to the fine target).
    pub fn new<B: AsRef<[u8]>>(scene: SceneRef<'_, B>, cam: Camera, settings: IsoCamSettings) -> Self {
        let mut s = Self {
            settings,
            eye: cam.eye,
            iso: settings.min_distance,
            coarse: cam.target,
            dir: cam.forward(),
            twist: 0.0,
            rest_twist: 0.0,
            fov_y: cam.fov_y,
            last: StepStats::default(),
        };
        s.reset(scene, cam);
        s
    }

    /// Restarts from a camera (after a go-to animation).
    pub fn reset<B: AsRef<[u8]>>(&mut self, scene: SceneRef<'_, B>, cam: Camera) {
        self.eye = cam.eye;
        self.fov_y = cam.fov_y;
        if let Some(f) = self.fine(scene, self.eye) {
            self.iso = (self.eye - f).length().max(self.settings.min_distance);
        }
        // The point looked at, not yet the coarse target: the first hover then turns toward the
        // coarse target at the pace the smoothing allows instead of snapping to it.
        self.coarse = cam.target;
        // Exactly the view given (a node's view is reached exactly), even beyond the tilt limit:
        // the limit bounds the visitor's input, and relaxes from here as the visitor hovers.
        self.dir = cam.forward();
        // Keep the camera's roll relative to the global up as the twist.
        let base = orthonormal_up(self.dir, self.settings.up, cam.up);
        let up = orthonormal_up(self.dir, cam.up, base);
        self.twist = base.cross(up).dot(self.dir).atan2(base.dot(up));
        self.rest_twist = self.twist;
    }

    /// The roll a small twist eases back to becomes upright (after a flight interrupted
    /// halfway, whose roll is nobody's choice).
    pub fn rest_upright(&mut self) {
        self.rest_twist = 0.0;
    }

    /// One frame of `dt` seconds with no finger down: a roll within `level_snap` of the rest
    /// roll eases back to it, else one within `level_snap` of upright eases upright (and upright
    /// becomes the rest); a larger one (a deliberate twist) becomes the rest roll.
    pub fn level(&mut self, dt: f64) {
        use std::f64::consts::{PI, TAU};
        let signed = |a: f64| (a + PI).rem_euclid(TAU) - PI;
        if !dt.is_finite() || !self.twist.is_finite() {
            return;
        }
        let snap = self.settings.level_snap;
        if signed(self.twist - self.rest_twist).abs() > snap {
            self.rest_twist = if signed(self.twist).abs() <= snap { 0.0 } else { self.twist };
        }
        let off = signed(self.twist - self.rest_twist);
        if off == 0.0 || off.abs() > snap {
            return;
        }
        let eased = off * (-dt / self.settings.level_secs.max(f64::MIN_POSITIVE)).exp();
        // Settled exactly once it no longer shows (1 mrad: half a pixel at the edge of a 1080p
        // image), in under a second from 20°.
        let eased = if eased.abs() < 1e-3 { 0.0 } else { eased };
        self.twist = (self.rest_twist + eased).rem_euclid(TAU);
    }

    /// Changes the vertical field of view (the projection), keeping the eye and the view.
    pub fn set_fov(&mut self, fov_y: f64) {
        if fov_y.is_finite() && fov_y > 0.0 {
            self.fov_y = fov_y;
        }
    }

    /// Moves the eye to `eye`, keeping the view direction and the twist, and takes the
    /// isolevel there (used to bring a far eye back toward the model; the caller keeps `eye`
    /// out of the surface).
    pub fn place_eye<B: AsRef<[u8]>>(&mut self, scene: SceneRef<'_, B>, eye: DVec3) {
        if !eye.is_finite() {
            return;
        }
        self.eye = eye;
        if let Some(f) = self.fine(scene, eye) {
            self.iso = (eye - f).length().max(self.settings.min_distance);
        }
    }

    /// The current isolevel (distance to the fine target).
    pub fn isolevel(&self) -> f64 {
        self.iso
    }

    /// The current coarse target.
    pub fn coarse_target(&self) -> DVec3 {
        self.coarse
    }

    /// The camera.
    pub fn camera(&self) -> Camera {
        let dist = (self.coarse - self.eye).length().max(self.settings.min_distance);
        let base = orthonormal_up(self.dir, self.settings.up, DVec3::Z);
        let up = rotate(base, self.dir, self.twist);
        Camera { eye: self.eye, target: self.eye + self.dir * dist, up, fov_y: self.fov_y }
    }

    fn fine<B: AsRef<[u8]>>(&self, scene: SceneRef<'_, B>, p: DVec3) -> Option<DVec3> {
        scene.store.fine_target(scene.cut, p, &self.settings.query).map(|t| t.point)
    }

    fn coarse_at<B: AsRef<[u8]>>(&self, scene: SceneRef<'_, B>, p: DVec3) -> Option<DVec3> {
        scene.store.coarse_target(scene.cut, p, &self.settings.query).map(|t| t.point)
    }

    /// Applies one frame's intent.
    pub fn apply<B: AsRef<[u8]>>(&mut self, scene: SceneRef<'_, B>, intent: &Intent) {
        let h = (intent.hover.0 + intent.pan.0, intent.hover.1 + intent.pan.1);
        if h.0.is_finite() && h.1.is_finite() && h != (0.0, 0.0) {
            self.hover(scene, h);
        }
        if intent.zoom.is_finite() && intent.zoom != 0.0 {
            self.zoom(scene, intent.zoom);
        }
        if intent.twist.is_finite() && intent.twist != 0.0 {
            self.twist = (self.twist + intent.twist).rem_euclid(std::f64::consts::TAU);
        }
    }

    /// Hover by a screen displacement (viewport heights; x right, y up).
    pub fn hover<B: AsRef<[u8]>>(&mut self, scene: SceneRef<'_, B>, delta: (f64, f64)) {
        let s = &self.settings;
        let world_per_height = 2.0 * (self.fov_y * 0.5).tan() * self.iso;
        let total = (delta.0.hypot(delta.1) * world_per_height).min(1e300);
        let step_len = (s.max_step * self.iso).max(f64::MIN_POSITIVE);
        let max_steps = s.max_steps_per_frame.max(1);
        let wanted_steps = (total / step_len).ceil();
        // An input longer than `max_steps_per_frame` steps is clamped to that many steps of the
        // largest size (the steps never grow beyond `max_step`).
        let (steps, scale) = if wanted_steps > f64::from(max_steps) {
            (max_steps, f64::from(max_steps) * step_len / total)
        } else {
            ((wanted_steps as u32).max(1), 1.0)
        };
        let (sx, sy) = (delta.0 * scale / f64::from(steps), delta.1 * scale / f64::from(steps));
        let prev = self.camera();
        let mut stats = StepStats { steps, ..StepStats::default() };
        for _ in 0..steps {
            let Some(f) = self.fine(scene, self.eye) else { return };
            // The screen axes of a view looking at the fine target (with the user's twist).
            let toward = (f - self.eye).try_normalize().unwrap_or(self.dir);
            let base = orthonormal_up(toward, self.settings.up, prev.up);
            let cam_up = rotate(base, toward, self.twist);
            let right = toward.cross(cam_up).try_normalize().unwrap_or(prev.right());
            let w = 2.0 * (self.fov_y * 0.5).tan() * self.iso;
            let mut eye = self.eye + right * (sx * w) + cam_up * (sy * w);
            // Re-project onto the isolevel. `settled`: the error at `eye` when the loop stopped
            // there (no move after it).
            let mut settled = None;
            for _ in 0..s.reproject_max_iterations {
                let Some(f) = self.fine(scene, eye) else { break };
                let d = (eye - f).length();
                let err = (d - self.iso).abs() / self.iso;
                if err <= s.reproject_tolerance {
                    settled = Some(err);
                    break;
                }
                stats.iterations += 1;
                let away = (eye - f).try_normalize().unwrap_or(-toward);
                eye = f + away * self.iso;
            }
            if !eye.is_finite() {
                return;
            }
            self.eye = self.keep_out(scene, eye);
            // The error where the eye ended, after the last move (measured again only when the
            // re-projection ran out of iterations or the eye was pushed out).
            let err = match settled {
                Some(err) if self.eye == eye => err,
                _ => self
                    .fine(scene, self.eye)
                    .map_or(0.0, |f| ((self.eye - f).length() - self.iso).abs() / self.iso),
            };
            stats.iso_error = stats.iso_error.max(if err.is_finite() { err } else { 0.0 });
        }
        self.last = stats;
        let Some(coarse) = self.coarse_at(scene, self.eye) else { return };
        let old_coarse = self.coarse;
        self.coarse = coarse;
        let wanted = (coarse - self.eye).try_normalize().unwrap_or(self.dir);
        let wanted = self.tilt_limited(wanted, self.dir);
        let smoothed = self.smoothed(&prev, old_coarse, wanted, delta.0.hypot(delta.1));
        // Interpolating between two directions can pass nearer the pole than either. The limit
        // in force is never stricter than the previous view (a node's view steeper than the
        // limit relaxes toward it at the smoothing's pace instead of snapping).
        let limit = self.settings.tilt_limit.min(tilt_from_up(prev.forward(), self.settings.up));
        self.dir = tilt_limited_to(smoothed, wanted, self.settings.up, limit);
    }

    /// Pushes `eye` out to `min_distance` from the nearest sample of the cut, if closer.
    fn keep_out<B: AsRef<[u8]>>(&self, scene: SceneRef<'_, B>, eye: DVec3) -> DVec3 {
        let mut eye = eye;
        for _ in 0..4 {
            let Some(t) = scene.store.fine_target(scene.cut, eye, &self.settings.query) else { break };
            if t.nearest_distance >= self.settings.min_distance {
                break;
            }
            let local = scene.store.to_local(eye);
            let Some(&(_, n, i)) =
                scene.store.knn_local(crate::scene::Level::Cut(scene.cut), local, 1, u32::MAX).first()
            else {
                break;
            };
            let p = scene.store.to_model(scene.store.splats(n)[i as usize].position());
            let away = (eye - p).try_normalize().unwrap_or(-self.dir);
            eye = p + away * self.settings.min_distance * 1.0001;
        }
        eye
    }

    /// Applies the tilt limit to a view direction (`fallback` gives the heading when looking
    /// straight along ±up).
    fn tilt_limited(&self, dir: DVec3, fallback: DVec3) -> DVec3 {
        tilt_limited_to(dir, fallback, self.settings.up, self.settings.tilt_limit)
    }

    /// Temporal smoothing of the orientation (9.3.3). The screen motion of the previous coarse
    /// target, from the previous camera to the new one, may be at most (1 + tolerance) × the
    /// user's input motion: when the coarse target jumps (the nearest part of the model
    /// changes) or the view is not yet centred on it, the view direction is interpolated toward
    /// the new one by the ratio input / motion, recursively; then it is blended with the previous
    /// direction. Orbiting keeps the old target near the centre, so it is not slowed down.
    fn smoothed(&self, prev: &Camera, old_coarse: DVec3, wanted: DVec3, input: f64) -> DVec3 {
        let s = &self.settings;
        let prev_dir = prev.forward();
        // Screen position in viewport heights (aspect 1 keeps x in height units).
        let screen = |c: &Camera| c.ndc(old_coarse, 1.0).map(|(x, y, _)| glam::DVec2::new(x, y) * 0.5);
        let camera_for = |dir: DVec3| {
            let up = rotate(orthonormal_up(dir, self.settings.up, prev.up), dir, self.twist);
            Camera { eye: self.eye, target: self.eye + dir, up, fov_y: self.fov_y }
        };
        let mut dir = wanted;
        if let Some(anchor) = screen(prev) {
            let bound = input * (1.0 + s.smoothing_tolerance);
            let motion = |t: f64| {
                screen(&camera_for(slerp_dir(prev_dir, wanted, t)))
                    .map_or(f64::INFINITY, |p| (p - anchor).length())
            };
            if motion(1.0) > bound {
                // The thesis interpolates by input / motion, which assumes no motion without
                // rotation; the eye's own translation moves the target too, so we search the
                // largest fraction within the bound by bisection (`smoothing_rounds` halvings).
                let (mut lo, mut hi) = (0.0, 1.0);
                for _ in 0..s.smoothing_rounds {
                    let mid = 0.5 * (lo + hi);
                    if motion(mid) <= bound { lo = mid } else { hi = mid }
                }
                dir = slerp_dir(prev_dir, wanted, lo);
            }
        }
        slerp_dir(prev_dir, dir, s.smoothing_blend.clamp(0.0, 1.0))
    }

    /// Zoom: positive `amount` brings the eye closer (log of the distance ratio), along the view
    /// direction: the point looked at stays at the centre of the screen.
    pub fn zoom<B: AsRef<[u8]>>(&mut self, scene: SceneRef<'_, B>, amount: f64) {
        let s = self.settings;
        let u = self.dir;
        let dc = (self.coarse - self.eye).length();
        if !(dc > 0.0 && dc.is_finite() && u.is_finite()) {
            return;
        }
        // The point looked at: on the view ray, at the coarse target's distance.
        let pivot = self.eye + u * dc;
        let candidate = |frac: f64| -> Option<(DVec3, f64)> {
            let d = dc * (-amount * frac).exp();
            if d.is_nan() || d < s.min_distance || !d.is_finite() {
                return None;
            }
            let eye = pivot - u * d;
            if (eye - self.coarse).length() < s.min_distance {
                return None;
            }
            let f = scene.store.fine_target(scene.cut, eye, &s.query)?;
            let df = (eye - f.point).length().min(f.nearest_distance);
            (df >= s.min_distance).then_some((eye, (eye - f.point).length()))
        };
        let accepted = candidate(1.0).or_else(|| {
            // Shorten the move to the largest safe fraction.
            let (mut lo, mut hi, mut best) = (0.0, 1.0, None);
            for _ in 0..s.zoom_bisections {
                let mid = 0.5 * (lo + hi);
                match candidate(mid) {
                    Some(c) => {
                        best = Some(c);
                        lo = mid;
                    }
                    None => hi = mid,
                }
            }
            best
        });
        if let Some((eye, iso)) = accepted {
            self.eye = eye;
            self.iso = iso.max(s.min_distance);
        }
    }
}

/// Angle between a view direction and the nearer of ±`up` (π/2 looking level).
fn tilt_from_up(dir: DVec3, up: DVec3) -> f64 {
    let up = up.try_normalize().unwrap_or(DVec3::Y);
    match dir.try_normalize() {
        Some(d) => d.dot(up).abs().clamp(0.0, 1.0).acos(),
        None => std::f64::consts::FRAC_PI_2,
    }
}

/// `dir` brought to at least `limit` from ±`up` (`fallback` gives the heading when looking
/// straight along ±up).
fn tilt_limited_to(dir: DVec3, fallback: DVec3, up: DVec3, limit: f64) -> DVec3 {
    let up = up.try_normalize().unwrap_or(DVec3::Y);
    let c = dir.dot(up);
    let limit = limit.clamp(0.0, std::f64::consts::FRAC_PI_2);
    if c.abs() <= limit.cos() {
        return dir;
    }
    let horizontal = (dir - up * c)
        .try_normalize()
        .or_else(|| (fallback - up * fallback.dot(up)).try_normalize())
        .unwrap_or_else(|| super::any_perpendicular(up));
    (horizontal * limit.sin() + up * c.signum() * limit.cos()).try_normalize().unwrap_or(horizontal)
}

/// Whether a view looks nearer to ±`up` than `tilt_limit` (radians), i.e. steeper than the
/// visitor's input can reach under IsoCam (see [`IsoCamSettings::tilt_limit`]). Authoring uses
/// it to flag such views; the kiosk still reaches them exactly.
pub fn exceeds_tilt_limit(view: &Camera, up: DVec3, tilt_limit: f64) -> bool {
    let limit = tilt_limit.clamp(0.0, std::f64::consts::FRAC_PI_2);
    tilt_from_up(view.forward(), up) < limit - 1e-12
}

impl IsoCamSettings {
    /// Whether a view is steeper than these settings' tilt limit ([`exceeds_tilt_limit`]).
    pub fn exceeds_tilt_limit(&self, view: &Camera) -> bool {
        exceeds_tilt_limit(view, self.up, self.tilt_limit)
    }
}
