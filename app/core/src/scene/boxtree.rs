//! The per-node search structure of thesis 9.7.1: the points of a node are sorted spatially and an
//! implicit bounding-box hierarchy is built by bisecting the array, down to leaves of fewer than
//! [`LEAF_POINTS`] points. Box `i` has children `2i+1` and `2i+2`; the range of a box is found by
//! halving its parent's range, so only the boxes are stored.
//!
//! A nearest-neighbour search may stop at any depth: a box at the depth limit stands for "the
//! point at the middle of its range", which is how the coarse target of IsoCam is cheap.

use crate::geom::Aabb;
use glam::Vec3;

/// Leaves of the implicit hierarchy hold fewer than this many points.
pub const LEAF_POINTS: usize = 16;

/// Anything with a position.
pub trait HasPosition {
    /// The position in local coordinates.
    fn position(&self) -> Vec3;
}

impl HasPosition for Vec3 {
    #[inline]
    fn position(&self) -> Vec3 {
        *self
    }
}

impl HasPosition for super::Splat {
    #[inline]
    fn position(&self) -> Vec3 {
        Vec3::from_array(self.pos)
    }
}

/// Depth of the leaves of the implicit hierarchy over `n` points (0: the root is the only leaf).
pub fn depth_for(n: usize) -> u32 {
    let mut d = 0;
    while n.div_ceil(1 << d) >= LEAF_POINTS {
        d += 1;
    }
    d
}

/// Number of boxes of the implicit hierarchy over `n` points (0 for no points).
pub fn box_count(n: usize) -> usize {
    if n == 0 { 0 } else { (1usize << (depth_for(n) + 1)) - 1 }
}

#[inline]
fn split(lo: usize, hi: usize) -> usize {
    lo + (hi - lo) / 2
}

/// Sorts `items` spatially, the order the implicit hierarchy expects: each range is split at its
/// middle index by a median partition along the longest axis of its points' bounding box.
pub fn sort_spatially<T: HasPosition>(items: &mut [T]) {
    let depth = depth_for(items.len());
    sort_range(items, depth);
}

fn sort_range<T: HasPosition>(items: &mut [T], depth_left: u32) {
    if depth_left == 0 || items.len() < 2 {
        return;
    }
    let b = Aabb::from_points(items.iter().map(HasPosition::position));
    let mid = split(0, items.len());
    partition_along(items, mid, b.extent().max_position());
    let (left, right) = items.split_at_mut(mid);
    sort_range(left, depth_left - 1);
    sort_range(right, depth_left - 1);
}

/// Reorders `items` so that the item at `mid` is where a sort along `axis` (0, 1 or 2) would put
/// it, with no item before it greater and none after it smaller (a median partition). One
/// comparison per axis, chosen once: indexing the position by a run-time axis in every
/// comparison costs a quarter of the time.
pub fn partition_along<T: HasPosition>(items: &mut [T], mid: usize, axis: usize) {
    match axis {
        0 => items.select_nth_unstable_by(mid, |a, b| a.position().x.total_cmp(&b.position().x)),
        1 => items.select_nth_unstable_by(mid, |a, b| a.position().y.total_cmp(&b.position().y)),
        _ => items.select_nth_unstable_by(mid, |a, b| a.position().z.total_cmp(&b.position().z)),
    };
}

/// The index ranges of the leaves of the implicit hierarchy over `n` points, in order.
pub fn leaf_ranges(n: usize) -> Vec<(usize, usize)> {
    ranges_at_depth(n, depth_for(n))
}

/// The ranges of the boxes `depth` levels below the root of the implicit hierarchy over `n`
/// points (deeper than the leaves: the leaves' ranges halved again), in order.
pub fn ranges_at_depth(n: usize, depth: u32) -> Vec<(usize, usize)> {
    fn rec(lo: usize, hi: usize, depth_left: u32, out: &mut Vec<(usize, usize)>) {
        if depth_left == 0 {
            out.push((lo, hi));
        } else {
            let mid = split(lo, hi);
            rec(lo, mid, depth_left - 1, out);
            rec(mid, hi, depth_left - 1, out);
        }
    }
    let mut out = Vec::new();
    if n > 0 {
        rec(0, n, depth, &mut out);
    }
    out
}

/// One box on the path from the root to a leaf of the implicit hierarchy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathStep {
    /// Heap index of the box.
    pub index: usize,
    /// First point of its range.
    pub lo: usize,
    /// End of its range.
    pub hi: usize,
    /// Levels below it down to the leaves.
    pub depth_left: u32,
}

impl PathStep {
    /// The root box of the implicit hierarchy over `n` points.
    pub fn root(n: usize) -> Self {
        Self { index: 0, lo: 0, hi: n, depth_left: depth_for(n) }
    }

    /// The two halves of an inner box (`depth_left > 0`), left first.
    pub fn children(&self) -> [Self; 2] {
        let mid = split(self.lo, self.hi);
        let d = self.depth_left - 1;
        [
            Self { index: 2 * self.index + 1, lo: self.lo, hi: mid, depth_left: d },
            Self { index: 2 * self.index + 2, lo: mid, hi: self.hi, depth_left: d },
        ]
    }
}

/// The path (root first) to every leaf of the implicit hierarchy over `n` points, in order.
pub fn leaf_paths(n: usize) -> Vec<Vec<PathStep>> {
    fn rec(step: PathStep, path: &mut Vec<PathStep>, out: &mut Vec<Vec<PathStep>>) {
        path.push(step);
        if step.depth_left == 0 {
            out.push(path.clone());
        } else {
            for child in step.children() {
                rec(child, path, out);
            }
        }
        path.pop();
    }
    let mut out = Vec::new();
    if n > 0 {
        rec(PathStep::root(n), &mut Vec::new(), &mut out);
    }
    out
}

/// Builds the boxes of the implicit hierarchy over spatially sorted `items`.
pub fn build_boxes<T: HasPosition>(items: &[T]) -> Vec<Aabb> {
    let mut boxes = vec![Aabb::EMPTY; box_count(items.len())];
    if !items.is_empty() {
        fill(items, &mut boxes, 0, 0, items.len(), depth_for(items.len()));
    }
    boxes
}

fn fill<T: HasPosition>(
    items: &[T],
    boxes: &mut [Aabb],
    i: usize,
    lo: usize,
    hi: usize,
    depth_left: u32,
) -> Aabb {
    let b = if depth_left == 0 {
        Aabb::from_points(items[lo..hi].iter().map(HasPosition::position))
    } else {
        let mid = split(lo, hi);
        let l = fill(items, boxes, 2 * i + 1, lo, mid, depth_left - 1);
        let r = fill(items, boxes, 2 * i + 2, mid, hi, depth_left - 1);
        l.union(r)
    };
    boxes[i] = b;
    b
}

/// The K nearest candidates found so far, sorted by squared distance.
#[derive(Clone, Debug)]
pub struct KBest<P> {
    k: usize,
    items: Vec<(f32, P)>,
}

impl<P: Copy> KBest<P> {
    /// An empty set that keeps at most `k` (≥ 1) candidates.
    pub fn new(k: usize) -> Self {
        Self { k: k.max(1), items: Vec::with_capacity(k.max(1) + 1) }
    }

    /// Squared distance a candidate must beat to enter (∞ until full).
    #[inline]
    pub fn bound(&self) -> f32 {
        if self.items.len() < self.k { f32::INFINITY } else { self.items[self.items.len() - 1].0 }
    }

    /// Offers a candidate.
    #[inline]
    pub fn offer(&mut self, d2: f32, p: P) {
        if d2 >= self.bound() {
            return;
        }
        let at = self.items.partition_point(|(d, _)| *d <= d2);
        self.items.insert(at, (d2, p));
        self.items.truncate(self.k);
    }

    /// Candidates, nearest first: (squared distance, payload).
    pub fn items(&self) -> &[(f32, P)] {
        &self.items
    }

    /// Forgets all candidates.
    pub fn clear(&mut self) {
        self.items.clear();
    }
}

/// A read-only view of one node's points and their implicit box hierarchy.
#[derive(Clone, Copy, Debug)]
pub struct BoxTree<'a, T> {
    /// Spatially sorted points.
    pub items: &'a [T],
    /// Boxes in heap order, as made by [`build_boxes`] (or read from a store).
    pub boxes: &'a [Aabb],
}

impl<'a, T: HasPosition> BoxTree<'a, T> {
    /// Wraps sorted points and their boxes. `boxes.len()` must equal `box_count(items.len())`.
    pub fn new(items: &'a [T], boxes: &'a [Aabb]) -> Self {
        debug_assert_eq!(boxes.len(), box_count(items.len()));
        Self { items, boxes }
    }

    /// Offers to `best` the points nearest to `q`, searching at most `max_depth` levels below the
    /// root; a box at that depth contributes the point at the middle of its range. `tag` turns a
    /// point index into the payload kept in `best`.
    pub fn knn<P: Copy>(&self, q: Vec3, max_depth: u32, best: &mut KBest<P>, tag: &impl Fn(u32) -> P) {
        if self.items.is_empty() {
            return;
        }
        let depth = depth_for(self.items.len());
        let d0 = self.boxes[0].distance_squared(q);
        self.knn_rec(q, 0, d0, 0, self.items.len(), depth, max_depth, best, tag);
    }

    /// Searches box `i` (at squared distance `d2` from `q`: each box's distance is computed once,
    /// by its parent, which needs it to order its children).
    #[expect(clippy::too_many_arguments, reason = "recursion state of a hot loop, kept flat")]
    fn knn_rec<P: Copy>(
        &self,
        q: Vec3,
        i: usize,
        d2: f32,
        lo: usize,
        hi: usize,
        depth_left: u32,
        max_depth: u32,
        best: &mut KBest<P>,
        tag: &impl Fn(u32) -> P,
    ) {
        if d2 >= best.bound() {
            return;
        }
        if depth_left == 0 {
            for (j, it) in self.items[lo..hi].iter().enumerate() {
                best.offer((it.position() - q).length_squared(), tag((lo + j) as u32));
            }
            return;
        }
        let mid = split(lo, hi);
        if max_depth == 0 {
            best.offer((self.items[mid].position() - q).length_squared(), tag(mid as u32));
            return;
        }
        let (l, r) = (2 * i + 1, 2 * i + 2);
        let dl = self.boxes[l].distance_squared(q);
        let dr = self.boxes[r].distance_squared(q);
        if dl <= dr {
            self.knn_rec(q, l, dl, lo, mid, depth_left - 1, max_depth - 1, best, tag);
            self.knn_rec(q, r, dr, mid, hi, depth_left - 1, max_depth - 1, best, tag);
        } else {
            self.knn_rec(q, r, dr, mid, hi, depth_left - 1, max_depth - 1, best, tag);
            self.knn_rec(q, l, dl, lo, mid, depth_left - 1, max_depth - 1, best, tag);
        }
    }

    /// All point indices whose position lies within the box `region` (used for region queries).
    pub fn for_each_in(&self, region: &Aabb, f: &mut impl FnMut(u32)) {
        if self.items.is_empty() {
            return;
        }
        self.in_rec(region, 0, 0, self.items.len(), depth_for(self.items.len()), f);
    }

    fn in_rec(
        &self,
        region: &Aabb,
        i: usize,
        lo: usize,
        hi: usize,
        depth_left: u32,
        f: &mut impl FnMut(u32),
    ) {
        let b = &self.boxes[i];
        if b.max.cmplt(region.min).any() || b.min.cmpgt(region.max).any() {
            return;
        }
        if depth_left == 0 {
            for j in lo..hi {
                let p = self.items[j].position();
                if p.cmpge(region.min).all() && p.cmple(region.max).all() {
                    f(j as u32);
                }
            }
            return;
        }
        let mid = split(lo, hi);
        self.in_rec(region, 2 * i + 1, lo, mid, depth_left - 1, f);
        self.in_rec(region, 2 * i + 2, mid, hi, depth_left - 1, f);
    }
}

impl BoxTree<'_, super::Splat> {
    /// First intersection of the ray `o + t d` (t in `[t_min, t_max]`, `d` unit) with the splats
    /// seen as balls of their radius, front to back. Balls that contain `o` are ignored: the ray
    /// starts outside the surface. `inflate` must be at least the largest radius of the node.
    /// Returns `(t, index)`.
    pub fn ray_cast(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32, inflate: f32) -> Option<(f32, u32)> {
        if self.items.is_empty() {
            return None;
        }
        let inv = d.recip();
        let mut best = None;
        let mut t_best = t_max;
        self.ray_rec(
            o,
            d,
            inv,
            t_min,
            &mut t_best,
            inflate,
            0,
            0,
            self.items.len(),
            depth_for(self.items.len()),
            &mut best,
        );
        best
    }

    #[expect(clippy::too_many_arguments, reason = "recursion state of a hot loop, kept flat")]
    fn ray_rec(
        &self,
        o: Vec3,
        d: Vec3,
        inv: Vec3,
        t_min: f32,
        t_best: &mut f32,
        inflate: f32,
        i: usize,
        lo: usize,
        hi: usize,
        depth_left: u32,
        best: &mut Option<(f32, u32)>,
    ) {
        if self.boxes[i].inflate(inflate).ray_interval(o, inv, t_min, *t_best).is_none() {
            return;
        }
        if depth_left == 0 {
            for j in lo..hi {
                let s = &self.items[j];
                if let Some(t) = ray_ball(o, d, s.position(), s.radius)
                    && t >= t_min
                    && t < *t_best
                {
                    *t_best = t;
                    *best = Some((t, j as u32));
                }
            }
            return;
        }
        let mid = split(lo, hi);
        let (l, r) = (2 * i + 1, 2 * i + 2);
        let el = self.boxes[l]
            .inflate(inflate)
            .ray_interval(o, inv, t_min, *t_best)
            .map_or(f32::INFINITY, |x| x.0);
        let er = self.boxes[r]
            .inflate(inflate)
            .ray_interval(o, inv, t_min, *t_best)
            .map_or(f32::INFINITY, |x| x.0);
        let order = if el <= er { [(l, lo, mid), (r, mid, hi)] } else { [(r, mid, hi), (l, lo, mid)] };
        for (c, a, b) in order {
            self.ray_rec(o, d, inv, t_min, t_best, inflate, c, a, b, depth_left - 1, best);
        }
    }
}

/// Entry parameter of the unit ray `o + t d` into the ball (c, r); `None` if it misses or if `o`
/// is inside the ball.
#[inline]
pub fn ray_ball(o: Vec3, d: Vec3, c: Vec3, r: f32) -> Option<f32> {
    let oc = o - c;
    let b = oc.dot(d);
    let cc = oc.length_squared() - r * r;
    if cc <= 0.0 || b > 0.0 {
        return None;
    }
    let disc = b * b - cc;
    (disc >= 0.0).then(|| -b - disc.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn cloud(n: usize, seed: u64) -> Vec<Vec3> {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        (0..n)
            .map(|_| Vec3::new(rng.random(), rng.random::<f32>() * 3.0, rng.random::<f32>() * 0.1))
            .collect()
    }

    #[test]
    fn depth_gives_leaves_under_sixteen_points() {
        for n in [1usize, 15, 16, 17, 31, 32, 33, 1000, 8192, 100_000] {
            let d = depth_for(n);
            assert!(n.div_ceil(1 << d) < LEAF_POINTS, "n={n} d={d}");
            if d > 0 {
                assert!(n.div_ceil(1 << (d - 1)) >= LEAF_POINTS);
            }
        }
        assert_eq!(box_count(0), 0);
        assert_eq!(box_count(10), 1);
    }

    #[test]
    fn full_depth_knn_matches_brute_force() {
        let mut pts = cloud(5000, 1);
        sort_spatially(&mut pts);
        let boxes = build_boxes(&pts);
        let tree = BoxTree::new(&pts, &boxes);
        for q in cloud(200, 2) {
            let mut best = KBest::new(8);
            tree.knn(q, u32::MAX, &mut best, &|i| i);
            let mut brute: Vec<f32> = pts.iter().map(|p| (*p - q).length_squared()).collect();
            brute.sort_by(f32::total_cmp);
            let got: Vec<f32> = best.items().iter().map(|x| x.0).collect();
            assert_eq!(got, brute[..8].to_vec());
        }
    }

    #[test]
    fn boxes_contain_their_ranges() {
        let mut pts = cloud(777, 3);
        sort_spatially(&mut pts);
        let boxes = build_boxes(&pts);
        let tree = BoxTree::new(&pts, &boxes);
        let region = Aabb { min: Vec3::splat(-1.0), max: Vec3::splat(10.0) };
        let mut n = 0;
        tree.for_each_in(&region, &mut |_| n += 1);
        assert_eq!(n, 777);
    }

    #[test]
    fn depth_zero_search_returns_the_middle_point() {
        let mut pts = cloud(100, 4);
        sort_spatially(&mut pts);
        let boxes = build_boxes(&pts);
        let tree = BoxTree::new(&pts, &boxes);
        let mut best = KBest::new(4);
        tree.knn(Vec3::ZERO, 0, &mut best, &|i| i);
        assert_eq!(best.items().len(), 1);
        assert_eq!(best.items()[0].1, 50);
    }
}
