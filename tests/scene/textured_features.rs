//! The colours of textured and coloured meshes, feature by feature: glTF's `COLOR_0`,
//! `baseColorFactor`, `KHR_texture_transform` and sampler wrap modes, PLY's `comment TextureFile`
//! with per-vertex texture coordinates and several atlases picked by `texnumber`, OBJ faces
//! switching materials with `usemtl` (a texture and a plain `Kd`, two atlases). Every file is
//! written by the test into a temporary directory.

use glam::DVec3;
use kiosk_import::read_all;
use kiosk_import::{InputPoint, ReadOptions};
use serde_json::{Value, json};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// A test image: `n × n` square blocks of one colour each, `side` texels a side, so that a sample
/// well inside a block has that block's colour exactly, whatever the bilinear filter; the blue
/// channel tells `palette`s apart.
#[derive(Clone, Copy)]
struct Blocks {
    side: u32,
    n: u32,
    palette: u8,
}

impl Blocks {
    /// The colour of block `(bx, by)` (`by` from the top of the image).
    fn colour(&self, bx: u32, by: u32) -> [u8; 4] {
        [(40 + 60 * bx) as u8, (40 + 60 * by) as u8, if self.palette == 0 { 30 } else { 220 }, 255]
    }

    fn write(&self, path: &Path) {
        let b = self.side / self.n;
        image::RgbaImage::from_fn(self.side, self.side, |x, y| image::Rgba(self.colour(x / b, y / b)))
            .save(path)
            .expect("png");
    }

    /// The block at texture coordinates `uv` (0,0 the image's top left; inside [0, 1]²) and its
    /// colour, where bilinear filtering reads that block's texels only (`None` near the edge of a
    /// block, where it blends two).
    fn at(&self, uv: [f64; 2]) -> Option<([u32; 2], [u8; 4])> {
        let b = f64::from(self.side / self.n);
        let t = uv.map(|c| c * f64::from(self.side));
        let block = t.map(|c| (c / b).floor());
        let inside = (0..2).all(|k| {
            (0.0..f64::from(self.n)).contains(&block[k]) && (0.6..=b - 0.6).contains(&(t[k] - block[k] * b))
        });
        inside.then(|| {
            let [bx, by] = block.map(|c| c as u32);
            ([bx, by], self.colour(bx, by))
        })
    }
}

/// Whether two colours are the same within 2 levels a channel (sRGB and filtering rounding).
fn near(a: [u8; 4], b: [u8; 4]) -> bool {
    (0..4).all(|k| a[k].abs_diff(b[k]) <= 2)
}

/// Every sample of `points` is `colour` (±2 levels), and there are many of them (the surface is
/// sampled, not only the corners).
fn assert_all(what: &str, points: &[InputPoint], colour: [u8; 4]) {
    assert!(points.len() > 100, "{what}: {} samples", points.len());
    let off: Vec<_> = points.iter().filter(|p| !near(p.color, colour)).take(5).collect();
    assert!(off.is_empty(), "{what}: samples not {colour:?}: {off:?}");
}

/// Checks every sample of `points` whose texture coordinates (`uv_of` its position: 0,0 the
/// image's top left, inside [0, 1]²) fall well inside a block of `tex` against that block's
/// colour, through `expect` (±2 levels); returns the blocks seen, after checking that most
/// samples were checked.
fn assert_blocks(
    what: &str,
    points: &[InputPoint],
    tex: &Blocks,
    uv_of: impl Fn(DVec3) -> [f64; 2],
    expect: impl Fn([u8; 4]) -> [u8; 4],
) -> BTreeSet<[u32; 2]> {
    let mut seen = BTreeSet::new();
    let mut checked = 0;
    for p in points {
        if let Some((block, colour)) = tex.at(uv_of(p.pos)) {
            checked += 1;
            seen.insert(block);
            let want = expect(colour);
            assert!(
                near(p.color, want),
                "{what}: the sample at {:?} (texture {:?}, block {block:?}) is {:?}, not {want:?}",
                p.pos,
                uv_of(p.pos),
                p.color
            );
        }
    }
    assert!(checked * 3 > points.len(), "{what}: only {checked} of {} samples checked", points.len());
    seen
}

/// The blocks `(bx, by)` for `bx` in `xs` and `by` in `ys`.
fn block_set(xs: std::ops::Range<u32>, ys: std::ops::Range<u32>) -> BTreeSet<[u32; 2]> {
    xs.flat_map(|x| ys.clone().map(move |y| [x, y])).collect()
}

/// Writes `name.gltf` and `name.bin` into `dir`: a unit square in z = 0 (corners (0,0), (1,0),
/// (1,1), (0,1); two triangles), with `TEXCOORD_0` `uv` at those corners and `COLOR_0` `colour`
/// (RGBA floats, linear) at every corner when given, and the material 0 of `extra` when it has
/// `materials`. The entries of `extra` (`materials`, `textures`, `images`, `samplers`,
/// `extensionsUsed`…) are added to the file's root as they are.
fn write_square_gltf(
    dir: &Path,
    name: &str,
    uv: Option<[[f32; 2]; 4]>,
    colour: Option<[f32; 4]>,
    extra: Value,
) -> PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut add = |bin: &mut Vec<u8>, values: &[f32], ty: &str, count: usize| {
        views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": 4 * values.len() }));
        bin.extend(values.iter().flat_map(|v| v.to_le_bytes()));
        let mut acc =
            json!({ "bufferView": views.len() - 1, "componentType": 5126, "count": count, "type": ty });
        if ty == "VEC3" {
            acc["min"] = json!([0.0, 0.0, 0.0]);
            acc["max"] = json!([1.0, 1.0, 0.0]);
        }
        accessors.push(acc);
        accessors.len() - 1
    };
    let positions: Vec<f32> = SQUARE_UV.iter().flat_map(|&[x, y]| [x, y, 0.0]).collect();
    let mut attributes = json!({ "POSITION": add(&mut bin, &positions, "VEC3", 4) });
    if let Some(uv) = uv {
        attributes["TEXCOORD_0"] = json!(add(&mut bin, uv.as_flattened(), "VEC2", 4));
    }
    if let Some(c) = colour {
        attributes["COLOR_0"] = json!(add(&mut bin, &[c; 4].concat(), "VEC4", 4));
    }
    views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": 12 }));
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    accessors
        .push(json!({ "bufferView": views.len() - 1, "componentType": 5123, "count": 6, "type": "SCALAR" }));
    let mut primitive = json!({ "attributes": attributes, "indices": accessors.len() - 1 });
    if extra.get("materials").is_some() {
        primitive["material"] = json!(0);
    }
    let mut root = json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [primitive] }],
        "buffers": [{ "uri": format!("{name}.bin"), "byteLength": bin.len() }],
        "bufferViews": views,
        "accessors": accessors,
    });
    if let Value::Object(extra) = extra {
        root.as_object_mut().expect("object").extend(extra);
    }
    std::fs::write(dir.join(format!("{name}.bin")), &bin).expect("write bin");
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_string_pretty(&root).expect("json")).expect("write gltf");
    path
}

/// A uniform white 4 × 4 PNG.
fn write_white(path: &Path) {
    image::RgbaImage::from_pixel(4, 4, image::Rgba([255; 4])).save(path).expect("png");
}

/// glTF texture coordinates of the square's corners: the corner's own (x, y).
const SQUARE_UV: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];

fn read(path: &Path, opts: &ReadOptions) -> Vec<InputPoint> {
    let (points, report) = read_all(path, opts).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(report.has_colors, "{}: no colours reported", path.display());
    points
}

#[test]
fn a_gltf_vertex_colour_multiplies_the_base_colour() {
    let dir = tempfile::tempdir().expect("temp dir");
    let opts = ReadOptions { texel_density: 16.0, ..Default::default() };
    // No material: COLOR_0 alone is the colour.
    let path = write_square_gltf(dir.path(), "red", None, Some([1.0, 0.0, 0.0, 1.0]), json!({}));
    assert_all("COLOR_0 red", &read(&path, &opts), [255, 0, 0, 255]);
    // A yellow factor times a magenta COLOR_0: red.
    let path = write_square_gltf(
        dir.path(),
        "yellow-magenta",
        None,
        Some([1.0, 0.0, 1.0, 1.0]),
        json!({ "materials": [{ "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 0.0, 1.0] } }] }),
    );
    assert_all("yellow factor × magenta COLOR_0", &read(&path, &opts), [255, 0, 0, 255]);
    // A white texture times COLOR_0 (0, 0.5, 1), linear: 0.5 is sRGB 188.
    write_white(&dir.path().join("white.png"));
    let path = write_square_gltf(
        dir.path(),
        "textured",
        Some(SQUARE_UV),
        Some([0.0, 0.5, 1.0, 1.0]),
        json!({
            "materials": [{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }],
            "textures": [{ "source": 0 }],
            "images": [{ "uri": "white.png" }],
        }),
    );
    assert_all("white texture × COLOR_0", &read(&path, &opts), [0, 188, 255, 255]);
}

#[test]
fn a_gltf_base_colour_factor_multiplies_the_texture_or_is_the_colour_without_one() {
    let dir = tempfile::tempdir().expect("temp dir");
    let opts = ReadOptions { texel_density: 16.0, ..Default::default() };
    let green = json!({ "baseColorFactor": [0.0, 1.0, 0.0, 1.0] });
    // Without a texture.
    let path = write_square_gltf(
        dir.path(),
        "plain",
        Some(SQUARE_UV),
        None,
        json!({ "materials": [{ "pbrMetallicRoughness": green }] }),
    );
    assert_all("green factor, no texture", &read(&path, &opts), [0, 255, 0, 255]);
    // On a white texture.
    write_white(&dir.path().join("white.png"));
    let mut pbr = green.clone();
    pbr["baseColorTexture"] = json!({ "index": 0 });
    let textures = |pbr: &Value, image: &str| {
        json!({
            "materials": [{ "pbrMetallicRoughness": pbr }],
            "textures": [{ "source": 0 }],
            "images": [{ "uri": image }],
        })
    };
    let path = write_square_gltf(dir.path(), "white", Some(SQUARE_UV), None, textures(&pbr, "white.png"));
    assert_all("green factor × white texture", &read(&path, &opts), [0, 255, 0, 255]);
    // On a texture of many colours, channel by channel: (1, 0, 1) keeps red and blue.
    let tex = Blocks { side: 16, n: 4, palette: 0 };
    tex.write(&dir.path().join("blocks.png"));
    pbr["baseColorFactor"] = json!([1.0, 0.0, 1.0, 1.0]);
    let path = write_square_gltf(dir.path(), "blocks", Some(SQUARE_UV), None, textures(&pbr, "blocks.png"));
    let seen = assert_blocks(
        "magenta factor × blocks",
        &read(&path, &opts),
        &tex,
        |p| [p.x, p.y],
        |[r, _, b, a]| [r, 0, b, a],
    );
    assert_eq!(seen, block_set(0..4, 0..4));
}

#[test]
fn a_gltf_texture_transform_offsets_rotates_and_scales_the_texture_coordinates() {
    // The extension's own example: offset (0, 1), rotation 90°, scale ½ "utilizes only the lower
    // left quadrant of the source image, rotated clockwise 90°". In the image's coordinates (0,0
    // its top left) (u, v) becomes (½ v, 1 − ½ u), the rotation as the example, the sample model
    // TextureTransformTest and KhronosGroup/glTF#1563 have it (u cos r + v sin r, −u sin r +
    // v cos r) before the offset; the other direction would read the upper right quadrant.
    let dir = tempfile::tempdir().expect("temp dir");
    let tex = Blocks { side: 16, n: 4, palette: 0 };
    tex.write(&dir.path().join("blocks.png"));
    let path = write_square_gltf(
        dir.path(),
        "transformed",
        Some(SQUARE_UV),
        None,
        json!({
            "extensionsUsed": ["KHR_texture_transform"],
            "materials": [{ "pbrMetallicRoughness": { "baseColorTexture": {
                "index": 0,
                "extensions": { "KHR_texture_transform": {
                    "offset": [0.0, 1.0],
                    "rotation": std::f64::consts::FRAC_PI_2,
                    "scale": [0.5, 0.5],
                } },
            } } }],
            "textures": [{ "source": 0 }],
            "images": [{ "uri": "blocks.png" }],
        }),
    );
    let points = read(&path, &ReadOptions { texel_density: 64.0, ..Default::default() });
    let (r, o, s) = (std::f64::consts::FRAC_PI_2, [0.0, 1.0], 0.5);
    let transformed = |p: DVec3| {
        let (u, v) = (p.x * s, p.y * s);
        [r.cos() * u + r.sin() * v + o[0], -r.sin() * u + r.cos() * v + o[1]]
    };
    let seen = assert_blocks("KHR_texture_transform", &points, &tex, transformed, |c| c);
    // Exactly the lower left quadrant: blocks 0–1 across, 2–3 down.
    assert_eq!(seen, block_set(0..2, 2..4));
    // Rotated clockwise: the square's corner (0, 0) reads the image's bottom left, its corner
    // (1, 0) the quadrant's top left, its corner (0, 1) the image's bottom middle (the blocks
    // there, looked at a little inside the square).
    let colour_near = |x: f64, y: f64| {
        points.iter().min_by(|a, b| {
            let d = |p: &InputPoint| (p.pos - DVec3::new(x, y, 0.0)).length();
            d(a).total_cmp(&d(b))
        })
    };
    for (x, y, block) in [(0.15, 0.15, [0, 3]), (0.85, 0.15, [0, 2]), (0.15, 0.85, [1, 3])] {
        let p = colour_near(x, y).expect("a sample");
        assert!(near(p.color, tex.colour(block[0], block[1])), "({x}, {y}): {:?}", p.color);
    }
}

#[test]
fn gltf_sampler_wrap_modes_clamp_or_mirror_texture_coordinates_outside_the_image() {
    // 2 × 2 blocks of one colour; the square's texture coordinates run over [1, 2]², outside the
    // image: CLAMP_TO_EDGE gives the bottom right corner's colour everywhere, MIRRORED_REPEAT
    // the image mirrored in both directions, (u, v) → (2 − u, 2 − v) (REPEAT would be (u − 1,
    // v − 1)).
    let dir = tempfile::tempdir().expect("temp dir");
    let tex = Blocks { side: 16, n: 2, palette: 1 };
    tex.write(&dir.path().join("quadrants.png"));
    let outside = SQUARE_UV.map(|[u, v]| [u + 1.0, v + 1.0]);
    let opts = ReadOptions { texel_density: 16.0, ..Default::default() };
    let file = |name: &str, wrap: u32| {
        let path = write_square_gltf(
            dir.path(),
            name,
            Some(outside),
            None,
            json!({
                "materials": [{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }],
                "textures": [{ "source": 0, "sampler": 0 }],
                "samplers": [{ "wrapS": wrap, "wrapT": wrap }],
                "images": [{ "uri": "quadrants.png" }],
            }),
        );
        read(&path, &opts)
    };
    const CLAMP_TO_EDGE: u32 = 33071;
    const MIRRORED_REPEAT: u32 = 33648;
    assert_all("CLAMP_TO_EDGE", &file("clamped", CLAMP_TO_EDGE), tex.colour(1, 1));
    let mirrored = file("mirrored", MIRRORED_REPEAT);
    let seen = assert_blocks("MIRRORED_REPEAT", &mirrored, &tex, |p| [1.0 - p.x, 1.0 - p.y], |c| c);
    assert_eq!(seen, block_set(0..2, 0..2));
    // The square's corner (0, 0), at texture (1, 1), is the bottom right block, mirrored.
    let corner = mirrored.iter().find(|p| p.pos.x < 0.1 && p.pos.y < 0.1).expect("a sample");
    assert!(near(corner.color, tex.colour(1, 1)), "{:?}", corner.color);
}

#[test]
fn a_ply_with_a_texture_file_and_per_vertex_coordinates_takes_the_texture_colour() {
    // A unit square, per-vertex texture coordinates (x, y) under either name; PLY's v runs up
    // from the bottom of the image, so the sample at (x, y) reads the image at (x, 1 − y). The
    // vertices' own grey is not the colour: the texture alone is (MeshLab writes its grey).
    let dir = tempfile::tempdir().expect("temp dir");
    let tex = Blocks { side: 16, n: 4, palette: 1 };
    tex.write(&dir.path().join("tex.png"));
    for (name, [u, v], grey) in [
        ("texture_uv.ply", ["texture_u", "texture_v"], false),
        ("st.ply", ["s", "t"], true),
        ("uv.ply", ["u", "v"], false),
    ] {
        let mut text = "ply\nformat ascii 1.0\ncomment TextureFile tex.png\nelement vertex 4\n".to_string();
        text += "property float x\nproperty float y\nproperty float z\n";
        text += &format!("property float {u}\nproperty float {v}\n");
        if grey {
            text += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
        }
        text += "element face 2\nproperty list uchar int vertex_indices\nend_header\n";
        for [x, y] in SQUARE_UV {
            text += &format!("{x} {y} 0 {x} {y}{}\n", if grey { " 128 128 128" } else { "" });
        }
        text += "3 0 1 2\n3 0 2 3\n";
        let path = dir.path().join(name);
        std::fs::write(&path, text).expect("write ply");
        let points = read(&path, &ReadOptions { texel_density: 16.0, ..Default::default() });
        let seen = assert_blocks(name, &points, &tex, |p| [p.x, 1.0 - p.y], |c| c);
        assert_eq!(seen, block_set(0..4, 0..4), "{name}");
    }
}

/// An OBJ unit square at x offset `ox`, its vertices numbered from `first`: its `v` lines, each
/// with a `vt` (x, y) (so a vertex and its texture coordinate have the same number), and its face,
/// whose corners name their texture coordinates when `textured`.
fn obj_square(ox: f64, first: usize, textured: bool) -> (String, String) {
    let mut v = String::new();
    for [x, y] in SQUARE_UV {
        v += &format!("v {} {y} 0\nvt {x} {y}\n", ox + f64::from(x));
    }
    let corners: Vec<String> =
        (first..first + 4).map(|i| if textured { format!("{i}/{i}") } else { i.to_string() }).collect();
    (v, format!("f {}\n", corners.join(" ")))
}

/// The samples of `points` on the square at x in [lo, lo + 1].
fn on_square(points: &[InputPoint], lo: f64) -> Vec<InputPoint> {
    points.iter().filter(|p| p.pos.x >= lo && p.pos.x <= lo + 1.0).copied().collect()
}

#[test]
fn obj_faces_take_the_colour_of_the_material_their_usemtl_names() {
    // Three squares side by side, x in [0, 1], [2, 3], [4, 5]: textured, plain blue (`Kd 0 0 1`,
    // no map), and textured again (back to the first material).
    let dir = tempfile::tempdir().expect("temp dir");
    let tex = Blocks { side: 16, n: 4, palette: 0 };
    tex.write(&dir.path().join("tex.png"));
    std::fs::write(dir.path().join("scene.mtl"), "newmtl painted\nmap_Kd tex.png\n\nnewmtl blue\nKd 0 0 1\n")
        .expect("write mtl");
    let squares: Vec<(String, String)> =
        (0..3).map(|k| obj_square(2.0 * k as f64, 4 * k + 1, k != 1)).collect();
    let mut text = "mtllib scene.mtl\n".to_string();
    for (v, _) in &squares {
        text += v;
    }
    for (material, (_, face)) in ["painted", "blue", "painted"].iter().zip(&squares) {
        text += &format!("usemtl {material}\n{face}");
    }
    let path = dir.path().join("scene.obj");
    std::fs::write(&path, text).expect("write obj");
    let points = read(&path, &ReadOptions { texel_density: 16.0, ..Default::default() });
    let on = |lo: f64| on_square(&points, lo);
    assert_eq!(points.len(), on(0.0).len() + on(2.0).len() + on(4.0).len(), "a sample off the squares");
    assert_all("Kd 0 0 1", &on(2.0), [0, 0, 255, 255]);
    for lo in [0.0, 4.0] {
        // OBJ's v runs up from the bottom of the image.
        let seen = assert_blocks("map_Kd", &on(lo), &tex, |p| [p.x - lo, 1.0 - p.y], |c| c);
        assert_eq!(seen, block_set(0..4, 0..4), "the square at x = {lo}");
    }
}

#[test]
fn two_obj_atlases_each_colour_their_own_faces() {
    // Two squares with the same texture coordinates, x in [0, 1] and [2, 3], materials with
    // different images (the blue channel tells them apart).
    let dir = tempfile::tempdir().expect("temp dir");
    let atlases = [Blocks { side: 16, n: 4, palette: 0 }, Blocks { side: 16, n: 4, palette: 1 }];
    atlases[0].write(&dir.path().join("atlas_0.png"));
    atlases[1].write(&dir.path().join("atlas_1.png"));
    std::fs::write(
        dir.path().join("atlases.mtl"),
        "newmtl first\nKd 1 1 1\nmap_Kd atlas_0.png\nnewmtl second\nKd 1 1 1\nmap_Kd atlas_1.png\n",
    )
    .expect("write mtl");
    let (v0, f0) = obj_square(0.0, 1, true);
    let (v1, f1) = obj_square(2.0, 5, true);
    let text = format!("mtllib atlases.mtl\n{v0}{v1}usemtl first\n{f0}usemtl second\n{f1}");
    let path = dir.path().join("atlases.obj");
    std::fs::write(&path, text).expect("write obj");
    let points = read(&path, &ReadOptions { texel_density: 16.0, ..Default::default() });
    for (k, lo) in [(0, 0.0), (1, 2.0)] {
        let on = on_square(&points, lo);
        let what = format!("atlas {k}");
        let seen = assert_blocks(&what, &on, &atlases[k], |p| [p.x - lo, 1.0 - p.y], |c| c);
        assert_eq!(seen, block_set(0..4, 0..4), "{what}");
    }
}

#[test]
fn a_ply_with_several_atlases_colours_each_face_from_its_texnumber() {
    // Agisoft's layout: one `TextureFile` per atlas, a `texnumber` per face. Two unit squares
    // side by side, the left one's faces on the red atlas, the right one's on the blue.
    let dir = tempfile::tempdir().expect("temp dir");
    for (name, rgb) in [("red.png", [200, 30, 30]), ("blue.png", [30, 30, 200])] {
        image::RgbaImage::from_pixel(16, 16, image::Rgba([rgb[0], rgb[1], rgb[2], 255]))
            .save(dir.path().join(name))
            .expect("png");
    }
    let ply = |third: u32| {
        format!(
            "ply\nformat ascii 1.0\ncomment TextureFile red.png\ncomment TextureFile blue.png\n\
             element vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
             element face 4\nproperty list uchar int vertex_indices\nproperty list uchar float texcoord\n\
             property int texnumber\nend_header\n\
             0 0 0\n1 0 0\n2 0 0\n0 1 0\n1 1 0\n2 1 0\n\
             3 0 1 4 6 0 0 1 0 1 1 0\n3 0 4 3 6 0 0 1 1 0 1 0\n\
             3 1 2 5 6 0 0 1 0 1 1 {third}\n3 1 5 4 6 0 0 1 1 0 1 1\n"
        )
    };
    let path = dir.path().join("atlases.ply");
    std::fs::write(&path, ply(1)).expect("write");
    let (points, report) = read_all(&path, &ReadOptions::default()).expect("two atlases");
    assert!(!report.warnings.iter().any(|w| w.contains("serves every face")), "{:?}", report.warnings);
    let (left, right): (Vec<&InputPoint>, Vec<&InputPoint>) = points.iter().partition(|p| p.pos.x < 1.0);
    assert!(left.len() > 100 && right.len() > 100, "{} and {} samples", left.len(), right.len());
    for (side, want) in [(&left, [200, 30, 30, 255]), (&right, [30, 30, 200, 255])] {
        for p in side.iter().filter(|p| (p.pos.x - 1.0).abs() > 0.05) {
            assert!(near(p.color, want), "{:?} at {:?}, want {want:?}", p.color, p.pos);
        }
    }
    // A face naming an atlas the file does not have is refused, with its row.
    std::fs::write(&path, ply(2)).expect("write");
    let e = read_all(&path, &ReadOptions::default()).expect_err("texnumber 2").to_string();
    assert!(e.contains("face") && e.contains("row 3") && e.contains("texnumber 2"), "{e}");
}
