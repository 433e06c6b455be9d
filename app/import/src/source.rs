//! Reading scans (PLY in every encoding, gzip-wrapped or not, and OBJ vertices) into a stream of
//! [`InputPoint`]s for the builder.
//!
//! Faces are used where they help: area-weighted vertex normals for meshes whose vertices fit in
//! memory (`face_vertex_limit`); larger meshes are streamed as point clouds and their normals are
//! estimated by the builder. Non-finite coordinates are an error naming the row, or are dropped
//! and counted with `drop_invalid`.
//!
//! A mesh's faces give each vertex an area-weighted normal, a radius at least the circumradius of
//! its triangles (so the splats cover the mesh without holes) and a spacing, the side of a third
//! of its triangles' area (so a mesh needs no neighbour search). When the vertices come first and
//! bring no normals (the common layout), each triangle is applied as it is read, its terms summed
//! into its vertices' own fields, and never kept; otherwise the triangles are kept and applied
//! once every vertex is there, in parallel by vertex range, each range taking its triangles in
//! file order, so both ways give the same values. A dropped vertex keeps its place, so the face
//! indices after it stay right; its triangles give nothing to their other vertices. A gzip'd file
//! is inflated a few 1 MiB blocks ahead, on a thread of its own (`ReadAhead`).

use crate::lines::{Stop, Tokens, parse_i64};
use crate::ply::{self, PlyError, PropKind};
use glam::{DVec3, Vec3};
use std::io::{BufRead, BufReader};
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

/// Options of the readers.
#[derive(Clone, Copy, Debug)]
pub struct ReadOptions {
    /// Drop samples with NaN/∞ coordinates (counted in a warning) instead of failing.
    pub drop_invalid: bool,
    /// Meshes with at most this many vertices get area-weighted normals from their faces.
    pub face_vertex_limit: u64,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self { drop_invalid: false, face_vertex_limit: 8_000_000 }
    }
}

/// Why a scan cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The PLY reader failed.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// I/O failure.
    #[error("read error: {0}")]
    Io(#[from] std::io::Error),
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
    #[error("{0}")]
    Sink(String),
    /// Not a format the importer reads.
    #[error(transparent)]
    Format(#[from] crate::formats::DetectError),
    /// The LAS/LAZ reader failed.
    #[error("LAS: {0}")]
    Las(#[from] crate::formats::las::LasError),
    /// The E57 reader failed.
    #[error("E57: {0}")]
    E57(#[from] crate::formats::e57::E57Error),
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
}

/// The consumer of read points: a closure taking them one by one, or the builder itself (which
/// takes a mesh's vertices over whole).
pub trait Sink {
    /// Takes one point; an error stops the reading.
    fn point(&mut self, p: InputPoint) -> Result<(), String>;

    /// Takes points in file order, all at once (the vertices of a mesh, once its faces are
    /// applied); one by one unless the consumer can do better.
    fn points(&mut self, points: Vec<InputPoint>) -> Result<(), String> {
        points.into_iter().try_for_each(|p| self.point(p))
    }
}

impl<F: FnMut(InputPoint) -> Result<(), String>> Sink for F {
    fn point(&mut self, p: InputPoint) -> Result<(), String> {
        self(p)
    }
}

impl Sink for crate::Builder {
    fn point(&mut self, p: InputPoint) -> Result<(), String> {
        self.push(p).map_err(|e| e.to_string())
    }

    fn points(&mut self, points: Vec<InputPoint>) -> Result<(), String> {
        self.push_all(points).map_err(|e| e.to_string())
    }
}

/// Opens a file, unwrapping gzip when its first bytes say so (inflated on a thread of its own,
/// ahead of the reader: inflating takes about as long as parsing the text it gives).
pub fn open(path: &Path) -> std::io::Result<Box<dyn BufRead + Send>> {
    let mut f = BufReader::with_capacity(1 << 20, std::fs::File::open(path)?);
    let gz = f.fill_buf()?.starts_with(&[0x1f, 0x8b]);
    Ok(if gz { ReadAhead::start(flate2::bufread::MultiGzDecoder::new(f)) } else { Box::new(f) })
}

/// A reader read on a thread of its own, a few blocks ahead of its consumer. A failure comes
/// after the bytes read before it; the thread stops when the consumer is dropped. The end of
/// the input is an empty block: a thread that stops without one (a panic) is an error, not an
/// input cut short.
struct ReadAhead {
    blocks: std::sync::mpsc::Receiver<std::io::Result<Vec<u8>>>,
    /// Blocks consumed, for the thread to fill again.
    spare: std::sync::mpsc::Sender<Vec<u8>>,
    block: Vec<u8>,
    at: usize,
    /// The empty block came.
    ended: bool,
}

impl ReadAhead {
    /// Bytes per block.
    const BLOCK: usize = 1 << 20;

    /// Reads `inner` ahead, or in place if the system refuses a thread.
    fn start(inner: impl std::io::Read + Send + 'static) -> Box<dyn BufRead + Send> {
        let (tx, blocks) = std::sync::mpsc::sync_channel(2);
        let (spare, spare_rx) = std::sync::mpsc::channel::<Vec<u8>>();
        let (inner_tx, inner_rx) = std::sync::mpsc::channel();
        let spawned = std::thread::Builder::new().name("read ahead".into()).spawn(move || {
            let Ok(mut inner) = inner_rx.recv() else { return };
            loop {
                let mut block = spare_rx.try_recv().unwrap_or_default();
                block.resize(Self::BLOCK, 0);
                let (got, failed) = crate::fill(&mut inner, &mut block);
                block.truncate(got);
                if got > 0 && tx.send(Ok(block)).is_err() {
                    return;
                }
                if let Some(e) = failed {
                    let _ = tx.send(Err(e));
                    return;
                }
                if got < Self::BLOCK {
                    let _ = tx.send(Ok(Vec::new()));
                    return;
                }
            }
        });
        match spawned {
            Ok(_) => {
                inner_tx.send(inner).map_or_else(
                    // The thread is gone already: read in place.
                    |e| Box::new(BufReader::with_capacity(Self::BLOCK, e.0)) as Box<dyn BufRead + Send>,
                    |()| Box::new(Self { blocks, spare, block: Vec::new(), at: 0, ended: false }),
                )
            }
            // `inner` was never handed over.
            Err(_) => Box::new(BufReader::with_capacity(Self::BLOCK, inner)),
        }
    }
}

impl std::io::Read for ReadAhead {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let got = self.fill_buf()?;
        let n = got.len().min(buf.len());
        buf[..n].copy_from_slice(&got[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for ReadAhead {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.at == self.block.len() && !self.ended {
            match self.blocks.recv() {
                Ok(Ok(block)) => {
                    self.ended = block.is_empty();
                    let used = std::mem::replace(&mut self.block, block);
                    // The thread may be done: the buffer is then dropped.
                    let _ = self.spare.send(used);
                    self.at = 0;
                }
                Ok(Err(e)) => return Err(e),
                Err(_) => return Err(std::io::Error::other("the thread reading the input stopped")),
            }
        }
        Ok(&self.block[self.at..])
    }

    fn consume(&mut self, n: usize) {
        self.at = (self.at + n).min(self.block.len());
    }
}

/// Whether a file looks like OBJ (by extension, ignoring `.gz`).
pub fn is_obj(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("").to_ascii_lowercase();
    name.trim_end_matches(".gz").ends_with(".obj")
}

/// Reads a scan file in any format the importer knows ([`crate::formats::detect`]: by content,
/// gzip'd PLY and OBJ by extension).
pub fn read_file(path: &Path, opts: &ReadOptions, sink: &mut dyn Sink) -> Result<ReadReport, ReadError> {
    use crate::formats::{Format, detect};
    match detect(path)? {
        Format::Las => Ok(crate::formats::las::read(path, sink)?),
        Format::E57 => Ok(crate::formats::e57::read(path, sink)?),
        Format::Obj => read_obj(&mut open(path)?, opts, sink),
        Format::Ply => read_ply(&mut open(path)?, opts, sink),
    }
}

/// Vertices buffered to apply face normals.
#[derive(Default)]
struct Buffered {
    /// Every vertex row, in order (a dropped one as a non-finite placeholder, so that face
    /// indices stay right; placeholders are never passed on).
    points: Vec<InputPoint>,
    /// The triangles of the faces, in file order, applied once every vertex is read.
    tris: Vec<[u32; 3]>,
    /// Whether some triangle's indices are still to be checked against the vertices (it was
    /// read before every vertex was).
    unchecked: bool,
    /// Vertices kept only for their place (dropped for a non-finite position).
    dropped: usize,
    /// Whether the triangles are applied as they come ([`Buffered::accumulate`]) instead of kept.
    streamed: bool,
}

impl Buffered {
    /// Keeps the place of a vertex dropped for its non-finite position `pos`, so that face
    /// indices stay right; it is never passed on, and its triangles give nothing to the others.
    fn push_dropped(&mut self, pos: DVec3) {
        debug_assert!(!pos.is_finite());
        self.dropped += 1;
        self.points.push(dropped_vertex(pos));
    }

    /// Takes the triangles (a fan) of a polygon ([`polygon_triangles`]), applied in
    /// [`Buffered::finish`]; its indices are checked there, the vertices still to come.
    fn add_polygon(&mut self, idx: &[f64]) -> Result<(), String> {
        polygon_triangles(idx, None, &mut self.tris)?;
        self.unchecked = true;
        Ok(())
    }

    /// Adds the terms of `tris`, read after every vertex, to the vertices they touch, in the
    /// vertices' own fields: the normal sums the area-weighted normals, the radius keeps the
    /// largest circumradius², the spacing sums twice the areas ([`Buffered::finish`] turns them
    /// into the normal, radius and spacing [`apply_triangles`] gives). For a mesh whose vertices
    /// come first and have no normals of their own, the common layout: its triangles are applied
    /// in file order as they are read and never kept, and the vertices need no other buffer.
    fn accumulate(&mut self, tris: &[[u32; 3]]) {
        let points = &mut self.points;
        for t in tris {
            // Indices were checked against the vertices, all read, when the face was converted.
            let (Some(a), Some(b), Some(c)) = t.map(|i| points.get(i as usize).map(|p| p.pos)).into() else {
                continue;
            };
            let Some(terms) = triangle_terms([a, b, c]) else { continue };
            for &i in t {
                let p = &mut points[i as usize];
                let mut sum = Terms::kept_in(p);
                sum.add(terms);
                sum.keep_in(p);
            }
        }
    }

    /// Applies the triangles and passes the vertices on with their face normals (where they
    /// have none of their own) and radii.
    fn finish(mut self, report: &mut ReadReport, sink: &mut dyn Sink) -> Result<(), ReadError> {
        let n = self.points.len();
        if self.unchecked
            && let Some(t) = self.tris.iter().find(|t| t.iter().any(|&i| i as usize >= n))
        {
            return Err(ReadError::Unusable(format!(
                "a face refers to vertex {} but the file has {n} vertices (indices start at 0)",
                t.iter().max().copied().unwrap_or(0)
            )));
        }
        if self.streamed {
            use rayon::prelude::*;
            self.points.par_iter_mut().for_each(|p| {
                let sum = Terms::kept_in(p);
                (p.normal, p.radius, p.spacing) = (sum.normal(), sum.radius(), sum.spacing());
            });
        } else if !self.tris.is_empty() {
            apply_triangles(&mut self.points, &std::mem::take(&mut self.tris));
        }
        // Dropped vertices kept their place for the faces only.
        if self.dropped > 0 {
            self.points.retain(|p| p.pos.is_finite());
        }
        report.points += self.points.len() as u64;
        sink.points(self.points).map_err(ReadError::Sink)
    }
}

/// The placeholder of a vertex dropped for its non-finite position `pos` (kept for the faces'
/// indices only).
fn dropped_vertex(pos: DVec3) -> InputPoint {
    debug_assert!(!pos.is_finite());
    InputPoint { pos, normal: Vec3::ZERO, color: [0; 4], radius: 0.0, spacing: 0.0 }
}

/// Appends the triangles (a fan) of a polygon to `tris`. A polygon with fewer than 3 vertices
/// or an index out of range is an error (a broken mesh); indices are checked against the
/// number of `vertices` when every vertex is read already, else only against the range of
/// `u32` (and later against the vertices, in [`Buffered::finish`]).
fn polygon_triangles(idx: &[f64], vertices: Option<usize>, tris: &mut Vec<[u32; 3]>) -> Result<(), String> {
    if idx.len() < 3 {
        return Err(format!("polygon with {} vertex index(es); a face needs at least 3", idx.len()));
    }
    // One test per index; which one is wrong, and how, only when one is.
    let below = vertices.map_or(f64::from(u32::MAX), |n| (n as f64).min(f64::from(u32::MAX)));
    if !idx.iter().all(|i| (0.0..below).contains(i)) {
        if let Some(bad) = idx.iter().find(|&&i| !(0.0..f64::from(u32::MAX)).contains(&i)) {
            return Err(format!("vertex index {bad} is out of range"));
        }
        let n = vertices.unwrap_or(usize::MAX);
        let bad = idx.iter().find(|&&i| i as usize >= n).copied().unwrap_or(f64::NAN);
        return Err(format!(
            "vertex index {bad} is out of range: the file has {n} vertices (indices start at 0)"
        ));
    }
    tris.extend((1..idx.len() - 1).map(|k| [idx[0], idx[k], idx[k + 1]].map(|i| i as u32)));
    Ok(())
}

/// Gives every vertex the normalised sum of its triangles' area-weighted normals (where it has
/// no normal of its own), as its radius the largest of their circumradii, and as its spacing
/// the square root of a third of their area (each triangle's area shared by its three
/// vertices: the area the vertex covers); a vertex in no triangle gets radius and spacing 0.
/// Every index must be below `points.len()`.
///
/// In parallel, deterministically: the vertices are split into one range per thread of the
/// pool, and each range takes the triangles that touch it in file order (a triangle across two
/// ranges is computed in both, to the same value), so every vertex sums its triangles in the
/// order of the file, as one pass over them would.
fn apply_triangles(points: &mut [InputPoint], tris: &[[u32; 3]]) {
    use rayon::prelude::*;
    let per = points.len().div_ceil(rayon::current_num_threads().max(1)).max(1);
    let all: &[InputPoint] = points;
    let sums: Vec<Vec<Terms>> = (0..all.len().div_ceil(per))
        .into_par_iter()
        .map(|j| {
            let lo = j * per;
            let mut sums = vec![Terms::default(); per.min(all.len() - lo)];
            for &t in tris {
                let local = t.map(|i| (i as usize).wrapping_sub(lo));
                if local.iter().all(|&k| k >= sums.len()) {
                    continue;
                }
                let Some(terms) = triangle_terms(t.map(|i| all[i as usize].pos)) else { continue };
                for k in local {
                    if let Some(s) = sums.get_mut(k) {
                        s.add(terms);
                    }
                }
            }
            sums
        })
        .collect();
    points.par_chunks_mut(per).zip(sums).for_each(|(points, sums)| {
        for (p, sum) in points.iter_mut().zip(sums) {
            if p.normal == Vec3::ZERO {
                p.normal = sum.normal();
            }
            (p.radius, p.spacing) = (sum.radius(), sum.spacing());
        }
    });
}

/// What a vertex sums of its triangles, in file order: their area-weighted normals, the largest
/// of their circumradii², twice their areas. In `f32`, the precision of what they become (the
/// terms of a triangle are computed in `f64`, from its vertices' `f64` positions): a vertex's
/// sum takes the same 20 bytes as the normal, radius and spacing it ends as, which is where a
/// streamed mesh keeps it ([`Buffered::accumulate`]).
#[derive(Clone, Copy, Debug, Default)]
struct Terms {
    normal: Vec3,
    r2: f32,
    area2: f32,
}

impl Terms {
    /// The sum a streamed vertex keeps in its normal, radius and spacing.
    #[inline]
    fn kept_in(p: &InputPoint) -> Self {
        Self { normal: p.normal, r2: p.radius, area2: p.spacing }
    }

    /// Keeps the sum in the vertex's normal, radius and spacing ([`Terms::kept_in`] reads it).
    #[inline]
    fn keep_in(self, p: &mut InputPoint) {
        (p.normal, p.radius, p.spacing) = (self.normal, self.r2, self.area2);
    }

    #[inline]
    fn add(&mut self, t: Terms) {
        self.normal += t.normal;
        self.r2 = self.r2.max(t.r2);
        self.area2 += t.area2;
    }

    /// The normalised sum (zero when the triangles have no area), normalised in `f64` so that a
    /// sum of tiny areas keeps its direction.
    fn normal(&self) -> Vec3 {
        self.normal.as_dvec3().try_normalize().map_or(Vec3::ZERO, |v| v.as_vec3())
    }

    /// The largest circumradius.
    fn radius(&self) -> f32 {
        self.r2.sqrt()
    }

    /// The square root of the area the vertex covers: a third of its triangles' area.
    fn spacing(&self) -> f32 {
        (self.area2 / 6.0).sqrt()
    }
}

/// A triangle's area-weighted normal, its circumradius squared (capped by its longest edge) and
/// twice its area, or `None` when a vertex was dropped (its triangles give nothing to the
/// others).
#[inline]
fn triangle_terms([a, b, c]: [DVec3; 3]) -> Option<Terms> {
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return None;
    }
    // Cross product length = 2 × area: area weighting for free.
    let nrm = (b - a).cross(c - a);
    // Every point of a triangle is within its circumradius of a vertex, so discs of that
    // radius at the vertices leave no hole (capped by the longest edge for slivers, whose
    // circumradius explodes). Squared, so that a vertex takes one square root in all.
    let (ab, bc, ca) = ((b - a).length_squared(), (c - b).length_squared(), (a - c).length_squared());
    let longest = ab.max(bc).max(ca);
    // |n|² = 4 × area²; the circumradius² is ab² bc² ca² / (4 |n|²), taken in an order that
    // keeps the products within the range of |n|² itself.
    let n2 = nrm.length_squared();
    let circum = if n2 > 0.0 { ab * (bc / n2) * ca * 0.25 } else { longest };
    Some(Terms { normal: nrm.as_vec3(), r2: circum.min(longest) as f32, area2: n2.sqrt() as f32 })
}

fn color_channel(v: f64, ty: ply::Scalar) -> u8 {
    use ply::Scalar::*;
    let x = match ty {
        F32 | F64 => v * 255.0,
        U16 | I16 => v / 257.0,
        U32 | I32 => v / 16_843_009.0,
        U8 | I8 => v,
    };
    if x.is_finite() { x.round().clamp(0.0, 255.0) as u8 } else { 0 }
}

/// Reads a PLY stream.
pub fn read_ply(
    r: &mut (dyn BufRead + Send),
    opts: &ReadOptions,
    sink: &mut dyn Sink,
) -> Result<ReadReport, ReadError> {
    let header = ply::read_header(r)?;
    let mut report = ReadReport { warnings: header.warnings.clone(), ..Default::default() };
    let names: Vec<&str> = header.elements.iter().map(|e| e.name.as_str()).collect();
    let vi = header.elements.iter().position(|e| e.name == "vertex").ok_or_else(|| {
        ReadError::Unusable(if names.is_empty() {
            "no 'vertex' element: the file declares no elements".into()
        } else {
            format!("no 'vertex' element (elements: {})", names.join(", "))
        })
    })?;
    let v = &header.elements[vi];
    let scalar = |name: &str| {
        v.prop(name).and_then(|i| match v.props[i].kind {
            PropKind::Scalar(t) => Some((i, t)),
            PropKind::List { .. } => None,
        })
    };
    let missing: Vec<&str> = ["x", "y", "z"].into_iter().filter(|n| scalar(n).is_none()).collect();
    if !missing.is_empty() {
        return Err(ReadError::Unusable(format!(
            "element 'vertex' has no scalar propert{} {}: it holds no 3D positions",
            if missing.len() == 1 { "y" } else { "ies" },
            missing.join(", ")
        )));
    }
    if v.count == 0 {
        return Err(ReadError::Unusable("the file has 0 vertices".into()));
    }
    let pos_idx = ["x", "y", "z"].map(|n| scalar(n).map_or(0, |s| s.0));
    let normal_idx = match ["nx", "ny", "nz"].map(scalar) {
        [Some(a), Some(b), Some(c)] => Some([a.0, b.0, c.0]),
        _ => None,
    };
    let color_idx = ["red", "green", "blue"]
        .map(scalar)
        .into_iter()
        .collect::<Option<Vec<_>>>()
        .or_else(|| ["diffuse_red", "diffuse_green", "diffuse_blue"].map(scalar).into_iter().collect());
    let alpha_idx = scalar("alpha").or_else(|| scalar("diffuse_alpha"));
    report.has_normals = normal_idx.is_some();
    report.has_colors = color_idx.is_some();

    let face = header.elements.iter().position(|e| e.name == "face").and_then(|fi| {
        let f = &header.elements[fi];
        let li = f.prop("vertex_indices").or_else(|| f.prop("vertex_index"))?;
        matches!(f.props[li].kind, PropKind::List { .. }).then_some((fi, li))
    });
    let use_faces = face.is_some() && v.count <= opts.face_vertex_limit;
    if face.is_some() && !use_faces {
        report.warnings.push(format!(
            "{} vertices exceed the face-normal limit ({}): faces ignored, normals estimated",
            v.count, opts.face_vertex_limit
        ));
    }
    let mut buffered = Buffered::default();
    // The vertices a face may refer to, when every vertex comes before the faces.
    let vertices = face.filter(|&(fi, _)| vi < fi).and_then(|_| usize::try_from(v.count).ok());
    buffered.streamed = use_faces && vertices.is_some() && normal_idx.is_none();
    if use_faces {
        // Every vertex is kept until the faces are applied: room for them at once, up to 4 Mi
        // (a broken header's count takes no more; the buffer grows past that as rows come).
        let _ = buffered.points.try_reserve_exact(usize::try_from(v.count.min(1 << 22)).unwrap_or(0));
        // And for a triangle per face (12 bytes each, kept until every vertex is read), up to 8 Mi.
        if let Some((fi, _)) = face.filter(|_| !buffered.streamed) {
            let faces = header.elements[fi].count.min(1 << 23);
            let _ = buffered.tris.try_reserve_exact(usize::try_from(faces).unwrap_or(0));
        }
    }
    let conv = PlyRows {
        vi,
        face,
        pos_idx,
        normal_idx,
        color_idx,
        alpha_idx,
        use_faces,
        drop_invalid: opts.drop_invalid,
        vertices,
    };
    let mut dropped = 0u64;
    let mut sink_err = None;
    let body_warnings = ply::read_body_converted(r, &header, &conv, |out: &mut PlyOut| {
        report.rows += out.rows;
        report.faces_used += out.faces;
        dropped += out.dropped;
        if use_faces {
            buffered.points.append(&mut out.points);
            if buffered.streamed {
                buffered.accumulate(&out.tris);
            } else {
                buffered.tris.append(&mut out.tris);
            }
            buffered.dropped += out.dropped as usize;
            buffered.unchecked |= out.unchecked;
        } else if sink_err.is_none() {
            for p in out.points.drain(..) {
                if let Err(e) = sink.point(p) {
                    sink_err = Some(e);
                    break;
                }
                report.points += 1;
            }
        }
        Ok(())
    });
    let body_warnings = body_warnings?;
    if let Some(e) = sink_err {
        return Err(ReadError::Sink(e));
    }
    report.warnings.extend(body_warnings);
    if dropped > 0 {
        report.warnings.push(format!("{dropped} vertex row(s) with non-finite coordinates dropped"));
    }
    if use_faces {
        buffered.finish(&mut report, sink)?;
    }
    Ok(report)
}

/// How [`read_ply`] converts the rows of a PLY body (on the pool, [`ply::Convert`]): vertices
/// into samples, faces into triangles (where they are used).
struct PlyRows {
    /// The vertex element, and the face element and its index list.
    vi: usize,
    face: Option<(usize, usize)>,
    /// Where a vertex row holds its position, normal, colour and alpha (with their types).
    pos_idx: [usize; 3],
    normal_idx: Option<[usize; 3]>,
    color_idx: Option<Vec<(usize, ply::Scalar)>>,
    alpha_idx: Option<(usize, ply::Scalar)>,
    /// Whether the faces give the vertices normals and radii (else only broken polygons are
    /// looked at: an error either way).
    use_faces: bool,
    drop_invalid: bool,
    /// The vertices a face may refer to, when every vertex comes before the faces (else the
    /// indices are checked once every vertex is read).
    vertices: Option<usize>,
}

/// The rows of a run converted: its vertices (a dropped one as a placeholder where the faces
/// are used, to keep the faces' indices right), its faces' triangles, and counts.
#[derive(Default)]
struct PlyOut {
    points: Vec<InputPoint>,
    tris: Vec<[u32; 3]>,
    /// Vertex rows, of which dropped for a non-finite position, and faces used.
    rows: u64,
    dropped: u64,
    faces: u64,
    /// Whether a triangle's indices are still to be checked against the vertices.
    unchecked: bool,
}

impl ply::Convert for PlyRows {
    type Out = PlyOut;

    fn clear(&self, out: &mut PlyOut) {
        out.points.clear();
        out.tris.clear();
        (out.rows, out.dropped, out.faces, out.unchecked) = (0, 0, 0, false);
    }

    fn convert(&self, ei: usize, ri: u64, row: &ply::Row, out: &mut PlyOut) -> Result<(), PlyError> {
        if ei == self.vi {
            out.rows += 1;
            let [x, y, z] = self.pos_idx.map(|i| row.values[i]);
            if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                if self.drop_invalid {
                    out.dropped += 1;
                    if self.use_faces {
                        out.points.push(dropped_vertex(DVec3::new(x, y, z)));
                    }
                    return Ok(());
                }
                return Err(PlyError::Row {
                    element: "vertex".into(),
                    row: ri + 1,
                    line: None,
                    msg: format!("non-finite coordinate ({x}, {y}, {z})"),
                });
            }
            let normal = self
                .normal_idx
                .map(|n| Vec3::new(row.values[n[0]] as f32, row.values[n[1]] as f32, row.values[n[2]] as f32))
                .and_then(|n| n.is_finite().then_some(n))
                .and_then(Vec3::try_normalize)
                .unwrap_or(Vec3::ZERO);
            let color = match &self.color_idx {
                Some(c) => {
                    let a = self.alpha_idx.map_or(255, |(i, t)| color_channel(row.values[i], t));
                    [
                        color_channel(row.values[c[0].0], c[0].1),
                        color_channel(row.values[c[1].0], c[1].1),
                        color_channel(row.values[c[2].0], c[2].1),
                        a.max(1),
                    ]
                }
                None => [0; 4],
            };
            out.points.push(InputPoint {
                pos: DVec3::new(x, y, z),
                normal,
                color,
                radius: 0.0,
                spacing: 0.0,
            });
        } else if let Some((fi, li)) = self.face
            && ei == fi
            && (self.use_faces || row.lists[li].len() < 3)
        {
            // Triangles are kept as read (indices checked here when the vertices came first) and
            // applied once every vertex is read.
            polygon_triangles(&row.lists[li], self.vertices, &mut out.tris).map_err(|msg| PlyError::Row {
                element: "face".into(),
                row: ri + 1,
                line: None,
                msg,
            })?;
            out.unchecked |= self.vertices.is_none();
            out.faces += 1;
        }
        Ok(())
    }
}

/// Reads an OBJ stream: `v x y z [r g b]` vertices and `f` faces (for normals). Other statements
/// (`vn`, `vt`, groups, materials, comments, in any encoding) are ignored. Read in blocks of
/// lines parsed in parallel ([`crate::lines`]), visited in order.
pub fn read_obj(
    r: &mut dyn BufRead,
    opts: &ReadOptions,
    sink: &mut dyn Sink,
) -> Result<ReadReport, ReadError> {
    let mut report = ReadReport::default();
    let mut buffered = Buffered::default();
    let mut dropped = 0u64;
    let mut idx = Vec::new();
    let unusable = |l: usize, m: String| ReadError::Unusable(format!("line {l}: {m}"));
    let mut visit = |_: &[u8], parsed: &mut ObjParsed| -> Result<(), ReadError> {
        for piece in &mut parsed.pieces {
            let (mut v, mut f) = (0, 0);
            for st in &piece.stmts {
                match *st {
                    ObjStmt::Vertex { line, n } => {
                        let vals = &piece.values[v..v + n];
                        v += n;
                        report.rows += 1;
                        let (x, y, z) = (vals[0], vals[1], vals[2]);
                        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                            if opts.drop_invalid {
                                dropped += 1;
                                buffered.push_dropped(DVec3::new(x, y, z));
                                continue;
                            }
                            return Err(ReadError::NonFinite {
                                element: "v".into(),
                                row: report.rows,
                                line: Some(line),
                                x,
                                y,
                                z,
                            });
                        }
                        let color = if vals.len() >= 6 {
                            report.has_colors = true;
                            let [r, g, b] = [3, 4, 5].map(|i| color_channel(vals[i], ply::Scalar::F64));
                            [r, g, b, 255]
                        } else {
                            [0; 4]
                        };
                        buffered.points.push(InputPoint {
                            pos: DVec3::new(x, y, z),
                            normal: Vec3::ZERO,
                            color,
                            radius: 0.0,
                            spacing: 0.0,
                        });
                    }
                    ObjStmt::Face { line, n } => {
                        let count = buffered.points.len() as f64;
                        // 1-based, negative = relative to the end.
                        idx.clear();
                        idx.extend(
                            piece.indices[f..f + n]
                                .iter()
                                .map(|&i| if i < 0 { count + i as f64 } else { i as f64 - 1.0 }),
                        );
                        f += n;
                        buffered.add_polygon(&idx).map_err(|m| unusable(line, m))?;
                        report.faces_used += 1;
                    }
                }
            }
            if let Some((line, msg)) = piece.error.take() {
                return Err(unusable(line, msg));
            }
        }
        Ok(())
    };
    crate::lines::read(r, &ObjLines, 0, &mut visit, |stop, at| {
        Err(match stop {
            Stop::Io(e) => ReadError::Io(e),
            Stop::Overlong => {
                unusable(at + 1, format!("longer than {} MiB (binary data?)", crate::lines::MAX_LINE >> 20))
            }
        })
    })?;
    if report.rows == 0 {
        return Err(ReadError::Unusable("the file has 0 vertices ('v' lines)".into()));
    }
    if dropped > 0 {
        report.warnings.push(format!("{dropped} vertex row(s) with non-finite coordinates dropped"));
    }
    if report.rows > opts.face_vertex_limit {
        buffered.tris.clear();
    }
    buffered.finish(&mut report, sink)?;
    Ok(report)
}

/// An OBJ statement the reader uses, with how many numbers it takes from its piece.
#[derive(Clone, Copy)]
enum ObjStmt {
    /// `v`: coordinates (and colour) in `values`.
    Vertex { line: usize, n: usize },
    /// `f`: vertex indices (as written: 1-based or negative) in `indices`.
    Face { line: usize, n: usize },
}

/// The statements of consecutive lines; parsing stops at the first line in error, which is
/// returned once the statements before it are visited.
#[derive(Default)]
struct ObjPiece {
    stmts: Vec<ObjStmt>,
    values: Vec<f64>,
    indices: Vec<i64>,
    error: Option<(usize, String)>,
}

/// A block of an OBJ file parsed: its `v` and `f` lines (byte range, 1-based line), and their
/// statements in pieces.
#[derive(Default)]
struct ObjParsed {
    lines: Vec<(usize, usize, usize)>,
    pieces: Vec<ObjPiece>,
}

/// OBJ as blocks of lines; reading stands at a number of lines.
struct ObjLines;

impl crate::lines::Format for ObjLines {
    type At = usize;
    type Out = ObjParsed;

    fn scan(&self, block: &[u8], mut line: usize, out: &mut ObjParsed) -> usize {
        out.lines.clear();
        for (start, end) in crate::lines::lines(block) {
            line += 1;
            if matches!(Tokens::new(&block[start..end]).next(), Some(b"v" | b"f")) {
                out.lines.push((start, end, line));
            }
        }
        line
    }

    fn parse(&self, block: &[u8], out: &mut ObjParsed) {
        crate::lines::in_pieces(&out.lines, &mut out.pieces, |_, lines, p| {
            p.stmts.clear();
            p.values.clear();
            p.indices.clear();
            p.error = None;
            for &(start, end, line) in lines {
                if let Err(msg) = parse_obj_line(&block[start..end], line, p) {
                    p.error = Some((line, msg));
                    return;
                }
            }
        });
    }
}

fn parse_obj_line(text: &[u8], line: usize, p: &mut ObjPiece) -> Result<(), String> {
    let mut tok = Tokens::new(text);
    let quoted = |t: &[u8]| String::from_utf8_lossy(t).into_owned();
    match tok.next() {
        Some(b"v") => {
            let start = p.values.len();
            while let Some(v) = tok.next_f64() {
                p.values.push(v.map_err(|t| format!("'{}' is not a number", quoted(t)))?);
            }
            let n = p.values.len() - start;
            if n < 3 {
                return Err("vertex with fewer than 3 coordinates".into());
            }
            p.stmts.push(ObjStmt::Vertex { line, n });
        }
        _ => {
            let start = p.indices.len();
            for t in tok {
                let first = t.split(|&b| b == b'/').next().unwrap_or_default();
                let i = parse_i64(first).ok_or_else(|| format!("bad face index '{}'", quoted(t)))?;
                p.indices.push(i);
            }
            p.stmts.push(ObjStmt::Face { line, n: p.indices.len() - start });
        }
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    /// Gives `data` in reads of at most `step` bytes, then fails (or ends).
    struct Trickle {
        data: Vec<u8>,
        at: usize,
        step: usize,
        fails: bool,
    }

    impl Read for Trickle {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            if self.at == self.data.len() {
                return if self.fails { Err(std::io::Error::other("the disk went away")) } else { Ok(0) };
            }
            let n = buf.len().min(self.step).min(self.data.len() - self.at);
            buf[..n].copy_from_slice(&self.data[self.at..self.at + n]);
            self.at += n;
            Ok(n)
        }
    }

    #[test]
    fn read_ahead_gives_every_byte_in_order_then_the_failure() {
        let data: Vec<u8> =
            (0..(5 * ReadAhead::BLOCK / 2) as u32).map(|i| (i * 7 + i / 4093) as u8).collect();
        for (len, fails) in
            [(data.len(), true), (data.len(), false), (2 * ReadAhead::BLOCK, false), (0, true), (0, false)]
        {
            let trickle = Trickle { data: data[..len].to_vec(), at: 0, step: 100_003, fails };
            let mut r = ReadAhead::start(trickle);
            let mut got = Vec::new();
            let end = r.read_to_end(&mut got);
            assert!(got == data[..len], "{len} bytes: {} read", got.len());
            match end {
                Err(e) => assert!(fails && e.to_string() == "the disk went away", "{len} bytes: {e}"),
                Ok(n) => assert!(!fails && n == len, "{len} bytes: {n} read, the failure lost"),
            }
        }
    }

    #[test]
    fn a_reading_thread_that_panics_is_an_error_not_the_end_of_the_input() {
        struct Panics;
        impl Read for Panics {
            fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
                panic!("a decoder bug");
            }
        }
        let e = ReadAhead::start(Panics).read_to_end(&mut Vec::new()).expect_err("no end of input");
        assert_eq!(e.to_string(), "the thread reading the input stopped");
    }

    #[test]
    fn a_reader_dropped_early_stops_its_thread() {
        let (tx, rx) = std::sync::mpsc::channel();
        struct Endless(std::sync::mpsc::Sender<()>);
        impl Read for Endless {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                buf.fill(b'x');
                Ok(buf.len())
            }
        }
        impl Drop for Endless {
            fn drop(&mut self) {
                let _ = self.0.send(());
            }
        }
        let mut r = ReadAhead::start(Endless(tx));
        assert_eq!(r.fill_buf().expect("bytes").first(), Some(&b'x'));
        drop(r);
        // The thread drops its reader when it finds nobody reads on.
        rx.recv_timeout(std::time::Duration::from_secs(60)).expect("the thread stopped");
    }
}
