//! `cargo bench --bench soak [-- --hours H --speed S]`: the kiosk binary under Xvfb replays the
//! recorded demo visit (tests/sessions/kiosk-visit.jsonl: both models, radial menu, go-to,
//! language, help, back, gallery swipe, then idle → attract loop → reset) over and over for an
//! hour of kiosk time at an accelerated clock, and reports its resident memory after warm-up
//! (`--warmup`, default 900 s of kiosk time) and at the end (goal: within 5 %).

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
    // Warm-up: the first 15 min of kiosk time (several visits, resets and both models: fonts,
    // thumbnails, GPU state of both models and the driver's pools reach their working size).
    let warmup = value("--warmup", 900.0);
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
        .args(["--warmup", &warmup.to_string()])
        .arg("--session")
        .arg(root.join("tests/sessions/kiosk-visit.jsonl"))
        .env("XDG_RUNTIME_DIR", &runtime)
        // Statistics and the visit log go to a temporary directory, never the user's state.
        .env("ISOKIOSK_STATE", dir.path().join("state"))
        .env("RUST_LOG", "warn")
        .output()
        .expect("xvfb-run (installed by .ci/setup)");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "kiosk failed\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    // Periodic samples ("soak: t = 300 s, RSS 123 kB") and the final line.
    let series: Vec<(f64, f64)> = stdout
        .lines()
        .filter_map(|l| {
            let rest = l.strip_prefix("soak: t = ")?;
            let (t, rss) = rest.split_once(" s, RSS ")?;
            Some((t.parse().ok()?, rss.trim_end_matches(" kB").parse().ok()?))
        })
        .collect();
    let line =
        stdout.lines().rfind(|l| l.starts_with("soak:") && l.contains("at the end")).expect("final line");
    println!("{line}");
    println!();
    println!("| kiosk time (s) | RSS (MB) |");
    println!("|---|---|");
    for (t, rss) in &series {
        println!("| {t:.0} | {:.1} |", rss / 1024.0);
    }
    let warm = series.iter().find(|(t, _)| *t >= warmup).map(|s| s.1).expect("warm-up sample");
    let end: f64 = line
        .split("at the end ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .expect("end RSS");
    println!();
    println!(
        "| kiosk time | clock speed | RSS after warm-up ({warmup:.0} s) | RSS at the end | change | goal |"
    );
    println!("|---|---|---|---|---|---|");
    let change = 100.0 * (end - warm) / warm;
    println!(
        "| {hours} h | {speed}× | {:.1} MB | {:.1} MB | {change:+.1} % | {} |",
        warm / 1024.0,
        end / 1024.0,
        if change.abs() <= 5.0 { "met (≤ 5 %)" } else { "NOT met (≤ 5 %)" }
    );
}
