//! ASCII bodies: every row of every element is one line.
//!
//! The body is read in blocks of whole lines. The lines of a block are assigned to their element
//! and row in one cheap scan, then parsed in parallel (pieces of consecutive lines on the rayon
//! pool) on a thread of its own while the reading thread inflates and reads the next block and
//! visits the rows of the block before, in order. Errors are those a line-by-line reader would
//! give, in the same order: a row is visited only if every row before it parsed and was visited.

use super::{Element, Header, PlyError, PropKind, Row, Scalar, short};
use rayon::prelude::*;
use std::io::BufRead;

/// Bytes read per block (whole lines: a line longer than this grows its block).
const BLOCK: usize = 1 << 20;
/// A longer line is an error (binary data in an ASCII body), not a reason to read the whole file.
const MAX_LINE: usize = 64 << 20;
/// Lines parsed by one task of the pool.
const PIECE: usize = 8192;

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
    /// Moves past elements whose rows are all read (and elements without rows).
    fn settle(&mut self, els: &[Element]) {
        while self.ei < els.len() && self.ri == els[self.ei].count {
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

/// A block parsed: its lines, their rows, and the cursor after it. Its buffers are reused by
/// the block after next (fresh pages cost more than the parse).
#[derive(Default)]
struct Parsed {
    block: Vec<u8>,
    lines: Vec<RowLine>,
    pieces: Vec<Piece>,
    after: Option<Cursor>,
}

/// Why no block was read.
enum BlockErr {
    Io(std::io::Error),
    /// No line end within [`MAX_LINE`] bytes.
    Overlong,
}

/// Reads the rows of every element of an ASCII body, calling `visit` for each in order. Returns
/// the number of non-blank lines after the last element.
pub(super) fn read_rows(
    r: &mut (impl BufRead + ?Sized),
    header: &Header,
    visit: &mut impl FnMut(usize, u64, &Row) -> Result<(), PlyError>,
) -> Result<usize, PlyError> {
    let els = &header.elements;
    let mut cursor = Cursor { ei: 0, ri: 0, line: header.lines, extra: 0 };
    cursor.settle(els);
    let mut carry = Vec::new();
    let mut row = Row::default();
    let mut row_ei = usize::MAX;
    std::thread::scope(|s| {
        // Block k is parsed on a thread of its own while block k − 1 is visited and block k + 1
        // read (and inflated) here.
        let mut spare = Parsed::default();
        let mut read = next_block(r, &mut carry, std::mem::take(&mut spare.block));
        let mut pending: Option<Parsed> = None;
        loop {
            let parsing = match read {
                Ok(block) => block.map(|b| {
                    let (at, buffers) = (cursor, std::mem::take(&mut spare));
                    s.spawn(move || parse_block(Parsed { block: b, ..buffers }, els, at))
                }),
                Err(e) => {
                    if let Some(mut done) = pending.take() {
                        visit_block(&mut done, els, &mut row, &mut row_ei, visit)?;
                    }
                    return Err(block_error(e, els, cursor));
                }
            };
            if let Some(mut done) = pending.take() {
                visit_block(&mut done, els, &mut row, &mut row_ei, visit)?;
                spare = done;
            }
            let Some(parsing) = parsing else { return Ok(()) };
            read = next_block(r, &mut carry, std::mem::take(&mut spare.block));
            let parsed = parsing
                .join()
                .map_err(|_| PlyError::Io(std::io::Error::other("the ASCII parser thread panicked")))?;
            cursor = parsed.after.unwrap_or(cursor);
            pending = Some(parsed);
        }
    })?;
    if cursor.ei < els.len() {
        let el = &els[cursor.ei];
        return Err(PlyError::Row {
            element: el.name.clone(),
            row: cursor.ri + 1,
            line: None,
            msg: format!("unexpected end of file: {} of {} rows present", cursor.ri, el.count),
        });
    }
    Ok(cursor.extra)
}

/// The error of a failed read after the rows before it (`at`: where reading stands).
fn block_error(e: BlockErr, els: &[Element], at: Cursor) -> PlyError {
    match e {
        BlockErr::Io(e) => PlyError::Io(e),
        BlockErr::Overlong => {
            let msg = format!("line longer than {} MiB (binary data in an ASCII body?)", MAX_LINE >> 20);
            match els.get(at.ei) {
                Some(el) => {
                    PlyError::Row { element: el.name.clone(), row: at.ri + 1, line: Some(at.line + 1), msg }
                }
                None => PlyError::Io(std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    format!("line {}: {msg}", at.line + 1),
                )),
            }
        }
    }
}

/// Reads the next block of whole lines into `buf` (the bytes after its last line end wait in
/// `carry` for the next block), or `None` at the end of the input.
fn next_block(
    r: &mut (impl BufRead + ?Sized),
    carry: &mut Vec<u8>,
    mut buf: Vec<u8>,
) -> Result<Option<Vec<u8>>, BlockErr> {
    buf.clear();
    buf.append(carry);
    let mut searched = 0;
    loop {
        let old = buf.len();
        let want = BLOCK.max(old);
        buf.resize(old + want, 0);
        let got = crate::read_full(r, &mut buf[old..]).map_err(BlockErr::Io)?;
        buf.truncate(old + got);
        let end = got < want;
        if let Some(last) = memchr::memrchr(b'\n', &buf[searched..]) {
            if !end {
                carry.extend_from_slice(&buf[searched + last + 1..]);
                buf.truncate(searched + last + 1);
            }
            // At the end of the input, the bytes after the last line end are the last line.
            return Ok(Some(buf));
        }
        if buf.len() > MAX_LINE {
            return Err(BlockErr::Overlong);
        }
        if end {
            return Ok((!buf.is_empty()).then_some(buf));
        }
        searched = buf.len();
    }
}

/// Assigns the block's non-blank lines to rows (sequentially, cheap) and parses them in pieces
/// on the pool.
fn parse_block(mut p: Parsed, els: &[Element], mut cursor: Cursor) -> Parsed {
    let block = &p.block;
    p.lines.clear();
    let mut start = 0;
    let last = (block.last() != Some(&b'\n')).then_some(block.len());
    for end in memchr::memchr_iter(b'\n', block).chain(last) {
        cursor.line += 1;
        if !block[start..end].iter().all(|&b| is_space(b)) {
            if cursor.ei < els.len() {
                p.lines.push(RowLine { start, end, ei: cursor.ei, ri: cursor.ri, line: cursor.line });
                cursor.ri += 1;
                cursor.settle(els);
            } else {
                cursor.extra += 1;
            }
        }
        start = end + 1;
    }
    p.pieces.resize_with(p.lines.len().div_ceil(PIECE), Piece::default);
    p.lines
        .par_chunks(PIECE)
        .zip(p.pieces.par_iter_mut())
        .for_each(|(ls, piece)| parse_piece(block, ls, els, piece));
    p.after = Some(cursor);
    p
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

/// Whitespace-separated tokens of a line.
struct Tokens<'a> {
    rest: &'a [u8],
}

impl<'a> Iterator for Tokens<'a> {
    type Item = &'a [u8];

    fn next(&mut self) -> Option<&'a [u8]> {
        let b = self.rest;
        let mut i = 0;
        while i < b.len() && is_space(b[i]) {
            i += 1;
        }
        if i == b.len() {
            self.rest = &[];
            return None;
        }
        let start = i;
        while i < b.len() && !is_space(b[i]) {
            i += 1;
        }
        self.rest = &b[i..];
        Some(&b[start..i])
    }
}

/// Whitespace as `str::split_whitespace` sees it, in the ASCII range (tab to carriage return,
/// space).
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t'..=b'\r')
}

fn parse_line(line: &[u8], el: &Element, out: &mut Piece) -> Result<(), String> {
    let mut tok = Tokens { rest: line };
    for p in &el.props {
        match p.kind {
            PropKind::Scalar(t) => out.values.push(parse_value(tok.next(), t, &p.name)?),
            PropKind::List { count, item } => {
                out.values.push(f64::NAN);
                let n = parse_value(tok.next(), count, &p.name)?;
                if n < 0.0 {
                    return Err(format!("property '{}': negative list length {n}", p.name));
                }
                for _ in 0..n as u64 {
                    let v = parse_value(tok.next(), item, &p.name)?;
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

/// The value of property `name` of type `ty` from its token.
#[inline]
fn parse_value(t: Option<&[u8]>, ty: Scalar, name: &str) -> Result<f64, String> {
    let Some(t) = t else { return Err(format!("missing value for property '{name}'")) };
    let v = match ty.range() {
        Some((lo, hi)) => match parse_int(t) {
            Some(v) if (lo..=hi).contains(&(v as f64)) => v as f64,
            Some(v) => return Err(format!("property '{name}': {v} out of range for {}", ty.name())),
            None => return Err(not_a(t, "an integer", name)),
        },
        None => match std::str::from_utf8(t).ok().and_then(|s| s.parse::<f64>().ok()) {
            Some(v) if ty == Scalar::F32 => f64::from(v as f32),
            Some(v) => v,
            None => return Err(not_a(t, "a number", name)),
        },
    };
    Ok(v)
}

#[cold]
fn not_a(t: &[u8], what: &str, name: &str) -> String {
    format!("property '{name}': '{}' is not {what}", short(&String::from_utf8_lossy(t)))
}

/// An `i64` as `str::parse` reads it (optional sign, decimal digits), without its UTF-8 check
/// for the short tokens that make up most ASCII bodies.
fn parse_int(t: &[u8]) -> Option<i64> {
    let digits = match t.first()? {
        b'-' | b'+' => &t[1..],
        _ => t,
    };
    if digits.is_empty() || digits.len() > 18 {
        return std::str::from_utf8(t).ok()?.parse().ok();
    }
    let mut v = 0i64;
    for &d in digits {
        let d = d.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v * 10 + i64::from(d);
    }
    Some(if t[0] == b'-' { -v } else { v })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integers_parse_as_str_parse_does() {
        for t in [
            "0",
            "-0",
            "+7",
            "-128",
            "255",
            "123456789012345678",
            "9223372036854775807",
            "-9223372036854775808",
        ] {
            assert_eq!(parse_int(t.as_bytes()), t.parse().ok(), "{t}");
        }
        for t in ["", "-", "+", "1.0", "1e3", "12a", "9223372036854775808", " 1", "--1"] {
            assert_eq!(parse_int(t.as_bytes()), None, "{t:?}");
        }
    }

    #[test]
    fn tokens_split_on_ascii_whitespace() {
        let toks: Vec<&[u8]> = Tokens { rest: b"  1 2\t3\r\n" }.collect();
        assert_eq!(toks, [b"1", b"2", b"3"]);
        assert_eq!(Tokens { rest: b" \t\r" }.next(), None);
    }
}
