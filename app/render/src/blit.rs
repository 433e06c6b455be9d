//! Presenting a canvas on a window surface, optionally turned by quarter turns (portrait
//! projectors and touch screens). The kiosk composes each window into a canvas texture (model,
//! overlays, text), which is also what its screenshots read back, and blits it here.

use crate::{Gpu, fullscreen};

/// The blit shader (shaders/blit.wgsl).
pub const BLIT_WGSL: &str = include_str!("../../../shaders/blit.wgsl");

/// A pipeline that copies a texture onto a target of a given format, turned.
pub struct Blit {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    uniforms: wgpu::Buffer,
}

impl Blit {
    /// A blit into targets of `format`.
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat) -> Self {
        let device = &gpu.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("blit"),
            source: wgpu::ShaderSource::Wgsl(BLIT_WGSL.into()),
        });
        let (layout, pipeline) = fullscreen::pipeline(
            device,
            "blit",
            (&module, "vs_main", "fs_main"),
            &[
                fullscreen::fragment_binding(0, fullscreen::UNIFORM),
                fullscreen::fragment_binding(
                    1,
                    fullscreen::texture(wgpu::TextureSampleType::Float { filterable: true }),
                ),
                fullscreen::fragment_binding(
                    2,
                    wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                ),
            ],
            format,
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("blit"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("blit"),
            size: 16,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self { pipeline, layout, sampler, uniforms }
    }

    /// Draws `source` over all of `target`, turned `quarter_turns` times clockwise.
    pub fn draw(
        &self,
        gpu: &Gpu,
        source: &wgpu::TextureView,
        target: &wgpu::TextureView,
        quarter_turns: u32,
    ) {
        let turns: [u32; 4] = [quarter_turns % 4, 0, 0, 0];
        gpu.queue.write_buffer(&self.uniforms, 0, bytemuck::cast_slice(&turns));
        let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("blit"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.uniforms.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(source) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        });
        let mut enc =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("blit") });
        fullscreen::draw(&mut enc, "blit", target, &self.pipeline, &group);
        gpu.queue.submit([enc.finish()]);
    }
}
