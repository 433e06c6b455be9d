//! What every reader gives and takes: a scan becomes a stream of [`InputPoint`]s handed to a
//! [`Sink`] (the builder, or a closure), read with [`ReadOptions`], and a [`ReadReport`]. The
//! readers themselves, one module per format, and the dispatch of a file to its reader are in
//! [`crate::formats`]. This module depends on no other of the crate.

use glam::{DVec3, Vec3};

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

impl ReadOptions {
    /// Whether `d` samples per texel is a density the readers take: more than 0, at most 64.
    pub fn texel_density_ok(d: f32) -> bool {
        d > 0.0 && d <= 64.0
    }
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
    /// ([`crate::formats::ReadError::Sink`]; an error type, for that to be one).
    type Error;

    /// Takes one point; an error stops the reading.
    fn point(&mut self, p: InputPoint) -> Result<(), Self::Error>;

    /// How many more points the reader will pass on after those it has passed, when it knows (a
    /// survey file's header, a mesh's surface samples after its vertices): for a progress bar.
    /// Nothing by default.
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
