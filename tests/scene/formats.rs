//! Survey formats (LAS/LAZ, E57) read from real files of public test suites
//! (`tests/data/formats/SOURCES.md`), and the formats the importer refuses, by content.

use kiosk_import::ReadOptions;
use kiosk_import::source::read_all;
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
    let src = data("simple.laz");
    let mut reader = las::Reader::from_path(&src).expect("read");
    let original: Vec<las::Point> =
        reader.read_all().expect("points").points().map(|p| p.expect("point")).collect();
    let shift = [1.0e6, 2.0e6, 5.0e2];
    let mut header = las::Builder::from((1, 2));
    header.point_format = *reader.header().point_format();
    header.transforms = las::Vector {
        x: las::Transform { scale: 0.001, offset: shift[0] },
        y: las::Transform { scale: 0.001, offset: shift[1] },
        z: las::Transform { scale: 0.001, offset: shift[2] },
    };
    let far = dir.path().join("far.las");
    let near = dir.path().join("near.las");
    for (path, d) in [(&far, shift), (&near, [0.0; 3])] {
        let mut h = header.clone();
        h.transforms.x.offset = d[0];
        h.transforms.y.offset = d[1];
        h.transforms.z.offset = d[2];
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
    let (a, _) = read_all(&far, &ReadOptions::default()).expect("far");
    let (b, _) = read_all(&near, &ReadOptions::default()).expect("near");
    assert_eq!(a.len(), original.len());
    for (p, q) in a.iter().zip(&b) {
        let d = p.pos - q.pos - glam::DVec3::from_array(shift);
        assert!(d.abs().max_element() <= 1.0e-3, "{d:?}");
    }
    let store = |scan: &Path, out: &str| {
        let out = dir.path().join(out);
        kiosk::import::import(scan, &out, &kiosk::import::ImportOptions::default()).expect("import");
        kiosk::open_store(&out).expect("store")
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
    assert!(e.contains("a glTF model") && e.contains("LAS and LAZ") && e.contains("E57"), "{e}");
    let truncated = dir.path().join("cut.laz");
    let bytes = std::fs::read(data("simple.laz")).expect("laz");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).expect("write");
    let e = read_all(&truncated, &ReadOptions::default()).expect_err("truncated LAZ").to_string();
    assert!(e.starts_with("LAS: "), "{e}");
}
