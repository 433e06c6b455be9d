//! The mesh reference: a triangle mesh rasterised with the splats' camera, lighting and colour
//! (shaders/mesh_reference.wgsl, `vs_mesh` and `fs_mesh`, compiled after the splat shader whose
//! frame uniforms and shading it uses), to measure the splats against the surface they sample. A
//! textured mesh is coloured from its texture per pixel (`vs_mesh_textured`, `fs_mesh_textured`),
//! as a viewer of the textured scan shows it. A benchmark and test aid, not a kiosk mode (behind
//! the `reference` feature, which only the tests and benchmarks turn on; the kiosk's renderer
//! compiles splat.wgsl alone): the mesh is uploaded at every call.

use crate::{
    DEPTH_FORMAT, FrameUniforms, Gpu, RenderError, RenderSettings, frame_binding, frame_uniforms, read_back,
};
use glam::{DVec3, Vec3};
use kiosk_core::camera::Camera;
use kiosk_core::geom::Aabb;
use wgpu::util::DeviceExt;

/// A triangle mesh with per-vertex normals and colours, positions relative to `origin`.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Where the positions are measured from (model coordinates).
    pub origin: DVec3,
    /// Vertex positions relative to `origin`.
    pub positions: Vec<Vec3>,
    /// Unit vertex normals (area-weighted means of their triangles' normals).
    pub normals: Vec<Vec3>,
    /// sRGB colours with alpha 255, or all zero for "no colour" (drawn stone grey, as splats).
    pub colors: Vec<[u8; 4]>,
    /// Triangles as indices into the vertices.
    pub triangles: Vec<[u32; 3]>,
    /// The texture that colours the mesh (sRGB, repeating), if it has one: then `uvs` holds a
    /// texture coordinate per vertex (0,0 the image's top left) and `colors` is not used.
    pub texture: Option<image::RgbaImage>,
    /// Texture coordinates, one per vertex when there is a texture.
    pub uvs: Vec<[f32; 2]>,
}

impl Mesh {
    /// A mesh of `positions` (model coordinates) and `triangles`, without colour, with
    /// area-weighted vertex normals; positions are kept relative to their bounding box's centre.
    /// Triangles with an index out of range are an error naming the triangle.
    pub fn new(positions: &[DVec3], triangles: Vec<[u32; 3]>) -> Result<Self, String> {
        let n = positions.len();
        if let Some((i, t)) = triangles.iter().enumerate().find(|(_, t)| t.iter().any(|&v| v as usize >= n)) {
            return Err(format!("triangle {i}: index {t:?} outside the {n} vertices"));
        }
        let (lo, hi) = positions
            .iter()
            .fold((DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let origin = if n == 0 { DVec3::ZERO } else { (lo + hi) * 0.5 };
        let local: Vec<Vec3> = positions.iter().map(|p| (*p - origin).as_vec3()).collect();
        let mut normals = vec![Vec3::ZERO; n];
        for t in &triangles {
            let [a, b, c] = t.map(|i| local[i as usize]);
            // The cross product's length is twice the area: an area-weighted sum.
            let face = (b - a).cross(c - a);
            for &i in t {
                normals[i as usize] += face;
            }
        }
        let normals = normals.into_iter().map(|v| v.normalize_or_zero()).collect();
        Ok(Self {
            origin,
            positions: local,
            normals,
            colors: vec![[0; 4]; n],
            triangles,
            texture: None,
            uvs: Vec::new(),
        })
    }

    /// The bounding box of the vertices (relative to `origin`).
    pub fn bbox(&self) -> Aabb {
        Aabb::from_points(self.positions.iter().copied())
    }
}

/// The mesh reference's own entry points, compiled after the splat shader ([`crate::SPLAT_WGSL`]),
/// whose uniforms and shading they use.
const MESH_REFERENCE_WGSL: &str = include_str!("../../../shaders/mesh_reference.wgsl");

/// Needs to be kept in sync with `MeshIn` in shaders/mesh_reference.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct MeshVertex {
    pos: [f32; 3],
    normal: [f32; 3],
    color: [u8; 4],
}

/// Needs to be kept in sync with `TexturedIn` in shaders/mesh_reference.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct TexturedVertex {
    pos: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
}

/// Draws [`Mesh`]es offscreen.
pub struct MeshRenderer {
    format: wgpu::TextureFormat,
    pipeline: wgpu::RenderPipeline,
    textured: wgpu::RenderPipeline,
    texture_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    uniforms: wgpu::Buffer,
    group: wgpu::BindGroup,
}

impl MeshRenderer {
    /// A mesh renderer drawing into textures of `format`.
    pub fn new(gpu: &Gpu, format: wgpu::TextureFormat) -> Self {
        let device = &gpu.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("splat.wgsl + mesh_reference.wgsl"),
            source: wgpu::ShaderSource::Wgsl([crate::SPLAT_WGSL, MESH_REFERENCE_WGSL].concat().into()),
        });
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty,
            count: None,
        };
        let texture_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mesh texture"),
            entries: &[
                entry(
                    0,
                    wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                ),
                entry(1, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)),
            ],
        });
        // One layout for both pipelines (the plain one does not read group 1).
        let (pipeline_layout, uniforms, group) = frame_binding(device, "mesh", &[&texture_layout]);
        const ATTRS: [wgpu::VertexAttribute; 3] =
            wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Unorm8x4];
        const TEXTURED_ATTRS: [wgpu::VertexAttribute; 3] =
            wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2];
        let make = |label, vertex, fragment, stride: usize, attributes: &[wgpu::VertexAttribute]| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vertex),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: stride as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes,
                    })],
                },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: wgpu::StencilState::default(),
                    bias: wgpu::DepthBiasState::default(),
                }),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fragment),
                    compilation_options: Default::default(),
                    targets: &[Some(format.into())],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let pipeline = make("mesh", "vs_mesh", "fs_mesh", std::mem::size_of::<MeshVertex>(), &ATTRS);
        let textured = make(
            "textured mesh",
            "vs_mesh_textured",
            "fs_mesh_textured",
            std::mem::size_of::<TexturedVertex>(),
            &TEXTURED_ATTRS,
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("mesh texture"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Self { format, pipeline, textured, texture_layout, sampler, uniforms, group }
    }

    /// The texture bind group: the mesh's texture, or one white texel for a plain mesh.
    fn texture_group(&self, gpu: &Gpu, image: Option<&image::RgbaImage>) -> wgpu::BindGroup {
        let white = image::RgbaImage::from_pixel(1, 1, image::Rgba([255; 4]));
        let image = image.unwrap_or(&white);
        let size = wgpu::Extent3d { width: image.width(), height: image.height(), depth_or_array_layers: 1 };
        let texture = crate::texture_2d(
            &gpu.device,
            "mesh texture",
            (image.width(), image.height()),
            wgpu::TextureFormat::Rgba8UnormSrgb,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        );
        gpu.queue.write_texture(
            texture.as_image_copy(),
            image.as_raw(),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * image.width()),
                rows_per_image: Some(image.height()),
            },
            size,
        );
        let view = texture.create_view(&Default::default());
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mesh texture"),
            layout: &self.texture_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        })
    }

    /// Renders `mesh` seen by `camera` at `size` with the lighting of `settings` (its splat
    /// settings are ignored) and returns the image.
    pub fn render_image(
        &self,
        gpu: &Gpu,
        mesh: &Mesh,
        camera: &Camera,
        size: (u32, u32),
        settings: &RenderSettings,
    ) -> Result<image::RgbaImage, RenderError> {
        let (w, h) = (size.0.max(1), size.1.max(1));
        gpu.check_size((w, h))?;
        let eye = (camera.eye - mesh.origin).as_vec3();
        let range = crate::depth_range_of(mesh.bbox(), eye, f32::INFINITY);
        let uniforms: FrameUniforms =
            frame_uniforms(mesh.origin, camera, (w, h), range, settings, self.format.is_srgb());
        gpu.queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
        let normal = |i: usize| mesh.normals.get(i).copied().unwrap_or_default().to_array();
        let contents: Vec<u8> = match &mesh.texture {
            Some(_) => bytemuck::cast_slice(
                &(0..mesh.positions.len())
                    .map(|i| TexturedVertex {
                        pos: mesh.positions[i].to_array(),
                        normal: normal(i),
                        uv: mesh.uvs.get(i).copied().unwrap_or_default(),
                    })
                    .collect::<Vec<_>>(),
            )
            .to_vec(),
            None => bytemuck::cast_slice(
                &(0..mesh.positions.len())
                    .map(|i| MeshVertex {
                        pos: mesh.positions[i].to_array(),
                        normal: normal(i),
                        color: mesh.colors.get(i).copied().unwrap_or_default(),
                    })
                    .collect::<Vec<_>>(),
            )
            .to_vec(),
        };
        let texture_group = self.texture_group(gpu, mesh.texture.as_ref());
        let device = &gpu.device;
        let vertex_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mesh vertices"),
            contents: &contents,
            usage: wgpu::BufferUsages::VERTEX,
        });
        let index_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mesh triangles"),
            contents: bytemuck::cast_slice(&mesh.triangles),
            usage: wgpu::BufferUsages::INDEX,
        });
        let texture = |label, format, usage| crate::texture_2d(device, label, (w, h), format, usage);
        let color = texture(
            "mesh image",
            self.format,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = texture("mesh depth", DEPTH_FORMAT, wgpu::TextureUsages::RENDER_ATTACHMENT);
        let (color_view, depth_view) =
            (color.create_view(&Default::default()), depth.create_view(&Default::default()));
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("mesh") });
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("mesh"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &color_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(crate::clear_color(settings.background, self.format)),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(if mesh.texture.is_some() { &self.textured } else { &self.pipeline });
            pass.set_bind_group(0, &self.group, &[]);
            pass.set_bind_group(1, &texture_group, &[]);
            pass.set_vertex_buffer(0, vertex_buffer.slice(..));
            pass.set_index_buffer(index_buffer.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..(mesh.triangles.len() * 3) as u32, 0, 0..1);
        }
        gpu.queue.submit([enc.finish()]);
        gpu.check()?;
        read_back(gpu, &color, (w, h))
    }
}
