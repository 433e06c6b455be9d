// Eye-dome lighting (Boucheny 2009, as in Potree): a screen-space pass that darkens pixels whose
// neighbours are closer to the eye, on the logarithm of the depth. It makes carvings readable on
// scans without colour. Reads the colour and depth of the splat pass, writes the final image.
//
// Needs to be kept in sync with `EdlUniforms` (app/render/src/lib.rs).

struct Edl {
    params: vec4<f32>,   // x: strength, y: radius in pixels, z: near, w: far
};

@group(0) @binding(0) var<uniform> edl: Edl;
@group(0) @binding(1) var color_tex: texture_2d<f32>;
@group(0) @binding(2) var depth_tex: texture_depth_2d;

struct Out {
    @builtin(position) clip: vec4<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> Out {
    // One triangle covering the screen.
    let x = f32((vi << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(vi & 2u) * 2.0 - 1.0;
    var o: Out;
    o.clip = vec4<f32>(x, y, 0.0, 1.0);
    return o;
}

fn log_depth(p: vec2<i32>) -> f32 {
    let size = vec2<i32>(textureDimensions(depth_tex));
    let q = clamp(p, vec2<i32>(0), size - vec2<i32>(1));
    let d = textureLoad(depth_tex, q, 0);
    if (d >= 1.0) {
        return 0.0; // background
    }
    // Reversed projection is not used: [0, 1] depth from a perspective with near/far.
    let near = edl.params.z;
    let far = edl.params.w;
    let z = near * far / (far - d * (far - near));
    return log2(max(z, 1e-30));
}

@fragment
fn fs_main(in: Out) -> @location(0) vec4<f32> {
    let p = vec2<i32>(in.clip.xy);
    let c = textureLoad(color_tex, p, 0);
    let d0 = log_depth(p);
    if (d0 == 0.0) {
        return c;
    }
    let r = i32(edl.params.y);
    var sum = 0.0;
    let offsets = array<vec2<i32>, 4>(vec2<i32>(r, 0), vec2<i32>(-r, 0), vec2<i32>(0, r), vec2<i32>(0, -r));
    for (var i = 0; i < 4; i++) {
        let dn = log_depth(p + offsets[i]);
        if (dn != 0.0) {
            sum += max(0.0, d0 - dn);
        }
    }
    // Potree's response (mean of the four differences); the darkening is limited so that the
    // depth steps between large coarse splats never blacken whole regions.
    let shade = max(exp(-sum * 0.25 * 300.0 * edl.params.x), 0.35);
    return vec4<f32>(c.rgb * shade, c.a);
}
