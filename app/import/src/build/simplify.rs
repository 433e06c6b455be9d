//! Simplification, the step that makes every inner node (stages 3 and 4): [`simplify`] reduces
//! the union of two children's samples to the parent's target by passes ([`simplify_pass`]) that
//! collapse near pairs with compatible normals, shortest first, matched within the leaves of the
//! samples' implicit box hierarchy ([`leaf_pairs`]). It hands back the parent's samples, still in
//! a spatial order, for the region stage to make the node of.

use super::region::Work;
use glam::Vec3;
use kiosk_core::scene::boxtree;
use rayon::prelude::*;

/// A merge is short when its length is at most this many times the larger splat radius of
/// the pair (neighbours on a surface are about 1.25 radii apart, a merged pair stays within 2).
const MERGE_REACH: f32 = 3.0;

/// Which pairs a simplification pass may collapse.
#[derive(Clone, Copy, Debug)]
struct MergeRule {
    /// Cosine of the largest angle between the normals (`None`: any normals).
    normal_cos: Option<f32>,
    /// Longest merge, in multiples of the larger radius of the pair (`None`: any length).
    reach: Option<f32>,
}

/// Reduces `pts` to `soft` samples by collapsing short near pairs with compatible normals
/// (bettio09 §3: shortest edges first; balsa12 §4: nearest neighbour with a compatible normal),
/// then, if short pairs ran out above `hard`, to `hard` by any pairs with compatible normals,
/// and at last by any pairs. The soft target halves a node's samples only where that keeps the
/// surface: an isolated sample (the tip of an ear) is not merged with one far away, which would
/// make a splat as large as the gap.
/// Each pass takes the samples in spatial order; within each leaf of the implicit box hierarchy
/// (fewer than 16 spatially close samples) it matches pairs greedily, shortest first; of the
/// candidate pairs of all leaves, the shortest are collapsed until the target remains. A pass
/// nearly halves the samples, so 2M → M takes one or two passes.
/// Merged sample: midpoint; normal and colour weighted by splat area; radius covering both.
///
/// The input is the concatenation of two nodes, each in the order of its implicit hierarchy (the
/// two halves of a kd split): already a spatial order. A pass keeps it: a merged pair takes the
/// place of its first sample, so later passes need no sort (the caller sorts the result for its
/// box hierarchy).
pub(super) fn simplify(mut pts: Vec<Work>, soft: usize, hard: usize, normal_cos: f32) -> Vec<Work> {
    let rules = [
        (soft, MergeRule { normal_cos: Some(normal_cos), reach: Some(MERGE_REACH) }),
        (hard, MergeRule { normal_cos: Some(normal_cos), reach: None }),
        (hard, MergeRule { normal_cos: None, reach: None }),
    ];
    for (target, rule) in rules {
        while pts.len() > target {
            match simplify_pass(&pts, target, rule) {
                Some(next) => pts = next,
                None => break,
            }
        }
    }
    pts
}

/// One pass of [`simplify`] towards `target` under `rule`; `None` when no pair qualifies.
fn simplify_pass(pts: &[Work], target: usize, rule: MergeRule) -> Option<Vec<Work>> {
    // (squared length bits << 32 | i, j), in the order of the ranges.
    let pairs_in = |ranges: Vec<(usize, usize)>| -> Vec<(u64, u32)> {
        ranges
            .par_iter()
            .flat_map_iter(|&(lo, hi)| {
                leaf_pairs(&pts[lo..hi], rule, |key| {
                    let (i, j) = pair_ends(key);
                    ((key & !0xffff_ffff) | (lo + i) as u64, (lo + j) as u32)
                })
            })
            .collect()
    };
    let needed = pts.len() - target;
    let depth = boxtree::depth_for(pts.len());
    // A pass that needs few merges (the last few of a halving) matches within the leaves'
    // halves or quarters: a quarter of the pairs to weigh per sample, or less, and still more
    // candidates than it takes. Where those hold too few, it matches within the leaves.
    let finer = (1..=2).take_while(|&d| needed << (d + 1) <= pts.len()).last().unwrap_or(0);
    let mut edges =
        if finer > 0 { pairs_in(boxtree::ranges_at_depth(pts.len(), depth + finer)) } else { Vec::new() };
    if edges.len() < needed {
        edges = pairs_in(boxtree::leaf_ranges(pts.len()));
    }
    if edges.is_empty() {
        return None;
    }
    if edges.len() > needed {
        // The `needed` shortest (keys are distinct: each sample is in one pair at most).
        let mut keys: Vec<u64> = edges.iter().map(|e| e.0).collect();
        let nth = *keys.select_nth_unstable(needed - 1).1;
        edges.retain(|e| e.0 <= nth);
    }
    // partner[i] = j for the first sample of a pair, i for the second (it is dropped).
    let mut partner = vec![u32::MAX; pts.len()];
    for &(key, j) in &edges {
        let i = key as u32;
        partner[i as usize] = j;
        partner[j as usize] = i;
    }
    // Each pair leaves one sample: the size is known, the vector never grows.
    let mut next = Vec::with_capacity(pts.len() - edges.len());
    next.extend(pts.iter().zip(&partner).enumerate().filter_map(|(i, (p, &j))| match j {
        u32::MAX => Some(*p),
        j if j as usize > i => Some(merge(p, &pts[j as usize])),
        _ => None,
    }));
    Some(next)
}

/// The pairs of one leaf (fewer than [`boxtree::LEAF_POINTS`] samples) that greedy matching takes,
/// shortest first, among the pairs `rule` allows, as `pair((squared length bits) << 32 | i << 8 | j)`
/// with i < j.
///
/// Keys are distinct, so greedy matching takes exactly the pairs that are, at some point, the
/// shortest pair of both their samples among the samples still free ("mutual nearest"); rounds
/// of that need no sort of the candidate pairs.
fn leaf_pairs<T>(leaf: &[Work], rule: MergeRule, mut pair: impl FnMut(u64) -> T) -> Vec<T> {
    const N: usize = boxtree::LEAF_POINTS;
    let m = leaf.len().min(N);
    let mut key = [[u64::MAX; N]; N];
    // best[i]: the shortest candidate pair of sample i among the samples still free.
    let mut best = [u64::MAX; N];
    for i in 0..m {
        for j in i + 1..m {
            let d2 = (leaf[i].pos - leaf[j].pos).length_squared();
            let short = rule.reach.is_none_or(|f| d2 <= (f * leaf[i].radius.max(leaf[j].radius)).powi(2));
            if short && rule.normal_cos.is_none_or(|c| compatible(leaf[i].normal, leaf[j].normal, c)) {
                let k = u64::from(d2.to_bits()) << 32 | (i as u64) << 8 | j as u64;
                key[i][j] = k;
                key[j][i] = k;
                best[i] = best[i].min(k);
                best[j] = best[j].min(k);
            }
        }
    }
    let mut out = Vec::with_capacity(m / 2);
    // The samples still free that have a candidate left: `free[..nf]`.
    let mut free: [usize; N] = std::array::from_fn(|i| i);
    let mut nf = m;
    loop {
        let mut taken = [false; N];
        let mut any = false;
        for &i in &free[..nf] {
            let k = best[i];
            let (a, b) = pair_ends(k);
            if k != u64::MAX && a == i && best[b] == k {
                taken[a] = true;
                taken[b] = true;
                any = true;
                out.push(pair(k));
            }
        }
        if !any {
            break;
        }
        // A sample with no candidate left stays unmatched.
        let before = nf;
        nf = 0;
        for f in 0..before {
            let i = free[f];
            if !taken[i] && best[i] != u64::MAX {
                free[nf] = i;
                nf += 1;
            }
        }
        if nf < 2 {
            break;
        }
        // Only a sample whose shortest pair lost its other sample has a new shortest pair: the
        // others' is still among the free ones, and nothing shorter came.
        for f in 0..nf {
            let i = free[f];
            let (a, b) = pair_ends(best[i]);
            if taken[if a == i { b } else { a }] {
                best[i] = free[..nf].iter().fold(u64::MAX, |b, &j| b.min(key[i][j]));
            }
        }
    }
    out
}

/// The two samples (i < j) of a [`leaf_pairs`] key.
#[inline]
fn pair_ends(key: u64) -> (usize, usize) {
    ((key >> 8) as u8 as usize, key as u8 as usize)
}

fn merge(a: &Work, b: &Work) -> Work {
    let (wa, wb) = (a.radius * a.radius, b.radius * b.radius);
    // Normals are oriented only away from their region's centroid: b's is turned to a's side.
    let bn = if a.normal.dot(b.normal) < 0.0 { -b.normal } else { b.normal };
    let normal = (a.normal * wa + bn * wb).try_normalize().unwrap_or(a.normal);
    // Equal colours blend to themselves (the weighted mean of c and c rounds back to c): a scan
    // without colours, or a region of one colour, skips the arithmetic.
    let color = if a.color == b.color { a.color } else { blend(a.color, wa, b.color, wb) };
    Work {
        pos: (a.pos + b.pos) * 0.5,
        normal,
        radius: (a.pos - b.pos).length() * 0.5 + a.radius.max(b.radius),
        color,
    }
}

/// Whether two normals are within the angle of cosine `cos` of each other, whichever way each
/// points: estimated normals are oriented only away from their region's centroid, so a normal
/// and its opposite describe the same surface.
fn compatible(a: Vec3, b: Vec3, cos: f32) -> bool {
    a.dot(b).abs() >= cos
}

/// The mean of colours `a` and `b` weighted by `wa` and `wb`, rounded to the nearest level.
fn blend(a: [u8; 4], wa: f32, b: [u8; 4], wb: f32) -> [u8; 4] {
    let ws = (wa + wb).max(f32::MIN_POSITIVE);
    std::array::from_fn(|k| {
        ((f32::from(a[k]) * wa + f32::from(b[k]) * wb) / ws).round().clamp(0.0, 255.0) as u8
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn leaf_pairs_are_the_greedy_matching_shortest_first() {
        // The plain greedy matching: every allowed pair sorted by key, each taken when both of
        // its samples are still free.
        fn greedy(leaf: &[Work], rule: MergeRule) -> Vec<u64> {
            let mut keys = Vec::new();
            for i in 0..leaf.len() {
                for j in i + 1..leaf.len() {
                    let d2 = (leaf[i].pos - leaf[j].pos).length_squared();
                    let r = leaf[i].radius.max(leaf[j].radius);
                    if rule.reach.is_none_or(|f| d2 <= (f * r).powi(2))
                        && rule.normal_cos.is_none_or(|c| leaf[i].normal.dot(leaf[j].normal).abs() >= c)
                    {
                        keys.push(u64::from(d2.to_bits()) << 32 | (i as u64) << 8 | j as u64);
                    }
                }
            }
            keys.sort_unstable();
            let mut used = [false; boxtree::LEAF_POINTS];
            let mut out = Vec::new();
            for k in keys {
                let (i, j) = pair_ends(k);
                if !used[i] && !used[j] {
                    used[i] = true;
                    used[j] = true;
                    out.push(k);
                }
            }
            out.sort_unstable();
            out
        }
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let rules = [
            MergeRule { normal_cos: Some(0.5), reach: Some(MERGE_REACH) },
            MergeRule { normal_cos: Some(0.5), reach: None },
            MergeRule { normal_cos: None, reach: None },
        ];
        let mut pairs = 0;
        for round in 0..3000 {
            let n = 2 + round % (boxtree::LEAF_POINTS - 1);
            // Coarse coordinates: some lengths tie, and ties are broken by the indices.
            let leaf: Vec<Work> = (0..n)
                .map(|_| Work {
                    pos: Vec3::new(
                        rng.random_range(0..8) as f32,
                        rng.random_range(0..8) as f32,
                        rng.random_range(0..3) as f32,
                    ),
                    normal: Vec3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        if rng.random() { 1.0 } else { -1.0 },
                    )
                    .normalize(),
                    radius: rng.random_range(0.2..2.0),
                    color: [0; 4],
                })
                .collect();
            for rule in rules {
                let mut got = leaf_pairs(&leaf, rule, |k| k);
                got.sort_unstable();
                assert_eq!(got, greedy(&leaf, rule), "round {round}, {rule:?}");
                pairs += got.len();
            }
        }
        assert!(pairs > 10_000, "the leaves had pairs to take: {pairs}");
    }

    #[test]
    fn a_merged_colour_is_the_area_weighted_mean_and_equal_colours_stay_as_they_are() {
        let at = |x: f32, radius: f32, color: [u8; 4]| Work {
            pos: Vec3::new(x, 0.0, 0.0),
            normal: Vec3::Z,
            radius,
            color,
        };
        // Radii 1 and 3: weights 1 and 9.
        let m = merge(&at(0.0, 1.0, [0, 100, 255, 10]), &at(1.0, 3.0, [100, 0, 255, 20]));
        assert_eq!(m.color, [90, 10, 255, 19]);
        // Equal colours stay as they are, as the weighted mean would leave them, whatever the
        // weights.
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        for _ in 0..10_000 {
            let c: [u8; 4] = std::array::from_fn(|_| rng.random());
            let (ra, rb) = (rng.random_range(1e-6..1e3), rng.random_range(1e-6..1e3));
            let m = merge(&at(0.0, ra, c), &at(1.0, rb, c));
            assert_eq!(m.color, c);
            assert_eq!(
                blend(c, ra * ra, c, rb * rb),
                c,
                "the weighted mean of {c:?} with radii {ra} and {rb}"
            );
        }
        // And with no weights at all (two splats of radius 0).
        assert_eq!(merge(&at(0.0, 0.0, [7; 4]), &at(0.0, 0.0, [7; 4])).color, [7; 4]);
    }

    #[test]
    fn normals_of_opposite_orientation_are_compatible_and_merge_into_one_plane() {
        // Two neighbours on the plane z = 0, their normals oriented either way (away from two
        // region centroids on either side).
        let a = Work { pos: Vec3::ZERO, normal: Vec3::Z, radius: 0.8, color: [0; 4] };
        let b =
            Work { pos: Vec3::X, normal: -Vec3::new(0.1, 0.0, 1.0).normalize(), radius: 0.8, color: [0; 4] };
        let rule = MergeRule { normal_cos: Some(0.5), reach: Some(MERGE_REACH) };
        assert_eq!(leaf_pairs(&[a, b], rule, |k| k).len(), 1, "the pair is compatible");
        // A normal at 80° is not, whichever way it points.
        let c = Work { normal: Vec3::new(1.0, 0.0, 0.18).normalize(), ..b };
        assert!(leaf_pairs(&[a, c], rule, |k| k).is_empty());
        assert!(leaf_pairs(&[a, Work { normal: -c.normal, ..c }], rule, |k| k).is_empty());
        // The merge keeps the plane (not the cancelled sum of opposite normals).
        let m = merge(&a, &b);
        assert!(m.normal.dot(Vec3::Z) > 0.99, "{:?}", m.normal);
        // Simplification merges them.
        assert_eq!(simplify(vec![a, b], 1, 2, 0.5).len(), 1);
    }

    #[test]
    fn simplification_halves_by_short_merges_and_reaches_m_by_any() {
        // A 4 × 4 grid (spacing 1, radius 0.8) and two samples far from it and from each other.
        let sample =
            |x: f32, y: f32| Work { pos: Vec3::new(x, y, 0.0), normal: Vec3::Z, radius: 0.8, color: [9; 4] };
        let mut pts: Vec<Work> = (0..16).map(|i| sample((i % 4) as f32, (i / 4) as f32)).collect();
        pts.extend([sample(100.0, 0.0), sample(200.0, 0.0)]);
        boxtree::sort_spatially(&mut pts);
        let lone = |s: &[Work]| s.iter().filter(|w| w.pos.x >= 100.0 && w.radius == 0.8).count();
        // Soft target 2, M = 18: the grid collapses by short merges into one sample; going
        // further would take a long merge, so the far samples stay as they are and no splat
        // grows past the grid.
        let soft = simplify(pts.clone(), 2, 18, 0.5);
        assert_eq!(lone(&soft), 2);
        assert_eq!(soft.len(), 3);
        assert!(
            soft.iter().all(|w| w.radius < 5.0),
            "{:?}",
            soft.iter().map(|w| w.radius).collect::<Vec<_>>()
        );
        // M = 2: reached, by merging far samples.
        let hard = simplify(pts, 2, 2, 0.5);
        assert_eq!(hard.len(), 2);
        assert!(hard.iter().any(|w| w.radius > 40.0));
    }

    #[test]
    fn a_pass_that_needs_few_merges_matches_in_finer_ranges_or_else_in_the_leaves() {
        // 64 samples on a line, spacing 1 (a little more at every fourth, so lengths differ).
        let line = |normal: &dyn Fn(usize) -> Vec3| -> Vec<Work> {
            (0..64)
                .map(|i| Work {
                    pos: Vec3::new(i as f32 + (i / 4) as f32 * 0.01, 0.0, 0.0),
                    normal: normal(i),
                    radius: 0.8,
                    color: [0; 4],
                })
                .collect()
        };
        let rule = MergeRule { normal_cos: Some(0.5), reach: Some(MERGE_REACH) };
        // 4 merges of 64: ranges of 2 or 3 samples hold enough candidates; the merges are of
        // neighbours (a merged splat covers both: half the spacing plus the radius).
        let out = simplify_pass(&line(&|_| Vec3::Z), 60, rule).expect("pairs");
        assert_eq!(out.len(), 60);
        assert!(
            out.iter().all(|w| w.radius <= 0.5 + 0.8 + 0.01),
            "{:?}",
            out.iter().map(|w| w.radius).collect::<Vec<_>>()
        );
        // Neighbours with perpendicular normals (opposite ones are compatible: normals are
        // oriented only away from a centroid): no pair within those ranges; the leaves have
        // pairs two apart (within 3 radii).
        let out =
            simplify_pass(&line(&|i| if i % 2 == 0 { Vec3::Z } else { Vec3::X }), 60, rule).expect("pairs");
        assert_eq!(out.len(), 60);
        assert!(out.iter().all(|w| w.normal == Vec3::Z || w.normal == Vec3::X));
        assert_eq!(out.iter().filter(|w| w.radius > 1.0 + 0.8 - 0.01).count(), 4);
    }
}
