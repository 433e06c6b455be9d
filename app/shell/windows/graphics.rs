//! Everything the windows draw with that lives on the GPU: the instance, the adapter, the device,
//! the windows' surfaces, the model renderer, the blit to the screen, the two egui painters and
//! the suggestion inset — made together, and renewed together.
//!
//! Renewal: lavapipe keeps memory it allocates while drawing (per frame, in its own threads) until
//! its device is destroyed, so a kiosk that runs for months on it grows (docs/performance.md,
//! Soak: +22 % to +35 % in a day of visits whether the renderer's objects were renewed or not).
//! The kiosk therefore renews all of it at each reset, when nobody is in front of it: the windows
//! stay, everything else is made again; images and model nodes load again on demand. What still
//! grows (a few kB a frame, in lavapipe's threads, live until the process ends) belongs to the
//! driver's process-wide state, which no renewal reaches.

use super::paint::Painter;
use super::surface::{Canvas, GpuWindow};
use super::{INSET_SIZE, config};
use anyhow::Context as _;
use kiosk_render::{Blit, Gpu, Renderer, wgpu};
use std::sync::Arc;
use winit::window::Window;

/// The GPU device and what is made on it.
pub(super) struct Graphics {
    pub gpu: Gpu,
    pub projection: GpuWindow,
    pub controller: GpuWindow,
    pub renderer: Renderer,
    pub blit: Blit,
    pub proj_painter: Painter,
    pub ctrl_painter: Painter,
    pub inset: Canvas,
    pub inset_id: egui::TextureId,
}

/// The two windows and their configuration, kept across renewals.
pub(super) struct Windows<'c> {
    pub projection: Arc<Window>,
    pub controller: Arc<Window>,
    pub config: &'c config::Config,
}

impl Graphics {
    /// A GPU instance, an adapter that can present to the projection window, a device on it and,
    /// on that, surfaces for both windows and everything drawn into them.
    pub fn new(w: &Windows<'_>) -> anyhow::Result<Self> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN | wgpu::Backends::GL,
            // wgpu validates every call itself; the Vulkan layers stay off in the kiosk (the render
            // tests run with them), set WGPU_VALIDATION=1 to turn them on.
            flags: wgpu::InstanceFlags::empty().with_env(),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let ps = instance.create_surface(w.projection.clone())?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&ps),
            apply_limit_buckets: false,
        }))
        .context("no GPU adapter for the windows")?;
        let adapter = &adapter;
        let cs = instance.create_surface(w.controller.clone())?;
        let gpu = Gpu::from_adapter(adapter)?;
        for (name, c) in [("projection", &w.config.projection), ("controller", &w.config.controller)] {
            gpu.check_size((c.size[0], c.size[1]))
                .with_context(|| format!("[{name}] size = {:?}", c.size))?;
        }
        let projection =
            GpuWindow::new(&gpu, w.projection.clone(), ps, adapter, w.config.projection.rotation)?;
        let controller =
            GpuWindow::new(&gpu, w.controller.clone(), cs, adapter, w.config.controller.rotation)?;
        let format = projection.format();
        let renderer = Renderer::new(&gpu, format);
        let blit = Blit::new(&gpu, format);
        let mut proj_painter = Painter::new(&gpu, format.remove_srgb_suffix());
        let ctrl_painter = Painter::new(&gpu, controller.format().remove_srgb_suffix());
        let inset = Canvas::new(&gpu, format, INSET_SIZE, "inset");
        let inset_id = proj_painter.register(&gpu, &inset.view);
        gpu.check()?;
        Ok(Self { gpu, projection, controller, renderer, blit, proj_painter, ctrl_painter, inset, inset_id })
    }
}
