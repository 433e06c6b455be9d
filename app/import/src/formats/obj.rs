//! Wavefront OBJ as points: `v` (with optional colour) and `f` (`a/b/c` and negative indices),
//! read in blocks of lines parsed in parallel ([`crate::lines`]); every other statement is
//! ignored.

use super::mesh::Buffered;
use super::ply::color_channel;
use crate::lines::{Stop, Tokens, parse_i64};
use crate::ply;
use crate::source::{InputPoint, ReadError, ReadOptions, ReadReport, Sink};
use glam::{DVec3, Vec3};
use std::io::BufRead;

/// Reads an OBJ stream: `v x y z [r g b]` vertices and `f` faces (for normals). Other statements
/// (`vn`, `vt`, groups, materials, comments, in any encoding) are ignored. Read in blocks of
/// lines parsed in parallel ([`crate::lines`]), visited in order.
pub fn read_obj(
    r: &mut dyn BufRead,
    opts: &ReadOptions,
    sink: &mut dyn Sink,
) -> Result<ReadReport, ReadError> {
    let mut report = ReadReport::default();
    let mut buffered = Buffered::default();
    let mut dropped = 0u64;
    let mut idx = Vec::new();
    let unusable = |l: usize, m: String| ReadError::Unusable(format!("line {l}: {m}"));
    let mut visit = |_: &[u8], parsed: &mut ObjParsed| -> Result<(), ReadError> {
        for piece in &mut parsed.pieces {
            let (mut v, mut f) = (0, 0);
            for st in &piece.stmts {
                match *st {
                    ObjStmt::Vertex { line, n } => {
                        let vals = &piece.values[v..v + n];
                        v += n;
                        report.rows += 1;
                        let (x, y, z) = (vals[0], vals[1], vals[2]);
                        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                            if opts.drop_invalid {
                                dropped += 1;
                                buffered.push_dropped(DVec3::new(x, y, z));
                                continue;
                            }
                            return Err(ReadError::NonFinite {
                                element: "v".into(),
                                row: report.rows,
                                line: Some(line),
                                x,
                                y,
                                z,
                            });
                        }
                        let color = if vals.len() >= 6 {
                            report.has_colors = true;
                            let [r, g, b] = [3, 4, 5].map(|i| color_channel(vals[i], ply::Scalar::F64));
                            [r, g, b, 255]
                        } else {
                            [0; 4]
                        };
                        buffered.points.push(InputPoint {
                            pos: DVec3::new(x, y, z),
                            normal: Vec3::ZERO,
                            color,
                            radius: 0.0,
                            spacing: 0.0,
                        });
                    }
                    ObjStmt::Face { line, n } => {
                        let count = buffered.points.len() as f64;
                        // 1-based, negative = relative to the end.
                        idx.clear();
                        idx.extend(
                            piece.indices[f..f + n]
                                .iter()
                                .map(|&i| if i < 0 { count + i as f64 } else { i as f64 - 1.0 }),
                        );
                        f += n;
                        buffered.add_polygon(&idx).map_err(|m| unusable(line, m))?;
                        report.faces_used += 1;
                    }
                }
            }
            if let Some((line, msg)) = piece.error.take() {
                return Err(unusable(line, msg));
            }
        }
        Ok(())
    };
    crate::lines::read(r, &ObjLines, 0, &mut visit, |stop, at| {
        Err(match stop {
            Stop::Io(e) => ReadError::Io(e),
            Stop::Overlong => {
                unusable(at + 1, format!("longer than {} MiB (binary data?)", crate::lines::MAX_LINE >> 20))
            }
        })
    })?;
    if report.rows == 0 {
        return Err(ReadError::Unusable("the file has 0 vertices ('v' lines)".into()));
    }
    if dropped > 0 {
        report.warnings.push(format!("{dropped} vertex row(s) with non-finite coordinates dropped"));
    }
    if report.rows > opts.face_vertex_limit {
        buffered.tris.clear();
    }
    buffered.finish(&mut report, sink)?;
    Ok(report)
}

/// An OBJ statement the reader uses, with how many numbers it takes from its piece.
#[derive(Clone, Copy)]
pub(crate) enum ObjStmt {
    /// `v`: coordinates (and colour) in `values`.
    Vertex { line: usize, n: usize },
    /// `f`: vertex indices (as written: 1-based or negative) in `indices`.
    Face { line: usize, n: usize },
}

/// The statements of consecutive lines; parsing stops at the first line in error, which is
/// returned once the statements before it are visited.
#[derive(Default)]
pub(crate) struct ObjPiece {
    stmts: Vec<ObjStmt>,
    values: Vec<f64>,
    indices: Vec<i64>,
    error: Option<(usize, String)>,
}

/// A block of an OBJ file parsed: its `v` and `f` lines (byte range, 1-based line), and their
/// statements in pieces.
#[derive(Default)]
pub(crate) struct ObjParsed {
    lines: Vec<(usize, usize, usize)>,
    pieces: Vec<ObjPiece>,
}

/// OBJ as blocks of lines; reading stands at a number of lines.
pub(crate) struct ObjLines;

impl crate::lines::Format for ObjLines {
    type At = usize;
    type Out = ObjParsed;

    fn scan(&self, block: &[u8], mut line: usize, out: &mut ObjParsed) -> usize {
        out.lines.clear();
        for (start, end) in crate::lines::lines(block) {
            line += 1;
            if matches!(Tokens::new(&block[start..end]).next(), Some(b"v" | b"f")) {
                out.lines.push((start, end, line));
            }
        }
        line
    }

    fn parse(&self, block: &[u8], out: &mut ObjParsed) {
        crate::lines::in_pieces(&out.lines, &mut out.pieces, |_, lines, p| {
            p.stmts.clear();
            p.values.clear();
            p.indices.clear();
            p.error = None;
            for &(start, end, line) in lines {
                if let Err(msg) = parse_obj_line(&block[start..end], line, p) {
                    p.error = Some((line, msg));
                    return;
                }
            }
        });
    }
}

pub(crate) fn parse_obj_line(text: &[u8], line: usize, p: &mut ObjPiece) -> Result<(), String> {
    let mut tok = Tokens::new(text);
    let quoted = |t: &[u8]| String::from_utf8_lossy(t).into_owned();
    match tok.next() {
        Some(b"v") => {
            let start = p.values.len();
            while let Some(v) = tok.next_f64() {
                p.values.push(v.map_err(|t| format!("'{}' is not a number", quoted(t)))?);
            }
            let n = p.values.len() - start;
            if n < 3 {
                return Err("vertex with fewer than 3 coordinates".into());
            }
            p.stmts.push(ObjStmt::Vertex { line, n });
        }
        _ => {
            let start = p.indices.len();
            for t in tok {
                let first = t.split(|&b| b == b'/').next().unwrap_or_default();
                let i = parse_i64(first).ok_or_else(|| format!("bad face index '{}'", quoted(t)))?;
                p.indices.push(i);
            }
            p.stmts.push(ObjStmt::Face { line, n: p.indices.len() - start });
        }
    }
    Ok(())
}
