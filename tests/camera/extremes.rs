//! Numerical extremes of the camera: whatever the input or the scale, it never yields NaN or ∞
//! and never comes closer to the surface than the minimum distance.

use super::{Script, assert_safe, run};
use crate::common;
use glam::DVec3;
use kiosk_core::camera::ControllerKind;
use kiosk_core::explore::ExploreSettings;
use kiosk_core::replay;

fn session() -> Script {
    Script::new().joystick(1, (0.2, 0.05), 2.0).wait(0.2).pinch(0.1, 0.7, 0.8).wait(0.2).joystick(
        1,
        (-0.1, -0.2),
        1.5,
    )
}

/// The same session on the model translated and scaled gives the same trace up to the
/// transform.
fn assert_same_trace_under(scale: f64, offset: DVec3) {
    // The vertices alone: the samples a plain mesh's large triangles get lie on regular grids,
    // whose exactly equal distances rounding under the transform breaks one way or the other
    // (another merge, another hierarchy); invariance holds where no distances tie.
    let pts = common::read_vertices("scans/stanford-bunny/bun_zipper_res2.ply");
    let a = common::build(&pts, common::small_nodes());
    let b = common::build(&common::transform(&pts, scale, offset), common::small_nodes());
    let ta = run(&a.store, &session(), ControllerKind::IsoCam);
    let tb = run(&b.store, &session(), ControllerKind::IsoCam);
    assert_safe(&ta);
    assert_safe(&tb);
    assert_eq!(ta.frames.len(), tb.frames.len());
    let diag = f64::from(a.store.bbox().diagonal());
    let mut worst: f64 = 0.0;
    for (fa, fb) in ta.frames.iter().zip(&tb.frames) {
        let back = (DVec3::from_array(fb.eye) - offset) / scale;
        worst = worst.max((back - DVec3::from_array(fa.eye)).length() / diag);
        let ua = DVec3::from_array(fa.up);
        assert!((ua - DVec3::from_array(fb.up)).length() < 1e-3);
    }
    assert!(worst < 1e-4, "scale {scale}, offset {offset}: eye paths differ by {worst:e} of the diagonal");
}

#[test]
fn georeferenced_model_gives_the_same_trace() {
    assert_same_trace_under(1.0, DVec3::new(1.0e7, 2.0e6, -4.0e6));
}

#[test]
fn sub_millimetre_model_gives_the_same_trace_up_to_scale() {
    assert_same_trace_under(1e-4, DVec3::ZERO);
}

#[test]
fn thousandfold_model_gives_the_same_trace_up_to_scale() {
    assert_same_trace_under(1e3, DVec3::ZERO);
}

#[test]
fn tiny_minimum_distance_and_huge_isolevel_stay_finite_and_safe() {
    let b = common::build(&common::read("scans/demosthenes/demosthenes-low-res.obj"), common::small_nodes());
    // Minimum distance 1e-5 of the diagonal: zoom in as far as it goes.
    let mut deep = Script::new();
    for _ in 0..8 {
        deep = deep.pinch(0.05, 0.95, 0.5).wait(0.05);
    }
    let deep = deep.joystick(1, (0.2, 0.0), 1.0);
    let s = ExploreSettings { min_distance_fraction: 1e-5, ..ExploreSettings::default() };
    let t = replay::run(&b.store, &deep.session(), &s);
    assert_safe(&t);
    let diag = f64::from(b.store.bbox().diagonal());
    assert!(
        t.summary.min_surface_distance < 1e-2 * diag,
        "did not get close: {}",
        t.summary.min_surface_distance
    );
    // Isolevel 10³ × the diagonal: zoom far out, then hover (with the kiosk's distance bound
    // lifted: this is IsoCam's own numerical extreme).
    let mut far = Script::new();
    for _ in 0..10 {
        far = far.pinch(0.95, 0.05, 0.3).wait(0.05);
    }
    let far = far.joystick(1, (0.3, 0.1), 2.0);
    let unbounded = ExploreSettings { max_distance_factor: f64::INFINITY, ..ExploreSettings::default() };
    let t = replay::run(&b.store, &far.session(), &unbounded);
    assert_safe(&t);
    let max_iso = t.frames.iter().filter_map(|f| f.isolevel).fold(0.0, f64::max);
    assert!(max_iso > 1e3 * diag, "isolevel reached only {:.1} diagonals", max_iso / diag);
}

#[test]
fn view_parallel_to_up_from_the_start_is_handled() {
    let b = common::build(&common::read("scans/stanford-bunny/bun_zipper_res2.ply"), common::small_nodes());
    let scene = kiosk_core::camera::SceneRef { store: &b.store, cut: &kiosk_core::Cut::leaves(&b.store) };
    let c = b.store.to_model(b.store.bbox().center());
    let diag = f64::from(b.store.bbox().diagonal());
    // Straight above, looking straight down, with up = +Y (parallel to the view).
    let cam = kiosk_core::camera::Camera { eye: c + DVec3::Y * diag, target: c, up: DVec3::Y, fov_y: 0.8 };
    let mut iso =
        kiosk_core::camera::IsoCam::new(scene, cam, kiosk_core::camera::IsoCamSettings::for_model(diag));
    for k in 0..200 {
        let a = k as f64 * 0.1;
        iso.hover(scene, (0.01 * a.cos(), 0.01 * a.sin()));
        iso.zoom(scene, if k % 2 == 0 { 0.05 } else { -0.05 });
        let c = iso.camera();
        assert!(c.is_finite(), "step {k}: {c:?}");
        assert!(c.up.dot(c.forward()).abs() < 1e-6);
    }
}
