// Oriented elliptical splats (Botsch & Kobbelt 2003, as cited by bettio09 §4.1): every sample is a
// disc of its radius, orthogonal to its normal, drawn as an instanced quad whose fragments outside
// the unit disc are discarded. Correct depth: the quad is a real 3D disc. The fallback mode draws
// screen-aligned round points of the same radius.
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
    camera_up: vec4<f32>,
    light_dir: vec4<f32>,       // xyz: direction toward the user light (camera space not needed: world)
    view_dir: vec4<f32>,        // xyz: forward direction of the camera (headlight)
    params: vec4<f32>,          // x: mode (0 splats, 1 round points), y: radius scale, z: ambient, w: light mix
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

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, inst: VertexIn) -> VertexOut {
    let corner = vec2<f32>(select(-1.0, 1.0, (vi & 1u) == 1u), select(-1.0, 1.0, (vi & 2u) == 2u));
    let n = oct_decode(inst.normal_oct);
    var u: vec3<f32>;
    var v: vec3<f32>;
    if (frame.params.x < 0.5) {
        // Oriented disc: a tangent basis of the normal.
        let a = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9);
        u = normalize(cross(n, a));
        v = cross(n, u);
    } else {
        u = frame.camera_right.xyz;
        v = frame.camera_up.xyz;
    }
    let r = inst.radius * frame.params.y;
    let p = inst.pos + frame.offset.xyz + (u * corner.x + v * corner.y) * r;
    var out: VertexOut;
    out.clip = frame.clip_from_camera * vec4<f32>(p, 1.0);
    out.uv = corner;
    out.normal = n;
    out.color = inst.color;
    return out;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    if (dot(in.uv, in.uv) > 1.0) {
        discard;
    }
    // Headlight plus a user light, both two-sided (scans have unoriented normals).
    let head = abs(dot(in.normal, frame.view_dir.xyz));
    let user = abs(dot(in.normal, normalize(frame.light_dir.xyz)));
    let diffuse = mix(head, user, frame.params.w);
    let shade = frame.params.z + (1.0 - frame.params.z) * diffuse;
    // Alpha 0 marks a scan without colour: a warm stone grey.
    let base = select(vec3<f32>(0.82, 0.80, 0.76), in.color.rgb, in.color.a > 0.0);
    return vec4<f32>(base * shade, 1.0);
}
