//! `KHR_draco_mesh_compression`: a primitive whose attributes and indices are one Draco stream
//! in a buffer view, decoded with the `draco-core` crate (pure Rust, fuzzed, decoding what
//! Google's Draco library and its glTF exporters write). The primitive's glTF accessors then
//! hold no data of their own: they give the type, count and normalisation of what the stream
//! decodes to, and the extension maps each attribute name to the stream's attribute id.
//! Attributes the stream does not hold are read from their accessors, as the extension allows.

use super::{Buffers, GltfError, view_bytes};
use gltf::json::Value;

/// The extension's name.
pub(super) const EXTENSION: &str = "KHR_draco_mesh_compression";

/// The accessors whose data is in a Draco stream, with no buffer view of their own: those of
/// the attributes each Draco primitive's stream holds, and of its indices.
pub(super) fn stream_accessors(json: &gltf::json::Root) -> impl Iterator<Item = usize> + '_ {
    use gltf::json::validation::Checked;
    json.meshes.iter().flat_map(|m| &m.primitives).flat_map(|p| {
        let ext = p.extensions.as_ref().and_then(|e| e.others.get(EXTENSION));
        let held = ext.and_then(|e| e.get("attributes")).and_then(Value::as_object);
        let in_stream = move |k: &Checked<gltf::json::mesh::Semantic>| match (k, held) {
            (Checked::Valid(s), Some(held)) => held.contains_key(&s.to_string()),
            _ => false,
        };
        let attributes = p.attributes.iter().filter(move |(k, _)| in_stream(k)).map(|(_, a)| a.value());
        attributes.chain(p.indices.iter().filter(move |_| ext.is_some()).map(|a| a.value()))
    })
}

/// A primitive's Draco stream, decoded.
pub(super) struct Draco {
    mesh: draco_core::mesh::Mesh,
    /// glTF attribute name (`POSITION`, `TEXCOORD_0`…) → the stream's attribute id.
    attributes: Vec<(String, u32)>,
    /// Where it is, for errors: "mesh M primitive P (KHR_draco_mesh_compression)".
    place: String,
}

impl Draco {
    /// The primitive's Draco stream decoded, or `None` if it has none.
    pub(super) fn of(
        prim: &gltf::Primitive,
        doc: &gltf::Document,
        buffers: &Buffers,
        place: &str,
    ) -> Result<Option<Self>, GltfError> {
        let Some(ext) = prim.extension_value(EXTENSION) else { return Ok(None) };
        let place = format!("{place} ({EXTENSION})");
        let at = |msg: String| GltfError::At { place: place.clone(), msg };
        let index =
            ext.get("bufferView").and_then(Value::as_u64).ok_or_else(|| at("no bufferView".into()))?;
        let view = usize::try_from(index)
            .ok()
            .and_then(|i| doc.views().nth(i))
            .ok_or_else(|| at(format!("bufferView {index}: the file has {}", doc.views().len())))?;
        let bytes = view_bytes(&view, buffers).map_err(|e| at(format!("bufferView {index}: {e}")))?;
        let names =
            ext.get("attributes").and_then(Value::as_object).ok_or_else(|| at("no attributes".into()))?;
        let attributes = names
            .iter()
            .map(|(name, id)| match id.as_u64().and_then(|id| u32::try_from(id).ok()) {
                Some(id) => Ok((name.clone(), id)),
                None => Err(at(format!("attribute {name}: {id} is not an attribute id"))),
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut mesh = draco_core::mesh::Mesh::new();
        draco_core::mesh_decoder::MeshDecoder::new()
            .decode(&mut draco_core::decoder_buffer::DecoderBuffer::new(bytes), &mut mesh)
            .map_err(|e| at(format!("the Draco stream in bufferView {index} cannot be decoded: {e}")))?;
        for (name, id) in &attributes {
            if mesh.attribute_by_unique_id(*id).is_none() {
                return Err(at(format!("attribute {name}: the Draco stream has no attribute {id}")));
            }
        }
        Ok(Some(Self { mesh, attributes, place }))
    }

    /// The vertices the stream decodes to.
    pub(super) fn vertices(&self) -> usize {
        self.mesh.num_points()
    }

    /// The values of the attribute `name` as floats, normalised as its accessor `acc` says
    /// (`dims` components each), or `None` when the stream does not hold it.
    pub(super) fn floats(
        &self,
        name: &str,
        acc: &gltf::Accessor,
        dims: &[usize],
    ) -> Option<Result<Vec<f32>, GltfError>> {
        let id = self.attributes.iter().find(|(n, _)| n == name)?.1;
        let attribute = self.mesh.attribute_by_unique_id(id)?;
        let d = acc.dimensions().multiplicity();
        if !dims.contains(&d) {
            return Some(Err(self.at(format!("{name}: {d} components, expected {dims:?}"))));
        }
        if acc.count() != self.vertices() {
            return Some(Err(self.at(format!(
                "{name}: its accessor counts {} values, the Draco stream {}",
                acc.count(),
                self.vertices()
            ))));
        }
        let mut values = attribute.read_f32s(self.vertices(), d);
        if acc.normalized() {
            use gltf::accessor::DataType;
            let max = match acc.data_type() {
                DataType::U8 => 255.0,
                DataType::I8 => 127.0,
                DataType::U16 => 65535.0,
                DataType::I16 => 32767.0,
                DataType::U32 | DataType::F32 => 1.0,
            };
            values.iter_mut().for_each(|v| *v = (*v / max).max(-1.0));
        }
        Some(Ok(values))
    }

    /// The triangles' vertex indices, three by three.
    pub(super) fn indices(&self) -> Vec<u32> {
        self.mesh.faces().iter().flat_map(|f| f.map(|p| p.0)).collect()
    }

    fn at(&self, msg: String) -> GltfError {
        GltfError::At { place: self.place.clone(), msg }
    }
}
