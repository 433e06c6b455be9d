//! A minimal reader of the test meshes (OBJ `v`/`f` lines, ASCII PLY with `x y z` first and a
//! face list) for the mesh reference renderer: independent of the importer's readers, so that a
//! fault there does not hide in the comparison.

use glam::DVec3;
use kiosk_content::MappedStore;
use kiosk_core::camera::{Camera, orthonormal_up};
use kiosk_render::reference::Mesh;
use std::path::Path;

/// The far, middle and close-up views of a model: the start view, then toward the surface
/// point at the centre of the image, at 0.35 and 0.06 of the model's diagonal.
pub fn views(store: &MappedStore, mesh: &Mesh) -> [(&'static str, Camera); 3] {
    views_from(store, mesh, None)
}

/// [`views`] from the model's `front` side (see [`kiosk_core::camera::start_camera`]).
pub fn views_from(store: &MappedStore, mesh: &Mesh, front: Option<DVec3>) -> [(&'static str, Camera); 3] {
    let far = kiosk_core::camera::start_camera(store, 0.8, DVec3::Y, front);
    let dir = far.forward();
    let diag = f64::from(store.bbox().diagonal());
    // The first vertex along the central ray (within 1 % of the diagonal from it).
    let hit = mesh
        .positions
        .iter()
        .map(|p| mesh.origin + p.as_dvec3())
        .filter_map(|p| {
            let t = (p - far.eye).dot(dir);
            ((p - (far.eye + dir * t)).length() < 0.01 * diag).then_some((t, p))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or(far.target, |(_, p)| p);
    let at = |d: f64| {
        let mut c = Camera { eye: hit - dir * d * diag, target: hit, up: far.up, fov_y: far.fov_y };
        c.up = orthonormal_up(c.forward(), far.up, DVec3::Z);
        c
    };
    [("far", far), ("middle", at(0.35)), ("close-up", at(0.06))]
}

/// Reads an OBJ or ASCII PLY mesh (by extension) into a [`Mesh`].
pub fn read(path: &Path) -> Result<Mesh, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let (positions, triangles) = if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj")) {
        parse_obj(&text)
    } else {
        parse_ply(&text)
    }
    .map_err(|e| format!("{}: {e}", path.display()))?;
    Mesh::new(&positions, triangles).map_err(|e| format!("{}: {e}", path.display()))
}

/// Reads a binary glTF (GLB) mesh with its base-colour texture into a textured [`Mesh`]: every
/// triangle primitive of the default scene with its node transforms, texture coordinates set 0,
/// the one image its materials share (JPEG or PNG in the file). For the textured reference render;
/// a file with several images, or base-colour factors other than 1, is an error.
pub fn read_glb(path: &Path) -> Result<Mesh, String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let bytes = std::fs::read(path).map_err(|e| err(&e))?;
    let glb = gltf::Gltf::from_slice(&bytes).map_err(|e| err(&e))?;
    let blob = glb.blob.as_deref().ok_or_else(|| err(&"no binary chunk"))?;
    let doc = &glb.document;
    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or_else(|| err(&"no scene"))?;
    let (mut positions, mut uvs, mut triangles) = (Vec::new(), Vec::new(), Vec::new());
    let mut image = None;
    let mut stack: Vec<(gltf::Node, glam::DMat4)> =
        scene.nodes().map(|n| (n, glam::DMat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        let m =
            parent * glam::DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        stack.extend(node.children().map(|c| (c, m)));
        let Some(mesh) = node.mesh() else { continue };
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                continue;
            }
            let pbr = prim.material().pbr_metallic_roughness();
            if pbr.base_color_factor() != [1.0; 4] {
                return Err(err(&"a base-colour factor other than 1"));
            }
            let tex = pbr.base_color_texture().ok_or_else(|| err(&"a primitive without a texture"))?;
            let source = tex.texture().source().index();
            if *image.get_or_insert(source) != source {
                return Err(err(&"several images"));
            }
            let reader = prim.reader(|_| Some(blob));
            let base = positions.len() as u32;
            let pos = reader.read_positions().ok_or_else(|| err(&"no positions"))?;
            positions.extend(pos.map(|p| m.transform_point3(glam::DVec3::from_array(p.map(f64::from)))));
            let tc = reader.read_tex_coords(tex.tex_coord()).ok_or_else(|| err(&"no texture coordinates"))?;
            uvs.extend(tc.into_f32());
            if uvs.len() != positions.len() {
                return Err(err(&"texture coordinates and positions differ in number"));
            }
            let idx: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..positions.len() as u32 - base).collect(),
            };
            // A mirroring transform turns the winding; the reference draws both sides anyway.
            triangles.extend(idx.chunks_exact(3).map(|t| [base + t[0], base + t[1], base + t[2]]));
        }
    }
    let source = image.ok_or_else(|| err(&"no textured primitive"))?;
    let img = doc.images().nth(source).ok_or_else(|| err(&"no such image"))?;
    let gltf::image::Source::View { view, .. } = img.source() else {
        return Err(err(&"an image outside the file"));
    };
    let data = &blob[view.offset()..view.offset() + view.length()];
    let texture = image::load_from_memory(data).map_err(|e| err(&e))?.to_rgba8();
    let mut out = Mesh::new(&positions, triangles).map_err(|e| err(&e))?;
    out.texture = Some(texture);
    out.uvs = uvs;
    Ok(out)
}

fn number(s: Option<&str>, line: usize) -> Result<f64, String> {
    s.and_then(|x| x.parse().ok()).ok_or_else(|| format!("line {line}: expected a number"))
}

fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
}

type Parsed = (Vec<DVec3>, Vec<[u32; 3]>);

fn parse_obj(text: &str) -> Result<Parsed, String> {
    let (mut v, mut t) = (Vec::new(), Vec::new());
    for (i, line) in text.lines().enumerate() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => v.push(DVec3::new(
                number(w.next(), i + 1)?,
                number(w.next(), i + 1)?,
                number(w.next(), i + 1)?,
            )),
            Some("f") => {
                let poly = w
                    .map(|c| {
                        let k: i64 = c
                            .split('/')
                            .next()
                            .and_then(|x| x.parse().ok())
                            .ok_or(format!("line {}: bad index", i + 1))?;
                        let k = if k < 0 { v.len() as i64 + k } else { k - 1 };
                        u32::try_from(k).map_err(|_| format!("line {}: bad index", i + 1))
                    })
                    .collect::<Result<Vec<u32>, String>>()?;
                fan(&poly, &mut t);
            }
            _ => {}
        }
    }
    Ok((v, t))
}

fn parse_ply(text: &str) -> Result<Parsed, String> {
    let mut lines = text.lines().enumerate();
    let (mut vertices, mut faces) = (0usize, 0usize);
    for (_, line) in lines.by_ref() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["format", f, ..] if *f != "ascii" => return Err(format!("{f} PLY: only ASCII is read here")),
            ["element", "vertex", n] => vertices = n.parse().map_err(|_| "bad vertex count")?,
            ["element", "face", n] => faces = n.parse().map_err(|_| "bad face count")?,
            ["end_header"] => break,
            _ => {}
        }
    }
    let mut v = Vec::with_capacity(vertices);
    let mut t = Vec::new();
    for _ in 0..vertices {
        let (i, line) = lines.next().ok_or("fewer vertices than declared")?;
        let mut w = line.split_whitespace();
        v.push(DVec3::new(number(w.next(), i + 1)?, number(w.next(), i + 1)?, number(w.next(), i + 1)?));
    }
    for _ in 0..faces {
        let (i, line) = lines.next().ok_or("fewer faces than declared")?;
        let poly: Vec<u32> = line
            .split_whitespace()
            .skip(1)
            .map(|x| x.parse().map_err(|_| format!("line {}: bad index", i + 1)))
            .collect::<Result<_, String>>()?;
        fan(&poly, &mut t);
    }
    Ok((v, t))
}
