//! IsoKiosk import: the readers of real scans (PLY in every encoding, OBJ) and the out-of-core
//! builder of the multiresolution point hierarchy. This is the file-heavy edge of the system;
//! the store it writes is read by the pure core.

pub mod build;
pub mod estimate;
pub mod ply;
pub mod source;
pub mod writer;

pub use build::{BuildError, BuildParams, BuildSummary, Builder, Stage};
pub use source::{InputPoint, ReadError, ReadOptions, ReadReport};
