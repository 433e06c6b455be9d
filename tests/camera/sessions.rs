//! Scripted touch sessions on real scans through the replay harness; each asserts properties of
//! the trace.

use super::{Script, assert_safe, run, scan};
use crate::common;
use glam::DVec3;
use kiosk_core::camera::ControllerKind;
use kiosk_core::explore::ExploreSettings;

fn v(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

/// Total signed angle swept by the eye around the vertical axis through `center`.
fn azimuth_swept(trace: &kiosk_core::trace::Trace, center: DVec3) -> f64 {
    let mut total = 0.0;
    let az = |e: DVec3| (e.z - center.z).atan2(e.x - center.x);
    for w in trace.frames.windows(2) {
        let mut d = az(v(w[1].eye)) - az(v(w[0].eye));
        if d > std::f64::consts::PI {
            d -= std::f64::consts::TAU;
        } else if d < -std::f64::consts::PI {
            d += std::f64::consts::TAU;
        }
        total += d;
    }
    total
}

#[test]
fn hover_goes_around_the_whole_model_on_its_isolevel() {
    let b = scan("scans/stanford-bunny/bun_zipper.ply");
    let trace = run(&b.store, &Script::new().joystick(1, (0.25, 0.0), 25.0), ControllerKind::IsoCam);
    assert_safe(&trace);
    let center = b.store.to_model(b.store.bbox().center());
    let swept = azimuth_swept(&trace, center).abs();
    assert!(swept > std::f64::consts::TAU, "swept only {swept:.2} rad");
    // The isolevel is kept while hovering.
    let iso0 = trace.frames[0].isolevel.expect("isocam");
    for f in &trace.frames {
        let iso = f.isolevel.expect("isocam");
        assert!((iso - iso0).abs() <= 1e-9 * iso0, "hover changed the isolevel");
    }
    // The view keeps facing the model: the view ray passes through its bounding sphere.
    let radius = f64::from(b.store.bbox().diagonal()) * 0.5;
    for f in &trace.frames {
        let d = (v(f.target) - v(f.eye)).normalize();
        let to_c = center - v(f.eye);
        let miss = (to_c - d * to_c.dot(d)).length();
        assert!(to_c.dot(d) > 0.0 && miss < radius, "looking away at t={} (ray misses by {miss})", f.t);
    }
}

#[test]
fn zoom_reaches_the_minimum_distance_and_comes_back() {
    let b = scan("scans/demosthenes/demosthenes-low-res.obj");
    let script = Script::new()
        .pinch(0.1, 0.9, 1.0)
        .wait(0.2)
        .pinch(0.1, 0.9, 1.0)
        .wait(0.2)
        .pinch(0.1, 0.9, 1.0)
        .wait(0.2)
        .pinch(0.1, 0.9, 1.0);
    let trace = run(&b.store, &script, ControllerKind::IsoCam);
    assert_safe(&trace);
    let min = trace.frames[0].min_distance;
    let closest = trace.frames.iter().map(|f| f.surface_distance).fold(f64::INFINITY, f64::min);
    assert!(closest < min * 1.5, "zoom stopped at {closest}, minimum {min}");
    // And back out.
    let back = script.clone().wait(0.2).pinch(0.9, 0.1, 1.0).wait(0.2).pinch(0.9, 0.1, 1.0);
    let trace2 = run(&b.store, &back, ControllerKind::IsoCam);
    assert_safe(&trace2);
    let end = trace2.frames.last().expect("frames").surface_distance;
    assert!(end > 10.0 * closest, "zoomed back out only to {end}");
}

#[test]
fn large_isolevel_orbits_smoothly_between_disconnected_parts() {
    // Two busts side by side: a model with two disconnected parts.
    let pts = common::read("scans/stanford-bunny/bun_zipper_res2.ply");
    let diag = 0.25;
    let mut both = common::transform(&pts, 1.0, DVec3::new(-diag, 0.0, 0.0));
    both.extend(common::transform(&pts, 1.0, DVec3::new(diag, 0.0, 0.0)));
    let b = common::build(&both, common::small_nodes());
    let trace = run(&b.store, &Script::new().joystick(1, (0.3, 0.0), 12.0), ControllerKind::IsoCam);
    assert_safe(&trace);
    // Smooth: the eye never jumps, the view never snaps.
    let iso = trace.frames[0].isolevel.expect("isocam");
    for w in trace.frames.windows(2) {
        let step = (v(w[1].eye) - v(w[0].eye)).length();
        assert!(step < 0.1 * iso, "eye jumped by {step} (isolevel {iso}) at t={}", w[1].t);
        let d0 = (v(w[0].target) - v(w[0].eye)).normalize();
        let d1 = (v(w[1].target) - v(w[1].eye)).normalize();
        assert!(
            d0.dot(d1) > 5f64.to_radians().cos(),
            "view turned by more than 5° in a frame at t={}",
            w[1].t
        );
    }
    let center = b.store.to_model(b.store.bbox().center());
    assert!(azimuth_swept(&trace, center).abs() > std::f64::consts::PI);
}

/// Finger 2 circles `turn` radians around finger 1 (radius 0.2 screen heights) in about a
/// second, then both lift.
fn two_finger_rotation(turn: f64) -> Script {
    let mut s = Script::new().down(1, 0.4, 0.5).down(2, 0.4 + 0.2 / (16.0 / 9.0), 0.5);
    let n = 60;
    let at = |a: f64| (0.4 + 0.2 * a.cos() / (16.0 / 9.0), 0.5 - 0.2 * a.sin());
    for k in 1..=n {
        let a = turn * k as f64 / n as f64;
        s = s.wait(0.016);
        let (x, y) = at(a);
        s.events.push(kiosk_core::gesture::TouchEvent {
            t: s.t,
            ev: kiosk_core::gesture::TouchKind::Move,
            id: 2,
            x,
            y,
        });
    }
    let end = at(turn);
    s.up(1, 0.4, 0.5).up(2, end.0, end.1)
}

/// The roll of a trace frame's camera away from upright (+Y), radians.
fn roll(f: &kiosk_core::trace::Frame) -> f64 {
    let forward = (v(f.target) - v(f.eye)).normalize_or_zero();
    let upright = (DVec3::Y - forward * forward.dot(DVec3::Y)).normalize_or_zero();
    upright.dot(v(f.up)).clamp(-1.0, 1.0).acos()
}

#[test]
fn two_finger_rotation_twists_the_up_vector() {
    let b = scan("scans/stanford-bunny/bun_zipper_res2.ply");
    // A quarter turn: deliberate, so it stays after the fingers lift.
    let s = two_finger_rotation(std::f64::consts::FRAC_PI_2).wait(1.0).cancel(99);
    let trace = run(&b.store, &s, ControllerKind::IsoCam);
    let last = trace.frames.last().expect("frames");
    assert!(roll(last) > 80f64.to_radians(), "the twist stays: {:.1}°", roll(last).to_degrees());
    assert_safe(&trace);
    let first = v(trace.frames[0].up);
    let last = v(trace.frames.last().expect("frames").up);
    let angle = first.dot(last).clamp(-1.0, 1.0).acos();
    assert!(angle > 30f64.to_radians(), "up turned by only {:.1}°", angle.to_degrees());
    // Twisting never moves the eye off its isolevel.
    let iso = trace.frames[0].isolevel.expect("isocam");
    assert!(trace.frames.iter().all(|f| (f.isolevel.expect("isocam") - iso).abs() < 1e-3 * iso));
}

#[test]
fn a_small_twist_eases_back_upright_when_the_fingers_lift() {
    // A pinch turns the fingers a little: 12° here. While they are down the view rolls with
    // them; once they lift it comes back upright within a second, and the eye stays where it is.
    let b = scan("scans/stanford-bunny/bun_zipper_res2.ply");
    let s = two_finger_rotation(12f64.to_radians());
    let lift = s.t;
    let s = s.wait(1.0).cancel(99);
    let trace = run(&b.store, &s, ControllerKind::IsoCam);
    assert_safe(&trace);
    let at = |t: f64| trace.frames.iter().find(|f| f.t + 1e-9 >= t).expect("frame");
    let held = roll(at(lift - 0.02));
    assert!(
        (held - 12f64.to_radians()).abs() < 2f64.to_radians(),
        "rolled with the fingers: {:.1}°",
        held.to_degrees()
    );
    let later = at(lift + 0.15);
    assert!(
        roll(later) < 0.6 * held && roll(later) > 0.0,
        "eases, no snap: {:.1}°",
        roll(later).to_degrees()
    );
    let settled = at(lift + 1.0);
    assert!(roll(settled) < 1e-6, "upright again: {:.4}°", roll(settled).to_degrees());
    assert!((v(settled.eye) - v(at(lift).eye)).length() < 1e-9, "only the roll moves");
}

#[test]
fn looking_straight_down_is_held_at_the_tilt_limit() {
    let b = scan("scans/stanford-bunny/bun_zipper.ply");
    // Hover up, over the top and beyond.
    let trace = run(&b.store, &Script::new().joystick(1, (0.0, -0.3), 12.0), ControllerKind::IsoCam);
    assert_safe(&trace);
    let limit = 10f64.to_radians();
    let mut steepest: f64 = 0.0;
    for f in &trace.frames {
        let d = (v(f.target) - v(f.eye)).normalize();
        let tilt = d.dot(DVec3::Y).abs().acos();
        assert!(tilt >= limit - 1e-6, "view within {:.2}° of vertical", tilt.to_degrees());
        steepest = steepest.max(d.dot(DVec3::NEG_Y));
        // Up stays orthogonal to the view.
        assert!(v(f.up).dot(d).abs() < 1e-6);
    }
    assert!(steepest > 0.9 * limit.cos(), "never looked down (steepest {steepest})");
}

#[test]
fn long_press_opens_the_menu_and_holds_the_camera() {
    let b = scan("scans/demosthenes/demosthenes-low-res.obj");
    let s = Script::new()
        .down(1, 0.5, 0.5)
        .wait(1.5)
        .drag(&[(1, (0.5, 0.5), (0.5, 0.3))], 0.2)
        .wait(0.2)
        .up(1, 0.5, 0.3);
    let trace = run(&b.store, &s, ControllerKind::IsoCam);
    assert_safe(&trace);
    assert_eq!(trace.summary.menu_requests, 1);
    assert_eq!(trace.summary.menu_selections, 1);
    let open: Vec<_> = trace.frames.iter().filter(|f| f.menu.is_some()).collect();
    assert!(!open.is_empty());
    assert!(open.iter().all(|f| f.controller == "menu"));
    // A long press never moves the camera.
    let e0 = trace.frames[0].eye;
    assert!(trace.frames.iter().all(|f| f.eye == e0));
}

#[test]
fn ten_fingers_and_event_storms_never_break_the_camera() {
    let b = scan("scans/stanford-bunny/bun_zipper_res2.ply");
    let mut s = Script::new();
    for id in 0..10 {
        s = s.down(id, 0.05 + 0.09 * id as f64, 0.5);
    }
    // A storm: 2000 moves at the same timestamp, wild coordinates included.
    for k in 0..2000 {
        let id = k % 10;
        let x = if k % 97 == 0 {
            -5.0
        } else if k % 89 == 0 {
            7.0
        } else {
            (k as f64 * 0.37).sin() * 0.5 + 0.5
        };
        s.events.push(kiosk_core::gesture::TouchEvent {
            t: s.t,
            ev: kiosk_core::gesture::TouchKind::Move,
            id,
            x,
            y: 0.5,
        });
    }
    s = s.wait(0.5);
    for id in 0..10 {
        s = s.drag(&[(id, (0.5, 0.5), (0.5 + 0.04 * (id as f64 - 5.0), 0.2))], 0.05);
    }
    for id in 0..10 {
        s = if id % 2 == 0 { s.up(id, 0.5, 0.5) } else { s.cancel(id) };
    }
    let trace = run(&b.store, &s, ControllerKind::IsoCam);
    assert_safe(&trace);
}

#[test]
fn lost_ups_cancels_and_reused_ids_recover() {
    let b = scan("scans/stanford-bunny/bun_zipper_res2.ply");
    let s = Script::new()
        .down(1, 0.5, 0.5)
        .drag(&[(1, (0.5, 0.5), (0.7, 0.5))], 0.3)
        // The `up` of finger 1 is lost: it comes down again elsewhere.
        .down(1, 0.2, 0.8)
        .wait(0.5)
        .cancel(1)
        .up(1, 0.2, 0.8)
        .up(42, 0.1, 0.1)
        .wait(0.5);
    let trace = run(&b.store, &s, ControllerKind::IsoCam);
    assert_safe(&trace);
    // After the cancel nothing moves.
    let tail: Vec<_> = trace.frames.iter().filter(|f| f.t > 1.0).collect();
    assert!(tail.windows(2).all(|w| w[0].eye == w[1].eye));
}

#[test]
fn zoom_bar_on_the_left_edge_zooms() {
    let b = scan("scans/demosthenes/demosthenes-low-res.obj");
    let s = Script::new().down(1, 0.03, 0.8).drag(&[(1, (0.03, 0.8), (0.03, 0.2))], 1.0).up(1, 0.03, 0.2);
    let trace = run(&b.store, &s, ControllerKind::IsoCam);
    assert_safe(&trace);
    let first = trace.frames[0].surface_distance;
    let last = trace.frames.last().expect("frames").surface_distance;
    assert!(last < 0.5 * first, "zoom bar: {first} → {last}");
    assert!(trace.frames.iter().any(|f| f.controller == "zoom"));
}

#[test]
fn trackball_rotates_about_the_centre_and_can_collide() {
    let b = scan("scans/stanford-bunny/bun_zipper.ply");
    let center = b.store.to_model(b.store.bbox().center());
    let trace = run(&b.store, &Script::new().joystick(1, (0.25, 0.0), 4.0), ControllerKind::Trackball);
    let r0 = (v(trace.frames[0].eye) - center).length();
    for f in &trace.frames {
        assert!(((v(f.eye) - center).length() - r0).abs() < 1e-9 * r0, "trackball left its sphere");
    }
    assert!(azimuth_swept(&trace, center).abs() > 1.0);
    // Pinching in far enough goes through the surface: the trackball does not prevent it.
    let deep =
        Script::new().pinch(0.1, 0.9, 1.0).wait(0.1).pinch(0.1, 0.9, 1.0).wait(0.1).pinch(0.1, 0.9, 1.0);
    let t = run(&b.store, &deep, ControllerKind::Trackball);
    assert!(t.summary.collisions > 0, "expected the baseline to collide");
    let iso = run(&b.store, &deep, ControllerKind::IsoCam);
    assert_safe(&iso);
}

#[test]
fn acevit_recentres_its_pivot_when_the_interaction_ends() {
    let b = scan("scans/demosthenes/demosthenes-low-res.obj");
    let s = Script::new().pinch(0.1, 0.6, 0.5).wait(0.3).joystick(1, (0.2, 0.0), 1.0).wait(0.5);
    let trace = run(&b.store, &s, ControllerKind::Acevit);
    for f in &trace.frames {
        assert!(f.eye.iter().all(|x| x.is_finite()));
    }
    // It moved, and the pivot logic kept the model in front of the camera.
    let last = trace.frames.last().expect("frames");
    assert_ne!(trace.frames[0].eye, last.eye);
    let center = b.store.to_model(b.store.bbox().center());
    let d = (v(last.target) - v(last.eye)).normalize();
    assert!(d.dot((center - v(last.eye)).normalize()) > 0.5);
}

#[test]
fn replay_is_byte_identical_and_the_cli_writes_the_trace() {
    let script = Script::new().joystick(1, (0.2, 0.1), 1.0).wait(0.2).pinch(0.2, 0.5, 0.5);
    let dir = tempfile::tempdir().expect("tmp");
    let session = dir.path().join("s.jsonl");
    std::fs::write(&session, script.session().to_jsonl()).expect("write session");
    let exe = env!("CARGO_BIN_EXE_kiosk");
    let exhibit = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("content/demosthenes");
    let mut traces = Vec::new();
    for (i, controller) in ["isocam", "isocam", "trackball", "acevit"].iter().enumerate() {
        let out = dir.path().join(format!("t{i}.jsonl"));
        let st = std::process::Command::new(exe)
            .env("ISOKIOSK_CACHE", crate::common::cache())
            .args(["replay", "--exhibit"])
            .arg(&exhibit)
            .arg("--session")
            .arg(&session)
            .arg("--trace")
            .arg(&out)
            .args(["--controller", controller, "--seed", "3"])
            .output()
            .expect("run kiosk");
        assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
        traces.push(std::fs::read(&out).expect("trace"));
    }
    assert_eq!(traces[0], traces[1], "same inputs must give byte-identical traces");
    assert_ne!(traces[0], traces[2]);
    let text = String::from_utf8(traces[0].clone()).expect("utf8");
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].contains("\"trace\":1"));
    assert!(lines.last().expect("summary").starts_with("{\"summary\":"));
    for key in [
        "\"eye\"",
        "\"target\"",
        "\"up\"",
        "\"surface_distance\"",
        "\"min_distance\"",
        "\"controller\"",
        "\"recommender\"",
        "\"node\"",
        "\"overlay\"",
        "\"menu\"",
    ] {
        assert!(lines[1].contains(key), "trace line lacks {key}");
    }
    // A malformed session is a clear error naming the line.
    std::fs::write(&session, "{\"t\":0,\"ev\":\"down\",\"id\":1,\"x\":0.5,\"y\":0.5}\n{oops}\n")
        .expect("write");
    let st = std::process::Command::new(exe)
        .env("ISOKIOSK_CACHE", crate::common::cache())
        .args(["replay", "--exhibit"])
        .arg(&exhibit)
        .arg("--session")
        .arg(&session)
        .arg("--trace")
        .arg(dir.path().join("bad.jsonl"))
        .output()
        .expect("run kiosk");
    assert!(!st.status.success());
    assert!(
        String::from_utf8_lossy(&st.stderr).contains("line 2"),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let _ = ExploreSettings::default();
}

#[test]
fn goto_eases_in_and_out_and_never_passes_through_the_model() {
    use kiosk_core::camera::{Camera, GoTo, SceneRef};
    let b = scan("scans/stanford-bunny/bun_zipper.ply");
    let cut = kiosk_core::Cut::leaves(&b.store);
    let scene = SceneRef { store: &b.store, cut: &cut };
    let c = scene.center();
    let diag = scene.diagonal();
    // From the front to the back: the straight line crosses the bunny.
    let from = Camera { eye: c + DVec3::Z * 0.6 * diag, target: c, up: DVec3::Y, fov_y: 0.8 };
    let to = Camera { eye: c - DVec3::Z * 0.6 * diag, target: c, up: DVec3::Y, fov_y: 0.8 };
    let anim = GoTo { from, to, start: 1.0, duration: 2.0 };
    let min = 0.01 * diag;
    let mut eyes = Vec::new();
    for k in 0..=180 {
        let t = 1.0 + k as f64 / 60.0;
        let cam = anim.camera_at(t, scene, min);
        assert!(cam.is_finite());
        let (d, _) = b.store.nearest_sample(cam.eye).expect("finite");
        assert!(d >= min * 0.99, "go-to passed within {d} of the surface at t={t}");
        eyes.push(cam.eye);
    }
    assert!((eyes[0] - from.eye).length() < 1e-12);
    assert!(anim.done(3.0) && !anim.done(2.9));
    assert_eq!(anim.camera_at(3.5, scene, min).target, to.target);
    // Ease in and out: slow at both ends, faster in the middle.
    let speed = |k: usize| (eyes[k + 1] - eyes[k]).length();
    assert!(speed(0) < 0.2 * speed(60) && speed(118) < 0.2 * speed(60));
}

#[test]
fn zooming_out_is_bounded_and_eases_back_for_every_controller() {
    let b = scan("scans/stanford-bunny/bun_zipper_res2.ply");
    let center = b.store.to_model(b.store.bbox().center());
    // Three pinches in, each a ninefold zoom out, then three seconds without a touch.
    let script = Script::new()
        .pinch(0.9, 0.1, 1.0)
        .wait(0.1)
        .pinch(0.9, 0.1, 1.0)
        .wait(0.1)
        .pinch(0.9, 0.1, 1.0)
        .wait(3.0)
        .cancel(99);
    for kind in [ControllerKind::IsoCam, ControllerKind::Trackball, ControllerKind::Acevit] {
        let trace = run(&b.store, &script, kind);
        let dist: Vec<f64> = trace.frames.iter().map(|f| (v(f.eye) - center).length()).collect();
        // The initial view is the framing view: the bound is three times its distance.
        let bound = ExploreSettings::default().max_distance_factor * dist[0];
        let far = dist.iter().copied().fold(0.0, f64::max);
        assert!(far > bound, "{kind:?}: the pinches never reached the bound ({far} vs {bound})");
        assert!(far <= 1.6 * bound, "{kind:?}: flew away to {:.2} × the bound", far / bound);
        let last = *dist.last().expect("frames");
        assert!(last <= bound * (1.0 + 1e-6), "{kind:?}: ended at {:.4} × the bound", last / bound);
        // Smoothly: no jump from one frame to the next once the fingers are up.
        let idle_from =
            trace.frames.iter().position(|f| f.t > script.session().duration() - 2.9).expect("tail");
        for w in dist[idle_from..].windows(2) {
            assert!(
                (w[1] - w[0]).abs() < 0.1 * bound,
                "{kind:?}: jumped by {:.3} × the bound",
                (w[1] - w[0]).abs() / bound
            );
        }
    }
}

#[test]
fn acevit_recentres_on_what_a_portrait_screen_shows() {
    use kiosk_core::camera::{Acevit, AcevitSettings, Camera, SceneRef};
    use rand::SeedableRng;
    let b = scan("scans/stanford-bunny/bun_zipper_res2.ply");
    let cut = kiosk_core::Cut::leaves(&b.store);
    let scene = SceneRef { store: &b.store, cut: &cut };
    let center = scene.center();
    let aspect = 9.0 / 16.0;
    let cam0 = kiosk_core::camera::initial_camera(&b.store, 0.8, DVec3::Y);
    // Turn the view left so that the model's centre is 2.2 half-widths right of a portrait
    // screen's centre: only the model's left edge is on screen (a 16:9 screen would show most).
    let angle = (2.2 * aspect * (cam0.fov_y * 0.5).tan()).atan();
    let dir = kiosk_core::camera::rotate(cam0.forward(), DVec3::Y, angle);
    let cam = Camera { target: cam0.eye + dir * (center - cam0.eye).length(), ..cam0 };
    let (x, _, _) = cam.ndc(center, aspect).expect("in front");
    assert!((x - 2.2).abs() < 1e-6, "set-up: centre at x = {x}");
    let settings = AcevitSettings { samples: 4096, sigma_xy: 0.5, sigma_depth: 0.5, min_radius: 0.0, aspect };
    let pivot = Acevit::new(cam, settings)
        .recenter(scene, &mut rand_pcg::Pcg64::seed_from_u64(5))
        .expect("part of the model is on screen");
    let (px, py, _) = cam.ndc(pivot, aspect).expect("pivot in front");
    assert!(px.abs() <= 1.0 && py.abs() <= 1.0, "the pivot is off the portrait screen at ({px:.3}, {py:.3})");
}
