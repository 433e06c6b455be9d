//! The survey formats' readers alone (`--survey-only`). One generated cloud, a noisy sphere of
//! 10 m radius in georeferenced coordinates (offsets of 5·10⁵ and 4·10⁶ m, quantised to the
//! millimetre, 8-bit colours), is written as LAS 1.2 (point format 3, 16-bit RGB), LAZ, E57
//! (double coordinates, 8-bit colours) and binary PLY (double positions, uchar colours): every
//! format holds the same points, so their imports do the same work and make the same store.
//! Each reader (into a sink that only counts) is timed beside its decoder crate's own bare loop
//! over the same file: `las`'s `fill_points` (LAS records copied, LAZ decompressed) and `e57`'s
//! point iterator with the same conversions as the importer.

use glam::DVec3;
use kiosk_import::formats;
use kiosk_import::source::{InputPoint, ReadOptions};
use rand::{Rng, SeedableRng};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The files' transforms: 1 mm, and the offsets of a projected survey.
const SCALE: f64 = 0.001;
const OFFSET: [f64; 3] = [5.0e5, 4.0e6, 0.0];

/// One point of the cloud: its integer coordinates (millimetres from [`OFFSET`]) and colour.
struct Point {
    ints: [i32; 3],
    rgb: [u8; 3],
}

impl Point {
    /// Its coordinates as the `las` crate computes them from the integers (so that every format
    /// holds the same `f64`s).
    fn pos(&self) -> [f64; 3] {
        std::array::from_fn(|k| las::Transform { scale: SCALE, offset: OFFSET[k] }.direct(self.ints[k]))
    }
}

/// `n` points on a sphere of radius 10 m with ±2 mm of noise, uniformly at random (seeded),
/// coloured by direction.
fn cloud(n: u64) -> Vec<Point> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    let centre = DVec3::new(20.0, 20.0, 50.0);
    (0..n)
        .map(|_| {
            let z: f64 = rng.random_range(-1.0..1.0);
            let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let s = (1.0 - z * z).sqrt();
            let dir = DVec3::new(s * phi.cos(), s * phi.sin(), z);
            let local = centre + dir * (10.0 + rng.random_range(-0.002..0.002));
            let ints = (local / SCALE).round().to_array().map(|v| v as i32);
            let rgb = (dir * 127.0 + 128.0).to_array().map(|v| v as u8);
            Point { ints, rgb }
        })
        .collect()
}

/// The cloud's files (generated once for each size, then reused).
struct Files {
    las: PathBuf,
    laz: PathBuf,
    e57: PathBuf,
    ply: PathBuf,
}

fn files(dir: &Path, n: u64) -> anyhow::Result<Files> {
    let name = |ext: &str| dir.join(format!("survey-{n}.{ext}"));
    let f = Files { las: name("las"), laz: name("laz"), e57: name("e57"), ply: name("ply") };
    if [&f.las, &f.laz, &f.e57, &f.ply].iter().all(|p| p.exists()) {
        return Ok(f);
    }
    println!("writing the survey cloud of {n} points to {}", dir.display());
    let pts = cloud(n);
    // Each file is written under a temporary name and renamed when complete.
    let done = |tmp: &Path, path: &Path| std::fs::rename(tmp, path);
    for path in [&f.las, &f.laz] {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("las");
        let tmp = dir.join(format!("survey-{n}.tmp.{ext}"));
        write_las(&pts, &tmp)?;
        done(&tmp, path)?;
    }
    let tmp = dir.join(format!("survey-{n}.tmp.e57"));
    write_e57(&pts, &tmp)?;
    done(&tmp, &f.e57)?;
    let tmp = dir.join(format!("survey-{n}.tmp.ply"));
    write_ply(&pts, &tmp)?;
    done(&tmp, &f.ply)?;
    Ok(f)
}

/// LAS 1.2, point format 3 (GPS time and 16-bit RGB); compressed when the name ends in `.laz`.
fn write_las(pts: &[Point], path: &Path) -> anyhow::Result<()> {
    let mut header = las::Builder::from((1, 2));
    header.point_format = las::point::Format::new(3)?;
    header.transforms = las::Vector {
        x: las::Transform { scale: SCALE, offset: OFFSET[0] },
        y: las::Transform { scale: SCALE, offset: OFFSET[1] },
        z: las::Transform { scale: SCALE, offset: OFFSET[2] },
    };
    let mut w = las::Writer::from_path(path, header.into_header()?)?;
    for (i, p) in pts.iter().enumerate() {
        let [x, y, z] = p.pos();
        let [r, g, b] = p.rgb.map(|c| u16::from(c) * 257);
        w.write_point(las::Point {
            x,
            y,
            z,
            intensity: 1000,
            gps_time: Some(i as f64 * 1e-5),
            color: Some(las::Color::new(r, g, b)),
            ..Default::default()
        })?;
    }
    w.close()?;
    Ok(())
}

/// One scan with double Cartesian coordinates and 8-bit colours.
fn write_e57(pts: &[Point], path: &Path) -> anyhow::Result<()> {
    use e57::{Record, RecordValue};
    let mut w = e57::E57Writer::from_file(path, "survey-cloud")?;
    let prototype = vec![
        Record::CARTESIAN_X_F64,
        Record::CARTESIAN_Y_F64,
        Record::CARTESIAN_Z_F64,
        Record::COLOR_RED_U8,
        Record::COLOR_GREEN_U8,
        Record::COLOR_BLUE_U8,
    ];
    let mut pc = w.add_pointcloud("survey-scan", prototype)?;
    for p in pts {
        let mut values: Vec<RecordValue> = p.pos().into_iter().map(RecordValue::Double).collect();
        values.extend(p.rgb.map(|c| RecordValue::Integer(i64::from(c))));
        pc.add_point(values)?;
    }
    pc.finalize()?;
    w.finalize()?;
    Ok(())
}

/// Binary little-endian PLY: double positions, uchar colours, no normals (they are estimated).
fn write_ply(pts: &[Point], path: &Path) -> anyhow::Result<()> {
    use std::io::Write;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, std::fs::File::create(path)?);
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment IsoKiosk benchmark: survey cloud\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
        pts.len()
    )?;
    for p in pts {
        for v in p.pos() {
            w.write_all(&v.to_le_bytes())?;
        }
        w.write_all(&p.rgb)?;
    }
    w.into_inner().map_err(std::io::IntoInnerError::into_error)?.sync_all()?;
    Ok(())
}

/// The importer's reader of `path` into a sink that counts: the points.
fn reader(path: &Path) -> anyhow::Result<u64> {
    let mut n = 0u64;
    let mut count = |_: InputPoint| -> Result<(), std::convert::Infallible> {
        n += 1;
        Ok(())
    };
    let report = formats::read_file(path, &ReadOptions::default(), &mut count)?;
    anyhow::ensure!(report.points == n, "{} points reported, {n} received", report.points);
    Ok(n)
}

/// `las`'s own loop: records into a reused buffer (LAZ decompressed, its chunks on every core as
/// the importer has them), nothing else.
fn las_decoder(path: &Path) -> anyhow::Result<u64> {
    las_loop(las::Reader::from_path(path)?)
}

/// The same loop with LAZ decompressed on one thread (as before the importer took its chunks in
/// parallel).
fn laz_decoder_one_thread(path: &Path) -> anyhow::Result<u64> {
    let options = las::ReaderOptions::default().with_laz_parallelism(las::LazParallelism::No);
    las_loop(las::Reader::with_options(std::io::BufReader::new(std::fs::File::open(path)?), options)?)
}

fn las_loop(mut r: las::Reader) -> anyhow::Result<u64> {
    let mut data = las::PointDataBuilder::new().for_header(r.header()).build();
    let mut n = 0;
    loop {
        let got = r.fill_points(1 << 16, &mut data)?;
        if got == 0 {
            return Ok(n);
        }
        n += got;
    }
}

/// `e57`'s own loop: every point of every scan, converted as the importer asks (spherical to
/// Cartesian, pose applied, intensity as colour), counted.
fn e57_decoder(path: &Path) -> anyhow::Result<u64> {
    let mut r = e57::E57Reader::from_file(path)?;
    let mut n = 0;
    for pc in r.pointclouds() {
        let mut points = r.pointcloud_simple(&pc)?;
        points.spherical_to_cartesian(true);
        points.apply_pose(true);
        points.intensity_to_color(true);
        for p in points {
            if matches!(p?.cartesian, e57::CartesianCoordinate::Valid { .. }) {
                n += 1;
            }
        }
    }
    Ok(n)
}

/// Seconds of `f` and its count.
fn timed(f: &mut dyn FnMut() -> anyhow::Result<u64>) -> anyhow::Result<(f64, u64)> {
    let start = Instant::now();
    let n = f()?;
    Ok((start.elapsed().as_secs_f64(), n))
}

/// `a` and `b` run in turn 5 times (after a run of each that warms the page cache): the median
/// seconds of each and the median of their ratios pair by pair (the machine's speed drifts less
/// within a pair than over the whole run), with the count of each.
fn side_by_side(
    a: &mut dyn FnMut() -> anyhow::Result<u64>,
    b: &mut dyn FnMut() -> anyhow::Result<u64>,
) -> anyhow::Result<[(f64, u64); 3]> {
    let (_, na) = timed(a)?;
    let (_, nb) = timed(b)?;
    let (mut sa, mut sb, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..5 {
        let (ta, ka) = timed(a)?;
        let (tb, kb) = timed(b)?;
        anyhow::ensure!(ka == na && kb == nb, "a different count");
        sa.push(ta);
        sb.push(tb);
        ratio.push(ta / tb);
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Ok([(median(sa), na), (median(sb), nb), (median(ratio), 0)])
}

/// Prints the readers alone beside their decoders' loops, each pair timed in turn.
pub fn readers(dir: &Path, n: u64) -> anyhow::Result<()> {
    let f = files(dir, n)?;
    println!(
        "\n## Survey readers alone ({n} points; each reader and its decoder's loop in turn, 5 pairs, medians; files in {})",
        dir.display()
    );
    println!(
        "| input | MB | reader s | reader M points/s | decoder's loop s | decoder M points/s | reader / decoder, pair by pair |"
    );
    println!("|---|---|---|---|---|---|---|");
    let mb = |p: &Path| std::fs::metadata(p).map_or(f64::NAN, |m| m.len() as f64 / 1e6);
    type Decoder = fn(&Path) -> anyhow::Result<u64>;
    let rows: [(&str, &PathBuf, Option<Decoder>); 5] = [
        ("LAS 1.2, format 3", &f.las, Some(las_decoder)),
        ("LAZ", &f.laz, Some(las_decoder)),
        ("LAZ, beside its decoder on one thread", &f.laz, Some(laz_decoder_one_thread)),
        ("E57", &f.e57, Some(e57_decoder)),
        ("PLY, binary", &f.ply, None),
    ];
    for (name, path, decoder) in rows {
        let cells = match decoder {
            Some(d) => {
                let [(rs, rn), (ds, dn), (ratio, _)] = side_by_side(&mut || reader(path), &mut || d(path))?;
                anyhow::ensure!(dn == rn, "{name}: the decoder gives {dn} points, the reader {rn}");
                format!(
                    "{rs:.3} | {:.1} | {ds:.3} | {:.1} | {ratio:.2}",
                    rn as f64 / rs / 1e6,
                    dn as f64 / ds / 1e6
                )
            }
            None => {
                let [(rs, rn), ..] = side_by_side(&mut || reader(path), &mut || Ok(0))?;
                format!("{rs:.3} | {:.1} | — | — | —", rn as f64 / rs / 1e6)
            }
        };
        println!("| {name} | {:.0} | {cells} |", mb(path));
    }
    println!(
        "\nWhole imports: target/release/kiosk import {} -o survey.kstore (and the same with {}, {}, {})",
        f.las.display(),
        f.laz.display(),
        f.e57.display(),
        f.ply.display()
    );
    Ok(())
}

/// The estimation of normals and spacings alone (`--estimation-only`), on the first `n` points of
/// the survey cloud (a region holds at most 2 M), beside the same estimator with `kiddo`'s exact
/// k-nearest search: the bound a well-kept kd-tree sets on the neighbour search, on as many
/// threads. Each is timed in turn, 5 pairs after a run of each; the normals of the two are
/// compared (they differ only where two neighbours tie at the k-th distance).
pub fn estimation(n: u64) -> anyhow::Result<()> {
    use kiddo::immutable::float::kdtree::ImmutableKdTree;
    use kiosk_import::estimate;
    let pts = cloud(n);
    let origin = DVec3::from(pts[0].pos());
    let mut pos: Vec<glam::Vec3> = pts.iter().map(|p| (DVec3::from(p.pos()) - origin).as_vec3()).collect();
    let boxes = estimate::sorted_tree(&mut pos);
    let k = kiosk_import::BuildParams::default().knn;
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get());
    println!(
        "\n## Normal and spacing estimation alone ({n} points of the survey cloud, k = {k}, {threads} threads; in turn, 5 pairs, medians)"
    );
    let arrays: Vec<[f32; 3]> = pos.iter().map(|p| p.to_array()).collect();
    let start = Instant::now();
    let tree: ImmutableKdTree<f32, u32, 3, 32> = ImmutableKdTree::new_from_slice(&arrays);
    let tree_s = start.elapsed().as_secs_f64();
    let kk = std::num::NonZero::new(k + 1).expect("k + 1 > 0");
    // The k nearest of every point (itself included), on `threads` threads, each given to `f`.
    let (tree, arrays, n_pos) = (&tree, &arrays, pos.len());
    let kiddo_each = |f: &(dyn Fn(usize, &[usize]) + Sync)| {
        let per = n_pos.div_ceil(threads);
        std::thread::scope(|s| {
            for t in 0..threads {
                s.spawn(move || {
                    let mut idx = Vec::with_capacity(k + 1);
                    for (i, q) in arrays.iter().enumerate().skip(t * per).take(per) {
                        idx.clear();
                        idx.extend(
                            tree.nearest_n::<kiddo::SquaredEuclidean>(q, kk)
                                .iter()
                                .map(|nn| nn.item as usize),
                        );
                        f(i, &idx);
                    }
                });
            }
        });
    };
    let ours = || {
        estimate::estimate(&pos, &boxes, k, estimate::Strides::EXACT, &|_| true, &|_| true).expect("points")
    };
    let mut ours_run = || Ok(std::hint::black_box(ours()).len() as u64);
    let mut search_run = || {
        let sum = std::sync::atomic::AtomicU64::new(0);
        kiddo_each(&|_, idx| {
            sum.fetch_add(idx.len() as u64, std::sync::atomic::Ordering::Relaxed);
        });
        Ok(sum.into_inner() / (k as u64 + 1))
    };
    // The estimator's normal (`estimate`'s) from the neighbours `idx` (the point itself included).
    let normal_of = |idx: &[usize]| {
        let mean = idx.iter().fold(glam::Vec3::ZERO, |a, &j| a + pos[j]) / idx.len() as f32;
        let cov = idx.iter().fold(glam::Mat3::ZERO, |c, &j| {
            let d = pos[j] - mean;
            c + glam::Mat3::from_cols(d * d.x, d * d.y, d * d.z)
        });
        estimate::smallest_eigenvector(cov)
    };
    let pca = |i: usize, idx: &[usize]| {
        std::hint::black_box((i, normal_of(idx)));
    };
    let mut whole_run = || {
        kiddo_each(&pca);
        Ok(n)
    };
    let [(ours_s, _), (search_s, _), (ratio_search, _)] = side_by_side(&mut ours_run, &mut search_run)?;
    let [_, (whole_s, _), (ratio_whole, _)] = side_by_side(&mut ours_run, &mut whole_run)?;
    println!("| estimation | s | M points/s | ours / it, pair by pair |");
    println!("|---|---|---|---|");
    println!("| ours: search, normal and spacing | {ours_s:.3} | {:.2} | 1 |", n as f64 / ours_s / 1e6);
    println!(
        "| kiddo's {}-nearest search alone (its tree built in {tree_s:.3} s, not counted) | {search_s:.3} | {:.2} | {ratio_search:.2} |",
        k + 1,
        n as f64 / search_s / 1e6
    );
    println!(
        "| kiddo's search and the same normal | {whole_s:.3} | {:.2} | {ratio_whole:.2} |",
        n as f64 / whole_s / 1e6
    );
    // The two searches find the same neighbours but for ties: compare the normals (up to sign).
    let mine = ours();
    let worst = std::sync::Mutex::new(Vec::with_capacity(pos.len()));
    kiddo_each(&|i, idx| {
        let dot = normal_of(idx).dot(mine[i].normal).abs().min(1.0);
        worst.lock().expect("angles").push(dot.acos().to_degrees());
    });
    let mut angles = worst.into_inner().expect("angles");
    angles.sort_by(f32::total_cmp);
    let at = |q: f64| angles[((angles.len() - 1) as f64 * q) as usize];
    println!(
        "\nNormals, ours against kiddo's neighbours: angle median {:.2e}°, 99.9th percentile {:.2e}°, largest {:.2e}°",
        at(0.5),
        at(0.999),
        at(1.0)
    );
    Ok(())
}

/// The normal stride of the estimation (`BuildParams::normal_stride`) against its time and the
/// error of the normals and spacings, on three clouds whose normals are estimated from their
/// positions alone:
/// - `n` points of the survey cloud, whose true normals are its sphere's radial directions (its
///   noise of ±2 mm is a tenth of the spacing at 5 M points);
/// - the dragon's vertices, against the mesh's area-weighted vertex normals (fine carving: the
///   curvature radius is a few spacings in places);
/// - a raw range scan of the bunny (Cyberware, scanner noise), against the normal of the nearest
///   vertex of the reconstructed bunny (in the same frame).
///
/// Each stride's normals are compared with that reference and with the exact estimate (stride
/// 1); the error is the unoriented angle. Writes `normal-stride.svg` into `dir`.
pub fn normal_tradeoff(n: u64, dragon: &Path, dir: &Path) -> anyhow::Result<()> {
    let survey = {
        let pts = cloud(n);
        let origin = DVec3::from(pts[0].pos());
        let centre = (DVec3::new(20.0, 20.0, 50.0) + DVec3::from(OFFSET) - origin).as_vec3();
        pts.iter()
            .map(|p| {
                let local = (DVec3::from(p.pos()) - origin).as_vec3();
                (local, (local - centre).normalize())
            })
            .collect::<Vec<_>>()
    };
    let local = |pts: &[InputPoint]| {
        let c = pts.iter().fold(DVec3::ZERO, |a, p| a + p.pos) / pts.len() as f64;
        move |p: DVec3| (p - c).as_vec3()
    };
    let dragon = {
        let (pts, _) = formats::read_all(dragon, &ReadOptions::default())?;
        let to = local(&pts);
        pts.iter().map(|p| (to(p.pos), p.normal)).collect::<Vec<_>>()
    };
    let bunny = {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scans/stanford-bunny");
        let (range, _) = formats::read_all(&data.join("range-scans/bun000.ply"), &ReadOptions::default())?;
        let (mesh, _) = formats::read_all(&data.join("bun_zipper.ply"), &ReadOptions::default())?;
        // bun.conf places bun000 at the identity: both are in the same frame.
        let to = local(&mesh);
        let arrays: Vec<[f32; 3]> = mesh.iter().map(|p| to(p.pos).to_array()).collect();
        let tree: kiddo::immutable::float::kdtree::ImmutableKdTree<f32, u32, 3, 32> =
            kiddo::immutable::float::kdtree::ImmutableKdTree::new_from_slice(&arrays);
        range
            .iter()
            .map(|p| {
                let q = to(p.pos);
                let nearest = tree.nearest_one::<kiddo::SquaredEuclidean>(&q.to_array());
                (q, mesh[nearest.item as usize].normal)
            })
            .collect::<Vec<_>>()
    };
    let k = kiosk_import::BuildParams::default().knn;
    let p = kiosk_import::BuildParams::default();
    let default = (p.normal_stride, p.normal_spread_deg);
    println!(
        "\n## Speed against accuracy: normal stride and spread (clouds without normals, k = {k}; estimation alone, fastest of 3)"
    );
    println!(
        "| input | stride, spread | estimate s | normal error vs reference: median ° | p90 ° | p99 ° | vs stride 1: median ° | p99 ° | spacing vs stride 1: median | p95 | points estimated as at stride 1 |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut series = Vec::new();
    for (name, cloud) in [("survey sphere", survey), ("dragon", dragon), ("bunny range scan", bunny)] {
        let rows = normal_stride_rows(name, cloud, k, default);
        series.push((name, rows));
    }
    plot_normal_tradeoff(&dir.join("normal-stride.svg"), &series)
}

/// A stride and spread, its estimation seconds, and the median and 99th percentile of its
/// normals' error.
type StrideRow = (String, f64, f64, f64);

/// [`normal_tradeoff`]'s rows for one cloud of (position, reference normal); returns, for each
/// stride, its row.
fn normal_stride_rows(
    name: &str,
    mut cloud: Vec<(glam::Vec3, glam::Vec3)>,
    k: usize,
    default: (usize, f32),
) -> Vec<StrideRow> {
    use kiosk_import::estimate::{self, Strides};
    let bits = |p: &glam::Vec3| p.to_array().map(f32::to_bits);
    // Duplicates are merged, as the builder merges them.
    cloud.sort_by_key(|a| bits(&a.0));
    cloud.dedup_by(|a, b| a.0 == b.0);
    let reference: std::collections::HashMap<[u32; 3], glam::Vec3> =
        cloud.iter().map(|(p, n)| (bits(p), *n)).collect();
    let mut pos: Vec<glam::Vec3> = cloud.iter().map(|c| c.0).collect();
    let boxes = estimate::sorted_tree(&mut pos);
    let run = |stride: usize, spread: f32| {
        let strides = Strides { normal: stride, spacing: 1, spread_cos: spread.to_radians().cos() };
        let mut best = f64::INFINITY;
        let mut out = Vec::new();
        for _ in 0..3 {
            let t = Instant::now();
            out = estimate::estimate(&pos, &boxes, k, strides, &|_| true, &|_| true).expect("points");
            best = best.min(t.elapsed().as_secs_f64());
        }
        (best, out)
    };
    // Unoriented, and exact near 0° (unlike the arc cosine of the dot product).
    let angle =
        |a: glam::Vec3, b: glam::Vec3| f64::from(a.cross(b).length().atan2(a.dot(b).abs()).to_degrees());
    let (_, exact) = run(1, 90.0);
    let mut points = Vec::new();
    // Spreads of 90° share whatever the normals found.
    let mut configs =
        vec![(1usize, 90.0f32), (2, 2.0), (2, 4.0), (2, 8.0), (2, 90.0), (3, 4.0), (4, 4.0), (4, 90.0)];
    if default.0 > 1 && !configs.contains(&default) {
        configs.push(default);
    }
    for (stride, spread) in configs {
        let (secs, est) = run(stride, spread);
        let truth: Vec<f64> = pos
            .iter()
            .zip(&est)
            .filter_map(|(p, e)| {
                reference.get(&bits(p)).filter(|n| **n != glam::Vec3::ZERO).map(|n| angle(e.normal, *n))
            })
            .collect();
        let vs_exact: Vec<f64> = est.iter().zip(&exact).map(|(a, b)| angle(a.normal, b.normal)).collect();
        let spacing: Vec<f64> =
            est.iter().zip(&exact).map(|(a, b)| f64::from((a.spacing / b.spacing - 1.0).abs())).collect();
        let same = est.iter().zip(&exact).filter(|(a, b)| a == b).count() as f64 / est.len() as f64;
        let label = match (stride, spread) {
            (1, _) => "1".to_string(),
            (_, 90.0) => format!("{stride}, any"),
            _ => format!("{stride}, {spread}°"),
        };
        let mark =
            if (stride, spread) == default || (stride == 1 && default.0 == 1) { " (default)" } else { "" };
        println!(
            "| {name} ({} points) | {label}{mark} | {secs:.3} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} | {:.3} | {:.0} % |",
            pos.len(),
            super::pct(truth.clone(), 0.5),
            super::pct(truth.clone(), 0.9),
            super::pct(truth.clone(), 0.99),
            super::pct(vs_exact.clone(), 0.5),
            super::pct(vs_exact, 0.99),
            super::pct(spacing.clone(), 0.5),
            super::pct(spacing, 0.95),
            same * 100.0,
        );
        points.push((label, secs, super::pct(truth.clone(), 0.5), super::pct(truth, 0.99)));
    }
    points
}

/// One panel per cloud: estimation time (relative to its exact estimation) against the median
/// error of its normals, each stride and spread labelled (the 99th percentiles are in the table).
fn plot_normal_tradeoff(path: &Path, series: &[(&str, Vec<StrideRow>)]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 300 * series.len() as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    let xmax =
        series.iter().flat_map(|(_, rows)| rows.iter().map(|r| r.1 / rows[0].1)).fold(1.0, f64::max) * 1.12;
    for ((name, rows), area) in series.iter().zip(root.split_evenly((series.len(), 1))) {
        let (lo, hi) = rows.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), r| (lo.min(r.2), hi.max(r.2)));
        let pad = (hi - lo).max(0.05) * 0.25;
        let mut chart = ChartBuilder::on(&area)
            .caption(format!("{name}: estimation time against the median normal error"), ("sans-serif", 16))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .build_cartesian_2d(0.0..xmax, (lo - pad)..(hi + pad))?;
        chart
            .configure_mesh()
            .x_desc("estimation time / exact (stride 1)")
            .y_desc("median angle, °")
            .draw()?;
        chart.draw_series(rows.iter().map(|r| {
            EmptyElement::at((r.1 / rows[0].1, r.2))
                + Circle::new((0, 0), 4, BLUE.filled())
                + Text::new(r.0.clone(), (6, -6), ("sans-serif", 11))
        }))?;
    }
    root.present()?;
    Ok(())
}
