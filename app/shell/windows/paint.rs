//! egui as a painter: each window composes its text, buttons, overlays and thumbnails with egui's
//! shapes over the canvas. Input does not go through egui — the core hit-tests the controller's
//! buttons — so a recorded session replays the same way whatever draws the screen.
//!
//! Images (overlays, thumbnails) are loaded when first shown and kept in an [`ImageCache`] of a
//! bounded size, least recently shown out first: a kiosk that runs for months shows every image
//! of its stories sooner or later, and an exhibit's images decoded at once can take more memory
//! than the machine has (an overlay is 3.7 MB at 1280×720, and as much again in the GPU's copy).

use egui::{ColorImage, TextureHandle, TextureOptions};
use kiosk_render::{Gpu, wgpu};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// An egui context and its wgpu renderer for one window.
pub struct Painter {
    /// The context (fonts, textures).
    pub ctx: egui::Context,
    renderer: egui_wgpu::Renderer,
    images: ImageCache,
}

/// Bytes of decoded images a painter keeps (about 25 overlays at 1280×720): more than one
/// screen shows at once (an overlay and a menu of eight thumbnails), so that a visit does not
/// decode an image twice; within it, a month of visits through every node stays flat.
pub const IMAGE_BUDGET: usize = 96 << 20;

/// Decoded images by file (or by a key of a rendered thumbnail), with what they take; the least
/// recently used go when the total passes the budget. A file that could not be read is
/// remembered (as `None`, taking nothing), so that it is reported once.
pub struct ImageCache {
    entries: HashMap<PathBuf, Cached>,
    bytes: usize,
    budget: usize,
    clock: u64,
}

struct Cached {
    texture: Option<TextureHandle>,
    bytes: usize,
    used: u64,
}

impl ImageCache {
    /// An empty cache that keeps at most `budget` bytes of images.
    pub fn new(budget: usize) -> Self {
        Self { entries: HashMap::new(), bytes: 0, budget, clock: 0 }
    }

    /// Whether `key` is held (or known broken).
    pub fn contains(&self, key: &Path) -> bool {
        self.entries.contains_key(key)
    }

    /// The image held under `key`, now the most recently used; `None` if not held, `Some(None)`
    /// if known broken.
    pub fn get(&mut self, key: &Path) -> Option<Option<TextureHandle>> {
        self.clock += 1;
        let e = self.entries.get_mut(key)?;
        e.used = self.clock;
        Some(e.texture.clone())
    }

    /// Holds `texture` (`None`: a broken file) under `key`, then lets the least recently used
    /// others go until the total is within the budget.
    pub fn insert(&mut self, key: &Path, texture: Option<TextureHandle>) {
        self.clock += 1;
        let bytes = texture.as_ref().map_or(0, |t| t.size().iter().product::<usize>() * 4);
        if let Some(old) = self.entries.insert(key.to_path_buf(), Cached { texture, bytes, used: self.clock })
        {
            self.bytes -= old.bytes;
        }
        self.bytes += bytes;
        while self.bytes > self.budget {
            let oldest = self
                .entries
                .iter()
                .filter(|(k, e)| e.bytes > 0 && k.as_path() != key)
                .min_by_key(|(_, e)| e.used)
                .map(|(k, _)| k.clone());
            let Some(k) = oldest else { break };
            if let Some(e) = self.entries.remove(&k) {
                // Dropping the handle frees the texture in egui and, at the next paint, the GPU.
                self.bytes -= e.bytes;
            }
        }
    }

    /// Bytes of the images held.
    #[cfg(test)]
    fn bytes(&self) -> usize {
        self.bytes
    }
}

/// Height in points the layout is designed for; windows of other heights scale.
pub const DESIGN_HEIGHT: f32 = 720.0;

impl Painter {
    /// A painter into targets of `format`.
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat) -> Self {
        let ctx = egui::Context::default();
        let renderer = egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        Self { ctx, renderer, images: ImageCache::new(IMAGE_BUDGET) }
    }

    /// Registers a GPU texture (e.g. an offscreen render) for drawing.
    pub fn register(&mut self, gpu: &Gpu, view: &wgpu::TextureView) -> egui::TextureId {
        self.renderer.register_native_texture(&gpu.device, view, wgpu::FilterMode::Linear)
    }

    /// Whether an image file is already loaded (or known broken).
    pub fn has_image(&self, path: &Path) -> bool {
        self.images.contains(path)
    }

    /// An image file as a texture, loaded once; a missing or broken file is logged once and
    /// gives `None` from then on.
    pub fn image(&mut self, path: &Path) -> Option<TextureHandle> {
        if let Some(t) = self.images.get(path) {
            return t;
        }
        let loaded = match kiosk_content::media::read_image(path) {
            Ok(img) => Some(self.texture(&path.display().to_string(), &img)),
            Err(e) => {
                tracing::warn!("image {e}; not shown");
                None
            }
        };
        self.images.insert(path, loaded.clone());
        loaded
    }

    /// Stores an image under a path-like key (e.g. a thumbnail rendered because its file was
    /// missing).
    pub fn put_image(&mut self, key: &Path, img: &image::RgbaImage) -> TextureHandle {
        let t = self.texture(&key.display().to_string(), img);
        self.images.insert(key, Some(t.clone()));
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
        self.ctx.set_pixels_per_point(ppp);
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(size.0 as f32 / ppp, size.1 as f32 / ppp),
            )),
            time: Some(time),
            ..Default::default()
        };
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

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(ctx: &egui::Context, name: &str, w: usize, h: usize) -> TextureHandle {
        ctx.load_texture(name, ColorImage::filled([w, h], egui::Color32::WHITE), TextureOptions::LINEAR)
    }

    #[test]
    fn the_image_cache_lets_the_least_recently_shown_go_and_frees_their_textures() {
        let ctx = egui::Context::default();
        let allocated = || ctx.tex_manager().read().num_allocated();
        let base = allocated();
        // Room for two images of 100 × 100 (40 000 bytes each), not three.
        let mut cache = ImageCache::new(100_000);
        let (a, b, c) = (Path::new("a.png"), Path::new("b.png"), Path::new("c.png"));
        cache.insert(a, Some(texture(&ctx, "a", 100, 100)));
        cache.insert(b, Some(texture(&ctx, "b", 100, 100)));
        cache.insert(Path::new("broken.png"), None);
        assert_eq!((cache.bytes(), allocated() - base), (80_000, 2));
        // `a` shown again: `b` is now the least recently shown and goes when `c` comes.
        assert!(cache.get(a).is_some_and(|t| t.is_some()));
        cache.insert(c, Some(texture(&ctx, "c", 100, 100)));
        assert!(cache.contains(a) && !cache.contains(b) && cache.contains(c));
        assert_eq!((cache.bytes(), allocated() - base), (80_000, 2), "b's texture freed");
        // A broken file stays known (reported once), and an image larger than the budget is
        // still held while it is the one shown.
        assert_eq!(cache.get(Path::new("broken.png")).map(|t| t.is_none()), Some(true));
        cache.insert(Path::new("big.png"), Some(texture(&ctx, "big", 200, 200)));
        assert!(cache.contains(Path::new("big.png")) && !cache.contains(a) && !cache.contains(c));
        assert_eq!((cache.bytes(), allocated() - base), (160_000, 1));
        assert!(cache.get(b).is_none(), "gone, to be loaded again when shown");
    }
}
