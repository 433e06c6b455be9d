//! Geometric queries on the scene (thesis 9.7.1):
//! - fine and coarse targets on the current cut: a K-nearest search whose depth inside each
//!   node's implicit box hierarchy is limited, reduced to one point by the weighted average
//!   p* = Σ wᵢ pᵢ / Σ wᵢ with wᵢ = (1 − (dᵢ² − d_min²)/(d_max² − d_min²))⁴;
//! - the exact nearest sample at full resolution (tests and the replay trace);
//! - ray casts, front to back, on the cut or at full resolution;
//! - a random sample of points of the cut (view similarity).
//!
//! Queries take and return model coordinates (`f64`) and work internally in the store's local
//! `f32` frame, so a model at 10⁷ m answers exactly like one at the origin.

use super::boxtree::{BoxTree, KBest};
use super::cut::{Cut, Side};
use super::splat::Splat;
use super::store::{NodeId, Store};
use glam::{DVec3, Vec3};
use rand::Rng;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Settings of the fine and coarse targets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryParams {
    /// Neighbours averaged for the fine target (thesis: 8).
    pub fine_k: usize,
    /// Search depth in each node's box hierarchy for the fine target (`u32::MAX`: to the leaves).
    pub fine_depth: u32,
    /// Neighbours averaged for the coarse target (thesis: 16).
    pub coarse_k: usize,
    /// Search depth for the coarse target ("near the root" of each node's box hierarchy).
    pub coarse_depth: u32,
}

impl Default for QueryParams {
    fn default() -> Self {
        Self { fine_k: 8, fine_depth: u32::MAX, coarse_k: 16, coarse_depth: 4 }
    }
}

/// The answer of a target query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TargetQuery {
    /// The weighted average of the neighbours (model coordinates).
    pub point: DVec3,
    /// Distance from the query to the nearest neighbour found.
    pub nearest_distance: f64,
    /// Neighbours used.
    pub count: usize,
}

/// A ray hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter (distance along the unit direction).
    pub t: f64,
    /// The hit point on the ray (model coordinates).
    pub point: DVec3,
    /// Node of the splat hit.
    pub node: NodeId,
    /// Index of the splat in its node.
    pub index: u32,
}

/// Which representation a query searches.
#[derive(Clone, Copy, Debug)]
pub enum Level<'a> {
    /// The nodes of a cut.
    Cut(&'a Cut),
    /// The leaves: full resolution.
    Full,
}

impl Level<'_> {
    fn side<B: AsRef<[u8]>>(&self, store: &Store<B>, id: NodeId) -> Side {
        match self {
            Level::Cut(c) => c.side[id as usize],
            Level::Full => {
                if store.node(id).is_leaf() {
                    Side::In
                } else {
                    Side::Above
                }
            }
        }
    }
}

#[derive(PartialEq)]
struct Pending(f32, NodeId);
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Pending {
    // Min-heap on the key, ties by node id for determinism.
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}

/// Weighted average of thesis 9.7.1 over `(squared distance, point)` pairs sorted by distance.
pub fn weighted_average(neigh: &[(f32, Vec3)]) -> Option<Vec3> {
    let (d_min, d_max) = (neigh.first()?.0, neigh.last()?.0);
    let span = d_max - d_min;
    let mut sum = Vec3::ZERO;
    let mut wsum = 0.0f32;
    for &(d2, p) in neigh {
        let w = if span > 0.0 { (1.0 - (d2 - d_min) / span).powi(4) } else { 1.0 };
        sum += w * p;
        wsum += w;
    }
    // The nearest point always has weight 1, so wsum ≥ 1.
    Some(sum / wsum)
}

impl<B: AsRef<[u8]>> Store<B> {
    /// The search tree of one node.
    pub fn box_tree(&self, id: NodeId) -> BoxTree<'_, Splat> {
        BoxTree::new(self.splats(id), self.boxes(id))
    }

    /// The `k` samples nearest to `q` (local coordinates) in `level`, searching `depth` levels
    /// into each node's box hierarchy. Nearest first: (squared distance, node, index).
    pub fn knn_local(&self, level: Level<'_>, q: Vec3, k: usize, depth: u32) -> Vec<(f32, NodeId, u32)> {
        let mut best: KBest<(NodeId, u32)> = KBest::new(k);
        let mut heap = BinaryHeap::new();
        let root = self.root();
        heap.push(Pending(self.node(root).bbox().distance_squared(q), root));
        while let Some(Pending(d2, id)) = heap.pop() {
            if d2 >= best.bound() {
                break;
            }
            match level.side(self, id) {
                Side::In => self.box_tree(id).knn(q, depth, &mut best, &|i| (id, i)),
                Side::Above => {
                    for c in self.node(id).children {
                        heap.push(Pending(self.node(c).bbox().distance_squared(q), c));
                    }
                }
                Side::Below => {}
            }
        }
        best.items().iter().map(|&(d2, (n, i))| (d2, n, i)).collect()
    }

    fn target(&self, cut: &Cut, q: DVec3, k: usize, depth: u32) -> Option<TargetQuery> {
        let q_local = self.to_local(q);
        if !q_local.is_finite() {
            return None;
        }
        let found = self.knn_local(Level::Cut(cut), q_local, k, depth);
        let neigh: Vec<(f32, Vec3)> =
            found.iter().map(|&(d2, n, i)| (d2, self.splats(n)[i as usize].position())).collect();
        let p = weighted_average(&neigh)?;
        Some(TargetQuery {
            point: self.to_model(p),
            nearest_distance: f64::from(neigh[0].0).sqrt(),
            count: neigh.len(),
        })
    }

    /// The fine target of `q` (model coordinates) on `cut`: K = `fine_k` neighbours searched to
    /// `fine_depth`. Used for the camera's position. `None` only for a non-finite query.
    pub fn fine_target(&self, cut: &Cut, q: DVec3, params: &QueryParams) -> Option<TargetQuery> {
        self.target(cut, q, params.fine_k, params.fine_depth)
    }

    /// The coarse target of `q` on `cut`: K = `coarse_k` neighbours searched to `coarse_depth`.
    /// Used for the camera's orientation (smooth).
    pub fn coarse_target(&self, cut: &Cut, q: DVec3, params: &QueryParams) -> Option<TargetQuery> {
        self.target(cut, q, params.coarse_k, params.coarse_depth)
    }

    /// The sample nearest to `q` at full resolution: (distance, position in model coordinates).
    pub fn nearest_sample(&self, q: DVec3) -> Option<(f64, DVec3)> {
        let q_local = self.to_local(q);
        if !q_local.is_finite() {
            return None;
        }
        let &(_, n, i) = self.knn_local(Level::Full, q_local, 1, u32::MAX).first()?;
        let p = self.to_model(self.splats(n)[i as usize].position());
        // Measure in f64 from the model-coordinate query, as the trace reports it.
        Some(((p - q).length(), p))
    }

    /// First hit of the ray from `origin` along `dir` (model coordinates) within `max_t`, front
    /// to back over the nodes of `level`; splats are balls of their radius.
    pub fn ray_cast(&self, level: Level<'_>, origin: DVec3, dir: DVec3, max_t: f64) -> Option<Hit> {
        let dir = dir.try_normalize()?.as_vec3();
        let o = self.to_local(origin);
        if !o.is_finite() {
            return None;
        }
        let inv = dir.recip();
        let mut t_best = if max_t.is_finite() { max_t as f32 } else { f32::INFINITY };
        let mut best: Option<(f32, NodeId, u32)> = None;
        let mut heap = BinaryHeap::new();
        let entry = |id: NodeId, t_best: f32| {
            let n = self.node(id);
            n.bbox().inflate(n.subtree_radius_max).ray_interval(o, inv, 0.0, t_best).map(|(a, _)| a)
        };
        if let Some(t) = entry(self.root(), t_best) {
            heap.push(Pending(t, self.root()));
        }
        while let Some(Pending(t_enter, id)) = heap.pop() {
            if t_enter >= t_best {
                break;
            }
            match level.side(self, id) {
                Side::In => {
                    let r = self.node(id).radius_max;
                    if let Some((t, i)) = self.box_tree(id).ray_cast(o, dir, 0.0, t_best, r) {
                        t_best = t;
                        best = Some((t, id, i));
                    }
                }
                Side::Above => {
                    for c in self.node(id).children {
                        if let Some(t) = entry(c, t_best) {
                            heap.push(Pending(t, c));
                        }
                    }
                }
                Side::Below => {}
            }
        }
        best.map(|(t, node, index)| Hit { t: f64::from(t), point: self.to_model(o + dir * t), node, index })
    }

    /// `count` samples drawn uniformly from the points of `cut` (local coordinates), with the
    /// injected random number generator.
    pub fn sample_cut(&self, cut: &Cut, count: usize, rng: &mut impl Rng) -> Vec<Vec3> {
        let nodes = cut.nodes();
        let mut prefix = Vec::with_capacity(nodes.len());
        let mut total = 0u64;
        for &n in nodes {
            total += u64::from(self.node(n).point_count);
            prefix.push(total);
        }
        if total == 0 {
            return Vec::new();
        }
        (0..count)
            .map(|_| {
                let r = rng.random_range(0..total);
                let k = prefix.partition_point(|&p| p <= r);
                let before = if k == 0 { 0 } else { prefix[k - 1] };
                self.splats(nodes[k])[(r - before) as usize].position()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_favour_the_nearest_and_ignore_the_farthest() {
        let n = [(1.0, Vec3::X), (4.0, Vec3::Y), (9.0, Vec3::Z)];
        let p = weighted_average(&n).expect("non-empty");
        // w = 1, (1 - 3/8)^4, 0
        let w1 = (1.0f32 - 3.0 / 8.0).powi(4);
        let expect = (Vec3::X + w1 * Vec3::Y) / (1.0 + w1);
        assert!((p - expect).length() < 1e-6);
        // Equal distances: plain average, no division by zero.
        let e = [(2.0, Vec3::X), (2.0, Vec3::NEG_X)];
        assert_eq!(weighted_average(&e), Some(Vec3::ZERO));
        assert_eq!(weighted_average(&[]), None);
    }
}
