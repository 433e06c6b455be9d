//! ASCII bodies: every row of every element is one line.
//!
//! The body is read in blocks of whole lines ([`crate::formats::lines`]). The lines of a block are
//! assigned to their element and row in one cheap scan, then parsed and converted in pieces,
//! whose conversions are taken in order. Errors are those a line-by-line reader
//! would give, in the same order: a row is taken only if every row before it parsed and
//! converted.

use super::{Convert, Element, Header, PlyError, PropKind, Property, Row, Scalar, short};
use crate::formats::lines::{self, Stop, Tokens};
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

/// A line of a block that holds a row: where it starts and ends in the block, and the lines of
/// the block before it (a block is at most [`lines::MAX_LINE`] and a [`lines::PIECE`] longer,
/// well within `u32`). Its row follows from where its piece starts ([`Parsed::firsts`]): the
/// rows of a piece are consecutive.
#[derive(Clone, Copy, Debug)]
struct RowLine {
    // A block holds less than twice `MAX_LINE` bytes (it grows to find a line's end, up to it).
    start: u32,
    end: u32,
    line: u32,
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

/// A block parsed: its lines that hold rows, the row of each piece's first line, and their
/// conversions in pieces.
struct Parsed<O> {
    /// Lines of the file before the block.
    before: usize,
    lines: Vec<RowLine>,
    /// Where reading stood at the first line of each piece (its element and row).
    firsts: Vec<Cursor>,
    pieces: Vec<Piece<O>>,
}

impl<O> Default for Parsed<O> {
    fn default() -> Self {
        Self { before: 0, lines: Vec::new(), firsts: Vec::new(), pieces: Vec::new() }
    }
}

const _: () = assert!(4 * lines::MAX_LINE as u64 <= u32::MAX as u64, "block offsets fit in u32");

/// The body's lines as rows of its elements, converted by `conv`.
struct Body<'a, C> {
    els: &'a [Element],
    /// Each element's fast path, where it has one.
    fast: Vec<Option<Fast>>,
    conv: &'a C,
}

impl<C: Convert> lines::Format for Body<'_, C> {
    type At = Cursor;
    type Out = Parsed<C::Out>;

    /// Assigns the block's non-blank lines to rows.
    fn scan(&self, block: &[u8], mut cursor: Cursor, p: &mut Self::Out) -> Cursor {
        let els = self.els;
        p.lines.clear();
        p.firsts.clear();
        p.before = cursor.line;
        for (start, end) in lines::lines(block) {
            cursor.line += 1;
            if lines::is_blank(&block[start..end]) {
                continue;
            }
            if cursor.ei < els.len() {
                if p.lines.len() % lines::PIECE == 0 {
                    p.firsts.push(cursor);
                }
                // Offsets and counts within a block fit (see `RowLine`).
                let line = (cursor.line - p.before - 1) as u32;
                p.lines.push(RowLine { start: start as u32, end: end as u32, line });
                cursor.ri += 1;
                cursor.settle(els);
            } else {
                cursor.extra += 1;
            }
        }
        cursor
    }

    /// Parses and converts the rows in pieces.
    fn parse(&self, block: &[u8], p: &mut Self::Out) {
        let (before, firsts) = (p.before, &p.firsts);
        lines::in_pieces(&p.lines, &mut p.pieces, |k, ls, piece| {
            parse_piece(block, ls, firsts[k], before, self.els, &self.fast, self.conv, piece)
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
        &Body { els, fast: els.iter().map(Fast::of).collect(), conv },
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

/// Parses and converts the lines of a piece, whose first line holds the row `at` names, in a
/// block after `before` lines of the file.
#[allow(clippy::too_many_arguments)]
fn parse_piece<C: Convert>(
    block: &[u8],
    lines: &[RowLine],
    mut at: Cursor,
    before: usize,
    els: &[Element],
    fast: &[Option<Fast>],
    conv: &C,
    p: &mut Piece<C::Out>,
) {
    conv.clear(&mut p.out);
    p.error = None;
    for l in lines {
        let (ei, ri, line) = (at.ei, at.ri, before + l.line as usize + 1);
        let el = &els[ei];
        if p.row_ei != Some(ei) {
            p.row_ei = Some(ei);
            p.row.size_for(el);
        }
        let (start, end) = (l.start as usize, l.end as usize);
        let text = &block[start..end];
        let taken = fast[ei].as_ref().is_some_and(|f| f.read(&block[start..], text.len(), &mut p.row));
        let parsed = if taken { Ok(()) } else { parse_line(text, el, &mut p.row) };
        let parsed = parsed.map_err(|msg| {
            let msg = if std::str::from_utf8(text).is_err() {
                "line is not valid UTF-8 text".into()
            } else if end == block.len() && block.last() != Some(&b'\n') {
                // Blocks end with a line's end except at the end of the file: this line is its
                // last, unfinished.
                format!("{msg}; the file ends in this line (cut short?)")
            } else {
                msg
            };
            PlyError::Row { element: el.name.clone(), row: ri + 1, line: Some(line), msg }
        });
        if let Err(e) = parsed.and_then(|()| conv.convert(ei, ri, &p.row, &mut p.out)) {
            p.error = Some(match e {
                PlyError::Row { element, row, line: None, msg } => {
                    PlyError::Row { element, row, line: Some(line), msg }
                }
                PlyError::NonFinite { row, line: None, x, y, z } => {
                    PlyError::NonFinite { row, line: Some(line), x, y, z }
                }
                other => other,
            });
            return;
        }
        // The next line holds the next row, as the scan assigned it.
        at.ri += 1;
        at.settle(els);
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

/// How the rows of an element are read on their fast path: a line of plain numbers (ASCII, each
/// within its type, as many as declared) is read straight into the row, in one pass. Any other
/// line (an error included) is left to [`parse_line`], which reads every line the fast path
/// takes into the same row: the fast path changes the speed, never the result.
#[derive(Clone, Debug)]
enum Fast {
    /// Every property a scalar, of these types (a vertex).
    Scalars(Vec<Scalar>),
    /// A single property, a list (a face).
    List { count: Scalar, item: Scalar },
}

impl Fast {
    /// The fast path of the rows of `el`, if they have one.
    fn of(el: &Element) -> Option<Self> {
        match el.props.as_slice() {
            [Property { kind: PropKind::List { count, item }, .. }] => {
                Some(Self::List { count: *count, item: *item })
            }
            props => props
                .iter()
                .map(|p| match p.kind {
                    PropKind::Scalar(t) => Some(t),
                    PropKind::List { .. } => None,
                })
                .collect::<Option<Vec<_>>>()
                .map(Self::Scalars),
        }
    }

    /// Reads the line of `len` bytes that `text` starts with (and runs on past: the rest of its
    /// block, which a number's parse may look into; the line end stops it) into
    /// `row` (sized for the element). False when the line is not one for the fast path (the
    /// row is then partly written, and [`parse_line`] writes it again).
    fn read(&self, text: &[u8], len: usize, row: &mut Row) -> bool {
        let mut at = 0;
        let all = match self {
            Self::Scalars(types) => types
                .iter()
                .zip(&mut row.values)
                .all(|(&ty, v)| plain_value(text, len, &mut at, ty).map(|x| *v = x).is_some()),
            Self::List { count, item } => {
                let Some(n) = plain_value(text, len, &mut at, *count).filter(|&n| n >= 0.0) else {
                    return false;
                };
                let list = &mut row.lists[0];
                list.clear();
                (0..n as u64).all(|_| plain_value(text, len, &mut at, *item).map(|x| list.push(x)).is_some())
            }
        };
        all && lines::skip(&text[..len], at, true) == len
    }
}

/// The plain number of type `ty` after the blanks at `*at` in the line of `len` bytes that
/// `text` starts with (a plain integer within the type's range, or a float as `fast-float2`
/// reads it), when a blank or the line's end follows; moves `*at` past it. The value
/// [`parse_value`] gives the same token.
#[inline(always)]
fn plain_value(text: &[u8], len: usize, at: &mut usize, ty: Scalar) -> Option<f64> {
    let start = lines::skip(&text[..len], *at, true);
    if start == len {
        return None;
    }
    // Past the line's end only when it ends with a line end, which no number takes.
    let rest = &text[start..];
    let (v, n) = match ty.range() {
        Some((lo, hi)) => {
            let (v, n) = lines::plain_int(rest)?;
            let v = v as f64;
            if !(lo..=hi).contains(&v) {
                return None;
            }
            (v, n)
        }
        None => {
            let (v, n) = fast_float2::parse_partial::<f64, _>(rest).ok()?;
            (if ty == Scalar::F32 { f64::from(v as f32) } else { v }, n)
        }
    };
    if n < rest.len() && !lines::is_space(rest[n]) {
        return None;
    }
    *at = start + n;
    Some(v)
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn element(kinds: &[PropKind]) -> Element {
        let props =
            kinds.iter().enumerate().map(|(i, &kind)| Property { name: format!("p{i}"), kind }).collect();
        Element { name: "e".into(), count: 1, props }
    }

    /// The row `parse_line` makes of `line`, or its error.
    fn generic(line: &[u8], el: &Element) -> Result<Row, String> {
        let mut row = Row::default();
        row.size_for(el);
        parse_line(line, el, &mut row).map(|()| row)
    }

    /// The row the fast path makes of `line` (followed in its block by `after`), if it takes it.
    fn fast(line: &[u8], after: &[u8], el: &Element) -> Option<Row> {
        let plan = Fast::of(el).expect("a shape with a fast path");
        let text = [line, after].concat();
        let mut row = Row::default();
        row.size_for(el);
        plan.read(&text, line.len(), &mut row).then_some(row)
    }

    fn bits(row: &Row) -> (Vec<u64>, Vec<Vec<u64>>) {
        let b = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        (b(&row.values), row.lists.iter().map(|l| b(l)).collect())
    }

    fn shapes() -> Vec<Element> {
        use Scalar::*;
        let s = PropKind::Scalar;
        vec![
            element(&[s(F32), s(F32), s(F32)]),
            element(&[s(F64), s(U8), s(I16), s(F32)]),
            element(&[s(I8), s(U16), s(I32), s(U32)]),
            element(&[PropKind::List { count: U8, item: I32 }]),
            element(&[PropKind::List { count: I32, item: U32 }]),
            element(&[PropKind::List { count: U8, item: F32 }]),
        ]
    }

    #[test]
    fn the_fast_path_takes_the_lines_of_common_meshes() {
        let vertex = element(&[PropKind::Scalar(Scalar::F32); 3]);
        let row = fast(b"0.032027 0.056575 -0.0503644 ", b"\n3 1 2 3\n", &vertex).expect("taken");
        assert_eq!(row.values, [0.032027f32, 0.056575, -0.0503644].map(f64::from));
        let face = element(&[PropKind::List { count: Scalar::U8, item: Scalar::I32 }]);
        let row = fast(b"3 437644 437643 12", b"", &face).expect("taken at the end of the input");
        assert_eq!(row.lists[0], [437644.0, 437643.0, 12.0]);
        assert_eq!(fast(b"4 1 2 3 4\r", b"\n", &face).expect("a CRLF line").lists[0], [1.0, 2.0, 3.0, 4.0]);
        for (line, why) in [
            (&b"3 1 2"[..], "a value missing"),
            (b"3 1 2 3 4", "a value too many"),
            (b"3 1 2 2147483648", "out of range"),
            (b"3 1 2 3x", "not a number"),
            (b"3 1\xc2\xa02 3", "a no-break space (left to the Unicode split)"),
            (b"-1", "a negative count"),
        ] {
            assert!(fast(line, b"\n", &face).is_none(), "{why}: left to parse_line");
        }
    }

    /// Lines of tokens plain and not (signs, exponents, `nan`, long digit runs, non-ASCII space
    /// and letters, CR, tabs, counts that do not match): wherever the fast path takes a line,
    /// `parse_line` reads the same row from it, bit for bit; and it takes a good share of them.
    #[test]
    fn the_fast_path_reads_every_line_it_takes_as_parse_line_does() {
        // Plain tokens first (most of each line), then the others.
        let tokens: &[&[u8]] = &[
            b"0",
            b"3",
            b"7",
            b"-1",
            b"+2",
            b"255",
            b"65535",
            b"12345678",
            b"00000012",
            b"0.5",
            b"-0.0503644",
            b"1.5e-3",
            b"256",
            b"-129",
            b"4294967295",
            b"4294967296",
            b"-2147483649",
            b"123456789012345678",
            b"1234567890123456789",
            b"1e5",
            b"1e",
            b".5",
            b"5.",
            b"nan",
            b"inf",
            b"-inf",
            b"infinity",
            b"0x10",
            b"1,5",
            b"\xc3\xa9",
            b"3e400",
        ];
        let seps: &[&[u8]] = &[b" ", b"  ", b"\t", b" \r", b"\xc2\xa0"];
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let pick = |rng: &mut rand_pcg::Pcg64, list: &[&'static [u8]], plain: usize| {
            if rng.random_bool(0.9) {
                list[rng.random_range(0..plain)]
            } else {
                list[rng.random_range(0..list.len())]
            }
        };
        let (mut taken, mut lines) = (0, 0);
        for el in shapes() {
            let is_list = matches!(el.props[0].kind, PropKind::List { .. });
            for _ in 0..4000 {
                let n = if is_list {
                    rng.random_range(0..6)
                } else {
                    el.props.len() + usize::from(rng.random_bool(0.1))
                };
                let mut line = Vec::new();
                if rng.random_bool(0.3) {
                    line.push(b' ');
                }
                if is_list {
                    let count = if rng.random_bool(0.8) {
                        n.to_string().into_bytes()
                    } else {
                        pick(&mut rng, tokens, 9).to_vec()
                    };
                    line.extend_from_slice(&count);
                }
                for i in 0..n {
                    if i > 0 || is_list {
                        line.extend_from_slice(pick(&mut rng, seps, 4));
                    }
                    line.extend_from_slice(pick(&mut rng, tokens, 12));
                }
                let after: &[u8] = [&b"\n"[..], b"\n123", b""][rng.random_range(0..3)];
                let got = fast(&line, after, &el);
                let want = generic(&line, &el);
                if let Some(row) = got {
                    let want = want.unwrap_or_else(|e| {
                        panic!("{}: fast path took it, parse_line: {e}", line.escape_ascii())
                    });
                    assert_eq!(bits(&row), bits(&want), "{}", line.escape_ascii());
                    taken += 1;
                }
                lines += 1;
            }
        }
        assert!(taken > lines / 4 && taken < lines, "{taken} lines taken of {lines}");
    }
}
