//! `cargo bench --bench soak [-- --hours H --speed S --warmup W]`: the kiosk binary under Xvfb
//! replays the recorded demo visit (tests/sessions/kiosk-visit.jsonl: both models, radial menu,
//! go-to, language, help, back, gallery swipe, then idle → attract loop → reset) over and over for
//! H hours of kiosk time at an accelerated clock (S×), and reports, every 300 s of kiosk time, its
//! resident memory, its open file descriptors and the size of its state directory (the visit
//! statistics and the rotated visit log). Goals: memory and open files within 5 % from the end of
//! the warm-up (`--warmup`, default 900 s of kiosk time) to the end — memory as the lowest and the
//! highest RSS of a window of samples, the first after the warm-up against the last (one sample
//! depends on what the screen shows at that moment); the state directory within its bound (the
//! log's rotation limit plus the statistics). Plot: target/bench/soak.svg (.png).
//!
//! The clock only decides how much kiosk time each drawn frame covers: the core steps at its fixed
//! rate whatever the speed, so a month at 3000× plays every visit, attract loop and reset, with
//! fewer frames drawn between them.

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
        // Statistics and the visit log go to a temporary directory, never the user's state;
        // the demo's imports to the build's own cache, never the user's.
        .env("ISOKIOSK_STATE", dir.path().join("state"))
        .env("ISOKIOSK_CACHE", root.join("target/bench/cache"))
        .env("RUST_LOG", "warn")
        .output()
        .expect("xvfb-run (installed by .ci/setup)");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "kiosk failed\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let series: Vec<Sample> = stdout.lines().filter_map(Sample::parse).collect();
    let line =
        stdout.lines().rfind(|l| l.starts_with("soak:") && l.contains("at the end")).expect("final line");
    println!("{line}");
    println!();
    // At most ~24 rows: every k-th sample, and the last.
    let k = series.len().div_ceil(24).max(1);
    println!(
        "| kiosk time (h) | RSS (MB) | of which anonymous | of which mapped files | heap in use (MB) | open files | state (kB) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (i, s) in series.iter().enumerate() {
        if i % k == k - 1 || i + 1 == series.len() {
            println!(
                "| {:.2} | {:.1} | {:.1} | {:.1} | {:.1} | {} | {:.0} |",
                s.t / 3600.0,
                s.rss_kb / 1024.0,
                s.anon_kb / 1024.0,
                s.file_kb / 1024.0,
                s.heap_kb / 1024.0,
                s.fds,
                s.state / 1024.0
            );
        }
    }
    let warm = series.iter().find(|s| s.t >= warmup).expect("a sample after the warm-up");
    let last = series.last().expect("samples");
    let after: Vec<&Sample> = series.iter().filter(|s| s.t >= warmup).collect();
    let max_rss = after.iter().map(|s| s.rss_kb).fold(0.0, f64::max);
    let max_fds = after.iter().map(|s| s.fds).max().unwrap_or(0);
    let max_state = series.iter().map(|s| s.state).fold(0.0, f64::max);
    let limits = kiosk_content::stats::LogLimits::default();
    // The log's bound (kiosk_content::stats::append_visit) plus 1 MiB for the statistics files.
    let state_bound = ((limits.keep as u64 + 1) * limits.max_bytes + (1 << 20)) as f64;
    let pct = |a: f64, b: f64| 100.0 * (b - a) / a.max(1.0);
    let goal = |ok: bool| if ok { "met" } else { "NOT met" };
    println!();
    println!(
        "| kiosk time | clock speed | quantity | after warm-up ({warmup:.0} s) | at the end | highest after warm-up | change | goal |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    // One sample is a moment of the visit loop: a large model explored holds its nodes in the
    // driver's memory, the gallery does not. The envelope of a window of samples is what is
    // compared: the lowest and the highest RSS of the first window after the warm-up against
    // those of the last window (each a tenth of the time after the warm-up, at least an hour).
    let span = series.last().map_or(0.0, |s| s.t) - warmup;
    let width = (0.1 * span).max(3600.0);
    let window = |lo: f64, hi: f64| {
        let v: Vec<f64> = after.iter().filter(|s| s.t >= lo && s.t <= hi).map(|s| s.rss_kb).collect();
        (v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(0.0, f64::max))
    };
    let end = warmup + span;
    let (first_lo, first_hi) = window(warmup, warmup + width);
    let (last_lo, last_hi) = window(end - width, end);
    let (lo_change, hi_change) = (pct(first_lo, last_lo), pct(first_hi, last_hi));
    println!(
        "| {hours} h | {speed}× | RSS, lowest of a window of {:.1} h | {:.1} MB | {:.1} MB | — | {lo_change:+.1} % | {} (≤ 5 %) |",
        width / 3600.0,
        first_lo / 1024.0,
        last_lo / 1024.0,
        goal(lo_change.abs() <= 5.0)
    );
    println!(
        "| {hours} h | {speed}× | RSS, highest of a window of {:.1} h | {:.1} MB | {:.1} MB | {:.1} MB | {hi_change:+.1} % | {} (≤ 5 %) |",
        width / 3600.0,
        first_hi / 1024.0,
        last_hi / 1024.0,
        max_rss / 1024.0,
        goal(hi_change.abs() <= 5.0)
    );
    let rss_change = pct(warm.rss_kb, last.rss_kb);
    println!(
        "| {hours} h | {speed}× | RSS, one sample each | {:.1} MB | {:.1} MB | {:.1} MB | {rss_change:+.1} % | — |",
        warm.rss_kb / 1024.0,
        last.rss_kb / 1024.0,
        max_rss / 1024.0,
    );
    let fd_change = pct(warm.fds as f64, last.fds as f64);
    println!(
        "| {hours} h | {speed}× | open files | {} | {} | {max_fds} | {fd_change:+.1} % | {} (≤ 5 %) |",
        warm.fds,
        last.fds,
        goal(fd_change.abs() <= 5.0)
    );
    println!(
        "| {hours} h | {speed}× | state directory | {:.0} kB | {:.0} kB | {:.0} kB | — | {} (≤ {:.0} kB) |",
        warm.state / 1024.0,
        last.state / 1024.0,
        max_state / 1024.0,
        goal(max_state <= state_bound),
        state_bound / 1024.0
    );
    let visits = std::fs::read_dir(dir.path().join("state"))
        .map(|d| {
            d.filter_map(|e| e.ok()).filter(|e| e.file_name().to_string_lossy().starts_with("visits")).count()
        })
        .unwrap_or(0);
    println!("\nvisit log files at the end: {visits}");
    if let Err(e) = plot(&series, hours, speed) {
        println!("plot failed: {e:#}");
    }
}

/// One report of the kiosk ("soak: t = 300 s, RSS 123 kB, 17 open files, state 4567 B, anon 100
/// kB, file 23 kB, heap 80 kB").
struct Sample {
    t: f64,
    rss_kb: f64,
    fds: usize,
    state: f64,
    /// Anonymous memory (heap, driver) and mapped files (stores), kB.
    anon_kb: f64,
    file_kb: f64,
    /// What the program holds in the heap, kB (0 off glibc).
    heap_kb: f64,
}

impl Sample {
    fn parse(line: &str) -> Option<Self> {
        let rest = line.strip_prefix("soak: t = ")?;
        let (t, rest) = rest.split_once(" s, RSS ")?;
        let (rss, rest) = rest.split_once(" kB, ")?;
        let (fds, rest) = rest.split_once(" open files, state ")?;
        let (state, rest) = rest.split_once(" B, anon ")?;
        let (anon, rest) = rest.split_once(" kB, file ")?;
        let (file, heap) = rest.strip_suffix(" kB")?.split_once(" kB, heap ")?;
        Some(Self {
            t: t.parse().ok()?,
            rss_kb: rss.parse().ok()?,
            fds: fds.parse().ok()?,
            state: state.parse().ok()?,
            anon_kb: anon.parse().ok()?,
            file_kb: file.parse().ok()?,
            heap_kb: heap.parse().ok()?,
        })
    }
}

fn plot(series: &[Sample], hours: f64, speed: f64) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench");
    std::fs::create_dir_all(&out)?;
    let svg = out.join("soak.svg");
    let root = SVGBackend::new(&svg, (1000, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let panels = root.split_evenly((1, 3));
    let xmax = series.last().map_or(1.0, |s| s.t / 3600.0).max(1e-3);
    let draw = |area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
                title: &str,
                y: &dyn Fn(&Sample) -> f64,
                color: RGBColor|
     -> anyhow::Result<()> {
        let ymax = series.iter().map(y).fold(0.0, f64::max).max(1.0) * 1.15;
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 15))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..xmax, 0.0..ymax)?;
        chart.configure_mesh().x_desc("kiosk time (h)").draw()?;
        chart.draw_series(LineSeries::new(
            series.iter().map(|s| (s.t / 3600.0, y(s))),
            color.stroke_width(2),
        ))?;
        Ok(())
    };
    draw(&panels[0], &format!("RSS (MB), {hours} h at {speed}×"), &|s| s.rss_kb / 1024.0, BLUE)?;
    draw(&panels[1], "open file descriptors", &|s| s.fds as f64, RED)?;
    draw(&panels[2], "state directory (kB)", &|s| s.state / 1024.0, RGBColor(0, 130, 0))?;
    root.present()?;
    drop(root);
    let png = kiosk_testkit::png_beside(&svg)?;
    println!("plot: {} ({})", svg.display(), png.display());
    Ok(())
}
