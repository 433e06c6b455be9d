//! Broken files made from good ones: bytes flipped, inserted, deleted, lines cut short, header
//! numbers blown up. A reader must never panic on any of them: it loads what the file still
//! says, or fails with an error that says something. (A hang would show as a test that does not
//! end; the header counts it is given are bounded by the limits of the readers.)

use crate::common::data;
use kiosk_import::formats;
use kiosk_import::source::ReadOptions;
use rand::{Rng, SeedableRng};
use std::io::BufReader;

type Rng64 = rand_pcg::Pcg64;

/// Small files of every encoding and shape: ASCII and binary both ways, point clouds and meshes,
/// lists with several count types, colours, OBJ.
const SEEDS: &[&str] = &[
    "ply-corpus/ok/assimp/cube_binary.ply",
    "ply-corpus/ok/assimp/float-color.ply",
    "ply-corpus/ok/pdal/mesh.ply",
    "ply-corpus/ok/pdal/simple_binary.ply",
    "ply-corpus/ok/happly/platonic_shelf_ascii.ply",
    "ply-corpus/ok/happly/platonic_shelf_big_endian.ply",
    "ply-corpus/ok/ply-rs/all_atomic_types_ok_ascii.ply",
    "ply-corpus/ok/ply-rs/house_2_ok_little_endian.ply",
    "ply-corpus/ok/trimesh/points_ascii_with_lists.ply",
    "scans/stanford-bunny/bun_zipper_res4.ply",
    "scans/demosthenes/demosthenes-low-res.obj",
];

/// One random change to `b`.
fn mutate(b: &mut Vec<u8>, rng: &mut Rng64) {
    let at = rng.random_range(0..b.len().max(1));
    match rng.random_range(0..7) {
        // A byte flipped, set to a delimiter, or to a digit.
        0 => {
            if let Some(x) = b.get_mut(at) {
                *x ^= 1 << rng.random_range(0..8);
            }
        }
        1 => {
            if let Some(x) = b.get_mut(at) {
                *x = [b' ', b'\n', b'\r', b'\t', b'-', b'.', b'e', 0, 0xff][rng.random_range(0..9)];
            }
        }
        2 => {
            if let Some(x) = b.get_mut(at) {
                *x = b'0' + rng.random_range(0..10);
            }
        }
        // Bytes inserted or deleted.
        3 => {
            let n = rng.random_range(1..8);
            let ins: Vec<u8> = (0..n).map(|_| rng.random()).collect();
            b.splice(at.min(b.len())..at.min(b.len()), ins);
        }
        4 => {
            let end = (at + rng.random_range(1..64)).min(b.len());
            b.drain(at.min(end)..end);
        }
        // Cut short.
        5 => b.truncate(at),
        // A number blown up: digits inserted after a digit (a count, an index, a coordinate).
        _ => {
            if let Some(i) = (at..b.len()).find(|&i| b[i].is_ascii_digit()) {
                let digits =
                    ["9", "99999", "4294967295", "18446744073709551615", "00"][rng.random_range(0..5)];
                b.splice(i + 1..i + 1, digits.bytes());
            }
        }
    }
}

/// What one read of a mutated file did: loaded (its report counts what it passed on), failed
/// with an error that says something, or panicked (the file is kept for the failure message).
fn judge(
    read: std::thread::Result<Result<(u64, u64), String>>,
    seed: &str,
    round: usize,
    bytes: &[u8],
    loaded: &mut usize,
    failed: &mut usize,
) {
    match read {
        Ok(Ok((reported, sunk))) => {
            assert_eq!(reported, sunk, "{seed} round {round}: the report counts what was passed on");
            *loaded += 1;
        }
        Ok(Err(msg)) => {
            assert!(msg.len() > 10, "{seed} round {round}: an error that says little: {msg:?}");
            *failed += 1;
        }
        Err(_) => {
            let name = seed.rsplit('/').next().unwrap_or("file");
            let path = std::env::temp_dir().join(format!("kiosk-mutation-{round}-{name}"));
            let _ = std::fs::write(&path, bytes);
            panic!("{seed} round {round}: the reader panicked (the file: {})", path.display())
        }
    }
}

#[test]
fn broken_files_never_panic_and_errors_say_something() {
    let opts = ReadOptions::default();
    let mut rng = Rng64::seed_from_u64(20_261_202);
    let (mut loaded, mut failed) = (0, 0);
    for seed in SEEDS {
        let good = std::fs::read(data(seed)).expect("seed file");
        let obj = seed.ends_with(".obj");
        for round in 0..300 {
            let mut b = good.clone();
            for _ in 0..rng.random_range(1..4) {
                mutate(&mut b, &mut rng);
            }
            let read = std::panic::catch_unwind(|| {
                let mut pts = 0u64;
                let mut sink = |_| {
                    pts += 1;
                    Ok(())
                };
                let mut r = BufReader::new(&b[..]);
                let got = if obj {
                    formats::obj::read_obj(&mut r, &opts, &mut sink)
                } else {
                    formats::ply::read_ply(&mut r, &opts, &mut sink)
                };
                got.map(|rep| (rep.points, pts)).map_err(|e| e.to_string())
            });
            judge(read, seed, round, &b, &mut loaded, &mut failed);
        }
    }
    // Both outcomes happen: the mutations reach the parsers, not only the header checks.
    assert!(loaded > 300 && failed > 300, "loaded {loaded}, failed {failed}");
}

#[test]
fn broken_survey_files_never_panic_and_errors_say_something() {
    let opts = ReadOptions::default();
    let mut rng = Rng64::seed_from_u64(20_261_204);
    let dir = tempfile::tempdir().expect("temp dir");
    let (mut loaded, mut failed) = (0, 0);
    // LAZ too: panics that its decoder (the laz crate) raises on corrupted points are turned into
    // errors (formats::guarded), and the chunk counts it would reserve memory for are checked
    // against the file first (see the test below).
    // The GLB, the glTF, the textured PLY and OBJ at 1/16 sample per texel, and a sample limit: a
    // mutated texture coordinate may ask for billions of samples, which is an error to see, not
    // a long run.
    let opts = ReadOptions { texel_density: 1.0 / 16.0, max_samples: 1 << 21, ..opts };
    for seed in [
        "formats/autzen.las",
        "formats/1_4_w_evlr.las",
        "formats/simple.laz",
        "formats/ColouredCubeDouble.e57",
        "formats/box-textured/BoxTextured.glb",
        "formats/BoxTextured-Draco.glb",
        "formats/BoxTextured-meshopt.glb",
        "formats/BoxTextured-meshopt-khr.glb",
        "formats/box-textured/BoxTexturedQuantized.gltf",
        "ply-corpus/ok/trimesh/fuze.ply",
        "formats/fuze/fuze.obj",
        "formats/fuze/fuze.obj.mtl",
    ] {
        let good = std::fs::read(data(seed)).expect("seed file");
        let path = dir.path().join(seed.rsplit('/').next().expect("name"));
        // An OBJ with its material library and texture: the OBJ mutated with the library
        // intact, or the library mutated and the OBJ read (the textured-OBJ path either way).
        let read_path = if seed.starts_with("formats/fuze/") {
            for f in ["fuze.obj", "fuze.obj.mtl", "fuze uv.jpg"] {
                if !seed.ends_with(f) {
                    std::fs::copy(data(&format!("formats/fuze/{f}")), dir.path().join(f)).expect("copy");
                }
            }
            dir.path().join("fuze.obj")
        } else {
            path.clone()
        };
        if seed.ends_with(".gltf") {
            // Its buffer and texture beside it, unchanged.
            for f in ["BoxTexturedQuantized.bin", "Cesium Logo Flat.png"] {
                std::fs::copy(data(&format!("formats/box-textured/{f}")), dir.path().join(f)).expect("copy");
            }
        }
        if seed.ends_with("fuze.ply") {
            // The texture it names beside it, unchanged: the textured-PLY path.
            std::fs::copy(data("ply-corpus/ok/trimesh/fuze uv.jpg"), dir.path().join("fuze uv.jpg"))
                .expect("copy");
        }
        for round in 0..150 {
            let mut b = good.clone();
            for _ in 0..rng.random_range(1..4) {
                mutate(&mut b, &mut rng);
            }
            std::fs::write(&path, &b).expect("write");
            let read = std::panic::catch_unwind(|| {
                let mut pts = 0u64;
                let got = formats::read_file(&read_path, &opts, &mut |_| {
                    pts += 1;
                    Ok(())
                });
                got.map(|rep| (rep.points, pts)).map_err(|e| e.to_string())
            });
            judge(read, seed, round, &b, &mut loaded, &mut failed);
        }
    }
    assert!(loaded > 50 && failed > 50, "loaded {loaded}, failed {failed}");
}

/// Reads `path` in a child process (this test binary, running only `test` with `var` naming
/// the file), so that a reader that aborts the process fails the test instead of ending the
/// whole run; returns what the child printed: `loaded N points` or `error: MESSAGE`.
fn read_in_child(test: &str, var: &str, path: &std::path::Path) -> String {
    let out = crate::common::rerun_in_child(test, var, path);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "reading {} ended the process ({}): {}",
        path.display(),
        out.status,
        String::from_utf8_lossy(&out.stderr)
            .lines()
            .find(|l| l.contains("allocation") || l.contains("panicked"))
            .unwrap_or("no message")
    );
    stdout.lines().find_map(|l| l.split_once("child: ")).map_or("", |(_, r)| r).to_string()
}

#[test]
fn a_laz_chunk_table_counting_too_many_chunks_is_a_clear_error() {
    const VAR: &str = "KIOSK_TEST_LAZ_FILE";
    if let Some(path) = std::env::var_os(VAR) {
        // The child: one read, its outcome printed.
        let got = formats::read_file(std::path::Path::new(&path), &ReadOptions::default(), &mut |_| Ok(()));
        match got {
            Ok(r) => println!("child: loaded {} points", r.points),
            Err(e) => println!("child: error: {e}"),
        }
        return;
    }
    // simple.laz: 1 065 points in one chunk, compressed point by point; the same points written
    // again as LAS 1.4 format 7, which the LAZ writer compresses in layers (the other chunked
    // compressor). The chunk table of each (at the byte that the 8 bytes at the start of the
    // point data give) counts one chunk. A count of 2³² − 1 made the LAZ decoder reserve 64 GiB
    // for the table, and the failed reservation aborted the process.
    let dir = tempfile::tempdir().expect("temp dir");
    let simple = std::fs::read(data("formats/simple.laz")).expect("seed file");
    let layered = dir.path().join("layered.laz");
    {
        let mut reader = las::Reader::from_path(data("formats/simple.laz")).expect("read");
        let mut header = las::Builder::from((1, 4));
        header.point_format = las::point::Format::new(7).expect("format 7");
        header.point_format.is_compressed = true;
        let mut w = las::Writer::from_path(&layered, header.into_header().expect("header")).expect("writer");
        for p in reader.read_all().expect("points").points() {
            w.write_point(p.expect("point")).expect("write");
        }
        w.close().expect("close");
    }
    let layered = std::fs::read(&layered).expect("written");
    let test = "scene::mutations::a_laz_chunk_table_counting_too_many_chunks_is_a_clear_error";
    for (name, good, compressor) in [("simple.laz", simple, 2), ("layered.laz", layered, 3)] {
        let at = |o: usize, n: usize| good[o..o + n].iter().rev().fold(0u64, |v, &b| v << 8 | u64::from(b));
        let vlr = good.windows(14).position(|w| w == b"laszip encoded").expect("the LAZ record");
        assert_eq!(at(vlr + 52, 2), compressor, "{name}: its compressor");
        let table = at(at(96, 4) as usize, 8) as usize;
        assert_eq!(at(table + 4, 4), 1, "{name}: one chunk");
        for (count, chunks) in [(u32::MAX, "4294967295 chunks"), (1 << 20, "1048576 chunks")] {
            let mut b = good.clone();
            b[table + 4..table + 8].copy_from_slice(&count.to_le_bytes());
            let path = dir.path().join(format!("{count}-{name}"));
            std::fs::write(&path, &b).expect("write");
            let got = read_in_child(test, VAR, &path);
            let place = format!("chunk table at byte {table}");
            assert!(
                got.starts_with("error:") && got.contains(&place) && got.contains(chunks),
                "{name}: {got}"
            );
        }
        // The file unchanged still loads, through the same check.
        let path = dir.path().join(name);
        std::fs::write(&path, &good).expect("write");
        assert_eq!(read_in_child(test, VAR, &path), "loaded 1065 points", "{name}");
    }
    // Found by fuzzing: the same count in a file whose header size (256) is smaller than LAS
    // 1.4's header, so that the `las` crate finds its records (and its LAZ record) elsewhere
    // than the header's size says.
    let got = read_in_child(test, VAR, &data("fuzz/laz-chunk-count-1.laz"));
    assert!(
        got.starts_with("error:") && got.contains("chunk table at byte 29070 counts 2949520967 chunks"),
        "{got}"
    );
    // Found by fuzzing: a LAZ whose point data starts elsewhere than where its header and records
    // end; the check for parallel decoding read the chunk table from there, unchecked, and its
    // count asked for gigabytes. The decoder on one thread reads it as far as it can.
    let got = read_in_child(test, VAR, &data("fuzz/laz-chunk-table-2.laz"));
    assert!(got.starts_with("error:") || got.starts_with("loaded"), "{got}");
}
