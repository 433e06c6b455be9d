//! The reader layer: which format a scan file is in, decided from its content (the extension
//! only tells PLY from OBJ inside gzip, and `.gltf` JSON), [`read_file`] dispatching a file to
//! its reader, and one module per format, each with its typed error: LAS/LAZ, E57, glTF, PLY
//! (over its parser, [`ply::parse`]) and OBJ (over the block line reader, `lines`). Meshes share
//! [`mesh`] (normals and spacings from faces) and [`surface`] (sampling triangles, with
//! [`texture`]). What the readers give and take is in [`crate::source`]; [`ReadError`] is any
//! reader's error, or the consumer's that stopped it.

pub mod e57;
pub mod gltf;
pub mod gzip;
pub mod las;
pub(crate) mod lines;
pub(crate) mod mesh;
pub mod obj;
pub mod ply;
pub mod surface;
pub mod texture;

use crate::source::{InputPoint, ReadOptions, ReadReport, Sink};
use ply::parse::PlyError;
use std::io::{BufReader, Read};
use std::path::Path;

/// A scan file's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Stanford PLY (any encoding, possibly gzip'd).
    Ply,
    /// Wavefront OBJ (possibly gzip'd).
    Obj,
    /// ASPRS LAS or LAZ (1.0–1.4; COPC is LAZ).
    Las,
    /// ASTM E57.
    E57,
    /// glTF 2.0: JSON (`.gltf`) or binary (`.glb`).
    Gltf,
}

/// What a file that is not a readable scan turned out to be.
#[derive(Debug, thiserror::Error)]
pub enum DetectError {
    /// The file cannot be read.
    #[error("read error: {0}")]
    Io(std::io::Error),
    /// A regular file of no bytes.
    #[error("the file is empty (0 bytes): not a scan")]
    Empty,
    /// A format this build does not read.
    #[error("{what}: not a format the importer reads; it reads {SUPPORTED}")]
    Unsupported {
        /// What the file looks like.
        what: &'static str,
    },
}

// The message is in the variant's own, so the I/O error is not also a source (see
// `ReadError`).
impl From<std::io::Error> for DetectError {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e)
    }
}

/// What a survey file that ends before the data its header announces (a copy cut short) gets
/// for an error, whichever decoder found it.
pub(crate) const CUT_SHORT: &str = "the file ends before the data its header announces (cut short?)";

/// A point's coordinates for a message: each as Rust writes it, or in scientific notation where
/// that would take more than 24 characters (the garbage of a misread file can be 1e-300).
pub(crate) fn coordinates(x: f64, y: f64, z: f64) -> String {
    let one = |v: f64| {
        let plain = v.to_string();
        if plain.len() <= 24 { plain } else { format!("{v:e}") }
    };
    format!("{}, {}, {}", one(x), one(y), one(z))
}

/// The formats the importer reads, for error messages.
pub const SUPPORTED: &str = "PLY (.ply, .ply.gz), OBJ (.obj, .obj.gz, with MTL materials), glTF 2.0 (.gltf, .glb), \
     LAS and LAZ (.las, .laz) and E57 (.e57)";

/// Decides a file's format from its first bytes (and, for text, its extension).
pub fn detect(path: &Path) -> Result<Format, DetectError> {
    let mut head = [0u8; 4096];
    let read = read_head(path, &mut head)?;
    if read == Some(0) {
        return Err(DetectError::Empty);
    }
    // A pipe is not peeked at: nothing read says nothing of its signature.
    let file = read.is_some();
    let head = &head[..read.unwrap_or(0)];
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("").to_ascii_lowercase();
    let unsupported = |what| Err(DetectError::Unsupported { what });
    if head.starts_with(b"LASF") {
        return Ok(Format::Las);
    }
    if head.starts_with(b"ASTM-E57") {
        return Ok(Format::E57);
    }
    if head.starts_with(b"ply") {
        return Ok(Format::Ply);
    }
    if head.starts_with(b"ISOKSTOR") {
        return unsupported("a file that is already a store (an exhibit takes it as it is)");
    }
    if head.starts_with(b"glTF") {
        return Ok(Format::Gltf);
    }
    // glTF JSON: an object with an "asset" near its start (or named .gltf).
    let text = head.trim_ascii_start();
    if text.starts_with(b"{")
        && (name.ends_with(".gltf") || memchr::memmem::find(text, b"\"asset\"").is_some())
    {
        return Ok(Format::Gltf);
    }
    if name.ends_with(".glb") {
        return unsupported("a file named .glb without the glTF binary header");
    }
    if file && (name.ends_with(".las") || name.ends_with(".laz")) {
        return unsupported("a file named .las or .laz that does not start with the LAS signature \"LASF\"");
    }
    if file && name.ends_with(".e57") {
        return unsupported("a file named .e57 that does not start with the E57 signature \"ASTM-E57\"");
    }
    if head.starts_with(&[0x89, b'P', b'N', b'G']) || head.starts_with(&[0xff, 0xd8, 0xff]) {
        return unsupported("an image");
    }
    if head.starts_with(b"PK\x03\x04") {
        return unsupported("a ZIP archive (unpack it first)");
    }
    // Text or gzip: by the name, `.gz` aside (the reader inflates by content).
    let base = name.trim_end_matches(".gz");
    if base.ends_with(".obj") {
        return Ok(Format::Obj);
    }
    if base.ends_with(".ply") || head.starts_with(&[0x1f, 0x8b]) || head.is_empty() {
        // A gzip'd file without a telling name, or a pipe: the PLY reader says what is wrong.
        return Ok(Format::Ply);
    }
    unsupported("an unknown file")
}

/// Reads the first bytes of a regular file into `head`: how many, `None` for anything else.
fn read_head(path: &Path, head: &mut [u8]) -> std::io::Result<Option<usize>> {
    // Only a regular file is peeked at: reading a pipe would take its bytes from the reader.
    if !std::fs::metadata(path)?.is_file() {
        return Ok(None);
    }
    let mut f = std::fs::File::open(path)?;
    let mut n = 0;
    while n < head.len() {
        match f.read(&mut head[n..])? {
            0 => break,
            k => n += k,
        }
    }
    Ok(Some(n))
}

/// Runs a decoder of another crate that may panic on a corrupted file (the LAZ decoder asserts
/// on its arithmetic coder's state), turning a panic into `err` with the panic's message: a
/// broken file is an error, never a crash of the kiosk.
pub(crate) fn guarded<T, E>(
    decode: impl FnOnce() -> Result<T, E>,
    err: impl FnOnce(String) -> E,
) -> Result<T, E> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(decode)).unwrap_or_else(|panic| {
        let msg = panic
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown failure".into());
        Err(err(format!("the decoder failed on corrupted data ({msg})")))
    })
}

/// Converts a colour channel of range `0..=max` to 8 bits, to the nearest (halves up; NaN
/// gives 0). Adding a half and truncating instead of `f64::round`, which baseline x86-64 calls
/// from the C library, for every channel of every point.
#[inline]
pub(crate) fn to_u8(v: f64, max: f64) -> u8 {
    (v / max * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// Why a scan cannot be read: the readers' own errors, or `E`, the error of the consumer of the
/// points ([`Sink::Error`]) that stopped the reading, as it gave it (a builder's I/O error stays
/// an I/O error).
#[derive(Debug, thiserror::Error)]
pub enum ReadError<E = std::convert::Infallible> {
    /// The PLY reader failed.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// I/O failure.
    #[error("read error: {0}")]
    Io(std::io::Error),
    /// A mesh's triangles cannot be sampled.
    #[error(transparent)]
    Surface(#[from] surface::SurfaceError),
    /// A sample has a non-finite coordinate.
    #[error("{element} row {row}{}: non-finite coordinate ({})", .line.map(|l| format!(" (line {l})")).unwrap_or_default(), coordinates(*.x, *.y, *.z))]
    NonFinite {
        /// Element ("vertex" or "v" for OBJ).
        element: String,
        /// 1-based row.
        row: u64,
        /// 1-based line when known.
        line: Option<usize>,
        /// Coordinates.
        x: f64,
        /// Coordinates.
        y: f64,
        /// Coordinates.
        z: f64,
    },
    /// Rejected by the consumer of the points.
    #[error(transparent)]
    Sink(E),
    /// Not a format the importer reads.
    #[error(transparent)]
    Format(#[from] DetectError),
    /// The LAS/LAZ reader failed.
    #[error("LAS: {0}")]
    Las(las::LasError),
    /// The E57 reader failed.
    #[error("E57: {0}")]
    E57(e57::E57Error),
    /// The OBJ reader failed.
    #[error(transparent)]
    Obj(#[from] obj::ObjError),
    /// The glTF reader failed.
    #[error("glTF: {0}")]
    Gltf(gltf::GltfError),
    /// A texture of the mesh cannot be used.
    #[error(transparent)]
    Texture(#[from] texture::TextureError),
}

// The wrapped errors' messages are in the variants' own (one line that says it all), so they are
// not also given as sources: a report of the chain would print each message twice.
impl<E> From<std::io::Error> for ReadError<E> {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e)
    }
}

impl<E> From<gltf::GltfError> for ReadError<E> {
    fn from(e: gltf::GltfError) -> Self {
        Self::Gltf(e)
    }
}

impl<E> ReadError<E> {
    /// Whether the reading stopped at a sample with a non-finite coordinate (which
    /// [`ReadOptions::drop_invalid`] would have dropped).
    pub fn is_non_finite(&self) -> bool {
        use las::LasError;
        matches!(
            self,
            Self::NonFinite { .. }
                | Self::Las(LasError::NonFinite { .. })
                | Self::Ply(PlyError::NonFinite { .. })
        )
    }
}

impl<E> From<las::LasError<E>> for ReadError<E> {
    fn from(e: las::LasError<E>) -> Self {
        e.split().map_or_else(Self::Sink, Self::Las)
    }
}

impl<E> From<e57::E57Error<E>> for ReadError<E> {
    fn from(e: e57::E57Error<E>) -> Self {
        e.split().map_or_else(Self::Sink, Self::E57)
    }
}

/// Whether a file looks like OBJ (by extension, ignoring `.gz`).
pub fn is_obj(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("").to_ascii_lowercase();
    name.trim_end_matches(".gz").ends_with(".obj")
}

/// Reads a scan file in any format the importer knows ([`detect`]: by content,
/// gzip'd PLY and OBJ by extension).
pub fn read_file<E>(
    path: &Path,
    opts: &ReadOptions,
    sink: &mut dyn Sink<Error = E>,
) -> Result<ReadReport, ReadError<E>> {
    match detect(path)? {
        Format::Las => Ok(las::read(path, sink)?),
        Format::E57 => Ok(e57::read(path, sink)?),
        Format::Obj => obj::read_obj_in(&mut gzip::open(path)?, path.parent(), opts, sink),
        Format::Ply => ply::read_ply_in(&mut gzip::open(path)?, path.parent(), opts, sink),
        Format::Gltf => gltf::read(path, opts, sink),
    }
}

/// Reads a whole file into memory (for small files and tests).
pub fn read_all(path: &Path, opts: &ReadOptions) -> Result<(Vec<InputPoint>, ReadReport), ReadError> {
    let mut pts = Vec::new();
    let rep = read_file(path, opts, &mut |p| {
        pts.push(p);
        Ok(())
    })?;
    Ok((pts, rep))
}

/// Reads from any byte source (PLY).
pub fn read_ply_bytes(bytes: &[u8], opts: &ReadOptions) -> Result<(Vec<InputPoint>, ReadReport), ReadError> {
    let mut pts = Vec::new();
    let mut r = BufReader::new(bytes);
    let rep = ply::read_ply(&mut r, opts, &mut |p| {
        pts.push(p);
        Ok(())
    })?;
    Ok((pts, rep))
}

#[cfg(test)]
mod tests {
    #[test]
    fn coordinates_in_messages_stay_short() {
        assert_eq!(super::coordinates(1.0, f64::NAN, -0.25), "1, NaN, -0.25");
        assert_eq!(super::coordinates(2.5e-300, f64::INFINITY, -1.5e250), "2.5e-300, inf, -1.5e250");
    }
}
