//! Normal and spacing estimation from the k nearest neighbours (bettio09 §3.1 names PCA
//! [PGK02] and density estimation without giving formulas; the choices here are ours):
//! - normal: eigenvector of the smallest eigenvalue of the neighbourhood covariance, oriented
//!   away from the centroid of the chunk (right for statues and busts; the renderer shades both
//!   sides anyway);
//! - spacing h = d_k √(π / k), the side of the area each sample covers when k neighbours fill
//!   a disc of radius d_k (the distance to the k-th neighbour);
//! - radius = `radius_factor` × h (0.8 covers a square grid of step h, whose worst gap is h/√2).

use glam::{Mat3, Vec3};
use kiosk_core::scene::boxtree::{self, BoxTree, KBest};
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

/// Per-sample results of [`estimate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// PCA normal (unit).
    pub normal: Vec3,
    /// Local sample spacing h.
    pub spacing: f32,
}

/// Estimates spacing, and the normal where `need_normal` says so (others get zero), for every
/// point of `positions` (spatially sorted, with `boxes` from [`boxtree::build_boxes`]) from its
/// `k` nearest neighbours. `None` when there are fewer than two distinct points.
pub fn estimate(
    positions: &[Vec3],
    boxes: &[kiosk_core::Aabb],
    k: usize,
    need_normal: &(dyn Fn(usize) -> bool + Sync),
) -> Option<Vec<Estimate>> {
    if positions.len() < 2 {
        return None;
    }
    let tree = BoxTree::new(positions, boxes);
    let k = k.clamp(2, positions.len() - 1);
    let centroid = positions.iter().fold(Vec3::ZERO, |a, p| a + *p) / positions.len() as f32;
    let paths = boxtree::leaf_paths(positions.len());
    let out = paths
        .par_iter()
        .flat_map_iter(|path| {
            let leaf = path[path.len() - 1];
            (leaf.lo..leaf.hi).map(move |i| (i, path))
        })
        .map(|(idx, path)| {
            let p = positions[idx];
            let mut best = KBest::new(k + 1);
            tree.knn_from_leaf(p, path, &mut best, &|i| i);
            let neigh = &best.items()[1..]; // the first is the point itself (duplicates are merged)
            let dk = neigh.last().map_or(0.0, |x| x.0.sqrt());
            let spacing = dk * (std::f32::consts::PI / k as f32).sqrt();
            if !need_normal(idx) {
                return Estimate { normal: Vec3::ZERO, spacing };
            }
            let mean =
                neigh.iter().fold(p, |a, &(_, i)| a + positions[i as usize]) / (neigh.len() + 1) as f32;
            let mut cov = Mat3::ZERO;
            for q in std::iter::once(p).chain(neigh.iter().map(|&(_, i)| positions[i as usize])) {
                let d = q - mean;
                cov += Mat3::from_cols(d * d.x, d * d.y, d * d.z);
            }
            let mut n = symmetric_eigen(cov)[0].1;
            if n.dot(p - centroid) < 0.0 {
                n = -n;
            }
            Estimate { normal: n, spacing }
        })
        .collect();
    Some(out)
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
    fn spacing_of_a_grid_is_its_step() {
        let mut pts: Vec<Vec3> =
            (0..2500).map(|i| Vec3::new((i % 50) as f32 * 0.01, (i / 50) as f32 * 0.01, 0.0)).collect();
        let boxes = sorted_tree(&mut pts);
        let est = estimate(&pts, &boxes, 12, &|_| true).expect("enough points");
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
