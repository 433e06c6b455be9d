//! Samples on the surface of a mesh's triangles, where its vertices alone do not carry it: a
//! textured triangle is sampled at the spacing of its texel footprint (times the samples per
//! texel asked for), each sample coloured from the texture; an untextured triangle larger than
//! the model's sample spacing is sampled at that spacing, so that a low-poly mesh has no holes.
//!
//! A triangle sampled `n` times a side is cut into `n²` congruent sub-triangles (its edges in
//! `n` equal parts), and each sub-triangle gives the sample at its centroid: `n²` samples that
//! tile the triangle exactly, never shared with a neighbour (no duplicates along edges), each
//! covering `area / n²` (its spacing, the side of that area) and reaching every point of its
//! sub-triangle within its radius (the distance from the centroid to the sub-triangle's
//! farthest corner), so the splats cover the mesh without holes. `n` is chosen for the area a
//! sample should cover, raised (at most 4 times) where a sliver would make sub-triangles much
//! longer than they are wide.
//!
//! Normals: the file's vertex normals interpolated; without them, the area-weighted vertex
//! normals interpolated where the surface is smooth (every corner's within 30° of the face's
//! normal), else the face's own normal (a box keeps its flat sides). Colours: the texture
//! sampled bilinearly in linear light ([`Texture::sample`]), times the material's factor and
//! the interpolated vertex colours (linear), encoded back into sRGB bytes.
//!
//! Samples are made in parallel, in batches of work units (a triangle's rows of sub-triangles,
//! a few tens of thousands of samples each) and passed on in triangle order: the same samples
//! in the same order whatever the number of threads, and memory bounded by a batch.

use super::texture::{Texture, encode_srgb, srgb_to_linear_lut};
use crate::formats::ReadError;
use crate::source::{InputPoint, ReadReport, Sink};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::sync::Arc;

/// A material: a colour factor (linear RGB and alpha) and maybe a texture.
#[derive(Clone, Debug)]
pub struct Material {
    /// Multiplies the texture's colour (or is the colour, without a texture); linear.
    pub factor: [f32; 4],
    /// The base colour texture.
    pub texture: Option<Arc<Texture>>,
    /// Whether the material gives a colour at all (an OBJ material with a `Kd` or a map, any
    /// glTF material); samples of a mesh without coloured materials nor vertex colours have
    /// none.
    pub colored: bool,
}

impl Default for Material {
    fn default() -> Self {
        Self { factor: [1.0; 4], texture: None, colored: false }
    }
}

/// No material: [`Tri::material`] of a triangle that has none.
pub const NO_MATERIAL: u32 = u32::MAX;

/// A triangle: its vertices, its texture coordinates (0,0 the top-left of the image, as
/// [`Texture::sample`] takes them; meaningless without a texture) and its material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tri {
    /// Indices into [`Surface::positions`].
    pub v: [u32; 3],
    /// Texture coordinates of the corners.
    pub uv: [[f32; 2]; 3],
    /// Index into [`Surface::materials`], or [`NO_MATERIAL`].
    pub material: u32,
}

/// A mesh to sample on its surface.
#[derive(Clone, Debug, Default)]
pub struct Surface {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Vertex normals from the file (unit or zero), or empty.
    pub normals: Vec<Vec3>,
    /// Vertex colours (linear RGB and alpha), or empty.
    pub colors: Vec<[f32; 4]>,
    /// Triangles.
    pub tris: Vec<Tri>,
    /// Materials.
    pub materials: Vec<Material>,
}

/// How densely a surface is sampled.
#[derive(Clone, Copy, Debug)]
pub struct SampleParams {
    /// Samples per texel of a textured triangle's footprint in its texture (1: one sample per
    /// texel; 0.25: one per 2 × 2 texels).
    pub texel_density: f32,
    /// Spacing of the samples of untextured triangles, in the file's units (0: one sample per
    /// untextured triangle).
    pub fill_spacing: f64,
    /// Most samples a surface may make: more is an error (a corrupted file's texture
    /// coordinates, or a density too high for the machine).
    pub max_samples: u64,
}

/// Most sub-triangles a side of one triangle: 2¹⁴ (268 M samples).
const MAX_DIVISIONS: u32 = 1 << 14;
/// Samples made and passed on at once.
const BATCH: u64 = 1 << 21;
/// Samples per work unit (rows of one triangle).
const UNIT: u64 = 1 << 14;
/// Cosine of the largest angle between a corner's smooth normal and the face's normal for the
/// normals to be interpolated (30°).
const SMOOTH_COS: f32 = 0.866;

/// Passes on the vertices of `points` that no triangle of `tris` uses (a point cloud in the same
/// file as a mesh sampled on its surface): they are samples of their own.
pub(crate) fn pass_lone_vertices<E>(
    points: &[InputPoint],
    tris: &[Tri],
    report: &mut ReadReport,
    sink: &mut dyn Sink<Error = E>,
) -> Result<(), ReadError<E>> {
    let mut in_tri = vec![false; points.len()];
    for t in tris {
        for i in t.v {
            if let Some(slot) = in_tri.get_mut(i as usize) {
                *slot = true;
            }
        }
    }
    let lone: Vec<InputPoint> = points
        .iter()
        .zip(&in_tri)
        .filter(|(p, used)| !**used && p.pos.is_finite())
        .map(|(p, _)| *p)
        .collect();
    if !lone.is_empty() {
        report.points += lone.len() as u64;
        sink.points(lone).map_err(ReadError::Sink)?;
    }
    Ok(())
}

impl Surface {
    /// The spacing that the untextured triangles of a model of this size are sampled at: the
    /// diagonal of the bounding box of its vertices divided by `divisions` (0 when there are no
    /// finite vertices).
    pub fn fill_spacing(positions: impl Iterator<Item = DVec3>, divisions: u32) -> f64 {
        let (lo, hi) = positions
            .filter(|p| p.is_finite())
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
        if lo.x > hi.x || divisions == 0 { 0.0 } else { (hi - lo).length() / f64::from(divisions) }
    }

    /// The number of parts each edge of triangle `t` is cut into (0 for a degenerate triangle,
    /// which gives no samples).
    fn divisions(&self, t: &Tri, p: &SampleParams) -> u32 {
        let [a, b, c] = t.v.map(|i| self.positions[i as usize]);
        let area = 0.5 * (b - a).cross(c - a).length();
        if !(area > 0.0 && area.is_finite()) {
            return 0;
        }
        // A textured triangle at its texel footprint, an untextured one at the fill spacing.
        let texture = self.materials.get(t.material as usize).and_then(|m| m.texture.as_ref());
        let n_area = match texture {
            Some(tex) => {
                let (w, h) = (f64::from(tex.width), f64::from(tex.height));
                let uv = t.uv.map(|[u, v]| (f64::from(u) * w, f64::from(v) * h));
                let texels = 0.5
                    * ((uv[1].0 - uv[0].0) * (uv[2].1 - uv[0].1) - (uv[2].0 - uv[0].0) * (uv[1].1 - uv[0].1))
                        .abs();
                if texels.is_finite() { (texels * f64::from(p.texel_density)).sqrt() } else { 1.0 }
            }
            None if p.fill_spacing > 0.0 => area.sqrt() / p.fill_spacing,
            None => 1.0,
        };
        let n_area = n_area.max(1.0);
        // Sub-triangles at most twice as long as the side of the area they cover, within 4 ×
        // the samples the area asks for.
        let longest = (b - a).length().max((c - b).length()).max((a - c).length());
        let n_len = longest / (2.0 * area.sqrt() / n_area);
        let n = n_len.clamp(n_area, 4.0 * n_area).ceil();
        if n.is_finite() { n.min(f64::from(MAX_DIVISIONS)) as u32 } else { MAX_DIVISIONS }
    }

    /// Samples every triangle and passes the samples on, in triangle order; adds them to the
    /// report. An error when there would be more than `max_samples`, or when the sink refuses.
    pub fn sample<E>(
        &self,
        params: &SampleParams,
        report: &mut ReadReport,
        sink: &mut dyn Sink<Error = E>,
    ) -> Result<u64, ReadError<E>> {
        let n = self.positions.len();
        if let Some((k, t)) = self.tris.iter().enumerate().find(|(_, t)| t.v.iter().any(|&i| i as usize >= n))
        {
            let vertex = t.v.iter().max().copied().unwrap_or(0);
            return Err(SurfaceError::TriangleVertex { triangle: k + 1, vertex, vertices: n }.into());
        }
        let divisions: Vec<u32> = self.tris.par_iter().map(|t| self.divisions(t, params)).collect();
        let total: u64 = divisions.iter().map(|&d| u64::from(d) * u64::from(d)).sum();
        if total > params.max_samples {
            return Err(SurfaceError::TooManySamples { samples: total, limit: params.max_samples }.into());
        }
        // Known before the first sample: the progress bar has its total (and an estimate).
        sink.expect(total);
        let smooth = self.smooth_normals();
        let vertex_colors = &self.colors;
        let mut made = 0u64;
        let mut units: Vec<(u32, u32, u32)> = Vec::new();
        let mut in_batch = 0u64;
        let mut flush = |units: &mut Vec<(u32, u32, u32)>, made: &mut u64| -> Result<(), ReadError<E>> {
            if units.is_empty() {
                return Ok(());
            }
            let samples: Vec<InputPoint> = units
                .par_iter()
                .flat_map_iter(|&(t, i0, i1)| {
                    let mut out = Vec::new();
                    self.sample_rows(
                        t as usize,
                        divisions[t as usize],
                        i0..i1,
                        &smooth,
                        vertex_colors,
                        &mut out,
                    );
                    out
                })
                .collect();
            units.clear();
            *made += samples.len() as u64;
            sink.points(samples).map_err(ReadError::Sink)
        };
        for (t, &d) in divisions.iter().enumerate() {
            // Rows of sub-triangles from the first corner: row i has 2 (d − i) − 1.
            let mut i = 0;
            while i < d {
                let mut j = i;
                let mut count = 0u64;
                while j < d && (count == 0 || count + u64::from(2 * (d - j) - 1) <= UNIT) {
                    count += u64::from(2 * (d - j) - 1);
                    j += 1;
                }
                units.push((t as u32, i, j));
                in_batch += count;
                i = j;
                if in_batch >= BATCH {
                    flush(&mut units, &mut made)?;
                    in_batch = 0;
                }
            }
        }
        flush(&mut units, &mut made)?;
        report.points += made;
        report.faces_used += self.tris.len() as u64;
        Ok(made)
    }

    /// Area-weighted vertex normals of the triangles (empty when the file gives normals).
    fn smooth_normals(&self) -> Vec<Vec3> {
        if !self.normals.is_empty() {
            return Vec::new();
        }
        let mut sum = vec![DVec3::ZERO; self.positions.len()];
        for t in &self.tris {
            let [a, b, c] = t.v.map(|i| self.positions[i as usize]);
            let n = (b - a).cross(c - a);
            if n.is_finite() {
                for i in t.v {
                    sum[i as usize] += n;
                }
            }
        }
        sum.into_iter().map(|n| n.try_normalize().map_or(Vec3::ZERO, |n| n.as_vec3())).collect()
    }

    /// The samples of rows `rows` of triangle `t` cut `d` times a side, appended to `out`.
    fn sample_rows(
        &self,
        t: usize,
        d: u32,
        rows: std::ops::Range<u32>,
        smooth: &[Vec3],
        vertex_colors: &[[f32; 4]],
        out: &mut Vec<InputPoint>,
    ) {
        let tri = &self.tris[t];
        let [a, b, c] = tri.v.map(|i| self.positions[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let face = e1.cross(e2);
        let face_n = face.try_normalize().map_or(Vec3::ZERO, |n| n.as_vec3());
        let area = 0.5 * face.length();
        let nf = f64::from(d);
        let spacing = (area.sqrt() / nf) as f32;
        // The sub-triangle's corners from its centroid (the downward ones are point reflections).
        let (s1, s2) = (e1 / nf, e2 / nf);
        let g = (s1 + s2) / 3.0;
        let radius = (g.length().max((g - s1).length()).max((g - s2).length()) * 1.0001) as f32;
        // Normals at the corners, or the face's.
        let corner_normals = if !self.normals.is_empty() {
            let n = tri.v.map(|i| self.normals[i as usize]);
            (n.iter().all(|n| *n != Vec3::ZERO)).then_some(n)
        } else {
            let n = tri.v.map(|i| smooth[i as usize]);
            n.iter().all(|n| n.dot(face_n) >= SMOOTH_COS).then_some(n)
        };
        let material = self.materials.get(tri.material as usize);
        let texture = material.and_then(|m| m.texture.as_deref());
        let corner_colors = (!vertex_colors.is_empty()).then(|| tri.v.map(|i| vertex_colors[i as usize]));
        let colored = material.is_some_and(|m| m.colored) || corner_colors.is_some() || texture.is_some();
        let factor = material.map_or([1.0; 4], |m| m.factor);
        out.reserve(rows.clone().map(|i| (2 * (d - i) - 1) as usize).sum());
        let mut emit = |u: f64, v: f64| {
            let w = 1.0 - u - v;
            let pos = a + e1 * u + e2 * v;
            let (uf, vf, wf) = (u as f32, v as f32, w as f32);
            let normal = match corner_normals {
                Some([na, nb, nc]) => (na * wf + nb * uf + nc * vf).try_normalize().unwrap_or(face_n),
                None => face_n,
            };
            let color = if colored {
                let mut lin = factor;
                if let Some(tex) = texture {
                    let tu = tri.uv[0][0] * wf + tri.uv[1][0] * uf + tri.uv[2][0] * vf;
                    let tv = tri.uv[0][1] * wf + tri.uv[1][1] * uf + tri.uv[2][1] * vf;
                    let s = tex.sample(tu, tv);
                    for k in 0..3 {
                        lin[k] *= s[k];
                    }
                }
                if let Some([ca, cb, cc]) = corner_colors {
                    for k in 0..3 {
                        lin[k] *= ca[k] * wf + cb[k] * uf + cc[k] * vf;
                    }
                }
                [encode_srgb(lin[0]), encode_srgb(lin[1]), encode_srgb(lin[2]), 255]
            } else {
                [0; 4]
            };
            out.push(InputPoint { pos, normal, color, radius, spacing });
        };
        for i in rows {
            for j in 0..d - i {
                // Upward sub-triangle (i, j), (i+1, j), (i, j+1) in steps of 1/d along e1, e2.
                emit((3.0 * f64::from(i) + 1.0) / (3.0 * nf), (3.0 * f64::from(j) + 1.0) / (3.0 * nf));
                if i + j + 1 < d {
                    emit((3.0 * f64::from(i) + 2.0) / (3.0 * nf), (3.0 * f64::from(j) + 2.0) / (3.0 * nf));
                }
            }
        }
    }
}

/// A colour of 8-bit sRGB channels as linear values (alpha as is).
pub(crate) fn linear_color(c: [u8; 4]) -> [f32; 4] {
    let lut = srgb_to_linear_lut();
    [lut[c[0] as usize], lut[c[1] as usize], lut[c[2] as usize], f32::from(c[3]) / 255.0]
}

impl crate::source::ReadOptions {
    /// The sampling parameters of a surface whose vertices span `positions`.
    pub(crate) fn sample_params(&self, positions: impl Iterator<Item = DVec3>) -> SampleParams {
        SampleParams {
            texel_density: self.texel_density,
            fill_spacing: Surface::fill_spacing(positions, self.fill_divisions),
            max_samples: self.max_samples,
        }
    }
}

/// Why a mesh's triangles cannot be sampled.
#[derive(Debug, thiserror::Error)]
pub enum SurfaceError {
    /// A face (a PLY's, read before its vertices) names a vertex the file does not have.
    #[error("a face refers to vertex {vertex} but the file has {vertices} vertices (indices start at 0)")]
    FaceVertex {
        /// The index named.
        vertex: u32,
        /// The vertices there are.
        vertices: usize,
    },
    /// A triangle names a vertex the mesh does not have.
    #[error("triangle {triangle} refers to vertex {vertex} but there are {vertices} vertices")]
    TriangleVertex {
        /// 1-based triangle.
        triangle: usize,
        /// The index named.
        vertex: u32,
        /// The vertices there are.
        vertices: usize,
    },
    /// Sampling at the density asked for would make too many samples (a corrupted file's
    /// texture coordinates, or a density too high).
    #[error(
        "sampling the surface at the texel density asked for would make {samples} samples, more than the limit of {limit}: lower the texel density"
    )]
    TooManySamples {
        /// The samples it would make.
        samples: u64,
        /// [`crate::ReadOptions::max_samples`].
        limit: u64,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(materials: Vec<Material>, uv: bool) -> Surface {
        let positions = vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        let uvs = |k: [usize; 3]| {
            let c = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
            if uv { k.map(|i| c[i]) } else { [[0.0; 2]; 3] }
        };
        let m = if materials.is_empty() { NO_MATERIAL } else { 0 };
        Surface {
            positions,
            tris: vec![
                Tri { v: [0, 1, 2], uv: uvs([0, 1, 2]), material: m },
                Tri { v: [0, 2, 3], uv: uvs([0, 2, 3]), material: m },
            ],
            materials,
            ..Default::default()
        }
    }

    fn collect(s: &Surface, p: &SampleParams) -> Vec<InputPoint> {
        let mut out = Vec::new();
        let mut report = ReadReport::default();
        s.sample(p, &mut report, &mut |q| {
            out.push(q);
            Ok(())
        })
        .expect("sample");
        assert_eq!(report.points, out.len() as u64);
        out
    }

    #[test]
    fn an_untextured_square_is_tiled_at_the_fill_spacing() {
        let s = square(Vec::new(), false);
        let p = SampleParams { texel_density: 1.0, fill_spacing: 0.05, max_samples: 1 << 30 };
        let pts = collect(&s, &p);
        // Each triangle (area 1/2): ⌈√0.5 / 0.05⌉ = 15 parts a side → 225 samples.
        assert_eq!(pts.len(), 2 * 15 * 15);
        // Every point of the square is within a sample's radius of a sample.
        for x in 0..=40 {
            for y in 0..=40 {
                let q = DVec3::new(f64::from(x) / 40.0, f64::from(y) / 40.0, 0.0);
                assert!(pts.iter().any(|p| (p.pos - q).length() <= f64::from(p.radius)), "hole at {q}");
            }
        }
        assert!(pts.iter().all(|p| p.normal == Vec3::Z && p.color == [0; 4]));
        let covered: f64 = pts.iter().map(|p| f64::from(p.spacing).powi(2)).sum();
        assert!((covered - 1.0).abs() < 1e-4, "{covered}");
    }

    #[test]
    fn a_textured_square_takes_its_colours_from_the_texture() {
        // A 4 × 4 checker, black and white, on the unit square: one sample per texel.
        let mut rgba = Vec::new();
        for y in 0..4 {
            for x in 0..4 {
                let v = if (x + y) % 2 == 0 { 255 } else { 0 };
                rgba.extend([v, v, v, 255]);
            }
        }
        let tex = Texture {
            name: "checker".into(),
            width: 4,
            height: 4,
            rgba,
            wrap: [super::super::texture::Wrap::ClampToEdge; 2],
        };
        let m = Material { factor: [1.0, 0.5, 1.0, 1.0], texture: Some(Arc::new(tex)), colored: true };
        let s = square(vec![m], true);
        let p = SampleParams { texel_density: 256.0, fill_spacing: 1.0, max_samples: 1 << 30 };
        let pts = collect(&s, &p);
        // 8 texels per triangle × 256 = 2048 samples wanted: ⌈√2048⌉ = 46 a side.
        assert_eq!(pts.len(), 2 * 46 * 46);
        let mut checked = 0;
        for q in &pts {
            // Texel (x, y) with y from the top: the square's y = 1 is the image's top row.
            let (x, y) = ((q.pos.x * 4.0) as i32, ((1.0 - q.pos.y) * 4.0) as i32);
            let (fx, fy) = (q.pos.x * 4.0 - f64::from(x), (1.0 - q.pos.y) * 4.0 - f64::from(y));
            // Near a texel's centre, the colour is the texel's (the green halved in linear light:
            // 188 in sRGB), blended with at most a tenth of its neighbours (linear 0.1 is sRGB 89).
            if (0.45..0.55).contains(&fx) && (0.45..0.55).contains(&fy) {
                checked += 1;
                let white = (x + y) % 2 == 0;
                let ok = if white {
                    q.color[0] >= 240 && (170..=188).contains(&q.color[1])
                } else {
                    q.color[0] <= 90 && q.color[1] <= 65
                };
                assert!(ok && q.color[3] == 255, "{:?} at texel ({x}, {y}): {:?}", q.pos, q.color);
            }
        }
        assert!(checked > 16, "{checked}");
    }

    #[test]
    fn too_many_samples_is_an_error() {
        let s = square(Vec::new(), false);
        let p = SampleParams { texel_density: 1.0, fill_spacing: 1e-6, max_samples: 1000 };
        let mut report = ReadReport::default();
        let e = s.sample(&p, &mut report, &mut |_| Ok(())).expect_err("limit").to_string();
        assert!(e.contains("texel density"), "{e}");
    }
}
