//! `cargo bench --bench render [-- --quick | --tradeoff-only | --quality-only | --cloud-radius-only]`: the renderer's numbers
//! (docs/performance.md). No GPU here: the adapter is lavapipe (software Vulkan); the command is
//! the same on a GPU.
//!
//! 1. Splats per second and ms per frame at 1920×1080 (1 px cut) for a real scan and the
//!    synthetic 50 M-point model (left in target/bench by `cargo bench --bench scene`).
//! 2. CPU cost per frame of the cut update and of the uploads while the camera moves.
//! 3. Speed against accuracy: pixel tolerance of the cut against frame time, splats drawn and
//!    image error (PSNR, SSIM) against a full-resolution render (table and
//!    `target/bench/render-tradeoff.svg`).
//! 4. Image quality of each splat mode against the mesh render (`quality`): PSNR, SSIM, visible
//!    edges and ms per frame at 1920×1080, far, middle and close up (table and
//!    `target/bench/render-quality.svg`).
//! 5. Samples per texel of a textured scan against build time, store size and colour error
//!    against the textured mesh (`texel`; `-- --texel-only`; `target/bench/render-texel.svg`).

mod quality;
mod texel;

use glam::DVec3;
use kiosk_content::MappedStore;
use kiosk_core::camera::Camera;
use kiosk_core::{Cut, CutParams};
use kiosk_render::{RenderSettings, SplatMode};
use plotters::prelude::*;
use std::path::Path;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn orbit(store: &MappedStore, k: usize, dist: f64) -> Camera {
    let c = store.to_model(store.bbox().center());
    let diag = f64::from(store.bbox().diagonal());
    let a = k as f64 * 0.05;
    let mut cam = Camera {
        eye: c + DVec3::new(a.cos(), 0.25, a.sin()) * diag * dist,
        target: c,
        up: DVec3::Y,
        fov_y: 0.8,
    };
    cam.up = kiosk_core::camera::orthonormal_up(cam.forward(), DVec3::Y, DVec3::Z);
    cam
}

fn main() -> anyhow::Result<()> {
    let quick = std::env::args().any(|a| a == "--quick");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out_dir = root.join("target/bench");
    std::fs::create_dir_all(&out_dir)?;
    let (gpu, mut renderer) = kiosk_content::snapshot::offscreen()?;
    println!("adapter: {} ({:?}, {:?})", gpu.adapter.name, gpu.adapter.backend, gpu.adapter.device_type);
    let quality_size = (1920, 1080);
    if std::env::args().any(|a| a == "--texel-only") {
        return texel::run(&gpu, &mut renderer, root, &out_dir, quality_size);
    }
    if std::env::args().any(|a| a == "--cloud-radius-only") {
        return quality::cloud_radius(&gpu, &mut renderer, root, &out_dir, quality_size);
    }
    if std::env::args().any(|a| a == "--quality-only") {
        quality::run(&gpu, &mut renderer, root, &out_dir, quality_size, if quick { 2 } else { 5 })?;
        return Ok(());
    }
    let dir = tempfile::tempdir()?;
    let scan_store = kiosk_testkit::synthetic::dragon_store(dir.path())?;
    let tradeoff_only = std::env::args().any(|a| a == "--tradeoff-only");
    let mut models = vec![("dragon (437 k)".to_string(), kiosk_content::open_store(&scan_store)?)];
    let big = out_dir.join("synthetic-50000000.kstore");
    if big.exists() && !tradeoff_only {
        models.push(("synthetic 50 M".into(), kiosk_content::open_store(&big)?));
    } else {
        println!(
            "(no target/bench/synthetic-50000000.kstore: run `cargo bench --bench scene -- --points 50000000` first)"
        );
    }
    let size = (1920u32, 1080u32);
    let (_t, view) = renderer.offscreen_target(&gpu, size);
    let settings = RenderSettings::default();
    println!(
        "\n## Frames at 1920×1080, 1 px cut, camera orbiting (GPU time included: each frame waits for the GPU)"
    );
    println!(
        "| model | mode | frames | median splats drawn | median ms per frame | M splats/s | median CPU ms cut update | median CPU ms render call (uploads, encoding) | MB uploaded in all |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (name, store) in &models {
        let frames = if tradeoff_only {
            0
        } else if quick {
            3
        } else {
            12
        };
        if frames == 0 {
            continue;
        }
        // The modes take turns at every frame of one orbit: side by side, same cut, same cache.
        let mut cut = Cut::root(store);
        let modes = SplatMode::ALL.len();
        let (mut ms, mut cpu_ms) = (vec![Vec::new(); modes], vec![Vec::new(); modes]);
        let (mut splats, mut cut_ms, mut uploaded) = (Vec::new(), Vec::new(), 0u64);
        for k in 0..frames {
            let cam = orbit(store, k, 0.7);
            let v = cam.view_params(store, size).expect("view");
            let t0 = Instant::now();
            cut.update(store, &v, &CutParams::default());
            cut_ms.push(t0.elapsed().as_secs_f64() * 1e3);
            let nodes = cut.visible_nodes(store, &v);
            for (i, (_, mode)) in SplatMode::ALL.into_iter().enumerate() {
                let settings = RenderSettings { mode, ..settings };
                let t1 = Instant::now();
                let st = renderer.render(&gpu, store, &nodes, &cam, &view, size, &settings)?;
                let t2 = Instant::now();
                gpu.wait()?;
                cpu_ms[i].push((t2 - t1).as_secs_f64() * 1e3);
                ms[i].push(t1.elapsed().as_secs_f64() * 1e3);
                if i == 0 {
                    splats.push(st.splats as f64);
                }
                uploaded += st.uploaded_bytes;
            }
        }
        let s = median(splats);
        let cut_ms = median(cut_ms);
        for (i, (mode, _)) in SplatMode::ALL.into_iter().enumerate() {
            let m = median(ms[i].clone());
            println!(
                "| {name} | {mode} | {frames} | {s:.0} | {m:.0} | {:.2} | {cut_ms:.3} | {:.1} | {:.0} |",
                s / m / 1e3,
                median(cpu_ms[i].clone()),
                uploaded as f64 / 1e6
            );
        }
    }

    // Speed against accuracy on the real scan, at 960×540.
    let store = &models[0].1;
    let small = (960u32, 540u32);
    let cam = orbit(store, 3, 0.45);
    let v = cam.view_params(store, small).expect("view");
    let full = Cut::leaves(store);
    let (reference, _) =
        renderer.render_image(&gpu, store, &full.visible_nodes(store, &v), &cam, small, &settings)?;
    println!("\n## Speed against accuracy: cut tolerance (dragon, 960×540; reference: full resolution)");
    println!("| tolerance px | nodes | splats drawn | ms per frame | PSNR dB | SSIM |");
    println!("|---|---|---|---|---|---|");
    let mut series = Vec::new();
    for tol in [0.5f32, 1.0, 2.0, 4.0, 8.0, 16.0] {
        let mut cut = Cut::root(store);
        cut.update(
            store,
            &v,
            &CutParams { tolerance_px: tol, max_changes: usize::MAX, ..CutParams::default() },
        );
        let nodes = cut.visible_nodes(store, &v);
        // Warm the cache, then time.
        renderer.render_image(&gpu, store, &nodes, &cam, small, &settings)?;
        let mut t = Vec::new();
        let mut last = None;
        for _ in 0..if quick { 2 } else { 5 } {
            let t0 = Instant::now();
            let r = renderer.render_image(&gpu, store, &nodes, &cam, small, &settings)?;
            t.push(t0.elapsed().as_secs_f64() * 1e3);
            last = Some(r);
        }
        let (img, st) = last.expect("frames");
        let p = kiosk_testkit::metrics::psnr(&img, &reference);
        let s = kiosk_testkit::metrics::ssim(&img, &reference);
        let ms = median(t);
        println!("| {tol} | {} | {} | {ms:.1} | {p:.2} | {s:.4} |", st.nodes, st.splats);
        series.push((tol, ms, p, s));
    }
    let svg = out_dir.join("render-tradeoff.svg");
    {
        let root = SVGBackend::new(&svg, (800, 500)).into_drawing_area();
        root.fill(&WHITE)?;
        let xmax = series.iter().map(|s| s.1).fold(0.0, f64::max) * 1.1;
        // Identical images have an infinite PSNR: plot them at the top of the axis.
        let finite = |p: f64| if p.is_finite() { p } else { 60.0 };
        let (ymin, ymax) =
            series.iter().fold((f64::INFINITY, 0.0f64), |(a, b), s| (a.min(finite(s.2)), b.max(finite(s.2))));
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Renderer: cut tolerance 0.5…16 px — frame time vs PSNR (dragon, lavapipe)",
                ("sans-serif", 18),
            )
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..xmax, (ymin - 1.0)..(ymax + 1.0))?;
        chart
            .configure_mesh()
            .x_desc("ms per frame (960×540)")
            .y_desc("PSNR against full resolution, dB")
            .draw()?;
        chart.draw_series(LineSeries::new(series.iter().map(|s| (s.1, s.2)), BLUE.stroke_width(2)))?;
        chart.draw_series(series.iter().map(|s| Circle::new((s.1, s.2), 4, BLUE.filled())))?;
        chart.draw_series(
            series
                .iter()
                .map(|s| Text::new(format!("{} px", s.0), (s.1, s.2 + 0.3), ("sans-serif", 12).into_font())),
        )?;
        root.present()?;
    }
    println!("\nplot: {}", svg.display());
    quality::run(&gpu, &mut renderer, root, &out_dir, quality_size, if quick { 2 } else { 5 })?;
    texel::run(&gpu, &mut renderer, root, &out_dir, quality_size)
}
