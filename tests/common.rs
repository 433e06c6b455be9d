//! Helpers shared by the integration tests.

use glam::DVec3;
use kiosk_content::MappedStore;
use kiosk_import::source::{InputPoint, ReadOptions};
use kiosk_import::{BuildParams, BuildSummary, Builder};
use std::ffi::OsStr;
use std::path::{Path, PathBuf};

/// The test data directory (copied into the repository with its SOURCES).
pub fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(rel)
}

/// The import cache of the tests' exhibits (under the target directory, not the user's cache):
/// pass it to `open_model_in`, or as `ISOKIOSK_CACHE` to a `kiosk` process.
pub fn cache() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("isokiosk-cache")
}

/// Writes a point cloud of `side` × `side` points without normals as a binary PLY at `path`: a
/// rippled unit square (a scan a kiosk must estimate normals for, and import for a while).
pub fn write_relief_ply(path: &Path, side: u32) {
    let n = side * side;
    let mut ply = format!("ply\nformat binary_little_endian 1.0\nelement vertex {n}\n").into_bytes();
    ply.extend_from_slice(b"property float x\nproperty float y\nproperty float z\nend_header\n");
    for i in 0..n {
        let (u, v) = (f64::from(i % side) / f64::from(side), f64::from(i / side) / f64::from(side));
        for c in [u, v, 0.05 * (u * 20.0).sin() * (v * 20.0).cos()] {
            ply.extend_from_slice(&(c as f32).to_le_bytes());
        }
    }
    std::fs::write(path, ply).expect("write scan");
}

/// Runs `kiosk snapshot --exhibit EXHIBIT -o OUT ARGS…` with the import cache in `cache` and
/// reads the image it wrote.
pub fn snapshot(exhibit: &Path, out: &Path, cache: &Path, args: &[&str]) -> image::RgbaImage {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .env("ISOKIOSK_CACHE", cache)
        .arg("snapshot")
        .args(args)
        .arg("--exhibit")
        .arg(exhibit)
        .arg("-o")
        .arg(out)
        .output()
        .expect("run kiosk");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    image::open(out).expect("png").to_rgba8()
}

/// Reads a scan into memory, as `kiosk import` does.
pub fn read(rel: &str) -> Vec<InputPoint> {
    read_with(rel, &ReadOptions::default())
}

/// Reader options that keep a plain mesh as its vertices alone (no samples on its large
/// triangles): for tests of what the readers make of rows and vertices, and of what the rest
/// does with exactly those points.
pub fn vertices_only() -> ReadOptions {
    ReadOptions { fill_plain_meshes: false, ..ReadOptions::default() }
}

/// Reads a scan into memory as its vertices alone ([`vertices_only`]).
pub fn read_vertices(rel: &str) -> Vec<InputPoint> {
    read_with(rel, &vertices_only())
}

fn read_with(rel: &str, opts: &ReadOptions) -> Vec<InputPoint> {
    let path = data(rel);
    match kiosk_import::read_all(&path, opts) {
        Ok((pts, _)) => pts,
        Err(e) => panic!("{}: {e}", path.display()),
    }
}

/// A built store, mapped; its file is already removed (the mapping keeps the pages), so that a
/// store kept in a `static` for the whole test run leaves nothing behind in the temporary
/// directory.
pub struct Built {
    pub store: MappedStore,
    pub summary: BuildSummary,
}

/// Builds a store from points.
pub fn build(points: &[InputPoint], params: BuildParams) -> Built {
    try_build(points, params).unwrap_or_else(|e| panic!("build failed: {e}"))
}

/// Builds a store from points, returning the builder's error.
pub fn try_build(points: &[InputPoint], params: BuildParams) -> Result<Built, kiosk_import::BuildError> {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("model.kstore");
    let mut b = Builder::new(params, dir.path())?;
    for p in points {
        b.push(*p)?;
    }
    let summary = b.finish(&out, &mut |_| {})?;
    let store = kiosk_content::open_store(&out).unwrap_or_else(|e| panic!("{e:#}"));
    dir.close().expect("remove the temporary directory");
    Ok(Built { store, summary })
}

/// Writes the points of `tests/data/formats/simple.laz` (laspy's test cloud) twice as LAS 1.2
/// files in `dir` with a scale of 1 mm: `far.las` moved by `shift` metres (offsets in its
/// header), `near.las` where it is. Returns (far, near, the original points).
pub fn las_far_and_near(dir: &Path, shift: [f64; 3]) -> (PathBuf, PathBuf, Vec<las::Point>) {
    let mut reader = las::Reader::from_path(data("formats/simple.laz")).expect("read simple.laz");
    let original: Vec<las::Point> =
        reader.read_all().expect("points").points().map(|p| p.expect("point")).collect();
    let mut header = las::Builder::from((1, 2));
    header.point_format = *reader.header().point_format();
    let (far, near) = (dir.join("far.las"), dir.join("near.las"));
    for (path, d) in [(&far, shift), (&near, [0.0; 3])] {
        let mut h = header.clone();
        let axis = |offset| las::Transform { scale: 0.001, offset };
        h.transforms = las::Vector { x: axis(d[0]), y: axis(d[1]), z: axis(d[2]) };
        let mut w = las::Writer::from_path(path, h.into_header().expect("header")).expect("writer");
        for p in &original {
            let mut q = p.clone();
            q.x += d[0];
            q.y += d[1];
            q.z += d[2];
            w.write_point(q).expect("write");
        }
        w.close().expect("close");
    }
    (far, near, original)
}

/// Small nodes so that real scans of a few ten thousand points make deep trees.
pub fn small_nodes() -> BuildParams {
    BuildParams { node_points: 512, chunk_points: 1_000_000, ..BuildParams::default() }
}

/// Applies `p ↦ p·scale + offset` to every position.
pub fn transform(points: &[InputPoint], scale: f64, offset: DVec3) -> Vec<InputPoint> {
    points
        .iter()
        .map(|p| InputPoint {
            pos: p.pos * scale + offset,
            radius: p.radius * scale as f32,
            spacing: p.spacing * scale as f32,
            ..*p
        })
        .collect()
}

/// Runs the test `test` of this test binary again in a child process, alone and with `var` set
/// to `value` (the child tells by `var` that it is the child): for what must not share the
/// process with the tests running beside it (an abort, the heap's counters).
pub fn rerun_in_child(test: &str, var: &str, value: impl AsRef<OsStr>) -> std::process::Output {
    let exe = std::env::current_exe().expect("the test binary");
    std::process::Command::new(exe)
        .args([test, "--exact", "--nocapture", "--test-threads=1"])
        .env(var, value)
        .output()
        .expect("run the test binary again")
}

/// Copies a directory tree (an exhibit, to break a copy of it).
pub fn copy_dir(from: &Path, to: &Path) {
    kiosk_testkit::copy_dir(from, to)
        .unwrap_or_else(|e| panic!("copy {} to {}: {e}", from.display(), to.display()));
}
