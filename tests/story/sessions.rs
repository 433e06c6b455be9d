//! Scripted touch sessions with an information graph, through the replay harness: a node
//! reached by attraction, a proposal accepted by a long press, a proposal ignored, the radial
//! menu.

use super::node;
use crate::common;
use glam::DVec3;
use kiosk_core::explore::ExploreSettings;
use kiosk_core::graph::InfoGraph;
use kiosk_core::replay;
use kiosk_core::session::Script;
use kiosk_core::trace::Trace;

struct Exhibit {
    built: common::Built,
    center: DVec3,
    eye0: DVec3,
}

fn exhibit() -> Exhibit {
    let built =
        common::build(&common::read("scans/demosthenes/demosthenes-low-res.obj"), common::small_nodes());
    let center = built.store.to_model(built.store.bbox().center());
    let eye0 = kiosk_core::camera::initial_camera(&built.store, 0.8, DVec3::Y).eye;
    Exhibit { built, center, eye0 }
}

impl Exhibit {
    /// A view from the initial eye orbited by `deg` about the vertical axis through the centre.
    fn orbited(&self, id: &str, deg: f64) -> kiosk_core::graph::Node {
        let a = deg.to_radians();
        let r = self.eye0 - self.center;
        let eye =
            self.center + DVec3::new(r.x * a.cos() + r.z * a.sin(), r.y, -r.x * a.sin() + r.z * a.cos());
        node(id, eye, self.center, 1.0)
    }

    fn run(&self, graph: &InfoGraph, script: &Script) -> Trace {
        replay::run_story(&self.built.store, &script.session(), &ExploreSettings::default(), Some(graph))
    }
}

/// Four views around the start view: one far behind, two beside it, one near it.
fn four_views(ex: &Exhibit) -> InfoGraph {
    graph(vec![
        ex.orbited("far", 150.0),
        ex.orbited("left", -12.0),
        ex.orbited("right", 20.0),
        ex.orbited("near", 4.0),
    ])
}

fn graph(nodes: Vec<kiosk_core::graph::Node>) -> InfoGraph {
    InfoGraph { default_lang: "en".into(), nodes, edges: vec![] }
}

fn states(t: &Trace) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for f in &t.frames {
        let s = f.recommender.clone().unwrap_or_default();
        if v.last() != Some(&s) {
            v.push(s);
        }
    }
    v
}

#[test]
fn a_node_is_reached_by_attraction() {
    let ex = exhibit();
    let g = graph(vec![ex.orbited("side", 70.0)]);
    // Nobody touches: the engine attracts toward the side view, finds the camera within its
    // accept distance and flies there (a touch during the flight would take the camera:
    // `moving_during_a_flight_takes_the_camera_where_it_is`).
    let t = ex.run(&g, &Script::new().wait(13.5).cancel(99));
    let s = states(&t);
    assert_eq!(t.summary.nodes_displayed, vec!["side".to_string()], "states {s:?}");
    let goto = s.iter().position(|x| x == "go-to").expect("go-to");
    assert!(
        s[..goto].contains(&"attract".to_string()) && !s[..goto].contains(&"propose".to_string()),
        "{s:?}"
    );
    assert!(t.frames.iter().any(|f| f.overlay.as_deref() == Some("side")));
    assert_eq!(t.summary.collisions, 0);
}

#[test]
fn a_proposal_is_accepted_with_a_long_press() {
    let ex = exhibit();
    let g = graph(vec![ex.orbited("back", 180.0)]);
    // Discover (3 s) + attract (8 s): proposed at ~11 s; long press at 12 s.
    let t = ex
        .run(&g, &Script::new().wait(12.0).down(1, 0.5, 0.5).wait(1.0).up(1, 0.5, 0.5).wait(3.0).cancel(99));
    assert_eq!(t.summary.proposals_accepted, 1, "{:?}", states(&t));
    assert_eq!(
        t.summary.menu_requests, 0,
        "the long press accepted the proposal instead of opening the menu"
    );
    assert_eq!(t.summary.nodes_displayed, vec!["back".to_string()]);
    let last = t.frames.last().expect("frames");
    assert_eq!(last.overlay.as_deref(), Some("back"));
    // The go-to ended at the node's view.
    let view = g.nodes[0].view;
    assert!(
        (DVec3::from_array(last.eye) - view.eye).length()
            < 1e-6 * f64::from(ex.built.store.bbox().diagonal()).max(1.0)
    );
}

#[test]
fn an_ignored_proposal_times_out_back_to_discover() {
    let ex = exhibit();
    let g = graph(vec![ex.orbited("back", 180.0)]);
    // (A touch-less session: a final ignored event sets its length.)
    let t = ex.run(&g, &Script::new().wait(21.0).cancel(99));
    let s = states(&t);
    assert!(t.summary.proposals_ignored >= 1, "{s:?}");
    assert!(t.summary.nodes_displayed.is_empty());
    let p = s.iter().position(|x| x == "propose").expect("proposed");
    assert_eq!(s.get(p + 1).map(String::as_str), Some("discover"), "{s:?}");
}

#[test]
fn the_radial_menu_offers_nearby_views_and_selects_by_direction() {
    let ex = exhibit();
    let g = four_views(&ex);
    // Long press during discover: the menu; point up (the nearest slot) and release.
    let t = ex.run(
        &g,
        &Script::new()
            .down(1, 0.5, 0.5)
            .wait(1.0)
            .drag(&[(1, (0.5, 0.5), (0.5, 0.3))], 0.2)
            .wait(0.1)
            .up(1, 0.5, 0.3)
            .wait(3.0)
            .cancel(99),
    );
    assert_eq!(t.summary.menu_requests, 1);
    let open = t.frames.iter().find(|f| f.menu.is_some()).expect("menu shown");
    let cands = &open.menu.as_ref().expect("menu").candidates;
    assert_eq!(cands.first().map(String::as_str), Some("near"), "nearest first: {cands:?}");
    assert!(!cands.contains(&"far".to_string()), "a view from behind is not offered: {cands:?}");
    assert_eq!(t.summary.nodes_displayed, vec!["near".to_string()], "{:?} {:?}", states(&t), t.summary);
    // The overlay stays until the visitor moves away.
    assert_eq!(t.frames.last().expect("frames").overlay.as_deref(), Some("near"));
}

#[test]
fn the_radial_menu_does_not_offer_the_view_on_display() {
    let ex = exhibit();
    let g = graph(vec![ex.orbited("left", -12.0), ex.orbited("right", 20.0), ex.orbited("near", 4.0)]);
    // Pick the nearest view; while its overlay stays, open the menu again and let go.
    let t = ex.run(
        &g,
        &Script::new()
            .down(1, 0.5, 0.5)
            .wait(1.0)
            .drag(&[(1, (0.5, 0.5), (0.5, 0.3))], 0.2)
            .wait(0.1)
            .up(1, 0.5, 0.3)
            .wait(3.0)
            .down(1, 0.5, 0.5)
            .wait(1.5)
            .up(1, 0.5, 0.5)
            .wait(0.5)
            .cancel(99),
    );
    assert_eq!(t.summary.menu_requests, 2, "{:?}", t.summary);
    let second = t
        .frames
        .iter()
        .filter(|f| f.t > 4.0 && f.overlay.as_deref() == Some("near"))
        .find_map(|f| f.menu.as_ref())
        .expect("the menu opened over the displayed view");
    assert!(!second.candidates.is_empty(), "the other views are offered");
    assert!(!second.candidates.contains(&"near".to_string()), "{:?}", second.candidates);
}

#[test]
fn kiosk_replay_runs_the_story_of_an_exhibit_directory() {
    let ex = exhibit();
    let g = graph(vec![ex.orbited("left", -12.0), ex.orbited("near", 4.0), ex.orbited("back", 180.0)]);
    let dir = tempfile::tempdir().expect("tmp");
    std::fs::copy(common::data("scans/demosthenes/demosthenes-low-res.obj"), dir.path().join("bust.obj"))
        .expect("model");
    std::fs::write(dir.path().join("graph.xml"), g.to_xml()).expect("graph");
    let script = Script::new()
        .down(1, 0.5, 0.5)
        .wait(1.0)
        .drag(&[(1, (0.5, 0.5), (0.5, 0.3))], 0.2)
        .wait(0.1)
        .up(1, 0.5, 0.3)
        .wait(3.0)
        .cancel(99);
    let session = dir.path().join("s.jsonl");
    std::fs::write(&session, script.session().to_jsonl()).expect("session");
    let trace = dir.path().join("t.jsonl");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .env("ISOKIOSK_CACHE", crate::common::cache())
        .args(["replay", "--exhibit"])
        .arg(dir.path())
        .arg("--session")
        .arg(&session)
        .arg("--trace")
        .arg(&trace)
        .output()
        .expect("run kiosk");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&trace).expect("trace");
    assert!(text.contains(r#""menu":{"open":true,"candidates":["near","left"]}"#), "menu not traced");
    assert!(text.contains(r#""recommender":"display","node":"near","overlay":"near""#), "overlay not traced");
    assert!(text.lines().last().expect("summary").contains(r#""nodes_displayed":["near"]"#));
}

#[test]
fn the_demo_exhibit_story_loads_without_problems() {
    demo_exhibit_loads_and_plays("demosthenes");
}

#[test]
fn the_nefertiti_exhibit_story_loads_without_problems() {
    demo_exhibit_loads_and_plays("nefertiti");
}

#[test]
fn the_belweder_exhibit_is_a_coloured_scan_of_a_million_samples_with_its_story() {
    demo_exhibit_loads_and_plays("belweder");
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("content/belweder");
    let (g, _) = kiosk_content::exhibit::open_graph(&dir).expect("readable").expect("a graph.xml");
    // Every medium resolves inside the exhibit, as the kiosk opens it; the overlays are labelled
    // drawings (SVG text).
    for n in &g.nodes {
        let files = n.overlay.0.values().chain(n.narration.0.values()).chain(&n.thumbnail).chain(&n.roi_mask);
        for f in files {
            kiosk_content::media::resolve(&dir, f).unwrap_or_else(|e| panic!("{}: {e}", n.id));
        }
        for (lang, f) in &n.overlay.0 {
            let svg = std::fs::read_to_string(dir.join(f)).expect("overlay");
            assert!(f.ends_with(".svg") && svg.contains("<text"), "{}/{lang}: {f}", n.id);
        }
    }
    // The glTF is imported at texel density: over a million samples, each with its texture's
    // colour (alpha 255), and the colours are those of a wooden cabinet, not a grey default.
    let store = kiosk_content::exhibit::open_model_in(&dir, &crate::common::cache()).expect("model");
    let h = store.header();
    assert!(h.leaf_point_count >= 1_000_000, "{} samples", h.leaf_point_count);
    let (mut coloured, mut warm, mut leaves) = (0u64, 0u64, 0u64);
    for (i, node) in store.nodes().iter().enumerate() {
        if !node.is_leaf() {
            continue;
        }
        for s in store.splats(i as u32) {
            leaves += 1;
            coloured += u64::from(s.color[3] == 255);
            warm += u64::from(i32::from(s.color[0]) - i32::from(s.color[2]) > 25);
        }
    }
    assert_eq!(leaves, h.leaf_point_count);
    assert_eq!(coloured, leaves, "every sample has a colour");
    assert!(warm * 5 > leaves, "the wood's warm colours: {warm} of {leaves}");
}

/// A demo exhibit of `content/`: its graph loads without problems, uses mandatory, strong and
/// weak dependencies, every node has its texts, media, thumbnail and ROI in both languages (the
/// files exist), and a visitor who waits is shown the introduction first.
fn demo_exhibit_loads_and_plays(name: &str) {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("content").join(name);
    let (g, problems) = kiosk_content::exhibit::open_graph(&dir).expect("readable").expect("a graph.xml");
    assert!(problems.is_empty(), "{name}: {problems:?}");
    assert!(g.nodes.len() >= 8, "{name}: {} nodes", g.nodes.len());
    for w in [1.0, 0.8, 0.2] {
        assert!(g.edges.iter().any(|e| e.weight == w), "{name}: no edge of weight {w}");
    }
    for n in &g.nodes {
        for lang in ["en", "it"] {
            assert!(n.title.0.contains_key(lang) && n.text.0.contains_key(lang), "{}: no {lang} text", n.id);
            assert!(
                n.overlay.0.contains_key(lang) && n.narration.0.contains_key(lang),
                "{}: no {lang} media",
                n.id
            );
        }
        assert!(n.roi_bbox.is_some() && n.thumbnail.is_some() && n.roi_mask.is_some(), "{}", n.id);
        // The mask is loaded for the engine (Eq. 11.3), not only named.
        let bitmap = n.roi_bitmap.as_ref().unwrap_or_else(|| panic!("{}: ROI mask not loaded", n.id));
        assert!(bitmap.count() > 0 && bitmap.count() < bitmap.w * bitmap.h, "{}: {bitmap:?}", n.id);
        let files = n.overlay.0.values().chain(n.narration.0.values()).chain(&n.thumbnail).chain(&n.roi_mask);
        for f in files {
            assert!(dir.join(f).is_file(), "{name}/{}: {f} missing", n.id);
        }
    }
    assert!(dir.join("CREDITS.md").is_file(), "{name}: no CREDITS.md");
    // The story plays: a visitor who waits is shown the introduction first.
    let store = kiosk_content::exhibit::open_model_in(&dir, &crate::common::cache()).expect("model");
    let t = replay::run_story(
        &store,
        &Script::new().wait(40.0).cancel(99).session(),
        &ExploreSettings::default(),
        Some(&g),
    );
    assert_eq!(
        t.summary.nodes_displayed.first().map(String::as_str),
        Some("intro"),
        "{name}: {:?}",
        t.summary
    );
    assert_eq!(t.summary.collisions, 0, "{name}");
}

#[test]
fn a_trace_never_replaces_its_session_and_a_recording_is_not_overwritten() {
    let dir = tempfile::tempdir().expect("temp dir");
    let exhibit = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("content/demosthenes");
    let session = dir.path().join("visit.jsonl");
    let text = kiosk_core::session::Script::new().tap(1, 0.5, 0.5).wait(0.5).session().to_jsonl();
    std::fs::write(&session, &text).expect("session");
    let kiosk = |args: &[&std::ffi::OsStr]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
            .args(args)
            .env("RUST_BACKTRACE", "0")
            .env("ISOKIOSK_CACHE", crate::common::cache())
            .output()
            .expect("run kiosk")
    };
    let s = session.as_os_str();
    let o = kiosk(&[
        "replay".as_ref(),
        "--exhibit".as_ref(),
        exhibit.as_os_str(),
        "--session".as_ref(),
        s,
        "--trace".as_ref(),
        s,
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--trace") && err.contains("input"), "{err}");
    assert_eq!(std::fs::read_to_string(&session).expect("session"), text, "the session is untouched");
    let o = kiosk(&["--record".as_ref(), s, "--windowed".as_ref()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--force"), "{err}");
    assert_eq!(std::fs::read_to_string(&session).expect("session"), text, "the recording is untouched");
    // A session beyond the longest allowed is refused with its line, before any frame is made.
    let long = dir.path().join("long.jsonl");
    std::fs::write(&long, format!("{text}{{\"t\":1e7,\"ev\":\"cancel\",\"id\":99,\"x\":0,\"y\":0}}\n"))
        .expect("write");
    let trace = dir.path().join("t.jsonl");
    let o = kiosk(&[
        "replay".as_ref(),
        "--exhibit".as_ref(),
        exhibit.as_os_str(),
        "--session".as_ref(),
        long.as_os_str(),
        "--trace".as_ref(),
        trace.as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("longest session") && err.contains("line 3"), "{err}");
}

/// One frame of a driven exploration: the camera shown and the trace line.
struct Driven {
    cam: kiosk_core::camera::Camera,
    frame: kiosk_core::trace::Frame,
}

/// Runs a script through an explorer (the replay's loop), keeping the cameras (the trace has no
/// field of view) and the explorer at the end.
fn drive<'a>(
    ex: &'a Exhibit,
    graph: &'a InfoGraph,
    settings: &ExploreSettings,
    script: &Script,
) -> (Vec<Driven>, kiosk_core::explore::Explorer<'a, memmap2::Mmap>) {
    let store = &ex.built.store;
    let session = script.session();
    let mut x = kiosk_core::explore::Explorer::new(store, Some(graph), settings, 0.0);
    let dt = 1.0 / settings.fps;
    let frames = ((session.duration() + settings.tail_secs) * settings.fps).ceil() as u64 + 1;
    let (mut next, mut out) = (0, Vec::new());
    for k in 0..frames {
        let t = k as f64 * dt;
        while next < session.events.len() && session.events[next].t <= t + 1e-9 {
            x.touch(&session.events[next]);
            next += 1;
        }
        let (frame, _) = x.step(t);
        out.push(Driven { cam: x.camera(), frame });
    }
    (out, x)
}

fn state_of(d: &Driven) -> &str {
    d.frame.recommender.as_deref().unwrap_or("")
}

#[test]
fn a_real_scale_projection_holds_through_a_go_to() {
    let ex = exhibit();
    let mut back = ex.orbited("back", 180.0);
    back.view.fov_y = 0.8;
    let g = graph(vec![back]);
    // Proposed at ~11 s, accepted at ~12.7 s, displayed from ~14.7 s; then the visitor hovers.
    let script = Script::new()
        .wait(12.0)
        .down(1, 0.5, 0.5)
        .wait(1.0)
        .up(1, 0.5, 0.5)
        .wait(3.0)
        .joystick(1, (0.15, 0.0), 2.0)
        .cancel(99);
    // Real scale: the configured field of view, every frame, the go-to included.
    let real = ExploreSettings { fov_y: 0.6, real_scale: true, ..ExploreSettings::default() };
    let (run, _) = drive(&ex, &g, &real, &script);
    assert!(run.iter().any(|d| state_of(d) == "display"), "the node was never displayed");
    for d in &run {
        assert_eq!(d.cam.fov_y, 0.6, "t={}: field of view {} in real-scale mode", d.frame.t, d.cam.fov_y);
    }
    // Not real scale: the node's field of view frames its go-to; moving brings the configured
    // one back.
    let plain = ExploreSettings { fov_y: 0.6, ..ExploreSettings::default() };
    let (run, _) = drive(&ex, &g, &plain, &script);
    let shown = run.iter().find(|d| state_of(d) == "display").expect("displayed");
    assert_eq!(shown.cam.fov_y, 0.8, "the go-to did not frame the node with its field of view");
    let hover_end = script.session().duration() - 0.02;
    let late = run.iter().rfind(|d| d.frame.t <= hover_end).expect("frames");
    assert_ne!(state_of(late), "go-to");
    assert!((late.cam.fov_y - 0.6).abs() < 0.01, "field of view {} after 2 s of hover", late.cam.fov_y);
    for w in run.windows(2) {
        assert!(
            (w[1].cam.fov_y - w[0].cam.fov_y).abs() < 0.02,
            "the field of view jumped at t={}",
            w[1].frame.t
        );
    }
}

#[test]
fn a_go_to_ends_exactly_at_a_view_steeper_than_the_tilt_limit() {
    let ex = exhibit();
    let diag = f64::from(ex.built.store.bbox().diagonal());
    // Looking down at the bust, 4° from vertical (IsoCam's limit is 10°).
    let tilt = 4f64.to_radians();
    let eye = ex.center + DVec3::new(tilt.sin(), tilt.cos(), 0.0) * diag;
    let g = graph(vec![node("above", eye, ex.center, 1.0)]);
    let view = g.nodes[0].view;
    assert!(kiosk_core::camera::exceeds_tilt_limit(&view, DVec3::Y, 10f64.to_radians()));
    let t = ex
        .run(&g, &Script::new().wait(12.0).down(1, 0.5, 0.5).wait(1.0).up(1, 0.5, 0.5).wait(3.0).cancel(99));
    assert_eq!(t.summary.nodes_displayed, vec!["above".to_string()], "{:?}", states(&t));
    let last = t.frames.last().expect("frames");
    assert_eq!(last.overlay.as_deref(), Some("above"));
    let forward = (DVec3::from_array(last.target) - DVec3::from_array(last.eye)).normalize();
    assert!(
        (forward - view.forward()).length() < 1e-9,
        "the view was changed at the end of the go-to: {forward:?} vs {:?}",
        view.forward()
    );
    assert!((DVec3::from_array(last.up) - view.up).length() < 1e-9);
    assert!((DVec3::from_array(last.eye) - view.eye).length() < 1e-9 * diag.max(1.0));
}

#[test]
fn a_menu_pick_during_a_proposal_counts_as_a_menu_pick() {
    let ex = exhibit();
    // "right" needs "back" first (mandatory): the engine proposes "back"; the menu offers "right".
    let mut g = graph(vec![ex.orbited("back", 180.0), ex.orbited("right", 20.0)]);
    g.edges.push(kiosk_core::graph::Edge { from: 0, to: 1, weight: 1.0 });
    // Attract from 3 s, proposal from ~11 s; the menu opens at ~10.2 s and picks at ~12.1 s.
    let script = Script::new()
        .wait(9.5)
        .down(1, 0.5, 0.5)
        .wait(2.3)
        .drag(&[(1, (0.5, 0.5), (0.5, 0.3))], 0.2)
        .wait(0.1)
        .up(1, 0.5, 0.3)
        .wait(3.0)
        .cancel(99);
    let (run, x) = drive(&ex, &g, &ExploreSettings::default(), &script);
    assert!(
        run.iter().any(|d| state_of(d) == "propose" && d.frame.menu.is_some()),
        "no proposal while the menu was open"
    );
    let s = &x.summary;
    assert_eq!(s.nodes_displayed, vec!["right".to_string()], "{s:?}");
    assert_eq!(s.menu_selections, 1, "{s:?}");
    assert_eq!(s.proposals_accepted, 0, "the menu pick was counted as an accepted proposal: {s:?}");
    assert_eq!(s.proposals_ignored, 1, "{s:?}");
    let rec = x.recommender().expect("engine");
    assert_eq!(rec.stats[0].refusals, 1, "the superseded proposal is not counted as refused");
    // The pick's go-to reached the picked view.
    let last = run.last().expect("frames");
    assert!((last.cam.eye - g.nodes[1].view.eye).length() < 1e-6 * ex.center.length().max(1.0));
}

#[test]
fn the_hidden_nudge_moves_each_controller_toward_the_attracting_view() {
    use kiosk_core::camera::ControllerKind;
    use kiosk_core::camera::{Intent, SceneRef};
    use kiosk_core::recommend::{RecSettings, RecState, Recommender, ViewContext};
    use rand::SeedableRng;
    let ex = exhibit();
    let store = &ex.built.store;
    let g = graph(vec![ex.orbited("side", 60.0)]);
    let goal = g.nodes[0].view.eye;
    let settings = ExploreSettings::default();
    let cut = kiosk_core::Cut::leaves(store);
    let scene = SceneRef { store, cut: &cut };
    let diag = scene.diagonal();
    let cam0 = kiosk_core::camera::initial_camera(store, settings.fov_y, settings.up);
    let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
    let samples: Vec<DVec3> =
        store.sample_cut(&cut, 64, &mut rng).into_iter().map(|p| store.to_model(p)).collect();
    let mut rec = Recommender::new(&g, RecSettings::default(), 0.0);
    rec.state = RecState::Attract { node: 0, since: 0.0 };
    let aspect = 16.0 / 9.0;
    for kind in [ControllerKind::IsoCam, ControllerKind::Trackball, ControllerKind::Acevit] {
        let base = kiosk_core::camera::make_controller(scene, cam0, kind, 0.01 * diag, DVec3::Y, aspect);
        let ctx =
            ViewContext { camera: base.camera(), aspect, samples: &samples, diagonal: diag, moving: true };
        // Vertical motion, orthogonal to the way toward the side view (to the right).
        for (what, intent) in [
            ("hover", Intent { hover: (0.0, 0.05), ..Intent::default() }),
            ("pan", Intent { pan: (0.0, 0.05), ..Intent::default() }),
        ] {
            let guided = kiosk_core::explore::guide_intent(&rec, &g, &ctx, intent, &base);
            let (mut with, mut without) = (base.clone(), base.clone());
            with.apply(scene, &guided, &mut rng);
            without.apply(scene, &intent, &mut rng);
            let d_with = (with.camera().eye - goal).length();
            let d_without = (without.camera().eye - goal).length();
            assert!(
                d_with < d_without - 1e-3 * diag,
                "{kind:?} {what}: the nudge moved away from the view ({d_with} vs {d_without} unguided)"
            );
            if what == "pan" && kind != ControllerKind::IsoCam {
                // A trackball's pan stays a pan: the view direction does not turn.
                let turn = with.camera().forward().dot(base.camera().forward());
                assert!(turn > 1.0 - 1e-9, "{kind:?}: the pan turned the view (cos {turn})");
            }
        }
    }
}

#[test]
fn a_go_to_turns_the_light_to_a_nodes_stored_light_and_keeps_the_light_without_one() {
    use kiosk_core::light::{ACTIVE_MIX, DEFAULT_MIX};
    let ex = exhibit();
    // Proposed at ~11 s, accepted at ~12.7 s, flown to, displayed.
    let script = Script::new().wait(12.0).down(1, 0.5, 0.5).wait(1.0).up(1, 0.5, 0.5).wait(3.0).cancel(99);
    let stored = DVec3::new(-1.0, 0.1, 0.0).normalize_or_zero();
    let mut lit = ex.orbited("back", 180.0);
    lit.light = Some(stored);
    let t = ex.run(&graph(vec![lit]), &script);
    assert_eq!(t.summary.nodes_displayed, ["back"], "{:?}", states(&t));
    let light = |f: &kiosk_core::trace::Frame| DVec3::from_array(f.light);
    let start = light(&t.frames[0]);
    let first_goto = t.frames.iter().position(|f| f.recommender.as_deref() == Some("go-to")).expect("go-to");
    let first_display =
        t.frames.iter().position(|f| f.recommender.as_deref() == Some("display")).expect("display");
    for f in &t.frames[..first_goto] {
        assert_eq!((light(f), f.light_mix), (start, DEFAULT_MIX), "before the go-to, at {}", f.t);
    }
    // During the go-to the light turns toward the node's, never away, without a jump; it is the
    // node's exactly when the view is.
    let angles: Vec<f64> =
        t.frames[first_goto..=first_display].iter().map(|f| light(f).angle_between(stored)).collect();
    assert!(angles.len() > 10, "the go-to lasts several frames");
    for w in angles.windows(2) {
        assert!(w[1] <= w[0] + 1e-12 && w[0] - w[1] < 0.1, "{w:?}");
    }
    assert!(angles[angles.len() / 2] > 1e-3 && angles[angles.len() / 2] < angles[0], "eased: {angles:?}");
    for f in &t.frames[first_display..] {
        assert_eq!(light(f), stored, "displayed in the node's light, at {}", f.t);
    }
    let last = t.frames.last().expect("frames");
    assert!((last.light_mix - ACTIVE_MIX).abs() < 1e-3, "the stored light dominates: {}", last.light_mix);
    // The same story without a stored light: the light never moves.
    let t = ex.run(&graph(vec![ex.orbited("back", 180.0)]), &script);
    assert_eq!(t.summary.nodes_displayed, ["back"]);
    for f in &t.frames {
        assert_eq!((light(f), f.light_mix), (start, DEFAULT_MIX), "at {}", f.t);
    }
}

#[test]
fn moving_during_a_flight_takes_the_camera_where_it_is() {
    let ex = exhibit();
    let g = four_views(&ex);
    // The menu pick starts a 2 s flight to "near" at 1.3 s; half a second in, the visitor drags.
    let pick = Script::new()
        .down(1, 0.5, 0.5)
        .wait(1.0)
        .drag(&[(1, (0.5, 0.5), (0.5, 0.3))], 0.2)
        .wait(0.1)
        .up(1, 0.5, 0.3);
    let t = ex.run(&g, &pick.clone().wait(0.5).joystick(2, (0.15, 0.0), 1.0).wait(3.0).cancel(99));
    let s = states(&t);
    let flew = s.iter().position(|x| x == "go-to").expect("a flight");
    assert_eq!(s[flew + 1], "discover", "the drag ends the flight: {s:?}");
    assert!(t.summary.nodes_displayed.is_empty(), "{:?}", t.summary);
    // The camera goes on from where the flight had brought it: no jump between frames.
    let eye = |f: &kiosk_core::trace::Frame| DVec3::from_array(f.eye);
    let steps: Vec<f64> = t.frames.windows(2).map(|w| (eye(&w[1]) - eye(&w[0])).length()).collect();
    let largest = steps.iter().copied().fold(0.0, f64::max);
    let typical = {
        let mut moving: Vec<f64> = steps.iter().copied().filter(|d| *d > 0.0).collect();
        moving.sort_by(f64::total_cmp);
        moving[moving.len() / 2]
    };
    assert!(largest < 6.0 * typical, "a jump of {largest} against a typical step of {typical}");
    // Without the drag the flight ends at the node, displayed.
    let t = ex.run(&g, &pick.wait(3.0).cancel(99));
    assert_eq!(t.summary.nodes_displayed, vec!["near".to_string()]);
}
