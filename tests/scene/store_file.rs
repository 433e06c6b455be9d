//! The store file: versioned, checksummed, and a clear error when truncated or corrupted.

use crate::common::{self, small_nodes};
use kiosk_core::StoreError;

fn store_bytes() -> Vec<u8> {
    let pts = common::read_vertices("scans/stanford-bunny/bun_zipper_res3.ply");
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("m.kstore");
    let mut b = kiosk_import::Builder::new(small_nodes(), dir.path()).expect("params");
    for p in pts {
        b.push(p).expect("push");
    }
    b.finish(&out, &mut |_| {}).expect("build");
    std::fs::read(&out).expect("read back")
}

fn open(bytes: &[u8]) -> anyhow::Result<kiosk_content::MappedStore> {
    let dir = tempfile::tempdir()?;
    let p = dir.path().join("x.kstore");
    std::fs::write(&p, bytes)?;
    kiosk_content::open_store(&p)
}

fn store_error(bytes: &[u8]) -> StoreError {
    let e = open(bytes).expect_err("must fail");
    e.downcast_ref::<StoreError>().cloned().unwrap_or_else(|| panic!("not a store error: {e:#}"))
}

#[test]
fn a_good_store_opens_and_verifies() {
    let bytes = store_bytes();
    let s = open(&bytes).expect("opens");
    for id in 0..s.nodes().len() as u32 {
        s.verify_node(id).expect("node verifies");
    }
    assert_eq!(s.header().leaf_point_count, 1889);
}

#[test]
fn truncated_store_is_a_clear_error() {
    let bytes = store_bytes();
    for cut in [bytes.len() - 1, bytes.len() / 2, 100, 8, 0] {
        let e = store_error(&bytes[..cut]);
        assert!(matches!(e, StoreError::Truncated { .. }), "cut at {cut}: {e}");
        assert!(e.to_string().starts_with("store truncated"), "{e}");
    }
    // A short file that is no store at all (a text named .kstore) says so, not "truncated".
    assert_eq!(store_error(b"hello\n"), StoreError::BadMagic);
}

#[test]
fn corrupted_index_or_header_is_a_clear_error() {
    let bytes = store_bytes();
    let header: kiosk_core::StoreHeader =
        bytemuck::pod_read_unaligned(&bytes[..kiosk_core::StoreHeader::LEN]);
    let mut b = bytes.clone();
    b[header.index_offset as usize + 20] ^= 0x40;
    assert_eq!(store_error(&b), StoreError::Checksum { what: "node index".into() });
    let mut b = bytes.clone();
    b[20] ^= 1; // inside the origin
    assert_eq!(store_error(&b), StoreError::Checksum { what: "header".into() });
    let mut b = bytes.clone();
    b[0] = b'X';
    assert_eq!(store_error(&b), StoreError::BadMagic);
    let mut b = bytes.clone();
    b[8] = 9;
    assert_eq!(store_error(&b), StoreError::Version { found: 9 });
}

#[test]
fn corrupted_node_data_is_found_by_verification() {
    let bytes = store_bytes();
    let s = open(&bytes).expect("opens");
    let off = s.node(0).points_offset as usize + 5;
    let mut b = bytes.clone();
    b[off] ^= 0x10;
    let s = open(&b).expect("opening reads only the index");
    assert_eq!(s.verify_node(0), Err(StoreError::Checksum { what: "node 0 data".into() }));
    assert!(s.verify_node(1).is_ok());
}

#[test]
fn import_takes_a_spacing_stride_and_refuses_one_out_of_range() {
    // A range scan with normals and no faces: every spacing is estimated (a mesh brings its own
    // from its faces, and the stride has nothing to do).
    let radii =
        import_takes_a_stride("--spacing-stride", "bun045.open3d_pcd_normals_binary.ply", 8, 4, 17, |s| {
            s.radius
        });
    assert!(radii.iter().flatten().all(|r| *r > 0.0));
}

#[test]
fn import_takes_a_normal_stride_and_refuses_one_out_of_range() {
    // The same scan without normals (a range grid, no faces): every normal is estimated, and
    // shared only in leaves whose normals agree (a few in a hundred on this noisy scan).
    // 8 would leave a leaf of 8 samples one normal, nothing to compare it with.
    import_takes_a_stride("--normal-stride", "bun045.pcl_pcd2ply_binary_rangegrid.ply", 4, 50, 8, |s| {
        s.normal().x
    });
}

/// Imports a tool export of the corpus with `flag` at 1 and `stride`: the same samples in the
/// same order, `what` of more than one in `one_in` of them shared from a neighbour at `stride`,
/// none lost; 0 and `too_large` are refused with a message that names the flag, and no store is
/// left. Returns `what` of the leaves' samples at 1 and at `stride`.
fn import_takes_a_stride(
    flag: &str,
    file: &str,
    stride: usize,
    one_in: usize,
    too_large: usize,
    what: fn(&kiosk_core::scene::splat::Splat) -> f32,
) -> Vec<Vec<f32>> {
    let dir = tempfile::tempdir().expect("temp dir");
    let scan = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/ply-corpus/tool-exports")
        .join(file);
    let import = |stride: &str, out: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
            .args(["import", "--quiet", flag, stride])
            .arg(&scan)
            .arg("-o")
            .arg(dir.path().join(out))
            .output()
            .expect("run kiosk")
    };
    let mut values = Vec::new();
    for stride in ["1".to_string(), stride.to_string()] {
        let stride = stride.as_str();
        let o = import(stride, &format!("s{stride}.kstore"));
        assert!(o.status.success(), "{flag} {stride}: {}", String::from_utf8_lossy(&o.stderr));
        let store = kiosk_content::open_store(&dir.path().join(format!("s{stride}.kstore"))).expect("store");
        let leaves: Vec<f32> = (0..store.nodes().len() as u32)
            .filter(|&id| store.node(id).is_leaf())
            .flat_map(|id| store.splats(id).iter().map(what).collect::<Vec<_>>())
            .collect();
        assert!(leaves.iter().all(|r| r.is_finite()), "{flag} {stride}");
        values.push(leaves);
    }
    assert_eq!(values[0].len(), values[1].len(), "{flag}");
    let differ = values[0].iter().zip(&values[1]).filter(|(a, b)| a != b).count();
    assert!(differ > values[0].len() / one_in, "{flag}: only {differ} of {} differ", values[0].len());
    for bad in ["0".to_string(), too_large.to_string()] {
        let bad = bad.as_str();
        let o = import(bad, "bad.kstore");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(&flag[2..]), "{flag} {bad}: {err}");
        assert!(!dir.path().join("bad.kstore").exists());
    }
    values
}

/// What a curator sees when a scan is broken: the file, then the element, row and line, once
/// (the error is not repeated as its own cause), and no store.
#[test]
fn import_of_a_broken_scan_names_file_row_and_line_once() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scan = dir.path().join("broken.ply");
    std::fs::write(
        &scan,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         end_header\n0 0 0\n1 0 0\n0 1 oops\n",
    )
    .expect("write");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .args(["import", "--quiet"])
        .arg(&scan)
        .arg("-o")
        .arg(dir.path().join("broken.kstore"))
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("run kiosk");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("broken.ply"), "{err}");
    let what = "element 'vertex' row 3 (line 10): property 'z': 'oops' is not a number";
    assert_eq!(err.matches(what).count(), 1, "{err}");
    assert!(!dir.path().join("broken.kstore").exists());
}

/// A store whose checksums were recomputed after its values were changed (crafted, or written
/// by a broken tool): the values themselves are checked.
#[test]
fn crafted_values_with_valid_checksums_are_refused() {
    use kiosk_core::scene::store::crc;
    use kiosk_core::{NodeRecord, StoreHeader};
    let bytes = store_bytes();
    let header: StoreHeader = bytemuck::pod_read_unaligned(&bytes[..StoreHeader::LEN]);
    let reseal = |b: &mut Vec<u8>, h: StoreHeader| {
        let h = h.seal();
        b[..StoreHeader::LEN].copy_from_slice(bytemuck::bytes_of(&h));
    };
    let corrupt = |b: &[u8]| match store_error(b) {
        StoreError::Corrupt(why) => why,
        StoreError::BadNode { why, .. } => why,
        e => panic!("not a value error: {e}"),
    };
    // A NaN origin.
    let mut b = bytes.clone();
    reseal(&mut b, StoreHeader { origin: [f64::NAN, 0.0, 0.0], ..header });
    assert!(corrupt(&b).contains("origin"));
    // The root's box stretched to ±3e38, with the index checksum recomputed.
    let size = std::mem::size_of::<NodeRecord>();
    let at = header.index_offset as usize + header.root as usize * size;
    let mut root: NodeRecord = bytemuck::pod_read_unaligned(&b[at..at + size]);
    root.bbox_min = [-3e38; 3];
    root.bbox_max = [3e38; 3];
    let mut b = bytes.clone();
    b[at..at + size].copy_from_slice(bytemuck::bytes_of(&root));
    let index_len = header.node_count as usize * size;
    let index_crc = crc(&b[header.index_offset as usize..header.index_offset as usize + index_len]);
    reseal(&mut b, StoreHeader { index_crc, ..header });
    assert!(corrupt(&b).contains("beyond"), "{}", corrupt(&b));
    // A leaf's splat moved out of its box, with the node's checksum recomputed: `verify` finds it.
    let s = open(&bytes).expect("opens");
    let leaf = (0..s.nodes().len() as u32).find(|&id| s.node(id).is_leaf()).expect("a leaf");
    let node = *s.node(leaf);
    drop(s);
    let mut b = bytes.clone();
    let p = node.points_offset as usize;
    b[p..p + 4].copy_from_slice(&(node.bbox_max[0] + 1.0).to_le_bytes());
    let dir = tempfile::tempdir().expect("tmp");
    let path = dir.path().join("moved.kstore");
    std::fs::write(&path, &b).expect("write");
    let crafted = kiosk_content::open_store(&path).expect("the index is untouched");
    let mut h = crc32fast::Hasher::new();
    h.update(bytemuck::cast_slice(crafted.splats(leaf)));
    h.update(bytemuck::cast_slice(crafted.boxes(leaf)));
    let data_crc = h.finalize();
    drop(crafted);
    let at = header.index_offset as usize + leaf as usize * size;
    let mut rec: NodeRecord = bytemuck::pod_read_unaligned(&b[at..at + size]);
    rec.data_crc = data_crc;
    b[at..at + size].copy_from_slice(bytemuck::bytes_of(&rec));
    let index_crc = crc(&b[header.index_offset as usize..header.index_offset as usize + index_len]);
    reseal(&mut b, StoreHeader { index_crc, ..header });
    std::fs::write(&path, &b).expect("write");
    let crafted = kiosk_content::open_store(&path).expect("opens: only verification reads node data");
    let e = crafted.verify_node(leaf).expect_err("verify checks values");
    assert!(e.to_string().contains("outside the node's bounding box"), "{e}");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_kiosk"))
        .arg("verify")
        .arg(&path)
        .output()
        .expect("run");
    assert!(!o.status.success(), "kiosk verify fails on it");
}
