//! The text readers (ASCII PLY and OBJ), which read in blocks of lines parsed in parallel,
//! against the binary PLY reader on the same mesh: every row, across block boundaries, blank
//! lines and CRLF ends; and their errors, which must name the row and line a line-by-line reader
//! would.

use kiosk_import::formats;
use kiosk_import::formats::obj::ObjError;
use kiosk_import::formats::ply::parse::{self as ply, PlyError, Row};
use kiosk_import::source::{self, ReadOptions};
use std::fmt::Write as _;
use std::io::BufReader;

/// A mesh of `n` vertices (float position, uchar colour, int label) and `2 n` triangles, as an
/// ASCII and as a binary little-endian PLY. The ASCII body has blank lines and CRLF line ends
/// here and there, and spans several of the reader's blocks (1 MiB) for n ≥ 40 000.
fn mesh(n: u32) -> (String, Vec<u8>) {
    let head = |format: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n\
             property float z\nproperty uchar red\nproperty int label\nelement face {}\n\
             property list uchar int vertex_indices\nend_header\n",
            2 * n
        )
    };
    let mut ascii = head("ascii");
    let mut bin = head("binary_little_endian").into_bytes();
    for i in 0..n {
        // Coordinates with many digits, tiny and large: `{}` of an f32 reads back exactly.
        let f = i as f32;
        let p = [f * 1.000_123_4e-3, (f * 0.618).sin() * 1.0e4, -f / 7.0];
        let (red, label) = ((i % 256) as u8, i as i32 - 1000);
        let end = if i % 97 == 0 { "\r\n" } else { "\n" };
        let _ = write!(ascii, "{} {} {} {red} {label}{end}", p[0], p[1], p[2]);
        if i % 1001 == 0 {
            ascii.push_str("  \t\n");
        }
        for v in p {
            bin.extend_from_slice(&v.to_le_bytes());
        }
        bin.push(red);
        bin.extend_from_slice(&label.to_le_bytes());
    }
    for i in 0..2 * n {
        let t = [i / 2, (i / 2 + 1) % n, (i / 2 + 2 + i % 2) % n];
        let _ = writeln!(ascii, "3 {} {} {}", t[0], t[1], t[2]);
        bin.push(3);
        for v in t {
            bin.extend_from_slice(&(v as i32).to_le_bytes());
        }
    }
    (ascii, bin)
}

/// A row as (element, row, values, lists).
type BodyRow = (usize, u64, Vec<f64>, Vec<Vec<f64>>);

/// Every row of a body.
fn rows(bytes: &[u8]) -> Result<Vec<BodyRow>, PlyError> {
    let mut r = BufReader::new(bytes);
    let header = ply::read_header(&mut r)?;
    let mut out = Vec::new();
    ply::read_body(&mut r, &header, |ei, ri, row: &Row| {
        // NaN (the value slot of a list) compared by bits.
        let values = row.values.iter().map(|v| if v.is_nan() { -0.0 } else { *v }).collect();
        out.push((ei, ri, values, row.lists.clone()));
        Ok(())
    })?;
    Ok(out)
}

#[test]
fn ascii_rows_equal_binary_rows_across_blocks() {
    let (ascii, bin) = mesh(60_000);
    assert!(ascii.len() > 4 << 20, "the body must span several blocks ({} bytes)", ascii.len());
    let (a, b) = (rows(ascii.as_bytes()).expect("ascii"), rows(&bin).expect("binary"));
    assert_eq!(a.len(), 180_000);
    assert_eq!(a, b);
    // And through the scan reader: the same points, with face normals, either way.
    let opts = crate::common::vertices_only();
    let (pa, ra) = formats::read_ply_bytes(ascii.as_bytes(), &opts).expect("ascii points");
    let (pb, rb) = formats::read_ply_bytes(&bin, &opts).expect("binary points");
    assert_eq!((ra.points, ra.faces_used), (60_000, 120_000));
    assert_eq!((ra.points, ra.faces_used), (rb.points, rb.faces_used));
    assert_eq!(pa, pb);
}

/// Replaces the text of line `line` (1-based) of a file.
fn with_line(text: &str, line: usize, new: &str) -> String {
    let mut lines: Vec<&str> = text.split('\n').collect();
    lines[line - 1] = new;
    lines.join("\n")
}

/// The 1-based file line of vertex row `row` (1-based) of [`mesh`]'s ASCII text.
fn line_of_vertex(text: &str, row: usize) -> usize {
    let header = 11;
    let mut seen = 0;
    for (i, l) in text.split('\n').enumerate().skip(header) {
        if !l.trim().is_empty() {
            seen += 1;
            if seen == row {
                return i + 1;
            }
        }
    }
    panic!("no row {row}");
}

#[test]
fn errors_in_later_blocks_name_their_row_and_line() {
    let (ascii, _) = mesh(60_000);
    let row = 50_001;
    let line = line_of_vertex(&ascii, row);
    let bad = with_line(&ascii, line, "1 2 oops 3 4");
    let e = rows(bad.as_bytes()).expect_err("a bad number").to_string();
    assert_eq!(e, format!("element 'vertex' row {row} (line {line}): property 'z': 'oops' is not a number"));

    // A value out of range in a face row near the end.
    let lines = ascii.split('\n').count();
    let bad = with_line(&ascii, lines - 2, "3 1 2 99999999999");
    let e = rows(bad.as_bytes()).expect_err("out of range").to_string();
    assert!(e.contains(&format!("element 'face' row 119999 (line {})", lines - 2)), "{e}");
    assert!(e.contains("99999999999 out of range for int32"), "{e}");

    // Of two errors, the earlier row's, even when the visit finds it and the parser the later.
    let first = line_of_vertex(&ascii, 30_000);
    let bad = with_line(&with_line(&ascii, first, "nan 0 0 1 1"), line, "1 2 oops 3 4");
    let e = formats::read_ply_bytes(bad.as_bytes(), &crate::common::vertices_only())
        .expect_err("nan")
        .to_string();
    assert!(e.starts_with(&format!("element 'vertex' row 30000 (line {first}): non-finite")), "{e}");
}

#[test]
fn a_truncated_ascii_body_says_how_many_rows_it_has() {
    let (ascii, _) = mesh(60_000);
    // Cut after the first two numbers of a face line about 1 MB before the end: that partial
    // line, without a line end, is the last row and lacks a value.
    let at = ascii.len() - 1_000_003;
    let start = ascii[..at].rfind('\n').expect("a line end") + 1;
    let cut = &ascii[..start + ascii[start..].match_indices(' ').nth(1).expect("two numbers").0];
    let line = cut.lines().count();
    let row = cut.lines().skip(11).filter(|l| !l.trim().is_empty()).count() - 60_000;
    let e = rows(cut.as_bytes()).expect_err("truncated").to_string();
    assert_eq!(
        e,
        format!(
            "element 'face' row {row} (line {line}): missing value for property 'vertex_indices'; the file ends \
             in this line (cut short?)"
        )
    );
    // Cut at a line end: the rows are all there up to it.
    let e = rows(&cut.as_bytes()[..start]).expect_err("truncated").to_string();
    let faces = row - 1;
    assert_eq!(
        e,
        format!("element 'face' row {}: unexpected end of file: {faces} of 120000 rows present", faces + 1)
    );
}

/// Bytes, then a read error (a disk or a network failing mid-file).
struct FailingAfter<'a>(&'a [u8]);

impl std::io::Read for FailingAfter<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.0.is_empty() {
            return Err(std::io::Error::other("the disk went away"));
        }
        let n = buf.len().min(self.0.len()).min(4096);
        buf[..n].copy_from_slice(&self.0[..n]);
        self.0 = &self.0[n..];
        Ok(n)
    }
}

#[test]
fn a_bad_row_before_a_read_error_is_the_error_reported() {
    let (ascii, _) = mesh(60_000);
    let line = line_of_vertex(&ascii, 20_000);
    let bad = with_line(&ascii, line, "1 2 oops 3 4");
    // The read fails ~100 kB after the bad row, in the same 1 MiB block.
    let upto = bad.match_indices('\n').nth(line + 4000).expect("lines").0;
    let mut r = BufReader::new(FailingAfter(&bad.as_bytes()[..upto]));
    let header = ply::read_header(&mut r).expect("header");
    let e = ply::read_body(&mut r, &header, |_, _, _| Ok(())).expect_err("bad row").to_string();
    assert_eq!(e, format!("element 'vertex' row 20000 (line {line}): property 'z': 'oops' is not a number"));
    // Without the bad row, the read error itself, after every row before it was visited.
    let upto = ascii.match_indices('\n').nth(line + 4000).expect("lines").0;
    let mut r = BufReader::new(FailingAfter(&ascii.as_bytes()[..upto]));
    let header = ply::read_header(&mut r).expect("header");
    let mut visited = 0;
    let e = ply::read_body(&mut r, &header, |_, _, _| {
        visited += 1;
        Ok(())
    })
    .expect_err("read error")
    .to_string();
    assert_eq!(e, "read error: the disk went away");
    let whole_lines = ascii[..upto].lines().skip(11).filter(|l| !l.trim().is_empty()).count();
    assert_eq!(visited, whole_lines - 1, "every whole row before the failure, not the partial one");
    // OBJ alike.
    let (obj, _) = obj_and_ply(60_000);
    let text = String::from_utf8_lossy(&obj).into_owned();
    let line = 3 * 20_000 + 4;
    let bad = with_line(&text, line, "v 1 2 oops");
    let upto = bad.match_indices('\n').nth(line + 4000).expect("lines").0;
    let e = formats::obj::read_obj(
        &mut BufReader::new(FailingAfter(&bad.as_bytes()[..upto])),
        &crate::common::vertices_only(),
        &mut |_| Ok(()),
    )
    .expect_err("bad vertex")
    .to_string();
    assert_eq!(e, format!("line {line}: 'oops' is not a number"));
}

#[test]
fn junk_after_the_last_element_is_a_warning_not_a_failure() {
    // A real gzip'd ASCII scan with junk after its gzip data (zero padding from a copy tool): the
    // decoder fails after the last row; every row is there, so the scan loads, with a warning.
    let gz =
        std::fs::read(crate::common::data("scans/stanford-dragon/dragon_vrip_res4.ply.gz")).expect("scan");
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("padded.ply.gz");
    std::fs::write(&path, [&gz[..], &[0u8; 512]].concat()).expect("write");
    let (pts, rep) = formats::read_all(&path, &crate::common::vertices_only()).expect("loads");
    assert_eq!(pts.len(), 5205);
    assert!(rep.warnings.iter().any(|w| w.contains("could not be read")), "{:?}", rep.warnings);
    // Missing rows are still an error, whatever comes after them.
    let cut = dir.path().join("cut.ply.gz");
    std::fs::write(&cut, &gz[..gz.len() / 2]).expect("write");
    let e = formats::read_all(&cut, &crate::common::vertices_only()).expect_err("half a scan").to_string();
    assert!(e.starts_with("read error:"), "{e}");
}

#[test]
fn unicode_whitespace_separates_values_as_before() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n\
               end_header\n0.5\u{a0}1 2\n\u{3000}\n3 4\u{2003}5\n";
    let (pts, _) = formats::read_ply_bytes(ply.as_bytes(), &crate::common::vertices_only()).expect("loads");
    let pos: Vec<[f64; 3]> = pts.iter().map(|p| p.pos.to_array()).collect();
    assert_eq!(pos, [[0.5, 1.0, 2.0], [3.0, 4.0, 5.0]]);
}

#[test]
fn a_line_without_end_is_an_error_not_a_whole_file_in_memory() {
    let (ascii, _) = mesh(10);
    let body = ascii.find("end_header\n").expect("header") + "end_header\n".len();
    let mut bytes = ascii.as_bytes()[..body].to_vec();
    bytes.extend(std::iter::repeat_n(b'7', 65 << 20));
    let e = rows(&bytes).expect_err("overlong").to_string();
    assert_eq!(
        e,
        "element 'vertex' row 1 (line 12): line longer than 64 MiB (binary data in an ASCII body?)"
    );
}

#[test]
fn extra_lines_after_the_last_element_are_counted_across_blocks() {
    let (ascii, _) = mesh(1000);
    let extra = "1 2 3\n".repeat(300_000);
    let text = format!("{ascii}{extra}\n \n");
    let mut r = BufReader::new(text.as_bytes());
    let header = ply::read_header(&mut r).expect("header");
    let warnings = ply::read_body(&mut r, &header, |_, _, _| Ok(())).expect("tolerated");
    assert_eq!(warnings, ["300000 extra line(s) after the last element ignored"]);
}

/// A mesh of `n` vertices (double coordinates) and `2 n` triangles as OBJ (with comments in Latin-1, `vn`/`vt` lines,
/// `a/b/c` and negative indices, CRLF ends here and there) and as a binary PLY.
fn obj_and_ply(n: u32) -> (Vec<u8>, Vec<u8>) {
    let mut obj =
        b"# exported by a scanner \xe9t\xe9 2026 (Latin-1)\r\nmtllib statue.mtl\no statue\n".to_vec();
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty double x\nproperty double y\n\
         property double z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        2 * n
    )
    .into_bytes();
    for i in 0..n {
        // `{}` of an f64 reads back exactly.
        let f = f64::from(i);
        let p = [f * 1.000_123_4e-3, (f * 0.618).sin() * 1.0e4, -f / 7.0];
        let end = if i % 89 == 0 { "\r\n" } else { "\n" };
        obj.extend(format!("v {} {} {}{end}vn 0 0 1\nvt 0.5 0.5\n", p[0], p[1], p[2]).bytes());
        for v in p {
            ply.extend_from_slice(&v.to_le_bytes());
        }
    }
    obj.extend(b"g body\nusemtl marble\n# faces\n");
    for i in 0..2 * n {
        let t = [i / 2, (i / 2 + 1) % n, (i / 2 + 2 + i % 2) % n];
        // Every third face as a/b/c, every fifth with its last index relative to the end.
        let last = if i % 5 == 0 { format!("{}", t[2] as i64 - n as i64) } else { format!("{}", t[2] + 1) };
        let line = if i % 3 == 0 {
            format!("f {0}/{0}/{0} {1}/{1}/{1} {last}\n", t[0] + 1, t[1] + 1)
        } else {
            format!("f {} {} {last}\n", t[0] + 1, t[1] + 1)
        };
        obj.extend(line.bytes());
        ply.push(3);
        for v in t {
            ply.extend_from_slice(&(v as i32).to_le_bytes());
        }
    }
    (obj, ply)
}

fn read_obj(bytes: &[u8], opts: &ReadOptions) -> Result<Vec<source::InputPoint>, String> {
    let mut pts = Vec::new();
    formats::obj::read_obj(&mut BufReader::new(bytes), opts, &mut |p| {
        pts.push(p);
        Ok(())
    })
    .map_err(|e| e.to_string())?;
    Ok(pts)
}

/// The OBJ reader keeps its faces' triangles and applies them once every vertex is read; the
/// PLY reader applies them as they come (the vertices come first and have no normals): the same
/// points, normals, radii and spacings included, bit for bit.
#[test]
fn obj_points_equal_binary_ply_points_across_blocks() {
    let (obj, ply) = obj_and_ply(60_000);
    assert!(obj.len() > 4 << 20, "several blocks ({} bytes)", obj.len());
    let opts = crate::common::vertices_only();
    let from_obj = read_obj(&obj, &opts).expect("obj");
    let (from_ply, rep) = formats::read_ply_bytes(&ply, &opts).expect("ply");
    assert_eq!((rep.points, rep.faces_used), (60_000, 120_000));
    assert_eq!(from_obj.len(), from_ply.len());
    if let Some(i) = (0..from_obj.len()).find(|&i| from_obj[i] != from_ply[i]) {
        panic!("point {i}: {:?} from OBJ, {:?} from PLY", from_obj[i], from_ply[i]);
    }
}

#[test]
fn obj_errors_name_their_line_in_later_blocks() {
    let (obj, _) = obj_and_ply(60_000);
    let text = String::from_utf8_lossy(&obj).into_owned();
    // Line 3 k + 4 is vertex k + 1 (three header lines, then v, vn, vt per vertex).
    let line = 3 * 50_000 + 4;
    let opts = crate::common::vertices_only();
    let bad = with_line(&text, line, "v 1 2 three");
    assert_eq!(
        read_obj(bad.as_bytes(), &opts).expect_err("bad number"),
        format!("line {line}: 'three' is not a number")
    );
    let bad = with_line(&text, line, "v 1 inf 3");
    assert_eq!(
        read_obj(bad.as_bytes(), &opts).expect_err("non-finite"),
        format!("v row 50001 (line {line}): non-finite coordinate (1, inf, 3)")
    );
    let faces = 3 * 60_000 + 4 + 3;
    let bad = with_line(&text, faces + 100_000, "f 1 x/2 3");
    assert_eq!(
        read_obj(bad.as_bytes(), &opts).expect_err("bad index"),
        format!("line {}: bad face index 'x/2'", faces + 100_000)
    );
    // The errors are typed: the line as a number, the material library by its path.
    let bad = with_line(&text, line, "v 1 2 three");
    let e =
        formats::obj::read_obj(&mut BufReader::new(bad.as_bytes()), &opts, &mut |_| Ok(())).expect_err("bad");
    assert!(matches!(e, kiosk_import::ReadError::Obj(ObjError::Line { line: l, .. }) if l == line), "{e:?}");
    let e = formats::obj::read_obj(&mut BufReader::new(&b"# nothing\n"[..]), &opts, &mut |_| Ok(()))
        .expect_err("empty");
    assert!(matches!(e, kiosk_import::ReadError::Obj(ObjError::NoVertices)), "{e:?}");
    // A dropped vertex keeps its place: the faces after it still find theirs.
    let bad = with_line(&text, line, "v nan 2 3");
    let pts = read_obj(bad.as_bytes(), &ReadOptions { drop_invalid: true, ..opts }).expect("dropped");
    assert_eq!(pts.len(), 59_999);
}

#[test]
fn faces_before_their_vertices_are_checked_once_every_vertex_is_read() {
    // A face element may come first: its indices can only be checked at the end.
    let ply = |face: &str| {
        format!(
            "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n\
             element vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n\
             {face}\n0 0 0\n1 0 0\n0 1 0\n"
        )
    };
    let (pts, rep) =
        formats::read_ply_bytes(ply("3 0 1 2").as_bytes(), &crate::common::vertices_only()).expect("loads");
    assert_eq!((pts.len(), rep.faces_used), (3, 1));
    for p in &pts {
        assert_eq!(p.normal.to_array(), [0.0, 0.0, 1.0], "the face's normal at {:?}", p.pos);
    }
    let err = formats::read_ply_bytes(ply("3 0 1 5").as_bytes(), &crate::common::vertices_only())
        .expect_err("index out of range")
        .to_string();
    assert!(err.contains("a face refers to vertex 5 but the file has 3 vertices"), "{err}");
}

#[test]
fn a_ply_without_positions_is_a_typed_error_naming_what_it_lacks() {
    let read = |text: &str| {
        formats::read_ply_bytes(text.as_bytes(), &ReadOptions::default()).expect_err("no positions")
    };
    let e =
        read("ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n");
    assert!(
        matches!(&e, kiosk_import::ReadError::Ply(PlyError::NoVertexElement { elements }) if elements == &["face"]),
        "{e:?}"
    );
    assert_eq!(e.to_string(), "no 'vertex' element (elements: face)");
    let e = read(
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
    );
    assert!(
        matches!(&e, kiosk_import::ReadError::Ply(PlyError::NoPositions { missing }) if missing == &["z"]),
        "{e:?}"
    );
    assert_eq!(e.to_string(), "element 'vertex' has no scalar property z: it holds no 3D positions");
    let e = read(
        "ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
    );
    assert!(matches!(e, kiosk_import::ReadError::Ply(PlyError::NoVertices)), "{e:?}");
}
