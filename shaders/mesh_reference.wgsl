// The mesh reference, a benchmark and test aid to measure the splats against the surface they
// sample: rasterised triangles with the splats' camera, light and colour (`vs_mesh` + `fs_mesh`),
// and textured ones (`vs_mesh_textured` + `fs_mesh_textured`: group 1, an sRGB texture filtered
// bilinearly in linear light, repeating), as a textured scan is seen. Not a shader of its own:
// compiled after splat.wgsl, whose frame uniforms and shading (`frame`, `facing`, `shade`,
// `base_color`) it uses (app/render/src/reference.rs).
//
// Needs to be kept in sync with `MeshVertex` and `TexturedVertex` (app/render/src/reference.rs).

struct MeshIn {
    @location(0) pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
};

struct MeshOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) to_point: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
};

// A mesh's interpolated normal turned toward the eye; a degenerate one faces the eye.
fn mesh_normal(normal: vec3<f32>, to_point: vec3<f32>) -> vec3<f32> {
    let l = length(normal);
    return select(-frame.view_dir.xyz, facing(normal / l, to_point), l > 1e-12);
}

@vertex
fn vs_mesh(v: MeshIn) -> MeshOut {
    let p = v.pos + frame.offset.xyz;
    var out: MeshOut;
    out.clip = frame.clip_from_camera * vec4<f32>(p, 1.0);
    out.to_point = p;
    out.normal = v.normal;
    out.color = v.color;
    return out;
}

@fragment
fn fs_mesh(in: MeshOut) -> @location(0) vec4<f32> {
    let n = mesh_normal(in.normal, in.to_point);
    return shade(base_color(in.color), n);
}

// ---- The textured mesh reference ----

@group(1) @binding(0) var mesh_texture: texture_2d<f32>;
@group(1) @binding(1) var mesh_sampler: sampler;

struct TexturedIn {
    @location(0) pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
};

struct TexturedOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) to_point: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
};

@vertex
fn vs_mesh_textured(v: TexturedIn) -> TexturedOut {
    let p = v.pos + frame.offset.xyz;
    var out: TexturedOut;
    out.clip = frame.clip_from_camera * vec4<f32>(p, 1.0);
    out.to_point = p;
    out.normal = v.normal;
    out.uv = v.uv;
    return out;
}

@fragment
fn fs_mesh_textured(in: TexturedOut) -> @location(0) vec4<f32> {
    let n = mesh_normal(in.normal, in.to_point);
    // The texture's format is sRGB: the sample is already linear light.
    return shade(textureSample(mesh_texture, mesh_sampler, in.uv).rgb, n);
}
