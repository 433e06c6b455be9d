//! End to end: the real `kiosk` binary under Xvfb (and lavapipe), driven by a touch session
//! through its real windows, with screenshots of both windows checked pixel by pixel and the
//! kiosk's trace telling what it was doing at those moments.

mod audio;
mod monitors;

use image::RgbaImage;
use kiosk_core::session::Script;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

struct Run {
    dir: tempfile::TempDir,
    trace: Vec<Value>,
    stderr: String,
}

impl Run {
    fn shot(&self, window: &str, t: f64) -> RgbaImage {
        self.tagged(window, &format!("{t:.1}"))
    }

    /// A window's screenshot `{window}-{tag}.png` (`preparing`: the first frame before the
    /// gallery).
    fn tagged(&self, window: &str, tag: &str) -> RgbaImage {
        let p = self.dir.path().join(format!("{window}-{tag}.png"));
        image::open(&p).unwrap_or_else(|e| panic!("{}: {e}\n{}", p.display(), self.stderr)).to_rgba8()
    }

    fn frame(&self, t: f64) -> &Value {
        self.trace
            .iter()
            .find(|f| f["t"].as_f64().is_some_and(|ft| ft + 1e-9 >= t))
            .unwrap_or_else(|| panic!("no frame at {t}"))
    }
}

fn content() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("content")
}

/// The demo exhibits the windows tests run on, in gallery order: their sessions and screenshots
/// are written for these two (the other demo exhibits are checked in `story::sessions`).
const EXHIBITS: &str = "exhibits = [\"demosthenes\", \"nefertiti\"]\n";

/// Runs the kiosk on a session with screenshots; fails loudly when Xvfb or the GPU is missing,
/// or when the kiosk logs an error.
fn run(script: &Script, shots: &[f64], config: &str, speed: f64) -> Run {
    let run = run_in(&content(), script, shots, &format!("{EXHIBITS}{config}"), speed);
    assert!(!run.stderr.contains("ERROR"), "the kiosk logged errors:\n{}", run.stderr);
    run
}

/// Runs the kiosk on the exhibits of `content`.
fn run_in(content: &Path, script: &Script, shots: &[f64], config: &str, speed: f64) -> Run {
    let dir = tempfile::tempdir().expect("temp dir");
    let session = dir.path().join("session.jsonl");
    std::fs::write(&session, script.session().to_jsonl()).expect("write session");
    let cfg = dir.path().join("kiosk.toml");
    std::fs::write(&cfg, format!("content = {:?}\n{config}", content.display().to_string())).expect("config");
    let trace = dir.path().join("trace.jsonl");
    let shots: Vec<String> = shots.iter().map(|t| format!("{t}")).collect();
    let runtime = std::env::temp_dir().join("xdg-runtime-isokiosk-tests");
    std::fs::create_dir_all(&runtime).expect("runtime dir");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&runtime, std::fs::Permissions::from_mode(0o700)).expect("chmod");
    }
    let out = Command::new("xvfb-run")
        .env("ISOKIOSK_CACHE", crate::common::cache())
        .args(["-a", "-s", "-screen 0 2200x800x24 -nolisten tcp"])
        .arg(env!("CARGO_BIN_EXE_kiosk"))
        .arg("--config")
        .arg(&cfg)
        .args(["--windowed", "--silent", "--speed", &speed.to_string()])
        .arg("--session")
        .arg(&session)
        .arg("--trace")
        .arg(&trace)
        .arg("--screenshot-at")
        .arg(shots.join(","))
        .arg("--screenshot-dir")
        .arg(dir.path())
        .env("XDG_RUNTIME_DIR", &runtime)
        // Statistics and the visit log go to a temporary directory, never the user's state.
        .env("ISOKIOSK_STATE", dir.path().join("state"))
        .env("RUST_LOG", "info,wgpu_core=warn,wgpu_hal=warn,naga=warn")
        .output()
        .expect("xvfb-run must be installed (.ci/setup installs xvfb and xauth)");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "kiosk failed: {:?}\n{stderr}", out.status);
    let trace = std::fs::read_to_string(&trace)
        .expect("trace")
        .lines()
        .map(|l| serde_json::from_str(l).expect("trace line is JSON"))
        .collect();
    Run { dir, trace, stderr }
}

fn luma(p: &image::Rgba<u8>) -> f64 {
    0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2])
}

/// Fraction of the pixels of a region brighter than `level`.
fn bright(img: &RgbaImage, (x0, y0, x1, y1): (u32, u32, u32, u32), level: f64) -> f64 {
    let mut n = 0;
    let mut hit = 0;
    for y in y0..y1.min(img.height()) {
        for x in x0..x1.min(img.width()) {
            n += 1;
            hit += usize::from(luma(img.get_pixel(x, y)) > level);
        }
    }
    hit as f64 / n.max(1) as f64
}

/// Of the overlay's nearly opaque pixels, the fraction whose screenshot pixel has its colour
/// (the drawings are amber: red well above blue).
fn overlay_match(shot: &RgbaImage, overlay: &RgbaImage) -> f64 {
    let (mut n, mut hit) = (0, 0);
    for (x, y, p) in overlay.enumerate_pixels() {
        if p[3] >= 200 && x < shot.width() && y < shot.height() {
            n += 1;
            let s = shot.get_pixel(x, y);
            hit += usize::from(i32::from(s[0]) - i32::from(s[2]) > 90);
        }
    }
    assert!(n > 1000, "the overlay has opaque strokes");
    hit as f64 / n as f64
}

/// Mean absolute difference (0–255) between a region of the screenshot and an image scaled to it.
fn region_difference(shot: &RgbaImage, rect: [f32; 4], img: &RgbaImage) -> f64 {
    let (x0, y0) = (rect[0].ceil() as u32, rect[1].ceil() as u32);
    let (x1, y1) = (rect[2].floor() as u32, rect[3].floor() as u32);
    let scaled = image::imageops::resize(img, x1 - x0, y1 - y0, image::imageops::FilterType::Triangle);
    let mut sum = 0.0;
    let mut n = 0.0;
    for (x, y, p) in scaled.enumerate_pixels() {
        let s = shot.get_pixel(x0 + x, y0 + y);
        for c in 0..3 {
            sum += (f64::from(s[c]) - f64::from(p[c])).abs();
            n += 1.0;
        }
    }
    sum / n
}

#[test]
fn a_visit_through_the_real_windows() {
    // Explore (tap), look, long press (radial menu), point up and release (go-to the first
    // candidate), watch its overlay, then open the menu over it and let go.
    let script = Script::new()
        .wait(0.3)
        .tap(1, 0.5, 0.86)
        .wait(1.2)
        .radial_pick(2, (0.5, 0.5), 1.3, (0.5, 0.3))
        .wait(4.0)
        .down(3, 0.5, 0.5)
        .wait(1.2)
        .cancel(3)
        .cancel(99);
    let run = run(&script, &[0.2, 1.5, 2.7, 6.8, 8.1], "", 1.0);
    // Gallery: the model turns on the projection, the controller shows the gallery card.
    assert_eq!(run.frame(0.2)["mode"], "gallery");
    let gallery_proj = run.shot("projection", 0.2);
    assert_eq!(gallery_proj.dimensions(), (1280, 720));
    assert!(bright(&gallery_proj, (440, 100, 840, 620), 150.0) > 0.25, "model on the projection");
    // Exploring: the model on the projection; on the controller nothing but help and buttons.
    assert_eq!(run.frame(1.5)["mode"], "explore");
    let proj = run.shot("projection", 1.5);
    let ctrl = run.shot("controller", 1.5);
    assert!(bright(&proj, (440, 100, 840, 620), 150.0) > 0.25, "model visible while exploring");
    assert!(
        bright(&ctrl, (0, 0, ctrl.width(), ctrl.height()), 150.0) < 0.03,
        "no model content on the controller"
    );
    let gallery_ctrl = run.shot("controller", 0.2);
    assert!(
        bright(&gallery_ctrl, (160, 85, 640, 355), 150.0) > 0.1,
        "the gallery card shows the model's picture (so the check above can see a model)"
    );
    // Long press: the radial menu with the candidates' thumbnails where the menu puts them.
    let f = run.frame(2.7);
    let candidates: Vec<String> = f["explore"]["menu"]["candidates"]
        .as_array()
        .unwrap_or_else(|| panic!("menu open at 2.7 s: {f}"))
        .iter()
        .map(|c| c.as_str().expect("id").to_string())
        .collect();
    assert!(!candidates.is_empty(), "candidates near the start view");
    let menu = run.shot("projection", 2.7);
    for (i, id) in candidates.iter().enumerate() {
        let thumb = image::open(content().join(format!("demosthenes/thumbs/{id}.png")))
            .expect("thumbnail")
            .to_rgba8();
        let rect = kiosk::windows::radial_slot_px((1280, 720), i, candidates.len());
        let in_menu = region_difference(&menu, rect, &thumb);
        let before = region_difference(&proj, rect, &thumb);
        assert!(
            in_menu < 20.0 && in_menu < before * 0.6,
            "thumbnail of {id}: {in_menu:.1} vs {before:.1} without the menu"
        );
    }
    // Released upwards: the first candidate is reached and its overlay shows.
    let f = run.frame(6.8);
    assert_eq!(f["explore"]["overlay"], Value::String(candidates[0].clone()), "{f}");
    let overlay = image::open(content().join(format!("demosthenes/overlays/{}-en.png", candidates[0])))
        .expect("overlay")
        .to_rgba8();
    let shown = overlay_match(&run.shot("projection", 6.8), &overlay);
    let not_shown = overlay_match(&proj, &overlay);
    assert!(
        shown > 0.7 && not_shown < 0.1,
        "overlay drawn: {shown:.2} of its strokes (before: {not_shown:.2})"
    );
    // The narration's captions on the controller (the node's text, in the bottom band).
    assert_eq!(f["explore"]["recommender"], "display");
    let band = (70, 400, 730, 470);
    let captions = bright(&run.shot("controller", 6.8), band, 150.0);
    assert!(captions > 0.02 && captions > 4.0 * bright(&ctrl, band, 150.0), "captions: {captions:.3}");
    // The menu opened over the overlay: the overlay stays on display but fades back, so that
    // the menu's labels do not cross its drawings.
    let f = run.frame(8.1);
    assert_eq!(f["explore"]["overlay"], Value::String(candidates[0].clone()), "{f}");
    assert!(f["explore"]["menu"]["candidates"].is_array(), "menu open at 8.1 s: {f}");
    let under_menu = overlay_match(&run.shot("projection", 8.1), &overlay);
    assert!(under_menu < 0.2, "overlay under the menu: {under_menu:.2} of its strokes at full colour");
}

#[test]
fn attract_loop_and_reset_with_an_accelerated_clock() {
    let script = Script::new().wait(0.3).tap(1, 0.5, 0.86).wait(11.0).cancel(99);
    let config = "attract_after_secs = 3.0\nreset_after_secs = 8.0\n";
    let run = run(&script, &[1.0, 5.0, 10.0], config, 3.0);
    assert_eq!(run.frame(1.0)["mode"], "explore");
    let f = run.frame(5.0);
    assert_eq!(f["mode"], "attract", "{f}");
    let countdown = f["countdown"].as_f64().expect("countdown");
    assert!((countdown - (0.35 + 8.0 - 5.0)).abs() < 0.05, "countdown {countdown}");
    assert_eq!(run.frame(10.0)["mode"], "gallery");
    // The controller calls the visitor during the attract loop: big text in the middle.
    let attract = run.shot("controller", 5.0);
    let exploring = run.shot("controller", 1.0);
    let middle = (150, 150, 650, 330);
    assert!(
        bright(&attract, middle, 150.0) > 2.0 * bright(&exploring, middle, 150.0) + 0.005,
        "\"touch to explore\" shown"
    );
    // Back in the gallery after the reset: the card with the first model's picture.
    let card = bright(&run.shot("controller", 10.0), (160, 85, 640, 355), 150.0);
    assert!(card > 0.1, "the gallery card after the reset: {card:.3} of its pixels bright\n{}", run.stderr);
    // The visit went to the log of the test's state directory, with its end; the statistics too.
    let state = run.dir.path().join("state");
    let log = std::fs::read_to_string(state.join("visits.jsonl")).expect("visit log");
    let visits: Vec<Value> = log.lines().map(|l| serde_json::from_str(l).expect("JSON line")).collect();
    assert_eq!(visits.len(), 1, "{log}");
    assert_eq!(visits[0]["ended"], "reset");
    assert_eq!(visits[0]["models"][0]["exhibit"], "demosthenes");
    assert!(visits[0]["wall_start"].as_f64().is_some_and(|w| w > 1.6e9), "{log}");
    let stats: Value =
        serde_json::from_str(&std::fs::read_to_string(state.join("demosthenes/stats.json")).expect("stats"))
            .expect("stats JSON");
    assert_eq!(stats["visits"], 1);
}

#[test]
fn broken_content_is_logged_once_and_the_rest_keeps_working() {
    // A copy of the Demosthenes exhibit with the intro's overlay truncated and its narration
    // missing, and a second exhibit whose model is garbage.
    let content = tempfile::tempdir().expect("temp dir");
    let good = content.path().join("a-demosthenes");
    crate::common::copy_dir(&self::content().join("demosthenes"), &good);
    let overlay = good.join("overlays/intro-en.png");
    let bytes = std::fs::read(&overlay).expect("overlay");
    std::fs::write(&overlay, &bytes[..bytes.len() / 3]).expect("truncate overlay");
    std::fs::remove_file(good.join("audio/intro-en.wav")).expect("remove narration");
    // Paths that lead out of the exhibit, and a FIFO where an overlay should be: none is read
    // (a FIFO would block the kiosk), each is reported once, the node keeps its other content.
    std::fs::write(content.path().join("secret.png"), &bytes).expect("a file outside the exhibit");
    let graph = good.join("graph.xml");
    let xml = std::fs::read_to_string(&graph).expect("graph");
    let xml =
        xml.replacen("thumbs/intro.png", "../secret.png", 1).replacen("roi/intro.png", "/etc/hostname", 1);
    std::fs::write(&graph, xml).expect("edit graph");
    let fifo = good.join("overlays/intro-it.png");
    std::fs::remove_file(&fifo).expect("remove overlay");
    assert!(Command::new("mkfifo").arg(&fifo).status().expect("mkfifo").success());
    // A misspelt key in its exhibit.toml: the key is ignored (reported once), the exhibit shows
    // with the up the file states.
    std::fs::write(good.join("exhibit.toml"), "up = \"y\"\nfrnt = \"-z\"\n").expect("exhibit.toml");
    let broken = content.path().join("b-broken");
    std::fs::create_dir_all(&broken).expect("mkdir");
    std::fs::write(broken.join("model.obj"), "v 1 2 three\nf 1 2 9\n").expect("garbage model");
    // Explore, then go to the intro twice through the radial menu (its overlay and narration
    // are asked for twice; each problem must be logged once).
    let menu_to_top = |s: Script| s.radial_pick(2, (0.5, 0.5), 1.0, (0.5, 0.3));
    let mut script = Script::new().wait(0.3).tap(1, 0.5, 0.86).wait(0.5);
    script = menu_to_top(script).wait(4.0).joystick(3, (0.2, 0.0), 1.0).wait(0.5);
    script = menu_to_top(script).wait(4.0).cancel(99);
    let run = run_in(content.path(), &script, &[6.0], "", 1.0);
    // Problems are logged as errors or warnings (the broken exhibit's import also logs its
    // start, as information).
    let count = |needle: &str| {
        let problem = |l: &&str| l.contains("ERROR") || l.contains("WARN");
        run.stderr.lines().filter(problem).filter(|l| l.contains(needle)).count()
    };
    assert_eq!(count("b-broken"), 1, "the broken exhibit is reported once:\n{}", run.stderr);
    assert_eq!(count("intro-en.png"), 1, "the broken overlay is reported once:\n{}", run.stderr);
    assert_eq!(count("intro-en.wav"), 1, "the missing narration is reported once:\n{}", run.stderr);
    assert_eq!(count("../secret.png"), 1, "a path out of the exhibit is reported once:\n{}", run.stderr);
    assert_eq!(count("/etc/hostname"), 1, "an absolute path is reported once:\n{}", run.stderr);
    assert_eq!(count("intro-it.png"), 1, "a FIFO overlay is reported once:\n{}", run.stderr);
    assert_eq!(count("unknown key `frnt`"), 1, "a misspelt key is reported once:\n{}", run.stderr);
    let displayed: Vec<&str> = run.trace.iter().filter_map(|f| f["explore"]["overlay"].as_str()).collect();
    assert!(displayed.contains(&"intro"), "the intro was displayed (without its drawing)");
    assert!(run.trace.iter().all(|f| f["model"] == 0), "the gallery holds only the good exhibit");
    let shot = run.shot("projection", 6.0);
    assert!(bright(&shot, (440, 100, 840, 620), 150.0) > 0.2, "the model still shows");
}

/// An exhibit `dir` whose scan is a PLY of `n` points without normals: a Fibonacci sphere of
/// radius 0.3, even and the same at every run (2.5 M points take a few seconds to import here).
fn write_sphere(dir: &Path, n: u32) {
    std::fs::create_dir_all(dir).expect("mkdir");
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n"
    )
    .into_bytes();
    ply.extend_from_slice(b"property float z\nend_header\n");
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    for i in 0..n {
        let y = 1.0 - 2.0 * (f64::from(i) + 0.5) / f64::from(n);
        let r = (1.0 - y * y).sqrt();
        let a = golden * f64::from(i);
        for c in [r * a.cos(), y, r * a.sin()] {
            ply.extend_from_slice(&((0.3 * c) as f32).to_le_bytes());
        }
    }
    std::fs::write(dir.join("sphere.ply"), ply).expect("write scan");
}

#[test]
fn the_windows_say_the_kiosk_is_preparing_while_a_new_scan_is_imported() {
    // A new scan of 2.5 M points without normals: the kiosk imports it into the cache before the
    // gallery opens (a few seconds here, minutes for a museum's scans), its windows open first
    // and say so.
    let content = tempfile::tempdir().expect("temp dir");
    write_sphere(&content.path().join("sphere"), 2_500_000);
    let script = Script::new().wait(1.5).cancel(99);
    let run = run_in(content.path(), &script, &[1.0], "", 1.0);
    assert!(!run.stderr.contains("ERROR"), "the kiosk logged errors:\n{}", run.stderr);
    let at = |needle: &str| {
        run.stderr.find(needle).unwrap_or_else(|| panic!("no \"{needle}\" in the log:\n{}", run.stderr))
    };
    assert!(
        at("windows open: preparing the exhibits") < at("importing sphere.ply: done"),
        "the windows opened before the import ended:\n{}",
        run.stderr
    );
    // Its first frame: the words in English (large) and Italian, and a dot of the pulse lit, on
    // both windows; the controller's small print at its foot.
    let projection = run.tagged("projection", "preparing");
    let controller = run.tagged("controller", "preparing");
    let (pw, ph) = projection.dimensions();
    let (cw, ch) = controller.dimensions();
    let words = bright(&projection, (pw / 10, ph * 34 / 100, pw * 9 / 10, ph / 2), 150.0);
    assert!(words > 0.02, "the words on the projection: {words:.3} of the band bright");
    assert!(amber(&projection, (0, 0, pw, ph)) > 0.0, "a lit dot on the projection");
    let foot = bright(&controller, (0, ch * 84 / 100, cw, ch * 94 / 100), 100.0);
    assert!(foot > 0.005, "the small print on the controller: {foot:.3}");
    let bare = bright(&projection, (0, ph * 84 / 100, pw, ph * 94 / 100), 100.0);
    assert_eq!(bare, 0.0, "no small print on the projection");
    // Then the kiosk runs as ever: the sphere in the gallery.
    let shot = run.shot("projection", 1.0);
    assert!(
        bright(&shot, (pw * 4 / 10, ph * 4 / 10, pw * 6 / 10, ph * 6 / 10), 60.0) > 0.5,
        "the model shows"
    );
}

#[test]
fn the_gallery_opens_with_the_exhibits_at_hand_and_a_new_scan_joins_it_once_imported() {
    // A bust whose model is a store, and a new scan of 1.5 M points: the gallery opens with the
    // bust at once, the scan is imported behind it and joins the gallery when nobody is there.
    let content = tempfile::tempdir().expect("temp dir");
    let bust = content.path().join("bust");
    std::fs::create_dir_all(&bust).expect("mkdir");
    let out = Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .arg("import")
        .arg(self::content().join("demosthenes/demosthenes-low-res.obj"))
        .arg("-o")
        .arg(bust.join("bust.kstore"))
        .arg("--quiet")
        .output()
        .expect("kiosk import");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    write_sphere(&content.path().join("sphere"), 1_500_000);
    let dir = tempfile::tempdir().expect("temp dir");
    let kiosk = Kiosk { config: "attract_after_secs = 0.5\nreset_after_secs = 1.0\n", screenshots: false };
    let steps = [("the gallery now holds", "")];
    // No session: a played one needs the whole gallery from its start, so it waits for imports.
    let (status, log) = stopped_by_a_signal(content.path(), dir.path(), None, &kiosk, &steps, 0.5);
    assert_eq!(status, 0, "{log}");
    assert!(!log.contains("ERROR"), "{log}");
    let at = |needle: &str| log.find(needle).unwrap_or_else(|| panic!("no \"{needle}\" in the log:\n{log}"));
    let opens = at("the gallery opens: 1 exhibit(s)");
    assert!(log[opens..].lines().next().is_some_and(|l| l.contains("1 more join it once imported")), "{log}");
    let imported = at("importing sphere.ply: done");
    let joins = at("the gallery now holds 2 exhibits");
    assert!(opens < imported && imported < joins, "opened, imported, joined in turn:\n{log}");
    assert!(
        log.contains(&format!("imported behind the gallery: {}", content.path().join("sphere").display())),
        "{log}"
    );
}

#[test]
fn a_kiosk_without_a_loadable_exhibit_says_it_is_closed_and_opens_when_content_comes() {
    // No exhibit yet (a content disk not mounted at boot, a copy under way): the kiosk stays up,
    // says the exhibition is closed, names the reason once in its log, and looks at the content
    // every second; the exhibit comes, and the gallery opens without a restart.
    let content = tempfile::tempdir().expect("temp dir");
    let dir = tempfile::tempdir().expect("temp dir");
    let staged = dir.path().join("staged");
    crate::common::copy_dir(&self::content().join("demosthenes"), &staged);
    let arrive = format!(
        "sleep 2.5; mv {:?} {:?}",
        staged.display().to_string(),
        content.path().join("demosthenes").display().to_string()
    );
    let steps = [("the exhibition is closed", arrive.as_str()), ("the gallery opens", "")];
    let kiosk = Kiosk { config: "retry_after_secs = 1.0\n", screenshots: true };
    // No session: a played one ends the kiosk when no exhibit loads (a test, not a museum).
    let (status, log) = stopped_by_a_signal(content.path(), dir.path(), None, &kiosk, &steps, 0.5);
    assert_eq!(status, 0, "{log}");
    let said =
        format!("no exhibit could be loaded from {}: the exhibition is closed", content.path().display());
    assert_eq!(log.matches(&said).count(), 1, "said once, however often tried:\n{log}");
    // Looked at every second, tried again once: when the exhibit came.
    let tried = log.matches("the content changed: trying the exhibits again").count();
    assert_eq!(tried, 1, "tried again only when the content changed:\n{log}");
    assert!(log.contains("the gallery opens: 1 exhibit(s)"), "{log}");
    // The closed screen: the words on both windows, no pulse, the reason at the controller's foot.
    let shot = |window: &str| {
        let p = dir.path().join(format!("{window}-closed.png"));
        image::open(&p).unwrap_or_else(|e| panic!("{}: {e}\n{log}", p.display())).to_rgba8()
    };
    let (projection, controller) = (shot("projection"), shot("controller"));
    let (pw, ph) = projection.dimensions();
    let (cw, ch) = controller.dimensions();
    let words = bright(&projection, (pw / 10, ph * 34 / 100, pw * 9 / 10, ph / 2), 150.0);
    assert!(words > 0.02, "the words on the projection: {words:.3} of the band bright");
    assert_eq!(amber(&projection, (0, 0, pw, ph)), 0.0, "no pulse: nothing is being prepared");
    let foot = bright(&controller, (0, ch * 84 / 100, cw, ch * 94 / 100), 100.0);
    assert!(foot > 0.005, "the reason on the controller: {foot:.3}");
}

/// How [`stopped_by_a_signal`] runs the kiosk: lines added to its configuration, and whether it
/// saves its screenshots (in the test's directory; none is due in a session that lasts).
struct Kiosk<'a> {
    config: &'a str,
    screenshots: bool,
}

impl Kiosk<'_> {
    const PLAIN: Self = Self { config: "", screenshots: false };
}

/// Starts the kiosk under Xvfb on the exhibits of `content` (its cache, state and screenshots in
/// `dir`, playing `script` if any: a played session ends the kiosk when no exhibit loads), and for each step in turn waits for its log to say the step's line
/// (at most a minute) and runs the step's shell command; sends it SIGTERM `delay` seconds after
/// the last, and returns its exit status and its log.
fn stopped_by_a_signal(
    content: &Path,
    dir: &Path,
    script: Option<&Script>,
    kiosk: &Kiosk<'_>,
    steps: &[(&str, &str)],
    delay: f64,
) -> (i32, String) {
    let mut args = Vec::new();
    if let Some(script) = script {
        let session = dir.join("session.jsonl");
        std::fs::write(&session, script.session().to_jsonl()).expect("write session");
        args.push(format!("--session {}", session.display()));
    }
    let cfg = dir.join("kiosk.toml");
    std::fs::write(&cfg, format!("content = {:?}\n{}", content.display().to_string(), kiosk.config))
        .expect("config");
    let log = dir.join("kiosk.log");
    let runtime = std::env::temp_dir().join("xdg-runtime-isokiosk-tests");
    std::fs::create_dir_all(&runtime).expect("runtime dir");
    if kiosk.screenshots {
        args.push(format!("--screenshot-at 99 --screenshot-dir {}", dir.display()));
    }
    // The shell follows the steps, then stops the kiosk as a service manager would.
    let script = r#"
        "$KIOSK" --config "$CFG" --windowed --silent $KIOSK_ARGS 2> "$LOG" &
        pid=$!
        i=0
        while [ $i -lt "$STEPS" ]; do
            eval "when=\$WHEN_$i; then=\$THEN_$i"
            for t in $(seq 600); do grep -q "$when" "$LOG" && break; sleep 0.1; done
            sh -c "$then"
            i=$((i + 1))
        done
        sleep "$DELAY"
        kill -TERM $pid
        wait $pid
        echo "status $?"
    "#;
    let mut command = Command::new("xvfb-run");
    command
        .args(["-a", "-s", "-screen 0 2200x800x24 -nolisten tcp", "sh", "-c", script])
        .env("KIOSK", env!("CARGO_BIN_EXE_kiosk"))
        .env("CFG", &cfg)
        .env("LOG", &log)
        .env("KIOSK_ARGS", args.join(" "))
        .env("STEPS", steps.len().to_string())
        .env("DELAY", delay.to_string())
        .env("ISOKIOSK_CACHE", dir.join("cache"))
        .env("ISOKIOSK_STATE", dir.join("state"))
        .env("XDG_RUNTIME_DIR", &runtime)
        .env("RUST_LOG", "info,wgpu_core=warn,wgpu_hal=warn,naga=warn");
    for (i, (when, then)) in steps.iter().enumerate() {
        command.env(format!("WHEN_{i}"), when).env(format!("THEN_{i}"), then);
    }
    let out = command.output().expect("xvfb-run must be installed (.ci/setup installs xvfb and xauth)");
    let log = std::fs::read_to_string(&log).unwrap_or_default();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let status = stdout
        .lines()
        .find_map(|l| l.strip_prefix("status "))
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("no status: {stdout}\n{}\n{log}", String::from_utf8_lossy(&out.stderr)));
    (status, log)
}

#[test]
fn a_signal_closes_the_kiosk_as_ctrl_q_does_while_preparing_and_while_running() {
    // Stopped by its service during a visit: the kiosk closes, and the visit in progress is in
    // the log with its end.
    let content = tempfile::tempdir().expect("temp dir");
    crate::common::copy_dir(&self::content().join("demosthenes"), &content.path().join("demosthenes"));
    let dir = tempfile::tempdir().expect("temp dir");
    let visit = Script::new().wait(0.3).tap(1, 0.5, 0.86).wait(120.0).cancel(99);
    let steps = [("the gallery opens", "")];
    let (status, log) =
        stopped_by_a_signal(content.path(), dir.path(), Some(&visit), &Kiosk::PLAIN, &steps, 2.0);
    assert_eq!(status, 0, "{log}");
    assert!(log.contains("a signal asks the kiosk to close"), "{log}");
    let visits = std::fs::read_to_string(dir.path().join("state/visits.jsonl")).expect("visit log");
    let visits: Vec<Value> = visits.lines().map(|l| serde_json::from_str(l).expect("JSON line")).collect();
    assert_eq!(visits.len(), 1, "{visits:?}");
    assert_eq!(visits[0]["ended"], "exit");

    // Stopped while it imports a new scan: it closes at once, without the import's work
    // directory (the next start imports again).
    let exhibit = content.path().join("demosthenes");
    std::fs::remove_dir_all(&exhibit).expect("remove");
    std::fs::create_dir_all(&exhibit).expect("mkdir");
    crate::common::write_relief_ply(&exhibit.join("relief.ply"), 1600);
    let dir = tempfile::tempdir().expect("temp dir");
    let steps = [("windows open: preparing the exhibits", "")];
    let (status, log) =
        stopped_by_a_signal(content.path(), dir.path(), Some(&visit), &Kiosk::PLAIN, &steps, 0.0);
    assert_eq!(status, 0, "{log}");
    assert!(log.contains("importing relief.ply: reading") && !log.contains("relief.ply: done"), "{log}");
    assert!(log.contains("closed while preparing the exhibits"), "{log}");
    let left: Vec<String> = std::fs::read_dir(dir.path().join("cache"))
        .expect("cache")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".import-"))
        .collect();
    assert!(left.is_empty(), "work directories left: {left:?}\n{log}");
}

/// Fraction of the pixels of a region in the interface's amber (the Light button when on, the
/// light's dot on its pad).
fn amber(img: &RgbaImage, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> f64 {
    let mut n = 0;
    let mut hit = 0;
    for y in y0..y1.min(img.height()) {
        for x in x0..x1.min(img.width()) {
            let p = img.get_pixel(x, y);
            n += 1;
            hit += usize::from(p[0] > 180 && i32::from(p[0]) - i32::from(p[2]) > 90);
        }
    }
    hit as f64 / n.max(1) as f64
}

#[test]
fn the_light_button_and_a_drag_relight_the_model_through_the_real_windows() {
    // Explore; tap Light (on); one finger drags far to the left and holds, then lifts.
    let (bx, by) = (0.56, 0.07);
    let script = Script::new()
        .wait(0.3)
        .tap(1, 0.5, 0.86)
        .wait(1.0)
        .tap(2, bx, by)
        .wait(0.5)
        .down(3, 0.5, 0.5)
        .drag(&[(3, (0.5, 0.5), (0.1, 0.5))], 0.6)
        .wait(0.6)
        .up(3, 0.1, 0.5)
        .wait(1.0)
        .cancel(99);
    let run = run(&script, &[1.2, 2.8, 3.8], "", 1.0);
    let light = |t: f64| -> Vec<f64> {
        let f = run.frame(t);
        f["explore"]["light"]
            .as_array()
            .unwrap_or_else(|| panic!("light traced at {t}: {f}"))
            .iter()
            .map(|v| v.as_f64().expect("number"))
            .collect()
    };
    assert_eq!(run.frame(1.2)["mode"], "explore");
    assert!(run.frame(1.2).get("light_on").is_none(), "the light is off at first");
    assert_eq!(run.frame(2.8)["light_on"], true, "the tap switched the light on");
    let (before, after) = (light(1.2), light(3.8));
    // A grazing light from the left of the start view (which looks down -Z with +X right).
    assert!(after[2].abs() < 1e-6 && after[0] < -0.9, "raking from the left: {after:?} (before {before:?})");
    // The finger steered the light, not the camera (which the story engine may still fly to a
    // view: the demo's first view is reached by attraction, and a view without a light of its
    // own keeps the visitor's).
    for f in run.trace.iter().filter(|f| f["t"].as_f64().is_some_and(|t| (1.2..=3.8).contains(&t))) {
        let c = &f["explore"]["controller"];
        assert!(c == "idle" || c == "go-to", "the camera was driven: {f}");
    }
    assert_eq!(light(3.3), after, "the light stays after the finger lifts");
    // The controller: the Light button lit, the light's dot on its pad while the finger holds.
    let (off, on) = (run.shot("controller", 1.2), run.shot("controller", 2.8));
    let button = (390, 6, 506, 61);
    assert!(amber(&on, button) > 0.3 && amber(&off, button) < 0.05, "the Light button is lit when on");
    let pad = (150, 90, 650, 400);
    assert!(amber(&on, pad) > 0.0005 && amber(&off, pad) == 0.0, "the light's dot on its pad");
    // The projection: the same view in another light.
    let (a, b) = (run.shot("projection", 1.2), run.shot("projection", 3.8));
    let (mut sum, mut n) = (0.0, 0.0);
    for y in 100..620 {
        for x in 440..840 {
            sum += (luma(a.get_pixel(x, y)) - luma(b.get_pixel(x, y))).abs();
            n += 1.0;
        }
    }
    assert!(sum / n > 3.0, "the model is lit differently: mean change {:.2}", sum / n);
}

#[test]
fn snapshot_renders_a_node_in_its_stored_light() {
    // A copy of the Demosthenes exhibit whose "face" view stores a raking light from the left.
    let dir = tempfile::tempdir().expect("temp dir");
    let exhibit = dir.path().join("demosthenes");
    crate::common::copy_dir(&content().join("demosthenes"), &exhibit);
    let shot = |name: &str| -> RgbaImage {
        let out = dir.path().join(name);
        crate::common::snapshot(
            &exhibit,
            &out,
            &crate::common::cache(),
            &["--node", "face", "--size", "320x180"],
        )
    };
    let plain = shot("plain.png");
    let graph = exhibit.join("graph.xml");
    let xml = std::fs::read_to_string(&graph).expect("graph");
    let (g, _) = kiosk_core::graph::InfoGraph::from_xml(&xml).expect("graph");
    let mut lit = g.clone();
    let i = lit.index_of("face").expect("face");
    let view = lit.nodes[i].view;
    lit.nodes[i].light = Some(-view.right());
    std::fs::write(&graph, lit.to_xml_over(&xml).expect("save")).expect("write");
    let raking = shot("raking.png");
    let (mut sum, mut n) = (0.0, 0.0);
    for (a, b) in plain.pixels().zip(raking.pixels()) {
        sum += (luma(a) - luma(b)).abs();
        n += 1.0;
    }
    assert!(sum / n > 2.0, "the stored light changed the picture: mean change {:.2}", sum / n);
}
