//! Normal and spacing estimation from the k nearest neighbours (bettio09 §3.1 names PCA
//! [PGK02] and density estimation without giving formulas; the choices here are ours):
//! - normal: eigenvector of the smallest eigenvalue of the neighbourhood covariance, oriented
//!   away from the centroid of the chunk (right for statues and busts; the renderer shades both
//!   sides anyway);
//! - spacing h = d_k √(π / k), the side of the area each sample covers when k neighbours fill
//!   a disc of radius d_k (the distance to the k-th neighbour);
//! - radius = `cloud_radius_factor` × h, 1.4 by default: 0.8 would cover a square grid of step
//!   h (its worst gap is h/√2), and does for a mesh's vertices (`radius_factor`, with their
//!   triangles' circumradius as a floor), but a scan's samples lie irregularly and discs of 0.8 h
//!   leave holes all over it (`cargo bench --bench render -- --cloud-radius-only`: the meshes'
//!   vertices as bare clouds against the mesh render; the dragon's SSIM at the middle view is
//!   0.71 at 0.8 and 0.96 at 1.4).
//!
//! Only what the input lacks is estimated: a mesh's vertices bring their normals and spacings
//! (the same side of the area each covers, from the faces: `formats::mesh::apply_triangles`).
//!
//! The normal is computed in `f64` from the smallest root of the covariance's characteristic
//! cubic (`smallest_eigenvector`: Newton's method, no trigonometry), with Jacobi rotations where
//! the smallest eigenvalue is nearly double. The neighbour search is exact and
//! batched by leaf of the region's implicit box hierarchy (8–15 neighbouring samples): each point
//! first tries a ball 1.25 times the area of the largest k-nearest ball of the leaf before
//! (neighbouring leaves have similar spacings), one walk of the boxes gathers the leaves those
//! balls reach, and a point whose ball holds enough samples keeps the nearest of them (no sample
//! outside the ball can be nearer); the others retry with twice the radius. Samples that bring a
//! normal but no spacing (most big scans) need only a spacing: by default one in 8 of each leaf
//! searches (`BuildParams::spacing_stride`) and the others take the spacing of the nearest
//! searched sample of their leaf, for a third of the search time (the accuracy it costs is
//! measured by `cargo bench --bench scene`; see docs/performance.md).
//!
//! Where a sample needs a normal, one in `normal_stride` of each leaf (`Strides`) searches
//! first; if the normals found agree within `normal_spread_deg`, the leaf's other samples take
//! the normal and spacing of the nearest of them, and otherwise they search too. A smooth stretch
//! of surface (a wall, terrain, a sphere) shares most normals and is estimated in under half the
//! time without a measurable loss; carving, edges and noise spread the normals and mostly search
//! (on the dragon and a raw range scan the median error to reference normals grows by 3 %, the
//! 99th percentile by under 1 %: `cargo bench --bench scene -- --normal-stride-only`,
//! docs/performance.md).
//!
//! Candidates are gathered without a branch and then sorted: keeping a running k nearest with
//! a bound that prunes leaves and samples was measured 1.10 times slower on a whole import (the
//! test per candidate is unpredictable), and a tighter first ball costs more retries than it
//! saves.

use glam::{Mat3, Vec3};
use kiosk_core::scene::boxtree::{self, PathStep};
use rayon::prelude::*;

/// Eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations: eigenvalues in
/// ascending order with their unit eigenvectors.
pub fn symmetric_eigen(m: Mat3) -> [(f32, Vec3); 3] {
    let mut a = [[0.0f64; 3]; 3];
    for (i, row) in a.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = f64::from(m.col(j)[i]);
        }
    }
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0f64]];
    for _sweep in 0..32 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        let diag = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        if off <= 1e-15 * diag.max(f64::MIN_POSITIVE) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * rp[k] - s * rq[k];
                a[q][k] = s * rp[k] + c * rq[k];
            }
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut out = [0, 1, 2].map(|i| {
        let e = Vec3::new(v[0][i] as f32, v[1][i] as f32, v[2][i] as f32);
        (a[i][i] as f32, e.try_normalize().unwrap_or(Vec3::Z))
    });
    out.sort_by(|x, y| x.0.total_cmp(&y.0));
    out
}

/// Unit eigenvector of the smallest eigenvalue of a symmetric 3×3 matrix (the PCA normal): the
/// smallest eigenvalue λ as the smallest root of the characteristic cubic, by Newton's method from
/// 0, the eigenvector as the longest cross product of two rows of `m - λ I`. When the smallest
/// eigenvalue is (nearly) double, that vector is ill-conditioned and [`symmetric_eigen`] decides.
///
/// Newton from 0 needs no trigonometry and, for a neighbourhood of a surface (λ small beside the
/// other two), two to four steps; it cannot overshoot: a covariance is positive semi-definite,
/// so 0 lies at or below the smallest root, and below it the cubic is negative, increasing and
/// concave (its inflection is at the mean eigenvalue), so every tangent meets zero between the
/// iterate and the root.
pub fn smallest_eigenvector(m: Mat3) -> Vec3 {
    let c = |i: usize, j: usize| f64::from(m.col(j)[i]);
    let scale =
        (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| c(i, j).abs()).fold(0.0, f64::max);
    if scale == 0.0 || !scale.is_finite() {
        return symmetric_eigen(m)[0].1;
    }
    let inv = 1.0 / scale;
    let a = [0, 1, 2].map(|i| [0, 1, 2].map(|j| c(i, j) * inv));
    // det(λ I - a) = λ³ - c2 λ² + c1 λ - c0.
    let c2 = a[0][0] + a[1][1] + a[2][2];
    let c1 = a[0][0] * a[1][1] - a[0][1] * a[1][0] + a[0][0] * a[2][2] - a[0][2] * a[2][0]
        + a[1][1] * a[2][2]
        - a[1][2] * a[2][1];
    let c0 = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    let mut smallest = 0.0f64;
    if c0 > 0.0 {
        for _ in 0..64 {
            let f = ((smallest - c2) * smallest + c1) * smallest - c0;
            let slope = (3.0 * smallest - 2.0 * c2) * smallest + c1;
            if f >= 0.0 || slope <= 0.0 {
                break;
            }
            let step = f / slope;
            smallest -= step;
            if -step <= 1e-12 * c2 {
                break;
            }
        }
    }
    // The other two: their sum and product, then the larger by the quadratic formula and the
    // smaller as product / larger (no cancellation).
    let sum = c2 - smallest;
    let product = c1 - smallest * sum;
    let largest = 0.5 * (sum + (sum * sum - 4.0 * product).max(0.0).sqrt());
    let middle = if largest > 0.0 { product / largest } else { 0.0 };
    // A double smallest eigenvalue (a line-like neighbourhood): no preferred normal here.
    let separated = middle - smallest >= 1e-6 * (largest - smallest).max(f64::MIN_POSITIVE);
    if !separated {
        return symmetric_eigen(m)[0].1;
    }
    let r = [0, 1, 2].map(|i| glam::DVec3::new(a[i][0], a[i][1], a[i][2]) - glam::DVec3::AXES[i] * smallest);
    let best = [r[0].cross(r[1]), r[0].cross(r[2]), r[1].cross(r[2])]
        .into_iter()
        .max_by(|x, y| x.length_squared().total_cmp(&y.length_squared()))
        .unwrap_or(glam::DVec3::Z);
    match best.try_normalize() {
        Some(n) => n.as_vec3(),
        None => symmetric_eigen(m)[0].1,
    }
}

/// Per-sample results of [`estimate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// PCA normal (unit).
    pub normal: Vec3,
    /// Local sample spacing h.
    pub spacing: f32,
}

/// How many points of each leaf search their neighbours (see [`estimate`]): one in `normal` of
/// a leaf where some point needs a normal, one in `spacing` of a leaf where points need only a
/// spacing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strides {
    /// Stride where a normal is needed.
    pub normal: usize,
    /// Stride where only spacings are.
    pub spacing: usize,
    /// Cosine of the largest angle between the normals found in a leaf for its other points to
    /// share them; a leaf whose normals spread wider (a carved, curved or noisy surface)
    /// searches for every point.
    pub spread_cos: f32,
}

impl Strides {
    /// Every point searches.
    pub const EXACT: Self = Self { normal: 1, spacing: 1, spread_cos: 1.0 };
}

/// Most neighbours [`estimate`] can use.
pub const MAX_K: usize = 32;

/// Estimates spacing, and the normal in every leaf where `need_normal` says so of some point
/// (in the other leaves normals are zero), for the points of `positions` (spatially sorted,
/// with `boxes` from [`boxtree::build_boxes`]) from
/// their `k` nearest neighbours (clamped to 2..=[`MAX_K`], and to the other points there are).
/// `None` when there are fewer than two distinct points.
///
/// Only the leaves of the implicit hierarchy (fewer than [`boxtree::LEAF_POINTS`] neighbouring
/// points, at least half as many) that hold a point that needs a normal or a spacing
/// (`need_spacing`; a mesh's vertices bring theirs) are estimated: the points of the others get
/// zero normals and spacings.
///
/// `strides` trade accuracy for speed: in every leaf estimated, only one point in the stride
/// searches its neighbours (the normal stride where some point needs a normal, the spacing
/// stride elsewhere); the others take the estimate of the nearest point of their leaf that did,
/// unless the normals found spread wider than [`Strides::spread_cos`] allows, when they search
/// too. [`Strides::EXACT`] searches for every point.
///
/// The search is exact and batched by leaf of the implicit hierarchy, in the order of the
/// points: each point first tries a ball a little larger than the k-nearest balls of the leaf
/// before (neighbouring leaves have similar spacing), and only grows it when it holds fewer
/// than k samples (see [`LeafSearch::leaf`]).
pub fn estimate(
    positions: &[Vec3],
    boxes: &[kiosk_core::Aabb],
    k: usize,
    strides: Strides,
    need_normal: &(dyn Fn(usize) -> bool + Sync),
    need_spacing: &(dyn Fn(usize) -> bool + Sync),
) -> Option<Vec<Estimate>> {
    if positions.len() < 2 {
        return None;
    }
    // At least 2 neighbours, unless the points are fewer: two points are each other's only one.
    let k = k.clamp(2, MAX_K).min(positions.len() - 1);
    let centroid = positions.iter().fold(Vec3::ZERO, |a, p| a + *p) / positions.len() as f32;
    let soa = Soa::new(positions);
    let search = LeafSearch { positions, soa: &soa, boxes, k: k + 1 };
    let strides = Strides { normal: strides.normal.max(1), spacing: strides.spacing.max(1), ..strides };
    let job = Job { search, centroid, need_normal, need_spacing, strides };
    let mut out = Vec::new();
    out.par_extend(rayon::iter::repeat_n(Estimate { normal: Vec3::ZERO, spacing: 0.0 }, positions.len()));
    let root = PathStep::root(positions.len());
    job.descend(root, &mut Vec::with_capacity(64), &mut Scratch::default(), &mut out);
    Some(out)
}

/// Ranges at least this long are split between threads.
const PARALLEL_POINTS: usize = 4096;

struct Job<'a> {
    search: LeafSearch<'a>,
    centroid: Vec3,
    need_normal: &'a (dyn Fn(usize) -> bool + Sync),
    need_spacing: &'a (dyn Fn(usize) -> bool + Sync),
    strides: Strides,
}

impl Job<'_> {
    /// Estimates the points of `step`'s range into `out` (that range), `path` leading to `step`.
    fn descend(&self, step: PathStep, path: &mut Vec<PathStep>, scratch: &mut Scratch, out: &mut [Estimate]) {
        path.push(step);
        if step.depth_left == 0 {
            let mut best = [TopK::new(self.search.k); boxtree::LEAF_POINTS];
            let best = &mut best[..step.hi - step.lo];
            let mask = |need: &dyn Fn(usize) -> bool| {
                (step.lo..step.hi).enumerate().fold(0u32, |m, (i, idx)| m | u32::from(need(idx)) << i)
            };
            let normals = mask(self.need_normal) != 0;
            if !normals && mask(self.need_spacing) == 0 {
                path.pop();
                return;
            }
            // A leaf where some point needs a normal searches with the normal stride, and every
            // point that searches there gets a normal.
            let stride = if normals { self.strides.normal } else { self.strides.spacing };
            let all = (1u32 << best.len()) - 1;
            let mut searched = (0..best.len()).step_by(stride).fold(0u32, |m, i| m | 1 << i);
            self.search_leaf(path, searched, normals, scratch, best, out);
            // Normals are shared only where those found agree; elsewhere every point searches.
            if normals && searched != all && !self.agree(searched, out) {
                self.search_leaf(path, all & !searched, normals, scratch, best, out);
                searched = all;
            }
            if searched != all {
                self.share(step.lo, searched, out);
            }
        } else {
            let [l, r] = step.children();
            let (ol, or) = out.split_at_mut(l.hi - l.lo);
            if step.hi - step.lo >= PARALLEL_POINTS {
                let mut other = path.clone();
                rayon::join(
                    || self.descend(l, path, scratch, ol),
                    || self.descend(r, &mut other, &mut Scratch::default(), or),
                );
            } else {
                self.descend(l, path, scratch, ol);
                self.descend(r, path, scratch, or);
            }
        }
        path.pop();
    }

    /// Searches the neighbours of the points of the leaf ending `path` with bit i of `which`
    /// set, and estimates them into `out` (the leaf's), with normals or not.
    fn search_leaf(
        &self,
        path: &[PathStep],
        which: u32,
        normals: bool,
        scratch: &mut Scratch,
        best: &mut [TopK],
        out: &mut [Estimate],
    ) {
        self.search.leaf(path, which, if normals { which } else { 0 }, scratch, best);
        let lo = path[path.len() - 1].lo;
        for (i, (o, b)) in out.iter_mut().zip(best.iter()).enumerate() {
            if which >> i & 1 == 1 {
                *o = self.finish(lo + i, b, normals);
            }
        }
    }

    /// Whether the normals of the `searched` points of a leaf (`out`), two at least, lie within
    /// [`Strides::spread_cos`] of each other (unoriented).
    fn agree(&self, searched: u32, out: &[Estimate]) -> bool {
        if searched.count_ones() < 2 {
            return self.strides.spread_cos <= 0.0;
        }
        let normals = || (0..out.len()).filter(move |i| searched >> i & 1 == 1).map(|i| out[i].normal);
        normals()
            .enumerate()
            .all(|(i, a)| normals().skip(i + 1).all(|b| a.dot(b).abs() >= self.strides.spread_cos))
    }

    /// Gives each point of the leaf starting at `lo` that was not `searched` (bit i for point i)
    /// the estimate of the nearest point that was.
    fn share(&self, lo: usize, searched: u32, out: &mut [Estimate]) {
        let pts = &self.search.positions[lo..lo + out.len()];
        for i in (0..out.len()).filter(|i| searched >> i & 1 == 0) {
            let nearest = (0..out.len())
                .filter(|j| searched >> j & 1 == 1)
                .min_by(|&a, &b| pts[a].distance_squared(pts[i]).total_cmp(&pts[b].distance_squared(pts[i])))
                .unwrap_or(i);
            out[i] = out[nearest];
        }
    }

    /// Spacing and normal of point `idx` from its nearest (itself first: duplicates are merged).
    fn finish(&self, idx: usize, best: &TopK, need_normal: bool) -> Estimate {
        let positions = self.search.positions;
        let k = self.search.k - 1;
        let p = positions[idx];
        let dk = best.d2[best.n - 1].sqrt();
        let spacing = dk * (std::f32::consts::PI / k as f32).sqrt();
        if !need_normal {
            return Estimate { normal: Vec3::ZERO, spacing };
        }
        let neigh = &best.idx[1..best.n];
        let mean = neigh.iter().fold(p, |a, &i| a + positions[i as usize]) / (neigh.len() + 1) as f32;
        let mut cov = Mat3::ZERO;
        for q in std::iter::once(p).chain(neigh.iter().map(|&i| positions[i as usize])) {
            let d = q - mean;
            cov += Mat3::from_cols(d * d.x, d * d.y, d * d.z);
        }
        let mut n = smallest_eigenvector(cov);
        if n.dot(p - self.centroid) < 0.0 {
            n = -n;
        }
        Estimate { normal: n, spacing }
    }
}

/// The k nearest of one point, by squared distance then index.
#[derive(Clone, Copy)]
struct TopK {
    n: usize,
    k: usize,
    d2: [f32; MAX_K + 1],
    idx: [u32; MAX_K + 1],
}

impl TopK {
    fn new(k: usize) -> Self {
        Self { n: 0, k, d2: [f32::INFINITY; MAX_K + 1], idx: [0; MAX_K + 1] }
    }

    /// Keeps only the `k`-th smallest distance of `keys` (at least `k` [`key`]s; reordered): all
    /// a spacing needs.
    fn fill_kth(&mut self, keys: &mut [u64]) {
        let kth = *keys.select_nth_unstable(self.k - 1).1;
        self.d2[self.k - 1] = f32::from_bits((kth >> 32) as u32);
        self.n = self.k;
    }

    /// Keeps the `k` smallest of `keys` ([`key`]s; reordered).
    fn fill(&mut self, keys: &mut [u64]) {
        let n = keys.len().min(self.k);
        if keys.len() <= 48 {
            // Small sets (the usual case): one sort is cheaper than a selection and a sort.
            keys.sort_unstable();
        } else {
            keys.select_nth_unstable(n - 1);
            keys[..n].sort_unstable();
        }
        let kept = &keys[..n];
        for (i, &key) in kept.iter().enumerate() {
            self.d2[i] = f32::from_bits((key >> 32) as u32);
            self.idx[i] = key as u32;
        }
        self.n = n;
    }
}

/// A candidate as one integer: squared distance (finite and non-negative, so its bits sort as the
/// numbers do), then index.
#[inline]
fn key(d2: f32, idx: usize) -> u64 {
    u64::from(d2.to_bits()) << 32 | idx as u64
}

/// Coordinates in separate arrays, so that distances to a run of points vectorise.
struct Soa {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl Soa {
    fn new(p: &[Vec3]) -> Self {
        Self {
            x: p.iter().map(|v| v.x).collect(),
            y: p.iter().map(|v| v.y).collect(),
            z: p.iter().map(|v| v.z).collect(),
        }
    }

    /// Squared distances from `q` to the points `lo..hi`, appended to `out`.
    #[inline]
    fn distances(&self, q: Vec3, lo: usize, hi: usize, out: &mut Vec<f32>) {
        let (x, y, z) = (&self.x[lo..hi], &self.y[lo..hi], &self.z[lo..hi]);
        out.extend(x.iter().zip(y).zip(z).map(|((&x, &y), &z)| {
            let (dx, dy, dz) = (x - q.x, y - q.y, z - q.z);
            dx * dx + dy * dy + dz * dz
        }));
    }
}

/// Buffers and state of one thread's leaf searches.
#[derive(Default)]
struct Scratch {
    /// Leaves whose boxes meet the box around the balls: (box index, lo, hi).
    leaves: Vec<(usize, usize, usize)>,
    /// Distances to one leaf.
    dist: Vec<f32>,
    /// Candidates within a point's ball.
    keys: Vec<u64>,
    /// Squared radius to try first: [`GROWTH`] × the largest k-th distance² of the last leaf.
    guess: f32,
}

/// The first ball tried holds this many times the area of the last leaf's largest k-nearest
/// ball (its radius ~12 % larger): most points find their k nearest at once.
const GROWTH: f32 = 1.25;

struct LeafSearch<'a> {
    positions: &'a [Vec3],
    soa: &'a Soa,
    boxes: &'a [kiosk_core::Aabb],
    k: usize,
}

impl LeafSearch<'_> {
    /// The k nearest (the point itself included) of every point of the leaf ending `path`, into
    /// `best` (one empty set per point of the leaf).
    ///
    /// Each point tries a ball (squared radius `t`): the leaves whose boxes meet the box around
    /// all the balls are gathered by one walk, each point searches those of them its own ball
    /// reaches, and a point whose ball holds at least k samples keeps the k nearest of them (no
    /// sample outside the ball can be nearer). The others try again with a ball of twice the
    /// radius. Only the points with bit i of `searched` set search; `normals` has bit i set when
    /// point i needs its neighbours (for a normal), not only the distance to the k-th.
    fn leaf(&self, path: &[PathStep], searched: u32, normals: u32, s: &mut Scratch, best: &mut [TopK]) {
        let leaf = path[path.len() - 1];
        let qs = &self.positions[leaf.lo..leaf.hi];
        let guess = if s.guess > 0.0 && s.guess.is_finite() {
            s.guess
        } else {
            let b = &self.boxes[leaf.index];
            b.extent().length_squared().max(f32::MIN_POSITIVE)
        };
        let mut t = [guess; boxtree::LEAF_POINTS];
        let mut pending: u32 = searched & ((1u64 << qs.len()) - 1) as u32;
        while pending != 0 {
            // The region every pending ball lies in (widened by a rounding margin); the walk
            // starts from the lowest box of the path that strictly contains it (samples of other
            // subtrees lie beyond a split plane of the path), else from the root.
            let mut region = kiosk_core::Aabb::EMPTY;
            for (i, &q) in qs.iter().enumerate().filter(|(i, _)| pending >> i & 1 == 1) {
                let r = t[i].sqrt() * (1.0 + 1e-5);
                region = region.union(kiosk_core::Aabb { min: q - r, max: q + r });
            }
            let start = path
                .iter()
                .rev()
                .find(|st| {
                    let b = &self.boxes[st.index];
                    region.min.is_finite() && region.min.cmpgt(b.min).all() && region.max.cmplt(b.max).all()
                })
                .copied()
                .unwrap_or(path[0]);
            s.leaves.clear();
            self.walk(&region, start, &mut s.leaves);
            for (i, &q) in qs.iter().enumerate() {
                if pending >> i & 1 == 0 {
                    continue;
                }
                s.keys.clear();
                for &(index, lo, hi) in &s.leaves {
                    if self.boxes[index].distance_squared(q) <= t[i] {
                        s.dist.clear();
                        self.soa.distances(q, lo, hi, &mut s.dist);
                        push_within(&mut s.keys, &s.dist, lo, t[i]);
                    }
                }
                if s.keys.len() >= self.k {
                    if normals >> i & 1 == 1 {
                        best[i].fill(&mut s.keys);
                    } else {
                        best[i].fill_kth(&mut s.keys);
                    }
                    pending &= !(1 << i);
                } else {
                    t[i] = (t[i] * 4.0).max(f32::MIN_POSITIVE);
                }
            }
        }
        let largest = best.iter().filter(|b| b.n > 0).map(|b| b.d2[b.n - 1]).fold(0.0, f32::max);
        s.guess = largest * GROWTH;
    }

    /// Gathers into `out` the leaves under `step` whose boxes meet `region`.
    fn walk(&self, region: &kiosk_core::Aabb, step: PathStep, out: &mut Vec<(usize, usize, usize)>) {
        let b = &self.boxes[step.index];
        if b.max.cmplt(region.min).any() || b.min.cmpgt(region.max).any() {
            return;
        }
        if step.depth_left == 0 {
            out.push((step.index, step.lo, step.hi));
            return;
        }
        for child in step.children() {
            self.walk(region, child, out);
        }
    }
}

/// Appends the [`key`]s of the distances of `d2` (of points `first..`) that are within `bound`.
#[inline]
fn push_within(keys: &mut Vec<u64>, d2: &[f32], first: usize, bound: f32) {
    // Branch-free: every key is written, only those within the bound advance the end.
    let start = keys.len();
    keys.resize(start + d2.len() + 1, 0);
    let mut n = start;
    for (j, &d) in d2.iter().enumerate() {
        keys[n] = key(d, first + j);
        n += usize::from(d <= bound);
    }
    keys.truncate(n);
}

/// Spatially sorts positions and builds their boxes (helper for [`estimate`]).
pub fn sorted_tree(positions: &mut [Vec3]) -> Vec<kiosk_core::Aabb> {
    boxtree::sort_spatially(positions);
    boxtree::build_boxes(positions)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigen_of_a_flat_covariance_gives_its_normal() {
        // Points on the plane z = 0.3 x: normal ∝ (-0.3, 0, 1).
        let pts: Vec<Vec3> = (0..100)
            .map(|i| {
                let (x, y) = ((i % 10) as f32, (i / 10) as f32);
                Vec3::new(x, y, 0.3 * x)
            })
            .collect();
        let mean = pts.iter().fold(Vec3::ZERO, |a, p| a + *p) / 100.0;
        let mut cov = Mat3::ZERO;
        for p in &pts {
            let d = *p - mean;
            cov += Mat3::from_cols(d * d.x, d * d.y, d * d.z);
        }
        let e = symmetric_eigen(cov);
        let expect = Vec3::new(-0.3, 0.0, 1.0).normalize_or_zero();
        assert!(e[0].1.dot(expect).abs() > 0.9999, "{:?}", e);
        assert!(e[0].0.abs() < 1e-3 * e[2].0);
        assert!(e[0].0 <= e[1].0 && e[1].0 <= e[2].0);
    }

    #[test]
    fn newton_normal_matches_jacobi() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let mut checked = 0;
        for case in 0..3000 {
            // Neighbourhoods from exactly flat to round, at scales from 1e-6 to 1e3, tilted at
            // random.
            let flat = [1e-4f32, 1e-2, 0.3, 1.0, 0.0, 1e-6][case % 6];
            let scale = 10f32.powi(rng.random_range(-6..=3));
            let axis = Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
            let rot = glam::Quat::from_axis_angle(
                axis.try_normalize().unwrap_or(Vec3::Z),
                rng.random::<f32>() * 6.0,
            );
            let pts: Vec<Vec3> = (0..13)
                .map(|_| {
                    let local = Vec3::new(
                        rng.random::<f32>() - 0.5,
                        (rng.random::<f32>() - 0.5) * 0.7,
                        (rng.random::<f32>() - 0.5) * flat,
                    );
                    rot * local * scale + Vec3::splat(100.0 * scale)
                })
                .collect();
            let mean = pts.iter().fold(Vec3::ZERO, |a, p| a + *p) / pts.len() as f32;
            let mut cov = Mat3::ZERO;
            for p in &pts {
                let d = *p - mean;
                cov += Mat3::from_cols(d * d.x, d * d.y, d * d.z);
            }
            let e = symmetric_eigen(cov);
            let n = smallest_eigenvector(cov);
            assert!((n.length() - 1.0).abs() < 1e-5, "case {case}: not unit: {n}");
            // Where the smallest eigenvalue is well separated, both give the same direction.
            if e[1].0 - e[0].0 > 1e-3 * e[2].0 {
                assert!(n.dot(e[0].1).abs() > 0.9999, "case {case}: {n} vs {:?}", e);
                checked += 1;
            }
            // The flattest are the plane's own normal, within the rounding of the points.
            if flat <= 1e-4 {
                let plane = rot * Vec3::Z;
                assert!(n.dot(plane).abs() > 0.9999, "case {case}, flatness {flat}: {n} vs {plane}");
            }
        }
        assert!(checked > 2000, "only {checked} separated cases");
        // Degenerate covariances still give a unit vector.
        for m in [Mat3::ZERO, Mat3::IDENTITY, Mat3::from_diagonal(Vec3::new(1.0, 0.0, 0.0))] {
            assert!((smallest_eigenvector(m).length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn batched_neighbours_match_brute_force() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        // A thin, uneven cloud: dense and sparse parts, so balls cross many leaves.
        let mut pts: Vec<Vec3> = (0..6000)
            .map(|i| {
                let s = if i % 3 == 0 { 0.1 } else { 1.0 };
                Vec3::new(rng.random::<f32>() * s, rng.random::<f32>() * 3.0 * s, rng.random::<f32>() * 0.05)
            })
            .collect();
        let boxes = sorted_tree(&mut pts);
        let paths = boxtree::leaf_paths(pts.len());
        for k in [2usize, 12, MAX_K] {
            let soa = Soa::new(&pts);
            let search = LeafSearch { positions: &pts, soa: &soa, boxes: &boxes, k: k + 1 };
            let mut scratch = Scratch::default();
            for path in &paths {
                let leaf = path[path.len() - 1];
                let mut found = vec![TopK::new(k + 1); leaf.hi - leaf.lo];
                search.leaf(path, u32::MAX, u32::MAX, &mut scratch, &mut found);
                // Points that need no normal only get the distance to their k-th neighbour.
                let mut kth = vec![TopK::new(k + 1); leaf.hi - leaf.lo];
                search.leaf(path, u32::MAX, 0, &mut scratch, &mut kth);
                for ((q, got), only) in (leaf.lo..leaf.hi).zip(found).zip(kth) {
                    let mut brute: Vec<f32> = pts.iter().map(|p| (*p - pts[q]).length_squared()).collect();
                    brute.sort_by(f32::total_cmp);
                    assert_eq!(&got.d2[..got.n], &brute[..k + 1], "point {q}, k {k}");
                    for (&i, &d2) in got.idx[..got.n].iter().zip(&got.d2) {
                        assert_eq!((pts[i as usize] - pts[q]).length_squared(), d2);
                    }
                    assert_eq!((only.n, only.d2[k]), (k + 1, brute[k]), "k-th only: point {q}, k {k}");
                }
            }
        }
    }

    /// A 50 × 50 grid of step 0.01 in z = 0, sorted, with its boxes.
    fn grid() -> (Vec<Vec3>, Vec<kiosk_core::Aabb>) {
        let mut pts: Vec<Vec3> =
            (0..2500).map(|i| Vec3::new((i % 50) as f32 * 0.01, (i / 50) as f32 * 0.01, 0.0)).collect();
        let boxes = sorted_tree(&mut pts);
        (pts, boxes)
    }

    #[test]
    fn only_leaves_holding_a_point_that_needs_something_are_estimated() {
        let (pts, boxes) = grid();
        let exact = estimate(&pts, &boxes, 12, Strides::EXACT, &|_| false, &|_| true).expect("enough points");
        // Points left of x = 0.2 lack a spacing, one point at the far right lacks a normal.
        let lacks_spacing = |i: usize| pts[i].x < 0.2;
        let lone = pts.iter().position(|p| p.x > 0.45 && p.y > 0.45).expect("a corner point");
        let est = estimate(&pts, &boxes, 12, Strides::EXACT, &|i| i == lone, &lacks_spacing)
            .expect("enough points");
        let (mut estimated, mut skipped) = (0, 0);
        for path in boxtree::leaf_paths(pts.len()) {
            let leaf = path[path.len() - 1];
            let needed = (leaf.lo..leaf.hi).any(|i| lacks_spacing(i) || i == lone);
            for i in leaf.lo..leaf.hi {
                if needed {
                    assert_eq!(est[i].spacing, exact[i].spacing, "point {i} of a leaf that needs one");
                    estimated += 1;
                } else {
                    assert_eq!(est[i], Estimate { normal: Vec3::ZERO, spacing: 0.0 }, "point {i}");
                    skipped += 1;
                }
            }
        }
        assert!(est[lone].normal.z.abs() > 0.999, "the point that needs a normal gets one");
        // 1000 points lack a spacing; leaves straddle x = 0.2, so a few more are estimated.
        assert!(
            (1000..1500).contains(&estimated) && skipped + estimated == 2500,
            "{estimated} estimated, {skipped} skipped"
        );
    }

    #[test]
    fn strides_search_some_points_and_share_their_estimates() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        // Uneven density, so that neighbouring points have different spacings.
        let mut pts: Vec<Vec3> = (0..5000)
            .map(|_| {
                let x = rng.random::<f32>().powi(3);
                Vec3::new(x, rng.random::<f32>(), 0.01 * (x * 40.0).sin())
            })
            .collect();
        let boxes = sorted_tree(&mut pts);
        // Leaves where no point needs a normal, some do, or all do.
        let some = |i: usize| i % 7 == 3 && i < 2500;
        let cases: [(&str, &(dyn Fn(usize) -> bool + Sync)); 3] =
            [("no normals", &|_| false), ("some normals", &some), ("all normals", &|_| true)];
        for (name, need) in cases {
            let exact = estimate(&pts, &boxes, 12, Strides::EXACT, &need, &|_| true).expect("enough points");
            for stride in [2usize, 4, 8, 16] {
                // Normals shared whatever their spread, or only where they agree (two at least
                // found: with strides of 8 and more a leaf may have one).
                let agreeing = Strides { normal: stride, spacing: 1, spread_cos: 3f32.to_radians().cos() };
                let configs = [
                    Some(Strides { spacing: stride, ..Strides::EXACT }),
                    Some(Strides { normal: stride, spacing: 1, spread_cos: 0.0 }),
                    (stride <= 4).then_some(agreeing),
                ];
                for strides in configs.into_iter().flatten() {
                    let est = estimate(&pts, &boxes, 12, strides, &need, &|_| true).expect("enough points");
                    let (mut searched, mut shared, mut spread_leaves) = (0, 0, 0);
                    for path in boxtree::leaf_paths(pts.len()) {
                        let leaf = path[path.len() - 1];
                        let normals = (leaf.lo..leaf.hi).any(need);
                        let stride = if normals { strides.normal } else { strides.spacing };
                        let first = |idx: usize| (idx - leaf.lo).is_multiple_of(stride);
                        let agree = strides.spread_cos <= 0.0
                            || (leaf.lo..leaf.hi).filter(|&i| first(i)).count() >= 2
                                && (leaf.lo..leaf.hi).filter(|&i| first(i)).all(|i| {
                                    (leaf.lo..leaf.hi).filter(|&j| first(j)).all(|j| {
                                        exact[i].normal.dot(exact[j].normal).abs() >= strides.spread_cos
                                    })
                                });
                        // A leaf whose first normals spread too wide searches every point.
                        let spread = normals && stride > 1 && !agree;
                        spread_leaves += usize::from(spread);
                        let is_searched = |idx: usize| spread || first(idx);
                        for idx in leaf.lo..leaf.hi {
                            let what = format!("{name}, {strides:?}, point {idx}");
                            if is_searched(idx) {
                                // Searched points are exact; in a leaf where some point needs a
                                // normal, all of them get one.
                                assert_eq!(est[idx], exact[idx], "{what}");
                                assert_eq!(est[idx].normal != Vec3::ZERO, normals, "{what}");
                                searched += 1;
                                continue;
                            }
                            // The others: the estimate of the nearest searched point of their leaf.
                            let nearest = (leaf.lo..leaf.hi)
                                .filter(|&j| is_searched(j))
                                .min_by(|&a, &b| {
                                    pts[a]
                                        .distance_squared(pts[idx])
                                        .total_cmp(&pts[b].distance_squared(pts[idx]))
                                })
                                .expect("a searched point in every leaf");
                            assert_eq!(est[idx], exact[nearest], "{what}");
                            if est[idx] != exact[idx] {
                                shared += 1;
                            }
                        }
                    }
                    // Each stride applies where its kind of leaf is.
                    let applies = match name {
                        "no normals" => strides.spacing > 1,
                        "all normals" => strides.normal > 1,
                        _ => true,
                    };
                    if applies {
                        // Where normals are shared only when they agree, the wave's curved
                        // leaves search every point and its flatter ones share.
                        let (least, spreads) = if strides.normal > 1 && strides.spread_cos > 0.0 {
                            (pts.len() / 50, 20)
                        } else {
                            (pts.len() / 8, 0)
                        };
                        assert!(
                            searched < pts.len() && shared > least && spread_leaves >= spreads,
                            "{name}, {strides:?}: {searched} searched, {shared} shared, {spread_leaves} leaves spread"
                        );
                    } else {
                        assert_eq!((searched, shared), (pts.len(), 0), "{name}, {strides:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn two_or_three_points_are_estimated_from_the_neighbours_they_have() {
        for n in [2usize, 3] {
            let mut pts: Vec<Vec3> = (0..n).map(|i| Vec3::new(i as f32, (i * i) as f32 * 0.5, 0.0)).collect();
            let boxes = sorted_tree(&mut pts);
            let est =
                estimate(&pts, &boxes, 12, Strides::EXACT, &|_| true, &|_| true).expect("distinct points");
            assert_eq!(est.len(), n);
            for e in &est {
                assert!(e.spacing > 0.0 && e.spacing.is_finite(), "{n} points: {e:?}");
                assert!((e.normal.length() - 1.0).abs() < 1e-5, "{n} points: {e:?}");
            }
        }
    }

    #[test]
    fn spacing_of_a_grid_is_its_step() {
        let (pts, boxes) = grid();
        let est = estimate(&pts, &boxes, 12, Strides::EXACT, &|_| true, &|_| true).expect("enough points");
        let interior: Vec<f32> = pts
            .iter()
            .zip(&est)
            .filter(|(p, _)| p.x > 0.05 && p.x < 0.44 && p.y > 0.05 && p.y < 0.44)
            .map(|(_, e)| e.spacing)
            .collect();
        let mean = interior.iter().sum::<f32>() / interior.len() as f32;
        // 12th neighbour on a grid is at 2 h: spacing = 2h √(π/12) ≈ 1.02 h.
        assert!((mean / 0.01 - 1.02).abs() < 0.05, "mean spacing {mean}");
        assert!(est.iter().all(|e| e.normal.z.abs() > 0.999));
    }
}
