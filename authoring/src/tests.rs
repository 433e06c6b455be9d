//! The authoring actions on a real exhibit, headless: capture, attach, ROI paint → box,
//! dependencies, validation, atomic save, reload → identical model; undo and redo.

use super::*;
use kiosk_core::camera::initial_camera;

fn exhibit() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("tmp");
    let scan =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/scans/demosthenes/demosthenes-low-res.obj");
    std::fs::copy(scan, dir.path().join("bust.obj")).expect("copy the scan");
    dir
}

/// Opens the exhibit with its import cache inside it (not the user's cache).
fn open(dir: &Path) -> anyhow::Result<(Project, Vec<Problem>)> {
    Project::open_in(dir, &dir.join(".import-cache"))
}

fn orbit(p: &Project, deg: f64) -> Camera {
    let c = initial_camera(&p.store, 0.8, DVec3::Y);
    let center = c.target;
    let a = deg.to_radians();
    let r = c.eye - center;
    Camera {
        eye: center + DVec3::new(r.x * a.cos() + r.z * a.sin(), r.y, -r.x * a.sin() + r.z * a.cos()),
        ..c
    }
}

#[test]
fn author_a_small_graph_save_and_reload_identically() {
    let dir = exhibit();
    let (mut p, problems) = open(dir.path()).expect("open");
    assert!(problems.is_empty() && p.graph.nodes.is_empty());
    let (gpu, mut renderer) = kiosk_testkit::test_gpu();
    let a = p.capture(orbit(&p, 0.0), Some("front"), Some((&gpu, &mut renderer))).expect("capture");
    let b = p.capture(orbit(&p, 40.0), None, Some((&gpu, &mut renderer))).expect("capture");
    assert_eq!(b, "view-1");
    assert!(dir.path().join("thumbs/front.png").exists());
    p.set_text(&a, "en", "The bust", "Demosthenes, Athenian orator.").expect("text");
    p.set_text(&a, "it", "Il busto", "Demostene, oratore ateniese.").expect("text");
    p.set_importance(&b, 0.6).expect("importance");
    p.set_dependency(&a, &b, 1.0).expect("dependency");
    // An overlay of the right aspect, and one of the wrong aspect (a warning).
    let ok = dir.path().join("drawing.png");
    image::RgbaImage::from_pixel(320, 180, image::Rgba([200, 30, 30, 128])).save(&ok).expect("png");
    assert_eq!(p.attach_overlay(&a, "en", &ok).expect("attach"), None);
    let square = dir.path().join("square.png");
    image::RgbaImage::from_pixel(100, 100, image::Rgba([0, 0, 0, 255])).save(&square).expect("png");
    let warn = p.attach_overlay(&b, "en", &square).expect("attach");
    assert!(warn.is_some_and(|w| w.contains("100×100")));
    // Paint the middle of the front view: the box lies inside the model's and is smaller.
    let mask = image::GrayImage::from_fn(160, 90, |x, y| {
        image::Luma([if (60..100).contains(&x) && (20..50).contains(&y) { 255 } else { 0 }])
    });
    let (lo, hi) = p.paint_roi(&a, &mask).expect("roi");
    let model = p.store.bbox();
    let (mlo, mhi) = (p.store.to_model(model.min), p.store.to_model(model.max));
    assert!(lo.cmpge(mlo - 1e-6).all() && hi.cmple(mhi + 1e-6).all());
    assert!((hi - lo).length() < 0.8 * (mhi - mlo).length());
    // Validation finds the square overlay, and nothing else.
    let problems: Vec<String> = p.validate().iter().map(ToString::to_string).collect();
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(problems[0].contains("node 'view-1': overlay"));
    assert!(p.dirty());
    p.save().expect("save");
    assert!(!p.dirty());
    let (again, problems) = open(dir.path()).expect("reopen");
    assert_eq!(problems.len(), 1);
    assert!(again.graph == p.graph, "the reloaded graph differs");
    // The saved file is what `kiosk replay` and the kiosk read.
    assert!(
        std::fs::read_to_string(dir.path().join("graph.xml"))
            .expect("xml")
            .contains("<infograph version=\"1\"")
    );
}

#[test]
fn undo_and_redo_walk_the_edits_and_errors_change_nothing() {
    let dir = exhibit();
    let (mut p, _) = open(dir.path()).expect("open");
    p.capture(orbit(&p, 0.0), Some("a"), None).expect("capture");
    p.capture(orbit(&p, 30.0), Some("b"), None).expect("capture");
    p.set_dependency("a", "b", 0.8).expect("dependency");
    let full = p.graph.clone();
    assert!(p.set_dependency("a", "zzz", 1.0).is_err());
    assert!(p.set_dependency("a", "b", 3.0).is_err());
    assert!(p.capture(orbit(&p, 10.0), Some("a"), None).is_err());
    assert!(p.graph == full, "a refused action changed the graph");
    assert!(p.undo());
    assert!(p.graph.edges.is_empty());
    assert!(p.undo() && p.undo());
    assert!(p.graph.nodes.is_empty());
    assert!(!p.undo());
    assert!(p.redo() && p.redo() && p.redo());
    assert!(p.graph == full);
    p.remove_node("a").expect("remove");
    assert_eq!(p.graph.nodes.len(), 1);
    assert!(p.graph.edges.is_empty());
}

#[test]
fn an_interrupted_save_keeps_the_previous_file() {
    let dir = exhibit();
    let (mut p, _) = open(dir.path()).expect("open");
    p.capture(orbit(&p, 0.0), Some("a"), None).expect("capture");
    p.save().expect("save");
    let before = std::fs::read(dir.path().join("graph.xml")).expect("saved");
    // A save that dies before the rename leaves only the temporary file behind.
    std::fs::write(dir.path().join(".graph.xml.saving"), b"<infograph version=\"1\"><node id=")
        .expect("partial");
    let (again, problems) = open(dir.path()).expect("reopen");
    assert!(problems.is_empty());
    assert_eq!(again.graph.nodes.len(), 1);
    assert_eq!(std::fs::read(dir.path().join("graph.xml")).expect("still there"), before);
}

#[test]
fn ids_and_languages_that_would_name_files_outside_the_exhibit_are_refused() {
    let dir = exhibit();
    let (mut p, _) = open(dir.path()).expect("open");
    let (gpu, mut renderer) = kiosk_testkit::test_gpu();
    let e = p
        .capture(orbit(&p, 0.0), Some("../../escaped"), Some((&gpu, &mut renderer)))
        .expect_err("an id with a path in it");
    assert!(e.to_string().contains("ASCII letters (a–z, A–Z, no accents), digits"), "{e}");
    assert!(p.graph.nodes.is_empty());
    let parent = dir.path().parent().expect("parent");
    assert!(!parent.join("escaped.png").exists() && !dir.path().join("thumbs").exists());
    let id = p.capture(orbit(&p, 0.0), Some("front"), None).expect("capture");
    let png = dir.path().join("drawing.png");
    image::RgbaImage::new(16, 9).save(&png).expect("png");
    let e = p.attach_overlay(&id, "../../x", &png).expect_err("a language with a path in it");
    assert!(e.to_string().contains("language"), "{e}");
    let e = p.set_narration(&id, "en", "../bust.obj").expect_err("a narration outside the exhibit");
    assert!(e.to_string().contains(".."), "{e}");
}

#[test]
fn an_svg_overlay_with_labels_attaches_and_a_broken_one_is_refused() {
    let dir = exhibit();
    let (mut p, _) = open(dir.path()).expect("open");
    let id = p.capture(orbit(&p, 0.0), Some("front"), None).expect("capture");
    let svg = dir.path().join("labels.svg");
    std::fs::write(
        &svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="1280" height="720"><text x="10" y="40">brow</text></svg>"#,
    )
    .expect("svg");
    assert_eq!(p.attach_overlay(&id, "en", &svg).expect("attach"), None);
    assert_eq!(p.graph.nodes[0].overlay.0.get("en").map(String::as_str), Some("overlays/front-en.svg"));
    assert!(dir.path().join("overlays/front-en.svg").exists());
    let broken = dir.path().join("broken.svg");
    std::fs::write(&broken, "<svg").expect("svg");
    let e = p.attach_overlay(&id, "it", &broken).expect_err("not an SVG");
    assert!(e.to_string().contains("broken.svg"), "{e}");
}

#[test]
fn saving_without_edits_keeps_the_file_byte_for_byte_even_what_could_not_be_read() {
    let dir = exhibit();
    let curated = r#"<?xml version="1.0" encoding="UTF-8"?>
<!-- kept by hand; the second node's fov is in degrees by mistake -->
<infograph version="1" default-lang="en" curator="anna">
  <node id="front" importance="high" colour="gold">
    <view eye="0 0 5" target="0 0 0" up="0 1 0" fov="0.8"/>
    <title lang="en">Front</title>
  </node>
  <node id="wide">
    <view eye="0 0 5" target="0 0 0" up="0 1 0" fov="32"/>
    <title lang="en">Wide</title>
    <overlay lang="en" src="overlays/wide-en.png"/>
  </node>
  <edge from="front" to="wide" weight="1"/>
</infograph>
"#;
    std::fs::write(dir.path().join("graph.xml"), curated).expect("write");
    let (mut p, problems) = open(dir.path()).expect("open");
    assert!(problems.iter().any(|p| p.node.as_deref() == Some("wide") && p.dropped), "{problems:?}");
    assert!(problems.iter().any(|p| p.node.as_deref() == Some("front") && p.msg.contains("\"high\"")));
    assert_eq!(p.graph.nodes.len(), 1);
    p.save().expect("save");
    assert_eq!(std::fs::read_to_string(dir.path().join("graph.xml")).expect("read"), curated);
    // An edit of the readable node keeps the unreadable one, its edge and the comment.
    p.set_text("front", "en", "The front", "").expect("text");
    p.save().expect("save");
    let saved = std::fs::read_to_string(dir.path().join("graph.xml")).expect("read");
    for kept in ["<!-- kept by hand", r#"fov="32""#, "overlays/wide-en.png", r#"to="wide""#, "The front"] {
        assert!(saved.contains(kept), "lost {kept}:\n{saved}");
    }
}

#[test]
fn a_curator_turns_the_model_upright_and_the_kiosk_reads_it() {
    let dir = exhibit();
    let (mut p, _) = open(dir.path()).expect("open");
    assert_eq!(p.pose.up, DVec3::Y, "no exhibit.toml: +Y");
    p.set_up(DVec3::Z).expect("set up");
    assert_eq!(kiosk_content::exhibit::model_up(dir.path()).expect("the kiosk reads it"), DVec3::Z);
    let (again, problems) = open(dir.path()).expect("reopen");
    assert_eq!(again.pose.up, DVec3::Z);
    assert!(problems.is_empty(), "{problems:?}");
    assert!(p.set_up(DVec3::ZERO).is_err(), "not a direction");
    assert!(p.set_up(DVec3::new(f64::NAN, 1.0, 0.0)).is_err(), "not a direction");
    std::fs::write(dir.path().join("exhibit.toml"), "up = \"diagonal\"\n").expect("write");
    let (broken, problems) = open(dir.path()).expect("opens all the same");
    assert_eq!(broken.pose.up, DVec3::Y);
    assert!(
        problems
            .iter()
            .any(|p| p.msg.contains("diagonal") && p.msg.ends_with("the model is shown with +Y up")),
        "{problems:?}"
    );
}

#[test]
fn a_curator_tilts_a_scan_standing_off_axis_and_the_kiosk_reads_it() {
    let dir = exhibit();
    // The exhibit's import setting survives the pose's writes.
    std::fs::write(dir.path().join("exhibit.toml"), "texel_density = 0.5\n").expect("write");
    let (mut p, _) = open(dir.path()).expect("open");
    p.set_front(DVec3::Z).expect("front +Z");
    // 3° then 4° about X: the pose turns as one, up and front, and the kiosk reads the vectors.
    p.tilt(DVec3::X, 3f64.to_radians()).expect("tilt");
    p.tilt(DVec3::new(2.0, 0.0, 0.0), 4f64.to_radians()).expect("tilt again");
    let (s, c) = 7f64.to_radians().sin_cos();
    let pose = kiosk_content::exhibit::model_pose(dir.path()).expect("the kiosk reads it");
    assert!(pose.up.abs_diff_eq(DVec3::new(0.0, c, s), 1e-12), "{pose:?}");
    assert!(pose.front.expect("front").abs_diff_eq(DVec3::new(0.0, -s, c), 1e-12), "{pose:?}");
    let start = kiosk_core::camera::start_camera(&p.store, 0.8, pose.up, pose.front);
    assert!(start.up.abs_diff_eq(pose.up, 1e-9), "the start view stands on the tilted up: {}", start.up);
    // Tilted back: the axis again, by name.
    p.tilt(DVec3::X, -7f64.to_radians()).expect("tilt back");
    let saved = std::fs::read_to_string(dir.path().join("exhibit.toml")).expect("exhibit.toml");
    assert!(saved.contains("up = \"y\"") && saved.contains("front = \"z\""), "{saved}");
    let density = kiosk_content::exhibit::import_options(dir.path()).expect("reads").read.texel_density;
    assert_eq!(density, 0.5, "{saved}");
    assert!(p.tilt(DVec3::ZERO, 0.1).is_err() && p.tilt(DVec3::X, f64::NAN).is_err());
}

#[test]
fn a_curator_turns_the_model_to_its_front_and_the_kiosk_starts_there() {
    let dir = exhibit();
    let (mut p, _) = open(dir.path()).expect("open");
    assert_eq!(p.pose.front, None, "no exhibit.toml: the default front");
    // Looking from below-left-behind: the front is that side, levelled to the up axis.
    p.set_front(DVec3::new(-1.0, -0.5, -1.0)).expect("set front");
    let front = DVec3::new(-1.0, 0.0, -1.0).normalize();
    let pose = kiosk_content::exhibit::model_pose(dir.path()).expect("the kiosk reads it");
    assert!(pose.front.expect("a front").abs_diff_eq(front, 1e-9), "{pose:?}");
    let start = kiosk_core::camera::start_camera(&p.store, 0.8, pose.up, pose.front);
    assert!(
        (start.eye - start.target).normalize().abs_diff_eq(front, 1e-9),
        "the start view looks at the front"
    );
    assert!(p.set_front(DVec3::Y).is_err(), "a front along the up axis is refused");
    // Turned upright about Z, the front stays (it is level); turned about X, it is dropped when
    // it would lie along the new up axis.
    p.set_front(DVec3::X).expect("front +X");
    p.set_up(DVec3::Z).expect("up Z");
    assert_eq!(kiosk_content::exhibit::model_pose(dir.path()).expect("read").front, Some(DVec3::X));
    p.set_up(DVec3::X).expect("up X");
    let pose = kiosk_content::exhibit::model_pose(dir.path()).expect("read");
    assert_eq!((pose.up, pose.front), (DVec3::X, None));
}

#[test]
fn a_nodes_light_is_checked_normalised_and_undoable() {
    let dir = exhibit();
    let (mut p, _) = open(dir.path()).expect("open");
    let id = p.capture(orbit(&p, 0.0), Some("front"), None).expect("capture");
    for bad in [DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 1.0), DVec3::new(0.0, f64::INFINITY, 0.0)] {
        let e = p.set_light(&id, Some(bad)).expect_err("refused");
        assert!(e.to_string().contains("node 'front': light"), "{e}");
    }
    assert!(p.set_light("nope", Some(DVec3::X)).is_err());
    assert_eq!(p.graph.nodes[0].light, None, "a refused light changes nothing");
    p.set_light(&id, Some(DVec3::new(-3.0, 0.0, 4.0))).expect("light");
    assert_eq!(p.graph.nodes[0].light, Some(DVec3::new(-0.6, 0.0, 0.8)));
    p.save().expect("save");
    let xml = std::fs::read_to_string(dir.path().join("graph.xml")).expect("saved");
    assert!(xml.contains(r#"light="-0.6 0 0.8""#), "{xml}");
    let (again, problems) = open(dir.path()).expect("reopen");
    assert!(problems.is_empty(), "{problems:?}");
    assert_eq!(again.graph, p.graph);
    p.set_light(&id, None).expect("remove");
    assert_eq!(p.graph.nodes[0].light, None);
    assert!(p.undo());
    assert_eq!(p.graph.nodes[0].light, Some(DVec3::new(-0.6, 0.0, 0.8)));
}

#[test]
fn the_readers_warnings_are_problems_of_the_project_also_once_cached() {
    // A scan the reader takes with a warning (an unknown header keyword): the curator sees it
    // among the problems, at every opening, not only the one that imported it.
    let dir = tempfile::tempdir().expect("tmp");
    let mut ply = String::from("ply\nformat ascii 1.0\nelement vertex 400\nproperty float x\n");
    ply += "property float y\nproperty float z\nscanner_angle 12\nend_header\n";
    for i in 0..400 {
        ply += &format!("{} {} {}\n", (i % 20) as f32 * 0.01, (i / 20) as f32 * 0.01, 0.002 * (i % 3) as f32);
    }
    std::fs::write(dir.path().join("grid.ply"), ply).expect("write");
    for opening in ["first", "cached"] {
        let (_, problems) = open(dir.path()).expect("open");
        let said: Vec<String> = problems.iter().map(ToString::to_string).collect();
        assert_eq!(
            said,
            ["model grid.ply: header line 7: unknown keyword 'scanner_angle' ignored"],
            "{opening}"
        );
        assert!(!problems[0].dropped, "{opening}: a warning");
    }
}
