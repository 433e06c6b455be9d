//! Numerical extremes (scans span sub-millimetre carvings and georeferenced coordinates of
//! 10⁶–10⁷ m): georeferenced offsets, sub-millimetre and huge scales, degenerate inputs.

use crate::common::{self, small_nodes};
use glam::{DVec3, Vec3};
use kiosk_core::{Cut, QueryParams};
use kiosk_import::source::InputPoint;
use rand::{Rng, SeedableRng};

fn probe_points(center: DVec3, diag: f64) -> Vec<DVec3> {
    let mut r = rand_pcg::Pcg64::seed_from_u64(5);
    (0..200)
        .map(|_| {
            center
                + DVec3::new(r.random_range(-0.6..0.6), r.random_range(-0.6..0.6), r.random_range(-0.6..0.6))
                    * diag
        })
        .collect()
}

/// Builds the demo bust as is and transformed by `p·s + t`; the fine and coarse targets and the
/// exact nearest sample of transformed queries are the transformed answers, up to rounding.
fn assert_same_queries_under(scale: f64, offset: DVec3) {
    let pts = common::read("scans/demosthenes/demosthenes-low-res.obj");
    let a = common::build(&pts, small_nodes());
    let b = common::build(&common::transform(&pts, scale, offset), small_nodes());
    assert_eq!(a.summary.leaf_points, b.summary.leaf_points);
    assert_eq!(a.summary.nodes, b.summary.nodes);
    let (sa, sb) = (&a.store, &b.store);
    let diag = f64::from(sa.bbox().diagonal());
    let (ca, cb) = (Cut::leaves(sa), Cut::leaves(sb));
    let q = QueryParams::default();
    let mut worst: f64 = 0.0;
    for p in probe_points(sa.to_model(sa.bbox().center()), diag) {
        let pb = p * scale + offset;
        let back = |x: DVec3| (x - offset) / scale;
        let fa = sa.fine_target(&ca, p, &q).expect("finite");
        let fb = sb.fine_target(&cb, pb, &q).expect("finite");
        let oa = sa.coarse_target(&ca, p, &q).expect("finite");
        let ob = sb.coarse_target(&cb, pb, &q).expect("finite");
        let (_, na) = sa.nearest_sample(p).expect("finite");
        let (_, nb) = sb.nearest_sample(pb).expect("finite");
        for (x, y) in [(fa.point, back(fb.point)), (oa.point, back(ob.point)), (na, back(nb))] {
            worst = worst.max((x - y).length() / diag);
        }
    }
    // f32 local coordinates: a few ulps of the model size.
    assert!(worst < 1e-5, "scale {scale}, offset {offset}: relative difference {worst:e}");
}

#[test]
fn georeferenced_model_answers_like_the_model_at_the_origin() {
    assert_same_queries_under(1.0, DVec3::new(1.0e7, -3.0e6, 4.5e6));
}

#[test]
fn sub_millimetre_scale_answers_like_the_original() {
    assert_same_queries_under(1e-4, DVec3::ZERO);
}

#[test]
fn thousandfold_scale_answers_like_the_original() {
    assert_same_queries_under(1e3, DVec3::ZERO);
}

#[test]
fn georeferenced_and_tiny_at_once() {
    assert_same_queries_under(1e-3, DVec3::new(6.0e6, 2.0e6, 350.0));
}

fn point(x: f64, y: f64, z: f64) -> InputPoint {
    InputPoint { pos: DVec3::new(x, y, z), normal: Vec3::ZERO, color: [0; 4], radius: 0.0, spacing: 0.0 }
}

#[test]
fn empty_model_is_a_clear_error() {
    let err = common::try_build(&[], small_nodes()).err().expect("must fail");
    assert_eq!(err.to_string(), "the model has no samples");
}

#[test]
fn one_point_and_identical_points_are_a_clear_error() {
    let err = common::try_build(&[point(1.0, 2.0, 3.0)], small_nodes()).err().expect("must fail");
    assert!(err.to_string().contains("all 1 samples are at the same position"), "{err}");
    let same = vec![point(1.0, 2.0, 3.0); 1000];
    let err = common::try_build(&same, small_nodes()).err().expect("must fail");
    assert!(err.to_string().contains("all 1000 samples are at the same position"), "{err}");
}

/// Documented result: collinear points build a model; their normals are an arbitrary (but
/// deterministic) perpendicular of the line, and every query stays finite.
#[test]
fn a_failed_build_leaves_no_partial_store_behind() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("m.kstore");
    let mut b = kiosk_import::Builder::new(small_nodes(), dir.path()).expect("params");
    for _ in 0..10 {
        b.push(point(1.0, 1.0, 1.0)).expect("push");
    }
    assert!(b.finish(&out, &mut |_| {}).is_err());
    let left: Vec<_> =
        std::fs::read_dir(dir.path()).expect("dir").map(|e| e.expect("entry").file_name()).collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn collinear_points_build_and_answer_finitely() {
    let pts: Vec<InputPoint> =
        (0..5000).map(|i| point(i as f64 * 1e-3, 2.0 * i as f64 * 1e-3, 0.5)).collect();
    let b = common::build(&pts, small_nodes());
    let cut = Cut::leaves(&b.store);
    for id in cut.nodes() {
        for s in b.store.splats(*id) {
            let n = s.normal();
            assert!(n.is_finite() && n.dot(Vec3::new(1.0, 2.0, 0.0).normalize_or_zero()).abs() < 1e-3);
            assert!(s.radius.is_finite() && s.radius > 0.0);
        }
    }
    let t = b.store.fine_target(&cut, DVec3::new(3.0, 0.0, 0.0), &QueryParams::default()).expect("finite");
    assert!(t.point.is_finite());
    let hit =
        b.store.ray_cast(kiosk_core::Level::Full, DVec3::new(1.0, 2.0, 5.0), DVec3::NEG_Z, f64::INFINITY);
    assert!(hit.is_some_and(|h| (h.point.z - 0.5).abs() < 0.01));
}

/// Documented result: coplanar points build a model whose normals are the plane's normal.
#[test]
fn coplanar_points_get_the_plane_normal() {
    let pts: Vec<InputPoint> =
        (0..10_000).map(|i| point((i % 100) as f64 * 0.01, (i / 100) as f64 * 0.01, 7.0)).collect();
    let b = common::build(&pts, small_nodes());
    for id in Cut::leaves(&b.store).nodes() {
        assert!(b.store.splats(*id).iter().all(|s| s.normal().z.abs() > 0.999));
    }
    assert_eq!(b.summary.leaf_points, 10_000);
}

/// Samples that bring a spacing (a mesh's vertices) keep it; the others have theirs estimated
/// from their neighbours, also where both kinds are mixed.
#[test]
fn spacings_brought_are_kept_and_the_missing_ones_estimated() {
    // A plane grid of step 0.01 m (estimated spacing about 0.01) whose even samples say 0.004.
    let pts: Vec<InputPoint> = (0..10_000)
        .map(|i| {
            let p = point((i % 100) as f64 * 0.01, (i / 100) as f64 * 0.01, 7.0);
            InputPoint { normal: Vec3::Z, spacing: if i % 2 == 0 { 0.004 } else { 0.0 }, ..p }
        })
        .collect();
    let b = common::build(&pts, small_nodes());
    let params = kiosk_import::BuildParams::default();
    let (mut brought, mut estimated) = (0, 0);
    for id in Cut::leaves(&b.store).nodes() {
        for s in b.store.splats(*id) {
            let p = b.store.to_model(s.position());
            let (ix, iy) = ((p.x / 0.01).round() as usize, (p.y / 0.01).round() as usize);
            // Spacings brought and estimated make radii by factors of their own.
            let factor = if ix % 2 == 0 { params.radius_factor } else { params.cloud_radius_factor };
            let h = s.radius / factor;
            if ix % 2 == 0 {
                assert!((h - 0.004).abs() < 1e-6, "sample ({ix}, {iy}): spacing {h}, brought 0.004");
                brought += 1;
            } else {
                // About the step inside; up to twice it near the border, whose neighbours are
                // all on one side.
                let inside = (3..97).contains(&ix) && (3..97).contains(&iy);
                let range = if inside { 0.007..0.014 } else { 0.007..0.02 };
                assert!(range.contains(&h), "sample ({ix}, {iy}): estimated spacing {h}, grid step 0.01");
                estimated += 1;
            }
        }
    }
    assert_eq!((brought, estimated), (5000, 5000));
    // Every sample bringing its spacing: nothing to estimate, and the nodes' spacings are theirs.
    let all: Vec<InputPoint> = pts.iter().map(|p| InputPoint { spacing: 0.004, ..*p }).collect();
    let b = common::build(&all, small_nodes());
    for id in Cut::leaves(&b.store).nodes() {
        assert!((b.store.node(*id).spacing - 0.004).abs() < 1e-6, "{}", b.store.node(*id).spacing);
        assert!(b.store.splats(*id).iter().all(|s| (s.radius - params.radius_factor * 0.004).abs() < 1e-6));
    }
}

#[test]
fn duplicate_points_are_merged() {
    // Its vertices are distinct (its large triangles' samples are not: the file has coincident
    // triangles).
    let mut pts = common::read_vertices("scans/stanford-bunny/bun_zipper_res4.ply");
    let n = pts.len() as u64;
    let dup: Vec<InputPoint> = pts.iter().take(100).copied().collect();
    pts.extend(dup);
    let b = common::build(&pts, small_nodes());
    assert_eq!(b.summary.input_points, n + 100);
    assert_eq!(b.summary.leaf_points, n);
}

#[test]
fn out_of_core_build_matches_the_in_memory_build() {
    let pts = common::read("scans/stanford-dragon/dragon_vrip_res2.ply.gz");
    let params = kiosk_import::BuildParams { node_points: 1024, chunk_points: 8192, ..Default::default() };
    let ooc = common::build(&pts, params);
    assert!(ooc.summary.chunks >= 8, "{} regions", ooc.summary.chunks);
    // The scan is read in sweep order; still no region holds more than half a chunk.
    assert!(ooc.summary.largest_region <= 4096, "a region of {} samples", ooc.summary.largest_region);
    let mem = common::build(&pts, kiosk_import::BuildParams { chunk_points: 1_000_000, ..params });
    assert_eq!(mem.summary.chunks, 1);
    assert_eq!(ooc.summary.leaf_points, mem.summary.leaf_points);
    for store in [&ooc.store, &mem.store] {
        for (id, n) in store.nodes().iter().enumerate() {
            store.verify_node(id as u32).expect("valid node");
            assert!(n.point_count as usize <= 1024);
            // An inner node holds at least as many samples as its larger child (at most M): the
            // leaves of a region are halved ranges of M/2 to M samples, so nodes above them are
            // as full. It holds more where halving would take long merges.
            if !n.is_leaf() {
                let larger = n.children.map(|c| store.node(c).point_count).into_iter().max();
                let larger = larger.expect("two children").min(1024);
                assert!(n.point_count >= larger, "node {id}: {} < {larger}", n.point_count);
            }
        }
    }
    // The same surface answers: nearest samples agree exactly (same samples at full resolution).
    let diag = f64::from(mem.store.bbox().diagonal());
    for p in probe_points(mem.store.to_model(mem.store.bbox().center()), diag) {
        let (da, _) = mem.store.nearest_sample(p).expect("finite");
        let (db, _) = ooc.store.nearest_sample(p).expect("finite");
        assert!((da - db).abs() < 1e-9 * diag);
    }
    // A mesh's samples bring their radii and spacings from the faces, through the cells of the
    // out-of-core build as well: the full-resolution samples are the same, radius for radius,
    // but for the few vertices in no triangle of area > 0 (their spacing is estimated from the
    // neighbours of their region, which the two builds cut differently).
    assert_eq!(ooc.store.origin(), mem.store.origin());
    let estimated: std::collections::HashSet<[u32; 3]> = pts
        .iter()
        .filter(|p| p.spacing == 0.0)
        .map(|p| mem.store.to_local(p.pos).to_array().map(f32::to_bits))
        .collect();
    assert!(
        estimated.len() < pts.len() / 1000,
        "{} of {} vertices without a spacing",
        estimated.len(),
        pts.len()
    );
    let leaf_samples = |store: &kiosk_content::MappedStore| {
        let mut v: Vec<([u32; 3], u32)> = (0..store.nodes().len() as u32)
            .filter(|&id| store.node(id).is_leaf())
            .flat_map(|id| {
                let splats = store.splats(id).iter();
                splats
                    .map(|s| (s.position().to_array().map(f32::to_bits), s.radius.to_bits()))
                    .collect::<Vec<_>>()
            })
            .filter(|(p, _)| !estimated.contains(p))
            .collect();
        v.sort_unstable();
        v
    };
    let (a, b) = (leaf_samples(&ooc.store), leaf_samples(&mem.store));
    assert!(a.len() + estimated.len() >= mem.summary.leaf_points as usize);
    assert!(a == b, "the samples or their radii differ");
}
