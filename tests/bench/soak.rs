//! `cargo bench --bench soak [-- --hours H --speed S]`: the kiosk binary under Xvfb replays the
//! recorded demo visit (tests/sessions/kiosk-visit.jsonl: both models, radial menu, go-to,
//! language, help, back, gallery swipe, then idle → attract loop → reset) over and over for an
//! hour of kiosk time at an accelerated clock, and reports its resident memory after warm-up
//! and at the end (goal: within 5 %).

use std::path::Path;
use std::process::Command;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let value = |name: &str, default: f64| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(default)
    };
    let hours = value("--hours", 1.0);
    let speed = value("--speed", 30.0);
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("temp dir");
    let cfg = dir.path().join("kiosk.toml");
    // Short timeouts so that every loop of the visit goes through the attract loop and the reset.
    let config = format!(
        "content = {:?}\nattract_after_secs = 20.0\nreset_after_secs = 60.0\n",
        root.join("content").display().to_string()
    );
    std::fs::write(&cfg, config).expect("config");
    let runtime = std::env::temp_dir().join("xdg-runtime-isokiosk-bench");
    std::fs::create_dir_all(&runtime).expect("runtime dir");
    let out = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 2200x800x24 -nolisten tcp"])
        .arg(env!("CARGO_BIN_EXE_kiosk"))
        .arg("--config")
        .arg(&cfg)
        .args(["--windowed", "--silent"])
        .args(["--speed", &speed.to_string(), "--run-for", &(hours * 3600.0).to_string()])
        .arg("--session")
        .arg(root.join("tests/sessions/kiosk-visit.jsonl"))
        .env("XDG_RUNTIME_DIR", &runtime)
        .env("RUST_LOG", "warn")
        .output()
        .expect("xvfb-run (installed by .ci/setup)");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "kiosk failed\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let line = stdout.lines().find(|l| l.starts_with("soak:")).expect("the kiosk's soak line");
    println!("{line}");
    let number_before = |key: &str| -> f64 {
        let i = line.find(key).expect(key);
        line[..i].split_whitespace().last().and_then(|v| v.parse().ok()).expect("number")
    };
    let warm = number_before("kB, at the end");
    let end: f64 = line
        .split("at the end ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .expect("end RSS");
    println!();
    println!("| kiosk time | clock speed | RSS after warm-up (300 s) | RSS at the end | change |");
    println!("|---|---|---|---|---|");
    println!(
        "| {hours} h | {speed}× | {:.1} MB | {:.1} MB | {:+.2} % |",
        warm / 1024.0,
        end / 1024.0,
        100.0 * (end - warm) / warm
    );
}
