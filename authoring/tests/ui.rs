//! The authoring tool's real egui interface, clicked through by labels (egui_kittest) with a
//! real GPU (lavapipe) for the live view and thumbnails: a curator authors a small story from a
//! bare scan, saves it, and the kiosk's `replay` command plays it.

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use kiosk_author::Project;
use kiosk_author::ui::AuthorApp;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn harness(dir: &Path) -> Harness<'static, AuthorApp> {
    // The import cache inside the exhibit's temporary directory, not the user's.
    let (project, problems) = Project::open_in(dir, &dir.join(".import-cache")).expect("open the exhibit");
    let gpu = kiosk_content::snapshot::offscreen().expect("a GPU adapter (lavapipe: .ci/setup installs it)");
    let app = AuthorApp::new(project, problems, Some(gpu));
    let mut h = Harness::new_ui_state(|ui, app: &mut AuthorApp| app.ui(ui), app);
    h.set_size(egui::vec2(1400.0, 900.0));
    h.run_steps(2);
    h
}

fn click(h: &mut Harness<'_, AuthorApp>, label: &str) {
    h.get_by_label(label).click();
    h.run_steps(2);
}

fn type_into(h: &mut Harness<'_, AuthorApp>, label: &str, text: &str) {
    h.get_by_label(label).focus();
    h.run_steps(1);
    h.get_by_label(label).type_text(text);
    h.run_steps(2);
}

/// Drags on the live view by `(dx, dy)` points from its centre.
fn drag_view(h: &mut Harness<'_, AuthorApp>, dx: f32, dy: f32) {
    let c = h.get_by_label("Live view").rect().center();
    h.drag_at(c);
    h.run_steps(1);
    for k in 1..=10 {
        h.hover_at(c + egui::vec2(dx, dy) * (k as f32 / 10.0));
        h.run_steps(1);
    }
    h.drop_at(c + egui::vec2(dx, dy));
    h.run_steps(2);
}

/// The `kiosk` binary of this workspace: the one `cargo test --workspace` built beside this
/// test, else built now.
fn kiosk_binary() -> PathBuf {
    let exe = std::env::current_exe().expect("test exe");
    let target = exe.parent().and_then(Path::parent).expect("target/debug");
    let bin = target.join("kiosk");
    if bin.exists() {
        return bin;
    }
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["build", "--quiet", "-p", "kiosk", "--bin", "kiosk"])
        .current_dir(repo())
        .status()
        .expect("cargo");
    assert!(status.success(), "cannot build the kiosk binary");
    assert!(bin.exists(), "{} missing", bin.display());
    bin
}

#[test]
fn a_curator_authors_a_story_through_the_window_and_the_kiosk_replays_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::copy(
        repo().join("content/demosthenes/demosthenes-low-res.obj"),
        dir.path().join("demosthenes-low-res.obj"),
    )
    .expect("copy scan");
    let mut h = harness(dir.path());
    assert!(h.state().project.graph.nodes.is_empty(), "a bare scan");

    // Two views: the start view, and one after gliding to the side.
    type_into(&mut h, "New id", "front");
    click(&mut h, "Capture view");
    let front = h.state().camera();
    drag_view(&mut h, 250.0, 0.0);
    let side = h.state().camera();
    assert!((side.eye - front.eye).length() > 1e-3, "the drag moved the camera");
    type_into(&mut h, "New id", "side");
    click(&mut h, "Capture view");
    assert_eq!(h.state().selected.as_deref(), Some("side"));
    assert!(dir.path().join("thumbs/side.png").exists(), "thumbnail rendered");

    // Texts in two languages.
    type_into(&mut h, "Title", "The side");
    type_into(&mut h, "Text", "Seen from the side, the head leans forward.");
    click(&mut h, "Apply texts");
    click(&mut h, "it");
    type_into(&mut h, "Title", "Il fianco");
    click(&mut h, "Apply texts");
    click(&mut h, "en");

    // The side depends on the front (mandatory).
    click(&mut h, "Predecessor");
    click(&mut h, "front");
    click(&mut h, "Mandatory 1");

    // An SVG overlay, rendered at the view's size.
    let svg = dir.path().join("arrow.svg");
    std::fs::write(
        &svg,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="160" height="90"><circle cx="80" cy="45" r="30" fill="none" stroke="#ffc440" stroke-width="4"/></svg>"##,
    )
    .expect("svg");
    type_into(&mut h, "Overlay file", &svg.display().to_string());
    click(&mut h, "Attach overlay");
    let png = image::open(dir.path().join("overlays/side-en.png")).expect("overlay written").to_rgba8();
    assert_eq!(png.dimensions(), (1280, 720));
    let stroke = png.get_pixel(640, 45 * 8 - 240); // top of the circle: y = (45 − 30) · 8
    assert!(stroke[3] > 200 && stroke[0] > 200, "the circle's stroke is drawn: {stroke:?}");
    assert_eq!(png.get_pixel(640, 360)[3], 0, "transparent inside");
    click(&mut h, "Preview overlay");

    // Region of interest: paint at the centre of the node's view.
    click(&mut h, "Go to view");
    click(&mut h, "Paint");
    drag_view(&mut h, 30.0, 10.0);
    click(&mut h, "Apply region");
    let i = h.state().project.graph.index_of("side").expect("side");
    assert!(h.state().project.graph.nodes[i].roi_bbox.is_some(), "ROI box computed: {:?}", h.state().log);
    click(&mut h, "Navigate");

    // Importance, undo/redo of the last edit.
    let edges = h.state().project.graph.edges.clone();
    assert_eq!(edges.len(), 1);
    assert_eq!(edges[0].weight, 1.0);
    click(&mut h, "Undo");
    assert!(h.state().project.graph.nodes[i].roi_bbox.is_none(), "undo removes the ROI");
    click(&mut h, "Redo");
    assert!(h.state().project.graph.nodes[i].roi_bbox.is_some(), "redo restores it");

    // Validation and the walk preview.
    click(&mut h, "Validate");
    let problems = h.state().problems.clone();
    assert!(problems.iter().all(|p| !p.dropped), "{problems:?}");
    click(&mut h, "Simulate walk");
    let walk = h.state().walk.clone();
    assert_eq!(walk.first().map(String::as_str), Some("front"), "the mandatory predecessor first: {walk:?}");
    assert!(walk.iter().any(|n| n == "side"), "{walk:?}");

    // Save and check what the kiosk makes of it.
    click(&mut h, "Save");
    assert!(!h.state().project.dirty());
    let (graph, problems) = kiosk_content::exhibit::open_graph(dir.path()).expect("read").expect("graph.xml");
    assert_eq!(graph.nodes.len(), 2);
    assert_eq!(graph.nodes[1].title.0.get("it").map(String::as_str), Some("Il fianco"));
    assert!(problems.iter().all(|p| !p.dropped), "{problems:?}");
    let session = dir.path().join("session.jsonl");
    std::fs::write(
        &session,
        "{\"session\":1,\"seed\":2}\n{\"t\":30.0,\"ev\":\"cancel\",\"id\":1,\"x\":0.5,\"y\":0.5}\n",
    )
    .expect("session");
    let trace = dir.path().join("trace.jsonl");
    let out = Command::new(kiosk_binary())
        .env("ISOKIOSK_CACHE", dir.path().join(".import-cache"))
        .args(["replay", "--exhibit"])
        .arg(dir.path())
        .arg("--session")
        .arg(&session)
        .arg("--trace")
        .arg(&trace)
        .output()
        .expect("kiosk replay");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&trace).expect("trace");
    assert!(text.contains("\"recommender\":\"discover\""), "the replay runs the story");

    // A recorded session replayed against the graph from the tool.
    type_into(&mut h, "Session", &session.display().to_string());
    click(&mut h, "Replay session");
    assert!(h.state().replayed.is_some(), "{:?}", h.state().log);
}

#[test]
fn the_demo_content_is_editable_and_re_savable_without_loss() {
    let dir = tempfile::tempdir().expect("temp dir");
    let src = repo().join("content/demosthenes");
    copy_dir(&src, dir.path());
    let before = std::fs::read_to_string(dir.path().join("graph.xml")).expect("graph");
    let mut h = harness(dir.path());
    assert_eq!(h.state().project.graph.nodes.len(), 9);
    click(&mut h, "intro — Demosthenes");
    type_into(&mut h, "Title", " (bust)");
    click(&mut h, "Apply texts");
    assert!(h.state().project.dirty());
    click(&mut h, "Undo");
    click(&mut h, "Save");
    let after = std::fs::read_to_string(dir.path().join("graph.xml")).expect("graph");
    assert_eq!(before, after, "an edit undone and saved leaves the demo graph byte-identical");
}

fn copy_dir(from: &Path, to: &Path) {
    kiosk_testkit::copy_dir(from, to)
        .unwrap_or_else(|e| panic!("copy {} to {}: {e}", from.display(), to.display()));
}

#[test]
fn an_edit_is_autosaved_without_input_and_never_over_a_crashed_sessions_autosave() {
    let dir = tempfile::tempdir().expect("temp dir");
    copy_dir(&repo().join("content/demosthenes"), dir.path());
    // A session that crashed left an autosave with a node renamed in its title.
    let graph = std::fs::read_to_string(dir.path().join("graph.xml")).expect("graph");
    let crashed = graph.replacen(">Demosthenes<", ">Demosthenes (unsaved)<", 1);
    assert_ne!(crashed, graph);
    let autosave = kiosk_author::ui::autosave_path(dir.path());
    std::fs::write(&autosave, &crashed).expect("autosave");
    let mut h = harness(dir.path());
    let recovered = kiosk_author::ui::recovered_path(dir.path());
    assert_eq!(std::fs::read_to_string(&recovered).expect("set aside"), crashed);
    // An edit in this session, then no input: the tool asks to be woken for the autosave.
    h.state_mut().project.set_importance("intro", 0.5).expect("edit");
    h.run_steps(1);
    let delay = h.output().viewport_output.get(&egui::ViewportId::ROOT).expect("root viewport").repaint_delay;
    assert!(delay <= std::time::Duration::from_secs(30), "no wake-up for the autosave: {delay:?}");
    h.state_mut().autosave();
    assert!(autosave.exists(), "this session's autosave");
    assert_eq!(std::fs::read_to_string(&recovered).expect("kept"), crashed, "the crashed autosave is kept");
    click(&mut h, "Restore autosave");
    let title = h.state().project.graph.nodes[0].title.0["en"].clone();
    assert_eq!(title, "Demosthenes (unsaved)");
    assert!(!recovered.exists(), "restored, so no longer offered");
}

#[test]
fn the_views_show_what_visitors_did_with_them() {
    let dir = tempfile::tempdir().expect("temp dir");
    copy_dir(&repo().join("content/demosthenes"), dir.path());
    let mut h = harness(dir.path());
    h.get_by_label_contains("intro").click();
    h.run_steps(2);
    assert!(h.query_by_label_contains("no visits recorded yet").is_some());
    let mut stats = kiosk_core::stats::ExhibitStats { visits: 12, ..Default::default() };
    stats.nodes.insert(
        "intro".into(),
        kiosk_core::stats::NodeTotals {
            displays: 4,
            dwell_secs: 100.0,
            proposals: 4,
            accepted: 3,
            menu_picks: 2,
            ..Default::default()
        },
    );
    h.state_mut().visitor_stats = stats;
    h.run_steps(2);
    let line = "Visitors (12 visits): shown 4 times, 25 s each on average, proposals accepted 75 %, picked in the menu 2 times";
    assert!(h.query_by_label(line).is_some(), "the selected view's figures");
}

#[test]
fn the_model_is_turned_upright_from_the_toolbar() {
    let dir = tempfile::tempdir().expect("temp dir");
    copy_dir(&repo().join("content/demosthenes"), dir.path());
    let mut h = harness(dir.path());
    click(&mut h, "z");
    let saved = std::fs::read_to_string(dir.path().join("exhibit.toml")).expect("exhibit.toml written");
    assert!(saved.contains("up = \"z\""), "{saved}");
    let cam = h.state().camera();
    assert!(cam.up.dot(glam::DVec3::Z) > 0.99, "the live view starts upright about Z: {}", cam.up);
}

#[test]
fn a_crooked_model_is_levelled_degree_by_degree_from_the_toolbar() {
    let dir = tempfile::tempdir().expect("temp dir");
    copy_dir(&repo().join("content/demosthenes"), dir.path());
    let mut h = harness(dir.path());
    // The bust's own vertical (+Y) on the live view's screen: its angle counter-clockwise from
    // the view's up, and how far it leans into the screen.
    let seen = |h: &Harness<'_, AuthorApp>| {
        let cam = h.state().camera();
        let right = cam.forward().cross(cam.up);
        let y = glam::DVec3::Y;
        ((-y.dot(right)).atan2(y.dot(cam.up)).to_degrees(), y.dot(cam.forward()))
    };
    let (angle, _) = seen(&h);
    assert!(angle.abs() < 1e-6, "the bust starts upright: {angle}°");
    for _ in 0..3 {
        click(&mut h, "Lean left");
    }
    let (angle, _) = seen(&h);
    assert!((angle - 3.0).abs() < 1e-6, "three clicks lean it 3° to the left: {angle}°");
    click(&mut h, "Lean right");
    let (angle, _) = seen(&h);
    assert!((angle - 2.0).abs() < 1e-6, "one back: {angle}°");
    let saved = std::fs::read_to_string(dir.path().join("exhibit.toml")).expect("exhibit.toml written");
    assert!(saved.contains("up = ["), "a vector up: {saved}");
    let pose = kiosk_content::exhibit::model_pose(dir.path()).expect("the kiosk reads it");
    assert!((pose.up.dot(glam::DVec3::Y).acos().to_degrees() - 2.0).abs() < 1e-6, "{pose:?}");
    // Tipped back: the new up leans toward the viewer, and the view turns with it, so the bust is
    // seen with its top tipped away: the up it stood on, level to the view before, now points
    // 1° into the view.
    let cam = h.state().camera();
    let before = pose.up;
    assert!(before.dot(cam.forward()).abs() < 1e-9, "level before");
    click(&mut h, "Tip back");
    let pose = kiosk_content::exhibit::model_pose(dir.path()).expect("read");
    assert!(pose.up.dot(cam.forward()) < -0.01, "{pose:?}");
    let tipped = before.dot(h.state().camera().forward()).asin().to_degrees();
    assert!((tipped - 1.0).abs() < 1e-6, "seen tipped back by 1°: {tipped}°");
    click(&mut h, "Tip forward");
    click(&mut h, "Lean right");
    click(&mut h, "Lean right");
    let saved = std::fs::read_to_string(dir.path().join("exhibit.toml")).expect("exhibit.toml");
    assert!(saved.contains("up = \"y\""), "levelled back to the axis: {saved}");
}

#[test]
fn the_side_in_view_becomes_the_front_from_the_toolbar() {
    let dir = tempfile::tempdir().expect("temp dir");
    copy_dir(&repo().join("content/demosthenes"), dir.path());
    let mut h = harness(dir.path());
    // Orbit to the model's side, then make that side its front.
    drag_view(&mut h, 400.0, 0.0);
    let cam = h.state().camera();
    let side = (cam.eye - cam.target).with_y(0.0).normalize();
    assert!(side.dot(glam::DVec3::Z) < 0.95, "the drag turned the view: {side}");
    click(&mut h, "Front from view");
    let saved = std::fs::read_to_string(dir.path().join("exhibit.toml")).expect("exhibit.toml written");
    assert!(saved.contains("front = "), "{saved}");
    let pose = kiosk_content::exhibit::model_pose(dir.path()).expect("the kiosk reads it");
    assert!(pose.front.expect("front").dot(side) > 0.999, "{pose:?} vs {side}");
    let start = h.state().camera();
    assert!((start.eye - start.target).normalize().dot(side) > 0.999, "the live view starts at the front");
}

#[test]
fn a_views_light_is_steered_in_the_live_view_and_saved_with_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    copy_dir(&repo().join("content/demosthenes"), dir.path());
    let before = std::fs::read_to_string(dir.path().join("graph.xml")).expect("graph");
    let mut h = harness(dir.path());
    click(&mut h, "intro — Demosthenes");
    assert!(h.query_by_label("Light: the visitor's").is_some(), "no light stored yet");
    let (cam, start) = (h.state().camera(), h.state().light);
    // The Light tool: a drag far to the left makes a grazing light from the left; the camera stays.
    click(&mut h, "Steer light");
    drag_view(&mut h, -500.0, 0.0);
    let light = h.state().light;
    assert_ne!(light.dir, start.dir, "the drag moved the light");
    let (back, right) = (-cam.forward(), cam.right());
    assert!(
        light.dir.dot(back).abs() < 1e-9 && light.dir.dot(right) < -0.9,
        "raking from the left: {}",
        light.dir
    );
    assert_eq!(h.state().camera(), cam, "the Light tool does not move the camera");
    assert_eq!(light.mix, kiosk_core::light::ACTIVE_MIX);
    click(&mut h, "Set light from live view");
    let i = h.state().project.graph.index_of("intro").expect("intro");
    assert_eq!(h.state().project.graph.nodes[i].light, Some(light.dir));
    click(&mut h, "Save");
    let after = std::fs::read_to_string(dir.path().join("graph.xml")).expect("graph");
    let (graph, problems) = kiosk_content::exhibit::open_graph(dir.path()).expect("read").expect("graph.xml");
    assert!(problems.is_empty(), "{problems:?}");
    assert_eq!(graph.nodes[i].light, Some(light.dir), "the saved light reads back exactly");
    assert!(after.contains(" light=\""), "{after}");
    // Only the intro was written anew: every other node and edge is as it was, byte for byte.
    let items = |text: &str| -> Vec<String> {
        text.split("\n  <")
            .skip(1)
            .map(|s| s.to_string())
            .filter(|s| !s.starts_with("node id=\"intro\""))
            .collect()
    };
    assert_eq!(items(&after), items(&before));
    // Another view, then back to the intro: the live view takes the stored light.
    click(&mut h, "face — A tense face");
    h.state_mut().light = start;
    click(&mut h, "intro — Demosthenes");
    assert_eq!(h.state().light.dir, light.dir, "going to the view takes its light");
    click(&mut h, "Remove light");
    assert_eq!(h.state().project.graph.nodes[i].light, None);
    click(&mut h, "Undo");
    assert_eq!(h.state().project.graph.nodes[i].light, Some(light.dir));
}

#[test]
fn the_window_says_what_it_does_while_the_exhibit_opens_and_why_it_cannot() {
    use kiosk_author::ui::opening::Opening;
    use std::time::{Duration, Instant};
    // Polls until the opening ends (a project, or a failure), at most a minute.
    fn settle(o: &mut Opening) -> Option<(Project, Vec<kiosk_core::graph::Problem>)> {
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(60) {
            if let Some(p) = o.poll() {
                return Some(p);
            }
            if o.failed().is_some() {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        panic!("the exhibit did not open in a minute");
    }
    // A scan not yet in the cache: the window says it opens the exhibit at once, then the
    // project comes with what the import last logged.
    let dir = tempfile::tempdir().expect("temp dir");
    let scan = repo().join("content/demosthenes/demosthenes-low-res.obj");
    std::fs::copy(scan, dir.path().join("bust.obj")).expect("copy the scan");
    let mut opening = Opening::spawn(dir.path(), &dir.path().join(".import-cache")).expect("spawn");
    {
        let mut h = Harness::new_ui(|ui| opening.ui(ui));
        h.run_steps(1);
        h.get_by_label_contains(&format!("Opening {}", dir.path().display()));
        h.get_by_label_contains("A new or changed scan is imported into the cache first");
    }
    let (project, problems) = settle(&mut opening).expect("the exhibit opens");
    assert!(opening.line().contains("importing bust.obj: done"), "{}", opening.line());
    assert!(problems.is_empty(), "{problems:?}");
    assert!(project.store.header().leaf_point_count > 9000);
    // A scan the reader cannot read: the window says why, naming the file.
    let broken = tempfile::tempdir().expect("temp dir");
    std::fs::write(broken.path().join("model.obj"), "v 1 2 three\nf 1 2 9\n").expect("write");
    let mut opening = Opening::spawn(broken.path(), &broken.path().join(".import-cache")).expect("spawn");
    assert!(settle(&mut opening).is_none());
    let why = opening.failed().expect("a reason").to_string();
    assert!(why.contains("model.obj"), "{why}");
    let mut h = Harness::new_ui(|ui| opening.ui(ui));
    h.run_steps(1);
    h.get_by_label_contains(&format!("Cannot open {}", broken.path().display()));
    h.get_by_label_contains("model.obj");
}
