//! `cargo bench --bench camera [-- --quick]`: IsoCam's numbers (docs/performance.md).
//!
//! 1. Hover step and full camera update per frame at maximum input speed, median µs, on a real
//!    scan and on the synthetic stores left by `cargo bench --bench scene` (50 M if present).
//! 2. Speed against accuracy: re-projection tolerance × iteration cap, and fine/coarse search
//!    depth, against step time, isolevel error and surface-distance violations (table and
//!    `target/bench/camera-tradeoff.svg`).
//! 3. IsoCam, trackball and ACeViT on the same sessions: collisions, mean distance error to the
//!    chosen isolevel, smoothness (angular acceleration of the view direction, jerk of the eye).

use glam::DVec3;
use kiosk_content::MappedStore;
use kiosk_core::camera::{ControllerKind, initial_camera};
use kiosk_core::camera::{IsoCam, IsoCamSettings, SceneRef};
use kiosk_core::explore::ExploreSettings;
use kiosk_core::replay;
use kiosk_core::session::Script;
use kiosk_core::trace::Trace;
use kiosk_core::{Cut, CutParams};
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let quick = std::env::args().any(|a| a == "--quick");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out_dir = root.join("target/bench");
    std::fs::create_dir_all(&out_dir)?;
    let dir = tempfile::tempdir()?;
    let scan_store = kiosk_testkit::synthetic::dragon_store(dir.path())?;
    let mut models: Vec<(String, MappedStore)> =
        vec![("dragon (437 k)".into(), kiosk_content::open_store(&scan_store)?)];
    for n in [50_000_000u64, 10_000_000] {
        let p = out_dir.join(format!("synthetic-{n}.kstore"));
        if p.exists() {
            models.push((format!("synthetic {} M", n / 1_000_000), kiosk_content::open_store(&p)?));
            break;
        }
    }
    if models.len() == 1 {
        println!(
            "(no synthetic store in target/bench: run `cargo bench --bench scene` first for the 50 M figure)"
        );
    }

    println!("\n## Hover at maximum input speed (joystick at full offset), 1920×1080, 1 px cut");
    println!(
        "| model | frames | median µs per hover step | median µs per frame (hover) | median µs per frame (hover + cut update) | max µs per frame |"
    );
    println!("|---|---|---|---|---|---|");
    for (name, store) in &models {
        speed_row(name, store, if quick { 120 } else { 600 });
    }

    tradeoff(&models[0].1, &out_dir, quick)?;
    controllers(&models[0].1);
    Ok(())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The kiosk's start camera and its converged 1 px cut at 1920×1080.
fn start(store: &MappedStore) -> (kiosk_core::camera::Camera, Cut) {
    let cam = initial_camera(store, 0.8, DVec3::Y);
    let mut cut = Cut::root(store);
    let unbounded = CutParams { max_changes: usize::MAX, ..CutParams::default() };
    cut.update(store, &cam.view_params(store, (1920, 1080)).expect("view"), &unbounded);
    (cam, cut)
}

fn speed_row(name: &str, store: &MappedStore, frames: usize) {
    let g = kiosk_core::gesture::GestureSettings::default();
    // Full joystick offset: (max_offset − dead zone) × speed, per frame at 60 Hz.
    let per_frame = (g.max_offset - 0.0) * g.hover_speed / 60.0;
    let (cam, mut cut) = start(store);
    let params = CutParams::default();
    let settings = IsoCamSettings::for_model(f64::from(store.bbox().diagonal()));
    let mut iso = IsoCam::new(SceneRef { store, cut: &cut }, cam, settings);
    // Come closer first: visitors look at details.
    for _ in 0..40 {
        iso.zoom(SceneRef { store, cut: &cut }, 0.05);
    }
    let (mut step_us, mut hover_us, mut frame_us) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..frames {
        let a = k as f64 * 0.01;
        let t0 = Instant::now();
        iso.hover(SceneRef { store, cut: &cut }, (per_frame * a.cos(), per_frame * 0.3 * a.sin()));
        let t1 = Instant::now();
        let v = iso.camera().view_params(store, (1920, 1080)).expect("view");
        cut.update(store, &v, &params);
        let t2 = Instant::now();
        let h = (t1 - t0).as_secs_f64() * 1e6;
        hover_us.push(h);
        step_us.push(h / f64::from(iso.last.steps.max(1)));
        frame_us.push((t2 - t0).as_secs_f64() * 1e6);
    }
    let max = frame_us.iter().copied().fold(0.0, f64::max);
    println!(
        "| {name} | {frames} | {:.1} | {:.1} | {:.1} | {:.0} |",
        median(step_us),
        median(hover_us),
        median(frame_us),
        max
    );
}

/// A long hover around and over the model, at the given settings: (µs per step, mean isolevel
/// error, max isolevel error, surface-distance violations, steps).
fn hover_run(store: &MappedStore, settings: IsoCamSettings, frames: usize) -> (f64, f64, f64, u64, u64) {
    let (cam, mut cut) = start(store);
    let params = CutParams::default();
    let mut iso = IsoCam::new(SceneRef { store, cut: &cut }, cam, settings);
    for _ in 0..30 {
        iso.zoom(SceneRef { store, cut: &cut }, 0.05);
    }
    let (mut us, mut err_sum, mut err_max, mut violations, mut steps) = (0.0, 0.0, 0.0f64, 0u64, 0u64);
    for k in 0..frames {
        let a = k as f64 * 0.013;
        let t = Instant::now();
        iso.hover(SceneRef { store, cut: &cut }, (0.008 * a.cos(), 0.004 * (0.7 * a).sin()));
        us += t.elapsed().as_secs_f64() * 1e6;
        steps += u64::from(iso.last.steps);
        let eye = iso.camera().eye;
        // Error measured against the exact (full-resolution) surface.
        let (d, _) = store.nearest_sample(eye).expect("finite");
        let e = (d - iso.isolevel()).abs() / iso.isolevel();
        err_sum += e;
        err_max = err_max.max(e);
        if d < settings.min_distance * (1.0 - settings.reproject_tolerance) {
            violations += 1;
        }
        let v = iso.camera().view_params(store, (1920, 1080)).expect("view");
        cut.update(store, &v, &params);
    }
    (us / steps.max(1) as f64, err_sum / frames as f64, err_max, violations, steps)
}

fn tradeoff(store: &MappedStore, out_dir: &Path, quick: bool) -> anyhow::Result<()> {
    let frames = if quick { 200 } else { 1500 };
    let base = IsoCamSettings::for_model(f64::from(store.bbox().diagonal()));
    println!(
        "\n## Speed against accuracy: re-projection tolerance × iteration cap (dragon, {frames} frames)"
    );
    println!("| tolerance | cap | µs per step | mean isolevel error | max isolevel error | violations |");
    println!("|---|---|---|---|---|---|");
    let mut series = Vec::new();
    for tol in [0.001, 0.01, 0.05, 0.2] {
        let mut line = Vec::new();
        for cap in [1u32, 2, 4, 8] {
            let s = IsoCamSettings { reproject_tolerance: tol, reproject_max_iterations: cap, ..base };
            let (us, mean, max, viol, _) = hover_run(store, s, frames);
            println!("| {tol} | {cap} | {us:.1} | {mean:.4} | {max:.4} | {viol} |");
            line.push((us, mean));
        }
        series.push((format!("tolerance {tol}"), line));
    }
    println!("\n## Speed against accuracy: fine and coarse search depth (tolerance 0.01, cap 8)");
    println!(
        "| fine depth | coarse depth | µs per step | mean isolevel error | max isolevel error | violations |"
    );
    println!("|---|---|---|---|---|---|");
    let mut depth_line = Vec::new();
    for (fine, coarse) in [(4u32, 2u32), (6, 3), (8, 4), (u32::MAX, 2), (u32::MAX, 4), (u32::MAX, 6)] {
        let mut s = base;
        s.query.fine_depth = fine;
        s.query.coarse_depth = coarse;
        let (us, mean, max, viol, _) = hover_run(store, s, frames);
        let f = if fine == u32::MAX { "full".to_string() } else { fine.to_string() };
        println!("| {f} | {coarse} | {us:.1} | {mean:.4} | {max:.4} | {viol} |");
        depth_line.push((us, mean));
    }
    series.push(("fine/coarse depth".into(), depth_line));
    let svg = out_dir.join("camera-tradeoff.svg");
    plot(&svg, &series)?;
    println!("\nplot: {}", svg.display());
    Ok(())
}

fn plot(path: &PathBuf, series: &[(String, Vec<(f64, f64)>)]) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let xmax = series.iter().flat_map(|(_, l)| l.iter().map(|p| p.0)).fold(0.0, f64::max) * 1.1;
    let ymax = series.iter().flat_map(|(_, l)| l.iter().map(|p| p.1)).fold(0.0, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption("IsoCam hover: speed against accuracy (dragon)", ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..xmax, 0.0..ymax.max(1e-6))?;
    chart
        .configure_mesh()
        .x_desc("µs per hover step")
        .y_desc("mean isolevel error (relative, exact surface)")
        .draw()?;
    let colors = [RED, BLUE, GREEN, MAGENTA, BLACK];
    for (i, (name, line)) in series.iter().enumerate() {
        let c = colors[i % colors.len()];
        chart
            .draw_series(LineSeries::new(line.iter().copied(), c.stroke_width(2)))?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
        chart.draw_series(line.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    root.present()?;
    Ok(())
}

/// Smoothness and accuracy of a trace: (mean isolevel error during hover, mean angular
/// acceleration of the view direction in rad/s², mean jerk of the eye in diagonals/s³).
fn quality(trace: &Trace, diag: f64, fps: f64) -> (f64, f64, f64) {
    let fr = &trace.frames;
    let dir = |f: &kiosk_core::trace::Frame| {
        (DVec3::from_array(f.target) - DVec3::from_array(f.eye)).normalize_or_zero()
    };
    let eye = |f: &kiosk_core::trace::Frame| DVec3::from_array(f.eye);
    // Isolevel error: surface distance against the distance when the current gesture started.
    let (mut err, mut n, mut chosen) = (0.0, 0usize, fr[0].surface_distance);
    for w in fr.windows(2) {
        if w[1].controller == "hover" {
            if w[0].controller != "hover" {
                chosen = w[0].surface_distance;
            }
            err += (w[1].surface_distance - chosen).abs() / chosen;
            n += 1;
        }
    }
    let ang: Vec<f64> =
        fr.windows(2).map(|w| dir(&w[0]).dot(dir(&w[1])).clamp(-1.0, 1.0).acos() * fps).collect();
    let acc = ang.windows(2).map(|w| (w[1] - w[0]).abs() * fps).sum::<f64>() / ang.len().max(1) as f64;
    let jerk = fr
        .windows(4)
        .map(|w| {
            (eye(&w[3]) - 3.0 * eye(&w[2]) + 3.0 * eye(&w[1]) - eye(&w[0])).length() * fps.powi(3) / diag
        })
        .sum::<f64>()
        / fr.len().max(1) as f64;
    (if n > 0 { err / n as f64 } else { 0.0 }, acc, jerk)
}

fn controllers(store: &MappedStore) {
    let sessions: Vec<(&str, Script)> = vec![
        ("orbit", Script::new().joystick(1, (0.3, 0.0), 8.0)),
        (
            "close-up",
            Script::new().pinch(0.1, 0.9, 1.0).wait(0.2).pinch(0.1, 0.9, 1.0).wait(0.2).joystick(
                1,
                (0.2, 0.1),
                6.0,
            ),
        ),
        ("over the top", Script::new().pinch(0.2, 0.6, 0.5).wait(0.1).joystick(1, (0.05, -0.3), 6.0)),
        (
            "mixed",
            Script::new()
                .joystick(1, (0.2, 0.0), 2.0)
                .pinch(0.1, 0.8, 1.0)
                .joystick(1, (-0.1, 0.25), 3.0)
                .pinch(0.8, 0.3, 0.5),
        ),
    ];
    let diag = f64::from(store.bbox().diagonal());
    println!("\n## Three controllers on the same sessions (dragon, 60 Hz)");
    println!(
        "| session | controller | frames | collisions | closest approach / min distance | mean isolevel error | angular acceleration rad/s² | eye jerk diag/s³ |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (name, script) in &sessions {
        for kind in [ControllerKind::IsoCam, ControllerKind::Trackball, ControllerKind::Acevit] {
            let settings = ExploreSettings { controller: kind, ..ExploreSettings::default() };
            let t = replay::run(store, &script.session(), &settings);
            let (err, acc, jerk) = quality(&t, diag, settings.fps);
            let min = t.frames[0].min_distance;
            println!(
                "| {name} | {} | {} | {} | {:.2} | {err:.3} | {acc:.2} | {jerk:.2} |",
                t.controller,
                t.summary.frames,
                t.summary.collisions,
                t.summary.min_surface_distance / min
            );
        }
    }
}
