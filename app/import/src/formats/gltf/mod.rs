//! glTF 2.0 (`.gltf` with its buffers and images, or `.glb`) as a surface to sample
//! ([`crate::formats::surface`]): every triangle primitive of the default scene (or the first)
//! with its nodes' transforms, its base colour (`baseColorTexture` × `baseColorFactor` × `COLOR_0`,
//! the sampler's wrap modes, `KHR_texture_transform`; or `KHR_materials_pbrSpecularGlossiness`'s
//! `diffuseTexture` × `diffuseFactor` where a material has it) and normals; `KHR_mesh_quantization`'s
//! integer attributes are read as the accessors say (normalised or not). Compressed geometry is
//! decoded: Draco primitives ([`draco`]) and meshopt buffer views, EXT or KHR ([`meshopt`]).
//! The JSON is parsed by the `gltf` crate; accessors are read here, every range checked, so
//! that a corrupted file is an error naming the accessor.

use super::surface::{Material, Surface, Tri};
use super::texture::{Texture, TextureError, Wrap};
use crate::formats::ReadError;
use crate::source::{ReadOptions, ReadReport, Sink};
use glam::{DMat3, DMat4, DVec3, Vec3};
use std::path::Path;
use std::sync::Arc;

mod draco;
mod meshopt;

/// Why a glTF file cannot be read: where in the file (an accessor, a buffer, a node…) and what.
#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    /// The JSON or the GLB container is broken, or refers to what is not there.
    #[error("{0}")]
    Invalid(String),
    /// A part of the file is unusable.
    #[error("{place}: {msg}")]
    At {
        /// e.g. "accessor 3", "buffer 0 (scene.bin)", "mesh 2 primitive 0".
        place: String,
        /// What is wrong.
        msg: String,
    },
    /// The file needs an extension the importer does not read.
    #[error("the file requires the extension {extension}, which the importer does not read")]
    Unsupported {
        /// The extension's name.
        extension: String,
    },
}

/// Extensions a file may require that this reader handles (or may ignore safely).
const READ_EXTENSIONS: &[&str] = &[
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_materials_unlit",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_lights_punctual",
    draco::EXTENSION,
    meshopt::EXTENSIONS[0],
    meshopt::EXTENSIONS[1],
];

/// The textures decoded, by image and wrap modes.
type Decoded = Vec<((usize, [Wrap; 2]), Arc<Texture>)>;

/// An accessor's view bytes, the start, the stride and the element size.
type Layout<'b> = (&'b [u8], usize, usize, usize);

/// Most nodes visited (a corrupted file's node graph may loop).
const MAX_NODE_VISITS: usize = 1 << 20;

/// Reads a glTF or GLB file.
pub fn read<E>(
    path: &Path,
    opts: &ReadOptions,
    sink: &mut dyn Sink<Error = E>,
) -> Result<ReadReport, ReadError<E>> {
    let bytes = std::fs::read(path)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let surface = super::guarded(|| load(&bytes, dir), |m| GltfError::Invalid(m).into())?;
    let (surface, mut report) = surface;
    if surface.tris.is_empty() {
        return Err(GltfError::Invalid("the default scene has no triangles".into()).into());
    }
    report.rows = surface.positions.len() as u64;
    report.has_normals = !surface.normals.is_empty();
    report.has_colors = surface.materials.iter().any(|m| m.colored) || !surface.colors.is_empty();
    let params = opts.sample_params(surface.positions.iter().copied());
    surface.sample(&params, &mut report, sink)?;
    Ok(report)
}

/// The model's default scene as a surface.
fn load<E>(bytes: &[u8], dir: &Path) -> Result<(Surface, ReadReport), ReadError<E>> {
    // The crate subtracts the 12-byte header from the GLB's declared length unchecked.
    if let Some(header) = bytes.strip_prefix(b"glTF") {
        let declared = header.get(4..8).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        match declared {
            Some(n) if u64::from(n) > bytes.len() as u64 => {
                return Err(GltfError::Invalid(format!(
                    "GLB header: the file should be {n} bytes long and has {} (cut short?)",
                    bytes.len()
                ))
                .into());
            }
            Some(n) if n >= 12 => {}
            Some(n) => {
                return Err(GltfError::Invalid(format!(
                    "GLB header: length {n} is shorter than the 12-byte header"
                ))
                .into());
            }
            None => return Err(GltfError::Invalid("GLB header: truncated".into()).into()),
        }
    }
    let gltf = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| GltfError::Invalid(format!("not a readable glTF: {e}")))?;
    let doc = &gltf.document;
    let json = doc.as_json();
    for ext in &json.extensions_required {
        if !READ_EXTENSIONS.contains(&ext.as_str()) {
            return Err(GltfError::Unsupported { extension: ext.clone() }.into());
        }
    }
    // The crate's validation looks a POSITION accessor up before checking its index: out of
    // range, it would panic.
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let name = |k: &gltf::json::validation::Checked<gltf::json::mesh::Semantic>| match k {
                gltf::json::validation::Checked::Valid(s) => format!("attribute {}", s.to_string()),
                gltf::json::validation::Checked::Invalid => "an unknown attribute".to_string(),
            };
            let indices = prim.attributes.iter().map(|(k, v)| (name(k), v.value()));
            for (what, i) in indices.chain(prim.indices.map(|v| ("indices".to_string(), v.value()))) {
                if i >= json.accessors.len() {
                    return Err(GltfError::Invalid(format!(
                        "mesh {m} primitive {p}: {what} names accessor {i}; the file has {}",
                        json.accessors.len()
                    ))
                    .into());
                }
            }
        }
    }
    // The crate's own validation, but for the required extensions it does not know and we read.
    let mut problems = Vec::new();
    gltf::json::validation::Validate::validate(json, json, gltf::json::Path::new, &mut |path, err| {
        problems.push((path().to_string(), err));
    });
    let draco_accessors: Vec<String> =
        draco::stream_accessors(json).map(|a| format!("accessors[{a}].bufferView")).collect();
    problems.retain(|(path, err)| {
        use gltf::json::validation::Error;
        let known_extension = path.starts_with("extensionsRequired") && *err == Error::Unsupported;
        let in_draco_stream = *err == Error::Missing && draco_accessors.contains(path);
        !(known_extension || in_draco_stream)
    });
    if let Some((path, err)) = problems.first() {
        return Err(GltfError::Invalid(format!("{path}: {err}")).into());
    }
    let mut report = ReadReport::default();
    let data = load_buffers(doc, gltf.blob.as_deref(), dir)?;
    let views = meshopt::decode_views(doc, &data)?;
    let buffers = Buffers { data, views };
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| GltfError::Invalid("the file has no scene".into()))?;
    let mut out = Surface::default();
    let mut materials: Vec<Option<u32>> = vec![None; doc.materials().len()];
    let mut default_material = None;
    let mut textures: Decoded = Vec::new();
    let mut any_normals = false;
    let mut any_colors = false;
    let mut normals: Vec<Vec3> = Vec::new();
    let mut colors: Vec<[f32; 4]> = Vec::new();
    let mut decoded: std::collections::HashMap<(usize, usize), Option<Arc<draco::Draco>>> =
        Default::default();
    let mut stack: Vec<(gltf::Node, DMat4)> = scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
    let mut visits = 0;
    while let Some((node, parent)) = stack.pop() {
        visits += 1;
        if visits > MAX_NODE_VISITS {
            return Err(GltfError::Invalid(format!(
                "more than {MAX_NODE_VISITS} node visits: the node graph loops"
            ))
            .into());
        }
        let local = DMat4::from_cols_array_2d(&node.transform().matrix().map(|c| c.map(f64::from)));
        let world = parent * local;
        if !world.is_finite() {
            return Err(GltfError::At {
                place: format!("node {}", node.index()),
                msg: "non-finite transform".into(),
            }
            .into());
        }
        stack.extend(node.children().map(|c| (c, world)));
        let Some(mesh) = node.mesh() else { continue };
        let normal_m = DMat3::from_mat4(world).inverse().transpose();
        let flip = DMat3::from_mat4(world).determinant() < 0.0;
        for prim in mesh.primitives() {
            let place = format!("mesh {} primitive {}", mesh.index(), prim.index());
            let at = |msg: String| GltfError::At { place: place.clone(), msg };
            let mode = prim.mode();
            use gltf::mesh::Mode;
            if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
                report.warnings.push(format!("{place}: {mode:?} skipped (only triangles are sampled)"));
                continue;
            }
            let pos_acc = prim.get(&gltf::Semantic::Positions).ok_or_else(|| at("no POSITION".into()))?;
            // Decoded once per primitive, however many nodes show its mesh.
            let draco = match decoded.entry((mesh.index(), prim.index())) {
                std::collections::hash_map::Entry::Occupied(e) => e.get().clone(),
                std::collections::hash_map::Entry::Vacant(e) => {
                    e.insert(draco::Draco::of(&prim, doc, &buffers, &place)?.map(Arc::new)).clone()
                }
            };
            // An attribute's values: from the Draco stream when it holds them, else its accessor.
            let floats = |semantic: gltf::Semantic, acc: &gltf::Accessor, dims: &[usize]| match draco
                .as_ref()
                .and_then(|d| d.floats(&semantic.to_string(), acc, dims))
            {
                Some(values) => values,
                None => read_floats(acc, &buffers, dims),
            };
            let pos = floats(gltf::Semantic::Positions, &pos_acc, &[3])?;
            let n = pos.len() / 3;
            let base = out.positions.len();
            if base + n > u32::MAX as usize {
                return Err(at("more than 4 G vertices".into()).into());
            }
            for p in pos.chunks_exact(3) {
                let q = world.transform_point3(DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])));
                if !q.is_finite() {
                    return Err(GltfError::At {
                        place: format!("accessor {}", pos_acc.index()),
                        msg: "non-finite position".into(),
                    }
                    .into());
                }
                out.positions.push(q);
            }
            // Normals and colours: kept for every vertex once one primitive has them.
            normals.resize(base, Vec3::ZERO);
            if let Some(acc) = prim.get(&gltf::Semantic::Normals) {
                let v = floats(gltf::Semantic::Normals, &acc, &[3])?;
                if v.len() / 3 != n {
                    return Err(at(format!("NORMAL has {} values, POSITION {n}", v.len() / 3)).into());
                }
                any_normals = true;
                normals.extend(v.chunks_exact(3).map(|c| {
                    (normal_m * DVec3::new(f64::from(c[0]), f64::from(c[1]), f64::from(c[2])))
                        .try_normalize()
                        .map_or(Vec3::ZERO, |v| v.as_vec3())
                }));
            } else {
                normals.resize(base + n, Vec3::ZERO);
            }
            colors.resize(base, [1.0; 4]);
            if let Some(acc) = prim.get(&gltf::Semantic::Colors(0)) {
                let v = floats(gltf::Semantic::Colors(0), &acc, &[3, 4])?;
                let dims = acc.dimensions().multiplicity();
                if v.len() / dims != n {
                    return Err(at(format!("COLOR_0 has {} values, POSITION {n}", v.len() / dims)).into());
                }
                any_colors = true;
                colors.extend(
                    v.chunks_exact(dims).map(|c| [c[0], c[1], c[2], if dims == 4 { c[3] } else { 1.0 }]),
                );
            } else {
                colors.resize(base + n, [1.0; 4]);
            }
            // The material, its texture and the texture coordinates it reads.
            let gm = prim.material();
            let material = match gm.index() {
                Some(i) => match materials[i] {
                    Some(m) => m,
                    None => {
                        let m = material(&gm, doc, &buffers, dir, &mut textures)?;
                        out.materials.push(m);
                        let k = (out.materials.len() - 1) as u32;
                        materials[i] = Some(k);
                        k
                    }
                },
                None => *default_material.get_or_insert_with(|| {
                    out.materials.push(Material { factor: [1.0; 4], texture: None, colored: false });
                    (out.materials.len() - 1) as u32
                }),
            };
            let info = base_colour(&gm).1;
            let uvs: Vec<[f32; 2]> = match &info {
                Some(info) => {
                    let transform = info.texture_transform();
                    let set = transform.as_ref().and_then(|t| t.tex_coord()).unwrap_or(info.tex_coord());
                    match prim.get(&gltf::Semantic::TexCoords(set)) {
                        Some(acc) => {
                            let v = floats(gltf::Semantic::TexCoords(set), &acc, &[2])?;
                            if v.len() / 2 != n {
                                return Err(at(format!(
                                    "TEXCOORD_{set} has {} values, POSITION {n}",
                                    v.len() / 2
                                ))
                                .into());
                            }
                            let (o, r, s) = transform
                                .map_or(([0.0; 2], 0.0, [1.0; 2]), |t| (t.offset(), t.rotation(), t.scale()));
                            let (sin, cos) = r.sin_cos();
                            v.chunks_exact(2)
                                .map(|c| {
                                    let (u, v) = (c[0] * s[0], c[1] * s[1]);
                                    [cos * u + sin * v + o[0], -sin * u + cos * v + o[1]]
                                })
                                .collect()
                        }
                        None => {
                            report
                                .warnings
                                .push(format!("{place}: textured but without TEXCOORD_{set}: untextured"));
                            Vec::new()
                        }
                    }
                }
                None => Vec::new(),
            };
            let textured = !uvs.is_empty();
            let mat = if textured || info.is_none() {
                material
            } else {
                // A textured material on a primitive without coordinates: its factor alone.
                let mut m = out.materials[material as usize].clone();
                m.texture = None;
                out.materials.push(m);
                (out.materials.len() - 1) as u32
            };
            let indices: Vec<u32> = match (&draco, prim.indices()) {
                (Some(d), _) => d.indices(),
                (None, Some(acc)) => read_indices(&acc, &buffers)?,
                (None, None) => (0..n as u32).collect(),
            };
            if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
                return Err(at(format!("index {bad} out of range: {n} vertices")).into());
            }
            let tri = |a: u32, b: u32, c: u32| {
                let (b, c) = if flip { (c, b) } else { (b, c) };
                let uv = if textured { [a, b, c].map(|i| uvs[i as usize]) } else { [[0.0; 2]; 3] };
                Tri { v: [a, b, c].map(|i| base as u32 + i), uv, material: mat }
            };
            // A Draco stream's faces are a triangle list, whatever mode the primitive names.
            let mode = if draco.is_some() { Mode::Triangles } else { mode };
            match mode {
                Mode::Triangles => out.tris.extend(indices.chunks_exact(3).map(|t| tri(t[0], t[1], t[2]))),
                Mode::TriangleStrip => out.tris.extend(
                    indices
                        .windows(3)
                        .enumerate()
                        .map(|(k, t)| if k % 2 == 0 { tri(t[0], t[1], t[2]) } else { tri(t[1], t[0], t[2]) }),
                ),
                _ => out.tris.extend((2..indices.len()).map(|k| tri(indices[0], indices[k - 1], indices[k]))),
            }
        }
    }
    if any_normals {
        normals.resize(out.positions.len(), Vec3::ZERO);
        out.normals = normals;
    }
    if any_colors {
        colors.resize(out.positions.len(), [1.0; 4]);
        out.colors = colors;
    }
    // The files beside it that it names (buffers and images; embedded ones are in the scan). Read
    // from the JSON: the crate's `Image::source` panics on an image without a source, which a
    // file may hold unused.
    let uris = json.buffers.iter().filter_map(|b| b.uri.as_deref());
    let uris = uris.chain(json.images.iter().filter_map(|i| i.uri.as_deref()));
    report.inputs.extend(uris.filter(|u| !u.starts_with("data:")).map(|u| dir.join(percent_decode(u))));
    Ok((out, report))
}

/// A material's colour factor and texture: `KHR_materials_pbrSpecularGlossiness`'s diffuse ones
/// where the material has that extension (older Sketchfab and Substance exports; the extension
/// says its clients prefer it to the metallic-roughness fallback), else the base colour's.
fn base_colour<'a>(gm: &gltf::Material<'a>) -> ([f32; 4], Option<gltf::texture::Info<'a>>) {
    match gm.pbr_specular_glossiness() {
        Some(sg) => (sg.diffuse_factor(), sg.diffuse_texture()),
        None => {
            let pbr = gm.pbr_metallic_roughness();
            (pbr.base_color_factor(), pbr.base_color_texture())
        }
    }
}

/// A glTF material as the sampler uses it (its texture decoded once per image and wrap modes).
fn material<E>(
    gm: &gltf::Material,
    doc: &gltf::Document,
    buffers: &Buffers,
    dir: &Path,
    textures: &mut Decoded,
) -> Result<Material, ReadError<E>> {
    let (factor, info) = base_colour(gm);
    if !factor.iter().all(|f| f.is_finite()) {
        return Err(GltfError::At {
            place: format!("material {}", gm.index().unwrap_or(0)),
            msg: "non-finite baseColorFactor (or diffuseFactor)".into(),
        }
        .into());
    }
    let texture = match info {
        None => None,
        Some(info) => {
            let tex = info.texture();
            let sampler = tex.sampler();
            let wrap = [sampler.wrap_s(), sampler.wrap_t()].map(|w| match w {
                gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
                gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
                gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
            });
            let image = tex.source();
            let key = (image.index(), wrap);
            if let Some((_, t)) = textures.iter().find(|(k, _)| *k == key) {
                Some(t.clone())
            } else {
                let decoded = match textures.iter().find(|((i, _), _)| *i == image.index()) {
                    Some((_, t)) => Texture { wrap, ..(**t).clone() },
                    None => Texture { wrap, ..image_texture(&image, doc, buffers, dir)? },
                };
                let t = Arc::new(decoded);
                textures.push((key, t.clone()));
                Some(t)
            }
        }
    };
    Ok(Material { factor, texture, colored: true })
}

/// Decodes an image of the file (in a buffer view, a data URI or a file beside it).
fn image_texture<E>(
    image: &gltf::Image,
    doc: &gltf::Document,
    buffers: &Buffers,
    dir: &Path,
) -> Result<Texture, ReadError<E>> {
    let name = format!("image {}", image.index());
    // The crate's `source` unwraps what the file may lack: checked first.
    let json = &doc.as_json().images[image.index()];
    let views = doc.as_json().buffer_views.len();
    let missing = match (&json.buffer_view, &json.uri) {
        (Some(v), _) if v.value() >= views => {
            Some(format!("its buffer view {} is not among the file's {views}", v.value()))
        }
        (Some(_), _) if json.mime_type.is_none() => Some("it has a buffer view but no mimeType".to_string()),
        (None, None) => Some("it has neither a uri nor a buffer view".to_string()),
        _ => None,
    };
    if let Some(msg) = missing {
        return Err(TextureError { source_name: name, msg }.into());
    }
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let bytes = view_bytes(&view, buffers).map_err(|msg| TextureError {
                source_name: format!("{name} (buffer view {})", view.index()),
                msg,
            })?;
            Ok(Texture::decode(&format!("{name} (buffer view {})", view.index()), bytes)?)
        }
        gltf::image::Source::Uri { uri, .. } => {
            if let Some(data) = uri.strip_prefix("data:") {
                let bytes = data_uri(data)
                    .map_err(|msg| TextureError { source_name: format!("{name} (data URI)"), msg })?;
                Ok(Texture::decode(&format!("{name} (data URI)"), &bytes)?)
            } else {
                Ok(Texture::load(&dir.join(percent_decode(uri)))?)
            }
        }
    }
}

/// Every buffer's bytes: the GLB's binary chunk, data URIs, files beside the model.
fn load_buffers<E>(
    doc: &gltf::Document,
    blob: Option<&[u8]>,
    dir: &Path,
) -> Result<Vec<Vec<u8>>, ReadError<E>> {
    doc.buffers()
        .map(|b| {
            let place = |what: &str| format!("buffer {}{what}", b.index());
            if meshopt::is_fallback(&b) {
                // Its views are compressed elsewhere (a view of it that is not fails as out of
                // range, naming the view).
                return Ok(Vec::new());
            }
            let bytes = match b.source() {
                gltf::buffer::Source::Bin => blob.map(<[u8]>::to_vec).ok_or_else(|| GltfError::At {
                    place: place(""),
                    msg: "refers to the GLB binary chunk, which the file lacks".into(),
                })?,
                gltf::buffer::Source::Uri(uri) => {
                    if let Some(data) = uri.strip_prefix("data:") {
                        data_uri(data).map_err(|msg| GltfError::At { place: place(" (data URI)"), msg })?
                    } else {
                        let path = dir.join(percent_decode(uri));
                        std::fs::read(&path).map_err(|e| GltfError::At {
                            place: place(&format!(" ({})", path.display())),
                            msg: if e.kind() == std::io::ErrorKind::NotFound {
                                "file not found".into()
                            } else {
                                format!("cannot read: {e}")
                            },
                        })?
                    }
                }
            };
            if bytes.len() < b.length() {
                return Err(GltfError::At {
                    place: place(""),
                    msg: format!("{} bytes, but the file says {}", bytes.len(), b.length()),
                }
                .into());
            }
            Ok(bytes)
        })
        .collect()
}

/// The file's buffers, and its compressed buffer views decoded.
struct Buffers {
    /// Each buffer's bytes (none for a meshopt fallback buffer).
    data: Vec<Vec<u8>>,
    /// Each buffer view's bytes, where it is meshopt-compressed.
    views: Vec<Option<Vec<u8>>>,
}

/// The bytes of a buffer view (decoded if it is compressed), range checked.
fn view_bytes<'b>(view: &gltf::buffer::View, buffers: &'b Buffers) -> Result<&'b [u8], String> {
    if let Some(Some(decoded)) = buffers.views.get(view.index()) {
        return Ok(decoded);
    }
    let buf = buffers.data.get(view.buffer().index()).ok_or("no such buffer")?;
    let end = view.offset().checked_add(view.length()).ok_or("range overflows")?;
    buf.get(view.offset()..end)
        .ok_or_else(|| format!("bytes {}..{end} are beyond the buffer's {}", view.offset(), buf.len()))
}

/// The bytes of a base64 data URI (after `data:`).
fn data_uri(data: &str) -> Result<Vec<u8>, String> {
    use base64::Engine;
    let (_, payload) = data.split_once(";base64,").ok_or("a data URI that is not base64")?;
    base64::engine::general_purpose::STANDARD.decode(payload.trim()).map_err(|e| format!("bad base64: {e}"))
}

/// A relative URI's `%XX` escapes decoded (a file name with spaces is `my%20texture.png`).
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && let Some(v) = b
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The raw bytes of an accessor's elements: the view's bytes, the start, the stride and the
/// element size (range checked); `None` for an accessor without a view (all zeros).
fn accessor_layout<'b>(acc: &gltf::Accessor, buffers: &'b Buffers) -> Result<Option<Layout<'b>>, GltfError> {
    let at = |msg: String| GltfError::At { place: format!("accessor {}", acc.index()), msg };
    if acc.sparse().is_some() {
        return Err(at("sparse accessors are not supported".into()));
    }
    let elem = acc.size();
    let Some(view) = acc.view() else {
        if acc.count() > 1 << 28 {
            return Err(at(format!("{} elements without data", acc.count())));
        }
        return Ok(None);
    };
    let bytes = view_bytes(&view, buffers).map_err(|m| at(format!("buffer view {}: {m}", view.index())))?;
    let stride = view.stride().unwrap_or(elem).max(elem);
    let count = acc.count();
    let need = if count == 0 {
        Some(0)
    } else {
        (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(elem))
            .and_then(|x| x.checked_add(acc.offset()))
    };
    match need {
        Some(n) if n <= bytes.len() => Ok(Some((bytes, acc.offset(), stride, elem))),
        _ => Err(at(format!(
            "{count} elements of {elem} bytes (stride {stride}) from byte {} do not fit in buffer view {} ({} bytes)",
            acc.offset(),
            view.index(),
            bytes.len()
        ))),
    }
}

/// An accessor's values as floats (integers normalised where the accessor says so), checked
/// to have one of `dims` components per element.
fn read_floats(acc: &gltf::Accessor, buffers: &Buffers, dims: &[usize]) -> Result<Vec<f32>, GltfError> {
    use gltf::accessor::DataType;
    let d = acc.dimensions().multiplicity();
    if !dims.contains(&d) {
        return Err(GltfError::At {
            place: format!("accessor {}", acc.index()),
            msg: format!("{d} components, expected {dims:?}"),
        });
    }
    let Some((bytes, start, stride, _)) = accessor_layout(acc, buffers)? else {
        return Ok(vec![0.0; acc.count() * d]);
    };
    let (ty, norm) = (acc.data_type(), acc.normalized());
    let size = ty.size();
    let mut out = Vec::with_capacity(acc.count() * d);
    for e in 0..acc.count() {
        for c in 0..d {
            let at = start + e * stride + c * size;
            let b = &bytes[at..at + size];
            let v = match ty {
                DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                DataType::U8 => f32::from(b[0]) / if norm { 255.0 } else { 1.0 },
                DataType::I8 => {
                    let x = f32::from(b[0] as i8);
                    if norm { (x / 127.0).max(-1.0) } else { x }
                }
                DataType::U16 => {
                    f32::from(u16::from_le_bytes([b[0], b[1]])) / if norm { 65535.0 } else { 1.0 }
                }
                DataType::I16 => {
                    let x = f32::from(i16::from_le_bytes([b[0], b[1]]));
                    if norm { (x / 32767.0).max(-1.0) } else { x }
                }
                DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
            };
            out.push(v);
        }
    }
    Ok(out)
}

/// An index accessor's values.
fn read_indices(acc: &gltf::Accessor, buffers: &Buffers) -> Result<Vec<u32>, GltfError> {
    use gltf::accessor::DataType;
    let at = |msg: String| GltfError::At { place: format!("accessor {} (indices)", acc.index()), msg };
    if acc.dimensions().multiplicity() != 1 {
        return Err(at("indices must be scalars".into()));
    }
    let Some((bytes, start, stride, _)) = accessor_layout(acc, buffers)? else {
        return Ok(vec![0; acc.count()]);
    };
    let ty = acc.data_type();
    (0..acc.count())
        .map(|e| {
            let i = start + e * stride;
            let b = &bytes[i..i + ty.size()];
            match ty {
                DataType::U8 => Ok(u32::from(b[0])),
                DataType::U16 => Ok(u32::from(u16::from_le_bytes([b[0], b[1]]))),
                DataType::U32 => Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                other => Err(at(format!("{other:?} indices (unsigned integers only)"))),
            }
        })
        .collect()
}
