//! A kiosk window on the GPU: its surface, the canvas the frame is composed in (model, overlays,
//! text), and the turned blit that presents the canvas. Screenshots read the canvas back, so they
//! show exactly what the window shows (before the turn).

use kiosk_render::{Blit, Gpu, wgpu};
use std::sync::Arc;
use winit::window::Window;

/// A canvas texture that can be drawn into, sampled and read back.
pub struct Canvas {
    /// The texture.
    pub texture: wgpu::Texture,
    /// Its view (the model renders here, in the surface's sRGB format).
    pub view: wgpu::TextureView,
    /// The same texels without sRGB encoding: egui paints here (it blends in gamma space).
    pub ui_view: wgpu::TextureView,
    /// Size in pixels.
    pub size: (u32, u32),
}

impl Canvas {
    /// A canvas of `format` and `size`.
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat, size: (u32, u32), label: &str) -> Self {
        let size = (size.0.max(1), size.1.max(1));
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[format.remove_srgb_suffix()],
        });
        let view = texture.create_view(&Default::default());
        let ui_view = texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(format.remove_srgb_suffix()),
            ..Default::default()
        });
        Self { texture, view, ui_view, size }
    }
}

/// One window with its surface and canvas.
pub struct GpuWindow {
    /// The window.
    pub window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// Quarter turns clockwise from the canvas to the screen.
    pub turns: u32,
    /// The canvas (logical orientation: width and height swapped for a quarter turn).
    pub canvas: Canvas,
}

impl GpuWindow {
    /// Wraps a window whose surface was created on the GPU's instance.
    pub fn new(
        gpu: &Gpu,
        window: Arc<Window>,
        surface: wgpu::Surface<'static>,
        adapter: &wgpu::Adapter,
        rotation_deg: u32,
    ) -> anyhow::Result<Self> {
        let caps = surface.get_capabilities(adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| matches!(f, wgpu::TextureFormat::Bgra8UnormSrgb | wgpu::TextureFormat::Rgba8UnormSrgb))
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| anyhow::anyhow!("the window surface offers no format"))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&gpu.device, &config);
        let turns = (rotation_deg / 90) % 4;
        let canvas = Canvas::new(gpu, format, logical((config.width, config.height), turns), "canvas");
        Ok(Self { window, surface, config, turns, canvas })
    }

    /// The surface's (and canvas') format.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.config.format
    }

    /// Follows a resize of the window.
    pub fn resize(&mut self, gpu: &Gpu, (w, h): (u32, u32)) {
        if w == 0 || h == 0 || (w, h) == (self.config.width, self.config.height) {
            return;
        }
        self.config.width = w;
        self.config.height = h;
        self.surface.configure(&gpu.device, &self.config);
        self.canvas = Canvas::new(gpu, self.config.format, logical((w, h), self.turns), "canvas");
    }

    /// Presents the canvas on the window.
    pub fn present(&mut self, gpu: &Gpu, blit: &Blit) -> anyhow::Result<()> {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f) | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&gpu.device, &self.config);
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => return Ok(()),
            wgpu::CurrentSurfaceTexture::Validation => anyhow::bail!("window surface: validation error"),
        };
        let view = frame.texture.create_view(&Default::default());
        blit.draw(gpu, &self.canvas.view, &view, self.turns);
        self.window.pre_present_notify();
        gpu.queue.present(frame);
        Ok(())
    }

    /// A point of the window (normalised, origin top-left) on the canvas (normalised).
    pub fn to_canvas(&self, u: f64, v: f64) -> (f64, f64) {
        canvas_point(self.turns, u, v)
    }
}

/// Where a point of a window (normalised, origin top-left) lies on its canvas when the canvas is
/// shown turned `turns` quarter turns clockwise — the mapping blit.wgsl samples with, so touches
/// land where the turned picture shows them.
pub fn canvas_point(turns: u32, u: f64, v: f64) -> (f64, f64) {
    match turns % 4 {
        1 => (v, 1.0 - u),
        2 => (1.0 - u, 1.0 - v),
        3 => (1.0 - v, u),
        _ => (u, v),
    }
}

/// The canvas size for a window size and a number of quarter turns.
fn logical((w, h): (u32, u32), turns: u32) -> (u32, u32) {
    if turns % 2 == 1 { (h, w) } else { (w, h) }
}

#[cfg(test)]
mod tests {
    use super::canvas_point;

    #[test]
    fn turned_touches_land_on_the_canvas_point_shown_there() {
        // A quarter turn clockwise: the canvas' top-left corner is shown at the window's
        // top-right, its top-right at the window's bottom-right.
        assert_eq!(canvas_point(1, 1.0, 0.0), (0.0, 0.0));
        assert_eq!(canvas_point(1, 1.0, 1.0), (1.0, 0.0));
        assert_eq!(canvas_point(2, 0.0, 0.0), (1.0, 1.0));
        assert_eq!(canvas_point(3, 0.0, 1.0), (0.0, 0.0));
        // Turning by 1 then by 3 (inverse pair) is the identity on any point.
        for &(u, v) in &[(0.2, 0.7), (0.9, 0.1), (0.5, 0.5)] {
            let (a, b) = canvas_point(1, u, v);
            let (x, y) = canvas_point(3, a, b);
            assert!((x - u).abs() < 1e-12 && (y - v).abs() < 1e-12);
            assert_eq!(canvas_point(0, u, v), (u, v));
            assert_eq!(canvas_point(4, u, v), (u, v));
        }
    }
}
