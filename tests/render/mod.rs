//! The renderer on lavapipe (software Vulkan; installed by `.ci/setup`): shaders validated by
//! naga, golden images at a stated perceptual tolerance, the georeferenced offset, close-ups
//! without holes, bounded uploads. A test that cannot get an adapter fails, loudly.

use crate::common;
use glam::DVec3;
use kiosk_content::MappedStore;
use kiosk_core::camera::Camera;
use kiosk_render::{Gpu, RenderSettings, Renderer, SplatMode};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// The perceptual tolerance of golden images: mean SSIM over 8×8 windows of the luminance.
const MIN_SSIM: f64 = 0.97;

/// Errors the Vulkan validation layers (installed by `.ci/setup`) and wgpu report through `log`.
static VALIDATION: Mutex<Vec<String>> = Mutex::new(Vec::new());

struct ValidationLog;

impl log::Log for ValidationLog {
    fn enabled(&self, m: &log::Metadata<'_>) -> bool {
        m.level() <= log::Level::Error && m.target().starts_with("wgpu")
    }
    fn log(&self, r: &log::Record<'_>) {
        if self.enabled(r.metadata()) {
            VALIDATION.lock().unwrap_or_else(|e| e.into_inner()).push(format!(
                "{}: {}",
                r.target(),
                r.args()
            ));
        }
    }
    fn flush(&self) {}
}

/// Fails on any validation message logged so far.
fn assert_no_validation_errors() {
    let v = std::mem::take(&mut *VALIDATION.lock().unwrap_or_else(|e| e.into_inner()));
    assert!(v.is_empty(), "GPU validation errors:\n{}", v.join("\n"));
}

/// One GPU for the whole test binary (lavapipe is slow to start; tests take turns).
fn gpu() -> &'static Mutex<(Gpu, Renderer)> {
    static GPU: OnceLock<Mutex<(Gpu, Renderer)>> = OnceLock::new();
    GPU.get_or_init(|| {
        static LOGGER: ValidationLog = ValidationLog;
        // Another test may have set a logger first; validation is then checked by wgpu alone.
        if log::set_logger(&LOGGER).is_ok() {
            log::set_max_level(log::LevelFilter::Error);
        }
        let (gpu, renderer) = kiosk_testkit::test_gpu();
        Mutex::new((gpu, renderer))
    })
}

fn render(
    store: &MappedStore,
    camera: &Camera,
    size: (u32, u32),
    settings: &RenderSettings,
) -> image::RgbaImage {
    let mut g = gpu().lock().unwrap_or_else(|e| e.into_inner());
    let (gpu, renderer) = &mut *g;
    let img = kiosk_content::snapshot::snapshot(gpu, renderer, store, camera, size, 1.0, settings)
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert_no_validation_errors();
    img
}

use kiosk_testkit::metrics::ssim;

fn golden_dir() -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

/// Compares with `tests/golden/NAME.png`; on a difference writes `NAME.actual.png` and
/// `NAME.diff.png` into the build directory (`target/tmp/golden/`) and fails. `ISOKIOSK_BLESS=1` writes the golden instead.
fn assert_golden(name: &str, img: &image::RgbaImage) {
    let dir = golden_dir();
    let golden = dir.join(format!("{name}.png"));
    if std::env::var_os("ISOKIOSK_BLESS").is_some() {
        img.save(&golden).expect("write golden");
        return;
    }
    // Candidates and differences go to the build directory: tests never write into the sources.
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("golden");
    std::fs::create_dir_all(&out).expect("golden output directory");
    let actual = out.join(format!("{name}.actual.png"));
    let Ok(reference) = image::open(&golden).map(|i| i.to_rgba8()) else {
        img.save(&actual).expect("write actual");
        panic!(
            "no golden image {} (candidate written to {}; bless with ISOKIOSK_BLESS=1)",
            golden.display(),
            actual.display()
        );
    };
    let s = ssim(&reference, img);
    if s < MIN_SSIM {
        img.save(&actual).expect("write actual");
        let (w, h) = img.dimensions();
        let diff = image::RgbaImage::from_fn(w, h, |x, y| {
            let (a, b) = (
                img.get_pixel(x, y),
                reference.get_pixel(x.min(reference.width() - 1), y.min(reference.height() - 1)),
            );
            let d = (0..3).map(|c| (i16::from(a[c]) - i16::from(b[c])).unsigned_abs()).max().unwrap_or(0);
            image::Rgba([(d * 4).min(255) as u8, 0, 0, 255])
        });
        let diff_path = out.join(format!("{name}.diff.png"));
        diff.save(&diff_path).expect("write diff");
        panic!(
            "{name}: SSIM {s:.4} < {MIN_SSIM} against {} (see {} and {})",
            golden.display(),
            actual.display(),
            diff_path.display()
        );
    }
}

#[test]
fn every_wgsl_file_validates_with_naga() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).expect("shaders/") {
        let p = e.expect("entry").path();
        if p.extension().is_some_and(|x| x == "wgsl") {
            let mut src = std::fs::read_to_string(&p).expect("read");
            // The mesh reference is compiled after the splat shader, whose shading it calls.
            if p.file_name().is_some_and(|f| f == "mesh_reference.wgsl") {
                src = std::fs::read_to_string(dir.join("splat.wgsl")).expect("splat.wgsl") + &src;
            }
            let module = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("{}: {}", p.display(), e.emit_to_string(&src)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::all(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{}: {}", p.display(), e.emit_to_string(&src)));
            n += 1;
        }
    }
    assert!(n >= 4, "expected the splat, mesh reference, EDL and blit shaders, found {n}");
}

#[test]
fn gpu_adapter_is_available() {
    let g = gpu().lock().unwrap_or_else(|e| e.into_inner());
    assert!(!g.0.adapter.name.is_empty());
}

fn bunny() -> &'static common::Built {
    static B: OnceLock<common::Built> = OnceLock::new();
    B.get_or_init(|| {
        common::build(&common::read("scans/stanford-bunny/bun_zipper.ply"), common::small_nodes())
    })
}

fn bust() -> &'static common::Built {
    static B: OnceLock<common::Built> = OnceLock::new();
    B.get_or_init(|| {
        common::build(&common::read("scans/demosthenes/demosthenes-low-res.obj"), common::small_nodes())
    })
}

fn start(store: &MappedStore) -> Camera {
    kiosk_core::camera::initial_camera(store, 0.8, DVec3::Y)
}

#[test]
fn golden_images_of_real_scans_in_every_mode() {
    let size = (160, 120);
    for (name, mode) in SplatMode::ALL {
        let settings = RenderSettings { mode, ..RenderSettings::default() };
        assert_golden(
            &format!("bunny-{name}"),
            &render(&bunny().store, &start(&bunny().store), size, &settings),
        );
        assert_golden(
            &format!("bust-{name}"),
            &render(&bust().store, &start(&bust().store), size, &settings),
        );
    }
    // Eye-dome lighting on the blended mode's depth.
    let edl = RenderSettings { edl_strength: 0.5, ..RenderSettings::default() };
    assert_golden("bust-edl", &render(&bust().store, &start(&bust().store), size, &edl));
}

/// The bust's mesh, its store and the close-up view of the quality benchmark, drawn by the mesh
/// reference renderer and in `mode`.
fn close_up_against_mesh(mode: SplatMode, size: (u32, u32)) -> (image::RgbaImage, image::RgbaImage) {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scans/demosthenes/demosthenes-low-res.obj");
    let mesh = kiosk_testkit::mesh::read(&path).expect("the bust's mesh");
    let store = &bust().store;
    let [_, _, (_, close)] = kiosk_testkit::mesh::views(store, &mesh);
    let settings = RenderSettings { mode, ..RenderSettings::default() };
    let splats = render(store, &close, size, &settings);
    let g = gpu().lock().unwrap_or_else(|e| e.into_inner());
    let reference = kiosk_render::reference::MeshRenderer::new(&g.0, kiosk_render::OFFSCREEN_FORMAT)
        .render_image(&g.0, &mesh, &close, size, &settings)
        .expect("mesh render");
    drop(g);
    assert_no_validation_errors();
    (splats, reference)
}

#[test]
fn a_blended_close_up_is_as_smooth_as_the_mesh_it_samples() {
    use kiosk_testkit::metrics::{coverage, edge_share, extra_edge_share, interior, srgb8};
    // The kiosk's wall is full HD or more; half of it keeps the test quick.
    let size = (960, 540);
    let bg = srgb8(RenderSettings::default().background);
    let measure = |mode| {
        let (img, reference) = close_up_against_mesh(mode, size);
        // Kept for a look when the test fails.
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("close-up");
        std::fs::create_dir_all(&out).expect("output directory");
        img.save(out.join(format!("{mode}.png"))).expect("write image");
        reference.save(out.join("mesh.png")).expect("write image");
        let mask = interior(&coverage(&reference, bg), &coverage(&img, bg), size, 2);
        assert!(
            mask.iter().filter(|m| **m).count() > (size.0 * size.1 / 2) as usize,
            "the close-up fills the image"
        );
        (
            edge_share(&img, &mask, 12),
            edge_share(&reference, &mask, 12),
            extra_edge_share(&img, &reference, &mask, 12, 2),
            ssim(&img, &reference),
        )
    };
    let (blended, mesh, blended_extra, blended_ssim) = measure(SplatMode::Blended);
    let (discs, _, discs_extra, discs_ssim) = measure(SplatMode::Discs);
    println!(
        "close-up steps > 12/255: mesh {mesh:.4}, blended {blended:.4} ({blended_extra:.4} where the mesh has none), \
         discs {discs:.4} ({discs_extra:.4}); SSIM blended {blended_ssim:.4}, discs {discs_ssim:.4}"
    );
    // Disc edges are steps where the surface has none (2 px away from its own). Opaque discs
    // show many times more of them than the surface has edges; blended splats at most twice as
    // many, all on the occluding contours, which the discs' rims scallop (the bust's mesh is
    // coarse: its splats are ~100 px wide at this distance).
    assert!(
        discs_extra > 4.0 * mesh,
        "discs: {discs_extra:.4} edges where the mesh has none, mesh {mesh:.4}"
    );
    assert!(
        blended_extra <= 2.0 * mesh,
        "blended: {blended_extra:.4} edges where the mesh has none, mesh {mesh:.4}"
    );
    assert!(blended * 5.0 < discs, "steps: blended {blended:.4}, discs {discs:.4}, mesh {mesh:.4}");
    assert!(
        blended_ssim >= 0.95 && blended_ssim > discs_ssim,
        "SSIM blended {blended_ssim:.4}, discs {discs_ssim:.4}"
    );
}

#[test]
fn the_mesh_reference_draws_the_surface_the_splats_sample() {
    // Far away every mode and the mesh agree: the reference shares camera, light and colour.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scans/stanford-bunny/bun_zipper.ply");
    let mesh = kiosk_testkit::mesh::read(&path).expect("the bunny's mesh");
    let store = &bunny().store;
    let [(_, far), ..] = kiosk_testkit::mesh::views(store, &mesh);
    let size = (320, 240);
    let reference = {
        let g = gpu().lock().unwrap_or_else(|e| e.into_inner());
        kiosk_render::reference::MeshRenderer::new(&g.0, kiosk_render::OFFSCREEN_FORMAT)
            .render_image(&g.0, &mesh, &far, size, &RenderSettings::default())
            .expect("mesh render")
    };
    for (name, mode) in SplatMode::ALL {
        let img = render(store, &far, size, &RenderSettings { mode, ..RenderSettings::default() });
        let s = ssim(&img, &reference);
        assert!(s > 0.95, "{name}: SSIM {s:.4} against the mesh");
    }
    // A mesh moved by 10⁷ m is drawn at the same place (camera-relative, as the splats).
    let mut moved = mesh.clone();
    let offset = DVec3::new(1.0e7, -4.0e6, 2.5e6);
    moved.origin += offset;
    let cam = Camera { eye: far.eye + offset, target: far.target + offset, ..far };
    let g = gpu().lock().unwrap_or_else(|e| e.into_inner());
    let again = kiosk_render::reference::MeshRenderer::new(&g.0, kiosk_render::OFFSCREEN_FORMAT)
        .render_image(&g.0, &moved, &cam, size, &RenderSettings::default())
        .expect("mesh render");
    assert!(ssim(&again, &reference) > 0.995);
}

#[test]
fn the_model_translated_by_ten_million_metres_renders_the_same_image() {
    let pts = common::read("scans/demosthenes/demosthenes-low-res.obj");
    let offset = DVec3::new(1.0e7, -4.0e6, 2.5e6);
    let far = common::build(&common::transform(&pts, 1.0, offset), common::small_nodes());
    let near_cam = start(&bust().store);
    let far_cam = Camera { eye: near_cam.eye + offset, target: near_cam.target + offset, ..near_cam };
    let size = (200, 150);
    let a = render(&bust().store, &near_cam, size, &RenderSettings::default());
    let b = render(&far.store, &far_cam, size, &RenderSettings::default());
    let s = ssim(&a, &b);
    assert!(s > 0.995, "SSIM {s}");
}

#[test]
fn a_las_cloud_a_million_metres_away_renders_like_the_cloud_at_the_origin() {
    // The same survey cloud with and without offsets of 10⁶ m in its LAS header, each imported
    // as a curator would, seen from the same place relative to it.
    let dir = tempfile::tempdir().expect("temp dir");
    let shift = DVec3::new(1.0e6, 2.0e6, 5.0e2);
    let (far, near, _) = common::las_far_and_near(dir.path(), shift.to_array());
    let import = |scan: &Path| {
        let out = scan.with_extension("kstore");
        kiosk_content::import::import(
            scan,
            &out,
            &kiosk_content::import::ImportOptions::default(),
            &mut kiosk_content::import::quiet,
        )
        .unwrap_or_else(|e| panic!("{}: {e:#}", scan.display()));
        kiosk_content::open_store(&out).unwrap_or_else(|e| panic!("{e:#}"))
    };
    let (far, near) = (import(&far), import(&near));
    assert!(
        (far.origin() - near.origin() - shift).abs().max_element() < 1.0e-3,
        "the offsets reach the origin"
    );
    let near_cam = start(&near);
    let far_cam = Camera { eye: near_cam.eye + shift, target: near_cam.target + shift, ..near_cam };
    let size = (200, 150);
    let a = render(&near, &near_cam, size, &RenderSettings::default());
    let b = render(&far, &far_cam, size, &RenderSettings::default());
    let bg = image::Rgba(a.get_pixel(0, 0).0);
    let drawn = a.pixels().filter(|&&p| p != bg).count();
    assert!(drawn > 1000, "the cloud covers {drawn} pixels");
    let s = ssim(&a, &b);
    assert!(s > 0.995, "SSIM {s}");
}

/// The small bunny's PLY text, and the same with every vertex moved by `turn`.
fn bunny_ply_turned(turn: impl Fn(DVec3) -> DVec3) -> (String, String) {
    let text =
        std::fs::read_to_string(common::data("scans/stanford-bunny/bun_zipper_res2.ply")).expect("bunny");
    let (header, body) = text.split_once("end_header\n").expect("a PLY header");
    let vertices: usize = header
        .lines()
        .find_map(|l| l.strip_prefix("element vertex "))
        .and_then(|n| n.trim().parse().ok())
        .expect("a vertex count");
    let mut turned = format!("{header}end_header\n");
    for (i, line) in body.lines().enumerate() {
        let v: Vec<&str> = line.split_whitespace().collect();
        if i < vertices {
            let p: Vec<f64> = v[..3].iter().map(|x| x.parse().expect("a coordinate")).collect();
            let q = turn(DVec3::new(p[0], p[1], p[2]));
            turned += &format!("{} {} {} {}\n", q.x, q.y, q.z, v[3..].join(" "));
        } else {
            turned += &format!("{line}\n");
        }
    }
    (text, turned)
}

/// An exhibit directory `name` under `dir` with the scan `ply` and, if given, `exhibit.toml`.
fn ply_exhibit(dir: &Path, name: &str, ply: &str, toml: Option<&str>) -> PathBuf {
    let d = dir.join(name);
    std::fs::create_dir_all(&d).expect("exhibit dir");
    std::fs::write(d.join("bunny.ply"), ply).expect("scan");
    if let Some(toml) = toml {
        std::fs::write(d.join("exhibit.toml"), toml).expect("exhibit.toml");
    }
    d
}

#[test]
fn a_z_up_scan_starts_upright_like_the_same_scan_standing_on_y() {
    // The bunny as scanned (Y up) and turned to stand on Z, as scanners and Metashape deliver
    // it ((x, y, z) → (x, −z, y)), each an exhibit of its own, the second saying `up = "z"`: the
    // kiosk's start view (`kiosk snapshot` without a view) shows both the same, upright.
    let dir = tempfile::tempdir().expect("temp dir");
    let (text, turned) = bunny_ply_turned(|p| DVec3::new(p.x, -p.z, p.y));
    let shot = |exhibit: &Path| {
        common::snapshot(
            exhibit,
            &exhibit.join("start.png"),
            &dir.path().join("cache"),
            &["--size", "240x180"],
        )
    };
    let standing = shot(&ply_exhibit(dir.path(), "y-up", &text, None));
    let lying = shot(&ply_exhibit(dir.path(), "z-up", &turned, Some("up = \"z\"\n")));
    let s = ssim(&standing, &lying);
    assert!(s > 0.99, "SSIM {s}: the Z-up scan does not start as the Y-up one");
    // Without its exhibit.toml the Z-up scan is seen lying on its side: the check can tell.
    let unsaid = shot(&ply_exhibit(dir.path(), "z-up-unsaid", &turned, None));
    let s = ssim(&standing, &unsaid);
    assert!(s < 0.9, "SSIM {s}: a lying bunny looks like a standing one");
}

#[test]
fn a_scan_turned_any_way_starts_upright_when_its_exhibit_says_how() {
    // The bunny turned 37° about an oblique axis, and its exhibit.toml giving the turned up and
    // front as vectors: the kiosk's start view shows it upright, from the front, as the same view
    // turned back shows the bunny as scanned.
    let dir = tempfile::tempdir().expect("temp dir");
    let cache = dir.path().join("cache");
    let turn = glam::DQuat::from_axis_angle(DVec3::new(0.3, 0.8, 0.5).normalize(), 37f64.to_radians());
    let (text, turned) = bunny_ply_turned(|p| turn * p);
    let (up, front) = (turn * DVec3::Y, turn * DVec3::Z);
    let toml =
        format!("up = [{}, {}, {}]\nfront = [{}, {}, {}]\n", up.x, up.y, up.z, front.x, front.y, front.z);
    let said = ply_exhibit(dir.path(), "turned", &turned, Some(&toml));
    let size = ["--size", "240x180"];
    let start = common::snapshot(&said, &said.join("start.png"), &cache, &size);
    let store = kiosk_content::exhibit::open_model_in(&said, &cache).expect("the turned store");
    let cam = kiosk_core::camera::start_camera(&store, 0.8, up, Some(front));
    assert!(cam.up.abs_diff_eq(up, 1e-9), "the start view stands on the stated up: {}", cam.up);
    let back = turn.inverse();
    let (e, t, u) = (back * cam.eye, back * cam.target, back * cam.up);
    let view = format!(
        "{},{},{},{},{},{},{},{},{},{}",
        e.x,
        e.y,
        e.z,
        t.x,
        t.y,
        t.z,
        u.x,
        u.y,
        u.z,
        0.8f64.to_degrees()
    );
    let standing = ply_exhibit(dir.path(), "as-scanned", &text, None);
    let expected = common::snapshot(
        &standing,
        &standing.join("view.png"),
        &cache,
        &[&size[..], &["--view", &view]].concat(),
    );
    let s = ssim(&expected, &start);
    assert!(s > 0.98, "SSIM {s}: the turned scan does not start as the scan seen the same way");
    // And it is framed as the scan as delivered: by the box of its samples in the upright frame,
    // not by the store's box, which is larger for a turned model.
    let scanned = kiosk_content::exhibit::open_model_in(&standing, &cache).expect("the store as scanned");
    let (center, radius) = kiosk_core::camera::upright_bounds(&store, up, front);
    let half = |b: kiosk_core::Aabb| f64::from(b.diagonal()) * 0.5;
    let (want, loose) = (half(scanned.bbox()), half(store.bbox()));
    assert!((radius / want - 1.0).abs() < 0.002, "framed radius {radius}, the scan's {want}");
    assert!(loose / want > 1.05, "the turned store's box ({loose}) is as tight as the scan's ({want})");
    let scanned_center = turn * scanned.to_model(scanned.bbox().center());
    assert!(
        center.distance(scanned_center) < 0.002 * want,
        "framed about {center}, the scan's {scanned_center}"
    );
    let scanned_start = common::snapshot(&standing, &standing.join("start.png"), &cache, &size);
    let s = ssim(&scanned_start, &start);
    assert!(s > 0.98, "SSIM {s}: the turned scan is not framed as the scan as delivered");
    // Without its exhibit.toml the turned scan starts askew: the check can tell.
    let unsaid = ply_exhibit(dir.path(), "turned-unsaid", &turned, None);
    let askew = common::snapshot(&unsaid, &unsaid.join("start.png"), &cache, &size);
    let s = ssim(&expected, &askew);
    assert!(s < 0.9, "SSIM {s}: an askew bunny looks like an upright one");
}

#[test]
fn a_close_up_at_the_minimum_distance_has_no_holes() {
    let store = &bunny().store;
    let cut = kiosk_core::Cut::leaves(store);
    let diag = f64::from(store.bbox().diagonal());
    let min = 0.01 * diag;
    // Look at the surface from the minimum distance, along the surface normal at a sample.
    let p = store.to_model(store.splats(cut.nodes()[cut.nodes().len() / 2])[100].position());
    let n = store.splats(cut.nodes()[cut.nodes().len() / 2])[100].normal().as_dvec3();
    let center = store.to_model(store.bbox().center());
    let n = if n.dot(p - center) < 0.0 { -n } else { n };
    let cam = Camera {
        eye: p + n * min,
        target: p,
        up: kiosk_core::camera::orthonormal_up(-n, DVec3::Y, DVec3::Z),
        fov_y: 0.8,
    };
    let img = render(store, &cam, (96, 96), &RenderSettings::default());
    let bg = RenderSettings::default().background;
    let is_bg = |px: &image::Rgba<u8>| {
        let srgb = |c: f64| {
            (255.0 * if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }).round()
                as i32
        };
        (0..3).all(|k| (i32::from(px[k]) - srgb(bg[k])).abs() <= 2)
    };
    // The central half of the image is surface everywhere: no background shows through.
    let holes = (24..72)
        .flat_map(|y| (24..72).map(move |x| (x, y)))
        .filter(|&(x, y)| is_bg(img.get_pixel(x, y)))
        .count();
    assert_eq!(holes, 0, "{holes} background pixels in the close-up");
}

#[test]
fn bounded_uploads_substitute_cached_ancestors() {
    let store = &bunny().store;
    let mut g = gpu().lock().unwrap_or_else(|e| e.into_inner());
    let (gpu, _) = &mut *g;
    let mut renderer = Renderer::new(gpu, kiosk_render::OFFSCREEN_FORMAT);
    let cam = start(store);
    let view = cam.view_params(store, (160, 120)).expect("view");
    let cut = kiosk_core::Cut::leaves(store);
    let nodes = cut.visible_nodes(store, &view);
    let tight = RenderSettings { upload_budget_bytes: 64 << 10, ..RenderSettings::default() };
    let (_, target) = renderer.offscreen_target(gpu, (160, 120));
    let mut frame = || renderer.render(gpu, store, &nodes, &cam, &target, (160, 120), &tight).expect("frame");
    let first = frame();
    assert!(first.substituted > 0, "{first:?}");
    assert!(first.uploaded_bytes <= (64 << 10) + 24 * u64::from(store.node(store.root()).point_count));
    // Frame after frame the cache fills and nothing is substituted any more.
    let mut last = first;
    for _ in 0..200 {
        last = frame();
        if last.substituted == 0 {
            break;
        }
    }
    assert_eq!(last.substituted, 0);
    assert_eq!(last.nodes, nodes.len());
    assert_no_validation_errors();
}

#[test]
fn a_rendered_image_is_complete_whatever_the_upload_budget() {
    // A snapshot, a thumbnail or a benchmark's frame is one frame: the budget that paces a live
    // view must not leave stand-in ancestors (large discs past the silhouette) in it.
    let store = &bunny().store;
    let mut g = gpu().lock().unwrap_or_else(|e| e.into_inner());
    let (gpu, _) = &mut *g;
    let cam = start(store);
    let view = cam.view_params(store, (160, 120)).expect("view");
    let nodes = kiosk_core::Cut::leaves(store).visible_nodes(store, &view);
    let image = |budget: u64| {
        let mut renderer = Renderer::new(gpu, kiosk_render::OFFSCREEN_FORMAT);
        let s = RenderSettings { upload_budget_bytes: budget, ..RenderSettings::default() };
        renderer.render_image(gpu, store, &nodes, &cam, (160, 120), &s).expect("image")
    };
    let (tight, stats) = image(64 << 10);
    assert_eq!(stats.substituted, 0, "{stats:?}");
    assert_eq!(stats.nodes, nodes.len());
    let (roomy, _) = image(u64::MAX);
    assert!(tight == roomy, "the same image whatever the budget");
    assert_no_validation_errors();
}

#[test]
fn validation_messages_are_caught() {
    // The checker itself must be able to fail: a logged wgpu error is reported. (Holding the GPU
    // keeps the other tests' checks from taking the deliberate message.)
    let _held = gpu().lock().unwrap_or_else(|e| e.into_inner());
    log::error!(target: "wgpu_hal::vulkan", "VALIDATION [test] a deliberate message");
    let caught = std::panic::catch_unwind(assert_no_validation_errors);
    assert!(
        caught.is_err() || log::max_level() < log::LevelFilter::Error,
        "a logged validation error went unnoticed"
    );
}

#[test]
fn one_renderer_switches_between_models() {
    // The node cache is per model: drawing another store must not reuse its buffers.
    let size = (160, 120);
    let s = RenderSettings::default();
    let a1 = render(&bust().store, &start(&bust().store), size, &s);
    let _ = render(&bunny().store, &start(&bunny().store), size, &s);
    let a2 = render(&bust().store, &start(&bust().store), size, &s);
    assert!(ssim(&a1, &a2) > 0.999);
}

#[test]
fn an_image_larger_than_the_device_allows_is_a_clear_error() {
    let guard = gpu().lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let (gpu, _) = &*guard;
    assert!(gpu.check_size((1280, 720)).is_ok());
    let side = gpu.device.limits().max_texture_dimension_2d;
    let e = gpu.check_size((side + 1, 100)).expect_err("wider than any texture").to_string();
    assert!(e.contains(&format!("{}×100", side + 1)) && e.contains("pixels a side"), "{e}");
    drop(guard);
    // Through the command line: the flag is named, and nothing is written.
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("big.png");
    let exhibit = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("content/demosthenes");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .env("ISOKIOSK_CACHE", common::cache())
        .args(["snapshot", "--size", "8200x8200", "-o"])
        .arg(&out)
        .arg("--exhibit")
        .arg(&exhibit)
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("run kiosk");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("--size 8200x8200") && err.contains("largest buffer"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn a_snapshot_writes_png_or_jpeg_and_refuses_other_names_before_it_writes() {
    let dir = tempfile::tempdir().expect("temp dir");
    let exhibit = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("content/demosthenes");
    let size = ["--size", "240x180"];
    let png = common::snapshot(&exhibit, &dir.path().join("s.png"), &common::cache(), &size);
    let jpg = common::snapshot(&exhibit, &dir.path().join("s.jpg"), &common::cache(), &size);
    let s = ssim(&png, &jpg);
    assert!(s > 0.9, "SSIM {s}: the JPEG shows the PNG's view");
    let out = dir.path().join("s.bmp");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .env("ISOKIOSK_CACHE", common::cache())
        .env("RUST_BACKTRACE", "0")
        .args(["snapshot", "--exhibit"])
        .arg(&exhibit)
        .arg("-o")
        .arg(&out)
        .output()
        .expect("run kiosk");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("name a .png or .jpg file"), "{err}");
    assert!(!out.exists());
    // Settings out of range are usage errors, as in kiosk.toml.
    let never = dir.path().join("never.png");
    for (flag, value) in [("--edl", "-1"), ("--tolerance", "0")] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
            .args(["snapshot", "--exhibit"])
            .arg(&exhibit)
            .arg("-o")
            .arg(&never)
            .arg(format!("{flag}={value}"))
            .env("ISOKIOSK_CACHE", common::cache())
            .output()
            .expect("run kiosk");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.code() == Some(2) && err.contains(flag), "{flag} {value}: {err}");
        assert!(!never.exists());
    }
}

#[test]
fn the_textured_mesh_reference_and_the_splats_show_the_same_texture() {
    // Khronos' BoxTextured: a cube with the glTF logo texture. The mesh reference samples the
    // texture per pixel; the store's splats carry the colours the importer sampled from it.
    let glb = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats/box-textured/BoxTextured.glb");
    let mesh = kiosk_testkit::mesh::read_glb(&glb).expect("the box's mesh and texture");
    assert!(mesh.texture.is_some() && mesh.uvs.len() == mesh.positions.len());
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("box.kstore");
    kiosk_content::import::import(
        &glb,
        &out,
        &kiosk_content::import::ImportOptions::default(),
        &mut kiosk_content::import::quiet,
    )
    .expect("import");
    let store = kiosk_content::open_store(&out).expect("open");
    let cam = {
        let c = store.to_model(store.bbox().center());
        let d = f64::from(store.bbox().diagonal());
        let mut cam = Camera {
            eye: c + DVec3::new(0.9, 0.7, 1.2).normalize() * 1.3 * d,
            target: c,
            up: DVec3::Y,
            fov_y: 0.8,
        };
        cam.up = kiosk_core::camera::orthonormal_up(cam.forward(), DVec3::Y, DVec3::Z);
        cam
    };
    let size = (320, 240);
    let settings = RenderSettings::default();
    let reference = {
        let g = gpu().lock().unwrap_or_else(|e| e.into_inner());
        kiosk_render::reference::MeshRenderer::new(&g.0, kiosk_render::OFFSCREEN_FORMAT)
            .render_image(&g.0, &mesh, &cam, size, &settings)
            .expect("mesh render")
    };
    let splats = render(&store, &cam, size, &settings);
    let bg = kiosk_testkit::metrics::srgb8(settings.background);
    let cover = |i: &image::RgbaImage| kiosk_testkit::metrics::coverage(i, bg);
    let mask = kiosk_testkit::metrics::interior(&cover(&reference), &cover(&splats), size, 2);
    assert!(mask.iter().filter(|m| **m).count() > 10_000, "the box fills the view");
    // The texture is there: the mesh image has many distinct colours (the logo on white, not a
    // flat shade), and the splats show the same ones.
    let colours: std::collections::HashSet<[u8; 3]> = reference
        .pixels()
        .zip(&mask)
        .filter(|(_, m)| **m)
        .map(|(p, _)| [p[0] & 0xf0, p[1] & 0xf0, p[2] & 0xf0])
        .collect();
    assert!(colours.len() > 20, "the reference shows a texture ({} colours)", colours.len());
    let de = kiosk_testkit::metrics::delta_e(&splats, &reference, &mask);
    let plain = kiosk_render::reference::Mesh { texture: None, uvs: Vec::new(), ..mesh.clone() };
    let grey = {
        let g = gpu().lock().unwrap_or_else(|e| e.into_inner());
        kiosk_render::reference::MeshRenderer::new(&g.0, kiosk_render::OFFSCREEN_FORMAT)
            .render_image(&g.0, &plain, &cam, size, &settings)
            .expect("mesh render")
    };
    let de_grey = kiosk_testkit::metrics::delta_e(&grey, &reference, &mask);
    assert!(de < 6.0 && de < de_grey / 3.0, "ΔE splats {de:.2} vs an untextured box {de_grey:.2}");
}

/// Drawing frames must not grow the heap: lavapipe compiled a new vertex shader for every pass
/// that drew splats, while the splat shader branched on a uniform alone (lavapipe inlines such a
/// uniform into a variant of the shader and keeps every variant until the device is destroyed):
/// ≈ 230 kB a pass, 4.5 MB a second in a kiosk at its real frame rate. The heap is shared by the
/// tests that run beside this one, so the measurement runs in a process of its own: the test
/// runs itself again.
#[test]
fn drawing_frames_does_not_grow_the_heap() {
    const CHILD: &str = "ISOKIOSK_HEAP_MEASUREMENT";
    const NAME: &str = "render::drawing_frames_does_not_grow_the_heap";
    if std::env::var_os(CHILD).is_some() {
        heap_growth_over_frames();
        return;
    }
    let out = common::rerun_in_child(NAME, CHILD, "1");
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "the measurement failed:\n{stdout}\n{stderr}");
    assert!(stdout.contains("1 passed"), "the measurement did not run:\n{stdout}\n{stderr}");
    for line in stdout.lines().filter(|l| l.contains("heap in use")) {
        println!("{line}");
    }
}

/// Draws the bunny in each mode, after a warm-up, in four windows of 30 frames each, and checks
/// the heap in use (allocated bytes, which fragmentation does not change) between windows: with
/// the old shader, every 40 blended frames took 23 MB. The heap is not flat even without a leak:
/// the driver (or a layer under it) takes about 22 MB once, on a quiet machine by the second
/// frame, on a busy one or a single core much later, after the heap has looked settled for many
/// frames; and once it holds that block, it lets it go for a frame now and then, or takes a second
/// one for a frame. So each window's figure is the median of its 30 frames (a block held or let go
/// for a few frames does not count), and the check is that the median of the three steps between
/// windows (signed) is under 3 MB: a one-time take or release moves one step, a block held through
/// most of one window two steps by opposite amounts, and a leak raises every step.
fn heap_growth_over_frames() {
    let (gpu, mut renderer) = kiosk_testkit::test_gpu();
    let store = &bunny().store;
    let camera = start(store);
    let size = (320, 240);
    for (name, mode) in [("blended", SplatMode::Blended), ("discs", SplatMode::Discs)] {
        let settings = RenderSettings { mode, ..RenderSettings::default() };
        let mut frame = || {
            kiosk_content::snapshot::snapshot(&gpu, &mut renderer, store, &camera, size, 1.0, &settings)
                .unwrap_or_else(|e| panic!("{e:#}"))
        };
        // Warm up until the heap settles (the pipelines compiled, the first frames' buffers
        // made). A leak never settles: after 20 rounds the frames are measured anyway.
        let in_use = || kiosk::windows::heap::in_use_kb().expect("glibc's heap counters");
        let mut last = in_use();
        for _ in 0..20 {
            for _ in 0..5 {
                frame();
            }
            let now = in_use();
            let settled = now.abs_diff(last) < 256;
            last = now;
            if settled {
                break;
            }
        }
        let mut median_of_window = || {
            let mut heap: Vec<u64> = (0..30)
                .map(|_| {
                    frame();
                    in_use()
                })
                .collect();
            heap.sort_unstable();
            heap[heap.len() / 2]
        };
        let windows = [median_of_window(), median_of_window(), median_of_window(), median_of_window()];
        println!("{name}: heap in use, median of each window of 30 frames: {windows:?} kB");
        let mut steps: Vec<i64> = windows.windows(2).map(|w| w[1] as i64 - w[0] as i64).collect();
        steps.sort_unstable();
        let median = steps[1];
        assert!(
            median < 3 * 1024,
            "{name}: the heap grew from window to window, {median} kB a step in the median ({windows:?} kB)"
        );
    }
}

#[test]
fn a_corrupted_node_is_never_drawn_its_ancestor_stands_in_and_a_snapshot_says_so() {
    // The bunny's store with one byte of a node's splats flipped (the index is sound: the store
    // opens, as a store damaged on disk would).
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("bunny.kstore");
    let mut b = kiosk_import::Builder::new(common::small_nodes(), dir.path()).expect("builder");
    for p in common::read("scans/stanford-bunny/bun_zipper.ply") {
        b.push(p).expect("push");
    }
    b.finish(&path, &mut |_| {}).expect("build");
    let sound = kiosk_content::open_store(&path).expect("the store");
    let camera = start(&sound);
    let size = (320, 240);
    let view = camera.view_params(&sound, size).expect("view");
    let mut cut = kiosk_core::Cut::root(&sound);
    let params = kiosk_core::CutParams { tolerance_px: 1.0, max_changes: usize::MAX, ..Default::default() };
    cut.update(&sound, &view, &params);
    let nodes = cut.visible_nodes(&sound, &view);
    // The node nearest the eye, so that it shows.
    let near = |id: &&u32| sound.to_model(sound.node(**id).bbox().center()).distance(camera.eye);
    let leaf = **nodes
        .iter()
        .filter(|&&id| id != sound.root())
        .collect::<Vec<_>>()
        .iter()
        .min_by(|a, b| near(a).total_cmp(&near(b)))
        .expect("a node below the root in view");
    let mut bytes = std::fs::read(&path).expect("read");
    bytes[sound.node(leaf).points_offset as usize + 4] ^= 0x40;
    let broken_path = dir.path().join("broken.kstore");
    std::fs::write(&broken_path, &bytes).expect("write");
    let broken = kiosk_content::open_store(&broken_path).expect("the index is sound");

    let g = gpu().lock().unwrap_or_else(|e| e.into_inner());
    let settings = RenderSettings::default();
    let fresh = || Renderer::new(&g.0, kiosk_render::OFFSCREEN_FORMAT);
    let (good, _) = fresh().render_image(&g.0, &sound, &nodes, &camera, size, &settings).expect("render");
    let mut renderer = fresh();
    let (image, stats) =
        renderer.render_image(&g.0, &broken, &nodes, &camera, size, &settings).expect("render");
    assert_eq!((stats.corrupt, stats.substituted), (1, 1), "{stats:?}");
    assert_eq!(renderer.corrupt_nodes().keys().copied().collect::<Vec<_>>(), [leaf]);
    assert!(renderer.corrupt_nodes()[&leaf].contains(&format!("node {leaf} data checksum")));
    // Its parent stands in: the bunny is whole, only coarser there.
    let s = ssim(&good, &image);
    let changed = good.pixels().zip(image.pixels()).filter(|(a, b)| a != b).count();
    assert!(s > 0.99 && changed > 100, "SSIM {s}, {changed} pixels changed, against the sound store");
    // Checked once: the next frame finds nothing new.
    let (_, stats) = renderer.render_image(&g.0, &broken, &nodes, &camera, size, &settings).expect("render");
    assert_eq!(stats.corrupt, 0, "{stats:?}");
    // A snapshot is an error that names the node.
    let e = kiosk_content::snapshot::snapshot(&g.0, &mut fresh(), &broken, &camera, size, 1.0, &settings)
        .expect_err("a corrupted store");
    assert!(e.to_string().contains(&format!("node {leaf} data checksum mismatch")), "{e}");
    let typed = e.downcast_ref::<kiosk_content::snapshot::CorruptView>().expect("a CorruptView");
    assert_eq!((typed.node, typed.count), (leaf, 1));
}

/// A 1024² texture of one-texel dark lines every 32 texels on a flat square (OBJ + MTL + PNG),
/// imported at `density` samples per texel.
fn line_texture_store(dir: &Path, density: f32) -> MappedStore {
    const SIDE: u32 = 1024;
    image::RgbImage::from_fn(SIDE, SIDE, |x, y| {
        if x % 32 == 0 || y % 32 == 0 { image::Rgb([20, 20, 60]) } else { image::Rgb([225, 220, 200]) }
    })
    .save(dir.join("lines.png"))
    .expect("png");
    std::fs::write(dir.join("square.mtl"), "newmtl lines\nKd 1 1 1\nmap_Kd lines.png\n").expect("mtl");
    let obj = "mtllib square.mtl\nusemtl lines\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
               vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    std::fs::write(dir.join("square.obj"), obj).expect("obj");
    let out = dir.join(format!("square-{density}.kstore"));
    let mut opts = kiosk_content::import::ImportOptions::default();
    opts.read.texel_density = density;
    kiosk_content::import::import(&dir.join("square.obj"), &out, &opts, &mut kiosk_content::import::quiet)
        .expect("import");
    kiosk_content::open_store(&out).expect("open")
}

/// The dark runs of a row of pixels (below halfway between the row's darkest and its median
/// luma): each run's width and darkest luma.
fn dark_runs(img: &image::RgbaImage, y: u32) -> Vec<(u32, f64)> {
    let luma: Vec<f64> = (0..img.width())
        .map(|x| {
            let p = img.get_pixel(x, y);
            0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2])
        })
        .collect();
    let mut sorted = luma.clone();
    sorted.sort_by(f64::total_cmp);
    let (dark, median) = (sorted[0], sorted[sorted.len() / 2]);
    let cut = (dark + median) / 2.0;
    let mut runs = Vec::new();
    let mut run: Option<(u32, f64)> = None;
    for &l in &luma {
        match (&mut run, l < cut) {
            (Some((w, m)), true) => {
                *w += 1;
                *m = m.min(l);
            }
            (None, true) => run = Some((1, l)),
            (Some(_), false) => runs.extend(run.take()),
            (None, false) => {}
        }
    }
    runs.extend(run);
    runs
}

#[test]
fn a_texture_keeps_its_one_texel_lines_in_the_render() {
    // Close up, at two pixels a texel: every one-texel line of the texture across the view is a
    // thin dark line in the image at one sample per texel. At one sample per 2 × 2 texels some
    // lines are lost between the samples (each sample takes the texture's colour where it lies).
    let dir = tempfile::tempdir().expect("temp dir");
    let size = (320u32, 240u32);
    let texel = 1.0 / 1024.0;
    let height = f64::from(size.1) / 2.0 * texel / 2.0 / (0.4f64).tan();
    let at = DVec3::new(0.5 + 7.0 * texel, 0.5 + 5.0 * texel, 0.0);
    let cam = Camera { eye: at + DVec3::Z * height, target: at, up: DVec3::Y, fov_y: 0.8 };
    let settings = RenderSettings::default();
    let lines = |density: f32| {
        let store = line_texture_store(dir.path(), density);
        let img = render(&store, &cam, size, &settings);
        [60, 120, 180].map(|y| dark_runs(&img, y))
    };
    // 160 texels across the view: five lines in each of three rows, each two pixels wide (three
    // where the row meets a line between pixel centres).
    for runs in lines(1.0) {
        assert_eq!(runs.len(), 5, "{runs:?}");
        assert!(runs.iter().all(|&(w, _)| (1..=3).contains(&w)), "one texel is two pixels: {runs:?}");
    }
    let coarse = lines(0.25);
    assert!(coarse.iter().any(|runs| runs.len() < 5), "lines lost at 0.25 samples per texel: {coarse:?}");
}
