//! Two monitors, as installed: the real `kiosk`, fullscreen (no `--windowed`), on an Xorg server
//! whose dummy driver has two RandR outputs (Xvfb shows winit a single monitor), with no window
//! manager. Each window must cover its configured monitor exactly (read from the X server), a
//! projector on its side (`rotation = 90`) gets a portrait canvas, and a touch session on the
//! controller moves the projection's camera.

use super::{Run, bright, content};
use kiosk_core::session::Script;
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const SETUP: &str = "the two-monitor test needs Xorg's dummy driver, xrandr and xwininfo: run .ci/setup";

/// A 1280x720 output (DUMMY0) and room for an 800x480 one (DUMMY1) to its right.
const XORG_CONF: &str = r#"Section "Device"
  Identifier "d"
  Driver "dummy"
  VideoRam 256000
EndSection
Section "Monitor"
  Identifier "m"
  HorizSync 5.0-1000.0
  VertRefresh 5.0-200.0
EndSection
Section "Screen"
  Identifier "s"
  Device "d"
  Monitor "m"
  DefaultDepth 24
  SubSection "Display"
    Depth 24
    Virtual 2200 800
  EndSubSection
EndSection
"#;

/// A child process ended when dropped (also when an assertion fails): asked to terminate (the X
/// server then removes its socket and lock file), killed if it has not after 3 s.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            let _ = Command::new("kill").args(["-TERM", &self.0.id().to_string()]).status();
            let start = Instant::now();
            while matches!(self.0.try_wait(), Ok(None)) && start.elapsed() < Duration::from_secs(3) {
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A window on the X screen: (its line of `xwininfo -tree`, width, height, x, y).
type Placed = (String, u32, u32, i32, i32);

/// An Xorg server on a free display, in its own temp dir, stopped when dropped.
struct Xorg {
    server: Killed,
    display: String,
    dir: tempfile::TempDir,
}

impl Xorg {
    /// Starts the server and sets up the two monitors: 1280x720 at 0,0 and 800x480 at 1280,0.
    fn start() -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let conf = dir.path().join("xorg.conf");
        std::fs::write(&conf, XORG_CONF).expect("write xorg.conf");
        let mut child = Command::new("Xorg")
            // The server picks a free display and writes its number on stdout once it accepts
            // connections.
            .args(["-displayfd", "1", "-config"])
            .arg(&conf)
            .args(["-noreset", "-nolisten", "tcp", "-logfile"])
            .arg(dir.path().join("xorg.log"))
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot run Xorg ({e}): {SETUP}"));
        let stdout = child.stdout.take().expect("Xorg's stdout");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut lines = BufReader::new(stdout).lines();
            let _ = tx.send(lines.next().and_then(Result::ok));
            lines.for_each(drop);
        });
        let line = rx.recv_timeout(Duration::from_secs(20)).ok().flatten().unwrap_or_default();
        let mut x = Self { server: Killed(child), display: format!(":{}", line.trim()), dir };
        assert!(line.trim().parse::<u32>().is_ok(), "Xorg did not start ({SETUP}):\n{}", x.log());
        let mode = "800x480_60 29.50 800 824 896 992 480 483 493 500 -hsync +vsync";
        x.xrandr(&["--newmode"].into_iter().chain(mode.split(' ')).collect::<Vec<_>>());
        x.xrandr(&["--addmode", "DUMMY1", "800x480_60"]);
        x.xrandr(&["--output", "DUMMY0", "--mode", "1280x720", "--pos", "0x0"]);
        x.xrandr(&["--output", "DUMMY1", "--mode", "800x480_60", "--pos", "1280x0"]);
        let monitors = x.xrandr(&["--listmonitors"]);
        assert!(monitors.starts_with("Monitors: 2"), "two monitors expected:\n{monitors}\n{}", x.log());
        assert!(x.server.0.try_wait().expect("Xorg status").is_none(), "Xorg exited:\n{}", x.log());
        x
    }

    fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        // Never a Wayland compositor of the machine running the tests: this X server.
        c.env("DISPLAY", &self.display).env_remove("WAYLAND_DISPLAY");
        c
    }

    fn xrandr(&self, args: &[&str]) -> String {
        let out = self
            .command("xrandr")
            .args(args)
            .output()
            .unwrap_or_else(|e| panic!("cannot run xrandr ({e}): {SETUP}"));
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "xrandr {args:?}: {stderr}\n{}", self.log());
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    /// The end of the server's log.
    fn log(&self) -> String {
        let log = std::fs::read_to_string(self.dir.path().join("xorg.log")).unwrap_or_default();
        let lines: Vec<&str> = log.lines().collect();
        lines[lines.len().saturating_sub(30)..].join("\n")
    }

    /// The kiosk's windows as the X server has them: (title, width, height, x, y).
    fn windows(&self) -> Vec<Placed> {
        let out = self
            .command("xwininfo")
            .args(["-root", "-tree"])
            .output()
            .unwrap_or_else(|e| panic!("cannot run xwininfo ({e}): {SETUP}"));
        assert!(out.status.success(), "xwininfo: {}", String::from_utf8_lossy(&out.stderr));
        // `0x200002 "IsoKiosk — projection": ("kiosk" "kiosk")  1280x720+0+0  +0+0`: the size,
        // then the position on the root window.
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        text.lines()
            .filter(|l| l.contains("IsoKiosk"))
            .map(|l| {
                let tokens: Vec<&str> = l.split_whitespace().collect();
                let at = tokens.iter().rposition(|t| t.contains('x') && t.contains('+')).expect(l);
                let (w, h) = tokens[at].split(['+', '-']).next().and_then(|s| s.split_once('x')).expect(l);
                let abs: Vec<i32> = tokens[at + 1]
                    .replace('-', "+-")
                    .split('+')
                    .filter(|s| !s.is_empty())
                    .map(|s| s.parse().expect(l))
                    .collect();
                (l.to_string(), w.parse().expect(l), h.parse().expect(l), abs[0], abs[1])
            })
            .collect()
    }

    /// Runs the kiosk fullscreen on a session with screenshots; returns the run and the windows'
    /// geometry once the first screenshots were taken.
    fn kiosk(&self, script: &Script, shots: &[f64], config: &str) -> (Run, Vec<Placed>) {
        let dir = tempfile::tempdir().expect("temp dir");
        let session = dir.path().join("session.jsonl");
        std::fs::write(&session, script.session().to_jsonl()).expect("write session");
        let cfg = dir.path().join("kiosk.toml");
        let content = content().display().to_string();
        std::fs::write(&cfg, format!("content = {content:?}\n{}{config}", super::EXHIBITS)).expect("config");
        let trace = dir.path().join("trace.jsonl");
        let log = dir.path().join("kiosk.log");
        let runtime = std::env::temp_dir().join("xdg-runtime-isokiosk-tests");
        std::fs::create_dir_all(&runtime).expect("runtime dir");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&runtime, std::fs::Permissions::from_mode(0o700)).expect("chmod");
        }
        let at: Vec<String> = shots.iter().map(|t| format!("{t}")).collect();
        let kiosk = self
            .command(env!("CARGO_BIN_EXE_kiosk"))
            .env("ISOKIOSK_CACHE", crate::common::cache())
            .arg("--config")
            .arg(&cfg)
            .arg("--silent")
            .arg("--session")
            .arg(&session)
            .arg("--trace")
            .arg(&trace)
            .arg("--screenshot-at")
            .arg(at.join(","))
            .arg("--screenshot-dir")
            .arg(dir.path())
            .env("XDG_RUNTIME_DIR", &runtime)
            // Visit statistics go to the test's directory, not the user's state.
            .env("ISOKIOSK_STATE", dir.path().join("state"))
            .env("RUST_LOG", "info,wgpu_core=warn,wgpu_hal=warn,naga=warn")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).expect("kiosk log"))
            .spawn()
            .expect("run the kiosk");
        let mut kiosk = Killed(kiosk);
        let stderr = || std::fs::read_to_string(&log).unwrap_or_default();
        // The windows, once both canvases were saved a first time (the windows are placed then).
        let first = dir.path().join(format!("controller-{:.1}.png", shots[0]));
        let start = Instant::now();
        while !first.exists() {
            if let Some(status) = kiosk.0.try_wait().expect("kiosk status") {
                panic!("kiosk exited before its first screenshot: {status}\n{}", stderr());
            }
            assert!(start.elapsed() < Duration::from_secs(30), "no screenshot after 30 s:\n{}", stderr());
            std::thread::sleep(Duration::from_millis(50));
        }
        let windows = self.windows();
        let status = loop {
            if let Some(status) = kiosk.0.try_wait().expect("kiosk status") {
                break status;
            }
            assert!(start.elapsed() < Duration::from_secs(60), "the kiosk did not end:\n{}", stderr());
            std::thread::sleep(Duration::from_millis(50));
        };
        let stderr = stderr();
        assert!(status.success(), "kiosk failed: {status}\n{stderr}");
        assert!(!stderr.contains("ERROR"), "the kiosk logged errors:\n{stderr}");
        let trace = std::fs::read_to_string(&trace)
            .expect("trace")
            .lines()
            .map(|l| serde_json::from_str(l).expect("trace line is JSON"))
            .collect();
        (Run { dir, trace, stderr }, windows)
    }
}

/// The window whose title names `which`: (width, height, x, y).
fn window(windows: &[Placed], which: &str) -> (u32, u32, i32, i32) {
    let found: Vec<_> = windows.iter().filter(|w| w.0.contains(&format!("{which}\""))).collect();
    assert_eq!(found.len(), 1, "one {which} window among {windows:#?}");
    let (_, w, h, x, y) = *found[0];
    (w, h, x, y)
}

fn eye(run: &Run, t: f64) -> [f64; 3] {
    let f = run.frame(t);
    let e: Vec<f64> = f["explore"]["eye"]
        .as_array()
        .unwrap_or_else(|| panic!("exploring at {t}: {f}"))
        .iter()
        .map(|v| v.as_f64().expect("eye coordinate"))
        .collect();
    [e[0], e[1], e[2]]
}

/// Mean absolute difference (0–255) of two screenshots of one size.
fn difference(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions());
    let sum: u64 = a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| u64::from(x.abs_diff(*y))).sum();
    sum as f64 / a.as_raw().len() as f64
}

/// Explore, then push the joystick to the right on the controller for a second.
fn visit() -> Script {
    Script::new().wait(0.3).tap(1, 0.5, 0.86).wait(0.9).joystick(2, (0.2, 0.0), 1.0).wait(0.3).cancel(99)
}

/// Checks a run: the joystick drag on the controller moves the camera, in the trace and on the
/// projection; the controller shows its buttons and no model.
fn check_visit(run: &Run, proj: (u32, u32), ctrl: (u32, u32)) {
    assert_eq!(run.frame(1.0)["mode"], "explore");
    let (before, after) = (eye(run, 1.0), eye(run, 2.6));
    let moved = before.iter().zip(&after).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
    assert!(moved > 0.5, "the joystick on the controller moves the camera: {before:?} → {after:?}");
    let (p0, p1) = (run.shot("projection", 1.0), run.shot("projection", 2.6));
    assert_eq!(p0.dimensions(), proj, "projection canvas");
    assert_eq!(run.shot("controller", 2.6).dimensions(), ctrl, "controller canvas");
    let (w, h) = proj;
    let middle = (w / 4, h / 4, 3 * w / 4, 3 * h / 4);
    assert!(bright(&p0, middle, 150.0) > 0.2, "the bust in the middle of the projection");
    assert!(difference(&p0, &p1) > 2.0, "the projection shows the camera's move");
    let c = run.shot("controller", 1.0);
    let buttons = bright(&c, (0, 0, ctrl.0, ctrl.1), 40.0);
    let model = bright(&c, (0, 0, ctrl.0, ctrl.1), 150.0);
    assert!(
        buttons > 0.02 && model < 0.03,
        "the controller's buttons ({buttons:.3}) and no model ({model:.3})"
    );
    let gallery = run.shot("controller", 0.2);
    assert!(bright(&gallery, (0, 0, ctrl.0, ctrl.1), 150.0) > 0.05, "the gallery card on the controller");
}

#[test]
fn fullscreen_on_two_monitors_as_installed() {
    let x = Xorg::start();
    let shots = [0.2, 1.0, 2.6];
    // Projection on the 1280x720 monitor, controller on the 800x480 one: each covers its
    // monitor, no `--windowed`.
    let config = "[projection]\nmonitor = 0\n[controller]\nmonitor = 1\n";
    let (run, windows) = x.kiosk(&visit(), &shots, config);
    assert_eq!(window(&windows, "projection"), (1280, 720, 0, 0), "{windows:#?}");
    assert_eq!(window(&windows, "controller"), (800, 480, 1280, 0), "{windows:#?}");
    check_visit(&run, (1280, 720), (800, 480));
    // A projector on its side, the monitors the other way round: the projection window still
    // covers its monitor, its canvas is drawn turned (portrait: 480x800); touches still drive it.
    let config = "[projection]\nmonitor = 1\nrotation = 90\n[controller]\nmonitor = 0\n";
    let (run, windows) = x.kiosk(&visit(), &shots, config);
    assert_eq!(window(&windows, "projection"), (800, 480, 1280, 0), "{windows:#?}");
    assert_eq!(window(&windows, "controller"), (1280, 720, 0, 0), "{windows:#?}");
    check_visit(&run, (480, 800), (1280, 720));
}
