//! Samples per texel against build time, store size and colour: a textured scan (the Belweder
//! television set of `content/belweder`, one 1024² JPEG atlas over 170 k triangles) is imported at
//! several texel densities (`kiosk import --texel-density D`), and the front views are drawn from
//! each store (blended splats) and from the textured mesh itself (the mesh reference, which
//! samples the texture per pixel). Printed: samples, build seconds, store size, and per view the
//! mean colour difference ΔE (CIE76; ≈ 2.3 is just noticeable) and SSIM against the textured mesh.
//! Plot: target/bench/render-texel.svg (.png).

use kiosk_render::reference::MeshRenderer;
use kiosk_render::{Gpu, RenderSettings, Renderer};
use kiosk_testkit::metrics::{coverage, delta_e, interior, srgb8, ssim};
use plotters::prelude::*;
use std::path::Path;
use std::time::Instant;

/// The densities measured: samples per texel by area (0.25: one sample per 2 × 2 texels; see
/// `kiosk import --texel-density`).
const DENSITIES: [f32; 5] = [0.25, 0.5, 1.0, 1.5, 2.0];

struct Row {
    density: f32,
    samples: u64,
    seconds: f64,
    store_mb: f64,
    /// (view, ΔE, SSIM).
    views: Vec<(&'static str, f64, f64)>,
}

pub fn run(
    gpu: &Gpu,
    renderer: &mut Renderer,
    root: &Path,
    out_dir: &Path,
    size: (u32, u32),
) -> anyhow::Result<()> {
    let glb = root.join("content/belweder/belweder-ot-1782.glb");
    let mesh = kiosk_testkit::mesh::read_glb(&glb).map_err(anyhow::Error::msg)?;
    let front = kiosk_content::exhibit::model_pose(&root.join("content/belweder"))?.front;
    let mesh_renderer = MeshRenderer::new(gpu, kiosk_render::OFFSCREEN_FORMAT);
    let settings = RenderSettings::default();
    let bg = srgb8(settings.background);
    let images = out_dir.join("texel");
    std::fs::create_dir_all(&images)?;
    let dir = tempfile::tempdir()?;
    let mut rows = Vec::new();
    let mut references: Vec<image::RgbaImage> = Vec::new();
    for density in DENSITIES {
        let out = dir.path().join(format!("belweder-{density}.kstore"));
        let mut opts = kiosk_content::import::ImportOptions::default();
        opts.read.texel_density = density;
        let t0 = Instant::now();
        let report = kiosk_content::import::import(&glb, &out, &opts, &mut kiosk_content::import::quiet)?;
        let seconds = t0.elapsed().as_secs_f64();
        let store_mb = std::fs::metadata(&out)?.len() as f64 / 1e6;
        let store = kiosk_content::open_store(&out)?;
        let mut views = Vec::new();
        for (k, (view, cam)) in kiosk_testkit::mesh::views_from(&store, &mesh, front).into_iter().enumerate()
        {
            if references.len() <= k {
                let r = mesh_renderer.render_image(gpu, &mesh, &cam, size, &settings)?;
                r.save(images.join(format!("{view}-mesh.png")))?;
                references.push(r);
            }
            let reference = &references[k];
            let v = cam.view_params(&store, size).expect("view");
            let mut cut = kiosk_core::Cut::root(&store);
            cut.update(
                &store,
                &v,
                &kiosk_core::CutParams { tolerance_px: 1.0, max_changes: usize::MAX, ..Default::default() },
            );
            let nodes = cut.visible_nodes(&store, &v);
            let (img, _) = renderer.render_image(gpu, &store, &nodes, &cam, size, &settings)?;
            img.save(images.join(format!("{view}-density-{density}.png")))?;
            let mask = interior(&coverage(reference, bg), &coverage(&img, bg), size, 2);
            views.push((view, delta_e(&img, reference, &mask), ssim(&img, reference)));
        }
        rows.push(Row { density, samples: report.build.leaf_points, seconds, store_mb, views });
    }
    println!(
        "\n## Samples per texel: build, store and colour against the textured mesh (Belweder, {}×{}, blended, 1 px cut)",
        size.0, size.1
    );
    println!(
        "| samples per texel | samples | build s | samples/s | store MB | ΔE far · middle · close-up | SSIM far · middle · close-up |"
    );
    println!("|---|---|---|---|---|---|---|");
    for r in &rows {
        let de: Vec<String> = r.views.iter().map(|v| format!("{:.2}", v.1)).collect();
        let ss: Vec<String> = r.views.iter().map(|v| format!("{:.4}", v.2)).collect();
        println!(
            "| {} | {} | {:.2} | {:.2} M | {:.0} | {} | {} |",
            r.density,
            r.samples,
            r.seconds,
            r.samples as f64 / r.seconds / 1e6,
            r.store_mb,
            de.join(" · "),
            ss.join(" · ")
        );
    }
    plot(&rows, out_dir)?;
    println!("images: {}", images.display());
    Ok(())
}

fn plot(rows: &[Row], out_dir: &Path) -> anyhow::Result<()> {
    let svg = out_dir.join("render-texel.svg");
    let root = SVGBackend::new(&svg, (1000, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(500);
    let xmax = f64::from(DENSITIES[DENSITIES.len() - 1]) * 1.05;
    let emax = rows.iter().flat_map(|r| r.views.iter().map(|v| v.1)).fold(1.0, f64::max) * 1.15;
    let mut chart = ChartBuilder::on(&left)
        .caption("Colour error against the textured mesh", ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..xmax, 0.0..emax)?;
    chart.configure_mesh().x_desc("samples per texel").y_desc("mean ΔE (CIE76)").draw()?;
    for (k, c) in [BLUE, RED, RGBColor(0, 140, 0)].into_iter().enumerate() {
        let name = rows.first().and_then(|r| r.views.get(k)).map_or("", |v| v.0);
        chart
            .draw_series(LineSeries::new(
                rows.iter().filter_map(|r| Some((f64::from(r.density), r.views.get(k)?.1))),
                c.stroke_width(2),
            ))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], c.stroke_width(2)));
    }
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw()?;
    let smax = rows.iter().map(|r| r.seconds).fold(0.1, f64::max) * 1.15;
    let mmax = rows.iter().map(|r| r.store_mb).fold(1.0, f64::max) * 1.15;
    let mut chart = ChartBuilder::on(&right)
        .caption("Build time and store size", ("sans-serif", 15))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .right_y_label_area_size(50)
        .build_cartesian_2d(0.0..xmax, 0.0..smax)?
        .set_secondary_coord(0.0..xmax, 0.0..mmax);
    chart.configure_mesh().x_desc("samples per texel").y_desc("build s").draw()?;
    chart.configure_secondary_axes().y_desc("store MB").draw()?;
    chart
        .draw_series(LineSeries::new(
            rows.iter().map(|r| (f64::from(r.density), r.seconds)),
            BLUE.stroke_width(2),
        ))?
        .label("build s")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], BLUE.stroke_width(2)));
    chart
        .draw_secondary_series(LineSeries::new(
            rows.iter().map(|r| (f64::from(r.density), r.store_mb)),
            RED.stroke_width(2),
        ))?
        .label("store MB")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], RED.stroke_width(2)));
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw()?;
    root.present()?;
    drop(root);
    let png = kiosk_testkit::png_beside(&svg)?;
    println!("plot: {} ({})", svg.display(), png.display());
    Ok(())
}
