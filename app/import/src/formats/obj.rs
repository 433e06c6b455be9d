//! Wavefront OBJ as points: `v` (with optional colour) and `f` (`a/b/c` and negative indices),
//! read in blocks of lines ([`crate::formats::lines`]). With materials (`mtllib`,
//! `usemtl`: [`mtl`]) and texture coordinates (`vt`), the mesh is sampled on its surface
//! ([`crate::formats::surface`]): every triangle at the spacing of its texel footprint, coloured
//! from its material's `map_Kd` times its `Kd`. Other statements are ignored.

use super::mesh::Buffered;
use super::ply::color_channel;
use super::ply::parse as ply;
use super::surface::{Material, NO_MATERIAL, Surface, Tri, linear_color};
use super::texture::{TextureCache, TextureError, Wrap};
use crate::formats::ReadError;
use crate::formats::lines::{Stop, Tokens, parse_i64};
use crate::source::{InputPoint, ReadOptions, ReadReport, Sink};
use glam::{DVec3, Vec3};
use std::io::BufRead;
use std::path::{Path, PathBuf};

/// Why an OBJ file or one of its material libraries cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum ObjError {
    /// A line of the OBJ file.
    #[error("line {line}: {msg}")]
    Line {
        /// 1-based line.
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// A line of a material library (`mtllib`).
    #[error("{file} line {line}: {msg}")]
    Library {
        /// The library's path.
        file: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// The file has no vertex.
    #[error("the file has 0 vertices ('v' lines)")]
    NoVertices,
}

/// Reads an OBJ stream: `v x y z [r g b]` vertices and `f` faces (for normals). Without the
/// file's directory, material libraries are not looked for (a warning says so).
pub fn read_obj<E>(
    r: &mut dyn BufRead,
    opts: &ReadOptions,
    sink: &mut dyn Sink<Error = E>,
) -> Result<ReadReport, ReadError<E>> {
    read_obj_in(r, None, opts, sink)
}

/// Reads an OBJ stream whose material libraries and textures are found relative to `dir` (the
/// OBJ file's directory): `v x y z [r g b]` vertices, `vt` texture coordinates, `f` faces,
/// `mtllib` and `usemtl`. Other statements (`vn`, groups, comments, in any encoding) are
/// ignored. Read in blocks of lines ([`crate::formats::lines`]), visited in order.
pub fn read_obj_in<E>(
    r: &mut dyn BufRead,
    dir: Option<&Path>,
    opts: &ReadOptions,
    sink: &mut dyn Sink<Error = E>,
) -> Result<ReadReport, ReadError<E>> {
    let mut report = ReadReport::default();
    let mut buffered = Buffered { fill: super::mesh::Fill::from_options(opts), ..Default::default() };
    let mut dropped = 0u64;
    let mut idx = Vec::new();
    // Materials: texture coordinates, the libraries named, the material of each triangle (an
    // index into `used`) and its corners' texture coordinates, recorded once a library is named.
    let mut texcoords: Vec<[f32; 2]> = Vec::new();
    let mut libraries: Vec<(String, usize)> = Vec::new();
    let mut used: Vec<String> = Vec::new();
    let mut current = NO_MATERIAL;
    let mut tri_mat: Vec<u32> = Vec::new();
    let mut tri_uv: Vec<[u32; 3]> = Vec::new();
    let unusable = |line: usize, msg: String| ReadError::Obj(ObjError::Line { line, msg });
    // Faces may name vertices read after them; the face that names the largest vertex beyond
    // those read before it (its line, its 0-based index) is checked once all are read.
    let mut ahead: Option<(usize, f64)> = None;
    let mut visit = |_: &[u8], parsed: &mut ObjParsed| -> Result<(), ReadError<E>> {
        for piece in &mut parsed.pieces {
            let (mut v, mut f, mut names) = (0, 0, 0);
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
                    ObjStmt::TexCoord => {
                        texcoords.push([piece.values[v] as f32, piece.values[v + 1] as f32]);
                        v += 2;
                    }
                    ObjStmt::MtlLib { line } => {
                        libraries.push((piece.names[names].clone(), line));
                        names += 1;
                        if tri_mat.len() < buffered.tris.len() {
                            tri_mat.resize(buffered.tris.len(), NO_MATERIAL);
                            tri_uv.resize(buffered.tris.len(), [u32::MAX; 3]);
                        }
                    }
                    ObjStmt::UseMtl => {
                        let name = &piece.names[names];
                        names += 1;
                        current = match used.iter().position(|u| u == name) {
                            Some(k) => k as u32,
                            None => {
                                used.push(name.clone());
                                (used.len() - 1) as u32
                            }
                        };
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
                        if let Some(k) = idx.iter().position(|&i| i < 0.0) {
                            let raw = piece.indices[f + k];
                            return Err(unusable(
                                line,
                                format!(
                                    "vertex index {raw}: OBJ counts vertices from 1 (or back from -1), and {count} 'v' lines come before it"
                                ),
                            ));
                        }
                        let last = idx.iter().copied().fold(0.0, f64::max);
                        if last >= count && ahead.is_none_or(|(_, a)| last > a) {
                            ahead = Some((line, last));
                        }
                        let before = buffered.tris.len();
                        buffered.add_polygon(&idx).map_err(|m| unusable(line, m))?;
                        if !libraries.is_empty() {
                            let nt = texcoords.len() as i64;
                            let mut corners = [0u32; 3];
                            let corner = |k: usize| -> Result<u32, ReadError<E>> {
                                match piece.tex_indices[f + k] {
                                    0 => Ok(u32::MAX),
                                    i => {
                                        let at = if i < 0 { nt + i } else { i - 1 };
                                        if (0..nt).contains(&at) {
                                            Ok(at as u32)
                                        } else {
                                            Err(unusable(
                                                line,
                                                format!(
                                                    "texture coordinate index {i} is out of range: {nt} 'vt' lines so far"
                                                ),
                                            ))
                                        }
                                    }
                                }
                            };
                            let first = corner(0)?;
                            for k in 1..n - 1 {
                                corners[0] = first;
                                corners[1] = corner(k)?;
                                corners[2] = corner(k + 1)?;
                                tri_uv.push(corners);
                                tri_mat.push(current);
                            }
                            debug_assert_eq!(tri_mat.len(), buffered.tris.len(), "{before}");
                        }
                        f += n;
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
    crate::formats::lines::read(r, &ObjLines, 0, &mut visit, |stop, at| {
        Err(match stop {
            Stop::Io(e) => ReadError::Io(e),
            Stop::Overlong => unusable(
                at + 1,
                format!("longer than {} MiB (binary data?)", crate::formats::lines::MAX_LINE >> 20),
            ),
        })
    })?;
    if report.rows == 0 {
        return Err(ReadError::Obj(ObjError::NoVertices));
    }
    if let Some((line, last)) = ahead {
        let n = buffered.points.len();
        if last >= n as f64 {
            let msg = format!(
                "a face refers to vertex {} but the file has {n} vertices (counted from 1)",
                last + 1.0
            );
            return Err(unusable(line, msg));
        }
    }
    if dropped > 0 {
        report.warnings.push(format!("{dropped} vertex row(s) with non-finite coordinates dropped"));
    }
    if !libraries.is_empty() && !buffered.tris.is_empty() {
        let materials = match dir {
            Some(dir) => {
                mtl::load_libraries(dir, &libraries, &used, &mut report.warnings, &mut report.inputs)?
            }
            None => {
                report.warnings.push("materials ignored: the OBJ was read without its directory".into());
                Vec::new()
            }
        };
        if materials.iter().any(Option::is_some) {
            return sample_materials(buffered, &texcoords, &tri_uv, &tri_mat, &materials, opts, report, sink);
        }
    }
    if report.rows > opts.face_vertex_limit {
        buffered.tris.clear();
    }
    buffered.finish(&mut report, sink)?;
    Ok(report)
}

/// A mesh with materials sampled on its surface: every triangle with its material (the
/// material named by its `usemtl`, if the libraries define it) and texture coordinates;
/// vertices in no triangle are passed on as they are.
#[allow(clippy::too_many_arguments)]
fn sample_materials<E>(
    buffered: Buffered,
    texcoords: &[[f32; 2]],
    tri_uv: &[[u32; 3]],
    tri_mat: &[u32],
    materials: &[Option<mtl::ObjMaterial>],
    opts: &ReadOptions,
    mut report: ReadReport,
    sink: &mut dyn Sink<Error = E>,
) -> Result<ReadReport, ReadError<E>> {
    let points = buffered.points;
    let mut surface = Surface {
        positions: points.iter().map(|p| p.pos).collect(),
        colors: if report.has_colors {
            points.iter().map(|p| linear_color(p.color)).collect()
        } else {
            Vec::new()
        },
        materials: materials
            .iter()
            .map(|m| m.as_ref().map(|m| m.material.clone()).unwrap_or_default())
            .collect(),
        ..Default::default()
    };
    surface.tris = buffered
        .tris
        .iter()
        .zip(tri_uv)
        .zip(tri_mat)
        .map(|((&v, uv), &m)| {
            let (offset, scale) = materials
                .get(m as usize)
                .and_then(Option::as_ref)
                .map_or(([0.0; 2], [1.0; 2]), |m| (m.offset, m.scale));
            // OBJ's v runs up from the bottom of the image; the sampler's down from the top.
            let uv = uv.map(|k| {
                let [u, v] = texcoords.get(k as usize).copied().unwrap_or([0.0; 2]);
                [u * scale[0] + offset[0], 1.0 - (v * scale[1] + offset[1])]
            });
            Tri { v, uv, material: if (m as usize) < materials.len() { m } else { NO_MATERIAL } }
        })
        .collect();
    let params = opts.sample_params(points.iter().map(|p| p.pos));
    // Vertices in no triangle (a point cloud in the same file) are samples of their own.
    super::surface::pass_lone_vertices(&points, &surface.tris, &mut report, sink)?;
    surface.sample(&params, &mut report, sink)?;
    report.has_colors |= surface.materials.iter().any(|m| m.colored);
    report.faces_used = report.faces_used.min(surface.tris.len() as u64);
    Ok(report)
}

/// Wavefront material libraries (`.mtl`): `newmtl`, `Kd`, `map_Kd` with its options (`-o`,
/// `-s`, `-clamp`; the others are skipped), file names with spaces, relative to the library.
pub mod mtl {
    use super::*;

    /// A material of a library, as the sampler uses it, with its texture transform.
    #[derive(Clone, Debug)]
    pub struct ObjMaterial {
        /// Colour factor and texture.
        pub material: Material,
        /// `map_Kd -o u v`.
        pub offset: [f32; 2],
        /// `map_Kd -s u v`.
        pub scale: [f32; 2],
    }

    /// The materials `used` (in that order; `None` where no library defines one) from the
    /// `libraries` named by `mtllib` (with their lines), found in `dir`. A library that cannot
    /// be read, or a material it does not define, is a warning; a texture that cannot be read is
    /// an error naming it.
    pub(crate) fn load_libraries<E>(
        dir: &Path,
        libraries: &[(String, usize)],
        used: &[String],
        warnings: &mut Vec<String>,
        inputs: &mut Vec<PathBuf>,
    ) -> Result<Vec<Option<ObjMaterial>>, ReadError<E>> {
        let mut defined: Vec<(String, ObjMaterial)> = Vec::new();
        let mut textures = TextureCache::default();
        for (names, line) in libraries {
            for path in library_files(dir, names) {
                inputs.push(path.clone());
                match std::fs::read(&path) {
                    Ok(bytes) => defined.extend(parse(&path, &bytes, &mut textures, warnings)?),
                    Err(e) => warnings.push(format!(
                        "material library {} (mtllib, line {line}) cannot be read: {e}; its materials are ignored",
                        path.display()
                    )),
                }
            }
        }
        inputs.extend(textures.paths());
        Ok(used
            .iter()
            .map(|name| {
                let found = defined.iter().rev().find(|(n, _)| n == name).map(|(_, m)| m.clone());
                if found.is_none() && !defined.is_empty() {
                    warnings.push(format!("material '{name}' (usemtl) is not in the material libraries"));
                }
                found
            })
            .collect())
    }

    /// The files an `mtllib` line names (quotes around a name dropped): the whole rest of the
    /// line if that is a file (a name with spaces) or has no spaces, else its words if one of
    /// them is a file; when none is, its words if they all end in `.mtl`, else the whole line (so
    /// that the warning names the one missing file as it is written).
    fn library_files(dir: &Path, names: &str) -> Vec<PathBuf> {
        let path = |n: &str| dir.join(n.trim_matches('"').replace('\\', "/"));
        let whole = path(names);
        if whole.is_file() || !names.contains(char::is_whitespace) {
            return vec![whole];
        }
        let words: Vec<&str> = names.split_whitespace().map(|n| n.trim_matches('"')).collect();
        let all_mtl = words.iter().all(|n| n.to_ascii_lowercase().ends_with(".mtl"));
        let words: Vec<PathBuf> = words.into_iter().map(path).collect();
        if words.iter().any(|w| w.is_file()) || all_mtl { words } else { vec![whole] }
    }

    /// The materials a library defines, in order.
    pub(crate) fn parse<E>(
        path: &Path,
        bytes: &[u8],
        textures: &mut TextureCache,
        warnings: &mut Vec<String>,
    ) -> Result<Vec<(String, ObjMaterial)>, ReadError<E>> {
        let dir = path.parent().unwrap_or(Path::new("."));
        let text = String::from_utf8_lossy(bytes);
        let file = path.display();
        let mut out: Vec<(String, ObjMaterial)> = Vec::new();
        let new = || ObjMaterial { material: Material::default(), offset: [0.0; 2], scale: [1.0; 2] };
        for (k, raw) in text.lines().enumerate() {
            let line = k + 1;
            let l = raw.trim();
            let (kw, rest) = l.split_once(char::is_whitespace).unwrap_or((l, ""));
            let rest = rest.trim();
            let bad = |what: &str| {
                ReadError::Obj(ObjError::Library { file: file.to_string(), line, msg: what.to_string() })
            };
            match kw {
                "newmtl" => out.push((rest.to_string(), new())),
                "Kd" => {
                    let Some((_, m)) = out.last_mut() else { return Err(bad("Kd before any newmtl")) };
                    let v: Vec<f32> = rest.split_whitespace().map_while(|t| t.parse().ok()).collect();
                    let c = match v[..] {
                        [g] => [g; 3],
                        [r, g, b, ..] => [r, g, b],
                        _ => return Err(bad(&format!("Kd '{rest}' is not a colour"))),
                    };
                    if !c.iter().all(|x| x.is_finite()) {
                        return Err(bad(&format!("Kd '{rest}' is not a colour")));
                    }
                    m.material.factor = [c[0], c[1], c[2], 1.0];
                    m.material.colored = true;
                }
                "map_Kd" => {
                    let Some((name, m)) = out.last_mut() else { return Err(bad("map_Kd before any newmtl")) };
                    let map = map_options(rest).map_err(|e| bad(&e))?;
                    let (tex_path, looked) = crate::formats::texture::image_path(dir, &map.file, warnings);
                    textures.looked_at(looked);
                    let wrap = if map.clamp { [Wrap::ClampToEdge; 2] } else { [Wrap::Repeat; 2] };
                    let texture = textures.get(&tex_path, wrap).map_err(|e| TextureError {
                        source_name: format!(
                            "{} (map_Kd of material '{name}', {file} line {line})",
                            tex_path.display()
                        ),
                        msg: e.msg,
                    })?;
                    m.material.texture = Some(texture);
                    m.material.colored = true;
                    (m.offset, m.scale) = (map.offset, map.scale);
                }
                _ => {}
            }
        }
        if out.is_empty() {
            warnings.push(format!("material library {file} defines no material (newmtl)"));
        }
        Ok(out)
    }

    /// A texture statement's options and file name.
    #[derive(Debug, PartialEq)]
    pub(crate) struct MapOptions {
        pub(crate) file: String,
        pub(crate) offset: [f32; 2],
        pub(crate) scale: [f32; 2],
        pub(crate) clamp: bool,
    }

    /// Reads `-o u v w`, `-s u v w`, `-clamp on` and skips the other options (with their
    /// arguments); the rest of the statement is the file name, spaces and all.
    pub(crate) fn map_options(rest: &str) -> Result<MapOptions, String> {
        let mut out = MapOptions { file: String::new(), offset: [0.0; 2], scale: [1.0; 2], clamp: false };
        let mut s = rest.trim_start();
        while s.starts_with('-') {
            let (opt, tail) = s.split_once(char::is_whitespace).unwrap_or((s, ""));
            let mut words = tail.split_whitespace().peekable();
            let mut consumed = Vec::new();
            // Options of 1–3 numbers take as many as follow; the others a fixed count.
            let fixed = match opt {
                "-blendu" | "-blendv" | "-cc" | "-clamp" | "-bm" | "-texres" | "-imfchan" | "-boost"
                | "-type" => 1,
                "-mm" => 2,
                "-o" | "-s" | "-t" => 0,
                _ => return Err(format!("unknown texture option '{opt}'")),
            };
            if fixed > 0 {
                for _ in 0..fixed {
                    consumed.push(
                        words.next().ok_or_else(|| format!("texture option '{opt}' without its value"))?,
                    );
                }
            } else {
                while consumed.len() < 3 && words.peek().is_some_and(|w| w.parse::<f32>().is_ok()) {
                    consumed.extend(words.next());
                }
                if consumed.is_empty() {
                    return Err(format!("texture option '{opt}' without its value"));
                }
            }
            let nums: Vec<f32> = consumed.iter().filter_map(|w| w.parse().ok()).collect();
            match opt {
                "-clamp" => out.clamp = consumed[0] == "on",
                "-o" => out.offset = [nums[0], nums.get(1).copied().unwrap_or(0.0)],
                "-s" => out.scale = [nums[0], nums.get(1).copied().unwrap_or(1.0)],
                _ => {}
            }
            // The rest after the consumed words.
            let mut t = tail;
            for w in &consumed {
                t = t.trim_start();
                t = &t[w.len()..];
            }
            s = t.trim_start();
        }
        if s.is_empty() {
            return Err("texture statement without a file name".into());
        }
        out.file = s.trim_end().to_string();
        Ok(out)
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn an_mtllib_line_names_one_file_with_spaces_or_several_mtl_files() {
            let dir = tempfile::tempdir().expect("temp dir");
            let d = dir.path();
            let names = |line: &str| -> Vec<PathBuf> { library_files(d, line) };
            // Missing or not, a name with spaces is one file (and a missing one is named whole).
            assert_eq!(names("box textured.mtl"), [d.join("box textured.mtl")]);
            assert_eq!(names("\"box textured.mtl\""), [d.join("box textured.mtl")]);
            std::fs::write(d.join("a b.mtl"), "").expect("write");
            assert_eq!(names("a b.mtl"), [d.join("a b.mtl")]);
            // Words that are all .mtl names, not one file: several libraries.
            assert_eq!(names("a.mtl B.MTL"), [d.join("a.mtl"), d.join("B.MTL")]);
            assert_eq!(names("\"a.mtl\" \"b.mtl\""), [d.join("a.mtl"), d.join("b.mtl")]);
            // Libraries of any name, one of them found: each word is one.
            std::fs::write(d.join("common.mat"), "").expect("write");
            assert_eq!(names("parts.mtl common.mat"), [d.join("parts.mtl"), d.join("common.mat")]);
        }

        #[test]
        fn map_options_and_names_with_spaces() {
            let m = map_options("-s 2 3 1 -o 0.5 -clamp on -bm 0.2 my texture.jpg").expect("options");
            assert_eq!(
                m,
                MapOptions {
                    file: "my texture.jpg".into(),
                    offset: [0.5, 0.0],
                    scale: [2.0, 3.0],
                    clamp: true
                }
            );
            assert_eq!(map_options("atlas 1.png").expect("plain").file, "atlas 1.png");
            assert!(map_options("-o").is_err());
            assert!(map_options("-clamp on").is_err());
            assert!(map_options("-zz 1 a.png").is_err());
        }
    }
}

/// An OBJ statement the reader uses, with how many numbers it takes from its piece.
#[derive(Clone, Copy)]
pub(crate) enum ObjStmt {
    /// `v`: coordinates (and colour) in `values`.
    Vertex {
        line: usize,
        n: usize,
    },
    /// `f`: vertex indices (as written: 1-based or negative) in `indices`, and as many texture
    /// coordinate indices in `tex_indices` (0 where a corner has none).
    Face {
        line: usize,
        n: usize,
    },
    /// `vt u [v [w]]`: the first two in `values`.
    TexCoord,
    /// `usemtl NAME` or `mtllib FILE…`: the rest of the line in `names`.
    UseMtl,
    MtlLib {
        line: usize,
    },
}

/// The statements of consecutive lines; parsing stops at the first line in error, which is
/// returned once the statements before it are visited.
#[derive(Default)]
pub(crate) struct ObjPiece {
    stmts: Vec<ObjStmt>,
    values: Vec<f64>,
    indices: Vec<i64>,
    tex_indices: Vec<i64>,
    names: Vec<String>,
    error: Option<(usize, String)>,
}

/// A block of an OBJ file parsed: its `v` and `f` lines (byte range, 1-based line), and their
/// statements in pieces.
#[derive(Default)]
pub(crate) struct ObjParsed {
    lines: Vec<(usize, usize, usize)>,
    pieces: Vec<ObjPiece>,
}

/// OBJ as blocks of lines; reading stands at a number of lines.
pub(crate) struct ObjLines;

impl crate::formats::lines::Format for ObjLines {
    type At = usize;
    type Out = ObjParsed;

    fn scan(&self, block: &[u8], mut line: usize, out: &mut ObjParsed) -> usize {
        out.lines.clear();
        for (start, end) in crate::formats::lines::lines(block) {
            line += 1;
            if matches!(
                Tokens::new(&block[start..end]).next(),
                Some(b"v" | b"f" | b"vt" | b"usemtl" | b"mtllib")
            ) {
                out.lines.push((start, end, line));
            }
        }
        line
    }

    fn parse(&self, block: &[u8], out: &mut ObjParsed) {
        crate::formats::lines::in_pieces(&out.lines, &mut out.pieces, |_, lines, p| {
            p.stmts.clear();
            p.values.clear();
            p.indices.clear();
            p.tex_indices.clear();
            p.names.clear();
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

pub(crate) fn parse_obj_line(text: &[u8], line: usize, p: &mut ObjPiece) -> Result<(), String> {
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
        Some(b"vt") => {
            let mut uv = [0.0; 2];
            for (k, slot) in uv.iter_mut().enumerate() {
                match tok.next_f64() {
                    Some(v) => *slot = v.map_err(|t| format!("'{}' is not a number", quoted(t)))?,
                    None if k == 1 => {}
                    None => return Err("texture coordinate without a value".into()),
                }
            }
            p.values.extend(uv);
            p.stmts.push(ObjStmt::TexCoord);
        }
        Some(kw @ (b"usemtl" | b"mtllib")) => {
            let rest = rest_of_line(text, kw.len());
            p.names.push(rest);
            p.stmts.push(if kw == b"usemtl" { ObjStmt::UseMtl } else { ObjStmt::MtlLib { line } });
        }
        _ => {
            let start = p.indices.len();
            for t in tok {
                let mut parts = t.split(|&b| b == b'/');
                let first = parts.next().unwrap_or_default();
                let i = parse_i64(first).ok_or_else(|| format!("bad face index '{}'", quoted(t)))?;
                let vt = match parts.next() {
                    None | Some(b"") => 0,
                    Some(vt) => {
                        parse_i64(vt).ok_or_else(|| format!("bad texture index in '{}'", quoted(t)))?
                    }
                };
                p.indices.push(i);
                p.tex_indices.push(vt);
            }
            p.stmts.push(ObjStmt::Face { line, n: p.indices.len() - start });
        }
    }
    Ok(())
}

/// The text of a line after its keyword (`kw_len` bytes after the leading whitespace), trimmed:
/// a name with spaces in it stays whole.
fn rest_of_line(text: &[u8], kw_len: usize) -> String {
    let start = text.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(0) + kw_len;
    String::from_utf8_lossy(text.get(start..).unwrap_or_default()).trim().to_string()
}
