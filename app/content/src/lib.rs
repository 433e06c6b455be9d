//! What both apps need of an exhibit on disk — the kiosk (`kiosk`) and the authoring tool
//! (`author`): stores opened through memory maps, exhibits (model, story, pose, ROI masks) and
//! their check, imports with their lock and persistent cache, media confined to their exhibit, offscreen
//! snapshots and their light, narration playback (kira), and the visit statistics' files. No
//! window, event loop or terminal here: those are each app's own.

pub mod audio;
pub mod check;
pub mod exhibit;
pub mod import;
pub mod media;
pub mod snapshot;
pub mod stats;

use anyhow::Context;
use kiosk_core::Store;
use std::path::Path;

/// A store opened through a read-only memory map.
pub type MappedStore = Store<memmap2::Mmap>;

/// Opens a store file by memory mapping it; errors name the file.
pub fn open_store(path: &Path) -> anyhow::Result<MappedStore> {
    let file = std::fs::File::open(path).with_context(|| format!("cannot open store {}", path.display()))?;
    // The mapping (`map_readonly`, the one `unsafe` here) is sound while no process truncates
    // or rewrites the file: a store is written under a temporary name and renamed, never
    // rewritten.
    let map = map_readonly(&file).with_context(|| format!("cannot map store {}", path.display()))?;
    Store::open(map).with_context(|| format!("{}", path.display()))
}

#[expect(
    unsafe_code,
    reason = "memory mapping is inherently unsafe if the file changes; stores are immutable once renamed into place"
)]
fn map_readonly(file: &std::fs::File) -> std::io::Result<memmap2::Mmap> {
    // SAFETY: see `open_store`.
    unsafe { memmap2::Mmap::map(file) }
}
