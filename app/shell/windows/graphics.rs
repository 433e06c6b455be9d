//! Everything the windows draw with that lives on the GPU device: the device, the windows'
//! surfaces, the model renderer, the blit to the screen, the two egui painters and the
//! suggestion inset — made together, and renewed together.
//!
//! Renewal: a driver may keep memory it allocates while drawing until its device is destroyed
//! (lavapipe did, a whole compiled vertex shader for every pass that drew splats, until the splat
//! shader stopped branching on a uniform alone: `shaders/splat.wgsl`; and renewing only the
//! renderer left its pipelines behind: docs/performance.md, Soak). The kiosk therefore renews the
//! whole device at each reset, when nobody is in front of it: the windows stay, their surfaces and
//! everything else are made again on a new device from the same adapter; images and model nodes
//! load again on demand. `ISOKIOSK_RENEW=never` keeps the device, to measure the difference.

use super::draw::{self, PreparingView};
use super::paint::Painter;
use super::surface::{Canvas, GpuWindow};
use super::{INSET_SIZE, config};
use anyhow::Context as _;
use kiosk_render::{Blit, Gpu, Renderer, wgpu};
use std::path::Path;
use std::sync::Arc;
use winit::window::Window;

/// Whether the device is renewed at each reset: yes, unless `ISOKIOSK_RENEW=never` (to measure
/// the difference side by side).
pub(super) fn renewal_wanted() -> bool {
    std::env::var_os("ISOKIOSK_RENEW").is_none_or(|v| v != "never")
}

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
    /// A device on `adapter` and, on it, surfaces for both windows and everything drawn into them.
    pub fn new(instance: &wgpu::Instance, adapter: &wgpu::Adapter, w: &Windows<'_>) -> anyhow::Result<Self> {
        let ps = instance.create_surface(w.projection.clone())?;
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

    /// Draws the preparing screen in both windows ([`super::preparing`]; the small print on the
    /// controller only) and presents it, waiting for the GPU (it is drawn once a second).
    pub fn draw_preparing(&mut self, view: &PreparingView<'_>) {
        let projection = PreparingView { detail: None, ..*view };
        let clear = Some(wgpu::Color::BLACK);
        let (target, size) = (self.projection.canvas.ui_view.clone(), self.projection.canvas.size);
        self.proj_painter
            .paint(&self.gpu, &target, size, clear, view.t, |ctx| draw::preparing(ctx, &projection));
        let (target, size) = (self.controller.canvas.ui_view.clone(), self.controller.canvas.size);
        self.ctrl_painter.paint(&self.gpu, &target, size, clear, view.t, |ctx| draw::preparing(ctx, view));
        for (name, w) in [("projection", &mut self.projection), ("controller", &mut self.controller)] {
            if let Err(e) = w.present(&self.gpu, &self.blit) {
                tracing::warn!("{name} window: {e}");
            }
        }
        let index = self.gpu.queue.submit([]);
        if let Err(e) =
            self.gpu.device.poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: None })
        {
            tracing::warn!("GPU wait: {e}");
        }
    }

    /// Saves both canvases as PNG, `{window}-{tag}.png` in `dir`.
    pub fn capture(&self, dir: &Path, tag: &str) -> anyhow::Result<()> {
        for (name, w) in [("projection", &self.projection), ("controller", &self.controller)] {
            let img = kiosk_render::read_back(&self.gpu, &w.canvas.texture, w.canvas.size)?;
            let path = dir.join(format!("{name}-{tag}.png"));
            img.save(&path).with_context(|| format!("cannot write {}", path.display()))?;
            tracing::info!("screenshot {}", path.display());
        }
        Ok(())
    }
}
