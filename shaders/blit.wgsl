// Copies a canvas onto a window surface, turned by a number of quarter turns clockwise
// (a projector or a touch screen mounted on its side).

struct Blit {
    // x: quarter turns clockwise (0..3).
    turns: vec4<u32>,
}

@group(0) @binding(0) var<uniform> blit: Blit;
@group(0) @binding(1) var canvas: texture_2d<f32>;
@group(0) @binding(2) var canvas_sampler: sampler;

struct VsOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) uv: vec2<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> VsOut {
    // One triangle covering the screen.
    let xy = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    var out: VsOut;
    out.pos = vec4<f32>(xy * 2.0 - 1.0, 0.0, 1.0);
    out.uv = vec2<f32>(xy.x, 1.0 - xy.y);
    return out;
}

@fragment
fn fs_main(in: VsOut) -> @location(0) vec4<f32> {
    let u = in.uv.x;
    let v = in.uv.y;
    var src = vec2<f32>(u, v);
    switch blit.turns.x {
        case 1u: { src = vec2<f32>(v, 1.0 - u); }
        case 2u: { src = vec2<f32>(1.0 - u, 1.0 - v); }
        case 3u: { src = vec2<f32>(1.0 - v, u); }
        default: {}
    }
    return textureSample(canvas, canvas_sampler, src);
}
