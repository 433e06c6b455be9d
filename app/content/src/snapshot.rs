//! `kiosk snapshot`: one frame of a model, offscreen, to an image; the thumbnails and live view of
//! the authoring tool; and the light a view is drawn in.

use crate::MappedStore;
use anyhow::Context;
use kiosk_core::camera::Camera;
use kiosk_core::light::Light;
use kiosk_core::{Cut, CutParams};
use kiosk_render::{Gpu, OFFSCREEN_FORMAT, RenderSettings, Renderer};

/// Renders `camera`'s view of `store` at `size` with a converged cut of `tolerance_px`; an
/// error if a node it would draw is corrupted.
pub fn snapshot(
    gpu: &Gpu,
    renderer: &mut Renderer,
    store: &MappedStore,
    camera: &Camera,
    size: (u32, u32),
    tolerance_px: f32,
    settings: &RenderSettings,
) -> anyhow::Result<image::RgbaImage> {
    let view = camera.view_params(store, size).context("degenerate view")?;
    let mut cut = Cut::root(store);
    cut.update(store, &view, &CutParams { tolerance_px, max_changes: usize::MAX, ..CutParams::default() });
    let nodes = cut.visible_nodes(store, &view);
    let (image, _) = renderer.render_image(gpu, store, &nodes, camera, size, settings)?;
    let corrupt: Vec<_> = renderer.corrupt_nodes().iter().filter(|(id, _)| nodes.contains(id)).collect();
    if let Some((id, why)) = corrupt.first() {
        return Err(CorruptView { why: why.to_string(), node: **id, count: corrupt.len() }.into());
    }
    Ok(image)
}

/// A view that would draw nodes failing their check (a damaged store).
#[derive(Debug, thiserror::Error)]
#[error("{why} ({count} node(s) of this view fail their check, node {node} first)")]
pub struct CorruptView {
    /// What is wrong with the first.
    pub why: String,
    /// The first node failing.
    pub node: kiosk_core::NodeId,
    /// How many of the view's nodes fail.
    pub count: usize,
}

/// A headless GPU and a renderer for offscreen images.
pub fn offscreen() -> anyhow::Result<(Gpu, Renderer)> {
    let gpu = Gpu::headless()?;
    let renderer = Renderer::new(&gpu, OFFSCREEN_FORMAT);
    gpu.check()?;
    Ok((gpu, renderer))
}

/// The renderer's settings with a light of the core.
pub fn lit(settings: RenderSettings, light: Light) -> RenderSettings {
    RenderSettings { light_dir: light.dir.as_vec3(), light_mix: light.mix as f32, ..settings }
}

/// The light a visit starts with, given its start view (`initial_camera`): the start light of
/// [`kiosk_core::light`], the headlight dominating.
pub fn start_light(start_view: &Camera) -> Light {
    Light { dir: kiosk_core::light::start_dir(start_view), mix: kiosk_core::light::DEFAULT_MIX }
}

/// The light of a node's view: its stored light (the user light dominating), else `otherwise`.
pub fn node_light(n: &kiosk_core::graph::Node, otherwise: Light) -> Light {
    match n.light {
        Some(dir) => Light { dir, mix: kiosk_core::light::ACTIVE_MIX },
        None => otherwise,
    }
}
