//! `kiosk snapshot`: one frame of a model, offscreen, to a PNG; the thumbnails and live view of
//! the authoring tool; and the light a view is drawn in.

use crate::MappedStore;
use anyhow::Context;
use glam::DVec3;
use kiosk_core::camera::{Camera, orthonormal_up};
use kiosk_core::light::Light;
use kiosk_core::{Cut, CutParams};
use kiosk_render::{Gpu, OFFSCREEN_FORMAT, RenderSettings, Renderer};

/// Parses `eye_x,eye_y,eye_z,target_x,target_y,target_z,up_x,up_y,up_z,fov_degrees`.
pub fn parse_view(s: &str) -> anyhow::Result<Camera> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().with_context(|| format!("'{x}' is not a number")))
        .collect::<anyhow::Result<_>>()?;
    anyhow::ensure!(
        v.len() == 10,
        "--view needs 10 numbers: eye(3), target(3), up(3), fov in degrees; got {}",
        v.len()
    );
    anyhow::ensure!(v.iter().all(|x| x.is_finite()), "--view numbers must be finite");
    let eye = DVec3::new(v[0], v[1], v[2]);
    let target = DVec3::new(v[3], v[4], v[5]);
    anyhow::ensure!(eye != target, "--view: eye and target coincide");
    anyhow::ensure!(v[9] > 0.0 && v[9] < 180.0, "--view: field of view must be in (0, 180) degrees");
    let mut c = Camera { eye, target, up: DVec3::new(v[6], v[7], v[8]), fov_y: v[9].to_radians() };
    c.up = orthonormal_up(c.forward(), c.up, DVec3::Y);
    Ok(c)
}

/// Parses `WxH`.
pub fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let (w, h) = s.split_once(['x', 'X']).with_context(|| format!("size '{s}' is not WxH"))?;
    let (w, h): (u32, u32) = (w.trim().parse()?, h.trim().parse()?);
    anyhow::ensure!((1..=16384).contains(&w) && (1..=16384).contains(&h), "size {w}x{h} outside 1…16384");
    Ok((w, h))
}

/// Renders `camera`'s view of `store` at `size` with a converged cut of `tolerance_px`.
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
    Ok(image)
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
