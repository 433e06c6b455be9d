//! The radial point-of-interest selector (thesis 9.4, 9.7.2), [`radial_candidates`]: views by
//! increasing eye distance are tested (angle to the current direction ≤ 90°, line of sight)
//! until N pass or the graph is exhausted —
//! a dense cluster of views facing away never empties the menu; those within a mean NDC distance
//! of 2 are ranked by the engine's similarity (Eq. 11.3 where it applies and is positive, first;
//! then Eq. 11.4) and the best M are shown, laid out nearest at the top and clockwise by
//! distance (9.4). The view being displayed (or flown to) is not offered. Mandatory
//! dependencies do not hide a menu choice: the menu is the visitor's own pick among what is in
//! front of them, and a point of interest they are looking at must be reachable even when its
//! introduction is still unseen. Dependencies order only the engine's own proposals; a node
//! displayed from the menu counts as visited, and its unseen predecessors stay proposable.

use crate::graph::InfoGraph;
use crate::recommend::{Projector, RecSettings, StepFrame, ViewContext};
use glam::DVec3;

/// The radial point-of-interest selector (thesis 9.4, 9.7.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadialSettings {
    /// Views that must pass the angle and line-of-sight tests (N), searched by distance.
    pub nearest: usize,
    /// Views presented (M).
    pub slots: usize,
    /// Largest angle between the view directions (thesis: 90°).
    pub max_angle: f64,
    /// Largest mean NDC distance (thesis: 2).
    pub max_ndc_distance: f64,
    /// Fewest ROI samples for ranking with the close metric (as [`RecSettings::min_roi_samples`]).
    pub min_roi_samples: usize,
}

impl Default for RadialSettings {
    fn default() -> Self {
        Self {
            nearest: 24,
            slots: 8,
            max_angle: std::f64::consts::FRAC_PI_2,
            max_ndc_distance: 2.0,
            min_roi_samples: RecSettings::default().min_roi_samples,
        }
    }
}

/// The views of a graph in a kd-tree on their eye positions (thesis 9.7.2): the implicit box
/// hierarchy of the scene, over eyes relative to their centroid.
#[derive(Clone, Debug)]
pub struct ViewIndex {
    center: DVec3,
    eyes: Vec<IndexedEye>,
    boxes: Vec<crate::geom::Aabb>,
}

#[derive(Clone, Copy, Debug)]
struct IndexedEye {
    pos: glam::Vec3,
    node: usize,
}

impl crate::scene::HasPosition for IndexedEye {
    fn position(&self) -> glam::Vec3 {
        self.pos
    }
}

impl ViewIndex {
    /// Indexes the views of `graph`.
    pub fn new(graph: &InfoGraph) -> Self {
        let n = graph.nodes.len().max(1) as f64;
        let center = graph.nodes.iter().fold(DVec3::ZERO, |a, v| a + v.view.eye) / n;
        let mut eyes: Vec<IndexedEye> = graph
            .nodes
            .iter()
            .enumerate()
            .map(|(node, v)| IndexedEye { pos: (v.view.eye - center).as_vec3(), node })
            .collect();
        crate::scene::boxtree::sort_spatially(&mut eyes);
        let boxes = crate::scene::boxtree::build_boxes(&eyes);
        Self { center, eyes, boxes }
    }

    /// The `k` views whose eyes are nearest to `p`, nearest first (exact distances in f64).
    pub fn nearest(&self, graph: &InfoGraph, p: DVec3, k: usize) -> Vec<usize> {
        let tree = crate::scene::BoxTree::new(&self.eyes, &self.boxes);
        let mut best = crate::scene::KBest::new(k.max(1));
        tree.knn((p - self.center).as_vec3(), u32::MAX, &mut best, &|i| i);
        let mut out: Vec<(f64, usize)> = best
            .items()
            .iter()
            .map(|&(_, i)| {
                let node = self.eyes[i as usize].node;
                ((graph.nodes[node].view.eye - p).length_squared(), node)
            })
            .collect();
        out.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        out.into_iter().map(|(_, n)| n).collect()
    }
}

/// Candidates for the radial menu (thesis 9.7.2; see the module documentation): the views
/// nearest the eye whose direction is within `max_angle` of the current one and that are in line
/// of sight (`line_of_sight(from, to)`, a ray cast on the scene by the caller), searched by
/// increasing distance until `nearest` pass or the graph is exhausted, except `exclude` (the
/// view being displayed); of those within `max_ndc_distance`, the `slots` most similar to the
/// current view (close metric first, then far), returned nearest first.
pub fn radial_candidates(
    graph: &InfoGraph,
    index: &ViewIndex,
    ctx: &ViewContext<'_>,
    settings: &RadialSettings,
    exclude: Option<usize>,
    line_of_sight: &mut dyn FnMut(DVec3, DVec3) -> bool,
) -> Vec<usize> {
    let cam = &ctx.camera;
    let total = graph.nodes.len();
    if total == 0 || settings.nearest == 0 || settings.slots == 0 {
        return Vec::new();
    }
    let cos_max = settings.max_angle.cos();
    // Search on by increasing distance until N views pass the angle and visibility tests.
    let mut passed = Vec::with_capacity(settings.nearest);
    let mut tested = vec![false; total];
    let mut k = settings.nearest.min(total);
    'search: loop {
        for i in index.nearest(graph, cam.eye, k) {
            if std::mem::replace(&mut tested[i], true) || Some(i) == exclude {
                continue;
            }
            let v = &graph.nodes[i].view;
            if v.forward().dot(cam.forward()) < cos_max || !line_of_sight(cam.eye, v.eye) {
                continue;
            }
            passed.push(i);
            if passed.len() == settings.nearest {
                break 'search;
            }
        }
        if k >= total {
            break;
        }
        k = k.saturating_mul(2).min(total);
    }
    // The mean NDC distance filter, then the ranking by similarity.
    let frame = StepFrame::new(ctx);
    let mut ranked: Vec<(bool, f64, usize, usize)> = Vec::with_capacity(passed.len());
    for (order, &i) in passed.iter().enumerate() {
        let node = &graph.nodes[i];
        let own = Projector::new(&node.view);
        if frame.mean_ndc_distance(&own).is_none_or(|d| d > settings.max_ndc_distance) {
            continue;
        }
        let close = frame.close(&own, node, settings.min_roi_samples).filter(|&s| s > 0.0);
        let (visible, sigma) = match close {
            Some(s) => (true, s),
            None => (false, frame.far(&node.view)),
        };
        ranked.push((visible, sigma, order, i));
    }
    ranked.sort_by(|a, b| b.0.cmp(&a.0).then(b.1.total_cmp(&a.1)).then(a.2.cmp(&b.2)));
    ranked.truncate(settings.slots);
    ranked.sort_by_key(|r| r.2);
    ranked.into_iter().map(|r| r.3).collect()
}

/// The radial slot chosen by a finger direction (radians, 0 = up, clockwise) among `count`
/// slots laid out with the nearest at the top and the rest clockwise.
pub fn slot_for_angle(angle: f64, count: usize) -> Option<usize> {
    if count == 0 || !angle.is_finite() {
        return None;
    }
    let step = std::f64::consts::TAU / count as f64;
    Some(((angle.rem_euclid(std::f64::consts::TAU) / step).round() as usize) % count)
}
