//! egui as a painter: each window composes its text, buttons, overlays and thumbnails with egui's
//! shapes over the canvas. Input does not go through egui — the core hit-tests the controller's
//! buttons — so a recorded session replays the same way whatever draws the screen.

use egui::{ColorImage, TextureHandle, TextureOptions};
use kiosk_render::{Gpu, wgpu};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// An egui context and its wgpu renderer for one window.
pub struct Painter {
    /// The context (fonts, textures).
    pub ctx: egui::Context,
    renderer: egui_wgpu::Renderer,
    images: HashMap<PathBuf, Option<TextureHandle>>,
}

/// Height in points the layout is designed for; windows of other heights scale.
pub const DESIGN_HEIGHT: f32 = 720.0;

impl Painter {
    /// A painter into targets of `format`.
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat) -> Self {
        let ctx = egui::Context::default();
        let renderer = egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        Self { ctx, renderer, images: HashMap::new() }
    }

    /// Registers a GPU texture (e.g. an offscreen render) for drawing.
    pub fn register(&mut self, gpu: &Gpu, view: &wgpu::TextureView) -> egui::TextureId {
        self.renderer.register_native_texture(&gpu.device, view, wgpu::FilterMode::Linear)
    }

    /// Whether an image file is already loaded (or known broken).
    pub fn has_image(&self, path: &Path) -> bool {
        self.images.contains_key(path)
    }

    /// An image file as a texture, loaded once; a missing or broken file is logged once and
    /// gives `None` from then on.
    pub fn image(&mut self, path: &Path) -> Option<TextureHandle> {
        if let Some(t) = self.images.get(path) {
            return t.clone();
        }
        let loaded = match kiosk_content::media::read_image(path) {
            Ok(img) => Some(self.texture(&path.display().to_string(), &img)),
            Err(e) => {
                tracing::warn!("image {e}; not shown");
                None
            }
        };
        self.images.insert(path.to_path_buf(), loaded.clone());
        loaded
    }

    /// Stores an image under a path-like key (e.g. a thumbnail rendered because its file was
    /// missing).
    pub fn put_image(&mut self, key: &Path, img: &image::RgbaImage) -> TextureHandle {
        let t = self.texture(&key.display().to_string(), img);
        self.images.insert(key.to_path_buf(), Some(t.clone()));
        t
    }

    fn texture(&self, name: &str, img: &image::RgbaImage) -> TextureHandle {
        let size = [img.width() as usize, img.height() as usize];
        let color = ColorImage::from_rgba_unmultiplied(size, img.as_raw());
        self.ctx.load_texture(name, color, TextureOptions::LINEAR)
    }

    /// Runs `draw` and paints its shapes into `target` (`size` pixels), over what is there
    /// (`clear: None`) or over a cleared background.
    pub fn paint(
        &mut self,
        gpu: &Gpu,
        target: &wgpu::TextureView,
        size: (u32, u32),
        clear: Option<wgpu::Color>,
        time: f64,
        draw: impl FnMut(&egui::Context),
    ) {
        let ppp = (size.1 as f32 / DESIGN_HEIGHT).max(0.25);
        let mut input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(size.0 as f32 / ppp, size.1 as f32 / ppp),
            )),
            time: Some(time),
            ..Default::default()
        };
        // The scale as the window's own (a zoom factor set on the context takes effect a pass
        // late: a new context's first pass laid out a screen of 15 000 points, and showed nothing).
        input.viewports.entry(egui::ViewportId::ROOT).or_default().native_pixels_per_point = Some(ppp);
        let mut output = self.ctx.run_pass(input, draw);
        let jobs = self.ctx.tessellate(output.shapes, output.pixels_per_point);
        let mut textures = std::mem::take(&mut output.textures_delta);
        for (id, deltas) in textures.set.drain() {
            for delta in deltas {
                self.renderer.update_texture(&gpu.device, &gpu.queue, id, &delta);
            }
        }
        let screen = egui_wgpu::ScreenDescriptor { size_in_pixels: [size.0, size.1], pixels_per_point: ppp };
        let mut enc =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("egui") });
        let extra = self.renderer.update_buffers(&gpu.device, &gpu.queue, &mut enc, &jobs, &screen);
        {
            let pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("egui"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: clear.map_or(wgpu::LoadOp::Load, wgpu::LoadOp::Clear),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            let mut pass = pass.forget_lifetime();
            self.renderer.render(&mut pass, &jobs, &screen);
        }
        gpu.queue.submit(extra.into_iter().chain([enc.finish()]));
        for id in std::mem::take(&mut textures.free) {
            self.renderer.free_texture(&id);
        }
    }
}
