//! The device the renderer draws with ([`Gpu`]: headless on Vulkan — lavapipe on machines
//! without a GPU — with validation on, or on an adapter a window chose), the errors of
//! rendering, and reading an image back from the GPU.

use std::sync::{Arc, Mutex};

/// Why rendering failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No GPU adapter (install lavapipe: `mesa-vulkan-drivers libvulkan1`).
    #[error(
        "no GPU adapter found ({0}); on a machine without GPU install lavapipe (mesa-vulkan-drivers, libvulkan1; in a checkout, .ci/setup installs them)"
    )]
    NoAdapter(String),
    /// The device could not be created.
    #[error("cannot create the GPU device: {0}")]
    Device(String),
    /// wgpu reported an error.
    #[error("GPU error: {0}")]
    Gpu(String),
    /// Reading back an image failed.
    #[error("cannot read the image back: {0}")]
    Readback(String),
    /// An image size the device cannot draw or read back.
    #[error("{0}")]
    Size(String),
}

/// A GPU device and queue, with wgpu's errors collected.
pub struct Gpu {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// What the adapter is (e.g. "llvmpipe … Vulkan Cpu").
    pub adapter: wgpu::AdapterInfo,
    errors: Arc<Mutex<Vec<String>>>,
}

impl Gpu {
    /// A headless device (Vulkan: a real GPU, or lavapipe on machines without one), with
    /// validation on.
    pub fn headless() -> Result<Self, RenderError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            flags: wgpu::InstanceFlags::VALIDATION,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            apply_limit_buckets: false,
        }))
        .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        Self::from_adapter(&adapter)
    }

    /// A device on an adapter chosen by the caller (e.g. compatible with a window surface).
    pub fn from_adapter(adapter: &wgpu::Adapter) -> Result<Self, RenderError> {
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("isokiosk"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| RenderError::Device(e.to_string()))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        Ok(Self { device, queue, adapter: adapter.get_info(), errors })
    }

    /// Whether this device can draw an image of `(w, h)` pixels and read it back: each side at
    /// most its largest texture, the padded pixels within its largest buffer.
    pub fn check_size(&self, (w, h): (u32, u32)) -> Result<(), RenderError> {
        let limits = self.device.limits();
        let side = limits.max_texture_dimension_2d;
        if w == 0 || h == 0 || w > side || h > side {
            return Err(RenderError::Size(format!(
                "{w}×{h} pixels: this GPU draws 1 to {side} pixels a side"
            )));
        }
        let row = u64::from(
            (w * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT,
        );
        let bytes = row * u64::from(h);
        if bytes > limits.max_buffer_size {
            return Err(RenderError::Size(format!(
                "{w}×{h} pixels: reading the image back takes {} MB, this GPU's largest buffer is {} MB",
                bytes >> 20,
                limits.max_buffer_size >> 20
            )));
        }
        Ok(())
    }

    /// Waits until the GPU has finished all submitted work (for timing and tests).
    pub fn wait(&self) -> Result<(), RenderError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| RenderError::Gpu(e.to_string()))?;
        Ok(())
    }

    /// The errors wgpu reported since the last call, as one error.
    pub fn check(&self) -> Result<(), RenderError> {
        let mut v = self.errors.lock().map_err(|_| RenderError::Gpu("error log poisoned".into()))?;
        if v.is_empty() { Ok(()) } else { Err(RenderError::Gpu(std::mem::take(&mut *v).join("; "))) }
    }
}

/// Copies an RGBA8 or BGRA8 texture (sRGB or not) into an RGBA image.
pub fn read_back(
    gpu: &Gpu,
    texture: &wgpu::Texture,
    (w, h): (u32, u32),
) -> Result<image::RgbaImage, RenderError> {
    let unpadded = w * 4;
    let padded = unpadded.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(padded) * u64::from(h),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc =
        gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
    enc.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
    let index = gpu.queue.submit([enc.finish()]);
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.device
        .poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: None })
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| RenderError::Readback(e.to_string()))?
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    let mut rgba = Vec::with_capacity((unpadded * h) as usize);
    {
        let view = buffer.slice(..).get_mapped_range().map_err(|e| RenderError::Readback(e.to_string()))?;
        for row in view.chunks_exact(padded as usize) {
            rgba.extend_from_slice(&row[..unpadded as usize]);
        }
    }
    buffer.unmap();
    gpu.check()?;
    if matches!(texture.format(), wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb) {
        for px in rgba.chunks_exact_mut(4) {
            px.swap(0, 2);
        }
    }
    image::RgbaImage::from_raw(w, h, rgba).ok_or_else(|| RenderError::Readback("size mismatch".into()))
}
