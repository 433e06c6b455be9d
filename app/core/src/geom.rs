//! Small geometric helpers shared by the scene and the camera.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Axis-aligned bounding box in `f32` local (origin-relative) coordinates. Stored as is (24 bytes)
/// in the search boxes of a store.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Pod, Zeroable)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Aabb {
    /// An empty box: the identity of [`Aabb::union`].
    pub const EMPTY: Self = Self { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// Whether no point was ever added.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }

    /// Grows the box to contain `p`.
    #[inline]
    pub fn include(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box containing both.
    #[inline]
    pub fn union(self, o: Self) -> Self {
        Self { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// The tight box of a set of points.
    #[inline]
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        let mut b = Self::EMPTY;
        for p in points {
            b.include(p);
        }
        b
    }

    /// Box grown by `r` in every direction.
    #[inline]
    pub fn inflate(self, r: f32) -> Self {
        Self { min: self.min - Vec3::splat(r), max: self.max + Vec3::splat(r) }
    }

    /// Extent along each axis (zero for an empty box).
    #[inline]
    pub fn extent(&self) -> Vec3 {
        if self.is_empty() { Vec3::ZERO } else { self.max - self.min }
    }

    /// Centre of the box.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f32 {
        self.extent().length()
    }

    /// The point of the box closest to `p` (p itself when inside).
    #[inline]
    pub fn closest_point(&self, p: Vec3) -> Vec3 {
        p.clamp(self.min, self.max)
    }

    /// Squared distance from `p` to the box (0 inside).
    #[inline]
    pub fn distance_squared(&self, p: Vec3) -> f32 {
        (self.closest_point(p) - p).length_squared()
    }

    /// Entry and exit parameters of the ray `o + t d` through the box, clipped to `[t_min, t_max]`;
    /// `None` when the ray misses.
    #[inline]
    pub fn ray_interval(&self, o: Vec3, inv_d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        let t0 = (self.min - o) * inv_d;
        let t1 = (self.max - o) * inv_d;
        let near = t0.min(t1);
        let far = t0.max(t1);
        // NaN (0 * inf on a slab boundary) must not widen the interval: max/min of glam skip NaN
        // in the way we need because we fold with the clip bounds first.
        let enter = t_min.max(near.x).max(near.y).max(near.z);
        let exit = t_max.min(far.x).min(far.y).min(far.z);
        (enter <= exit).then_some((enter, exit))
    }
}
