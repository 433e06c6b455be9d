//! LAS 1.0–1.4 and LAZ (with the `las` crate and its LAZ decoder): coordinates are the file's
//! integers times its scale plus its offset, in f64 (georeferenced coordinates go into the
//! store's f64 origin, so millimetres survive offsets of 10⁶ m); colour is 16-bit per channel by
//! the specification, but many writers store 8-bit values: the file is taken as 8-bit when no
//! channel of its first points exceeds 255. Without colour, intensity becomes grey, scaled the
//! same way (a file whose first points have neither is left without colour). Normals and
//! spacings are estimated by the builder.
//!
//! Deciding over the whole file would need a second pass over it (for LAZ, a second decode), so
//! a later chunk that contradicts an 8-bit decision (a value above 255) switches the rest of the
//! file to 16-bit, with a warning naming the points taken as 8-bit: most of the model is right,
//! and the curator knows which part is not.

use crate::source::{InputPoint, ReadReport, Sink};
use glam::DVec3;
use std::path::Path;

/// Why a LAS or LAZ file cannot be read: the reader's own errors, or `E`, the error of the
/// consumer of the points that stopped the reading.
#[derive(Debug, thiserror::Error)]
pub enum LasError<E = std::convert::Infallible> {
    /// The `las` crate's error on the header, the variable-length records or the chunk table.
    #[error("{}", message(.0))]
    Las(::las::Error),
    /// The `las` crate's error on the point records (or their LAZ chunks) from `first` on.
    #[error("points {first}–{last}: {}", message(.cause))]
    Records {
        /// 1-based index of the first point of the batch being decoded.
        first: u64,
        /// 1-based index of its last point.
        last: u64,
        /// The decoder's error.
        cause: ::las::Error,
    },
    /// A point with a non-finite coordinate.
    #[error("point {index}: non-finite coordinate ({})", super::coordinates(*.x, *.y, *.z))]
    NonFinite {
        /// 1-based index.
        index: u64,
        /// Coordinates.
        x: f64,
        /// Coordinates.
        y: f64,
        /// Coordinates.
        z: f64,
    },
    /// Rejected by the consumer of the points, with its error.
    #[error(transparent)]
    Sink(E),
    /// The decoder gave up on corrupted data.
    #[error("{0}")]
    Corrupt(String),
}

// The decoder's message is in the variants' own, so it is not also a source (see
// `crate::formats::ReadError`).
impl<E> From<::las::Error> for LasError<E> {
    fn from(e: ::las::Error) -> Self {
        Self::Las(e)
    }
}

/// The `las` crate's message, or what a file that ends before its header, records or chunks do
/// means, in a user's words.
fn message(e: &::las::Error) -> String {
    let io = match e {
        ::las::Error::Io(io) | ::las::Error::LasZipError(::laz::LasZipError::IoError(io)) => Some(io),
        _ => None,
    };
    match io {
        Some(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => super::CUT_SHORT.into(),
        Some(io) => format!("read error: {io}"),
        None => e.to_string(),
    }
}

impl<E> LasError<E> {
    /// The reader's own error, or the consumer's.
    pub(crate) fn split(self) -> Result<LasError, E> {
        match self {
            Self::Las(e) => Ok(LasError::Las(e)),
            Self::Records { first, last, cause } => Ok(LasError::Records { first, last, cause }),
            Self::NonFinite { index, x, y, z } => Ok(LasError::NonFinite { index, x, y, z }),
            Self::Sink(e) => Err(e),
            Self::Corrupt(msg) => Ok(LasError::Corrupt(msg)),
        }
    }
}

/// Points decoded at a time, at most.
const CHUNK: u64 = 1 << 16;

/// Bytes of point records decoded at a time, at most: the decoder fills a buffer of the records'
/// length (up to 64 KiB by the header) times their number (up to [`CHUNK`]).
const CHUNK_BYTES: u64 = 16 << 20;

/// Reads a LAS or LAZ file into `sink`.
pub fn read<E>(path: &Path, sink: &mut dyn Sink<Error = E>) -> Result<ReadReport, LasError<E>> {
    super::guarded(|| read_guarded(path, sink), LasError::Corrupt)
}

/// Checks the lengths in a LAS header against the file's size before the `las` crate allocates
/// by them (a corrupted length would ask for gigabytes and abort the process): the header,
/// the variable-length records, the point data of an uncompressed file, and the extended
/// records of LAS 1.4. Returns whether a LAZ file's chunks may be decoded in parallel
/// ([`check_chunk_table`]).
fn check_lengths<E>(path: &Path) -> Result<bool, LasError<E>> {
    use std::io::{Read, Seek, SeekFrom};
    let bad = |why: String| LasError::Corrupt(format!("the header is inconsistent with the file: {why}"));
    let mut f = std::fs::File::open(path).map_err(|e| LasError::Las(e.into()))?;
    let size = f.metadata().map_err(|e| LasError::Las(e.into()))?.len();
    let mut h = [0u8; 375];
    let n = f.read(&mut h).map_err(|e| LasError::Las(e.into()))?;
    if n < 227 {
        return Err(bad(format!("{size} bytes, shorter than a header")));
    }
    let u16_at = |o: usize| u16::from_le_bytes([h[o], h[o + 1]]);
    let u32_at = |o: usize| u32::from_le_bytes([h[o], h[o + 1], h[o + 2], h[o + 3]]);
    let u64_at = |o: usize| u64::from_le_bytes(h[o..o + 8].try_into().unwrap_or([0; 8]));
    if h[24] != 1 || h[25] > 4 {
        return Err(LasError::Corrupt(format!(
            "LAS version {}.{}: the importer reads LAS 1.0 to 1.4 (and LAZ files of those)",
            h[24], h[25]
        )));
    }
    let (minor, header_size) = (h[25], u64::from(u16_at(94)));
    let (offset, vlrs) = (u64::from(u32_at(96)), u32_at(100));
    let (format, record_len) = (h[104], u64::from(u16_at(105)));
    if header_size > size || offset > size || header_size > offset {
        return Err(bad(format!("header size {header_size}, point data at {offset}, file {size} bytes")));
    }
    // Variable-length records: 54-byte headers and their data, between the header and the points.
    let mut at = header_size;
    for i in 0..vlrs {
        let mut vh = [0u8; 54];
        f.seek(SeekFrom::Start(at))
            .and_then(|_| f.read_exact(&mut vh))
            .map_err(|_| bad(format!("record {} beyond the file", i + 1)))?;
        // reserved (2), user id (16), record id (2), length after the header (2), description (32)
        at += 54 + u64::from(u16::from_le_bytes([vh[20], vh[21]]));
        if at > size {
            return Err(bad(format!("variable-length record {} ends beyond the file", i + 1)));
        }
    }
    // The `las` crate computes where the points end from LAS 1.4's 64-bit count, unchecked.
    if minor >= 4
        && n >= 255
        && u64_at(247).checked_mul(record_len).and_then(|b| b.checked_add(offset)).is_none()
    {
        return Err(bad(format!("{} points of {record_len} bytes overflow the file's offsets", u64_at(247))));
    }
    let compressed = format & 0x80 != 0 || format & 0x40 != 0;
    let parallel = compressed && check_chunk_table(&mut f, offset, size)?;
    let points = if minor >= 4 && n >= 255 { u64_at(247) } else { u64::from(u32_at(107)) };
    if !compressed
        && points.checked_mul(record_len).and_then(|b| b.checked_add(offset)).is_none_or(|end| end > size)
    {
        return Err(bad(format!(
            "{points} points of {record_len} bytes from byte {offset} do not fit in {size} bytes"
        )));
    }
    if minor >= 4 && n >= 375 {
        let (mut at, count) = (u64_at(235), u32_at(243));
        for i in 0..count {
            let mut eh = [0u8; 60];
            if at == 0 || at > size {
                return Err(bad(format!("extended record {} starts beyond the file", i + 1)));
            }
            f.seek(SeekFrom::Start(at))
                .and_then(|_| f.read_exact(&mut eh))
                .map_err(|_| bad(format!("extended record {} beyond the file", i + 1)))?;
            let len = u64::from_le_bytes(eh[20..28].try_into().unwrap_or([0; 8]));
            at = at.checked_add(60).and_then(|a| a.checked_add(len)).filter(|&e| e <= size).ok_or_else(
                || bad(format!("extended record {} of {len} bytes ends beyond the file", i + 1)),
            )?;
        }
    }
    check_transforms(&h)?;
    Ok(parallel)
}

/// Checks the header's scale factors and offsets (from the first 227 bytes of `h`): a point's
/// coordinate is its integer times the scale plus the offset, so a scale of 0 would put every
/// point on one plane and a non-finite one would make every coordinate NaN, with nothing wrong
/// in the points themselves.
fn check_transforms<E>(h: &[u8]) -> Result<(), LasError<E>> {
    let f64_at = |o: usize| f64::from_le_bytes(h[o..o + 8].try_into().unwrap_or([0; 8]));
    for (k, axis) in ["X", "Y", "Z"].into_iter().enumerate() {
        let (scale, offset) = (f64_at(131 + 8 * k), f64_at(155 + 8 * k));
        if !scale.is_finite() || scale == 0.0 {
            return Err(LasError::Corrupt(format!(
                "the header's {axis} scale factor is {scale}: every {axis} would be {}",
                if scale == 0.0 { "the offset (a flat model)" } else { "meaningless" }
            )));
        }
        if !offset.is_finite() {
            return Err(LasError::Corrupt(format!("the header's {axis} offset is {offset}")));
        }
    }
    Ok(())
}

/// The smallest point record (format 0), in bytes. Each chunk of a LAZ file starts with its
/// first point uncompressed, so a chunk takes at least this many bytes of the file.
const MIN_RECORD: u64 = 20;

/// Checks the number of chunks that a LAZ chunk table announces before the LAZ decoder reserves
/// 16 bytes for each (a corrupted count asks for up to 64 GiB, and a failed reservation aborts
/// the process): the chunks lie between the start of the point data and the table, at least
/// [`MIN_RECORD`] bytes each, so the table takes less memory than the file's size. Whether the
/// file has a table is read from its LAZ record as the `las` crate finds it (its own walk of the
/// records: where it starts them need not be where the header's size says); the table's place
/// as the decoder finds it: the 8 bytes at the start of the point data, else the file's last 8
/// bytes. A table that is not in the file is left to the decoder, which reports it (or, for
/// fixed-size chunks, reads without it).
///
/// Returns whether the chunks may be decompressed in parallel (several at once, on the pool):
/// only once the count is checked is the table read as the decoder reads it (the parallel
/// decoder allocates by it), and then the chunks must fit in the file and none may hold more
/// than [`PARALLEL_CHUNK_POINTS`]. Any other file is decompressed on one thread, chunk by
/// chunk, as the decoder always did. Figures in docs/performance.md (Survey formats).
fn check_chunk_table<E>(f: &mut std::fs::File, data_start: u64, size: u64) -> Result<bool, LasError<E>> {
    use std::io::{Read, Seek, SeekFrom};
    f.seek(SeekFrom::Start(0)).map_err(|e| LasError::Las(e.into()))?;
    let header = ::las::Header::new(std::io::BufReader::new(&mut *f))?;
    let laz = header.vlrs().iter().find(|v| v.user_id == "laszip encoded" && v.record_id == 22204);
    // Its first two bytes: the compressor, 2 and 3 being the chunked ones (1 has no table).
    if !laz.is_some_and(|v| matches!(v.data.get(..2), Some([2 | 3, 0]))) {
        return Ok(false);
    }
    let mut read_at =
        |at: u64, buf: &mut [u8]| f.seek(SeekFrom::Start(at)).and_then(|_| f.read_exact(buf)).is_ok();
    let mut b = [0u8; 8];
    let mut table = if read_at(data_start, &mut b) { i64::from_le_bytes(b) } else { return Ok(false) };
    if table <= data_start as i64 {
        if size < 8 || !read_at(size - 8, &mut b) {
            return Ok(false);
        }
        table = i64::from_le_bytes(b);
    }
    let table = table as u64;
    let mut h = [0u8; 8];
    if table <= data_start || !read_at(table, &mut h) {
        return Ok(false);
    }
    // version (4), number of chunks (4)
    let chunks = u64::from(u32::from_le_bytes([h[4], h[5], h[6], h[7]]));
    let room = table.saturating_sub(data_start + 8);
    if chunks > room / MIN_RECORD {
        return Err(LasError::Corrupt(format!(
            "the LAZ chunk table at byte {table} counts {chunks} chunks, more than the {room} bytes \
             of compressed points before it can hold ({MIN_RECORD} bytes at least each)"
        )));
    }
    // The table's offset is at the start of the point data (not necessarily where the header
    // and its records end).
    let mut parallel = || -> Option<bool> {
        f.seek(SeekFrom::Start(data_start)).ok()?;
        let table =
            ::laz::laszip::ChunkTable::read_from(std::io::BufReader::new(&mut *f), &header.laz_vlr().ok()?)
                .ok()?;
        let chunks: &[::laz::laszip::ChunkTableEntry] = table.as_ref();
        let bytes = chunks.iter().try_fold(0u64, |sum, c| sum.checked_add(c.byte_count))?;
        Some(bytes <= size && chunks.iter().all(|c| c.point_count <= PARALLEL_CHUNK_POINTS))
    };
    Ok(parallel().unwrap_or(false))
}

/// Most points a LAZ chunk may hold for the file to be decompressed in parallel.
const PARALLEL_CHUNK_POINTS: u64 = 1 << 20;

fn read_guarded<E>(path: &Path, sink: &mut dyn Sink<Error = E>) -> Result<ReadReport, LasError<E>> {
    let parallel = if check_lengths(path)? { ::las::LazParallelism::Yes } else { ::las::LazParallelism::No };
    let options = ::las::ReaderOptions::default().with_laz_parallelism(parallel);
    let file = std::fs::File::open(path).map_err(|e| LasError::Las(e.into()))?;
    let mut reader = ::las::Reader::with_options(std::io::BufReader::new(file), options)?;
    let header = reader.header().clone();
    let has_colors = header.point_format().has_color;
    let total = header.number_of_points();
    let batch = CHUNK.min(CHUNK_BYTES / u64::from(header.point_format().len()).max(1)).max(1);
    let mut report = ReadReport::default();
    // Where colour comes from and its range (8 or 16 bits), decided on the first chunk; a later
    // chunk may widen 8 bits to 16 (see the module's doc).
    let mut mode: Option<Colour> = None;
    let mut index = 0u64;
    // The records of a chunk, read into one buffer reused from chunk to chunk; their fields are
    // taken column by column (no `las::Point` is made: its decoding of every field cost more
    // than the rest of this reader).
    let mut data = ::las::PointDataBuilder::new().for_header(&header).build();
    sink.expect(total);
    while index < total {
        let n = batch.min(total - index);
        let read = reader.fill_points(n, &mut data).map_err(|cause| LasError::Records {
            first: index + 1,
            last: index + n,
            cause,
        })?;
        if read == 0 {
            report.warnings.push(format!("the header announces {total} points, the file holds {index}"));
            break;
        }
        let mode = match mode {
            None => *mode.insert(Colour::of(&data, has_colors)),
            Some(m) => {
                let widened = m.widened(&data);
                if let Some(w) = widened {
                    report.warnings.push(format!(
                        "{} values above 255 in points {}–{}: points 1–{index} were taken as 8-bit and \
                         are too bright; the rest is read as 16-bit",
                        w.name(),
                        index + 1,
                        index + read
                    ));
                }
                *mode.insert(widened.unwrap_or(m))
            }
        };
        let out = convert(&data, &header, mode, index)?;
        index += out.len() as u64;
        report.rows += out.len() as u64;
        report.points += out.len() as u64;
        sink.points(out).map_err(LasError::Sink)?;
    }
    report.has_colors = !matches!(mode, None | Some(Colour::None));
    Ok(report)
}

/// Records converted at a time by one task of [`convert`].
const PART: usize = 1 << 13;

/// The points of a chunk whose first point follows the `before`-th of the file, converted on the
/// pool a part at a time (each part's records taken column by column, as the `las` crate reads a
/// buffer of them); the error is that of the first point in the file's order that has one.
/// Converting a chunk on one core made the reading of a 5 M-point LAS file, and with it the start
/// of its import, wait on that core.
fn convert<E>(
    data: &::las::PointData,
    header: &::las::Header,
    mode: Colour,
    before: u64,
) -> Result<Vec<InputPoint>, LasError<E>> {
    use rayon::prelude::*;
    let mut out = vec![InputPoint::at(DVec3::ZERO, [0; 4]); data.len()];
    let record = data.record_len();
    let failed: Vec<LasError> = out
        .par_chunks_mut(PART)
        .zip(data.raw_bytes().par_chunks(PART * record))
        .enumerate()
        .filter_map(|(i, (out, bytes))| {
            let part = ::las::PointDataBuilder::new().for_header(header).build_from_bytes(bytes.to_vec());
            let first = before + (i * PART) as u64;
            part.map_err(LasError::Las).and_then(|part| fill(&part, mode, first, out)).err()
        })
        .collect();
    match failed.into_iter().next() {
        None => Ok(out),
        Some(LasError::NonFinite { index, x, y, z }) => Err(LasError::NonFinite { index, x, y, z }),
        Some(LasError::Las(e)) => Err(LasError::Las(e)),
        Some(other) => Err(LasError::Corrupt(other.to_string())),
    }
}

/// Fills `out` with the points of `part` in `mode`; the first follows the `before`-th point of the
/// file (1-based indices in errors).
fn fill(part: &::las::PointData, mode: Colour, before: u64, out: &mut [InputPoint]) -> Result<(), LasError> {
    match (mode, part.rgb()) {
        (Colour::Rgb(max), Some(rgb)) => points(
            part,
            before,
            rgb.map(|(r, g, b)| {
                let ch = |v: u16| super::to_u8(f64::from(v), max);
                [ch(r), ch(g), ch(b), 255]
            }),
            out,
        ),
        (Colour::Intensity(max), _) => points(
            part,
            before,
            part.intensity().map(|i| {
                let g = super::to_u8(f64::from(i), max);
                [g, g, g, 255]
            }),
            out,
        ),
        _ => points(part, before, std::iter::repeat([0; 4]), out),
    }
}

/// The points of `data` with their `colors`, into `out`; the first follows the `before`-th point
/// of the file (1-based indices in errors).
fn points(
    data: &::las::PointData,
    before: u64,
    colors: impl Iterator<Item = [u8; 4]>,
    out: &mut [InputPoint],
) -> Result<(), LasError> {
    let coords = data.x().zip(data.y()).zip(data.z()).zip(colors);
    for (index, (o, (((x, y), z), color))) in (before + 1..).zip(out.iter_mut().zip(coords)) {
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return Err(LasError::NonFinite { index, x, y, z });
        }
        *o = InputPoint::at(DVec3::new(x, y, z), color);
    }
    Ok(())
}

/// Where a file's colour comes from, with the largest value of its range.
#[derive(Clone, Copy, Debug)]
enum Colour {
    Rgb(f64),
    Intensity(f64),
    None,
}

impl Colour {
    /// Decided on the first points: RGB when the format has it and it is not all zero, else
    /// intensity when it is not all zero; 8-bit when no value exceeds 255.
    fn of(points: &::las::PointData, has_rgb: bool) -> Self {
        let range = |largest: u16| if largest > 255 { 65535.0 } else { 255.0 };
        let rgb = points.rgb().and_then(|c| c.map(|(r, g, b)| r.max(g).max(b)).max());
        match rgb {
            Some(m) if has_rgb && m > 0 => return Self::Rgb(range(m)),
            _ => {}
        }
        match points.intensity().max() {
            Some(m) if m > 0 => Self::Intensity(range(m)),
            _ => Self::None,
        }
    }

    /// The 16-bit mode when this is 8-bit and `points` hold a value above 255.
    fn widened(self, points: &::las::PointData) -> Option<Self> {
        match self {
            Self::Rgb(max) if max < 256.0 => {
                let above = points.rgb()?.any(|(r, g, b)| r.max(g).max(b) > 255);
                above.then_some(Self::Rgb(65535.0))
            }
            Self::Intensity(max) if max < 256.0 => {
                points.intensity().any(|i| i > 255).then_some(Self::Intensity(65535.0))
            }
            _ => None,
        }
    }

    /// What the colour is made of, for warnings.
    fn name(self) -> &'static str {
        match self {
            Self::Rgb(_) => "colour",
            Self::Intensity(_) => "intensity",
            Self::None => "no colour",
        }
    }
}
