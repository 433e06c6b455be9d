//! ASCII bodies: every row of every element is one line.
//!
//! The body is read in blocks of whole lines ([`crate::lines`]). The lines of a block are
//! assigned to their element and row in one cheap scan, then parsed and converted in pieces in
//! parallel; the pieces' conversions are taken in order. Errors are those a line-by-line reader
//! would give, in the same order: a row is taken only if every row before it parsed and
//! converted.

use super::{Convert, Element, Header, PlyError, PropKind, Row, Scalar, short};
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

/// The rows of consecutive lines, each parsed into `row` and converted into `out`. Parsing stops
/// at the first line in error, which is kept to be returned once the rows before it are taken.
#[derive(Default)]
struct Piece<O> {
    /// The row being parsed, and its element.
    row: Row,
    row_ei: Option<usize>,
    out: O,
    error: Option<PlyError>,
}

/// A block parsed: its lines that hold rows, and their conversions in pieces.
struct Parsed<O> {
    lines: Vec<RowLine>,
    pieces: Vec<Piece<O>>,
}

impl<O> Default for Parsed<O> {
    fn default() -> Self {
        Self { lines: Vec::new(), pieces: Vec::new() }
    }
}

/// The body's lines as rows of its elements, converted by `conv`.
struct Body<'a, C> {
    els: &'a [Element],
    conv: &'a C,
}

impl<C: Convert> lines::Format for Body<'_, C> {
    type At = Cursor;
    type Out = Parsed<C::Out>;

    /// Assigns the block's non-blank lines to rows.
    fn scan(&self, block: &[u8], mut cursor: Cursor, p: &mut Self::Out) -> Cursor {
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

    /// Parses and converts the rows in pieces on the pool.
    fn parse(&self, block: &[u8], p: &mut Self::Out) {
        lines::in_pieces(&p.lines, &mut p.pieces, |ls, piece| {
            parse_piece(block, ls, self.els, self.conv, piece)
        });
    }
}

/// Reads the rows of every element of an ASCII body, converting each with `conv` and passing
/// the conversions of each piece to `take` in order. Returns warnings: non-blank lines after
/// the last element, and input that could not be read after it (junk after gzip data, say),
/// which a line-by-line reader would have stopped at.
pub(super) fn read_rows<C: Convert>(
    r: &mut (impl BufRead + ?Sized),
    header: &Header,
    conv: &C,
    take: &mut impl FnMut(&mut C::Out) -> Result<(), PlyError>,
) -> Result<Vec<String>, PlyError> {
    let els = &header.elements;
    let mut start = Cursor { ei: 0, ri: 0, line: header.lines, extra: 0 };
    start.settle(els);
    let mut warnings = Vec::new();
    let end = lines::read(
        r,
        &Body { els, conv },
        start,
        |_, parsed| take_block(parsed, take),
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

fn parse_piece<C: Convert>(
    block: &[u8],
    lines: &[RowLine],
    els: &[Element],
    conv: &C,
    p: &mut Piece<C::Out>,
) {
    conv.clear(&mut p.out);
    p.error = None;
    for l in lines {
        let el = &els[l.ei];
        if p.row_ei != Some(l.ei) {
            p.row_ei = Some(l.ei);
            p.row.size_for(el);
        }
        let text = &block[l.start..l.end];
        let parsed = parse_line(text, el, &mut p.row).map_err(|msg| {
            let msg =
                if std::str::from_utf8(text).is_err() { "line is not valid UTF-8 text".into() } else { msg };
            PlyError::Row { element: el.name.clone(), row: l.ri + 1, line: Some(l.line), msg }
        });
        if let Err(e) = parsed.and_then(|()| conv.convert(l.ei, l.ri, &p.row, &mut p.out)) {
            p.error = Some(match e {
                PlyError::Row { element, row, line: None, msg } => {
                    PlyError::Row { element, row, line: Some(l.line), msg }
                }
                other => other,
            });
            return;
        }
    }
}

/// Takes the conversions of a block's pieces in order; returns the first parse, conversion or
/// take error.
fn take_block<O>(
    parsed: &mut Parsed<O>,
    take: &mut impl FnMut(&mut O) -> Result<(), PlyError>,
) -> Result<(), PlyError> {
    for piece in &mut parsed.pieces {
        take(&mut piece.out)?;
        if let Some(e) = piece.error.take() {
            return Err(e);
        }
    }
    Ok(())
}

/// Parses a line into `row`, a row of `el`.
fn parse_line(line: &[u8], el: &Element, row: &mut Row) -> Result<(), String> {
    let mut tok = Tokens::new(line);
    for (pi, p) in el.props.iter().enumerate() {
        match p.kind {
            PropKind::Scalar(t) => row.values[pi] = parse_value(&mut tok, t, &p.name)?,
            PropKind::List { count, item } => {
                let n = parse_value(&mut tok, count, &p.name)?;
                if n < 0.0 {
                    return Err(format!("property '{}': negative list length {n}", p.name));
                }
                let list = &mut row.lists[pi];
                list.clear();
                for _ in 0..n as u64 {
                    list.push(parse_value(&mut tok, item, &p.name)?);
                }
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
