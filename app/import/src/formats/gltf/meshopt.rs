//! `EXT_meshopt_compression` (what `gltfpack -c` and `-cc` write) and its Khronos successor
//! `KHR_meshopt_compression` (`gltfpack -ce khr`: the same layout, plus version 1 of the vertex
//! codec and the `COLOR` filter): a buffer view's bytes are a meshoptimizer stream elsewhere in
//! the file, decoded with the `meshoptimizer-rs` crate (a pure-Rust port of meshoptimizer's
//! codecs, byte-identical to them) into the view's bytes before any accessor reads them. The
//! buffer the views formally point into is then often a "fallback" with no data of its own.

use super::GltfError;
use gltf::json::Value;
use meshoptimizer_rs::codec::{self, Filter, Mode, decode_buffer_view};
use meshoptimizer_rs::{Limits, Workspace};

/// The extensions' names: EXT, then KHR.
pub(super) const EXTENSIONS: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// The name and object of whichever of the two extensions `of` finds.
fn extension<'v>(of: impl Fn(&str) -> Option<&'v Value>) -> Option<(&'static str, &'v Value)> {
    EXTENSIONS.iter().find_map(|&name| of(name).map(|v| (name, v)))
}

/// Whether `buffer` is a fallback that holds no data: every view of it is compressed.
pub(super) fn is_fallback(buffer: &gltf::Buffer) -> bool {
    let ext = extension(|name| buffer.extension_value(name));
    ext.and_then(|(_, e)| e.get("fallback")).and_then(Value::as_bool) == Some(true)
}

/// Each buffer view's bytes decoded where the view is compressed (`None` where it is not),
/// from the file's `buffers`.
pub(super) fn decode_views(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
) -> Result<Vec<Option<Vec<u8>>>, GltfError> {
    doc.views()
        .map(|view| {
            let Some((name, ext)) = extension(|name| view.extension_value(name)) else { return Ok(None) };
            let at =
                |msg: String| GltfError::At { place: format!("buffer view {} ({name})", view.index()), msg };
            let number =
                |key: &str| ext.get(key).and_then(Value::as_u64).and_then(|v| usize::try_from(v).ok());
            let required = |key: &str| number(key).ok_or_else(|| at(format!("no {key}")));
            let (buffer, length) = (required("buffer")?, required("byteLength")?);
            let (stride, count) = (required("byteStride")?, required("count")?);
            let offset = number("byteOffset").unwrap_or(0);
            let text = |key: &str, default: Option<&'static str>| {
                ext.get(key).and_then(Value::as_str).or(default).ok_or_else(|| at(format!("no {key}")))
            };
            let (mode_name, filter_name) = (text("mode", None)?, text("filter", Some("NONE"))?);
            let mode = Mode::parse(mode_name).map_err(|_| at(format!("unknown mode {mode_name}")))?;
            let source =
                buffers.get(buffer).and_then(|b| b.get(offset..offset.checked_add(length)?)).ok_or_else(
                    || at(format!("bytes {offset}..+{length} of buffer {buffer} are not in the file")),
                )?;
            // What it decodes to is the view's bytes: a count or stride that disagrees with the
            // view is refused before anything is allocated. The crate bounds what one call may
            // allocate (1 GiB by default); a sound stream of more than 16 MiB may decode to up to
            // 64 times its size (meshopt compresses a few times at most).
            if count.checked_mul(stride) != Some(view.length()) {
                return Err(at(format!("{count} × {stride} bytes, the view has {}", view.length())));
            }
            let limits = Limits { max_bytes: (64 * length).max(1 << 30), ..Limits::default() };
            let ws = &mut Workspace::new(limits);
            let unknown = || at(format!("unknown filter {filter_name}"));
            let decoded = if name == EXTENSIONS[0] {
                let filter = Filter::parse(filter_name).map_err(|_| unknown())?;
                decode_buffer_view(mode, filter, count, stride, source, ws)
            } else {
                khr(mode, filter_name, count, stride, source, ws).ok_or_else(unknown)?
            };
            let bytes = decoded.map_err(|e| at(format!("the stream cannot be decoded: {e}")))?;
            Ok(Some(bytes))
        })
        .collect()
}

/// A `KHR_meshopt_compression` view decoded: the codecs' own decoders (which read both
/// versions of the vertex codec), then its filter; `None` for a filter it does not name.
fn khr(
    mode: Mode,
    filter: &str,
    count: usize,
    stride: usize,
    source: &[u8],
    ws: &mut Workspace,
) -> Option<Result<Vec<u8>, meshoptimizer_rs::Error>> {
    type FilterFn = fn(&mut [u8], usize, usize, &mut Workspace) -> Result<(), meshoptimizer_rs::Error>;
    let apply: Option<FilterFn> = match filter {
        "NONE" => None,
        "OCTAHEDRAL" => Some(codec::decode_filter_oct),
        "QUATERNION" => Some(codec::decode_filter_quat),
        "EXPONENTIAL" => Some(codec::decode_filter_exp),
        "COLOR" => Some(codec::decode_filter_color),
        _ => return None,
    };
    let mut decode = || {
        let mut bytes = match mode {
            Mode::Attributes => codec::decode_vertex_buffer(count, stride, source, ws)?,
            Mode::Triangles => codec::decode_index_buffer(count, stride, source, ws)?,
            Mode::Indices => codec::decode_index_sequence(count, stride, source, ws)?,
        };
        if let Some(apply) = apply {
            apply(&mut bytes, count, stride, ws)?;
        }
        Ok(bytes)
    };
    Some(decode())
}
