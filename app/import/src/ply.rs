//! A streaming PLY reader: ASCII, binary little and big endian, every scalar type spelling, lists
//! with any count type, any elements and properties (unknown ones are read and skipped).
//!
//! Errors name the line (header and ASCII bodies) or the element row (binary bodies). Tolerated
//! quirks are reported as warnings: header lines without a keyword, trailing whitespace, extra
//! rows after the last element.

use std::io::BufRead;

mod ascii;

/// Scalar types of PLY, with both the classic and the sized spellings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    /// char / int8
    I8,
    /// uchar / uint8
    U8,
    /// short / int16
    I16,
    /// ushort / uint16
    U16,
    /// int / int32
    I32,
    /// uint / uint32
    U32,
    /// float / float32
    F32,
    /// double / float64
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    /// Size in bytes in binary bodies.
    pub fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn range(self) -> Option<(f64, f64)> {
        Some(match self {
            Self::I8 => (-128.0, 127.0),
            Self::U8 => (0.0, 255.0),
            Self::I16 => (-32768.0, 32767.0),
            Self::U16 => (0.0, 65535.0),
            Self::I32 => (-2_147_483_648.0, 2_147_483_647.0),
            Self::U32 => (0.0, 4_294_967_295.0),
            Self::F32 | Self::F64 => return None,
        })
    }

    fn name(self) -> &'static str {
        match self {
            Self::I8 => "int8",
            Self::U8 => "uint8",
            Self::I16 => "int16",
            Self::U16 => "uint16",
            Self::I32 => "int32",
            Self::U32 => "uint32",
            Self::F32 => "float32",
            Self::F64 => "float64",
        }
    }

    fn decode(self, b: &[u8], big: bool) -> f64 {
        macro_rules! rd {
            ($t:ty, $n:expr) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(&b[..$n]);
                f64::from(if big { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) })
            }};
        }
        match self {
            Self::I8 => f64::from(b[0] as i8),
            Self::U8 => f64::from(b[0]),
            Self::I16 => rd!(i16, 2),
            Self::U16 => rd!(u16, 2),
            Self::I32 => rd!(i32, 4),
            Self::U32 => rd!(u32, 4),
            Self::F32 => rd!(f32, 4),
            Self::F64 => rd!(f64, 8),
        }
    }
}

/// The type of a property.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PropKind {
    /// One value.
    Scalar(Scalar),
    /// A count followed by that many items.
    List {
        /// Type of the count.
        count: Scalar,
        /// Type of the items.
        item: Scalar,
    },
}

/// A declared property.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Property {
    /// Its name.
    pub name: String,
    /// Its type.
    pub kind: PropKind,
}

/// A declared element.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Element {
    /// Its name ("vertex", "face", …).
    pub name: String,
    /// Number of rows.
    pub count: u64,
    /// Its properties, in order.
    pub props: Vec<Property>,
}

impl Element {
    /// Bytes per row in a binary file when every property is a scalar (lists vary).
    pub fn row_size(&self) -> Option<usize> {
        self.props
            .iter()
            .map(|p| match p.kind {
                PropKind::Scalar(t) => Some(t.size()),
                PropKind::List { .. } => None,
            })
            .sum()
    }

    /// Index of a property by name.
    pub fn prop(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|p| p.name == name)
    }
}

/// Body encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Text.
    Ascii,
    /// Binary, little endian.
    BinaryLe,
    /// Binary, big endian.
    BinaryBe,
}

/// A parsed header.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Body encoding.
    pub format: Format,
    /// Elements in body order.
    pub elements: Vec<Element>,
    /// Number of header lines (the body starts after them).
    pub lines: usize,
    /// Tolerated oddities.
    pub warnings: Vec<String>,
}

/// Why a PLY file cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum PlyError {
    /// Reading failed.
    #[error("read error: {0}")]
    Io(#[from] std::io::Error),
    /// Problem in the header.
    #[error("header line {line}: {msg}")]
    Header {
        /// 1-based line.
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// Problem in a body row.
    #[error("element '{element}' row {row}{}: {msg}", .line.map(|l| format!(" (line {l})")).unwrap_or_default())]
    Row {
        /// Element name.
        element: String,
        /// 1-based row within the element.
        row: u64,
        /// 1-based file line (ASCII bodies).
        line: Option<usize>,
        /// What is wrong.
        msg: String,
    },
}

fn herr(line: usize, msg: impl Into<String>) -> PlyError {
    PlyError::Header { line, msg: msg.into() }
}

/// Reads the header, leaving `r` at the first byte of the body.
pub fn read_header(r: &mut (impl BufRead + ?Sized)) -> Result<Header, PlyError> {
    let mut buf = Vec::new();
    let mut line_no = 0usize;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut warnings = Vec::new();
    const MAX_HEADER_LINE: usize = 64 * 1024;
    loop {
        buf.clear();
        let n = std::io::Read::take(&mut *r, MAX_HEADER_LINE as u64).read_until(b'\n', &mut buf)?;
        line_no += 1;
        if n == 0 {
            return Err(if line_no == 1 {
                herr(1, "empty file: missing the 'ply' magic line")
            } else {
                herr(line_no, "unexpected end of file: the header has no 'end_header'")
            });
        }
        if buf.len() >= MAX_HEADER_LINE {
            return Err(herr(line_no, "header line longer than 64 KiB (binary data in the header?)"));
        }
        if buf.contains(&0) {
            return Err(herr(line_no, "NUL byte in the header (binary data before 'end_header')"));
        }
        let text =
            std::str::from_utf8(&buf).map_err(|_| herr(line_no, "header is not text (invalid UTF-8)"))?;
        let trimmed = text.trim();
        if line_no == 1 {
            if trimmed != "ply" {
                return Err(herr(1, format!("missing the 'ply' magic line (found {:?})", short(trimmed))));
            }
            continue;
        }
        let mut tok = trimmed.split_whitespace();
        let Some(key) = tok.next() else { continue };
        match key {
            "format" => {
                let f = match tok.next() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::BinaryLe,
                    Some("binary_big_endian") => Format::BinaryBe,
                    other => return Err(herr(line_no, format!("unknown format {other:?}"))),
                };
                if let Some(v) = tok.next()
                    && v != "1.0"
                {
                    warnings.push(format!("header line {line_no}: format version {v}, read as 1.0"));
                }
                format = Some(f);
            }
            "comment" | "obj_info" => {}
            "element" => {
                let name = tok.next().ok_or_else(|| herr(line_no, "element without a name"))?;
                let count = tok
                    .next()
                    .and_then(|c| c.parse::<u64>().ok())
                    .ok_or_else(|| herr(line_no, format!("element '{name}' has no valid row count")))?;
                elements.push(Element { name: name.to_string(), count, props: Vec::new() });
            }
            "property" => {
                let el = elements.last_mut().ok_or_else(|| herr(line_no, "property before any element"))?;
                let t = tok.next().ok_or_else(|| herr(line_no, "property without a type"))?;
                let ty = |s: Option<&str>| -> Result<Scalar, PlyError> {
                    let s = s.ok_or_else(|| herr(line_no, "property type missing"))?;
                    Scalar::parse(s).ok_or_else(|| herr(line_no, format!("unknown property type '{s}'")))
                };
                let kind = if t == "list" {
                    let count = ty(tok.next())?;
                    if matches!(count, Scalar::F32 | Scalar::F64) {
                        return Err(herr(line_no, "list count type must be an integer"));
                    }
                    PropKind::List { count, item: ty(tok.next())? }
                } else {
                    PropKind::Scalar(ty(Some(t))?)
                };
                let name = tok.next().ok_or_else(|| herr(line_no, "property without a name"))?;
                el.props.push(Property { name: name.to_string(), kind });
            }
            "end_header" => break,
            other => {
                warnings.push(format!("header line {line_no}: unknown keyword '{}' ignored", short(other)))
            }
        }
    }
    let format = format.ok_or_else(|| herr(line_no, "the header has no 'format' line"))?;
    Ok(Header { format, elements, lines: line_no, warnings })
}

fn short(s: &str) -> String {
    s.chars().take(40).collect()
}

/// One decoded row: scalar properties as `f64` (NaN for lists) and list items.
#[derive(Debug, Default)]
pub struct Row {
    /// Value of each scalar property, by property index.
    pub values: Vec<f64>,
    /// Items of each list property, by property index (empty for scalars).
    pub lists: Vec<Vec<f64>>,
}

/// Reads every element of the body, calling `visit(element index, row index, row)` for each row
/// (an element without properties has nothing to read or visit). Returns warnings about
/// tolerated oddities.
pub fn read_body(
    r: &mut (impl BufRead + Send + ?Sized),
    header: &Header,
    mut visit: impl FnMut(usize, u64, &Row) -> Result<(), PlyError>,
) -> Result<Vec<String>, PlyError> {
    if header.format == Format::Ascii {
        return ascii::read_rows(r, header, &mut visit);
    }
    let mut warnings = Vec::new();
    let big = header.format == Format::BinaryBe;
    let mut row = Row::default();
    let mut bytes = Vec::new();
    for (ei, el) in header.elements.iter().enumerate() {
        row.values.clear();
        row.values.resize(el.props.len(), f64::NAN);
        row.lists.resize_with(el.props.len(), Vec::new);
        if let Some(size) = el.row_size() {
            read_fixed_rows(r, el, ei, size, big, &mut row, &mut visit)?;
            continue;
        }
        for ri in 0..el.count {
            read_binary_row(r, el, big, &mut row, &mut bytes).map_err(|e| match e {
                BinErr::Eof => unexpected_end(el, ri),
                BinErr::Io(e) => PlyError::Io(e),
            })?;
            visit(ei, ri, &row)?;
        }
    }
    // Anything after the last element?
    let mut rest = Vec::new();
    let n = r.read_to_end(&mut rest)?;
    if n > 0 {
        warnings.push(format!("{n} extra byte(s) after the last element ignored"));
    }
    Ok(warnings)
}

enum BinErr {
    Eof,
    Io(std::io::Error),
}

fn read_exact(r: &mut (impl BufRead + ?Sized), n: usize, buf: &mut Vec<u8>) -> Result<(), BinErr> {
    buf.resize(n, 0);
    r.read_exact(buf)
        .map_err(|e| if e.kind() == std::io::ErrorKind::UnexpectedEof { BinErr::Eof } else { BinErr::Io(e) })
}

/// The error for an element whose rows end after `present` of them.
pub(crate) fn unexpected_end(el: &Element, present: u64) -> PlyError {
    PlyError::Row {
        element: el.name.clone(),
        row: present + 1,
        line: None,
        msg: format!("unexpected end of file: {present} of {} rows present", el.count),
    }
}

/// The decoded values of a batch of whole rows, and whether the input ended within it.
struct Decoded {
    values: Vec<f64>,
    ended: bool,
}

/// The rows of a binary element whose rows all have `size` (> 0) bytes, read and decoded a
/// batch at a time.
struct Batches<'a, R: ?Sized> {
    r: &'a mut R,
    el: &'a Element,
    size: usize,
    big: bool,
    /// Rows per batch.
    batch: u64,
    buf: Vec<u8>,
    /// Rows read so far (all of them once the input ended or failed).
    done: u64,
}

impl<R: BufRead + ?Sized> Batches<'_, R> {
    /// The next batch, decoded into `values`; `None` after the last one, a short one or a failure.
    fn next(&mut self, mut values: Vec<f64>) -> Option<std::io::Result<Decoded>> {
        if self.done >= self.el.count {
            return None;
        }
        let rows = self.batch.min(self.el.count - self.done) as usize;
        self.buf.resize(rows * self.size, 0);
        let got = match crate::read_full(self.r, &mut self.buf) {
            Ok(got) => got,
            Err(e) => {
                self.done = self.el.count;
                return Some(Err(e));
            }
        };
        values.clear();
        for bytes in self.buf[..got].chunks_exact(self.size) {
            let mut at = 0;
            for p in &self.el.props {
                if let PropKind::Scalar(t) = p.kind {
                    values.push(t.decode(&bytes[at..], self.big));
                    at += t.size();
                }
            }
        }
        let ended = got < self.buf.len();
        self.done = if ended { self.el.count } else { self.done + rows as u64 };
        Some(Ok(Decoded { values, ended }))
    }
}

/// Reads the rows of a binary element whose rows all have `size` bytes (scalars only), 1 MiB of
/// rows per read. An element of more than one batch (the points of a large scan) is read and
/// decoded on a thread of its own, a batch ahead of the visits: reading and decoding take as
/// long as the visits.
fn read_fixed_rows(
    r: &mut (impl BufRead + Send + ?Sized),
    el: &Element,
    ei: usize,
    size: usize,
    big: bool,
    row: &mut Row,
    visit: &mut impl FnMut(usize, u64, &Row) -> Result<(), PlyError>,
) -> Result<(), PlyError> {
    if size == 0 {
        // No properties: nothing to read and nothing to visit, however many rows it claims.
        return Ok(());
    }
    let batch = ((1 << 20) / size).max(1) as u64;
    let mut batches = Batches { r, el, size, big, batch, buf: Vec::new(), done: 0 };
    // Visits the rows of a batch; hands its buffer back.
    let mut visited = 0u64;
    let mut take = |d: Decoded| -> Result<Vec<f64>, PlyError> {
        for values in d.values.chunks_exact(row.values.len()) {
            row.values.copy_from_slice(values);
            visit(ei, visited, row)?;
            visited += 1;
        }
        if d.ended {
            return Err(unexpected_end(el, visited));
        }
        Ok(d.values)
    };
    if el.count > batch {
        let threaded = std::thread::scope(|s| {
            let (decoded_tx, decoded) = std::sync::mpsc::channel::<std::io::Result<Decoded>>();
            // Value buffers go round: at most three in use (decoded, queued, visited).
            let (spare, spare_rx) = std::sync::mpsc::channel::<Vec<f64>>();
            for _ in 0..3 {
                spare.send(Vec::new()).expect("its receiver is here");
            }
            let source = &mut batches;
            // The decoder stops after the last batch, a short one or a failure (`next` has
            // none after them), or when the visits stop (their side hangs up: it may finish the
            // read it is in first).
            let decoder = move || {
                while let Ok(values) = spare_rx.recv() {
                    let Some(d) = source.next(values) else { return };
                    if decoded_tx.send(d).is_err() {
                        return;
                    }
                }
            };
            // Without a thread (the system refuses one), the rows are read below instead.
            std::thread::Builder::new().name("ply rows".into()).spawn_scoped(s, decoder).ok()?;
            Some(decoded.into_iter().try_for_each(|d| {
                // The decoder may be done already: the buffer is then dropped.
                let _ = spare.send(take(d?)?);
                Ok(())
            }))
        });
        if let Some(result) = threaded {
            return result;
        }
    }
    let mut values = Vec::new();
    while let Some(d) = batches.next(values) {
        values = take(d?)?;
    }
    Ok(())
}

fn read_binary_row(
    r: &mut (impl BufRead + ?Sized),
    el: &Element,
    big: bool,
    row: &mut Row,
    buf: &mut Vec<u8>,
) -> Result<(), BinErr> {
    for (pi, p) in el.props.iter().enumerate() {
        match p.kind {
            PropKind::Scalar(t) => {
                read_exact(r, t.size(), buf)?;
                row.values[pi] = t.decode(buf, big);
            }
            PropKind::List { count, item } => {
                read_exact(r, count.size(), buf)?;
                let n = count.decode(buf, big).max(0.0) as usize;
                read_exact(r, n * item.size(), buf)?;
                let list = &mut row.lists[pi];
                list.clear();
                list.extend(buf.chunks_exact(item.size()).map(|c| item.decode(c, big)));
            }
        }
    }
    Ok(())
}
