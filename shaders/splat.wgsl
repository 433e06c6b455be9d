// The surface shader: every way the renderer draws a model, sharing one camera and one shading.
//
// - Discs (`vs_main` + `fs_disc`): oriented elliptical splats (Botsch & Kobbelt 2003, as cited
//   by bettio09 §4.1), each a disc of its radius orthogonal to its normal, drawn as an instanced
//   quad whose fragments outside the unit disc are discarded, opaque, shaded with its one normal.
// - Points (`vs_main` in points mode + `fs_disc`): screen-aligned round points of the same radius.
// - Blended (the default; deferred surface splatting after Zwicker et al. 2001 and Botsch et al.
//   2005): `vs_visibility` + `fs_visibility` write the discs' depth pushed back along the view
//   ray by `epsilon` × the splat's radius; `vs_main` + `fs_accumulate` then add, for every
//   fragment within that epsilon of the front surface, its colour and normal weighted by a
//   Gaussian of the distance to the disc centre into two float targets (additive blending);
//   `vs_fullscreen` + `fs_resolve` divide by the summed weight and shade each pixel with its
//   blended normal. Overlapping splats of one surface blend; occluded ones fail the depth test.
// The mesh reference of tests and benchmarks (mesh_reference.wgsl) is compiled after this file
// and shares its frame uniforms and shading; the kiosk's renderer compiles this file alone.
//
// Colour: the store keeps sRGB bytes; they are decoded to linear light here, shaded in linear
// light, and encoded again only when the target is not an sRGB format.
//
// Coordinates are camera-relative: positions are stored relative to the model origin (f32) and
// `frame.offset` = origin − eye is computed in f64 on the CPU, so a model at 10⁷ m renders like
// one at the origin.
//
// Needs to be kept in sync with `Splat` (app/core/src/scene/splat.rs) and `FrameUniforms`
// (app/render/src/lib.rs).

struct Frame {
    clip_from_camera: mat4x4<f32>,
    offset: vec4<f32>,          // xyz: origin − eye (camera-relative translation)
    camera_right: vec4<f32>,    // for round points
    camera_up: vec4<f32>,       // w: the projection's focal scale (cot of half the vertical fov)
    light_dir: vec4<f32>,       // xyz: direction toward the user light (model axes)
    view_dir: vec4<f32>,        // xyz: forward direction of the camera (the headlight shines along it)
    params: vec4<f32>,          // x: mode (0 discs, 1 round points), y: radius scale, z: ambient, w: light mix
    viewport: vec4<f32>,        // x, y: target size in pixels, z: smallest splat radius in pixels, w: blend epsilon
    shading: vec4<f32>,         // x: specular strength, y: shininess, z: 1 when the target encodes sRGB itself, w: kernel sharpness
    background: vec4<f32>,      // linear RGBA
};

@group(0) @binding(0) var<uniform> frame: Frame;

struct VertexIn {
    @location(0) pos: vec3<f32>,
    @location(1) radius: f32,
    @location(2) normal_oct: vec2<f32>,
    @location(3) color: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
};

fn oct_decode(e: vec2<f32>) -> vec3<f32> {
    var n = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) {
        let s = vec2<f32>(select(-1.0, 1.0, n.x >= 0.0), select(-1.0, 1.0, n.y >= 0.0));
        let xy = (vec2<f32>(1.0) - abs(n.yx)) * s;
        n = vec3<f32>(xy.x, xy.y, n.z);
    }
    let l = length(n);
    if (l > 0.0) {
        return n / l;
    }
    return vec3<f32>(0.0, 0.0, 1.0);
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + vec3<f32>(0.055)) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let x = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    let lo = x * 12.92;
    let hi = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - vec3<f32>(0.055);
    return select(hi, lo, x <= vec3<f32>(0.0031308));
}

/// The colour of a sample in linear light: alpha 0 marks a scan without colour (a warm stone
/// grey).
fn base_color(c: vec4<f32>) -> vec3<f32> {
    return select(vec3<f32>(0.64, 0.61, 0.56), srgb_to_linear(c.rgb), c.a > 0.0);
}

/// A normal turned toward the eye (scans have unoriented normals): `to_point` is eye → point.
fn facing(n: vec3<f32>, to_point: vec3<f32>) -> vec3<f32> {
    return select(n, -n, dot(n, to_point) > 0.0);
}

/// Lambert plus a little Blinn–Phong specular from a headlight and the user light, mixed by
/// `params.w`; `n` faces the eye. Returns the pixel as the target wants it.
fn shade(base: vec3<f32>, n: vec3<f32>) -> vec4<f32> {
    let to_eye = -frame.view_dir.xyz;
    let light = normalize(frame.light_dir.xyz);
    let head = max(dot(n, to_eye), 0.0);
    let user = max(dot(n, light), 0.0);
    let diffuse = mix(head, user, frame.params.w);
    let shininess = frame.shading.y;
    let spec_head = pow(max(dot(n, to_eye), 0.0), shininess);
    let spec_user = select(0.0, pow(max(dot(n, normalize(light + to_eye)), 0.0), shininess), user > 0.0);
    let spec = frame.shading.x * mix(spec_head, spec_user, frame.params.w);
    let ambient = frame.params.z;
    return finish(base * (ambient + (1.0 - ambient) * diffuse) + vec3<f32>(spec));
}

/// Encodes a linear colour for the target.
fn finish(c: vec3<f32>) -> vec4<f32> {
    return vec4<f32>(select(linear_to_srgb(c), c, frame.shading.z > 0.5), 1.0);
}

/// The corner of an instanced quad (triangle strip of four).
fn corner(vi: u32) -> vec2<f32> {
    return vec2<f32>(select(-1.0, 1.0, (vi & 1u) == 1u), select(-1.0, 1.0, (vi & 2u) == 2u));
}

/// A splat's quad corner, pushed back along its view ray by `push` × its radius.
fn splat_vertex(vi: u32, inst: VertexIn, push: f32) -> VertexOut {
    let c = corner(vi);
    let center = inst.pos + frame.offset.xyz;
    let n = facing(oct_decode(inst.normal_oct), center);
    // Oriented disc: a tangent basis of the normal; round points: the camera's axes. Chosen with
    // `select`, not `if`: lavapipe compiles a new vertex shader for every pass that draws with
    // a shader branching on a uniform alone (it inlines such uniforms), and keeps each one until
    // the device is destroyed (docs/performance.md, Soak).
    let a = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9);
    let tangent = normalize(cross(n, a));
    let discs = frame.params.x < 0.5;
    let u = select(frame.camera_right.xyz, tangent, discs);
    let v = select(frame.camera_up.xyz, cross(n, tangent), discs);
    var r = inst.radius * frame.params.y;
    // A far splat covers at least `viewport.z` pixels: no splat falls between pixel centres.
    let depth = max(dot(center, frame.view_dir.xyz), 1e-30);
    let pixels = r * frame.camera_up.w * 0.5 * frame.viewport.y / depth;
    if (pixels < frame.viewport.z) {
        r = r * frame.viewport.z / max(pixels, 1e-30);
    }
    var p = center + (u * c.x + v * c.y) * r;
    p = p + normalize(p) * (push * r);
    var out: VertexOut;
    out.clip = frame.clip_from_camera * vec4<f32>(p, 1.0);
    out.uv = c;
    out.normal = n;
    out.color = inst.color;
    return out;
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, inst: VertexIn) -> VertexOut {
    return splat_vertex(vi, inst, 0.0);
}

@fragment
fn fs_disc(in: VertexOut) -> @location(0) vec4<f32> {
    if (dot(in.uv, in.uv) > 1.0) {
        discard;
    }
    return shade(base_color(in.color), normalize(in.normal));
}

// ---- Blended splatting ----

@vertex
fn vs_visibility(@builtin(vertex_index) vi: u32, inst: VertexIn) -> VertexOut {
    return splat_vertex(vi, inst, frame.viewport.w);
}

@fragment
fn fs_visibility(in: VertexOut) {
    if (dot(in.uv, in.uv) > 1.0) {
        discard;
    }
}

struct Accumulated {
    @location(0) color: vec4<f32>,   // rgb: Σ w·colour (linear), a: Σ w
    @location(1) normal: vec4<f32>,  // xyz: Σ w·normal
};

@fragment
fn fs_accumulate(in: VertexOut) -> Accumulated {
    let d2 = dot(in.uv, in.uv);
    if (d2 > 1.0) {
        discard;
    }
    // A Gaussian truncated at the disc's edge, lifted so that the edge weighs nothing.
    let edge = exp(-frame.shading.w);
    let w = max((exp(-frame.shading.w * d2) - edge) / (1.0 - edge), 0.0) + 1e-4;
    var out: Accumulated;
    out.color = vec4<f32>(base_color(in.color) * w, w);
    out.normal = vec4<f32>(normalize(in.normal) * w, 0.0);
    return out;
}

@group(0) @binding(1) var accumulated_color: texture_2d<f32>;
@group(0) @binding(2) var accumulated_normal: texture_2d<f32>;

struct Fullscreen {
    @builtin(position) clip: vec4<f32>,
};

@vertex
fn vs_fullscreen(@builtin(vertex_index) vi: u32) -> Fullscreen {
    let x = f32((vi << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(vi & 2u) * 2.0 - 1.0;
    var o: Fullscreen;
    o.clip = vec4<f32>(x, y, 0.0, 1.0);
    return o;
}

@fragment
fn fs_resolve(in: Fullscreen) -> @location(0) vec4<f32> {
    let p = vec2<i32>(in.clip.xy);
    let c = textureLoad(accumulated_color, p, 0);
    if (c.a <= 0.0) {
        return finish_background();
    }
    let n = textureLoad(accumulated_normal, p, 0).xyz;
    let l = length(n);
    let normal = select(-frame.view_dir.xyz, n / l, l > 1e-12);
    return shade(c.rgb / c.a, normal);
}

fn finish_background() -> vec4<f32> {
    let b = finish(frame.background.rgb);
    return vec4<f32>(b.rgb, frame.background.a);
}
