//! The IsoKiosk renderer: draws a cut of the point hierarchy into any `wgpu::TextureView`, so
//! the same code serves the kiosk windows, the authoring tool, thumbnails and tests; an offscreen
//! path returns an RGBA image.
//!
//! - Three ways to draw splats ([`SplatMode`]): **blended** (the default), deferred surface
//!   splatting after Zwicker et al. 2001 and Botsch et al. 2005 — a visibility pass writes the
//!   discs' depth pushed back along the view ray, an accumulation pass adds every splat within
//!   that epsilon of the front surface, its colour and normal weighted by a smooth kernel, into
//!   float targets, and a normalisation pass shades each pixel with its blended normal; opaque
//!   **discs**, each shaded with its one normal; round **points**. shaders/splat.wgsl says how.
//! - The blended mode's choices, measured against the mesh render in the render benchmark
//!   (docs/performance.md): the epsilon is 2 splat radii ([`DEFAULT_BLEND_EPSILON`]; 0 leaves
//!   the discs' rims and, at grazing angles, holes; 1 still scallops concave creases; 4 starts
//!   to blend across them); the kernel is a Gaussian truncated at the disc's rim, falling to 8 %
//!   of its centre weight at the rim before the truncation (its sharpness barely matters: the
//!   discs' radii already make neighbours overlap by construction); the disc keeps the radius
//!   the store gives (the cut's radii cover the surface without holes), and a far splat is
//!   enlarged to 0.75 px so that none falls between pixel centres. Silhouettes stay sharp: the
//!   discs' own extent decides coverage.
//! - Shading is one function for every mode and for the mesh reference ([`reference`]): the
//!   store's sRGB colours decoded to linear light, normals turned toward the eye, Lambert from a
//!   headlight and the user light (mixed by [`RenderSettings::light_mix`]) plus a little
//!   Blinn–Phong specular; encoded for the target.
//! - Camera-relative coordinates: splats stay `f32` relative to the model origin; the per-frame
//!   translation origin − eye is computed in `f64` on the CPU, so a model at 10⁷ m renders like
//!   one at the origin.
//! - A GPU cache of node buffers under a memory budget (least recently used first out), fed by
//!   the cut; uploads per frame are bounded, and a node not yet uploaded is drawn as its nearest
//!   cached ancestor, so a sudden turn never stalls a frame nor opens a hole.
//! - Optional eye-dome lighting (a screen-space pass on the depth buffer; in blended mode the
//!   visibility pass's depth).
//!
//! Errors from wgpu are captured and returned, never swallowed: a frame with a validation error
//! is an `Err`.

use glam::{DVec3, Mat4, Vec3};
use kiosk_core::camera::Camera;
use kiosk_core::scene::{NodeId, Splat, Store};
use std::collections::{HashMap, HashSet};
use wgpu::util::DeviceExt;

pub use wgpu;

mod blit;
mod fullscreen;
mod gpu;
#[cfg(feature = "reference")]
pub mod reference;
mod settings;
pub use blit::{BLIT_WGSL, Blit};
pub use gpu::{Gpu, RenderError, read_back};
pub use settings::{DEFAULT_BLEND_EPSILON, FrameStats, RenderSettings, SplatMode};

/// The splat shader (validated by a test with naga).
pub const SPLAT_WGSL: &str = include_str!("../../../shaders/splat.wgsl");
/// The eye-dome lighting shader.
pub const EDL_WGSL: &str = include_str!("../../../shaders/edl.wgsl");

/// Colour format of offscreen images.
pub const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Needs to be kept in sync with `Frame` in shaders/splat.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct FrameUniforms {
    clip_from_camera: [[f32; 4]; 4],
    offset: [f32; 4],
    camera_right: [f32; 4],
    camera_up: [f32; 4],
    light_dir: [f32; 4],
    view_dir: [f32; 4],
    params: [f32; 4],
    viewport: [f32; 4],
    shading: [f32; 4],
    background: [f32; 4],
}

/// Needs to be kept in sync with `Edl` in shaders/edl.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct EdlUniforms {
    params: [f32; 4],
}

struct CacheEntry {
    buffer: wgpu::Buffer,
    count: u32,
    bytes: u64,
    last_used: u64,
}

struct Targets {
    size: (u32, u32),
    depth: wgpu::TextureView,
    /// Intermediate colour for the EDL pass.
    color: wgpu::TextureView,
    edl_group: wgpu::BindGroup,
    /// The blended mode's sums: Σ w·colour and Σ w, Σ w·normal.
    accumulated: [wgpu::TextureView; 2],
    resolve_group: wgpu::BindGroup,
}

/// The blended mode's accumulation format: blendable floats (16 bits hold the sums of the few
/// dozen splats that overlap at a pixel to 3 significant digits).
const ACCUMULATION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The renderer for one colour format.
pub struct Renderer {
    format: wgpu::TextureFormat,
    /// Opaque discs and round points.
    pipeline: wgpu::RenderPipeline,
    /// Blended mode: the depth of the discs pushed back by the epsilon.
    visibility_pipeline: wgpu::RenderPipeline,
    /// Blended mode: weighted sums of colour and normal.
    accumulate_pipeline: wgpu::RenderPipeline,
    /// Blended mode: normalisation and shading.
    resolve_pipeline: wgpu::RenderPipeline,
    resolve_layout: wgpu::BindGroupLayout,
    edl_pipeline: wgpu::RenderPipeline,
    edl_layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
    edl_uniforms: wgpu::Buffer,
    group: wgpu::BindGroup,
    cache: HashMap<NodeId, CacheEntry>,
    cache_bytes: u64,
    /// Which store the cache holds nodes of (index checksum, length, origin).
    cache_store: Option<(u32, u64, [u64; 3])>,
    /// Nodes of that store whose data failed their check (never uploaded), and why.
    corrupt: std::collections::BTreeMap<NodeId, String>,
    frame: u64,
    /// Depth and EDL targets by size, most recently used first (a window and an inset alternate
    /// without reallocating).
    targets: Vec<Targets>,
}

/// A 2D texture of `(w, h)` pixels (at least 1 a side), one mip level, one sample.
pub(crate) fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    (w, h): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: w.max(1), height: h.max(1), depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// The surface shader (shaders/splat.wgsl): discs, points and blended splats.
pub(crate) fn surface_shader(device: &wgpu::Device) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("splat.wgsl"),
        source: wgpu::ShaderSource::Wgsl(SPLAT_WGSL.into()),
    })
}

/// The frame uniforms (binding 0, vertex and fragment stages): a pipeline layout with them (group
/// 0) and the `more` groups after them, their buffer and bind group.
pub(crate) fn frame_binding(
    device: &wgpu::Device,
    label: &str,
    more: &[&wgpu::BindGroupLayout],
) -> (wgpu::PipelineLayout, wgpu::Buffer, wgpu::BindGroup) {
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("frame"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: fullscreen::UNIFORM,
            count: None,
        }],
    });
    let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("frame uniforms"),
        size: std::mem::size_of::<FrameUniforms>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("frame"),
        layout: &layout,
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() }],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &std::iter::once(Some(&layout))
            .chain(more.iter().map(|l| Some(*l)))
            .collect::<Vec<_>>(),
        immediate_size: 0,
    });
    (pipeline_layout, uniforms, group)
}

/// What differs between the splat pipelines.
struct SplatPipeline<'a> {
    label: &'a str,
    vertex: &'a str,
    fragment: &'a str,
    targets: &'a [Option<wgpu::ColorTargetState>],
    depth_write: bool,
    depth_compare: wgpu::CompareFunction,
}

fn splat_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    p: &SplatPipeline<'_>,
) -> wgpu::RenderPipeline {
    // Needs to be kept in sync with `Splat` (24 bytes).
    const ATTRS: [wgpu::VertexAttribute; 4] =
        wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32, 2 => Snorm16x2, 3 => Unorm8x4];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(p.label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(p.vertex),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Splat>() as u64,
                step_mode: wgpu::VertexStepMode::Instance,
                attributes: &ATTRS,
            })],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleStrip,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(p.depth_write),
            depth_compare: Some(p.depth_compare),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        }),
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(p.fragment),
            compilation_options: Default::default(),
            targets: p.targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl Renderer {
    /// A renderer drawing into views of `format`.
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat) -> Self {
        let device = &gpu.device;
        let splat = surface_shader(device);
        let edl = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("edl.wgsl"),
            source: wgpu::ShaderSource::Wgsl(EDL_WGSL.into()),
        });
        let (pipeline_layout, uniforms, group) = frame_binding(device, "splats", &[]);
        let pipeline = splat_pipeline(
            device,
            &pipeline_layout,
            &splat,
            &SplatPipeline {
                label: "discs",
                vertex: "vs_main",
                fragment: "fs_disc",
                targets: &[Some(format.into())],
                depth_write: true,
                depth_compare: wgpu::CompareFunction::Less,
            },
        );
        let visibility_pipeline = splat_pipeline(
            device,
            &pipeline_layout,
            &splat,
            &SplatPipeline {
                label: "visibility",
                vertex: "vs_visibility",
                fragment: "fs_visibility",
                targets: &[],
                depth_write: true,
                depth_compare: wgpu::CompareFunction::Less,
            },
        );
        let additive = wgpu::ColorTargetState {
            format: ACCUMULATION_FORMAT,
            blend: Some(wgpu::BlendState {
                color: wgpu::BlendComponent {
                    src_factor: wgpu::BlendFactor::One,
                    dst_factor: wgpu::BlendFactor::One,
                    operation: wgpu::BlendOperation::Add,
                },
                alpha: wgpu::BlendComponent {
                    src_factor: wgpu::BlendFactor::One,
                    dst_factor: wgpu::BlendFactor::One,
                    operation: wgpu::BlendOperation::Add,
                },
            }),
            write_mask: wgpu::ColorWrites::ALL,
        };
        let accumulate_pipeline = splat_pipeline(
            device,
            &pipeline_layout,
            &splat,
            &SplatPipeline {
                label: "accumulate",
                vertex: "vs_main",
                fragment: "fs_accumulate",
                targets: &[Some(additive.clone()), Some(additive)],
                depth_write: false,
                depth_compare: wgpu::CompareFunction::LessEqual,
            },
        );
        let unfiltered = fullscreen::texture(wgpu::TextureSampleType::Float { filterable: false });
        let (resolve_layout, resolve_pipeline) = fullscreen::pipeline(
            device,
            "resolve",
            (&splat, "vs_fullscreen", "fs_resolve"),
            &[
                fullscreen::fragment_binding(0, fullscreen::UNIFORM),
                fullscreen::fragment_binding(1, unfiltered),
                fullscreen::fragment_binding(2, unfiltered),
            ],
            format,
        );
        let (edl_layout, edl_pipeline) = fullscreen::pipeline(
            device,
            "edl",
            (&edl, "vs_main", "fs_main"),
            &[
                fullscreen::fragment_binding(0, fullscreen::UNIFORM),
                fullscreen::fragment_binding(1, unfiltered),
                fullscreen::fragment_binding(2, fullscreen::texture(wgpu::TextureSampleType::Depth)),
            ],
            format,
        );
        let edl_uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("edl uniforms"),
            size: std::mem::size_of::<EdlUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            format,
            pipeline,
            visibility_pipeline,
            accumulate_pipeline,
            resolve_pipeline,
            resolve_layout,
            edl_pipeline,
            edl_layout,
            uniforms,
            edl_uniforms,
            group,
            cache: HashMap::new(),
            cache_bytes: 0,
            cache_store: None,
            corrupt: std::collections::BTreeMap::new(),
            frame: 0,
            targets: Vec::new(),
        }
    }

    /// The colour format it draws into.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    fn targets(&mut self, gpu: &Gpu, size: (u32, u32)) -> &Targets {
        if let Some(i) = self.targets.iter().position(|t| t.size == size) {
            let t = self.targets.remove(i);
            self.targets.insert(0, t);
        } else {
            let tex = |label, format, usage| {
                texture_2d(&gpu.device, label, size, format, usage).create_view(&Default::default())
            };
            let attach = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
            let depth = tex("depth", DEPTH_FORMAT, attach);
            let color = tex("edl input", self.format, attach);
            let accumulated =
                [tex("Σ colour", ACCUMULATION_FORMAT, attach), tex("Σ normal", ACCUMULATION_FORMAT, attach)];
            let resolve_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("resolve"),
                layout: &self.resolve_layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: self.uniforms.as_entire_binding() },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&accumulated[0]),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(&accumulated[1]),
                    },
                ],
            });
            let edl_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("edl"),
                layout: &self.edl_layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: self.edl_uniforms.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&color) },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&depth) },
                ],
            });
            self.targets.insert(0, Targets { size, depth, color, edl_group, accumulated, resolve_group });
            self.targets.truncate(MAX_TARGET_SIZES);
        }
        &self.targets[0]
    }

    /// The nodes of the current store whose data failed their check, with why: they are drawn
    /// as their nearest sound ancestor, if any.
    pub fn corrupt_nodes(&self) -> &std::collections::BTreeMap<NodeId, String> {
        &self.corrupt
    }

    /// Makes the visible nodes resident (within the upload budget) and returns what to draw.
    fn resident<B: AsRef<[u8]>>(
        &mut self,
        gpu: &Gpu,
        store: &Store<B>,
        nodes: &[NodeId],
        settings: &RenderSettings,
        stats: &mut FrameStats,
    ) -> Vec<NodeId> {
        self.frame += 1;
        let frame = self.frame;
        // Node ids are per store: another model empties the cache.
        let h = store.header();
        let key = (h.index_crc, h.file_len, h.origin.map(f64::to_bits));
        if self.cache_store != Some(key) {
            self.cache.clear();
            self.cache_bytes = 0;
            self.cache_store = Some(key);
            self.corrupt.clear();
        }
        let mut draw = Vec::with_capacity(nodes.len());
        let mut seen = HashSet::new();
        let upload = |r: &mut Self, id: NodeId, stats: &mut FrameStats| {
            let splats = store.splats(id);
            let bytes: &[u8] = bytemuck::cast_slice(splats);
            let buffer = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("node"),
                contents: bytes,
                usage: wgpu::BufferUsages::VERTEX,
            });
            r.cache.insert(
                id,
                CacheEntry {
                    buffer,
                    count: splats.len() as u32,
                    bytes: bytes.len() as u64,
                    last_used: frame,
                },
            );
            r.cache_bytes += bytes.len() as u64;
            stats.uploads += 1;
            stats.uploaded_bytes += bytes.len() as u64;
        };
        // A node's data is checked once, before its first upload (a CRC over its bytes, as
        // cheap as the copy): a corrupted node is never drawn, its nearest sound ancestor is
        // (its parent, usually: a coarser patch where the node was).
        let sound = |r: &mut Self, id: NodeId, stats: &mut FrameStats| {
            if r.corrupt.contains_key(&id) {
                return false;
            }
            match store.verify_node(id) {
                Ok(()) => true,
                Err(e) => {
                    r.corrupt.insert(id, e.to_string());
                    stats.corrupt += 1;
                    false
                }
            }
        };
        for &id in nodes {
            if let Some(e) = self.cache.get_mut(&id) {
                e.last_used = frame;
                if seen.insert(id) {
                    draw.push(id);
                }
                continue;
            }
            let size = u64::from(store.node(id).point_count) * std::mem::size_of::<Splat>() as u64;
            let within =
                stats.uploaded_bytes + size <= settings.upload_budget_bytes || stats.uploaded_bytes == 0;
            if within && sound(self, id, stats) {
                upload(self, id, stats);
                if seen.insert(id) {
                    draw.push(id);
                }
                continue;
            }
            let mut a = store.node(id).parent;
            let stand_in = if within {
                // Corrupt: its nearest sound ancestor stands in, uploaded if need be.
                while a != u32::MAX && !self.cache.contains_key(&a) {
                    if sound(self, a, stats) {
                        upload(self, a, stats);
                        break;
                    }
                    a = store.node(a).parent;
                }
                a
            } else {
                // Over budget: the nearest cached ancestor stands in (the root, at worst,
                // uploaded if sound).
                while a != u32::MAX && !self.cache.contains_key(&a) {
                    a = store.node(a).parent;
                }
                if a == u32::MAX {
                    let root = store.root();
                    if !self.cache.contains_key(&root) && sound(self, root, stats) {
                        upload(self, root, stats);
                    }
                    root
                } else {
                    a
                }
            };
            if let Some(e) = self.cache.get_mut(&stand_in) {
                e.last_used = frame;
                stats.substituted += 1;
                if seen.insert(stand_in) {
                    draw.push(stand_in);
                }
            }
        }
        // Evict least recently used nodes not drawn this frame.
        if self.cache_bytes > settings.gpu_budget_bytes {
            let mut old: Vec<(u64, NodeId)> = self
                .cache
                .iter()
                .filter(|(_, e)| e.last_used < frame)
                .map(|(id, e)| (e.last_used, *id))
                .collect();
            old.sort_unstable();
            for (_, id) in old {
                if self.cache_bytes <= settings.gpu_budget_bytes {
                    break;
                }
                if let Some(e) = self.cache.remove(&id) {
                    self.cache_bytes -= e.bytes;
                }
            }
        }
        stats.cache_bytes = self.cache_bytes;
        draw
    }

    /// Draws `nodes` (a cut's visible nodes) of `store` seen by `camera` into `target`, of
    /// `size` pixels.
    #[expect(clippy::too_many_arguments, reason = "one frame's inputs; a struct would only rename them")]
    pub fn render<B: AsRef<[u8]>>(
        &mut self,
        gpu: &Gpu,
        store: &Store<B>,
        nodes: &[NodeId],
        camera: &Camera,
        target: &wgpu::TextureView,
        size: (u32, u32),
        settings: &RenderSettings,
    ) -> Result<FrameStats, RenderError> {
        let mut stats = FrameStats::default();
        let draw = self.resident(gpu, store, nodes, settings, &mut stats);
        let eye = store.to_local(camera.eye);
        let (reach, nearest) = drawn_reach(store, &draw, eye);
        let (near, far) = depth_range_of(store.bbox(), eye, nearest);
        let uniforms =
            frame_uniforms(store.origin(), camera, size, (near, far), settings, self.format.is_srgb());
        gpu.queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        let edl_on = settings.edl_strength > 0.0;
        gpu.queue.write_buffer(
            &self.edl_uniforms,
            0,
            bytemuck::bytes_of(&EdlUniforms {
                params: [settings.edl_strength, settings.edl_radius, near, far],
            }),
        );
        self.targets(gpu, size);
        let t = self.targets.first().ok_or_else(|| RenderError::Gpu("no render targets".into()))?;
        let mut enc =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        let shaded = if edl_on { &t.color } else { target };
        // Draws every resident node of the cut with the pass's pipeline.
        let draw_nodes = |pass: &mut wgpu::RenderPass<'_>, stats: &mut FrameStats| {
            pass.set_bind_group(0, &self.group, &[]);
            for id in &draw {
                if let Some(e) = self.cache.get(id)
                    && e.count > 0
                {
                    pass.set_vertex_buffer(0, e.buffer.slice(..));
                    pass.draw(0..4, 0..e.count);
                    stats.nodes += 1;
                    stats.splats += u64::from(e.count);
                }
            }
        };
        let depth = |load| wgpu::RenderPassDepthStencilAttachment {
            view: &t.depth,
            depth_ops: Some(wgpu::Operations { load, store: wgpu::StoreOp::Store }),
            stencil_ops: None,
        };
        let color = |view, clear| wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
        };
        match settings.mode {
            SplatMode::Discs | SplatMode::Points => {
                let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("splats"),
                    color_attachments: &[Some(color(shaded, clear_color(settings.background, self.format)))],
                    depth_stencil_attachment: Some(depth(wgpu::LoadOp::Clear(1.0))),
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&self.pipeline);
                draw_nodes(&mut pass, &mut stats);
            }
            SplatMode::Blended => {
                {
                    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("visibility"),
                        color_attachments: &[],
                        depth_stencil_attachment: Some(depth(wgpu::LoadOp::Clear(1.0))),
                        timestamp_writes: None,
                        occlusion_query_set: None,
                        multiview_mask: None,
                    });
                    pass.set_pipeline(&self.visibility_pipeline);
                    draw_nodes(&mut pass, &mut FrameStats::default());
                }
                {
                    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("accumulate"),
                        color_attachments: &[
                            Some(color(&t.accumulated[0], wgpu::Color::TRANSPARENT)),
                            Some(color(&t.accumulated[1], wgpu::Color::TRANSPARENT)),
                        ],
                        depth_stencil_attachment: Some(depth(wgpu::LoadOp::Load)),
                        timestamp_writes: None,
                        occlusion_query_set: None,
                        multiview_mask: None,
                    });
                    pass.set_pipeline(&self.accumulate_pipeline);
                    draw_nodes(&mut pass, &mut stats);
                }
                // The resolve runs only where the drawn nodes can be (on lavapipe it costs as
                // much as drawing a small model's splats when run over a whole 1080p frame);
                // the background around is the pass's clear.
                fullscreen::draw_within(
                    &mut enc,
                    "resolve",
                    shaded,
                    (&self.resolve_pipeline, &t.resolve_group),
                    clear_color(settings.background, self.format),
                    screen_rect(reach, &uniforms, size),
                );
            }
        }
        if edl_on {
            fullscreen::draw(&mut enc, "edl", target, &self.edl_pipeline, &t.edl_group);
        }
        gpu.queue.submit([enc.finish()]);
        gpu.check()?;
        Ok(stats)
    }

    /// A colour texture of this renderer's format that can be drawn into and read back.
    pub fn offscreen_target(&self, gpu: &Gpu, (w, h): (u32, u32)) -> (wgpu::Texture, wgpu::TextureView) {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        let texture = texture_2d(&gpu.device, "offscreen", (w, h), self.format, usage);
        let view = texture.create_view(&Default::default());
        (texture, view)
    }

    /// Renders offscreen and returns the image (sRGB RGBA8). The image is complete: every node
    /// is uploaded whatever the per-frame upload budget, which only paces a live view (in a
    /// snapshot, a thumbnail or a benchmark's frame, a stand-in ancestor's large discs would
    /// stay in the picture).
    pub fn render_image<B: AsRef<[u8]>>(
        &mut self,
        gpu: &Gpu,
        store: &Store<B>,
        nodes: &[NodeId],
        camera: &Camera,
        size: (u32, u32),
        settings: &RenderSettings,
    ) -> Result<(image::RgbaImage, FrameStats), RenderError> {
        let (w, h) = (size.0.max(1), size.1.max(1));
        gpu.check_size((w, h))?;
        let (texture, view) = self.offscreen_target(gpu, (w, h));
        let settings = RenderSettings { upload_budget_bytes: u64::MAX, ..*settings };
        let stats = self.render(gpu, store, nodes, camera, &view, (w, h), &settings)?;
        let image = read_back(gpu, &texture, (w, h))?;
        Ok((image, stats))
    }
}

/// Sizes of depth/EDL targets a renderer keeps at once.
const MAX_TARGET_SIZES: usize = 3;

/// What the drawn nodes can reach: the union of their boxes grown by their largest splat, and
/// its nearest point's distance to `eye` (store-local coordinates); one pass per frame serves
/// the depth range and the resolve's screen rectangle.
fn drawn_reach<B: AsRef<[u8]>>(
    store: &Store<B>,
    nodes: &[NodeId],
    eye: Vec3,
) -> (kiosk_core::geom::Aabb, f32) {
    let mut union = kiosk_core::geom::Aabb::EMPTY;
    let mut nearest = f32::INFINITY;
    for &id in nodes {
        let n = store.node(id);
        let b = kiosk_core::geom::Aabb { min: Vec3::from(n.bbox_min), max: Vec3::from(n.bbox_max) }
            .inflate(n.radius_max);
        nearest = nearest.min(b.distance_squared(eye).sqrt());
        union = union.union(b);
    }
    (union, nearest)
}

/// The eight corners of a box.
fn corners(b: kiosk_core::geom::Aabb) -> [Vec3; 8] {
    std::array::from_fn(|k| {
        Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        )
    })
}

/// The pixels (x, y, width, height) that `reach` (the drawn nodes' boxes, [`drawn_reach`]) can
/// cover, with 2 pixels to spare; `None` (everywhere) when it reaches behind the eye.
fn screen_rect(reach: kiosk_core::geom::Aabb, u: &FrameUniforms, (w, h): (u32, u32)) -> Option<[u32; 4]> {
    if reach.is_empty() {
        return Some([0, 0, 0, 0]);
    }
    let clip = Mat4::from_cols_array_2d(&u.clip_from_camera);
    let offset = Vec3::from_slice(&u.offset[..3]);
    let (mut lo, mut hi) = (glam::Vec2::splat(f32::MAX), glam::Vec2::splat(f32::MIN));
    for c in corners(reach) {
        let p = clip * (c + offset).extend(1.0);
        if p.w <= 1e-6 * (c + offset).length().max(1e-30) {
            return None;
        }
        let ndc = glam::Vec2::new(p.x, p.y) / p.w;
        lo = lo.min(ndc);
        hi = hi.max(ndc);
    }
    // NDC y points up, pixel rows down.
    let to_px = |x: f32, size: u32| (x * 0.5 + 0.5) * size as f32;
    let x0 = (to_px(lo.x, w) - 2.0).floor().clamp(0.0, w as f32) as u32;
    let x1 = (to_px(hi.x, w) + 2.0).ceil().clamp(0.0, w as f32) as u32;
    let y0 = (h as f32 - to_px(hi.y, h) - 2.0).floor().clamp(0.0, h as f32) as u32;
    let y1 = (h as f32 - to_px(lo.y, h) + 2.0).ceil().clamp(0.0, h as f32) as u32;
    Some([x0, y0, x1.saturating_sub(x0), y1.saturating_sub(y0)])
}

/// Near and far planes around `bbox` seen from `eye` (both in one local frame), with nothing
/// nearer than `nearest` to draw: the near plane at half that, never nearer than 10⁻⁴ of the
/// box's diagonal (the camera keeps farther from the surface than that).
fn depth_range_of(bbox: kiosk_core::geom::Aabb, eye: Vec3, nearest: f32) -> (f32, f32) {
    let diag = f64::from(bbox.diagonal()).max(1e-30);
    let nearest =
        f64::from(bbox.distance_squared(eye).sqrt().max(if nearest.is_finite() { nearest } else { 0.0 }));
    let farthest = corners(bbox).iter().map(|c| f64::from((*c - eye).length())).fold(0.0, f64::max);
    let near = (nearest * 0.5).max(diag * 1e-4);
    // Beyond the farthest corner by the blended mode's push of the farthest splats.
    let far = (farthest * 1.05).max(near * 2.0);
    (near as f32, far as f32)
}

/// The clear colour of `background` (linear RGBA) in a target of `format`: an sRGB target
/// encodes it itself, another gets it encoded (as the shaders encode their colours).
fn clear_color([r, g, b, a]: [f64; 4], format: wgpu::TextureFormat) -> wgpu::Color {
    let encode = |c: f64| {
        if format.is_srgb() {
            c
        } else if c <= 0.003_130_8 {
            12.92 * c
        } else {
            1.055 * c.clamp(0.0, 1.0).powf(1.0 / 2.4) - 0.055
        }
    };
    wgpu::Color { r: encode(r), g: encode(g), b: encode(b), a }
}

/// The shaders' frame uniforms: `origin` is the model's (the store's) origin, the splats' and
/// mesh vertices' positions are relative to it.
pub(crate) fn frame_uniforms(
    origin: DVec3,
    camera: &Camera,
    size: (u32, u32),
    (near, far): (f32, f32),
    s: &RenderSettings,
    srgb_target: bool,
) -> FrameUniforms {
    let forward = camera.forward();
    let right = camera.right();
    let up = right.cross(forward);
    let view = glam::camera::rh::view::look_to_mat4(Vec3::ZERO, forward.as_vec3(), up.as_vec3());
    let aspect = size.0.max(1) as f32 / size.1.max(1) as f32;
    let proj = glam::camera::rh::proj::directx::perspective(camera.fov_y as f32, aspect, near, far);
    let clip: Mat4 = proj * view;
    let offset = (origin - camera.eye).as_vec3();
    let mode = match s.mode {
        SplatMode::Blended | SplatMode::Discs => 0.0,
        SplatMode::Points => 1.0,
    };
    let focal = 1.0 / (camera.fov_y as f32 * 0.5).tan();
    let [r, g, b, a] = s.background.map(|c| c as f32);
    FrameUniforms {
        clip_from_camera: clip.to_cols_array_2d(),
        offset: offset.extend(0.0).to_array(),
        camera_right: right.as_vec3().extend(0.0).to_array(),
        camera_up: up.as_vec3().extend(focal).to_array(),
        light_dir: s.light_dir.normalize_or(Vec3::Y).extend(0.0).to_array(),
        view_dir: forward.as_vec3().extend(0.0).to_array(),
        params: [mode, s.radius_scale, s.ambient, s.light_mix],
        viewport: [size.0.max(1) as f32, size.1.max(1) as f32, s.min_pixel_radius, s.blend_epsilon],
        shading: [
            s.specular,
            s.shininess.max(1.0),
            if srgb_target { 1.0 } else { 0.0 },
            s.kernel_sharpness.max(0.01),
        ],
        background: [r, g, b, a],
    }
}
