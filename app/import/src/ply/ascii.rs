//! ASCII bodies: every row of every element is one line.
//!
//! The body is read in blocks of whole lines ([`crate::lines`]). The lines of a block are
//! assigned to their element and row in one cheap scan, then parsed in pieces in parallel; the
//! rows are visited in order. Errors are those a line-by-line reader would give, in the same
//! order: a row is visited only if every row before it parsed and was visited.

use super::{Element, Header, PlyError, PropKind, Row, Scalar, short};
use crate::lines::{self, Stop, Tokens};
use std::io::BufRead;

/// Where reading stands between blocks.
#[derive(Clone, Copy, Debug)]
struct Cursor {
    /// Element of the next row (the number of elements once every row is read).
    ei: usize,
    /// Row of that element.
    ri: u64,
    /// Lines of the file before the next line (header included).
    line: usize,
    /// Non-blank lines after the last element.
    extra: usize,
}

impl Cursor {
    /// Moves past elements whose rows are all read, elements without rows, and elements without
    /// properties (whose rows would be empty lines, which are skipped as blank: there is nothing
    /// to read, however many rows the header claims).
    fn settle(&mut self, els: &[Element]) {
        while self.ei < els.len() && (self.ri == els[self.ei].count || els[self.ei].props.is_empty()) {
            self.ei += 1;
            self.ri = 0;
        }
    }
}

/// A line of a block that holds a row.
#[derive(Clone, Copy, Debug)]
struct RowLine {
    start: usize,
    end: usize,
    ei: usize,
    ri: u64,
    /// 1-based line of the file.
    line: usize,
}

/// The rows parsed from consecutive lines, flat: each row's values (NaN for lists), and the items
/// of its lists one after the other (`list_ends` closes each list). Parsing stops at the first
/// line in error, which is kept to be returned once the rows before it are visited.
#[derive(Default)]
struct Piece {
    rows: usize,
    values: Vec<f64>,
    items: Vec<f64>,
    list_ends: Vec<usize>,
    error: Option<PlyError>,
}

/// A block parsed: its lines that hold rows, and their values in pieces.
#[derive(Default)]
struct Parsed {
    lines: Vec<RowLine>,
    pieces: Vec<Piece>,
}

/// The body's lines as rows of its elements.
struct Body<'a> {
    els: &'a [Element],
}

impl lines::Format for Body<'_> {
    type At = Cursor;
    type Out = Parsed;

    /// Assigns the block's non-blank lines to rows.
    fn scan(&self, block: &[u8], mut cursor: Cursor, p: &mut Parsed) -> Cursor {
        let els = self.els;
        p.lines.clear();
        for (start, end) in lines::lines(block) {
            cursor.line += 1;
            if lines::is_blank(&block[start..end]) {
                continue;
            }
            if cursor.ei < els.len() {
                p.lines.push(RowLine { start, end, ei: cursor.ei, ri: cursor.ri, line: cursor.line });
                cursor.ri += 1;
                cursor.settle(els);
            } else {
                cursor.extra += 1;
            }
        }
        cursor
    }

    /// Parses the rows in pieces on the pool.
    fn parse(&self, block: &[u8], p: &mut Parsed) {
        lines::in_pieces(&p.lines, &mut p.pieces, |ls, piece| parse_piece(block, ls, self.els, piece));
    }
}

/// Reads the rows of every element of an ASCII body, calling `visit` for each in order. Returns
/// warnings: non-blank lines after the last element, and input that could not be read after it
/// (junk after gzip data, say), which a line-by-line reader would have stopped at.
pub(super) fn read_rows(
    r: &mut (impl BufRead + ?Sized),
    header: &Header,
    visit: &mut impl FnMut(usize, u64, &Row) -> Result<(), PlyError>,
) -> Result<Vec<String>, PlyError> {
    let els = &header.elements;
    let mut start = Cursor { ei: 0, ri: 0, line: header.lines, extra: 0 };
    start.settle(els);
    let mut row = Row::default();
    let mut row_ei = usize::MAX;
    let mut warnings = Vec::new();
    let end = lines::read(
        r,
        &Body { els },
        start,
        |_, parsed| visit_block(parsed, els, &mut row, &mut row_ei, visit),
        |stop, at| {
            if let Some(el) = els.get(at.ei) {
                return Err(block_error(stop, el, at));
            }
            let why = match stop {
                Stop::Io(e) => e.to_string(),
                Stop::Overlong => format!("a line longer than {} MiB", lines::MAX_LINE >> 20),
            };
            warnings.push(format!("input after line {} could not be read ({why}); ignored", at.line));
            Ok(at)
        },
    )?;
    if end.ei < els.len() {
        return Err(super::unexpected_end(&els[end.ei], end.ri));
    }
    if end.extra > 0 {
        warnings.insert(0, format!("{} extra line(s) after the last element ignored", end.extra));
    }
    Ok(warnings)
}

/// The error of a failed read after the rows before it, in element `el` (`at`: where reading
/// stands).
fn block_error(e: Stop, el: &Element, at: Cursor) -> PlyError {
    match e {
        Stop::Io(e) => PlyError::Io(e),
        Stop::Overlong => PlyError::Row {
            element: el.name.clone(),
            row: at.ri + 1,
            line: Some(at.line + 1),
            msg: format!("line longer than {} MiB (binary data in an ASCII body?)", lines::MAX_LINE >> 20),
        },
    }
}

fn parse_piece(block: &[u8], lines: &[RowLine], els: &[Element], p: &mut Piece) {
    p.rows = 0;
    p.values.clear();
    p.items.clear();
    p.list_ends.clear();
    p.error = None;
    for l in lines {
        let el = &els[l.ei];
        let text = &block[l.start..l.end];
        if let Err(msg) = parse_line(text, el, p) {
            let msg =
                if std::str::from_utf8(text).is_err() { "line is not valid UTF-8 text".into() } else { msg };
            p.error =
                Some(PlyError::Row { element: el.name.clone(), row: l.ri + 1, line: Some(l.line), msg });
            return;
        }
        p.rows += 1;
    }
}

/// Visits the parsed rows of a block in order; returns the first parse or visit error.
fn visit_block(
    parsed: &mut Parsed,
    els: &[Element],
    row: &mut Row,
    row_ei: &mut usize,
    visit: &mut impl FnMut(usize, u64, &Row) -> Result<(), PlyError>,
) -> Result<(), PlyError> {
    let mut lines = parsed.lines.iter();
    for piece in &mut parsed.pieces {
        let (mut v, mut l, mut item) = (0, 0, 0);
        for rl in lines.by_ref().take(piece.rows) {
            let el = &els[rl.ei];
            if *row_ei != rl.ei {
                *row_ei = rl.ei;
                row.values.clear();
                row.values.resize(el.props.len(), f64::NAN);
                row.lists.resize_with(el.props.len(), Vec::new);
            }
            row.values.copy_from_slice(&piece.values[v..v + el.props.len()]);
            v += el.props.len();
            for (pi, p) in el.props.iter().enumerate() {
                if let PropKind::List { .. } = p.kind {
                    let end = piece.list_ends[l];
                    l += 1;
                    row.lists[pi].clear();
                    row.lists[pi].extend_from_slice(&piece.items[item..end]);
                    item = end;
                }
            }
            visit(rl.ei, rl.ri, row).map_err(|e| match e {
                PlyError::Row { element, row, line: None, msg } => {
                    PlyError::Row { element, row, line: Some(rl.line), msg }
                }
                other => other,
            })?;
        }
        if let Some(e) = piece.error.take() {
            return Err(e);
        }
    }
    Ok(())
}

fn parse_line(line: &[u8], el: &Element, out: &mut Piece) -> Result<(), String> {
    let mut tok = Tokens::new(line);
    for p in &el.props {
        match p.kind {
            PropKind::Scalar(t) => out.values.push(parse_value(&mut tok, t, &p.name)?),
            PropKind::List { count, item } => {
                out.values.push(f64::NAN);
                let n = parse_value(&mut tok, count, &p.name)?;
                if n < 0.0 {
                    return Err(format!("property '{}': negative list length {n}", p.name));
                }
                for _ in 0..n as u64 {
                    let v = parse_value(&mut tok, item, &p.name)?;
                    out.items.push(v);
                }
                out.list_ends.push(out.items.len());
            }
        }
    }
    if tok.next().is_some() {
        return Err(format!("more values than the {} properties declared", el.props.len()));
    }
    Ok(())
}

/// The value of property `name` of type `ty` from the next token (inlined into the row loop:
/// the errors are made out of line).
#[inline(always)]
fn parse_value(tok: &mut Tokens<'_>, ty: Scalar, name: &str) -> Result<f64, String> {
    match ty.range() {
        Some((lo, hi)) => match tok.next_int() {
            Some(Ok(v)) if (lo..=hi).contains(&(v as f64)) => Ok(v as f64),
            Some(Ok(v)) => Err(out_of_range(v, ty, name)),
            Some(Err(t)) => Err(not_a(t, "an integer", name)),
            None => Err(missing(name)),
        },
        None => match tok.next_f64() {
            Some(Ok(v)) if ty == Scalar::F32 => Ok(f64::from(v as f32)),
            Some(Ok(v)) => Ok(v),
            Some(Err(t)) => Err(not_a(t, "a number", name)),
            None => Err(missing(name)),
        },
    }
}

#[cold]
fn missing(name: &str) -> String {
    format!("missing value for property '{name}'")
}

#[cold]
fn out_of_range(v: i64, ty: Scalar, name: &str) -> String {
    format!("property '{name}': {v} out of range for {}", ty.name())
}

#[cold]
fn not_a(t: &[u8], what: &str, name: &str) -> String {
    format!("property '{name}': '{}' is not {what}", short(&String::from_utf8_lossy(t)))
}
