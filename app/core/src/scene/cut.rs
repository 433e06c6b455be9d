//! The view-dependent cut (balsa12 §6.1, thesis 9.3.3): a front through the hierarchy such that
//! every node in it shows its samples at most `tolerance_px` apart on screen.
//!
//! The cut always covers the **whole** model: nodes outside the frustum are not dropped but made
//! coarser (their tolerance is multiplied by `out_of_view_factor`), because the camera's distance
//! queries need a complete model. Frustum culling happens only in [`Cut::visible_nodes`], the
//! list the renderer draws.
//!
//! Updates are incremental (start from the previous front, split or merge locally) and bounded
//! (`max_changes` splits and merges per update), so a sudden turn never stalls a frame; the cut
//! converges over the next frames instead.

use super::store::{NONE, NodeId, Store};
use crate::geom::Aabb;
use glam::{DVec3, Mat4, Vec3, Vec4, Vec4Swizzles};

/// Settings of the cut.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutParams {
    /// Largest allowed on-screen spacing between samples, in pixels (balsa12: typically 2).
    pub tolerance_px: f32,
    /// Nodes outside the frustum use `tolerance_px * out_of_view_factor`.
    pub out_of_view_factor: f32,
    /// Largest number of splits + merges in one update (time bound).
    pub max_changes: usize,
}

impl Default for CutParams {
    fn default() -> Self {
        Self { tolerance_px: 1.0, out_of_view_factor: 8.0, max_changes: 256 }
    }
}

/// What the cut needs to know of the camera, in the store's local coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewParams {
    /// Eye position (local coordinates).
    pub eye: Vec3,
    /// Clip-from-local matrix (projection × view) for frustum tests.
    pub clip_from_local: Mat4,
    /// Pixels per unit of `size / distance`: `viewport_height / (2 tan(fov_y / 2))`.
    pub px_per_unit: f32,
}

impl ViewParams {
    /// A perspective view looking from `eye` toward `target` (model coordinates, f64), with
    /// vertical field of view `fov_y` (radians), for a viewport of `width × height` pixels.
    /// Returns `None` when eye and target coincide or the up vector is parallel to the view.
    pub fn look_at(
        store_origin: DVec3,
        eye: DVec3,
        target: DVec3,
        up: DVec3,
        fov_y: f32,
        size_px: (u32, u32),
        near_far: (f32, f32),
    ) -> Option<Self> {
        let eye_l = (eye - store_origin).as_vec3();
        let dir = (target - eye).try_normalize()?.as_vec3();
        let up = up.try_normalize()?.as_vec3();
        if dir.cross(up).length_squared() < 1e-12 || !(fov_y > 0.0 && fov_y < 3.1) {
            return None;
        }
        let (w, h) = (size_px.0.max(1) as f32, size_px.1.max(1) as f32);
        let view = glam::camera::rh::view::look_to_mat4(eye_l, dir, up);
        let proj = glam::camera::rh::proj::directx::perspective(fov_y, w / h, near_far.0, near_far.1);
        Some(Self { eye: eye_l, clip_from_local: proj * view, px_per_unit: h / (2.0 * (fov_y * 0.5).tan()) })
    }

    /// The six frustum planes (inside: `dot(plane, (p, 1)) ≥ 0`), for [0, 1] depth clip space.
    pub fn frustum_planes(&self) -> [Vec4; 6] {
        let m = self.clip_from_local.transpose();
        let (r0, r1, r2, r3) = (m.x_axis, m.y_axis, m.z_axis, m.w_axis);
        [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2]
    }

    /// On-screen size in pixels of a sphere of diameter `size` at the point of `bbox` closest to
    /// the eye (∞ when the eye is inside the box).
    pub fn projected_px(&self, bbox: &Aabb, size: f32) -> f32 {
        let d = bbox.distance_squared(self.eye).sqrt();
        if d <= 0.0 { f32::INFINITY } else { size * self.px_per_unit / d }
    }
}

/// Whether a box is at least partly inside the frustum.
pub fn box_in_frustum(planes: &[Vec4; 6], b: &Aabb) -> bool {
    planes.iter().all(|p| {
        let n = p.xyz();
        let corner = Vec3::select(n.cmpge(Vec3::ZERO), b.max, b.min);
        n.dot(corner) + p.w >= 0.0
    })
}

/// What an update did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CutStats {
    /// Nodes replaced by their children.
    pub splits: usize,
    /// Sibling pairs replaced by their parent.
    pub merges: usize,
    /// Whether the budget stopped the update before it converged.
    pub budget_hit: bool,
    /// Nodes in the cut afterwards.
    pub nodes: usize,
    /// Samples in the cut afterwards.
    pub points: u64,
}

/// Where a node is relative to the front.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Side {
    /// An ancestor of front nodes.
    Above,
    /// In the front.
    In,
    /// A descendant of a front node.
    Below,
}

/// A cut through the hierarchy: a set of nodes whose union covers the model exactly once.
#[derive(Clone, Debug)]
pub struct Cut {
    pub(crate) side: Vec<Side>,
    front: Vec<NodeId>,
}

impl Cut {
    /// The coarsest cut: the root alone.
    pub fn root<B: AsRef<[u8]>>(store: &Store<B>) -> Self {
        let mut side = vec![Side::Below; store.nodes().len()];
        side[store.root() as usize] = Side::In;
        Self { side, front: vec![store.root()] }
    }

    /// The full-resolution cut: every leaf (for reference renders and tests).
    pub fn leaves<B: AsRef<[u8]>>(store: &Store<B>) -> Self {
        let nodes = store.nodes();
        let side = nodes.iter().map(|n| if n.is_leaf() { Side::In } else { Side::Above }).collect();
        let front = (0..nodes.len() as u32).filter(|&i| nodes[i as usize].is_leaf()).collect();
        Self { side, front }
    }

    /// Nodes in the cut, sorted by id.
    pub fn nodes(&self) -> &[NodeId] {
        &self.front
    }

    /// Whether `id` is in the cut.
    pub fn contains(&self, id: NodeId) -> bool {
        self.side.get(id as usize) == Some(&Side::In)
    }

    /// Total samples in the cut.
    pub fn point_count<B: AsRef<[u8]>>(&self, store: &Store<B>) -> u64 {
        self.front.iter().map(|&n| u64::from(store.node(n).point_count)).sum()
    }

    /// Updates the cut for a new view, incrementally from the current one.
    pub fn update<B: AsRef<[u8]>>(
        &mut self,
        store: &Store<B>,
        view: &ViewParams,
        params: &CutParams,
    ) -> CutStats {
        let planes = view.frustum_planes();
        let nodes = store.nodes();
        let wants_detail = |id: NodeId| {
            let n = &nodes[id as usize];
            let bbox = n.bbox();
            let tol = if box_in_frustum(&planes, &bbox) {
                params.tolerance_px
            } else {
                params.tolerance_px * params.out_of_view_factor
            };
            view.projected_px(&bbox, n.spacing) > tol
        };
        let mut stats = CutStats::default();
        let mut budget = params.max_changes;
        loop {
            let mut changed = false;
            let mut next = Vec::with_capacity(self.front.len() + 16);
            for &id in &self.front {
                if self.side[id as usize] != Side::In {
                    continue; // merged into its parent earlier in this pass
                }
                let n = &nodes[id as usize];
                if budget > 0 && !n.is_leaf() && wants_detail(id) {
                    self.side[id as usize] = Side::Above;
                    for c in n.children {
                        self.side[c as usize] = Side::In;
                        next.push(c);
                    }
                    stats.splits += 1;
                    budget -= 1;
                    changed = true;
                    continue;
                }
                let p = n.parent;
                if budget > 0 && p != NONE {
                    let [a, b] = nodes[p as usize].children;
                    let both_in = self.side[a as usize] == Side::In && self.side[b as usize] == Side::In;
                    if both_in && !wants_detail(p) {
                        self.side[a as usize] = Side::Below;
                        self.side[b as usize] = Side::Below;
                        self.side[p as usize] = Side::In;
                        next.push(p);
                        stats.merges += 1;
                        budget -= 1;
                        changed = true;
                        continue;
                    }
                }
                next.push(id);
            }
            next.retain(|&id| self.side[id as usize] == Side::In);
            next.sort_unstable();
            next.dedup();
            self.front = next;
            if !changed {
                break;
            }
            if budget == 0 {
                stats.budget_hit = true;
                break;
            }
        }
        stats.nodes = self.front.len();
        stats.points = self.point_count(store);
        stats
    }

    /// The nodes of the cut inside the frustum: what the renderer draws.
    pub fn visible_nodes<B: AsRef<[u8]>>(&self, store: &Store<B>, view: &ViewParams) -> Vec<NodeId> {
        let planes = view.frustum_planes();
        self.front
            .iter()
            .copied()
            .filter(|&id| {
                let n = store.node(id);
                box_in_frustum(&planes, &n.bbox().inflate(n.radius_max))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frustum_keeps_what_is_in_front_and_drops_what_is_behind() {
        let v = ViewParams::look_at(
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, 10.0),
            DVec3::ZERO,
            DVec3::Y,
            0.8,
            (640, 480),
            (0.1, 100.0),
        )
        .expect("valid view");
        let planes = v.frustum_planes();
        let unit = |c: Vec3| Aabb { min: c - Vec3::splat(0.5), max: c + Vec3::splat(0.5) };
        assert!(box_in_frustum(&planes, &unit(Vec3::ZERO)));
        assert!(!box_in_frustum(&planes, &unit(Vec3::new(0.0, 0.0, 20.0))), "behind the eye");
        assert!(!box_in_frustum(&planes, &unit(Vec3::new(30.0, 0.0, 0.0))), "far to the right");
        assert!(!box_in_frustum(&planes, &unit(Vec3::new(0.0, 0.0, -200.0))), "beyond the far plane");
        assert!((v.projected_px(&unit(Vec3::ZERO), 1.0) - 480.0 / (2.0 * 0.4f32.tan()) / 9.5).abs() < 1e-3);
    }
}
