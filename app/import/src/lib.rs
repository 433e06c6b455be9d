//! IsoKiosk import: the readers of real scans (PLY in every encoding, OBJ with MTL, glTF/GLB,
//! LAS/LAZ, E57) and the out-of-core builder of the multiresolution point hierarchy. This is the
//! file-heavy edge of the system; the store it writes is read by the pure core.

pub mod build;
pub mod estimate;
pub mod formats;
pub mod source;
pub mod writer;

pub use build::{BuildError, BuildParams, BuildSummary, Builder, Stage};

/// What the importer (readers and builder) makes of a scan, as a number: bumped by every change
/// that makes different stores from the same input with the same settings, so that stores
/// cached from a scan (the kiosk's exhibits) are built again by the new code (each bump's reason
/// is in the history of this line).
pub const BUILDER_REVISION: u32 = 8;
pub use formats::{ReadError, read_all, read_file};
pub use source::{InputPoint, ReadOptions, ReadReport, Sink};

/// Reads into `buf` until it is full or the input ends; returns the bytes read.
pub(crate) fn read_full(r: &mut (impl std::io::Read + ?Sized), buf: &mut [u8]) -> std::io::Result<usize> {
    match fill(r, buf) {
        (n, None) => Ok(n),
        (_, Some(e)) => Err(e),
    }
}

/// Reads into `buf` until it is full, the input ends or reading fails: the bytes read, and the
/// failure (the bytes before it are good).
pub(crate) fn fill(r: &mut (impl std::io::Read + ?Sized), buf: &mut [u8]) -> (usize, Option<std::io::Error>) {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return (n, Some(e)),
        }
    }
    (n, None)
}
