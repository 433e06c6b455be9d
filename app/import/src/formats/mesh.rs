//! What a mesh's faces give its vertices: an area-weighted normal, a radius at least the
//! circumradius of their triangles (so the splats cover the mesh without holes) and a spacing, the
//! side of a third of their triangles' area (so a mesh needs no neighbour search). When the
//! vertices come first and bring no normals (the common layout), each triangle is applied as it is
//! read, its terms summed into a sum per vertex ([`Terms`], turned into the vertex's normal, radius
//! and spacing by [`Buffered::finish`]), and never kept; otherwise the triangles are kept and
//! applied once every vertex is there, in parallel by vertex range, each range taking its triangles
//! in file order, so both ways give the same values. A dropped vertex keeps its place, so the face
//! indices after it stay right; its triangles give nothing to their other vertices.

use super::surface::{NO_MATERIAL, SampleParams, Surface, SurfaceError, Tri, linear_color};
use crate::formats::ReadError;
use crate::source::{InputPoint, ReadReport, Sink};
use glam::{DVec3, Vec3};

/// Vertices buffered to apply face normals.
#[derive(Default)]
pub(crate) struct Buffered {
    /// Every vertex row, in order (a dropped one as a non-finite placeholder, so that face
    /// indices stay right; placeholders are never passed on).
    pub(crate) points: Vec<InputPoint>,
    /// The triangles of the faces, in file order, applied once every vertex is read.
    pub(crate) tris: Vec<[u32; 3]>,
    /// Whether some triangle's indices are still to be checked against the vertices (it was
    /// read before every vertex was).
    pub(crate) unchecked: bool,
    /// Vertices kept only for their place (dropped for a non-finite position).
    pub(crate) dropped: usize,
    /// Whether the triangles are applied as they come ([`Buffered::accumulate`]) instead of kept.
    pub(crate) streamed: bool,
    /// Triangles larger than the model's sample spacing are sampled on their surface
    /// ([`Fill`]); `None`: every triangle only gives its vertices their terms.
    pub(crate) fill: Option<Fill>,
    /// The triangles to sample on their surface, set aside by [`Buffered::accumulate`].
    pub(crate) big: Vec<[u32; 3]>,
    /// The squared circumradius above which a triangle is sampled on its surface, once known.
    pub(crate) big_r2: Option<f64>,
    /// What each vertex sums of the triangles applied as they come ([`Buffered::accumulate`]),
    /// by vertex index.
    pub(crate) sums: Vec<Terms>,
}

/// How a mesh without materials fills its large triangles: a triangle whose circumradius is
/// more than twice the model's sample spacing (the diagonal of its bounding box over
/// `divisions`) is sampled on its surface at that spacing ([`crate::formats::surface`]), and its
/// vertices (unless smaller triangles use them too) are not samples of their own: a low-poly
/// mesh has no holes and no giant discs, a fine mesh is its vertices as before.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fill {
    /// The model's sample spacing is the diagonal of its bounding box over this.
    pub(crate) divisions: u32,
    /// Most samples the surface may make.
    pub(crate) max_samples: u64,
}

impl Fill {
    /// From the reader's options (`None` when filling is off).
    pub(crate) fn from_options(opts: &crate::source::ReadOptions) -> Option<Self> {
        (opts.fill_plain_meshes && opts.fill_divisions > 0)
            .then_some(Self { divisions: opts.fill_divisions, max_samples: opts.max_samples })
    }
}

impl Buffered {
    /// Keeps the place of a vertex dropped for its non-finite position `pos`, so that face
    /// indices stay right; it is never passed on, and its triangles give nothing to the others.
    pub(crate) fn push_dropped(&mut self, pos: DVec3) {
        debug_assert!(!pos.is_finite());
        self.dropped += 1;
        self.points.push(dropped_vertex(pos));
    }

    /// Takes the triangles (a fan) of a polygon ([`polygon_triangles`]), applied in
    /// [`Buffered::finish`]; its indices are checked there, the vertices still to come.
    pub(crate) fn add_polygon(&mut self, idx: &[f64]) -> Result<(), String> {
        polygon_triangles(idx, None, &mut self.tris)?;
        self.unchecked = true;
        Ok(())
    }

    /// Adds the terms of `tris`, read after every vertex, to the sums of the vertices they touch
    /// ([`Buffered::sums`]; [`Buffered::finish`] turns them into the normal, radius and spacing
    /// [`apply_triangles`] gives). For a mesh whose vertices come first and have no normals of
    /// their own, the common layout: its triangles are applied in file order as they are read
    /// and never kept.
    pub(crate) fn accumulate(&mut self, tris: &[[u32; 3]]) {
        let big_r2 = self.big_r2();
        let points = &self.points;
        self.sums.resize(points.len(), Terms::default());
        for t in tris {
            // Indices were checked against the vertices, all read, when the face was converted.
            let (Some(a), Some(b), Some(c)) = t.map(|i| points.get(i as usize).map(|p| p.pos)).into() else {
                continue;
            };
            let Some(terms) = triangle_terms([a, b, c]) else { continue };
            if f64::from(terms.r2) > big_r2 {
                self.big.push(*t);
                continue;
            }
            for &i in t {
                self.sums[i as usize].add(terms);
            }
        }
    }

    /// The squared circumradius above which a triangle is sampled on its surface (computed at
    /// the first call, every vertex read; infinite without [`Fill`]).
    fn big_r2(&mut self) -> f64 {
        let Some(fill) = self.fill else { return f64::INFINITY };
        *self.big_r2.get_or_insert_with(|| {
            let h = Surface::fill_spacing(self.points.iter().map(|p| p.pos), fill.divisions);
            if h > 0.0 { (2.0 * h).powi(2) } else { f64::INFINITY }
        })
    }

    /// Whether every kept triangle's indices name a vertex (faces read before their vertices
    /// are checked once every vertex is read).
    pub(crate) fn check_indices<E>(&self) -> Result<(), ReadError<E>> {
        let n = self.points.len();
        match self.tris.iter().find(|t| t.iter().any(|&i| i as usize >= n)) {
            Some(t) => {
                Err(SurfaceError::FaceVertex { vertex: t.iter().max().copied().unwrap_or(0), vertices: n }
                    .into())
            }
            None => Ok(()),
        }
    }

    /// Applies the triangles and passes the vertices on with their face normals (where they
    /// have none of their own) and radii; then the samples of the large triangles' surfaces.
    pub(crate) fn finish<E>(
        mut self,
        report: &mut ReadReport,
        sink: &mut dyn Sink<Error = E>,
    ) -> Result<(), ReadError<E>> {
        if self.unchecked {
            self.check_indices()?;
        }
        if !self.streamed && self.fill.is_some() && !self.tris.is_empty() {
            let big_r2 = self.big_r2();
            let points = &self.points;
            let (big, small): (Vec<[u32; 3]>, Vec<[u32; 3]>) =
                std::mem::take(&mut self.tris).into_iter().partition(|t| {
                    triangle_terms(t.map(|i| points[i as usize].pos))
                        .is_some_and(|s| f64::from(s.r2) > big_r2)
                });
            (self.big, self.tris) = (big, small);
        }
        let surface = (!self.big.is_empty()).then(|| self.big_surface(report));
        if self.streamed {
            use rayon::prelude::*;
            self.sums.resize(self.points.len(), Terms::default());
            self.points.par_iter_mut().zip(std::mem::take(&mut self.sums)).for_each(|(p, sum)| {
                (p.normal, p.radius, p.spacing) = (sum.normal(), sum.radius(), sum.spacing());
            });
        } else if !self.tris.is_empty() {
            apply_triangles(&mut self.points, &std::mem::take(&mut self.tris));
        }
        // Vertices of large triangles only: their surface samples stand for them.
        if let Some((_, only_big)) = &surface {
            let mut k = 0;
            self.points.retain(|p| {
                k += 1;
                !(only_big[k - 1] && p.radius == 0.0 && p.spacing == 0.0)
            });
        }
        // Dropped vertices kept their place for the faces only.
        if self.dropped > 0 {
            self.points.retain(|p| p.pos.is_finite());
        }
        report.points += self.points.len() as u64;
        sink.points(self.points).map_err(ReadError::Sink)?;
        if let (Some((surface, _)), Some(fill)) = (surface, self.fill) {
            let params = SampleParams {
                texel_density: 1.0,
                fill_spacing: self.big_r2.map_or(0.0, |r2| r2.sqrt() / 2.0),
                max_samples: fill.max_samples,
            };
            surface.sample(&params, report, sink)?;
        }
        Ok(())
    }

    /// The large triangles as a surface to sample (their vertices with the file's normals and
    /// colours), and which vertices are in large triangles (dropped unless a small one uses
    /// them too).
    fn big_surface(&self, report: &ReadReport) -> (Surface, Vec<bool>) {
        let mut index = vec![u32::MAX; self.points.len()];
        let mut surface = Surface::default();
        for t in &self.big {
            let v = t.map(|i| {
                let slot = &mut index[i as usize];
                if *slot == u32::MAX {
                    *slot = surface.positions.len() as u32;
                    let p = &self.points[i as usize];
                    surface.positions.push(p.pos);
                    if report.has_normals {
                        surface.normals.push(p.normal);
                    }
                    if report.has_colors {
                        surface.colors.push(linear_color(p.color));
                    }
                }
                *slot
            });
            surface.tris.push(Tri { v, uv: [[0.0; 2]; 3], material: NO_MATERIAL });
        }
        (surface, index.into_iter().map(|i| i != u32::MAX).collect())
    }
}

/// The placeholder of a vertex dropped for its non-finite position `pos` (kept for the faces'
/// indices only).
pub(crate) fn dropped_vertex(pos: DVec3) -> InputPoint {
    debug_assert!(!pos.is_finite());
    InputPoint { pos, normal: Vec3::ZERO, color: [0; 4], radius: 0.0, spacing: 0.0 }
}

/// Appends the triangles (a fan) of a polygon to `tris`. A polygon with fewer than 3 vertices
/// or an index out of range is an error (a broken mesh); indices are checked against the
/// number of `vertices` when every vertex is read already, else only against the range of
/// `u32` (and later against the vertices, in [`Buffered::finish`]).
pub(crate) fn polygon_triangles(
    idx: &[f64],
    vertices: Option<usize>,
    tris: &mut Vec<[u32; 3]>,
) -> Result<(), String> {
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
pub(crate) fn apply_triangles(points: &mut [InputPoint], tris: &[[u32; 3]]) {
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
/// terms of a triangle are computed in `f64`, from its vertices' `f64` positions).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Terms {
    normal: Vec3,
    r2: f32,
    area2: f32,
}

impl Terms {
    #[inline]
    pub(crate) fn add(&mut self, t: Terms) {
        self.normal += t.normal;
        self.r2 = self.r2.max(t.r2);
        self.area2 += t.area2;
    }

    /// The normalised sum (zero when the triangles have no area), normalised in `f64` so that a
    /// sum of tiny areas keeps its direction.
    pub(crate) fn normal(&self) -> Vec3 {
        self.normal.as_dvec3().try_normalize().map_or(Vec3::ZERO, |v| v.as_vec3())
    }

    /// The largest circumradius.
    pub(crate) fn radius(&self) -> f32 {
        self.r2.sqrt()
    }

    /// The square root of the area the vertex covers: a third of its triangles' area.
    pub(crate) fn spacing(&self) -> f32 {
        (self.area2 / 6.0).sqrt()
    }
}

/// A triangle's area-weighted normal, its circumradius squared (capped by its longest edge) and
/// twice its area, or `None` when a vertex was dropped (its triangles give nothing to the
/// others).
#[inline]
pub(crate) fn triangle_terms([a, b, c]: [DVec3; 3]) -> Option<Terms> {
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
