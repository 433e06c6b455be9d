//! The readers' common interface: a scan becomes a stream of [`InputPoint`]s handed to a
//! [`Sink`] (the builder), with a [`ReadReport`]; [`read_file`] picks the reader by the file's
//! content ([`crate::formats::detect`]). The readers themselves are in [`crate::formats`]: PLY
//! and OBJ (their faces give meshes normals, radii and spacings: [`crate::formats::mesh`]), LAS
//! and LAZ, E57. Non-finite coordinates are an error naming the row, or are dropped and counted
//! with `drop_invalid`.

pub use crate::formats::gzip::open;
pub use crate::formats::obj::read_obj;
pub use crate::formats::ply::read_ply;
use crate::ply::PlyError;
use glam::{DVec3, Vec3};
use std::io::BufReader;
use std::path::Path;

/// One sample as read from a file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InputPoint {
    /// Position in the file's coordinates.
    pub pos: DVec3,
    /// Unit normal, or zero when unknown.
    pub normal: Vec3,
    /// sRGB colour with alpha 255, or all zero when the file has no colour.
    pub color: [u8; 4],
    /// Radius this sample must cover at least (from the mesh's faces), or 0 when unknown.
    pub radius: f32,
    /// Side of the area this sample covers (the square root of a third of its triangles' area,
    /// from the mesh's faces), or 0 when unknown (then estimated from its neighbours).
    pub spacing: f32,
}

impl InputPoint {
    /// A point of a cloud (a survey scan): its position and colour; its normal and the area it
    /// covers are estimated from its neighbours.
    pub fn at(pos: DVec3, color: [u8; 4]) -> Self {
        Self { pos, normal: Vec3::ZERO, color, radius: 0.0, spacing: 0.0 }
    }
}

/// Options of the readers.
#[derive(Clone, Copy, Debug)]
pub struct ReadOptions {
    /// Drop samples with NaN/∞ coordinates (counted in a warning) instead of failing.
    pub drop_invalid: bool,
    /// Plain meshes with at most this many vertices get area-weighted normals from their faces
    /// (larger ones are read as clouds); a textured mesh keeps its faces whatever its size.
    pub face_vertex_limit: u64,
    /// Samples per texel of a textured triangle's footprint in its texture
    /// ([`crate::formats::surface`]): 1 samples a texture at its own resolution.
    pub texel_density: f32,
    /// The model's sample spacing is the diagonal of its bounding box over this: the untextured
    /// triangles of a mesh with materials (glTF, OBJ with MTL) are sampled on their surface at
    /// that spacing, and so are those of a plain mesh more than twice as large, with
    /// `fill_plain_meshes` (0: one sample per untextured triangle; [`crate::formats::surface`]).
    pub fill_divisions: u32,
    /// Whether a plain mesh (PLY or OBJ without materials) samples its triangles larger than the
    /// model's sample spacing on their surface (no holes in a low-poly mesh) instead of giving
    /// their vertices discs as large as the triangles. On by default; a fine scan's triangles
    /// are smaller than that and keep their vertices alone.
    pub fill_plain_meshes: bool,
    /// Most samples the surfaces of a mesh may make (an error beyond: a corrupted file's texture
    /// coordinates, or a density too high).
    pub max_samples: u64,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            drop_invalid: false,
            face_vertex_limit: 8_000_000,
            texel_density: 1.0,
            fill_divisions: 256,
            fill_plain_meshes: true,
            max_samples: 2_000_000_000,
        }
    }
}

impl ReadOptions {
    /// The sampling parameters of a surface whose vertices span `positions`.
    pub(crate) fn sample_params(
        &self,
        positions: impl Iterator<Item = DVec3>,
    ) -> crate::formats::surface::SampleParams {
        crate::formats::surface::SampleParams {
            texel_density: self.texel_density,
            fill_spacing: crate::formats::surface::Surface::fill_spacing(positions, self.fill_divisions),
            max_samples: self.max_samples,
        }
    }
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
    /// The file is readable but is not a usable point set.
    #[error("{0}")]
    Unusable(String),
    /// A sample has a non-finite coordinate.
    #[error("{element} row {row}{}: non-finite coordinate ({x}, {y}, {z})", .line.map(|l| format!(" (line {l})")).unwrap_or_default())]
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
    Format(#[from] crate::formats::DetectError),
    /// The LAS/LAZ reader failed.
    #[error("LAS: {0}")]
    Las(crate::formats::las::LasError),
    /// The E57 reader failed.
    #[error("E57: {0}")]
    E57(crate::formats::e57::E57Error),
    /// The OBJ reader failed.
    #[error(transparent)]
    Obj(#[from] crate::formats::obj::ObjError),
    /// The glTF reader failed.
    #[error("glTF: {0}")]
    Gltf(crate::formats::gltf::GltfError),
    /// A texture of the mesh cannot be used.
    #[error(transparent)]
    Texture(#[from] crate::formats::texture::TextureError),
}

// The wrapped errors' messages are in the variants' own (one line that says it all), so they are
// not also given as sources: a report of the chain would print each message twice.
impl<E> From<std::io::Error> for ReadError<E> {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e)
    }
}

impl<E> From<crate::formats::gltf::GltfError> for ReadError<E> {
    fn from(e: crate::formats::gltf::GltfError) -> Self {
        Self::Gltf(e)
    }
}

impl<E> ReadError<E> {
    /// Whether the reading stopped at a sample with a non-finite coordinate (which
    /// [`ReadOptions::drop_invalid`] would have dropped).
    pub fn is_non_finite(&self) -> bool {
        use crate::formats::las::LasError;
        matches!(
            self,
            Self::NonFinite { .. }
                | Self::Las(LasError::NonFinite { .. })
                | Self::Ply(PlyError::NonFinite { .. })
        )
    }
}

impl<E> From<crate::formats::las::LasError<E>> for ReadError<E> {
    fn from(e: crate::formats::las::LasError<E>) -> Self {
        e.split().map_or_else(Self::Sink, Self::Las)
    }
}

impl<E> From<crate::formats::e57::E57Error<E>> for ReadError<E> {
    fn from(e: crate::formats::e57::E57Error<E>) -> Self {
        e.split().map_or_else(Self::Sink, Self::E57)
    }
}

/// What a read produced besides the points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReadReport {
    /// Vertices read from the file (including dropped ones).
    pub rows: u64,
    /// Samples passed on.
    pub points: u64,
    /// Faces used for normals.
    pub faces_used: u64,
    /// Whether the file had normals.
    pub has_normals: bool,
    /// Whether the file had colours.
    pub has_colors: bool,
    /// Tolerated oddities.
    pub warnings: Vec<String>,
    /// The other files the scan names and the reader looked for (material libraries, textures,
    /// buffers), found or not: the model changes when one of them does.
    pub inputs: Vec<std::path::PathBuf>,
}

/// The consumer of read points: a closure taking them one by one, or the builder itself (which
/// takes a mesh's vertices over whole, and a survey reader's batches a batch at a time).
pub trait Sink {
    /// Why it stops taking points: given back to the reader's caller as it is
    /// ([`ReadError::Sink`]; an error type, for [`ReadError`] to be one).
    type Error;

    /// Takes one point; an error stops the reading.
    fn point(&mut self, p: InputPoint) -> Result<(), Self::Error>;

    /// How many points the reader expects to pass on, when the file says (a survey file's
    /// header): for a progress bar. Nothing by default.
    fn expect(&mut self, _points: u64) {}

    /// Takes points in file order, all at once (the vertices of a mesh, once its faces are
    /// applied; a batch of a survey file); one by one unless the consumer can do better.
    fn points(&mut self, points: Vec<InputPoint>) -> Result<(), Self::Error> {
        points.into_iter().try_for_each(|p| self.point(p))
    }
}

/// A closure that takes every point (it cannot fail: a consumer that may stop the reading
/// implements [`Sink`] with its own error).
impl<F: FnMut(InputPoint) -> Result<(), std::convert::Infallible>> Sink for F {
    type Error = std::convert::Infallible;

    fn point(&mut self, p: InputPoint) -> Result<(), Self::Error> {
        self(p)
    }
}

impl Sink for crate::Builder {
    type Error = crate::BuildError;

    fn point(&mut self, p: InputPoint) -> Result<(), Self::Error> {
        self.push(p)
    }

    fn points(&mut self, points: Vec<InputPoint>) -> Result<(), Self::Error> {
        self.push_all(points)
    }
}

/// Whether a file looks like OBJ (by extension, ignoring `.gz`).
pub fn is_obj(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("").to_ascii_lowercase();
    name.trim_end_matches(".gz").ends_with(".obj")
}

/// Reads a scan file in any format the importer knows ([`crate::formats::detect`]: by content,
/// gzip'd PLY and OBJ by extension).
pub fn read_file<E>(
    path: &Path,
    opts: &ReadOptions,
    sink: &mut dyn Sink<Error = E>,
) -> Result<ReadReport, ReadError<E>> {
    use crate::formats::{Format, detect};
    match detect(path)? {
        Format::Las => Ok(crate::formats::las::read(path, sink)?),
        Format::E57 => Ok(crate::formats::e57::read(path, sink)?),
        Format::Obj => crate::formats::obj::read_obj_in(&mut open(path)?, path.parent(), opts, sink),
        Format::Ply => crate::formats::ply::read_ply_in(&mut open(path)?, path.parent(), opts, sink),
        Format::Gltf => crate::formats::gltf::read(path, opts, sink),
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
    let rep = read_ply(&mut r, opts, &mut |p| {
        pts.push(p);
        Ok(())
    })?;
    Ok((pts, rep))
}
