//! `EXT_meshopt_compression` (what `gltfpack -c` and `-cc` write): a buffer view's bytes are
//! a meshoptimizer stream elsewhere in the file, decoded with the `meshoptimizer-rs` crate (a
//! pure-Rust port of meshoptimizer's codecs, byte-identical to them) into the view's bytes
//! before any accessor reads them. The buffer the views formally point into is then often a
//! "fallback" with no data of its own.

use super::GltfError;
use gltf::json::Value;
use meshoptimizer_rs::codec::{Filter, Mode, decode_buffer_view};
use meshoptimizer_rs::{Limits, Workspace};

/// The extension's name.
pub(super) const EXTENSION: &str = "EXT_meshopt_compression";

/// Whether `buffer` is a fallback that holds no data: every view of it is compressed.
pub(super) fn is_fallback(buffer: &gltf::Buffer) -> bool {
    buffer.extension_value(EXTENSION).and_then(|e| e.get("fallback")).and_then(Value::as_bool) == Some(true)
}

/// Each buffer view's bytes decoded where the view is compressed (`None` where it is not),
/// from the file's `buffers`.
pub(super) fn decode_views(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
) -> Result<Vec<Option<Vec<u8>>>, GltfError> {
    doc.views()
        .map(|view| {
            let Some(ext) = view.extension_value(EXTENSION) else { return Ok(None) };
            let at = |msg: String| GltfError::At {
                place: format!("buffer view {} ({EXTENSION})", view.index()),
                msg,
            };
            let number =
                |key: &str| ext.get(key).and_then(Value::as_u64).and_then(|v| usize::try_from(v).ok());
            let required = |key: &str| number(key).ok_or_else(|| at(format!("no {key}")));
            let (buffer, length) = (required("buffer")?, required("byteLength")?);
            let (stride, count) = (required("byteStride")?, required("count")?);
            let offset = number("byteOffset").unwrap_or(0);
            let name = |key: &str, default: Option<&'static str>| {
                ext.get(key).and_then(Value::as_str).or(default).ok_or_else(|| at(format!("no {key}")))
            };
            let (mode, filter) = (name("mode", None)?, name("filter", Some("NONE"))?);
            let mode = Mode::parse(mode).map_err(|_| at(format!("unknown mode {mode}")))?;
            let filter = Filter::parse(filter).map_err(|_| at(format!("unknown filter {filter}")))?;
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
            let bytes = decode_buffer_view(mode, filter, count, stride, source, &mut Workspace::new(limits))
                .map_err(|e| at(format!("the stream cannot be decoded: {e}")))?;
            Ok(Some(bytes))
        })
        .collect()
}
