//! Survey formats (LAS/LAZ, E57) read from real files of public test suites
//! (`tests/data/formats/SOURCES.md`), and the formats the importer refuses, by content.

use kiosk_import::read_all;
use kiosk_import::{InputPoint, ReadOptions};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/formats").join(name)
}

#[test]
fn las_and_laz_give_every_point_with_its_colour_or_intensity() {
    // (file, points in the header, has RGB)
    for (name, count, rgb) in [
        ("autzen.las", 106, false),
        ("1_4_w_evlr.las", 1000, false),
        ("simple.laz", 1065, true),
        ("plane.laz", 0, false),
        ("extra.laz", 0, false),
    ] {
        let path = data(name);
        let header_count = las::Reader::from_path(&path).expect("las").header().number_of_points();
        if count > 0 {
            assert_eq!(header_count, count, "{name}");
        }
        let (points, report) =
            read_all(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(points.len() as u64, header_count, "{name}: every point of the header");
        assert!(points.iter().all(|p| p.pos.is_finite()), "{name}");
        let distinct: std::collections::BTreeSet<[u8; 4]> = points.iter().map(|p| p.color).collect();
        let intensities: std::collections::BTreeSet<u16> = las::Reader::from_path(&path)
            .expect("las")
            .read_all()
            .expect("points")
            .points()
            .map(|p| p.expect("point").intensity)
            .collect();
        if rgb || intensities.len() > 4 {
            assert!(distinct.len() > 4, "{name}: {} colours — colour or intensity is lost", distinct.len());
            assert!(points.iter().all(|p| p.color[3] == 255), "{name}");
        } else {
            assert!(report.has_colors || distinct.len() == 1, "{name}");
        }
        if rgb {
            assert!(
                points.iter().any(|p| p.color[0] != p.color[1] || p.color[1] != p.color[2]),
                "{name}: RGB"
            );
        }
        assert!(report.warnings.is_empty(), "{name}: {:?}", report.warnings);
    }
}

#[test]
fn a_las_cloud_a_million_metres_away_keeps_its_millimetres() {
    // The same cloud written again with an offset of 10⁶ m (scale 1 mm): read back, every point
    // is the original plus the offset to the millimetre, and the stores built from both have the
    // same samples relative to their origins.
    let dir = tempfile::tempdir().expect("temp dir");
    let shift = [1.0e6, 2.0e6, 5.0e2];
    let (far, near, original) = crate::common::las_far_and_near(dir.path(), shift);
    let (a, _) = read_all(&far, &ReadOptions::default()).expect("far");
    let (b, _) = read_all(&near, &ReadOptions::default()).expect("near");
    assert_eq!(a.len(), original.len());
    for (p, q) in a.iter().zip(&b) {
        let d = p.pos - q.pos - glam::DVec3::from_array(shift);
        assert!(d.abs().max_element() <= 1.0e-3, "{d:?}");
    }
    let store = |scan: &Path, out: &str| {
        let out = dir.path().join(out);
        kiosk_content::import::import(
            scan,
            &out,
            &kiosk_content::import::ImportOptions::default(),
            &mut kiosk_content::import::quiet,
        )
        .expect("import");
        kiosk_content::open_store(&out).expect("store")
    };
    let (sa, sb) = (store(&far, "far.kstore"), store(&near, "near.kstore"));
    assert!((sa.origin() - sb.origin() - glam::DVec3::from_array(shift)).abs().max_element() < 1.0e-3);
    let ra = sa.splats(sa.root());
    let rb = sb.splats(sb.root());
    assert_eq!(ra.len(), rb.len());
    let worst = ra
        .iter()
        .zip(rb)
        .map(|(x, y)| (x.position() - y.position()).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(worst < 2.0e-3, "the far cloud's samples moved by {worst} m relative to its origin");
}

#[test]
fn e57_scans_merge_with_their_poses_and_colours() {
    for (name, coloured) in
        [("bunnyInt32.e57", false), ("ColouredCubeDouble.e57", true), ("ColourRepresentation.e57", true)]
    {
        let path = data(name);
        let reader = e57::E57Reader::from_file(&path).expect("e57");
        let records: u64 = reader.pointclouds().iter().map(|pc| pc.records).sum();
        let (points, report) =
            read_all(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            !points.is_empty() && points.len() as u64 <= records,
            "{name}: {} of {records}",
            points.len()
        );
        assert_eq!(report.rows, records, "{name}: every record visited");
        assert!(points.iter().all(|p| p.pos.is_finite()), "{name}");
        if coloured {
            assert!(
                points.iter().any(|p| p.color[0] != p.color[1] || p.color[1] != p.color[2]),
                "{name}: colour"
            );
        }
        let _ = reader.pointclouds();
    }
}

#[test]
fn broken_survey_files_and_other_formats_are_clear_errors() {
    for name in ["empty.e57", "InvalidCVHeader.e57", "ZeroPointsInvalid.e57"] {
        let e = read_all(&data(name), &ReadOptions::default()).expect_err(name).to_string();
        assert!(e.starts_with("E57: ") && e.len() > 8, "{name}: {e}");
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let glb = dir.path().join("statue.glb");
    std::fs::write(&glb, b"glTF\x02\0\0\0 rest of a binary glTF").expect("write");
    let e = read_all(&glb, &ReadOptions::default()).expect_err("glTF").to_string();
    assert!(e.starts_with("glTF: ") && e.len() > 20, "{e}");
    let unknown = dir.path().join("statue.xyz");
    std::fs::write(&unknown, b"\x01\x02 not a scan").expect("write");
    let e = read_all(&unknown, &ReadOptions::default()).expect_err("unknown").to_string();
    assert!(e.contains("glTF 2.0") && e.contains("LAS and LAZ") && e.contains("E57"), "{e}");
    // A GLB cut short says so, with its declared and actual lengths.
    let whole = std::fs::read(data("BoxTextured-meshopt.glb")).expect("glb");
    for cut in [12, 1500, whole.len() - 1] {
        let path = dir.path().join("cut.glb");
        std::fs::write(&path, &whole[..cut]).expect("write");
        let e = read_all(&path, &ReadOptions::default()).expect_err("cut GLB").to_string();
        let expect =
            format!("GLB header: the file should be {} bytes long and has {cut} (cut short?)", whole.len());
        assert!(e.contains(&expect), "{cut}: {e}");
    }
    // A text PLY cut in the middle of a row says so.
    let path = dir.path().join("cut.ply");
    std::fs::write(
        &path,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         end_header\n0 0 0\n1 1",
    )
    .expect("write");
    let e = read_all(&path, &ReadOptions::default()).expect_err("cut PLY").to_string();
    let expect = "row 2 (line 9): missing value for property 'z'; the file ends in this line (cut short?)";
    assert!(e.contains(expect), "{e}");
    // A gzip'd scan cut short blames the compressed file.
    let gz = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/scans/stanford-dragon/dragon_vrip_res4.ply.gz"),
    )
    .expect("gz");
    let path = dir.path().join("cut.ply.gz");
    std::fs::write(&path, &gz[..gz.len() / 2]).expect("write");
    let e = read_all(&path, &ReadOptions::default()).expect_err("cut gzip").to_string();
    assert!(e.contains("gzip: ") && e.contains("the compressed file is damaged or cut short"), "{e}");
    // A survey file whose signature is damaged, or an empty file, is not blamed on PLY.
    for (name, bytes, expect) in [
        ("scan.las", &b"LASX rest of a header"[..], "does not start with the LAS signature \"LASF\""),
        ("scan.laz", b"", "the file is empty (0 bytes)"),
        ("scan.e57", b"ASTM-E75 rest of a header", "does not start with the E57 signature \"ASTM-E57\""),
        ("scan.ply", b"", "the file is empty (0 bytes)"),
    ] {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).expect("write");
        let e = read_all(&path, &ReadOptions::default()).expect_err(name).to_string();
        assert!(e.contains(expect) && !e.contains("'ply'"), "{name}: {e}");
    }
    let truncated = dir.path().join("cut.laz");
    let bytes = std::fs::read(data("simple.laz")).expect("laz");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).expect("write");
    let e = read_all(&truncated, &ReadOptions::default()).expect_err("truncated LAZ").to_string();
    assert!(e.starts_with("LAS: "), "{e}");
    // Compressed data damaged in the middle: the error names the points being decoded.
    let damaged = dir.path().join("damaged.laz");
    let mut bytes = std::fs::read(data("simple.laz")).expect("laz");
    let mid = bytes.len() / 2;
    bytes[mid..mid + 64].fill(0xff);
    std::fs::write(&damaged, &bytes).expect("write");
    let e = read_all(&damaged, &ReadOptions::default()).expect_err("damaged LAZ").to_string();
    assert!(e.starts_with("LAS: points "), "{e}");
    // A header whose version, scale or offset no point could be read with is named as such, not
    // blamed on the points (a scale of 0 would otherwise make a flat model without a word).
    let autzen = std::fs::read(data("autzen.las")).expect("las");
    let cases: [(usize, &[u8], &str); 4] = [
        (25, &[9], "LAS version 1.9: the importer reads LAS 1.0 to 1.4"),
        (131, &0f64.to_le_bytes(), "the header's X scale factor is 0: every X would be the offset"),
        (147, &f64::NAN.to_le_bytes(), "the header's Z scale factor is NaN"),
        (163, &f64::INFINITY.to_le_bytes(), "the header's Y offset is inf"),
    ];
    for (at, value, expect) in cases {
        let mut bytes = autzen.clone();
        bytes[at..at + value.len()].copy_from_slice(value);
        let path = dir.path().join("header.las");
        std::fs::write(&path, &bytes).expect("write");
        let e = read_all(&path, &ReadOptions::default()).expect_err(expect).to_string();
        assert!(e.starts_with("LAS: ") && e.contains(expect), "{e}");
    }
}

/// The BoxTextured sample (Khronos, `box-textured/` in SOURCES.md): its triangles in the model's
/// coordinates (the node's matrix applied: (x, y, z) → (x, z, −y)) with their texture
/// coordinates, read from its buffer here, independently of the importer.
fn box_triangles() -> Vec<([glam::DVec3; 3], [[f64; 2]; 3])> {
    let buf = std::fs::read(data("box-textured/BoxTextured0.bin")).expect("bin");
    let f = |at: usize| f64::from(f32::from_le_bytes(buf[at..at + 4].try_into().expect("4 bytes")));
    let pos = |i: usize| glam::DVec3::new(f(288 + 12 * i), f(288 + 12 * i + 8), -f(288 + 12 * i + 4));
    let uv = |i: usize| [f(576 + 8 * i), f(576 + 8 * i + 4)];
    (0..12)
        .map(|t| {
            let k: [usize; 3] = std::array::from_fn(|c| {
                usize::from(u16::from_le_bytes([buf[768 + 6 * t + 2 * c], buf[769 + 6 * t + 2 * c]]))
            });
            (k.map(pos), k.map(uv))
        })
        .collect()
}

/// The texture coordinates at `p` on the box (glTF's: 0,0 the image's top left), from the
/// triangle it lies in.
fn box_uv(tris: &[([glam::DVec3; 3], [[f64; 2]; 3])], p: glam::DVec3) -> Option<[f64; 2]> {
    tris.iter().find_map(|([a, b, c], uv)| {
        let (e1, e2, d) = (*b - *a, *c - *a, p - *a);
        let n = e1.cross(e2);
        if d.dot(n.normalize()).abs() > 1e-3 {
            return None;
        }
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (d1, d2) = (d.dot(e1), d.dot(e2));
        let den = d11 * d22 - d12 * d12;
        let (v, w) = ((d22 * d1 - d12 * d2) / den, (d11 * d2 - d12 * d1) / den);
        let u = 1.0 - v - w;
        (u >= -1e-6 && v >= -1e-6 && w >= -1e-6)
            .then(|| [0, 1].map(|k| u * uv[0][k] + v * uv[1][k] + w * uv[2][k]))
    })
}

/// Whether `color` is within the colours of the 2 × 2 texels around `uv` (repeat wrap), a
/// little tolerance aside: what bilinear filtering between them can give.
fn matches_texture(img: &image::RgbaImage, uv: [f64; 2], color: [u8; 4]) -> bool {
    let (w, h) = (f64::from(img.width()), f64::from(img.height()));
    let (x, y) = (uv[0] * w - 0.5, uv[1] * h - 0.5);
    let (x0, y0) = (x.floor() as i64, y.floor() as i64);
    let texel = |dx: i64, dy: i64| {
        let xi = (x0 + dx).rem_euclid(i64::from(img.width())) as u32;
        let yi = (y0 + dy).rem_euclid(i64::from(img.height())) as u32;
        img.get_pixel(xi, yi).0
    };
    let near = [texel(0, 0), texel(1, 0), texel(0, 1), texel(1, 1)];
    (0..3).all(|k| {
        let lo = near.iter().map(|t| t[k]).min().unwrap_or(0);
        let hi = near.iter().map(|t| t[k]).max().unwrap_or(255);
        (i32::from(lo) - 2..=i32::from(hi) + 2).contains(&i32::from(color[k]))
    })
}

#[test]
fn a_textured_box_takes_its_colours_from_the_texture_in_every_format() {
    let tris = box_triangles();
    let img = image::open(data("box-textured/Cesium Logo Flat.png")).expect("png").to_rgba8();
    let opts = ReadOptions { texel_density: 0.25, ..Default::default() };
    let mut counts = Vec::new();
    for name in [
        "box-textured/BoxTextured.gltf",
        "box-textured/BoxTextured.glb",
        "box-textured/BoxTexturedQuantized.gltf",
        // Its colour from KHR_materials_pbrSpecularGlossiness; the metallic-roughness fallback
        // is black.
        "box-textured/BoxTexturedSpecGloss.gltf",
        "box-textured/box textured.obj",
        // Draco-compressed (KHR_draco_mesh_compression), decoded.
        "BoxTextured-Draco.glb",
        // meshopt-compressed by gltfpack (EXT_meshopt_compression, quantized, octahedral normals).
        "BoxTextured-meshopt.glb",
        // The same as KHR_meshopt_compression (version 1 of the vertex codec).
        "BoxTextured-meshopt-khr.glb",
    ] {
        let (points, report) = read_all(&data(name), &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(report.has_colors, "{name}");
        // Each face shows the whole 256 × 256 texture: 64 k texels × 0.25 = 16 k samples per
        // face, 8 k per triangle: ⌈√8192⌉² = 91² per triangle.
        assert_eq!(points.len(), 12 * 91 * 91, "{name}");
        let mut off = 0;
        for p in &points {
            let uv = box_uv(&tris, p.pos).unwrap_or_else(|| panic!("{name}: {:?} is not on the box", p.pos));
            if !matches_texture(&img, uv, p.color) {
                off += 1;
            }
            assert!((p.normal.length() - 1.0).abs() < 1e-3, "{name}: normal {:?}", p.normal);
            assert!(p.spacing > 0.0 && p.radius >= p.spacing * 0.5, "{name}");
        }
        // The quantized file's coordinates are rounded (1e-4 m, 1/65535 of the texture): a few
        // samples land on the neighbouring texel.
        assert!(
            off * 200 <= points.len(),
            "{name}: {off} of {} samples off their texel's colour",
            points.len()
        );
        let distinct: std::collections::BTreeSet<[u8; 4]> = points.iter().map(|p| p.color).collect();
        assert!(distinct.len() > 100, "{name}: {} colours", distinct.len());
        counts.push(points.len());
    }
}

#[test]
fn texture_colour_arrives_in_the_store() {
    use kiosk_content::import::Phase;
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("box.kstore");
    let mut opts = kiosk_content::import::ImportOptions::default();
    opts.read.texel_density = 0.25;
    let mut seen: Vec<(Phase, u64, u64)> = Vec::new();
    kiosk_content::import::import(
        &data("box-textured/BoxTextured.glb"),
        &out,
        &opts,
        &mut |phase, done, total| seen.push((phase, done, total)),
    )
    .expect("import");
    // The progress bar knows how many samples the surface makes before the first one, and
    // counts up to it.
    let reading: Vec<_> = seen.iter().filter(|(p, ..)| *p == Phase::Reading).collect();
    let first_total = reading.iter().position(|&&(_, _, total)| total > 0).expect("a total");
    assert!(
        reading[first_total].1 == 0 && reading[first_total].2 == 12 * 91 * 91,
        "{:?}",
        reading[first_total]
    );
    assert!(reading.last().is_some_and(|&&(_, done, total)| done == total), "{:?}", reading.last());
    // The building's bar ends full, though duplicates merged make fewer samples than were read.
    let building = seen.iter().rev().find(|(p, ..)| *p == Phase::Building).expect("building");
    assert!(building.1 == building.2 && building.2 == 12 * 91 * 91, "{building:?}");
    let store = kiosk_content::open_store(&out).expect("store");
    let tris = box_triangles();
    let img = image::open(data("box-textured/Cesium Logo Flat.png")).expect("png").to_rgba8();
    let (mut leaves, mut off) = (0usize, 0usize);
    for id in (0..store.nodes().len() as u32).filter(|&id| store.node(id).is_leaf()) {
        for s in store.splats(id) {
            leaves += 1;
            let p = store.origin() + glam::Vec3::from_array(s.pos).as_dvec3();
            let uv = box_uv(&tris, p).expect("on the box");
            assert_eq!(s.color[3], 255);
            if !matches_texture(&img, uv, s.color) {
                off += 1;
            }
        }
    }
    assert_eq!(leaves, 12 * 91 * 91, "every sample is a leaf splat");
    assert!(off * 100 <= leaves, "{off} of {leaves} splats off their texel's colour");
}

#[test]
fn a_low_poly_box_is_sampled_on_its_faces_without_holes() {
    // 12 triangles, 8 vertices, no texture: a unit cube.
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("cube.obj");
    let mut text = String::new();
    for i in 0..8 {
        text += &format!("v {} {} {}\n", i & 1, (i >> 1) & 1, (i >> 2) & 1);
    }
    for f in ["1 3 4 2", "5 6 8 7", "1 2 6 5", "3 7 8 4", "1 5 7 3", "2 4 8 6"] {
        text += &format!("f {f}\n");
    }
    std::fs::write(&path, text).expect("write");
    let opts = ReadOptions { fill_divisions: 64, fill_plain_meshes: true, ..Default::default() };
    let (points, report) = read_all(&path, &opts).expect("cube");
    let h = 3f64.sqrt() / 64.0;
    // No vertex with a giant disc: every sample is a surface sample of the fill spacing.
    assert!(points.iter().all(|p| f64::from(p.radius) < 1.5 * h), "a vertex's disc remains");
    // About one sample per h² of the 6 m² (at most 4/3 that for the rounding up per triangle).
    let n = points.len() as f64;
    assert!(n >= 6.0 / (h * h) * 0.9 && n <= 6.0 / (h * h) * 1.4, "{n} samples");
    assert_eq!(report.points, points.len() as u64);
    // Every point of every face is within the radius of a sample (on a 40 × 40 grid per face).
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            for a in 0..=40 {
                for b in 0..=40 {
                    let mut q = [0.0; 3];
                    q[axis] = side;
                    q[(axis + 1) % 3] = f64::from(a) / 40.0;
                    q[(axis + 2) % 3] = f64::from(b) / 40.0;
                    let q = glam::DVec3::from_array(q);
                    assert!(
                        points.iter().any(|p| (p.pos - q).length() <= f64::from(p.radius)),
                        "hole at {q}"
                    );
                }
            }
        }
    }
    // Flat faces keep flat normals (the corners' averaged normals are not interpolated).
    assert!(points.iter().all(|p| p.normal.abs().max_element() > 0.999), "a bent normal");
    // By default too (at the default spacing, the diagonal / 256), not only when asked; the
    // vertices alone when asked.
    let (filled, _) = read_all(&path, &ReadOptions::default()).expect("cube");
    assert!(filled.len() > 100_000, "{} samples by default", filled.len());
    let (vertices, _) =
        read_all(&path, &ReadOptions { fill_plain_meshes: false, ..Default::default() }).expect("cube");
    assert_eq!(vertices.len(), 8);
}

#[test]
fn a_textured_ply_is_sampled_like_the_same_mesh_as_a_textured_obj() {
    // MeshLab's fuze bottle, exported both ways with one texture: per-face `texcoord` lists in
    // the PLY (`comment TextureFile fuze uv.jpg`), `vt` + MTL in the OBJ. The OBJ+MTL path is
    // the oracle: the same triangles and texture give the same samples.
    let ply = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ply-corpus/ok/trimesh/fuze.ply");
    let (p, prep) = read_all(&ply, &ReadOptions::default()).expect("textured PLY");
    let (o, _) = read_all(&data("fuze/fuze.obj"), &ReadOptions::default()).expect("textured OBJ");
    assert!(prep.has_colors);
    assert!(p.len() > 20 * 502, "{} samples: the surface is sampled, not only the 502 vertices", p.len());
    let rel = (p.len() as f64 - o.len() as f64).abs() / o.len() as f64;
    assert!(rel < 0.01, "PLY {} samples, OBJ {}", p.len(), o.len());
    // Every PLY sample has an OBJ sample at its place with its colour (the texture's, not the
    // file's per-face RGBA).
    let grid = 1e-4;
    let key = |q: &InputPoint| (q.pos / grid).round().as_i64vec3().to_array();
    let by_place: std::collections::HashMap<[i64; 3], [u8; 4]> =
        o.iter().map(|q| (key(q), q.color)).collect();
    let (mut found, mut same) = (0usize, 0usize);
    for q in &p {
        if let Some(c) = by_place.get(&key(q)) {
            found += 1;
            same += usize::from((0..3).all(|k| c[k].abs_diff(q.color[k]) <= 2));
        }
    }
    assert!(
        found as f64 > 0.95 * p.len() as f64,
        "{found} of {} PLY samples at an OBJ sample's place",
        p.len()
    );
    assert!(same as f64 > 0.99 * found as f64, "{same} of {found} with the same colour");
    let distinct: std::collections::HashSet<[u8; 4]> = p.iter().map(|q| q.color).collect();
    assert!(distinct.len() > 1000, "{} colours: the texture's detail", distinct.len());
}

#[test]
fn a_textured_ply_without_its_image_names_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    let ply = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ply-corpus/ok/trimesh/fuze.ply");
    std::fs::copy(&ply, dir.path().join("fuze.ply")).expect("copy");
    let e =
        read_all(&dir.path().join("fuze.ply"), &ReadOptions::default()).expect_err("no texture").to_string();
    assert!(e.contains("fuze uv.jpg") && e.contains("not found"), "{e}");
    // The same file read as a stream (no directory to look in) is its vertices, with a warning.
    let mut r = std::io::BufReader::new(std::fs::File::open(&ply).expect("open"));
    let mut n = 0u64;
    let rep = kiosk_import::formats::ply::read_ply(&mut r, &crate::common::vertices_only(), &mut |_| {
        n += 1;
        Ok(())
    })
    .expect("vertices");
    assert_eq!(n, 502);
    assert!(rep.warnings.iter().any(|w| w.contains("fuze uv.jpg")), "{:?}", rep.warnings);
    // Texture coordinates with no image named at all (Blender's export of BoxTextured): read
    // uncoloured, and the warning says why.
    let ply = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ply-corpus/ok/trimesh/BoxTextured.ply");
    let (_, rep) = read_all(&ply, &ReadOptions::default()).expect("box");
    assert!(!rep.has_colors);
    assert!(rep.warnings.iter().any(|w| w.contains("no `comment TextureFile NAME`")), "{:?}", rep.warnings);
}

#[test]
fn broken_glb_files_found_by_fuzzing_are_clear_errors() {
    // Found by fuzzing: a declared length under 12 bytes overflowed the glTF crate's arithmetic.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/glb-header-length-1.glb");
    let e = read_all(&path, &ReadOptions::default()).expect_err("a broken header").to_string();
    assert!(e.contains("GLB header: length") && e.contains("shorter than the 12-byte header"), "{e}");
    // Found by fuzzing: a mesh naming accessors the file lacks made the crate's validation index
    // out of range.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/glb-accessor-index-1.glb");
    let e = read_all(&path, &ReadOptions::default()).expect_err("missing accessors").to_string();
    assert!(
        e.contains("mesh 0 primitive 0") && e.contains("names accessor") && e.contains("the file has 0"),
        "{e}"
    );
}

#[test]
fn broken_las_files_found_by_fuzzing_are_clear_errors() {
    // Found by fuzzing: a LAS 1.4 point count whose size in bytes overflows 64 bits made the las
    // crate's arithmetic overflow (a panic where overflow is checked, a wrapped offset elsewhere).
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz/las-point-count-1.laz");
    let e = read_all(&path, &ReadOptions::default()).expect_err("a broken count").to_string();
    assert!(e.contains("overflow the file's offsets") && !e.contains("decoder failed"), "{e}");
}

#[test]
fn broken_gltf_files_and_unread_extensions_are_clear_errors() {
    let dir = tempfile::tempdir().expect("temp dir");
    // An extension the importer does not read, required: named.
    let json = std::fs::read_to_string(data("box-textured/BoxTextured.gltf")).expect("gltf");
    let required = json.replacen('{', r#"{"extensionsRequired":["EXT_mesh_gpu_instancing"],"#, 1);
    std::fs::write(dir.path().join("required.gltf"), required).expect("write");
    let e = read_all(&dir.path().join("required.gltf"), &ReadOptions::default()).expect_err("required");
    assert!(e.to_string().contains("requires the extension EXT_mesh_gpu_instancing"), "{e}");
    // A missing texture names the file.
    for f in ["BoxTextured.gltf", "BoxTextured0.bin", "box textured.obj", "box textured.mtl"] {
        std::fs::copy(data(&format!("box-textured/{f}")), dir.path().join(f)).expect("copy");
    }
    for name in ["BoxTextured.gltf", "box textured.obj"] {
        let e = read_all(&dir.path().join(name), &ReadOptions::default()).expect_err(name).to_string();
        assert!(e.contains("Cesium Logo Flat.png") && e.contains("not found"), "{name}: {e}");
    }
    // A buffer that is missing names the buffer and the file.
    std::fs::remove_file(dir.path().join("BoxTextured0.bin")).expect("rm");
    let e =
        read_all(&dir.path().join("BoxTextured.gltf"), &ReadOptions::default()).expect_err("bin").to_string();
    assert!(e.contains("buffer 0") && e.contains("BoxTextured0.bin"), "{e}");
}

#[test]
fn e57_scans_in_spherical_and_cartesian_coordinates_merge_with_their_poses() {
    use e57::{Quaternion, Record, RecordValue, Transform, Translation};
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("two-scans.e57");
    let mut w = e57::E57Writer::from_file(&path, "two-scans").expect("writer");
    // Scan 1: Cartesian, coloured, turned 90° about z and moved 10 m along x; its second point
    // is flagged invalid, its fourth has a direction only (state 1: no usable position).
    let prototype = vec![
        Record::CARTESIAN_X_F64,
        Record::CARTESIAN_Y_F64,
        Record::CARTESIAN_Z_F64,
        Record::CARTESIAN_INVALID_STATE,
        Record::COLOR_RED_U8,
        Record::COLOR_GREEN_U8,
        Record::COLOR_BLUE_U8,
    ];
    let mut pc = w.add_pointcloud("cartesian", prototype).expect("scan 1");
    let half = std::f64::consts::FRAC_1_SQRT_2;
    pc.set_transform(Some(Transform {
        rotation: Quaternion { w: half, x: 0.0, y: 0.0, z: half },
        translation: Translation { x: 10.0, y: 0.0, z: 0.0 },
    }));
    // Four points: the 2-bit states fill a whole byte (the e57 crate reads a scan whose
    // bit-packed states fill less than a byte as an internal error).
    for (p, state, rgb) in [
        ([1.0, 0.0, 0.0], 0, [255, 0, 0]),
        ([5.0, 5.0, 5.0], 2, [0, 255, 0]),
        ([0.0, 2.0, 0.0], 0, [0, 0, 255]),
        ([0.0, 0.0, 4.0], 1, [0, 0, 0]),
    ] {
        let mut v: Vec<RecordValue> = p.into_iter().map(RecordValue::Double).collect();
        v.push(RecordValue::Integer(state));
        v.extend(rgb.map(RecordValue::Integer));
        pc.add_point(v).expect("point");
    }
    pc.finalize().expect("scan 1 written");
    // Scan 2: spherical (range, azimuth, elevation), intensity only, no pose; its last point is
    // flagged invalid.
    let prototype = vec![
        Record::SPHERICAL_RANGE_F64,
        Record::SPHERICAL_AZIMUTH_F64,
        Record::SPHERICAL_ELEVATION_F64,
        Record::SPHERICAL_INVALID_STATE,
        Record::INTENSITY_UNIT_F32,
    ];
    let mut pc = w.add_pointcloud("spherical", prototype).expect("scan 2");
    let right = std::f64::consts::FRAC_PI_2;
    for (r, az, el, state, i) in [
        (2.0, 0.0, 0.0, 0, 0.5f32),
        (3.0, right, 0.0, 0, 1.0),
        (1.0, 0.0, right, 0, 0.0),
        (9.0, 1.0, 0.2, 2, 0.3),
    ] {
        let v = vec![
            RecordValue::Double(r),
            RecordValue::Double(az),
            RecordValue::Double(el),
            RecordValue::Integer(state),
            RecordValue::Single(i),
        ];
        pc.add_point(v).expect("point");
    }
    pc.finalize().expect("scan 2 written");
    w.finalize().expect("file written");

    let (points, report) = read_all(&path, &ReadOptions::default()).expect("read");
    let expect: [([f64; 3], [u8; 3]); 5] = [
        ([10.0, 1.0, 0.0], [255, 0, 0]),
        ([8.0, 0.0, 0.0], [0, 0, 255]),
        ([2.0, 0.0, 0.0], [128, 128, 128]),
        ([0.0, 3.0, 0.0], [255, 255, 255]),
        ([0.0, 0.0, 1.0], [0, 0, 0]),
    ];
    assert_eq!(points.len(), expect.len(), "{points:?}");
    for (p, (pos, rgb)) in points.iter().zip(expect) {
        assert!((p.pos - glam::DVec3::from_array(pos)).abs().max_element() < 1e-9, "{:?} vs {pos:?}", p.pos);
        for (got, want) in p.color.iter().zip(rgb) {
            assert!(got.abs_diff(want) <= 1, "{:?} vs {rgb:?} at {pos:?}", p.color);
        }
    }
    assert!(
        report.warnings.iter().any(|w| w.starts_with("3 points flagged invalid")),
        "{:?}",
        report.warnings
    );
}

#[test]
fn a_scan_names_the_other_files_it_was_read_from() {
    // These go beside a cached store, so that an edited texture, buffer or material library
    // imports the scan again (`kiosk_content::exhibit`).
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ply-corpus/ok/trimesh");
    for (scan, inputs) in [
        (
            data("box-textured/BoxTextured.gltf"),
            vec![data("box-textured/BoxTextured0.bin"), data("box-textured/Cesium Logo Flat.png")],
        ),
        (data("box-textured/BoxTextured.glb"), vec![]),
        (
            data("box-textured/box textured.obj"),
            vec![data("box-textured/box textured.mtl"), data("box-textured/Cesium Logo Flat.png")],
        ),
        (corpus.join("fuze.ply"), vec![corpus.join("fuze uv.jpg")]),
    ] {
        let (_, report) =
            read_all(&scan, &ReadOptions::default()).unwrap_or_else(|e| panic!("{}: {e}", scan.display()));
        let mut got = report.inputs.clone();
        got.sort();
        let mut want = inputs;
        want.sort();
        assert_eq!(got, want, "{}", scan.display());
    }
}

#[test]
fn a_textured_ply_beyond_the_face_limit_keeps_its_texture() {
    // A plain mesh beyond the limit is read as a cloud; a textured one would lose its colour.
    let fuze = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ply-corpus/ok/trimesh/fuze.ply");
    let (within, _) = read_all(&fuze, &ReadOptions::default()).expect("fuze");
    let small = ReadOptions { face_vertex_limit: 100, ..Default::default() };
    let (beyond, report) = read_all(&fuze, &small).expect("fuze beyond the limit");
    assert!(!report.warnings.iter().any(|w| w.contains("texture")), "{:?}", report.warnings);
    assert_eq!(beyond.len(), within.len());
    assert!(beyond.iter().zip(&within).all(|(a, b)| a.pos == b.pos && a.color == b.color));
    // The plain bunny beyond it: faces ignored, said so.
    let bunny =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/scans/stanford-bunny/bun_zipper_res4.ply");
    let (_, report) = read_all(&bunny, &small).expect("bunny");
    assert!(report.warnings.iter().any(|w| w.contains("face-normal limit")), "{:?}", report.warnings);
}

#[test]
fn a_texture_named_by_the_exporters_absolute_path_is_found_beside_the_library() {
    let dir = tempfile::tempdir().expect("temp dir");
    for f in ["box textured.obj", "Cesium Logo Flat.png"] {
        std::fs::copy(data("box-textured").join(f), dir.path().join(f)).expect("copy");
    }
    let mtl = std::fs::read_to_string(data("box-textured/box textured.mtl")).expect("mtl");
    let windows = r"C:\Users\curator\Exports\Cesium Logo Flat.png";
    let mtl = mtl.replace("map_Kd Cesium Logo Flat.png", &format!("map_Kd {windows}"));
    assert!(mtl.contains(windows), "{mtl}");
    std::fs::write(dir.path().join("box textured.mtl"), mtl).expect("write mtl");
    let (want, _) = read_all(&data("box-textured/box textured.obj"), &ReadOptions::default()).expect("box");
    let (got, report) =
        read_all(&dir.path().join("box textured.obj"), &ReadOptions::default()).expect("moved box");
    assert!(
        report.warnings.iter().any(|w| w.contains(windows) && w.contains("not found")),
        "{:?}",
        report.warnings
    );
    assert_eq!(got.len(), want.len());
    assert!(got.iter().zip(&want).all(|(a, b)| a.color == b.color), "the texture's colours");
    // Both are the scan's inputs: the named file appearing later imports it again.
    let named = report.inputs.iter().any(|p| p.to_string_lossy().ends_with("Exports/Cesium Logo Flat.png"));
    assert!(named && report.inputs.contains(&dir.path().join("Cesium Logo Flat.png")), "{:?}", report.inputs);
    // Not there either: the error names the path the library gave.
    std::fs::remove_file(dir.path().join("Cesium Logo Flat.png")).expect("remove");
    let e = read_all(&dir.path().join("box textured.obj"), &ReadOptions::default()).expect_err("no texture");
    assert!(e.to_string().contains("Exports/Cesium Logo Flat.png"), "{e}");
}

#[test]
fn a_gltf_with_an_unused_image_without_a_source_still_imports() {
    // The gltf crate panics when asked for such an image's source; nothing uses it here.
    let dir = tempfile::tempdir().expect("temp dir");
    for f in ["BoxTextured0.bin", "Cesium Logo Flat.png"] {
        std::fs::copy(data("box-textured").join(f), dir.path().join(f)).expect("copy");
    }
    let text = std::fs::read_to_string(data("box-textured/BoxTextured.gltf")).expect("gltf");
    let mut json: serde_json::Value = serde_json::from_str(&text).expect("json");
    json["images"].as_array_mut().expect("images").push(serde_json::json!({ "name": "unused, no source" }));
    let path = dir.path().join("box.gltf");
    std::fs::write(&path, serde_json::to_string(&json).expect("json")).expect("write");
    let (points, report) = read_all(&path, &ReadOptions::default()).expect("imports");
    assert!(!points.is_empty());
    assert_eq!(report.inputs.len(), 2, "{:?}", report.inputs);
}

#[test]
fn a_las_file_whose_colours_widen_after_its_first_chunk_is_read_as_16_bit_from_there() {
    // LAS colour is 16-bit by the specification, 8-bit in practice for many writers; the depth
    // is decided on the first 65 536 points. A file whose first chunk holds only values up to
    // 255 and whose later points use 16 bits switches to 16-bit where that shows, and says
    // which points were taken as 8-bit. The same for intensity, in a file without colour.
    let dir = tempfile::tempdir().expect("temp dir");
    const FIRST: u32 = 1 << 16;
    let n = FIRST + 5000;
    for (name, format) in [("rgb.las", 2u8), ("intensity.las", 0)] {
        let path = dir.path().join(name);
        let mut header = las::Builder::from((1, 2));
        header.point_format = las::point::Format::new(format).expect("format");
        let mut w = las::Writer::from_path(&path, header.into_header().expect("header")).expect("writer");
        for i in 0..n {
            // 200 in the first chunk; 40 000 of 65 535 after it.
            let v: u16 = if i < FIRST { 200 } else { 40_000 };
            let mut p =
                las::Point { x: f64::from(i % 300), y: f64::from(i / 300), z: 0.0, ..Default::default() };
            if format == 2 {
                p.color = Some(las::Color { red: v, green: v, blue: v });
            } else {
                p.intensity = v;
            }
            w.write_point(p).expect("write");
        }
        w.close().expect("close");
        let (points, report) = read_all(&path, &ReadOptions::default()).expect("read");
        assert_eq!(points.len(), n as usize, "{name}");
        let expected = format!("in points {}–{n}: points 1–{FIRST} were taken as 8-bit", FIRST + 1);
        assert!(
            report.warnings.len() == 1 && report.warnings[0].contains(&expected),
            "{name}: {:?}",
            report.warnings
        );
        let grey = |p: &InputPoint| p.color[0];
        assert!(points[..FIRST as usize].iter().all(|p| grey(p) == 200), "{name}: the first chunk as 8-bit");
        // 40 000 / 65 535 × 255 = 155.6.
        assert!(points[FIRST as usize..].iter().all(|p| grey(p) == 156), "{name}: the rest as 16-bit");
    }
}

#[test]
fn compressed_exports_read_like_their_source() {
    // The Belweder GLB compressed by two real exporters, against the uncompressed file: Draco by
    // Cesium's gltf-pipeline (11-bit positions, 10-bit texture coordinates) and meshopt by
    // gltfpack (14-bit positions, 12-bit texture coordinates). The same object, its colours and
    // its extent, within what the quantization moves.
    let opts = ReadOptions { texel_density: 0.25, ..Default::default() };
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("content/belweder/belweder-ot-1782.glb");
    let (a, ra) = read_all(&source, &opts).expect("source");
    // (file, least sample ratio, position step as a fraction of the largest side)
    for (name, least, step) in
        [("belweder-draco.glb", 0.85, 1.0 / 2047.0), ("belweder-meshopt.glb", 0.99, 1.0 / 16383.0)]
    {
        let (b, rb) = read_all(&data(name), &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(ra.has_colors && rb.has_colors && rb.has_normals, "{name}");
        assert!(rb.warnings.is_empty(), "{name}: {:?}", rb.warnings);
        // A triangle's samples follow its texel footprint, ⌈√(texels × d)⌉²: at 0.25 samples
        // per texel most of these small triangles sit near a rounding step, and 10-bit
        // coordinates move their footprints across it (at 1 per texel the Draco file's count
        // differs by 2 %).
        let ratio = b.len() as f64 / a.len() as f64;
        assert!((least..1.05).contains(&ratio), "{name}: {} samples against {}", b.len(), a.len());
        let bounds = |p: &[InputPoint]| {
            p.iter().fold((glam::DVec3::MAX, glam::DVec3::MIN), |(lo, hi), q| (lo.min(q.pos), hi.max(q.pos)))
        };
        let ((alo, ahi), (blo, bhi)) = (bounds(&a), bounds(&b));
        let side = (ahi - alo).max_element();
        let moved = (alo - blo).abs().max_element().max((ahi - bhi).abs().max_element());
        assert!(
            moved <= 2.0 * step * side,
            "{name}: the extent moved by {moved}, {} steps",
            moved / (step * side)
        );
        let mean = |p: &[InputPoint]| {
            let s = p.iter().fold([0.0f64; 3], |s, q| std::array::from_fn(|k| s[k] + f64::from(q.color[k])));
            s.map(|c| c / p.len() as f64)
        };
        let (ma, mb) = (mean(&a), mean(&b));
        assert!((0..3).all(|k| (ma[k] - mb[k]).abs() < 2.0), "{name}: mean colour {ma:?} against {mb:?}");
        let distinct: std::collections::BTreeSet<[u8; 4]> = b.iter().map(|p| p.color).collect();
        assert!(distinct.len() > 10_000, "{name}: {} colours: the texture is sampled", distinct.len());
        assert!(b.iter().all(|p| (p.normal.length() - 1.0).abs() < 1e-3), "{name}: normals decoded");
    }
}

/// `glb` with its JSON chunk rewritten by `edit` (the binary chunk kept).
fn glb_with_json(glb: &[u8], edit: impl FnOnce(&mut serde_json::Value)) -> Vec<u8> {
    let u32_at = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().expect("4 bytes")) as usize;
    let json_len = u32_at(12);
    let mut json: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).expect("JSON chunk");
    edit(&mut json);
    let mut text = serde_json::to_vec(&json).expect("JSON");
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let bin = &glb[20 + json_len..];
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + text.len() + bin.len()) as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend(bin);
    out
}

#[test]
fn a_draco_primitive_is_read_as_its_stream_says() {
    let dir = tempfile::tempdir().expect("temp dir");
    let glb = std::fs::read(data("BoxTextured-Draco.glb")).expect("glb");
    let opts = ReadOptions { texel_density: 0.25, ..Default::default() };
    let primitive = |j: &mut serde_json::Value| j["meshes"][0]["primitives"][0].take();
    // A primitive that names a strip: the stream's faces are a triangle list all the same.
    let strip = glb_with_json(&glb, |j| {
        let mut p = primitive(j);
        p["mode"] = 5.into();
        j["meshes"][0]["primitives"][0] = p;
    });
    std::fs::write(dir.path().join("strip.glb"), strip).expect("write");
    let (points, _) = read_all(&dir.path().join("strip.glb"), &opts).expect("strip");
    assert_eq!(points.len(), 12 * 91 * 91, "the box's 12 triangles");
    // An attribute the stream does not hold, whose accessor has no data: an error naming the
    // accessor, not texture coordinates of zero (one flat colour).
    let unheld = glb_with_json(&glb, |j| {
        let mut p = primitive(j);
        let held = p["extensions"]["KHR_draco_mesh_compression"]["attributes"].as_object_mut().expect("map");
        held.remove("TEXCOORD_0").expect("TEXCOORD_0 in the stream");
        let accessor = p["attributes"]["TEXCOORD_0"].as_u64().expect("accessor");
        j["meshes"][0]["primitives"][0] = p;
        assert!(j["accessors"][accessor as usize].get("bufferView").is_none());
    });
    std::fs::write(dir.path().join("unheld.glb"), unheld).expect("write");
    let e = read_all(&dir.path().join("unheld.glb"), &opts).expect_err("unheld").to_string();
    assert!(e.contains("accessors[") && e.contains("bufferView"), "{e}");
}

#[test]
fn las_1_0_and_1_1_files_read_like_1_2() {
    // laspy's test cloud written as LAS 1.0, 1.1 and 1.2 with point format 1 (the newest both old
    // versions have: no colour, so intensity is the grey): the same points and greys from each.
    let dir = tempfile::tempdir().expect("temp dir");
    let mut reader = las::Reader::from_path(data("simple.laz")).expect("read simple.laz");
    let original: Vec<las::Point> =
        reader.read_all().expect("points").points().map(|p| p.expect("point")).collect();
    let mut read = Vec::new();
    for minor in [0u8, 1, 2] {
        let path = dir.path().join(format!("v1{minor}.las"));
        let mut header = las::Builder::from((1, minor));
        header.point_format = las::point::Format::new(1).expect("format 1");
        header.transforms = *reader.header().transforms();
        let mut w = las::Writer::from_path(&path, header.into_header().expect("header")).expect("writer");
        for p in &original {
            w.write_point(las::Point { color: None, ..p.clone() }).expect("write");
        }
        w.close().expect("close");
        let version = las::Reader::from_path(&path).expect("reread").header().version();
        assert_eq!((version.major, version.minor), (1, minor));
        let (points, report) =
            read_all(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("1.{minor}: {e}"));
        assert!(report.warnings.is_empty(), "1.{minor}: {:?}", report.warnings);
        assert_eq!(points.len(), original.len(), "1.{minor}");
        read.push(points);
    }
    for (minor, points) in read.iter().enumerate() {
        for (p, q) in points.iter().zip(&original) {
            assert!((p.pos - glam::DVec3::new(q.x, q.y, q.z)).abs().max_element() < 1e-9, "1.{minor}");
        }
        let greys: std::collections::BTreeSet<u8> = points.iter().map(|p| p.color[0]).collect();
        assert!(greys.len() > 4, "1.{minor}: intensity becomes grey: {greys:?}");
        let same = points.iter().zip(&read[2]).all(|(a, b)| a.color == b.color && a.pos == b.pos);
        assert!(same, "1.{minor} reads like 1.2");
    }
}
