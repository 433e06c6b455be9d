//! Properties: random gesture sequences never bring the eye closer than the minimum distance,
//! never produce NaN; long hovers keep the isolevel.

use super::{Script, assert_safe, run};
use crate::common;
use kiosk_core::camera::ControllerKind;
use kiosk_core::camera::{IsoCam, IsoCamSettings, SceneRef};
use proptest::prelude::*;
use std::sync::OnceLock;

fn bunny() -> &'static common::Built {
    static B: OnceLock<common::Built> = OnceLock::new();
    B.get_or_init(|| {
        common::build(&common::read("scans/stanford-bunny/bun_zipper_res2.ply"), common::small_nodes())
    })
}

#[derive(Clone, Debug)]
enum Gesture {
    Joystick { dx: f64, dy: f64, secs: f64 },
    Pinch { d0: f64, d1: f64, secs: f64 },
    Tap { x: f64, y: f64 },
    Wild { x: f64, y: f64 },
}

fn gesture() -> impl Strategy<Value = Gesture> {
    prop_oneof![
        (-0.5..0.5f64, -0.5..0.5f64, 0.05..1.5f64).prop_map(|(dx, dy, secs)| Gesture::Joystick {
            dx,
            dy,
            secs
        }),
        (0.02..0.95f64, 0.02..0.95f64, 0.05..1.0f64).prop_map(|(d0, d1, secs)| Gesture::Pinch {
            d0,
            d1,
            secs
        }),
        (0.0..1.0f64, 0.0..1.0f64).prop_map(|(x, y)| Gesture::Tap { x, y }),
        (-10.0..10.0f64, -10.0..10.0f64).prop_map(|(x, y)| Gesture::Wild { x, y }),
    ]
}

fn script(gs: &[Gesture]) -> Script {
    let mut s = Script::new();
    for g in gs {
        s = match *g {
            Gesture::Joystick { dx, dy, secs } => s.joystick(1, (dx, dy), secs),
            Gesture::Pinch { d0, d1, secs } => s.pinch(d0, d1, secs),
            Gesture::Tap { x, y } => s.down(3, x, y).wait(0.05).up(3, x, y),
            Gesture::Wild { x, y } => s.down(4, 0.5, 0.5).drag(&[(4, (0.5, 0.5), (x, y))], 0.2).up(4, x, y),
        }
        .wait(0.05);
    }
    s
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    #[test]
    fn random_gestures_never_collide_nor_produce_nan(gs in prop::collection::vec(gesture(), 1..6)) {
        let trace = run(&bunny().store, &script(&gs), ControllerKind::IsoCam);
        assert_safe(&trace);
    }
}

#[test]
fn hundred_thousand_hover_steps_keep_the_isolevel() {
    let b = common::build(&common::read("scans/demosthenes/demosthenes-low-res.obj"), common::small_nodes());
    let cut = kiosk_core::Cut::leaves(&b.store);
    let scene = SceneRef { store: &b.store, cut: &cut };
    let cam = kiosk_core::camera::initial_camera(&b.store, 0.8, glam::DVec3::Y);
    let settings = IsoCamSettings::for_model(scene.diagonal());
    let mut iso = IsoCam::new(scene, cam, settings);
    let level = iso.isolevel();
    let mut worst: f64 = 0.0;
    let mut steps = 0u64;
    let mut k = 0u64;
    while steps < 100_000 {
        // A slowly turning direction: around and over the model.
        let a = k as f64 * 0.002;
        iso.hover(scene, (0.01 * a.cos(), 0.01 * (0.3 * a).sin()));
        steps += u64::from(iso.last.steps);
        worst = worst.max(iso.last.iso_error);
        k += 1;
        let f = scene.store.fine_target(scene.cut, iso.camera().eye, &settings.query).expect("finite");
        let d = (iso.camera().eye - f.point).length();
        assert!(
            (d - level).abs() <= settings.reproject_tolerance * level * 1.0001,
            "drift: {d} vs {level} after {steps} steps"
        );
    }
    assert!(worst <= settings.reproject_tolerance);
    assert_eq!(iso.isolevel(), level);
}

/// IsoCam on the bunny's leaves, from the initial framing view.
fn isocam_on_bunny(
    cut: &kiosk_core::Cut,
    edit: impl FnOnce(&mut IsoCamSettings),
) -> (IsoCam, SceneRef<'_, memmap2::Mmap>) {
    let b = bunny();
    let scene = SceneRef { store: &b.store, cut };
    let cam = kiosk_core::camera::initial_camera(&b.store, 0.8, glam::DVec3::Y);
    let mut settings = IsoCamSettings::for_model(scene.diagonal());
    edit(&mut settings);
    (IsoCam::new(scene, cam, settings), scene)
}

#[test]
fn zoom_moves_along_the_view_direction_after_a_hover() {
    let cut = kiosk_core::Cut::leaves(&bunny().store);
    let (mut iso, scene) = isocam_on_bunny(&cut, |_| {});
    // One large hover: the smoothed view lags behind the new coarse target.
    iso.hover(scene, (0.4, 0.15));
    let before = iso.camera();
    let to_coarse = (iso.coarse_target() - before.eye).normalize();
    let lag = before.forward().dot(to_coarse).clamp(-1.0, 1.0).acos();
    assert!(
        lag > 1f64.to_radians(),
        "view and coarse target agree ({:.3}°): nothing to test",
        lag.to_degrees()
    );
    iso.zoom(scene, 0.3);
    let after = iso.camera();
    let moved = after.eye - before.eye;
    assert!(moved.length() > 1e-3 * scene.diagonal(), "the zoom did not move");
    let off_axis = moved.normalize().cross(before.forward()).length();
    assert!(off_axis < 1e-9, "the eye left the line of sight (sin {off_axis:e})");
    assert!(moved.dot(before.forward()) > 0.0, "zoom in went backward");
    assert!((after.forward() - before.forward()).length() < 1e-12, "the view turned");
}

#[test]
fn a_view_steeper_than_the_tilt_limit_is_kept_and_relaxes_without_a_snap() {
    let b = bunny();
    let cut = kiosk_core::Cut::leaves(&b.store);
    let scene = SceneRef { store: &b.store, cut: &cut };
    let settings = IsoCamSettings::for_model(scene.diagonal());
    let center = b.store.to_model(b.store.bbox().center());
    // Looking down, 4° from vertical (the limit is 10°).
    let tilt = 4f64.to_radians();
    let from = glam::DVec3::new(tilt.sin(), tilt.cos(), 0.0);
    let eye = center + from * scene.diagonal();
    let steep = kiosk_core::camera::Camera {
        eye,
        target: center,
        up: kiosk_core::camera::orthonormal_up(-from, glam::DVec3::NEG_X, glam::DVec3::Z),
        fov_y: 0.8,
    };
    assert!(settings.exceeds_tilt_limit(&steep));
    assert!(!settings.exceeds_tilt_limit(&kiosk_core::camera::initial_camera(&b.store, 0.8, glam::DVec3::Y)));
    // Reset (the end of a go-to) keeps the view exactly.
    let mut iso = IsoCam::new(scene, steep, settings);
    let c = iso.camera();
    assert!((c.forward() - steep.forward()).length() < 1e-12, "{:?} vs {:?}", c.forward(), steep.forward());
    assert!((c.up - steep.up).length() < 1e-9, "{:?} vs {:?}", c.up, steep.up);
    assert_eq!(c.eye, steep.eye);
    // Hovering relaxes it toward the limit a little at a time.
    let mut prev = c.forward();
    for _ in 0..300 {
        iso.hover(scene, (0.02, 0.0));
        let d = iso.camera().forward();
        let turn = prev.dot(d).clamp(-1.0, 1.0).acos();
        assert!(turn < 5f64.to_radians(), "the view snapped by {:.2}°", turn.to_degrees());
        prev = d;
    }
    let tilt = iso.camera().forward().dot(glam::DVec3::Y).abs().acos().to_degrees();
    assert!(!settings.exceeds_tilt_limit(&iso.camera()), "never relaxed to the limit (tilt {tilt:.2}°)");
}

#[test]
fn a_hover_longer_than_the_step_cap_is_clamped_not_stretched() {
    let cut = kiosk_core::Cut::leaves(&bunny().store);
    let (mut iso, scene) = isocam_on_bunny(&cut, |s| s.max_steps_per_frame = 4);
    let level = iso.isolevel();
    let eye0 = iso.camera().eye;
    // One viewport height: about 0.84 isolevels of travel, 17 steps of 5 %.
    iso.hover(scene, (1.0, 0.0));
    assert_eq!(iso.last.steps, 4);
    let moved = (iso.camera().eye - eye0).length();
    // At most 4 steps of 5 % of the isolevel (re-projection moves the eye a little more).
    assert!(moved <= 4.0 * 0.05 * level * 1.1, "moved {:.3} isolevels", moved / level);
    assert!(moved >= 4.0 * 0.05 * level * 0.5, "moved only {:.3} isolevels", moved / level);
}

#[test]
fn iso_error_is_the_error_where_the_eye_ended() {
    let cut = kiosk_core::Cut::leaves(&bunny().store);
    // One re-projection per step and a single large step: re-projection stops after one move.
    let (mut iso, scene) = isocam_on_bunny(&cut, |s| {
        s.reproject_max_iterations = 1;
        s.max_step = 1.0;
    });
    let level = iso.isolevel();
    iso.hover(scene, (0.3, 0.2));
    assert_eq!(iso.last.steps, 1);
    let eye = iso.camera().eye;
    let f = scene.store.fine_target(scene.cut, eye, &iso.settings.query).expect("target");
    let actual = ((eye - f.point).length() - level).abs() / level;
    assert!(
        (iso.last.iso_error - actual).abs() <= 1e-12,
        "reported {:e}, actual {:e}",
        iso.last.iso_error,
        actual
    );
}

#[test]
fn levelling_eases_small_twists_to_the_rest_roll_and_keeps_deliberate_ones() {
    use kiosk_core::camera::{Intent, rotate};
    let b = bunny();
    let cut = kiosk_core::Cut::leaves(&b.store);
    let scene = SceneRef { store: &b.store, cut: &cut };
    let settings = IsoCamSettings::for_model(scene.diagonal());
    let start = kiosk_core::camera::initial_camera(&b.store, 0.8, glam::DVec3::Y);
    // A node's view rolled by 8° (set from outside, as at the end of a go-to) is its rest roll.
    let node =
        kiosk_core::camera::Camera { up: rotate(start.up, start.forward(), 8f64.to_radians()), ..start };
    let mut iso = IsoCam::new(scene, node, settings);
    let roll_from = |c: kiosk_core::camera::Camera, of: kiosk_core::camera::Camera| {
        c.up.dot(of.up).clamp(-1.0, 1.0).acos().to_degrees()
    };
    let settle = |iso: &mut IsoCam| (0..60).for_each(|_| iso.level(1.0 / 60.0));
    settle(&mut iso);
    assert!(roll_from(iso.camera(), node) < 1e-6, "the node's roll stays");
    let twist = |iso: &mut IsoCam, degrees: f64| {
        iso.apply(scene, &Intent { twist: f64::to_radians(degrees), ..Intent::default() })
    };
    // 15° more: within the 20° detent, back to the node's roll.
    twist(&mut iso, 15.0);
    assert!((roll_from(iso.camera(), node) - 15.0).abs() < 1e-6);
    settle(&mut iso);
    assert!(roll_from(iso.camera(), node) < 1e-6, "back to the node's roll");
    // 50°: deliberate, it stays and becomes the rest roll; 10° more eases back to it.
    twist(&mut iso, -50.0);
    settle(&mut iso);
    let turned = iso.camera();
    assert!((roll_from(turned, node) - 50.0).abs() < 1e-6, "a deliberate twist stays");
    twist(&mut iso, 10.0);
    settle(&mut iso);
    assert!(roll_from(iso.camera(), turned) < 1e-6, "back to the deliberate roll");
    // Straightening a deliberate twist by hand: from −42° (the node's 8° less 50°) back to −7°,
    // within 20° of upright: it eases upright (and upright is the rest again).
    twist(&mut iso, 35.0);
    settle(&mut iso);
    assert!(roll_from(iso.camera(), start) < 1e-6, "upright after straightening by hand");
    // A flight interrupted halfway leaves its roll (12° here) to no one: it eases upright.
    let halfway =
        kiosk_core::camera::Camera { up: rotate(start.up, start.forward(), 12f64.to_radians()), ..start };
    iso.reset(scene, halfway);
    settle(&mut iso);
    assert!(roll_from(iso.camera(), halfway) < 1e-6, "a view set from outside keeps its roll");
    iso.reset(scene, halfway);
    iso.rest_upright();
    settle(&mut iso);
    assert!(roll_from(iso.camera(), start) < 1e-6, "upright once the rest is");
    // With the detent at 0, every twist stays.
    let mut free = IsoCam::new(scene, start, IsoCamSettings { level_snap: 0.0, ..settings });
    free.apply(scene, &Intent { twist: 5f64.to_radians(), ..Intent::default() });
    settle(&mut free);
    assert!((roll_from(free.camera(), start) - 5.0).abs() < 1e-6);
}
