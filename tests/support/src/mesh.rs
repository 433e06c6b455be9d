//! A minimal reader of the test meshes (OBJ `v`/`f` lines, ASCII PLY with `x y z` first and a
//! face list) for the mesh reference renderer: independent of the importer's readers, so that a
//! fault there does not hide in the comparison.

use glam::DVec3;
use kiosk::MappedStore;
use kiosk_core::camera::{Camera, orthonormal_up};
use kiosk_render::reference::Mesh;
use std::path::Path;

/// The far, middle and close-up views of a model: the start view, then toward the surface
/// point at the centre of the image, at 0.35 and 0.06 of the model's diagonal.
pub fn views(store: &MappedStore, mesh: &Mesh) -> [(&'static str, Camera); 3] {
    let far = kiosk_core::replay::initial_camera(store, 0.8, DVec3::Y);
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
