//! Stages 3 and 4, the regions: [`Ctx::region`] takes one region's samples (in memory, or read
//! back from its cells), merges duplicates, sorts them once in the order of the hierarchy
//! ([`hierarchy_sort`]), estimates the normals and spacings they lack and cuts the subtree
//! ([`build_subtree`]): leaves first, each inner node simplified from its children
//! ([`parent_of`]). [`Ctx::top`] does so for the regions in the order of the spill stage's
//! [`Plan`] and joins their roots up to the root. Every node goes to the store writer as it is
//! made; the builder gets the root.

use super::simplify::simplify;
use super::spill::{Cell, Plan, RawRec, Record, read_region};
use super::{BuildError, BuildParams, Stage, Timings, lap};
use crate::estimate::{self, Estimate};
use crate::writer::{NodeSink, NodeStats, PendingNode};
use glam::{DVec3, Vec3};
use kiosk_core::scene::boxtree;
use kiosk_core::{Aabb, Splat};
use rayon::prelude::*;

/// A sample being processed, in local coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Work {
    pub(super) pos: Vec3,
    pub(super) normal: Vec3,
    pub(super) radius: f32,
    pub(super) color: [u8; 4],
}

impl boxtree::HasPosition for Work {
    #[inline]
    fn position(&self) -> Vec3 {
        self.pos
    }
}

/// A finished subtree: its root id and the root's samples (for simplification into the parent).
pub(super) struct Sub {
    pub(super) id: u32,
    samples: Vec<Work>,
    spacing: f32,
}

/// The regions of an out-of-core build, read one by one in the plan's order, each into the
/// buffer of the one before ([`Scratch`] says why).
pub(super) struct Regions {
    files: std::vec::IntoIter<Vec<Cell>>,
    buffer: Vec<RawRec>,
}

impl Regions {
    pub(super) fn new(files: Vec<Vec<Cell>>) -> Self {
        Self { files: files.into_iter(), buffer: Vec::new() }
    }

    /// The samples of the next region (its cell files are deleted once read).
    fn next(&mut self) -> std::io::Result<Vec<RawRec>> {
        let files =
            self.files.next().ok_or_else(|| std::io::Error::other("the plan has more regions than cells"))?;
        read_region(&files, std::mem::take(&mut self.buffer))
    }
}

/// What a sample of a region brings besides its position: as read, zero where unknown.
#[derive(Clone, Copy, Debug)]
struct Attrs {
    normal: Vec3,
    color: [u8; 4],
    /// The radius it must cover at least.
    min_radius: f32,
    spacing: f32,
}

/// Whether `h` is a spacing (positive and finite; 0 stands for unknown).
#[inline]
fn known_spacing(h: f32) -> bool {
    h > 0.0 && h.is_finite()
}

/// The buffers of [`Ctx::region`], kept from one region to the next with the read buffer of
/// [`Regions`]: fresh pages for every region (≈ 100 MB each) cost a page fault and a zeroed
/// page per 4 KiB, and a 50 M-point build took 1.12 times as long without them (20 M: 1.08; 5 M:
/// 1.02), at the cost of 65 MB more peak memory at 50 M (docs/performance.md, speed devices).
#[derive(Default)]
pub(super) struct Scratch {
    pts: Vec<(Vec3, Attrs)>,
    keyed: Vec<Keyed>,
    positions: Vec<Vec3>,
    sorted: Vec<Attrs>,
    work: Vec<Work>,
    h2: Vec<f32>,
}

pub(super) struct Ctx<'a> {
    pub(super) params: BuildParams,
    pub(super) scratch: Scratch,
    /// Whether [`Ctx::scratch`] is kept for a next region (else freed as soon as it is used).
    pub(super) keep_scratch: bool,
    pub(super) sink: NodeSink,
    pub(super) done: u64,
    pub(super) total: u64,
    pub(super) progress: &'a mut dyn FnMut(Stage),
    pub(super) timings: Timings,
    pub(super) largest_region: u64,
}

impl Ctx<'_> {
    /// Builds the regions under `plan`, in order, from the samples `regions` delivers in the same
    /// order, and joins them.
    pub(super) fn top(
        &mut self,
        plan: &Plan,
        regions: &mut Regions,
        origin: DVec3,
    ) -> Result<Option<Sub>, BuildError> {
        match plan {
            Plan::Region => {
                let clock = std::time::Instant::now();
                let recs = regions.next()?;
                self.timings.distribute += clock.elapsed();
                if recs.is_empty() {
                    regions.buffer = recs;
                    return Ok(None);
                }
                // The buffer is kept for the next region as soon as this one has taken its samples.
                self.region(recs, origin, |recs| regions.buffer = recs).map(Some)
            }
            Plan::Split(children) => {
                let l = self.top(&children[0], regions, origin)?;
                let r = self.top(&children[1], regions, origin)?;
                match (l, r) {
                    (Some(a), Some(b)) => self.join(a, b).map(Some),
                    (a, b) => Ok(a.or(b)),
                }
            }
        }
    }

    /// Processes one in-memory region into a subtree; `recs` is handed to `done` as soon as the
    /// region has taken its samples from it.
    pub(super) fn region<R: Record>(
        &mut self,
        recs: Vec<R>,
        origin: DVec3,
        done: impl FnOnce(Vec<R>),
    ) -> Result<Sub, BuildError> {
        let mut clock = std::time::Instant::now();
        let n_in = recs.len() as u64;
        self.largest_region = self.largest_region.max(n_in);
        let mut s = std::mem::take(&mut self.scratch);
        let pts = &mut s.pts;
        recs.par_iter()
            .map(|r| {
                let (normal, color, min_radius, spacing) = r.attributes();
                ((r.position() - origin).as_vec3(), Attrs { normal, color, min_radius, spacing })
            })
            .collect_into_vec(pts);
        done(recs);
        // Merge duplicates (identical stored positions): average their normals and colours, keep
        // the largest radius and the area they cover together. A group of duplicates becomes its
        // first sample; the others are dropped. Samples keep their input order.
        let mut groups = Vec::new();
        duplicate_groups(pts.len(), |i| pts[i].0, position_hash, |run| groups.push(run.to_vec()));
        let mut dropped = vec![false; pts.len()];
        for run in &groups {
            let of = |k: usize| pts[k].1;
            let normal = run.iter().fold(Vec3::ZERO, |a, &k| a + of(k).normal).normalize_or_zero();
            let mut c = [0u32; 4];
            for &k in run {
                for (acc, v) in c.iter_mut().zip(of(k).color) {
                    *acc += u32::from(v);
                }
            }
            let n = run.len() as u32;
            let min_radius = run.iter().fold(0.0f32, |a, &k| a.max(of(k).min_radius));
            let spacing = run.iter().map(|&k| of(k).spacing.powi(2)).sum::<f32>().sqrt();
            pts[run[0]].1 = Attrs { normal, color: c.map(|x| (x / n) as u8), min_radius, spacing };
            for &k in &run[1..] {
                dropped[k] = true;
            }
        }
        if dropped.contains(&true) {
            let mut k = 0;
            pts.retain(|_| {
                k += 1;
                !dropped[k - 1]
            });
        }
        let merged = &*pts;
        self.timings.merge += lap(&mut clock);
        if merged.len() < 2 {
            return Err(BuildError::Degenerate(format!(
                "all {n_in} samples are at the same position: a model needs at least 2 distinct points"
            )));
        }
        // One spatial order serves everything below: the splits of the node kd-tree at the top,
        // the implicit box hierarchy of each node under it. Estimation searches the whole region
        // in this order, and the subtree is cut from it without moving a sample again.
        let keyed = &mut s.keyed;
        merged.par_iter().enumerate().map(|(i, p)| Keyed { pos: p.0, idx: i as u32 }).collect_into_vec(keyed);
        hierarchy_sort(keyed, self.params.node_points);
        // A sample's splat from what the input brought (`a`) and, where it brought no normal or
        // spacing, their estimates (`e`).
        let lacks_normal = |a: &Attrs| a.normal == Vec3::ZERO;
        let lacks_spacing = |a: &Attrs| !known_spacing(a.spacing);
        let (radius_factor, cloud_radius_factor) =
            (self.params.radius_factor, self.params.cloud_radius_factor);
        let splat = |pos: Vec3, a: &Attrs, e: Estimate| {
            let normal = if lacks_normal(a) { e.normal } else { a.normal };
            let (spacing, factor) =
                if lacks_spacing(a) { (e.spacing, cloud_radius_factor) } else { (a.spacing, radius_factor) };
            // A lone point far from the rest still gets a finite, positive radius.
            let h = if known_spacing(spacing) { spacing } else { f32::MIN_POSITIVE };
            let radius = (factor * h).max(a.min_radius);
            (Work { pos, normal, radius, color: a.color }, h * h)
        };
        if !merged.par_iter().any(|(_, a)| lacks_normal(a) || lacks_spacing(a)) {
            // Nothing to estimate (a mesh brings normals and spacings from its faces): the
            // samples go straight into their order.
            let none = Estimate { normal: Vec3::ZERO, spacing: 0.0 };
            keyed
                .par_iter()
                .map(|k| splat(k.pos, &merged[k.idx as usize].1, none))
                .unzip_into_vecs(&mut s.work, &mut s.h2);
            self.timings.order += lap(&mut clock);
        } else {
            let positions = &mut s.positions;
            keyed.par_iter().map(|k| k.pos).collect_into_vec(positions);
            // The rest of each sample follows its position (one gather).
            let sorted = &mut s.sorted;
            keyed.par_iter().map(|k| merged[k.idx as usize].1).collect_into_vec(sorted);
            self.timings.order += lap(&mut clock);
            // Estimation searches the whole region in its spatial order.
            let need_normal = |k: usize| lacks_normal(&sorted[k]);
            let need_spacing = |k: usize| lacks_spacing(&sorted[k]);
            let boxes = boxtree::build_boxes(positions);
            let strides = estimate::Strides {
                normal: self.params.normal_stride,
                spacing: self.params.spacing_stride,
                spread_cos: self.params.normal_spread_deg.to_radians().cos(),
            };
            let est =
                estimate::estimate(positions, &boxes, self.params.knn, strides, &need_normal, &need_spacing)
                    .ok_or_else(|| BuildError::Degenerate("fewer than 2 distinct points".into()))?;
            self.timings.estimate += lap(&mut clock);
            positions
                .par_iter()
                .zip(&*sorted)
                .zip(&est)
                .map(|((&pos, a), &e)| splat(pos, a, e))
                .unzip_into_vecs(&mut s.work, &mut s.h2);
        }
        if !self.keep_scratch {
            // Only the samples in their order are left to use.
            (s.pts, s.keyed, s.positions, s.sorted) = Default::default();
        }
        let r = self.split(&mut s.work, &mut s.h2);
        self.timings.nodes += lap(&mut clock);
        self.scratch = s;
        r
    }

    /// Builds the subtree of one region (both halves of every split in parallel), sending each
    /// node to the writer as it is made: ids in post order, known from the sample counts, so
    /// that stores are identical whatever the scheduling.
    fn split(&mut self, work: &mut [Work], h2: &mut [f32]) -> Result<Sub, BuildError> {
        let base = self.sink.reserve(subtree_nodes(work.len(), self.params.node_points));
        let sender = self.sink.sender()?;
        let built = build_subtree(work, h2, &self.params, base, &|id, node| sender.send(id, node.into()));
        drop(sender);
        // A write that failed stops the build here rather than at the next node.
        self.sink.check()?;
        self.done += work.len() as u64;
        (self.progress)(Stage::Build(self.done, self.total));
        Ok(Sub { id: built.id, samples: built.samples, spacing: built.spacing })
    }

    /// Makes the parent of two subtrees by simplifying the union of their samples.
    fn join(&mut self, a: Sub, b: Sub) -> Result<Sub, BuildError> {
        let mut parent = parent_of(a.samples, a.spacing, b.samples, b.spacing, &self.params);
        parent.children = Some([a.id, b.id]);
        let (samples, spacing) = (std::mem::take(&mut parent.stored), parent.spacing);
        let id = self.sink.send(parent.into())?;
        Ok(Sub { id, samples, spacing })
    }
}

/// A node ready to be written.
struct NodeOut {
    splats: Vec<Splat>,
    boxes: Vec<Aabb>,
    /// Children as indices into the subtree's node list.
    children: Option<[u32; 2]>,
    spacing: f32,
    /// Checksum of `splats` and `boxes`.
    data_crc: u32,
    /// The samples as stored (quantised normals): what the parent is built from (balsa12 §4);
    /// taken by the parent's builder.
    stored: Vec<Work>,
}

impl From<NodeOut> for PendingNode {
    fn from(n: NodeOut) -> Self {
        Self {
            splats: n.splats,
            boxes: n.boxes,
            children: n.children,
            stats: NodeStats { spacing: n.spacing, data_crc: n.data_crc },
        }
    }
}

/// A subtree built: its root's id and samples.
struct SubtreeOut {
    id: u32,
    samples: Vec<Work>,
    spacing: f32,
}

/// The nodes [`build_subtree`] makes of `n` samples.
fn subtree_nodes(n: usize, node_points: usize) -> u32 {
    if n <= node_points {
        1
    } else {
        1 + subtree_nodes(n / 2, node_points) + subtree_nodes(n - n / 2, node_points)
    }
}

fn make_node(mut w: Vec<Work>, children: Option<[u32; 2]>, spacing: f32) -> NodeOut {
    boxtree::sort_spatially(&mut w);
    node_from_sorted(&w, children, spacing)
}

/// A node from samples already in the order of its implicit box hierarchy.
fn node_from_sorted(w: &[Work], children: Option<[u32; 2]>, spacing: f32) -> NodeOut {
    let boxes = boxtree::build_boxes(w);
    let splats: Vec<Splat> = w.iter().map(|s| Splat::new(s.pos, s.normal, s.radius, s.color)).collect();
    let stored = splats
        .iter()
        .map(|s| Work { pos: s.position(), normal: s.normal(), radius: s.radius, color: s.color })
        .collect();
    let data_crc = kiosk_core::scene::store::node_data_crc(&splats, &boxes);
    NodeOut { splats, boxes, children, spacing, data_crc, stored }
}

/// The parent of two nodes: the union of their samples simplified to as many samples as the
/// larger child holds where that takes only short merges, and to at most M in any case.
/// Leaves are halved ranges of M/2 to M samples, so every node of a region is about as full as
/// its leaves; simplifying to M instead would leave parents of underfull leaves nearly as dense
/// as their children (one level for little coarsening) at the cost of a full simplification
/// pass and a larger store. Its spacing keeps the area the children cover:
/// n_p h_p² = n_a h_a² + n_b h_b².
fn parent_of(a: Vec<Work>, ha: f32, b: Vec<Work>, hb: f32, params: &BuildParams) -> NodeOut {
    let area = a.len() as f64 * f64::from(ha).powi(2) + b.len() as f64 * f64::from(hb).powi(2);
    let soft = params.node_points.min(a.len().max(b.len()));
    let mut all = a;
    all.extend(b);
    let simplified = simplify(all, soft, params.node_points, params.merge_normal_cos);
    let spacing = (area / simplified.len() as f64).sqrt() as f32;
    make_node(simplified, None, spacing)
}

/// Cuts the subtree out of samples in [`hierarchy_sort`] order (leaves of at most M samples),
/// building both halves in parallel, and passes each node to `emit` as it is made, with its id:
/// `base` and on in post order (the root last; [`subtree_nodes`] of them).
fn build_subtree(
    work: &mut [Work],
    h2: &mut [f32],
    params: &BuildParams,
    base: u32,
    emit: &(dyn Fn(u32, NodeOut) + Sync),
) -> SubtreeOut {
    if work.len() <= params.node_points {
        let spacing = (h2.iter().map(|&x| f64::from(x)).sum::<f64>() / h2.len() as f64).sqrt() as f32;
        let mut node = node_from_sorted(work, None, spacing);
        let samples = std::mem::take(&mut node.stored);
        emit(base, node);
        return SubtreeOut { id: base, samples, spacing };
    }
    let mid = work.len() / 2;
    let (wl, wr) = work.split_at_mut(mid);
    let (hl, hr) = h2.split_at_mut(mid);
    let right_base = base + subtree_nodes(mid, params.node_points);
    let (l, r) = rayon::join(
        || build_subtree(wl, hl, params, base, emit),
        || build_subtree(wr, hr, params, right_base, emit),
    );
    let mut parent = parent_of(l.samples, l.spacing, r.samples, r.spacing, params);
    parent.children = Some([l.id, r.id]);
    let id = r.id + 1;
    let samples = std::mem::take(&mut parent.stored);
    let spacing = parent.spacing;
    emit(id, parent);
    SubtreeOut { id, samples, spacing }
}

/// Calls `group` with the indices (ascending) of every set of at least two of the `n` samples at
/// bit-identical positions (sample `i` at `position(i)`). One integer per sample finds them:
/// `hash` of the position above the sample's index, sorted, so that equal positions are
/// contiguous and in input order; a run of equal hashes is then split by position (distinct
/// positions may share a hash).
fn duplicate_groups(
    n: usize,
    position: impl Fn(usize) -> Vec3 + Sync,
    hash: impl Fn(Vec3) -> u64 + Sync,
    mut group: impl FnMut(&[usize]),
) {
    let idx_bits = usize::BITS - (n.max(2) - 1).leading_zeros();
    let mut keys: Vec<u64> =
        (0..n).into_par_iter().map(|i| hash(position(i)) << idx_bits | i as u64).collect();
    keys.par_sort_unstable();
    let index = |k: u64| (k & ((1 << idx_bits) - 1)) as usize;
    let bits = |k: usize| position(k).to_array().map(f32::to_bits);
    let mut i = 0;
    while i < keys.len() {
        let mut j = i + 1;
        while j < keys.len() && keys[j] >> idx_bits == keys[i] >> idx_bits {
            j += 1;
        }
        if j - i > 1 {
            let mut rest: Vec<usize> = keys[i..j].iter().map(|&k| index(k)).collect();
            while let Some(&first) = rest.first() {
                let run: Vec<usize>;
                (run, rest) = rest.iter().partition(|&&k| bits(k) == bits(first));
                if run.len() > 1 {
                    group(&run);
                }
            }
        }
        i = j;
    }
}

/// A hash of a position's bits (equal positions, equal hashes), well mixed in every bit.
#[inline]
fn position_hash(p: Vec3) -> u64 {
    let [x, y, z] = p.to_array().map(|c| u64::from(c.to_bits()));
    // MurmurHash3's 64-bit finaliser over the three coordinates.
    let mut h = (x << 32 | y) ^ z.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^ h >> 33
}

/// A position and where it came from, for sorting a region once.
#[derive(Clone, Copy)]
struct Keyed {
    pos: Vec3,
    idx: u32,
}

impl boxtree::HasPosition for Keyed {
    #[inline]
    fn position(&self) -> Vec3 {
        self.pos
    }
}

/// Orders `items` as the hierarchy is cut: ranges of more than `node_points` items are split at
/// their middle index by a median partition along [`choose_axis`] (the node kd-tree); a range
/// of at most `node_points` (a leaf node) is sorted for its implicit box hierarchy.
fn hierarchy_sort<T: boxtree::HasPosition + Send>(items: &mut [T], node_points: usize) {
    if items.len() <= node_points {
        boxtree::sort_spatially(items);
        return;
    }
    let axis = choose_axis(items);
    let mid = items.len() / 2;
    boxtree::partition_along(items, mid, axis);
    let (l, r) = items.split_at_mut(mid);
    rayon::join(|| hierarchy_sort(l, node_points), || hierarchy_sort(r, node_points));
}

/// Split axis (balsa12 §4): candidates are median splits (perfectly balanced) along every axis
/// whose extent is at least half the longest; among them, the one whose children are the most
/// compact (smallest worst ratio between the two largest extents of a child's box). Candidates
/// are judged on an evenly strided sample of at most [`AXIS_SAMPLE`] points: its box, its median
/// and its halves' boxes stand for the range's (the split itself is exact).
fn choose_axis<T: boxtree::HasPosition>(work: &[T]) -> usize {
    let step = work.len().div_ceil(AXIS_SAMPLE).max(1);
    let sample: Vec<Vec3> = work.iter().step_by(step).map(boxtree::HasPosition::position).collect();
    let ext = Aabb::from_points(sample.iter().copied()).extent();
    let longest = ext.max_element();
    let mut best = (f32::INFINITY, ext.max_position());
    for axis in 0..3 {
        if ext[axis] < 0.5 * longest || ext[axis] <= 0.0 {
            continue;
        }
        let mut vals: Vec<f32> = sample.iter().map(|p| p[axis]).collect();
        let mid = vals.len() / 2;
        let (_, &mut at, _) = vals.select_nth_unstable_by(mid, f32::total_cmp);
        let mut worst: f32 = 0.0;
        for side in [false, true] {
            let b = Aabb::from_points(sample.iter().copied().filter(|p| (p[axis] >= at) == side));
            let mut e = b.extent().to_array();
            e.sort_by(f32::total_cmp);
            let ratio = if e[1] > 0.0 { e[2] / e[1] } else { f32::INFINITY };
            worst = worst.max(ratio);
        }
        if worst < best.0 {
            best = (worst, axis);
        }
    }
    best.1
}

/// Most points [`choose_axis`] judges candidate splits on.
const AXIS_SAMPLE: usize = 16_384;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duplicates_are_grouped_in_input_order_even_when_distinct_positions_share_a_hash() {
        let p = |x: f32| Vec3::new(x, 1.0, -2.0);
        let positions = [p(1.0), p(2.0), p(1.0), p(3.0), p(2.0), p(1.0), p(-0.0), p(0.0)];
        for hash in [position_hash as fn(Vec3) -> u64, |_| 7, |v: Vec3| u64::from(v.x.to_bits() % 2)] {
            let mut groups = Vec::new();
            duplicate_groups(positions.len(), |i| positions[i], hash, |g| groups.push(g.to_vec()));
            groups.sort();
            assert_eq!(groups, vec![vec![0, 2, 5], vec![1, 4]]);
        }
        let mut none = Vec::new();
        duplicate_groups(1, |_| p(1.0), position_hash, |g| none.push(g.to_vec()));
        assert!(none.is_empty());
    }

    #[test]
    fn hierarchy_order_cuts_nodes_at_middles_and_sorts_each_leaf_node() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let mut pts: Vec<Vec3> = (0..5000)
            .map(|_| Vec3::new(rng.random(), rng.random::<f32>() * 4.0, rng.random::<f32>() * 0.2))
            .collect();
        let before = pts.clone();
        hierarchy_sort(&mut pts, 1000);
        // A permutation: nothing lost, nothing invented.
        let key = |v: &Vec3| v.to_array().map(f32::to_bits);
        let (mut a, mut b) =
            (before.iter().map(key).collect::<Vec<_>>(), pts.iter().map(key).collect::<Vec<_>>());
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b);
        // Every cut, of the node kd-tree and of each leaf node's box hierarchy (down to its
        // leaves of < 16 points), is a median split: its halves are separated along one axis.
        fn separated(l: &[Vec3], r: &[Vec3]) -> bool {
            (0..3).any(|axis| {
                let lmax = l.iter().map(|v| v[axis]).fold(f32::NEG_INFINITY, f32::max);
                let rmin = r.iter().map(|v| v[axis]).fold(f32::INFINITY, f32::min);
                lmax <= rmin
            })
        }
        fn boxes(p: &[Vec3], depth_left: u32) {
            if depth_left > 0 {
                let (l, r) = p.split_at(p.len() / 2);
                assert!(separated(l, r), "a box split of {} points does not separate its halves", p.len());
                boxes(l, depth_left - 1);
                boxes(r, depth_left - 1);
            }
        }
        fn check(p: &[Vec3], m: usize) {
            if p.len() <= m {
                boxes(p, boxtree::depth_for(p.len()));
                return;
            }
            let (l, r) = p.split_at(p.len() / 2);
            assert!(separated(l, r), "a node cut of {} points does not separate its halves", p.len());
            check(l, m);
            check(r, m);
        }
        check(&pts, 1000);
    }
}
