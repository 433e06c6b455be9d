//! A streaming PLY reader: ASCII, binary little and big endian, every scalar type spelling, lists
//! with any count type, any elements and properties (unknown ones are read and skipped).
//!
//! Errors name the line (header and ASCII bodies) or the element row (binary bodies). Tolerated
//! quirks are reported as warnings: header lines without a keyword, trailing whitespace, extra
//! rows after the last element.
//!
//! The reader is our own rather than a PLY crate: the kiosk needs errors that name the element,
//! row and line, and tolerance of the quirks real scanners and tools write (the decisions on the
//! test corpus, file by file, are in `tests/scene/corpus.rs`). ASCII bodies are parsed in
//! blocks of lines (`ascii`, over `crate::formats::lines`). A binary element whose rows have a
//! fixed size (a point cloud's vertices) is read about 1 MiB of rows at a time; rows with lists
//! (faces) are converted 4096 at a time. An element without properties has nothing to
//! read, whatever count its header claims. Damaged files (bytes flipped, inserted or deleted, cut
//! short, header counts blown up: `tests/scene/mutations.rs`) give an error or what the file
//! still says, never a panic.

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
    /// Texture images named by `comment TextureFile NAME` lines (MeshLab, Agisoft), in order.
    pub texture_files: Vec<String>,
}

/// Why a PLY file cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum PlyError {
    /// Reading failed.
    #[error("read error: {0}")]
    Io(std::io::Error),
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
    /// A vertex with a non-finite coordinate (which [`crate::ReadOptions::drop_invalid`] drops).
    #[error("element 'vertex' row {row}{}: non-finite coordinate ({})", .line.map(|l| format!(" (line {l})")).unwrap_or_default(), crate::formats::coordinates(*.x, *.y, *.z))]
    NonFinite {
        /// 1-based row within the vertex element.
        row: u64,
        /// 1-based file line (ASCII bodies).
        line: Option<usize>,
        /// The coordinates.
        x: f64,
        /// The coordinates.
        y: f64,
        /// The coordinates.
        z: f64,
    },
    /// The header declares no `vertex` element.
    #[error("no 'vertex' element{}", if .elements.is_empty() { ": the file declares no elements".to_string() } else { format!(" (elements: {})", .elements.join(", ")) })]
    NoVertexElement {
        /// The elements it declares.
        elements: Vec<String>,
    },
    /// The `vertex` element lacks scalar `x`, `y` or `z`.
    #[error("element 'vertex' has no scalar propert{} {}: it holds no 3D positions", if .missing.len() == 1 { "y" } else { "ies" }, .missing.join(", "))]
    NoPositions {
        /// The coordinates it lacks.
        missing: Vec<&'static str>,
    },
    /// The `vertex` element has no rows.
    #[error("the file has 0 vertices")]
    NoVertices,
}

// The message is in the variant's own, so the I/O error is not also a source (see
// `crate::formats::ReadError`).
impl From<std::io::Error> for PlyError {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e)
    }
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
    let mut texture_files = Vec::new();
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
            "comment" => {
                let rest = trimmed["comment".len()..].trim();
                if let Some(name) = rest.strip_prefix("TextureFile").map(str::trim)
                    && !name.is_empty()
                {
                    texture_files.push(name.to_string());
                }
            }
            "obj_info" => {}
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
    Ok(Header { format, elements, lines: line_no, warnings, texture_files })
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

impl Row {
    /// Makes the row one of `el`'s: a NaN value and an empty list per property.
    pub(crate) fn size_for(&mut self, el: &Element) {
        let n = el.props.len();
        self.values.clear();
        self.values.resize(n, f64::NAN);
        self.lists.resize_with(n, Vec::new);
        self.lists.iter_mut().for_each(Vec::clear);
    }
}

/// What a reader makes of the rows of a body, each row on its own, on the reading thread (ASCII
/// bodies in pieces, binary rows of a fixed size a batch at a time). The results of consecutive rows are then taken in file
/// order ([`read_body_converted`]), so that what is taken and the first error are those of a
/// reader that converts one row after the other.
pub trait Convert {
    /// What consecutive rows convert into; reused from run to run (its pages stay mapped).
    type Out: Default;

    /// Empties `out` before a run of rows.
    fn clear(&self, out: &mut Self::Out);

    /// Converts row `ri` (0-based) of element `ei` into `out`. An error is returned after the
    /// rows before it are taken (an ASCII body adds the line to a row error without one).
    fn convert(&self, ei: usize, ri: u64, row: &Row, out: &mut Self::Out) -> Result<(), PlyError>;
}

/// Reads every element of the body, converting each row with `conv` and passing the results of
/// consecutive rows to `take`, in file order (an element without properties has nothing to
/// read or convert). Returns warnings about tolerated oddities.
pub fn read_body_converted<C: Convert>(
    r: &mut (impl BufRead + ?Sized),
    header: &Header,
    conv: &C,
    mut take: impl FnMut(&mut C::Out) -> Result<(), PlyError>,
) -> Result<Vec<String>, PlyError> {
    if header.format == Format::Ascii {
        return ascii::read_rows(r, header, conv, &mut take);
    }
    let mut warnings = Vec::new();
    let big = header.format == Format::BinaryBe;
    let mut row = Row::default();
    let mut bytes = Vec::new();
    let mut out = C::Out::default();
    for (ei, el) in header.elements.iter().enumerate() {
        row.size_for(el);
        if let Some(size) = el.row_size() {
            read_fixed_rows(r, el, ei, size, big, conv, &mut take)?;
            continue;
        }
        conv.clear(&mut out);
        for ri in 0..el.count {
            let converted = match read_binary_row(r, el, big, &mut row, &mut bytes) {
                Ok(()) => conv.convert(ei, ri, &row, &mut out),
                Err(BinErr::Eof) => Err(unexpected_end(el, ri)),
                Err(BinErr::Io(e)) => Err(PlyError::Io(e)),
            };
            if let Err(e) = converted {
                take(&mut out)?;
                return Err(e);
            }
            if (ri + 1) % VARIABLE_RUN == 0 {
                take(&mut out)?;
                conv.clear(&mut out);
            }
        }
        take(&mut out)?;
    }
    // Anything after the last element?
    let mut rest = Vec::new();
    let n = r.read_to_end(&mut rest)?;
    if n > 0 {
        warnings.push(format!("{n} extra byte(s) after the last element ignored"));
    }
    Ok(warnings)
}

/// Binary rows of variable size (with lists) converted between two takes.
const VARIABLE_RUN: u64 = 4096;

/// Reads every element of the body, calling `visit(element index, row index, row)` for each row
/// in order (an element without properties has nothing to read or visit). Returns warnings
/// about tolerated oddities.
pub fn read_body(
    r: &mut (impl BufRead + ?Sized),
    header: &Header,
    mut visit: impl FnMut(usize, u64, &Row) -> Result<(), PlyError>,
) -> Result<Vec<String>, PlyError> {
    let els = &header.elements;
    let mut row = Row::default();
    let mut row_ei = None;
    read_body_converted(r, header, &Copied(els), |copied: &mut CopiedRows| {
        let (mut v, mut l, mut item) = (0, 0, 0);
        for &(ei, ri) in &copied.rows {
            let el = &els[ei];
            if row_ei != Some(ei) {
                row_ei = Some(ei);
                row.size_for(el);
            }
            row.values.copy_from_slice(&copied.values[v..v + el.props.len()]);
            v += el.props.len();
            for (pi, p) in el.props.iter().enumerate() {
                if let PropKind::List { .. } = p.kind {
                    let end = copied.list_ends[l];
                    l += 1;
                    row.lists[pi].clear();
                    row.lists[pi].extend_from_slice(&copied.items[item..end]);
                    item = end;
                }
            }
            visit(ei, ri, &row)?;
        }
        Ok(())
    })
}

/// Rows copied as they are (of the elements `.0`), to be visited in order by [`read_body`].
struct Copied<'a>(&'a [Element]);

/// Rows flat: each row's element and index, its values (NaN for lists), and the items of its
/// lists one after the other (`list_ends` closes each list).
#[derive(Default)]
struct CopiedRows {
    rows: Vec<(usize, u64)>,
    values: Vec<f64>,
    items: Vec<f64>,
    list_ends: Vec<usize>,
}

impl Convert for Copied<'_> {
    type Out = CopiedRows;

    fn clear(&self, out: &mut CopiedRows) {
        out.rows.clear();
        out.values.clear();
        out.items.clear();
        out.list_ends.clear();
    }

    fn convert(&self, ei: usize, ri: u64, row: &Row, out: &mut CopiedRows) -> Result<(), PlyError> {
        out.rows.push((ei, ri));
        out.values.extend_from_slice(&row.values);
        for (p, list) in self.0[ei].props.iter().zip(&row.lists) {
            if let PropKind::List { .. } = p.kind {
                out.items.extend_from_slice(list);
                out.list_ends.push(out.items.len());
            }
        }
        Ok(())
    }
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

/// A batch of whole rows converted: what they convert into, the first row that failed to
/// convert (the rows after it are not read), and where the input ended within the batch.
struct Converted<O> {
    out: O,
    error: Option<PlyError>,
    /// Rows present when the input ended within the batch.
    ended: Option<u64>,
}

/// The rows of a binary element whose rows all have `size` (> 0) bytes, read, decoded and
/// converted a batch at a time.
struct Batches<'a, R: ?Sized, C> {
    r: &'a mut R,
    el: &'a Element,
    ei: usize,
    conv: &'a C,
    size: usize,
    big: bool,
    /// Rows per batch.
    batch: u64,
    buf: Vec<u8>,
    row: Row,
    /// Rows read so far (all of them once the input ended or failed).
    done: u64,
}

impl<R: BufRead + ?Sized, C: Convert> Batches<'_, R, C> {
    /// The next batch, converted into `out`; `None` after the last one, a short one or a
    /// failure.
    fn next(&mut self, mut out: C::Out) -> Option<std::io::Result<Converted<C::Out>>> {
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
        self.conv.clear(&mut out);
        let mut error = None;
        for (k, bytes) in self.buf[..got].chunks_exact(self.size).enumerate() {
            let mut at = 0;
            for (v, p) in self.row.values.iter_mut().zip(&self.el.props) {
                if let PropKind::Scalar(t) = p.kind {
                    *v = t.decode(&bytes[at..], self.big);
                    at += t.size();
                }
            }
            if let Err(e) = self.conv.convert(self.ei, self.done + k as u64, &self.row, &mut out) {
                error = Some(e);
                break;
            }
        }
        let ended = (got < self.buf.len()).then_some(self.done + (got / self.size) as u64);
        self.done = if ended.is_some() || error.is_some() { self.el.count } else { self.done + rows as u64 };
        Some(Ok(Converted { out, error, ended }))
    }
}

/// Reads the rows of a binary element whose rows all have `size` bytes (scalars only), 1 MiB of
/// rows per read, each batch decoded and converted, then taken. (Decoding a batch ahead on a
/// thread of its own was measured side by side: a 5 M-point binary PLY imported in 0.97 of the
/// time, under the 10 % a speed device must earn; docs/performance.md.)
fn read_fixed_rows<C: Convert>(
    r: &mut (impl BufRead + ?Sized),
    el: &Element,
    ei: usize,
    size: usize,
    big: bool,
    conv: &C,
    take: &mut impl FnMut(&mut C::Out) -> Result<(), PlyError>,
) -> Result<(), PlyError> {
    if size == 0 {
        // No properties: nothing to read and nothing to convert, however many rows it claims.
        return Ok(());
    }
    let batch = ((1 << 20) / size).max(1) as u64;
    let mut row = Row::default();
    row.size_for(el);
    let mut batches = Batches { r, el, ei, conv, size, big, batch, buf: Vec::new(), row, done: 0 };
    // Takes the rows of a batch; gives its buffer back for the next.
    let mut take_batch = |mut c: Converted<C::Out>| -> Result<C::Out, PlyError> {
        take(&mut c.out)?;
        if let Some(e) = c.error {
            return Err(e);
        }
        if let Some(present) = c.ended {
            return Err(unexpected_end(el, present));
        }
        Ok(c.out)
    };
    let mut out = C::Out::default();
    while let Some(c) = batches.next(out) {
        out = take_batch(c?)?;
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
