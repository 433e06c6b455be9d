//! The splats against the surface they sample: each model is imported, and the same views are
//! drawn from its mesh by the mesh reference renderer (same camera, light and colour) and from
//! its store in each splat mode. Printed: PSNR, SSIM, the share of visible edges (pixels inside
//! the model, 2 px from both images' silhouettes, stepping by > 12/255 to a neighbour) and ms per frame; then SSIM against the cut's
//! pixel tolerance at the far view; plots in target/bench/render-quality*.svg.

use kiosk_content::MappedStore;
use kiosk_core::camera::Camera;
use kiosk_core::{Cut, CutParams};
use kiosk_render::reference::MeshRenderer;
use kiosk_render::{Gpu, RenderSettings, Renderer, SplatMode};
use kiosk_testkit::metrics::{coverage, edge_share, interior, psnr, srgb8, ssim};
use plotters::prelude::*;
use std::path::Path;
use std::time::Instant;

/// The models: the two demo meshes (tuned on) and a held-back scan (not tuned on).
const MODELS: [(&str, &str); 3] = [
    ("demosthenes", "content/demosthenes/demosthenes-low-res.obj"),
    ("nefertiti", "content/nefertiti/nefertiti-lowres.obj"),
    ("bunny (held back)", "tests/data/scans/stanford-bunny/bun_zipper.ply"),
];

/// The blended mode's knobs tried at the close-ups: (blend epsilon, kernel sharpness).
const KNOBS: [(f32, f32); 7] =
    [(0.0, 2.5), (0.5, 2.5), (1.0, 2.5), (2.0, 2.5), (4.0, 2.5), (1.0, 1.0), (1.0, 5.0)];

/// A model, a mode and its SSIM by cut tolerance.
type ToleranceSeries = (String, SplatMode, Vec<(f32, f64)>);

/// One row of the quality table.
pub struct Row {
    pub model: String,
    pub view: &'static str,
    pub mode: SplatMode,
    pub psnr: f64,
    pub ssim: f64,
    pub edges: f64,
    pub mesh_edges: f64,
    pub ms: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// What the comparisons against the mesh render draw with: the mesh renderer, the default
/// settings and their background (sRGB), a temporary directory for stores, and the directory
/// the images are saved in (`quality/` in the output directory).
struct Against {
    mesh_renderer: MeshRenderer,
    base: RenderSettings,
    bg: [u8; 3],
    dir: tempfile::TempDir,
    images: std::path::PathBuf,
}

impl Against {
    fn new(gpu: &Gpu, out_dir: &Path) -> anyhow::Result<Self> {
        let base = RenderSettings::default();
        let images = out_dir.join("quality");
        std::fs::create_dir_all(&images)?;
        Ok(Self {
            mesh_renderer: MeshRenderer::new(gpu, kiosk_render::OFFSCREEN_FORMAT),
            base,
            bg: srgb8(base.background),
            dir: tempfile::tempdir()?,
            images,
        })
    }
}

/// Draws `camera`'s view with a converged cut of `tolerance` and times `frames` more frames.
#[expect(clippy::too_many_arguments, reason = "one measurement's inputs")]
fn splat_frame(
    gpu: &Gpu,
    renderer: &mut Renderer,
    store: &MappedStore,
    camera: &Camera,
    size: (u32, u32),
    tolerance: f32,
    settings: &RenderSettings,
    frames: usize,
) -> anyhow::Result<(image::RgbaImage, f64)> {
    let v = camera.view_params(store, size).expect("view");
    let mut cut = Cut::root(store);
    cut.update(
        store,
        &v,
        &CutParams { tolerance_px: tolerance, max_changes: usize::MAX, ..CutParams::default() },
    );
    let nodes = cut.visible_nodes(store, &v);
    let (img, _) = renderer.render_image(gpu, store, &nodes, camera, size, settings)?;
    let (_t, target) = renderer.offscreen_target(gpu, size);
    let mut ms = Vec::new();
    for _ in 0..frames {
        let t0 = Instant::now();
        renderer.render(gpu, store, &nodes, camera, &target, size, settings)?;
        gpu.wait()?;
        ms.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    Ok((img, if ms.is_empty() { f64::NAN } else { median(ms) }))
}

/// Runs the comparison and prints its tables; `size` is the image size, `frames` the timed
/// frames per measurement.
pub fn run(
    gpu: &Gpu,
    renderer: &mut Renderer,
    root: &Path,
    out_dir: &Path,
    size: (u32, u32),
    frames: usize,
) -> anyhow::Result<Vec<Row>> {
    let Against { mesh_renderer, base, bg, dir, images } = Against::new(gpu, out_dir)?;
    let mut rows = Vec::new();
    let mut tolerance_series: Vec<ToleranceSeries> = Vec::new();
    let mut knob_rows = Vec::new();
    println!(
        "\n## Image quality against the mesh render ({}×{}, 1 px cut; SSIM of the luminance, 8×8 windows; edges: share of model pixels stepping > 12/255)",
        size.0, size.1
    );
    println!("| model | view | mode | PSNR dB | SSIM | edges (mesh) | ms per frame |");
    println!("|---|---|---|---|---|---|---|");
    for (name, rel) in MODELS {
        let path = root.join(rel);
        let store_path = dir.path().join(format!("{}.kstore", name.split(' ').next().unwrap_or("m")));
        let opts = kiosk_content::import::ImportOptions::default();
        kiosk_content::import::import(&path, &store_path, &opts, &mut kiosk_content::import::quiet)?;
        let store = kiosk_content::open_store(&store_path)?;
        let mesh = kiosk_testkit::mesh::read(&path).map_err(anyhow::Error::msg)?;
        for (view, cam) in kiosk_testkit::mesh::views(&store, &mesh) {
            let reference = mesh_renderer.render_image(gpu, &mesh, &cam, size, &base)?;
            let stem = format!("{}-{view}", name.split(' ').next().unwrap_or("m"));
            reference.save(images.join(format!("{stem}-mesh.png")))?;
            let covered = coverage(&reference, bg);
            for (mode_name, mode) in SplatMode::ALL {
                let settings = RenderSettings { mode, ..base };
                let (img, ms) = splat_frame(gpu, renderer, &store, &cam, size, 1.0, &settings, frames)?;
                img.save(images.join(format!("{stem}-{mode_name}.png")))?;
                let mask = interior(&covered, &coverage(&img, bg), size, 2);
                let mesh_edges = edge_share(&reference, &mask, 12);
                edge_map(&img, &mask).save(images.join(format!("{stem}-{mode_name}-edges.png")))?;
                let row = Row {
                    model: name.into(),
                    view,
                    mode,
                    psnr: psnr(&img, &reference),
                    ssim: ssim(&img, &reference),
                    edges: edge_share(&img, &mask, 12),
                    mesh_edges,
                    ms,
                };
                println!(
                    "| {} | {view} | {mode} | {:.2} | {:.4} | {:.3} ({:.3}) | {:.0} |",
                    row.model, row.psnr, row.ssim, row.edges, row.mesh_edges, row.ms
                );
                rows.push(row);
                if view == "close-up" && mode == SplatMode::Blended {
                    for (eps, sharp) in KNOBS {
                        let knob = RenderSettings { blend_epsilon: eps, kernel_sharpness: sharp, ..settings };
                        let (img, ms) = splat_frame(gpu, renderer, &store, &cam, size, 1.0, &knob, frames)?;
                        img.save(images.join(format!("{stem}-blended-e{eps}-k{sharp}.png")))?;
                        knob_rows.push(format!(
                            "| {name} | {eps} | {sharp} | {:.4} | {:.3} | {ms:.0} |",
                            ssim(&img, &reference),
                            edge_share(&img, &mask, 12)
                        ));
                    }
                }
                if view == "far" && mode != SplatMode::Points {
                    let mut series = Vec::new();
                    for tol in [1.0f32, 2.0, 4.0, 8.0, 16.0] {
                        let (img, _) = splat_frame(gpu, renderer, &store, &cam, size, tol, &settings, 0)?;
                        series.push((tol, ssim(&img, &reference)));
                    }
                    tolerance_series.push((name.into(), mode, series));
                }
            }
        }
    }
    println!("\n## Far view: SSIM against the mesh render by the cut's pixel tolerance");
    println!("| model | mode | 1 px | 2 px | 4 px | 8 px | 16 px |");
    println!("|---|---|---|---|---|---|---|");
    for (model, mode, s) in &tolerance_series {
        let cells: Vec<String> = s.iter().map(|(_, v)| format!("{v:.4}")).collect();
        println!("| {model} | {mode} | {} |", cells.join(" | "));
    }
    println!("\n## Blended close-ups: the blend epsilon (splat radii) and the kernel's sharpness");
    println!("| model | epsilon | sharpness | SSIM | edges | ms per frame |");
    println!("|---|---|---|---|---|---|");
    for r in &knob_rows {
        println!("{r}");
    }
    plot(&rows, &tolerance_series, out_dir)?;
    println!("\nimages: {}", images.display());
    Ok(rows)
}

/// The image with its steps > 12/255 inside `mask` in red (what `edge_share` counts).
fn edge_map(img: &image::RgbaImage, mask: &[bool]) -> image::RgbaImage {
    let (w, h) = img.dimensions();
    let step = |a: &image::Rgba<u8>, b: &image::Rgba<u8>| (0..3).any(|c| a[c].abs_diff(b[c]) > 12);
    image::RgbaImage::from_fn(w, h, |x, y| {
        let p = img.get_pixel(x, y);
        let i = (y * w + x) as usize;
        let edge = mask[i]
            && ((x + 1 < w && mask[i + 1] && step(p, img.get_pixel(x + 1, y)))
                || (y + 1 < h && mask[i + w as usize] && step(p, img.get_pixel(x, y + 1))));
        if edge { image::Rgba([255, 0, 0, 255]) } else { image::Rgba([p[0] / 2, p[1] / 2, p[2] / 2, 255]) }
    })
}

fn color(mode: SplatMode) -> RGBColor {
    match mode {
        SplatMode::Blended => BLUE,
        SplatMode::Discs => RED,
        SplatMode::Points => RGBColor(0, 150, 0),
    }
}

fn plot(rows: &[Row], tolerance: &[ToleranceSeries], out_dir: &Path) -> anyhow::Result<()> {
    let svg = out_dir.join("render-quality.svg");
    let root = SVGBackend::new(&svg, (1000, 500)).into_drawing_area();
    root.fill(&WHITE)?;
    let (left, right) = root.split_horizontally(560);
    let xmax = rows.iter().map(|r| r.ms).filter(|m| m.is_finite()).fold(1.0, f64::max) * 1.1;
    let ymin = rows.iter().map(|r| r.ssim).fold(1.0, f64::min).min(0.9) - 0.01;
    let mut chart = ChartBuilder::on(&left)
        .caption("SSIM against the mesh render vs ms per frame", ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(0.0..xmax, ymin..1.0)?;
    chart.configure_mesh().x_desc("ms per frame (lavapipe)").y_desc("SSIM").draw()?;
    for (_, mode) in SplatMode::ALL {
        let pts: Vec<(f64, f64)> = rows.iter().filter(|r| r.mode == mode).map(|r| (r.ms, r.ssim)).collect();
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 4, color(mode).filled())))?
            .label(mode.name())
            .legend(move |(x, y)| Circle::new((x, y), 4, color(mode).filled()));
    }
    chart.draw_series(
        rows.iter()
            .filter(|r| r.mode == SplatMode::Blended)
            .map(|r| Text::new(r.view, (r.ms, r.ssim + 0.003), ("sans-serif", 11).into_font())),
    )?;
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw()?;
    let mut chart = ChartBuilder::on(&right)
        .caption("Far view: SSIM vs cut tolerance", ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(0.5f32..17.0, ymin..1.0)?;
    chart.configure_mesh().x_desc("cut tolerance, px").y_desc("SSIM").draw()?;
    for (model, mode, s) in tolerance {
        let c = color(*mode);
        chart
            .draw_series(LineSeries::new(s.iter().copied(), c.stroke_width(2)))?
            .label(format!("{model} {mode}"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 15, y)], c.stroke_width(2)));
    }
    chart.configure_series_labels().border_style(BLACK).background_style(WHITE).draw()?;
    root.present()?;
    drop(root);
    let png = kiosk_testkit::png_beside(&svg)?;
    println!("\nplot: {} ({})", svg.display(), png.display());
    Ok(())
}

/// The splat radius of point clouds (`BuildParams::cloud_radius_factor`) against the mesh render:
/// each model's vertices alone, as a bare point cloud (no normals, no spacings, no faces: all
/// estimated, as for a survey scan), built with each radius factor and drawn blended at the
/// middle and close-up views. The models are the quality table's and the dragon, whose
/// marching-cubes vertices lie the least regularly. Printed: SSIM, PSNR, and the share of the
/// mesh's interior where the splats' pixel is more than 48/255 from the mesh's in some channel
/// (the surface behind, or the background, seen through a gap; or a disc overhanging a crease).
/// Images in target/bench/quality.
pub fn cloud_radius(
    gpu: &Gpu,
    renderer: &mut Renderer,
    root: &Path,
    out_dir: &Path,
    size: (u32, u32),
) -> anyhow::Result<()> {
    use kiosk_import::source::{InputPoint, ReadOptions};
    use kiosk_import::{BuildParams, Builder};
    const FACTORS: [f32; 7] = [0.8, 1.0, 1.2, 1.4, 1.6, 2.0, 2.5];
    let Against { mesh_renderer, base, bg, dir, images } = Against::new(gpu, out_dir)?;
    let default = BuildParams::default().cloud_radius_factor;
    println!(
        "\n## Point clouds: splat radius against the mesh render ({}×{}, blended, 1 px cut; the meshes' vertices alone, normals and spacings estimated)",
        size.0, size.1
    );
    println!("| model | view | radius / spacing | SSIM | PSNR dB | pixels off by > 48/255 |");
    println!("|---|---|---|---|---|---|");
    let mut series: Vec<(String, Vec<(f32, f64)>)> = Vec::new();
    // The mesh reader takes plain text: the dragon is unpacked first.
    let dragon = dir.path().join("dragon_vrip.ply");
    std::io::copy(
        &mut kiosk_import::formats::gzip::open(&kiosk_testkit::synthetic::dragon_scan())?,
        &mut std::fs::File::create(&dragon)?,
    )?;
    let dragon = dragon.to_string_lossy().into_owned();
    for (name, rel) in MODELS.into_iter().chain([("dragon (held back)", dragon.as_str())]) {
        let path = root.join(rel);
        let opts = ReadOptions { fill_plain_meshes: false, ..ReadOptions::default() };
        let (pts, _) = kiosk_import::formats::read_all(&path, &opts)?;
        let mesh = kiosk_testkit::mesh::read(&path).map_err(anyhow::Error::msg)?;
        let short = name.split(' ').next().unwrap_or("m");
        let mut close = Vec::new();
        let mut references = Vec::new();
        for factor in FACTORS {
            let out = dir.path().join(format!("{short}-{factor}.kstore"));
            let params = BuildParams { cloud_radius_factor: factor, ..BuildParams::default() };
            let mut b = Builder::new(params, dir.path())?;
            b.push_all(pts.iter().map(|p| InputPoint::at(p.pos, p.color)).collect())?;
            b.finish(&out, &mut |_| {})?;
            let store = kiosk_content::open_store(&out)?;
            let views = kiosk_testkit::mesh::views(&store, &mesh);
            if references.is_empty() {
                for (view, cam) in &views[1..] {
                    let reference = mesh_renderer.render_image(gpu, &mesh, cam, size, &base)?;
                    let covered = coverage(&reference, bg);
                    let inside = interior(&covered, &covered, size, 2);
                    references.push((*view, reference, inside));
                }
            }
            for ((view, cam), (_, reference, inside)) in views[1..].iter().zip(&references) {
                let (img, _) = splat_frame(gpu, renderer, &store, cam, size, 1.0, &base, 0)?;
                img.save(images.join(format!("{short}-cloud-{view}-r{factor}.png")))?;
                let inner = inside.iter().filter(|&&i| i).count().max(1);
                let holes = inside
                    .iter()
                    .zip(img.pixels().zip(reference.pixels()))
                    .filter(|(i, (a, b))| **i && (0..3).any(|c| a[c].abs_diff(b[c]) > 48))
                    .count();
                let ssim = ssim(&img, reference);
                let mark = if factor == default { " (default)" } else { "" };
                println!(
                    "| {name} | {view} | {factor}{mark} | {ssim:.4} | {:.2} | {:.2} % |",
                    psnr(&img, reference),
                    100.0 * holes as f64 / inner as f64
                );
                if *view == "close-up" {
                    close.push((factor, ssim));
                }
            }
        }
        series.push((name.into(), close));
    }
    plot_cloud_radius(&series, &out_dir.join("render-cloud-radius.svg"))
}

fn plot_cloud_radius(series: &[(String, Vec<(f32, f64)>)], path: &Path) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (800, 500)).into_drawing_area();
    root.fill(&WHITE)?;
    let lo = series.iter().flat_map(|(_, s)| s.iter().map(|p| p.1)).fold(1.0, f64::min);
    let mut chart = ChartBuilder::on(&root)
        .caption("Point clouds: splat radius against SSIM to the mesh (close-ups)", ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.7f32..2.6f32, (lo - 0.01)..1.0)?;
    chart.configure_mesh().x_desc("splat radius / estimated spacing").y_desc("SSIM").draw()?;
    for (i, (name, s)) in series.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(s.iter().copied(), colour.stroke_width(2)))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        chart.draw_series(s.iter().map(|p| Circle::new(*p, 4, colour.filled())))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()?;
    root.present()?;
    println!("\nplot: {}", path.display());
    Ok(())
}
