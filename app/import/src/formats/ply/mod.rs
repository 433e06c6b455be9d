//! PLY files as points: the `vertex` element's positions, normals and colours (any scalar type,
//! colours scaled to 8 bits), and the `face` element's polygons for the mesh terms of
//! [`crate::formats::mesh`]. The low-level parser is [`crate::formats::ply::parse`].
//!
//! A textured PLY (MeshLab, Agisoft: `comment TextureFile NAME`, the image beside the file,
//! with per-face `texcoord` lists or per-vertex `s t`, `u v`, `texture_u texture_v`) is sampled
//! on its surface at texel density like a textured OBJ ([`crate::formats::surface`]). A face's
//! `texnumber` (Agisoft's several atlases) picks its texture among the `TextureFile`s, in their
//! order; without it the first texture serves every face. The texture alone gives the colour
//! (MeshLab writes its default grey as the vertices' colour of a textured mesh).

pub mod parse;

use super::mesh::{Buffered, dropped_vertex, polygon_triangles};
use super::surface::{Material, Surface, Tri};
use super::texture::Texture;
use crate::formats::ReadError;
use crate::source::{InputPoint, ReadOptions, ReadReport, Sink};
use glam::{DVec3, Vec3};
use parse::{PlyError, PropKind};
use std::io::BufRead;
use std::path::Path;
use std::sync::Arc;

pub(crate) fn color_channel(v: f64, ty: parse::Scalar) -> u8 {
    use parse::Scalar::*;
    let x = match ty {
        F32 | F64 => v * 255.0,
        U16 | I16 => v / 257.0,
        U32 | I32 => v / 16_843_009.0,
        U8 | I8 => v,
    };
    if x.is_finite() { x.round().clamp(0.0, 255.0) as u8 } else { 0 }
}

/// Reads a PLY stream (its textures, if any, are not looked for: [`read_ply_in`]).
pub fn read_ply<E>(
    r: &mut dyn BufRead,
    opts: &ReadOptions,
    sink: &mut dyn Sink<Error = E>,
) -> Result<ReadReport, ReadError<E>> {
    read_ply_in(r, None, opts, sink)
}

/// Reads a PLY stream whose texture files (`comment TextureFile`) are in `dir`.
pub fn read_ply_in<E>(
    r: &mut dyn BufRead,
    dir: Option<&Path>,
    opts: &ReadOptions,
    sink: &mut dyn Sink<Error = E>,
) -> Result<ReadReport, ReadError<E>> {
    let header = parse::read_header(r)?;
    let mut report = ReadReport { warnings: header.warnings.clone(), ..Default::default() };
    let names: Vec<&str> = header.elements.iter().map(|e| e.name.as_str()).collect();
    let vi = header.elements.iter().position(|e| e.name == "vertex").ok_or_else(|| {
        PlyError::NoVertexElement { elements: names.iter().map(|n| n.to_string()).collect() }
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
        return Err(PlyError::NoPositions { missing }.into());
    }
    if v.count == 0 {
        return Err(PlyError::NoVertices.into());
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
    // Texture coordinates: per vertex, or per face corner.
    let vertex_uv = [["s", "t"], ["u", "v"], ["texture_u", "texture_v"], ["texture_s", "texture_t"]]
        .into_iter()
        .find_map(|[a, b]| Some([scalar(a)?.0, scalar(b)?.0]));
    let face_uv = face.and_then(|(fi, _)| {
        let f = &header.elements[fi];
        f.prop("texcoord").filter(|&i| matches!(f.props[i].kind, PropKind::List { .. }))
    });
    // A textured mesh keeps its faces whatever its size (its colour is on them, as for OBJ and
    // glTF); a plain one beyond the limit is read as a cloud.
    let textured =
        dir.is_some() && !header.texture_files.is_empty() && (vertex_uv.is_some() || face_uv.is_some());
    let use_faces = face.is_some() && (v.count <= opts.face_vertex_limit || textured);
    // A face's texture among the files named, when there are several.
    let face_texnumber = face.filter(|_| header.texture_files.len() > 1).and_then(|(fi, _)| {
        let f = &header.elements[fi];
        f.prop("texnumber").filter(|&i| matches!(f.props[i].kind, PropKind::Scalar(_)))
    });
    let named = if face_texnumber.is_some() {
        &header.texture_files[..]
    } else {
        &header.texture_files[..1.min(header.texture_files.len())]
    };
    let texture = match (header.texture_files.first(), vertex_uv.is_some() || face_uv.is_some()) {
        (Some(name), true) if use_faces => match dir {
            Some(dir) => {
                let mut paths = Vec::new();
                for n in named {
                    let (path, looked) = super::texture::image_path(dir, n, &mut report.warnings);
                    report.inputs.extend(looked);
                    paths.push(path);
                }
                Some(paths.iter().map(|p| Texture::load(p).map(Arc::new)).collect::<Result<Vec<_>, _>>()?)
            }
            None => {
                report
                    .warnings
                    .push(format!("texture '{name}' not looked for: the file's directory is unknown"));
                None
            }
        },
        (Some(name), _) => {
            report
                .warnings
                .push(format!("texture '{name}' unused: the file has no texture coordinates on faces"));
            None
        }
        // A mesh's (a cloud's `u`, `v` may mean something else).
        (None, true) if face.is_some() => {
            report.warnings.push(
                "texture coordinates but no `comment TextureFile NAME` naming an image: imported without \
                 the texture's colours"
                    .into(),
            );
            None
        }
        (None, _) => None,
    };
    if header.texture_files.len() > 1 && face_texnumber.is_none() {
        report.warnings.push(format!(
            "{} texture files: the first ('{}') serves every face",
            header.texture_files.len(),
            header.texture_files[0]
        ));
    }
    if face.is_some() && !use_faces {
        report.warnings.push(format!(
            "{} vertices exceed the face-normal limit ({}): faces ignored, normals estimated",
            v.count, opts.face_vertex_limit
        ));
    }
    let mut buffered = Buffered { fill: super::mesh::Fill::from_options(opts), ..Default::default() };
    // The vertices a face may refer to, when every vertex comes before the faces.
    let vertices = face.filter(|&(fi, _)| vi < fi).and_then(|_| usize::try_from(v.count).ok());
    buffered.streamed = use_faces && vertices.is_some() && normal_idx.is_none() && texture.is_none();
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
        vertex_uv: vertex_uv.filter(|_| texture.is_some()),
        face_uv: face_uv.filter(|_| texture.is_some() && vertex_uv.is_none()),
        face_texnumber: face_texnumber.filter(|_| texture.is_some()).map(|i| (i, named.len())),
    };
    let (mut uvs, mut tri_uvs, mut tri_tex) = (Vec::new(), Vec::new(), Vec::new());
    let mut dropped = 0u64;
    let mut sink_err = None;
    let body_warnings = parse::read_body_converted(r, &header, &conv, |out: &mut PlyOut| {
        report.rows += out.rows;
        report.faces_used += out.faces;
        dropped += out.dropped;
        if use_faces {
            buffered.points.append(&mut out.points);
            uvs.append(&mut out.uvs);
            tri_uvs.append(&mut out.tri_uvs);
            tri_tex.append(&mut out.tri_tex);
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
    if let Some(texture) = texture {
        let uv = TriangleUvs { uvs: &uvs, tri_uvs: &tri_uvs, tri_tex: &tri_tex };
        return sample_textured(buffered, &uv, texture, opts, report, sink);
    }
    if use_faces {
        buffered.finish(&mut report, sink)?;
    }
    Ok(report)
}

/// Where the triangles of a textured PLY find their texels: their corners' texture coordinates
/// per vertex (`uvs`) or per triangle (`tri_uvs`), and each triangle's texture (`tri_tex`, an
/// index into the textures; empty: the first serves every triangle).
struct TriangleUvs<'a> {
    uvs: &'a [[f32; 2]],
    tri_uvs: &'a [[[f32; 2]; 3]],
    tri_tex: &'a [u32],
}

/// A textured PLY sampled on its surface: every triangle with its texture (`textures`, in the
/// order of the file's `TextureFile`s) at its texture coordinates; vertices in no triangle are
/// passed on as they are.
fn sample_textured<E>(
    buffered: Buffered,
    uv: &TriangleUvs<'_>,
    textures: Vec<Arc<Texture>>,
    opts: &ReadOptions,
    mut report: ReadReport,
    sink: &mut dyn Sink<Error = E>,
) -> Result<ReadReport, ReadError<E>> {
    buffered.check_indices()?;
    let points = buffered.points;
    // PLY's v runs up from the bottom of the image; the sampler's down from the top.
    let flip = |[u, v]: [f32; 2]| [u, 1.0 - v];
    let tris: Vec<Tri> = buffered
        .tris
        .iter()
        .enumerate()
        .map(|(k, &v)| {
            let corners = match uv.tri_uvs.get(k) {
                Some(corners) => corners.map(flip),
                None => v.map(|i| flip(uv.uvs.get(i as usize).copied().unwrap_or([0.0; 2]))),
            };
            Tri { v, uv: corners, material: uv.tri_tex.get(k).copied().unwrap_or(0) }
        })
        .collect();
    super::surface::pass_lone_vertices(&points, &tris, &mut report, sink)?;
    let surface = Surface {
        positions: points.iter().map(|p| p.pos).collect(),
        normals: if report.has_normals { points.iter().map(|p| p.normal).collect() } else { Vec::new() },
        // The texture alone colours the surface: MeshLab writes its default grey as the vertices'
        // colour of a textured mesh.
        colors: Vec::new(),
        tris,
        materials: textures
            .into_iter()
            .map(|t| Material { factor: [1.0; 4], texture: Some(t), colored: true })
            .collect(),
    };
    let params = opts.sample_params(points.iter().map(|p| p.pos));
    surface.sample(&params, &mut report, sink)?;
    report.has_colors = true;
    Ok(report)
}

/// How [`read_ply`] converts the rows of a PLY body ([`parse::Convert`]): vertices
/// into samples, faces into triangles (where they are used).
pub(crate) struct PlyRows {
    /// The vertex element, and the face element and its index list.
    vi: usize,
    face: Option<(usize, usize)>,
    /// Where a vertex row holds its position, normal, colour and alpha (with their types).
    pos_idx: [usize; 3],
    normal_idx: Option<[usize; 3]>,
    color_idx: Option<Vec<(usize, parse::Scalar)>>,
    alpha_idx: Option<(usize, parse::Scalar)>,
    /// Whether the faces give the vertices normals and radii (else only broken polygons are
    /// looked at: an error either way).
    use_faces: bool,
    drop_invalid: bool,
    /// The vertices a face may refer to, when every vertex comes before the faces (else the
    /// indices are checked once every vertex is read).
    vertices: Option<usize>,
    /// Where a vertex row holds its texture coordinates, or a face row its corners' (a textured
    /// file only).
    vertex_uv: Option<[usize; 2]>,
    face_uv: Option<usize>,
    /// The face's `texnumber` and the number of textures it picks among.
    face_texnumber: Option<(usize, usize)>,
}

/// The rows of a run converted: its vertices (a dropped one as a placeholder where the faces
/// are used, to keep the faces' indices right), its faces' triangles, and counts.
#[derive(Default)]
pub(crate) struct PlyOut {
    points: Vec<InputPoint>,
    tris: Vec<[u32; 3]>,
    /// Vertex rows, of which dropped for a non-finite position, and faces used.
    rows: u64,
    dropped: u64,
    faces: u64,
    /// Whether a triangle's indices are still to be checked against the vertices.
    unchecked: bool,
    /// Texture coordinates of the vertices, or of the triangles' corners (a textured file).
    uvs: Vec<[f32; 2]>,
    tri_uvs: Vec<[[f32; 2]; 3]>,
    /// Each triangle's texture (a file with several, per face `texnumber`).
    tri_tex: Vec<u32>,
}

impl parse::Convert for PlyRows {
    type Out = PlyOut;

    fn clear(&self, out: &mut PlyOut) {
        out.points.clear();
        out.tris.clear();
        out.uvs.clear();
        out.tri_uvs.clear();
        out.tri_tex.clear();
        (out.rows, out.dropped, out.faces, out.unchecked) = (0, 0, 0, false);
    }

    fn convert(&self, ei: usize, ri: u64, row: &parse::Row, out: &mut PlyOut) -> Result<(), PlyError> {
        if ei == self.vi {
            out.rows += 1;
            let [x, y, z] = self.pos_idx.map(|i| row.values[i]);
            if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                if self.drop_invalid {
                    out.dropped += 1;
                    if self.use_faces {
                        out.points.push(dropped_vertex(DVec3::new(x, y, z)));
                        if self.vertex_uv.is_some() {
                            out.uvs.push([0.0; 2]);
                        }
                    }
                    return Ok(());
                }
                return Err(PlyError::NonFinite { row: ri + 1, line: None, x, y, z });
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
            if let Some([u, v]) = self.vertex_uv {
                out.uvs.push([row.values[u] as f32, row.values[v] as f32]);
            }
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
            if let Some(ti) = self.face_uv {
                let (corners, uv) = (row.lists[li].len(), &row.lists[ti]);
                if uv.len() != 2 * corners {
                    return Err(PlyError::Row {
                        element: "face".into(),
                        row: ri + 1,
                        line: None,
                        msg: format!("{} texcoord values for {corners} corners (2 per corner)", uv.len()),
                    });
                }
                let at = |k: usize| [uv[2 * k] as f32, uv[2 * k + 1] as f32];
                out.tri_uvs.extend((1..corners - 1).map(|k| [at(0), at(k), at(k + 1)]));
            }
            if let Some((ni, textures)) = self.face_texnumber {
                let n = row.values[ni];
                if !(n >= 0.0 && n < textures as f64) || n.fract() != 0.0 {
                    return Err(PlyError::Row {
                        element: "face".into(),
                        row: ri + 1,
                        line: None,
                        msg: format!(
                            "texnumber {n}: the file names {textures} texture files (0 to {})",
                            textures - 1
                        ),
                    });
                }
                let corners = row.lists[li].len();
                out.tri_tex.extend(std::iter::repeat_n(n as u32, corners - 2));
            }
            out.unchecked |= self.vertices.is_none();
            out.faces += 1;
        }
        Ok(())
    }
}
