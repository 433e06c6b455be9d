//! `cargo bench --bench scene [-- --points N[,N…]] [--quick] [--tradeoff-only | --textured-only]`: the scene's numbers
//! (docs/performance.md).
//! `-- --survey-only [--points N]`: the survey formats' readers alone, beside their decoders' bare
//! loops, on one generated cloud written as LAS, LAZ, E57 and PLY (left in `target/bench/` for
//! timing whole imports of each with `kiosk import`).
//! `-- --estimation-only [--points N]`: the estimation of normals and spacings alone on the
//! survey cloud's first N points (2 M), beside the same estimator on `kiddo`'s neighbour search.
//! `-- --textured-only`: the textured reader alone by samples per texel (the textured box), and
//! the Belweder exhibit's GLB read alone and imported whole.
//! `-- --texture-8k`: an 8192² texture on a 200 k-triangle mesh (OBJ + MTL + PNG) read alone and
//! imported at one sample per texel.
//! `-- --queries-only A.kstore B.kstore …`: tables 2 and 3 only, on existing stores side by side.
//! `-- --reference`: only the machine's reference figure (inflating the scan), printed with the
//! tables too: the same fixed work in every run, to tell the machine's slow stretches from its fast.
//!
//! Prints tables (and writes `target/bench/scene-tradeoff.svg`):
//! 1. build throughput and peak RSS: a real scan and synthetic statue-like clouds (10 M by
//!    default; `--points 10000000,50000000` for the 50 M figure), each built in a child process
//!    so that its peak RSS is its own;
//! 2. fine / coarse target: median µs per query, beside `kiddo`'s exact 8-NN on the same points
//!    in the same run;
//! 3. cut update: ms per frame for a moving camera at 1920×1080, 1 px;
//! 4. speed against accuracy: node size M, search depth and K against query time and error; the
//!    neighbours k and the spacing stride of the estimation against its time and error.

use anyhow::Context;
use glam::{DVec3, Vec3};
use kiosk_content::MappedStore;
use kiosk_core::scene::query::Level;
use kiosk_core::{Cut, CutParams, QueryParams, ViewParams};
use kiosk_import::formats;
use kiosk_import::source::{InputPoint, ReadOptions};
use kiosk_import::{BuildParams, Builder};
use plotters::prelude::*;
use rand::{Rng, SeedableRng};
use std::path::{Path, PathBuf};
use std::time::Instant;

type Rng64 = rand_pcg::Pcg64;

mod survey;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let Some(i) = args.iter().position(|a| a == "--child-build") {
        let stride = args.get(i + 4).map_or(Ok(BuildParams::default().spacing_stride), |s| s.parse())?;
        let normal = args.get(i + 5).map_or(Ok(BuildParams::default().normal_stride), |s| s.parse())?;
        return child_build(&args[i + 1], args[i + 2].parse()?, &args[i + 3], stride, normal);
    }
    if let Some(i) = args.iter().position(|a| a == "--queries-only") {
        // Side by side on existing stores (e.g. built by two versions of the builder).
        let stores = args[i + 1..]
            .iter()
            .map(|p| Ok((p.clone(), kiosk_content::open_store(Path::new(p))?)))
            .collect::<anyhow::Result<Vec<_>>>()?;
        query_header();
        for _round in 0..2 {
            for (name, store) in &stores {
                query_row(name, store);
            }
        }
        cut_header();
        for (name, store) in &stores {
            cut_row(name, store);
        }
        return Ok(());
    }
    if args.iter().any(|a| a == "--reference") {
        println!("reference: inflating the scan takes {:.0} ms (median of 5)", inflate_ms(&real_scan())?);
        return Ok(());
    }
    let quick = args.iter().any(|a| a == "--quick");
    if args.iter().any(|a| a == "--textured-only") {
        return textured_reader();
    }
    if args.iter().any(|a| a == "--texture-8k") {
        return texture_8k();
    }
    if args.iter().any(|a| a == "--survey-only") {
        let n = points_arg(&args, SURVEY_POINTS)?;
        let out_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench");
        std::fs::create_dir_all(&out_dir)?;
        return survey::readers(&out_dir, n);
    }
    if args.iter().any(|a| a == "--estimation-only") {
        let n = points_arg(&args, 2_000_000)?;
        return survey::estimation(n);
    }
    if args.iter().any(|a| a == "--normal-stride-only") {
        let n = points_arg(&args, 2_000_000)?;
        let out_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench");
        std::fs::create_dir_all(&out_dir)?;
        return survey::normal_tradeoff(n, &real_scan(), &out_dir);
    }
    if args.iter().any(|a| a == "--tradeoff-only") {
        let out_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench");
        std::fs::create_dir_all(&out_dir)?;
        return tradeoff(&real_scan(), &out_dir, quick);
    }
    let sizes: Vec<u64> = args
        .iter()
        .position(|a| a == "--points")
        .and_then(|i| args.get(i + 1))
        .map(|s| s.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_else(|| vec![if quick { 1_000_000 } else { 10_000_000 }]);
    let out_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench");
    std::fs::create_dir_all(&out_dir)?;
    let scan = real_scan();
    println!(
        "machine: {} cores; scan: {}; reference: inflating the scan takes {:.0} ms (median of 5)",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        scan.display(),
        inflate_ms(&scan)?
    );

    // 1. Build.
    println!("\n## Build (release, default M = {})", BuildParams::default().node_points);
    build_table_header("points");
    let scan_store = out_dir.join("scan.kstore");
    // A quarter of a second: its figure is the median of several builds (each row printed, so
    // that the machine's swings around it show), as the queries' figures are medians. Back to
    // back, and each after a pause as a single import runs: here the paused ones have often been
    // slower (fresh memory is dearer after a pause on this machine, though that is not the whole
    // cause), so both are measured.
    let scan_input = format!("scan:{}", scan.display());
    let scan_builds = (0..SCAN_BUILDS)
        .map(|_| child(&scan_input, 8192, &scan_store, None))
        .collect::<anyhow::Result<Vec<(u64, f64)>>>()?;
    let spaced_builds = (0..SPACED_SCAN_BUILDS)
        .map(|_| {
            std::thread::sleep(std::time::Duration::from_secs(SCAN_PAUSE_S));
            child(&scan_input, 8192, &scan_store, None)
        })
        .collect::<anyhow::Result<Vec<(u64, f64)>>>()?;
    let mut synthetic_stores = Vec::new();
    for &n in &sizes {
        let p = out_dir.join(format!("synthetic-{n}.kstore"));
        child(&format!("synthetic:{n}"), 8192, &p, None)?;
        synthetic_stores.push((n, p));
    }
    // The same first cloud with the exact spacing of every sample, side by side.
    if BuildParams::default().spacing_stride != 1 {
        let p = out_dir.join("synthetic-exact.kstore");
        child(&format!("synthetic:{}", sizes[0]), 8192, &p, Some(1))?;
        std::fs::remove_file(p)?;
    }

    println!();
    for (builds, how) in
        [(&scan_builds, "back to back".to_string()), (&spaced_builds, format!("{SCAN_PAUSE_S} s apart"))]
    {
        let points = builds[0].0 as f64;
        let secs: Vec<f64> = builds.iter().map(|b| b.1).collect();
        let (lo, hi, med) = (pct(secs.clone(), 0.0), pct(secs.clone(), 1.0), median(secs));
        println!(
            "{}, {how}: median of {} builds {med:.3} s = {:.2} M points/s (fastest {lo:.3} s, slowest {hi:.3} s)",
            scan.file_name().map_or("scan".into(), |n| n.to_string_lossy()),
            builds.len(),
            points / med / 1e6
        );
    }

    // 2. Queries.
    println!("\n## Fine and coarse targets on a 1 px cut (1920×1080), median µs per query");
    query_header();
    let mut models = vec![("scan".to_string(), kiosk_content::open_store(&scan_store)?)];
    for (n, p) in &synthetic_stores {
        models.push((format!("synthetic {} M", n / 1_000_000), kiosk_content::open_store(p)?));
    }
    for (name, store) in &models {
        query_row(name, store);
    }

    // 3. Cut update.
    println!("\n## Cut update, camera orbiting and zooming, 1920×1080, 1 px, budget 256 changes/frame");
    cut_header();
    for (name, store) in &models {
        cut_row(name, store);
    }

    // 4. Speed against accuracy.
    tradeoff(&scan, &out_dir, quick)?;
    Ok(())
}

/// The reader alone (no build): `path` read `runs` times into a sink that counts; its samples and
/// the median seconds.
fn reader_alone(path: &Path, opts: &ReadOptions, runs: usize) -> anyhow::Result<(u64, f64)> {
    let mut times = Vec::new();
    let mut n = 0u64;
    for _ in 0..runs {
        n = 0;
        let start = Instant::now();
        let mut count = |_: InputPoint| -> Result<(), std::convert::Infallible> {
            n += 1;
            Ok(())
        };
        let report = formats::read_file(path, opts, &mut count)?;
        times.push(start.elapsed().as_secs_f64());
        anyhow::ensure!(report.points == n, "{} points reported, {n} received", report.points);
    }
    Ok((n, median(times)))
}

/// Textured meshes: the reader alone by samples per texel on the textured box
/// (`tests/data/formats`), then a real textured scan, the Belweder exhibit's GLB, and the same
/// GLB Draco- and meshopt-compressed by real exporters (`tests/data/formats`), each read alone
/// and imported whole (3 builds, each in a child process) at the default density.
fn textured_reader() -> anyhow::Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("tests/data/formats/box-textured/BoxTextured.glb");
    println!("\n## Textured reader alone ({}, median of 3)", path.display());
    println!("| samples per texel | samples | seconds | M samples/s |");
    println!("|---|---|---|---|");
    for density in [0.25f32, 1.0, 4.0, 16.0] {
        let opts = ReadOptions { texel_density: density, ..Default::default() };
        let (n, s) = reader_alone(&path, &opts, 3)?;
        println!("| {density} | {n} | {s:.3} | {:.1} |", n as f64 / s / 1e6);
    }
    let out = root.join("target/bench/belweder.kstore");
    std::fs::create_dir_all(out.parent().unwrap_or(Path::new(".")))?;
    for glb in [
        root.join("content/belweder/belweder-ot-1782.glb"),
        root.join("tests/data/formats/belweder-draco.glb"),
        root.join("tests/data/formats/belweder-meshopt.glb"),
    ] {
        let (n, s) = reader_alone(&glb, &ReadOptions::default(), 3)?;
        println!("\n## A textured scan: {}", glb.display());
        println!("reader alone, median of 3: {n} samples in {s:.3} s, {:.2} M samples/s", n as f64 / s / 1e6);
        build_table_header("samples");
        for _ in 0..3 {
            child(&format!("scan:{}", glb.display()), BuildParams::default().node_points, &out, None)?;
        }
    }
    Ok(())
}

/// An 8 k texture on a 200 k-triangle mesh: a 317 × 317 grid of vertices (199 712 triangles)
/// over 1 m², gently waved, its texture coordinates spanning an 8192² image of 4-texel checks
/// crossed by one-texel lines every 64 texels; written as OBJ + MTL + PNG (before the clock, kept
/// in `target/bench/texture-8k/`) and imported in a child process at the default density, one
/// sample per texel. The store is left there to be looked at (`kiosk snapshot`).
fn texture_8k() -> anyhow::Result<()> {
    use std::io::Write;
    const SIDE: u32 = 8192;
    const GRID: usize = 317;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench/texture-8k");
    std::fs::create_dir_all(&dir)?;
    let png = dir.join("checks.png");
    if !png.exists() {
        image::RgbImage::from_fn(SIDE, SIDE, |x, y| {
            if x % 64 == 0 || y % 64 == 0 {
                image::Rgb([20, 20, 60])
            } else if (x / 4 + y / 4) % 2 == 0 {
                image::Rgb([230, 200, 120])
            } else {
                image::Rgb([150, 60, 40])
            }
        })
        .save(&png)?;
    }
    std::fs::write(dir.join("grid.mtl"), "newmtl checks\nKd 1 1 1\nmap_Kd checks.png\n")?;
    let obj = dir.join("grid.obj");
    let mut w = std::io::BufWriter::new(std::fs::File::create(&obj)?);
    writeln!(w, "mtllib grid.mtl\nusemtl checks")?;
    let step = 1.0 / (GRID - 1) as f64;
    for j in 0..GRID {
        for i in 0..GRID {
            let (x, y) = (i as f64 * step, j as f64 * step);
            writeln!(w, "v {x:.6} {y:.6} {:.6}", 0.02 * (6.0 * x).sin() * (4.0 * y).cos())?;
        }
    }
    for j in 0..GRID {
        for i in 0..GRID {
            // Texture coordinates with v up, as OBJ has them.
            writeln!(w, "vt {:.6} {:.6}", i as f64 * step, j as f64 * step)?;
        }
    }
    let at = |i: usize, j: usize| j * GRID + i + 1;
    for j in 0..GRID - 1 {
        for i in 0..GRID - 1 {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            writeln!(w, "f {a}/{a} {b}/{b} {c}/{c}\nf {a}/{a} {c}/{c} {d}/{d}")?;
        }
    }
    w.into_inner().map_err(std::io::IntoInnerError::into_error)?.sync_all()?;
    println!("\n## An 8192² texture on {} triangles, one sample per texel", 2 * (GRID - 1) * (GRID - 1));
    let (n, s) = reader_alone(&obj, &ReadOptions::default(), 1)?;
    println!("reader alone: {n} samples in {s:.2} s, {:.2} M samples/s", n as f64 / s / 1e6);
    build_table_header("samples");
    child(
        &format!("scan:{}", obj.display()),
        BuildParams::default().node_points,
        &dir.join("grid.kstore"),
        None,
    )?;
    Ok(())
}

/// The number after `--points`, or `default`.
fn points_arg(args: &[String], default: u64) -> anyhow::Result<u64> {
    let given = args.iter().position(|a| a == "--points").and_then(|i| args.get(i + 1));
    Ok(given.map_or(Ok(default), |s| s.parse())?)
}

/// Points of the survey cloud unless `--points` says otherwise.
const SURVEY_POINTS: u64 = 5_000_000;

/// How long this machine takes, now, to inflate the scan's gzip stream (one thread): the same
/// fixed work in every run, printed beside the tables so that runs in the machine's slow and fast
/// stretches can be told apart.
fn inflate_ms(scan: &Path) -> anyhow::Result<f64> {
    let mut ms: Vec<f64> = (0..5)
        .map(|_| {
            let t = Instant::now();
            std::io::copy(&mut formats::gzip::open(scan)?, &mut std::io::sink())?;
            Ok(t.elapsed().as_secs_f64() * 1e3)
        })
        .collect::<anyhow::Result<_>>()?;
    ms.sort_by(f64::total_cmp);
    Ok(ms[2])
}

fn real_scan() -> PathBuf {
    kiosk_testkit::synthetic::dragon_scan()
}

/// Builds of the real scan in a run, back to back and then each after a pause: each row is
/// printed, the figures are their medians.
const SCAN_BUILDS: usize = 9;
const SPACED_SCAN_BUILDS: usize = 5;
const SCAN_PAUSE_S: u64 = 6;

/// Runs one build in a child process, prints its row (with the default spacing stride unless
/// one is given) and returns its input points and seconds.
fn child(input: &str, m: usize, out: &Path, spacing_stride: Option<usize>) -> anyhow::Result<(u64, f64)> {
    let exe = std::env::current_exe()?;
    let mut args = vec!["--child-build".to_string(), input.into(), m.to_string(), out.display().to_string()];
    args.extend(spacing_stride.map(|s| s.to_string()));
    let o = std::process::Command::new(exe).args(args).output()?;
    if !o.status.success() {
        anyhow::bail!("build of {input} failed: {}", String::from_utf8_lossy(&o.stderr));
    }
    let row = String::from_utf8_lossy(&o.stdout);
    print!("{row}");
    // The row is `| label | points | seconds | …`.
    let cell = |i: usize| row.split('|').nth(i).map(str::trim).unwrap_or_default();
    let points = cell(2).parse().with_context(|| format!("points of the row {row:?}"))?;
    let secs = cell(3).parse().with_context(|| format!("seconds of the row {row:?}"))?;
    Ok((points, secs))
}

/// The header of a table of builds ([`child`]'s rows), counting `what` (points or samples).
fn build_table_header(what: &str) {
    println!(
        "| input | {what} | seconds | {what}/s | peak RSS MB | nodes | levels | store MB | \
         s: read · distribute · merge · order · estimate · nodes · finish |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
}

fn peak_rss_mb() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// A statue-like synthetic surface: a body of several displaced ellipsoids (torso, head, arms,
/// legs) with fine "carvings" (high-frequency relief), sampled uniformly at random.
pub fn synthetic_point(rng: &mut Rng64) -> InputPoint {
    // (centre, radii) in metres: a 2 m figure.
    const PARTS: [([f64; 3], [f64; 3]); 7] = [
        ([0.0, 1.2, 0.0], [0.22, 0.35, 0.15]),
        ([0.0, 1.72, 0.0], [0.11, 0.14, 0.12]),
        ([-0.33, 1.25, 0.0], [0.06, 0.3, 0.06]),
        ([0.33, 1.25, 0.0], [0.06, 0.3, 0.06]),
        ([-0.11, 0.45, 0.0], [0.08, 0.45, 0.08]),
        ([0.11, 0.45, 0.0], [0.08, 0.45, 0.08]),
        ([0.0, 0.02, 0.0], [0.4, 0.03, 0.3]),
    ];
    let part = PARTS[rng.random_range(0..PARTS.len())];
    let z: f64 = rng.random_range(-1.0..1.0);
    let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let s = (1.0 - z * z).sqrt();
    let dir = DVec3::new(s * phi.cos(), z, s * phi.sin());
    let relief = 1.0 + 0.01 * (60.0 * phi).sin() * (80.0 * z).sin() + 0.002 * (400.0 * phi).sin();
    let r = DVec3::from_array(part.1);
    let pos = DVec3::from_array(part.0) + dir * r * relief;
    let normal = (dir / r).normalize_or_zero().as_vec3();
    InputPoint { pos, normal, color: [0; 4], radius: 0.0, spacing: 0.0 }
}

/// Writes `n` samples of [`synthetic_point`] to a binary little-endian PLY of float positions and
/// normals (how scanners deliver big clouds), so that the timed build reads a file as
/// `kiosk import` does instead of timing the generator.
fn write_synthetic_ply(n: u64, path: &Path) -> anyhow::Result<()> {
    use std::io::Write;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(path)?);
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment IsoKiosk benchmark: synthetic statue\n\
         element vertex {n}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nend_header\n"
    )?;
    let mut rng = Rng64::seed_from_u64(42);
    for _ in 0..n {
        let p = synthetic_point(&mut rng);
        for v in p.pos.as_vec3().to_array().into_iter().chain(p.normal.to_array()) {
            w.write_all(&v.to_le_bytes())?;
        }
    }
    // On disk before the clock starts, as a scan to import is: otherwise the build would also
    // pay for writing back this file's pages (1.2 GB at 50 M), which compete with its own.
    w.into_inner().map_err(std::io::IntoInnerError::into_error)?.sync_all()?;
    Ok(())
}

fn child_build(
    input: &str,
    m: usize,
    out: &str,
    spacing_stride: usize,
    normal_stride: usize,
) -> anyhow::Result<()> {
    let out = Path::new(out);
    let params = BuildParams { node_points: m, spacing_stride, normal_stride, ..BuildParams::default() };
    let tmp = out.parent().unwrap_or(Path::new("."));
    let (path, label, generated) = match input.strip_prefix("synthetic:") {
        Some(n) => {
            let n: u64 = n.parse()?;
            let path = tmp.join(format!("synthetic-{n}.ply"));
            write_synthetic_ply(n, &path)?;
            (path, format!("synthetic statue {} M", n / 1_000_000), true)
        }
        None => {
            let path = PathBuf::from(input.trim_start_matches("scan:"));
            let label = path.file_name().map_or("scan".into(), |n| n.to_string_lossy().into_owned());
            (path, label, false)
        }
    };
    let d = BuildParams::default();
    let label = [
        ("spacing stride", spacing_stride, d.spacing_stride),
        ("normal stride", normal_stride, d.normal_stride),
    ]
    .into_iter()
    .filter(|(_, value, default)| value != default)
    .fold(label, |label, (name, value, _)| format!("{label}, {name} {value}"));
    // Before the clock: replacing a store deletes the old one in the final rename, which on this
    // `discard`-mounted disk takes ~20 ms for the dragon's 24 MB; deleting is not building.
    if let Err(e) = std::fs::remove_file(out)
        && e.kind() != std::io::ErrorKind::NotFound
    {
        return Err(e.into());
    }
    let start = Instant::now();
    let mut b = Builder::new(params, tmp)?;
    formats::read_file(&path, &ReadOptions::default(), &mut b)
        .with_context(|| format!("build of {label}"))?;
    let read = start.elapsed().as_secs_f64();
    let s = b.finish(out, &mut |_| {})?;
    let secs = start.elapsed().as_secs_f64();
    // After the clock: deleting a file is not part of importing it.
    if generated {
        std::fs::remove_file(&path)?;
    }
    let t = s.timings;
    println!(
        "| {label} | {} | {secs:.3} | {:.0} | {:.0} | {} | {} | {:.0} | {read:.2} · {:.2} · {:.2} · {:.2} · {:.2} · {:.2} · {:.3} |",
        s.input_points,
        s.input_points as f64 / secs,
        peak_rss_mb(),
        s.nodes,
        s.levels,
        s.bytes as f64 / 1e6,
        t.distribute.as_secs_f64(),
        t.merge.as_secs_f64(),
        t.order.as_secs_f64(),
        t.estimate.as_secs_f64(),
        t.nodes.as_secs_f64(),
        t.finish.as_secs_f64(),
    );
    Ok(())
}

fn view_at(store: &MappedStore, eye: DVec3, target: DVec3) -> ViewParams {
    let diag = store.bbox().diagonal();
    ViewParams::look_at(store.origin(), eye, target, DVec3::Y, 0.8, (1920, 1080), (diag * 1e-4, diag * 10.0))
        .expect("valid view")
}

fn mid_view(store: &MappedStore) -> (ViewParams, DVec3, f64) {
    let c = store.to_model(store.bbox().center());
    let diag = f64::from(store.bbox().diagonal());
    (view_at(store, c + DVec3::new(0.3, 0.1, 0.5) * diag, c), c, diag)
}

fn converged_cut(store: &MappedStore, v: &ViewParams, tol: f32) -> Cut {
    let mut cut = Cut::root(store);
    cut.update(store, v, &CutParams { tolerance_px: tol, max_changes: usize::MAX, ..CutParams::default() });
    cut
}

fn near_surface_queries(store: &MappedStore, cut: &Cut, n: usize, seed: u64) -> Vec<DVec3> {
    let mut rng = Rng64::seed_from_u64(seed);
    let diag = store.bbox().diagonal();
    store
        .sample_cut(cut, n, &mut rng.clone())
        .into_iter()
        .map(|p| {
            let d = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            store.to_model(p + d * 0.02 * diag)
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn pct(mut v: Vec<f64>, p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p) as usize]
}

/// Reads every node of `cut` once, as drawing it does (the renderer uploads the cut's splats),
/// so that queries are timed on a model in memory, not on its first reads from disk (a store
/// just built is not in the page cache: it is written around it).
fn read_cut(store: &MappedStore, cut: &Cut) {
    for &n in cut.nodes() {
        store.verify_node(n).expect("a store just built is intact");
    }
}

/// Median µs of `f` over the queries (each timed in a batch of 10 to beat timer resolution).
fn time_each(qs: &[DVec3], mut f: impl FnMut(DVec3)) -> f64 {
    let mut t = Vec::new();
    for chunk in qs.chunks(10) {
        let s = Instant::now();
        for &q in chunk {
            f(q);
        }
        t.push(s.elapsed().as_secs_f64() * 1e6 / chunk.len() as f64);
    }
    median(t)
}

fn query_header() {
    println!("| model | cut points | fine K=8 µs | coarse K=16 µs | kiddo exact 8-NN µs | fine / kiddo |");
    println!("|---|---|---|---|---|---|");
}

fn query_row(name: &str, store: &MappedStore) {
    let (v, _, _) = mid_view(store);
    let cut = converged_cut(store, &v, 1.0);
    let qs = near_surface_queries(store, &cut, 20_000, 1);
    read_cut(store, &cut);
    let params = QueryParams::default();
    let fine = time_each(&qs, |q| {
        std::hint::black_box(store.fine_target(&cut, q, &params));
    });
    let coarse = time_each(&qs, |q| {
        std::hint::black_box(store.coarse_target(&cut, q, &params));
    });
    let pts: Vec<[f32; 3]> =
        cut.nodes().iter().flat_map(|&n| store.splats(n).iter().map(|s| s.pos)).collect();
    let kd: kiddo::immutable::float::kdtree::ImmutableKdTree<f32, u32, 3, 32> =
        kiddo::immutable::float::kdtree::ImmutableKdTree::new_from_slice(&pts);
    let kiddo_us = time_each(&qs, |q| {
        let l = store.to_local(q).to_array();
        std::hint::black_box(
            kd.nearest_n::<kiddo::SquaredEuclidean>(&l, std::num::NonZero::new(8).expect("8")),
        );
    });
    println!("| {name} | {} | {fine:.2} | {coarse:.2} | {kiddo_us:.2} | {:.2} |", pts.len(), fine / kiddo_us);
}

fn cut_header() {
    println!("| model | frames | median ms | p95 ms | max ms (frame) | median nodes | median points |");
    println!("|---|---|---|---|---|---|---|");
}

fn cut_row(name: &str, store: &MappedStore) {
    let c = store.to_model(store.bbox().center());
    let diag = f64::from(store.bbox().diagonal());
    let params = CutParams::default();
    let mut cut = Cut::root(store);
    let (mut ms, mut nodes, mut points) = (Vec::new(), Vec::new(), Vec::new());
    let frames = 600;
    for f in 0..frames {
        let a = f as f64 * 0.01;
        let dist = 0.25 + 0.6 * (0.5 + 0.5 * (a * 1.3).cos());
        let eye = c + DVec3::new(a.cos(), 0.3 * (a * 0.7).sin(), a.sin()) * diag * dist;
        let v = view_at(store, eye, c);
        let s = Instant::now();
        let st = cut.update(store, &v, &params);
        ms.push(s.elapsed().as_secs_f64() * 1e3);
        nodes.push(st.nodes as f64);
        points.push(st.points as f64);
    }
    // Which frame took longest: the first (a cold memory map) or any (the machine's scheduler).
    let (slowest, max) =
        ms.iter().copied().enumerate().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap_or_default();
    println!(
        "| {name} | {frames} | {:.3} | {:.3} | {max:.3} ({slowest}) | {:.0} | {:.0} |",
        median(ms.clone()),
        pct(ms, 0.95),
        median(nodes),
        median(points)
    );
}

/// Error of the fine target: distance to the exact nearest full-resolution sample, in units of
/// the local sample spacing.
fn fine_error(store: &MappedStore, cut: &Cut, qs: &[DVec3], params: &QueryParams) -> (f64, f64) {
    let errs: Vec<f64> = qs
        .iter()
        .map(|&q| {
            let f = store.fine_target(cut, q, params).expect("finite");
            let (_, node, _) = store.knn_local(Level::Full, store.to_local(q), 1, u32::MAX)[0];
            let (_, exact) = store.nearest_sample(q).expect("finite");
            (f.point - exact).length() / f64::from(store.node(node).spacing)
        })
        .collect();
    (median(errs.clone()), pct(errs, 0.95))
}

fn tradeoff(scan: &Path, out_dir: &Path, quick: bool) -> anyhow::Result<()> {
    let (pts, _) = formats::read_all(scan, &ReadOptions::default())?;
    let n_queries = if quick { 1000 } else { 5000 };
    println!("\n## Speed against accuracy: node size M ({}; full-resolution cut)", scan.display());
    println!(
        "| M | build s | nodes | fine µs | error median (spacings) | error p95 | cut update ms (orbit) |"
    );
    println!("|---|---|---|---|---|---|---|");
    let mut series_m = Vec::new();
    let dir = tempfile::tempdir()?;
    for m in [2048usize, 4096, 8192, 16384] {
        let out = dir.path().join(format!("m{m}.kstore"));
        let t = Instant::now();
        let mut b = Builder::new(BuildParams { node_points: m, ..BuildParams::default() }, dir.path())?;
        for p in &pts {
            b.push(*p)?;
        }
        let s = b.finish(&out, &mut |_| {})?;
        let build_s = t.elapsed().as_secs_f64();
        let store = kiosk_content::open_store(&out)?;
        let cut = Cut::leaves(&store);
        let qs = near_surface_queries(&store, &cut, n_queries, 2);
        read_cut(&store, &cut);
        let params = QueryParams::default();
        let us = time_each(&qs, |q| {
            std::hint::black_box(store.fine_target(&cut, q, &params));
        });
        let (e50, e95) = fine_error(&store, &cut, &qs, &params);
        let mut cut_ms = Vec::new();
        let (c, diag) = (store.to_model(store.bbox().center()), f64::from(store.bbox().diagonal()));
        let mut moving = Cut::root(&store);
        for f in 0..120 {
            let a = f as f64 * 0.05;
            let v = view_at(&store, c + DVec3::new(a.cos(), 0.2, a.sin()) * diag * 0.6, c);
            let t = Instant::now();
            moving.update(&store, &v, &CutParams::default());
            cut_ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        println!(
            "| {m} | {build_s:.2} | {} | {us:.2} | {e50:.3} | {e95:.3} | {:.3} |",
            s.nodes,
            median(cut_ms)
        );
        series_m.push((format!("M={m}"), us, e95));
    }

    knn_tradeoff(&pts, dir.path())?;
    spacing_tradeoff(&pts, quick);

    println!("\n## Speed against accuracy: search depth and K of the fine target (M = 8192)");
    println!("| K | depth | µs per query | error median (spacings) | error p95 |");
    println!("|---|---|---|---|---|");
    let out = dir.path().join("m8192.kstore");
    let store = kiosk_content::open_store(&out)?;
    let cut = Cut::leaves(&store);
    let qs = near_surface_queries(&store, &cut, n_queries, 3);
    let mut series_k: Vec<(u32, Vec<(f64, f64)>)> = Vec::new();
    for k in [1usize, 4, 8, 16] {
        let mut line = Vec::new();
        for depth in [2u32, 4, 6, 8, u32::MAX] {
            let params = QueryParams { fine_k: k, fine_depth: depth, ..QueryParams::default() };
            let us = time_each(&qs, |q| {
                std::hint::black_box(store.fine_target(&cut, q, &params));
            });
            let (e50, e95) = fine_error(&store, &cut, &qs, &params);
            let d = if depth == u32::MAX { "full".to_string() } else { depth.to_string() };
            println!("| {k} | {d} | {us:.2} | {e50:.3} | {e95:.3} |");
            line.push((us, e95));
        }
        series_k.push((k as u32, line));
    }
    let svg = out_dir.join("scene-tradeoff.svg");
    plot(&svg, &series_m, &series_k)?;
    println!("\nplot: {}", svg.display());
    Ok(())
}

/// The neighbours k of normal and spacing estimation against its time and the normals' error:
/// the scan is built without its normals (estimated by PCA) and every full-resolution sample's
/// normal is compared with the area-weighted normal of the mesh at that vertex (unoriented: the
/// renderer lights both sides).
fn knn_tradeoff(pts: &[InputPoint], dir: &Path) -> anyhow::Result<()> {
    println!(
        "\n## Speed against accuracy: neighbours k of the estimation (scan without its normals, M = 8192)"
    );
    println!(
        "| k | estimate s | build s | normal error median ° | p90 ° | p99 ° | median radius / radius at k = 12 |"
    );
    println!("|---|---|---|---|---|---|---|");
    let mut reference: Option<std::collections::HashMap<[u32; 3], Vec3>> = None;
    let mut radius_12 = f64::NAN;
    let mut rows = Vec::new();
    for k in [6usize, 8, 12, 16, 24] {
        let out = dir.join(format!("k{k}.kstore"));
        let t = Instant::now();
        let mut b = Builder::new(BuildParams { knn: k, ..BuildParams::default() }, dir)?;
        for p in pts {
            b.push(InputPoint { normal: Vec3::ZERO, spacing: 0.0, ..*p })?;
        }
        let s = b.finish(&out, &mut |_| {})?;
        let build_s = t.elapsed().as_secs_f64();
        let store = kiosk_content::open_store(&out)?;
        // Leaf samples are the input positions in local f32 coordinates: find each one's vertex.
        let reference = reference.get_or_insert_with(|| {
            pts.iter().map(|p| (store.to_local(p.pos).to_array().map(f32::to_bits), p.normal)).collect()
        });
        let (mut errs, mut radii, mut unmatched) = (Vec::new(), Vec::new(), 0usize);
        for id in 0..store.nodes().len() as u32 {
            if !store.node(id).is_leaf() {
                continue;
            }
            for sp in store.splats(id) {
                match reference.get(&sp.position().to_array().map(f32::to_bits)) {
                    Some(n) if *n != Vec3::ZERO => {
                        errs.push(f64::from(sp.normal().dot(*n).abs().min(1.0).acos().to_degrees()))
                    }
                    _ => unmatched += 1,
                }
                radii.push(f64::from(sp.radius));
            }
        }
        if unmatched > 0 {
            println!("(k = {k}: {unmatched} samples without a mesh normal)");
        }
        let r = median(radii);
        if k == 12 {
            radius_12 = r;
        }
        rows.push((
            k,
            s.timings.estimate.as_secs_f64(),
            build_s,
            median(errs.clone()),
            pct(errs.clone(), 0.9),
            pct(errs, 0.99),
            r,
        ));
    }
    for (k, est, build_s, e50, e90, e99, r) in rows {
        println!("| {k} | {est:.2} | {build_s:.2} | {e50:.2} | {e90:.2} | {e99:.2} | {:.3} |", r / radius_12);
    }
    Ok(())
}

/// The spacing stride of the estimation (`BuildParams::spacing_stride`) against its time and the
/// spacings' error, on the scan's positions and on a synthetic statue: the error against the
/// exact search of every point (stride 1), and against a smoother reference, the exact spacing
/// from 32 neighbours, beside which the exact 12-neighbour spacing has its own error.
fn spacing_tradeoff(scan: &[InputPoint], quick: bool) {
    use kiosk_import::estimate;
    println!(
        "\n## Speed against accuracy: spacing stride (k = 12, spacings only, as for scans with normals)"
    );
    println!(
        "| input | stride | estimate s | relative error vs stride 1: median | p95 | vs 32-NN reference: median | p95 | share below -20 % |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let mut faces_note = None;
    let mut rng = Rng64::seed_from_u64(7);
    let n = if quick { 200_000 } else { 2_000_000 };
    let synthetic: Vec<DVec3> = (0..n).map(|_| synthetic_point(&mut rng).pos).collect();
    let inputs = [
        ("scan", scan.iter().map(|p| p.pos).collect::<Vec<_>>()),
        (if quick { "synthetic 0.2 M" } else { "synthetic 2 M" }, synthetic),
    ];
    for (name, pos) in inputs {
        let c = pos.iter().fold(DVec3::ZERO, |a, p| a + *p) / pos.len() as f64;
        let local = |p: DVec3| (p - c).as_vec3();
        // The spacings a mesh brings from its faces (what the builder uses for the scan), by
        // position, duplicates merged as the builder merges them (their areas added).
        let mut from_faces = std::collections::HashMap::<[u32; 3], f32>::new();
        if name == "scan" {
            for p in scan.iter().filter(|p| p.spacing > 0.0) {
                *from_faces.entry(local(p.pos).to_array().map(f32::to_bits)).or_default() +=
                    p.spacing.powi(2);
            }
        }
        let mut pts: Vec<Vec3> = pos.iter().map(|p| local(*p)).collect();
        pts.sort_by(|a, b| a.to_array().map(f32::to_bits).cmp(&b.to_array().map(f32::to_bits)));
        pts.dedup();
        let boxes = estimate::sorted_tree(&mut pts);
        let spacings = |k: usize, stride: usize| {
            let t = Instant::now();
            let e = estimate::estimate(
                &pts,
                &boxes,
                k,
                estimate::Strides { spacing: stride, ..estimate::Strides::EXACT },
                &|_| false,
                &|_| true,
            )
            .expect("distinct points");
            (t.elapsed().as_secs_f64(), e.into_iter().map(|e| f64::from(e.spacing)).collect::<Vec<_>>())
        };
        let (_, reference) = spacings(32, 1);
        let (_, exact) = spacings(12, 1);
        let row = |stride: &str, seconds: &str, h: &[f64]| {
            let rel = |base: &[f64]| -> Vec<f64> { h.iter().zip(base).map(|(a, b)| a / b - 1.0).collect() };
            let (vs_exact, vs_ref) = (rel(&exact), rel(&reference));
            let abs = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x.abs()).collect() };
            let below = vs_ref.iter().filter(|&&x| x < -0.2).count() as f64 / vs_ref.len() as f64;
            println!(
                "| {name} | {stride} | {seconds} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} % |",
                median(abs(&vs_exact)),
                pct(abs(&vs_exact), 0.95),
                median(abs(&vs_ref)),
                pct(abs(&vs_ref), 0.95),
                below * 100.0
            );
        };
        for stride in [1usize, 2, 4, 8, 16] {
            // The fastest of two runs: the machine is shared.
            let (t1, h) = spacings(12, stride);
            let (t2, _) = spacings(12, stride);
            row(&stride.to_string(), &format!("{:.3}", t1.min(t2)), &h);
        }
        if !from_faces.is_empty() {
            // Every vertex in a triangle brings its spacing; the others take the estimate's.
            let h: Vec<f64> = pts
                .iter()
                .zip(&exact)
                .map(|(p, &e)| {
                    from_faces.get(&p.to_array().map(f32::to_bits)).map_or(e, |&a| f64::from(a.sqrt()))
                })
                .collect();
            row("faces", "while reading", &h);
            // Per vertex the faces and the neighbours differ; over the surface they should agree.
            let area = |h: &[f64]| h.iter().map(|x| x * x).sum::<f64>();
            faces_note = Some(format!(
                "(scan, faces: the vertices' areas add up to {:.3} times what the exact 12-NN spacings give)",
                area(&h) / area(&exact)
            ));
        }
    }
    if let Some(note) = faces_note {
        println!("{note}");
    }
}

fn plot(path: &Path, m: &[(String, f64, f64)], k: &[(u32, Vec<(f64, f64)>)]) -> anyhow::Result<()> {
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let xmax =
        k.iter().flat_map(|(_, l)| l.iter().map(|p| p.0)).chain(m.iter().map(|p| p.1)).fold(0.0, f64::max)
            * 1.1;
    let ymax =
        k.iter().flat_map(|(_, l)| l.iter().map(|p| p.1)).chain(m.iter().map(|p| p.2)).fold(0.0, f64::max)
            * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption("Fine target: speed against accuracy (dragon, full-resolution cut)", ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..xmax, 0.0..ymax)?;
    chart
        .configure_mesh()
        .x_desc("median µs per query")
        .y_desc("p95 error (sample spacings from the exact nearest sample)")
        .draw()?;
    let colors = [RED, BLUE, GREEN, MAGENTA];
    for (i, (kk, line)) in k.iter().enumerate() {
        let c = colors[i % colors.len()];
        chart
            .draw_series(LineSeries::new(line.iter().copied(), c.stroke_width(2)))?
            .label(format!("K={kk}, depth 2…full"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
        chart.draw_series(line.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
    }
    chart
        .draw_series(m.iter().map(|(_, x, y)| TriangleMarker::new((*x, *y), 7, BLACK.filled())))?
        .label("node size M = 2k…16k (K=8, full depth)")
        .legend(|(x, y)| TriangleMarker::new((x + 10, y), 6, BLACK.filled()));
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw()?;
    root.present()?;
    Ok(())
}
