// Full-screen passes of depth peeling on scenes with coloured transmission: per-channel
// accumulators, one target per colour channel, because a blend unit multiplies a channel only
// by its own target's values (and dual-source blending allows a single target, while the
// peelers write several per pass).
//
// A front (under) accumulator of channel c is an RGBA target holding (F_c, 0, 0, T_c), cleared
// to (0, 0, 0, 1): a layer (C_c, t_c) blends as F_c += C_c · T_c (colour factors DstAlpha, One)
// and T_c *= t_c (alpha factors Zero, SrcAlpha). A back (over) accumulator of channel c is an RG
// target holding (B_c, Tb_c), cleared to (0, 1): a layer blends as B_c = C_c + t_c · B_c and
// Tb_c = t_c · Tb_c (colour factors One, SrcAlpha; the shader's output alpha is t_c). The
// identity layer of both is (0, 0, 0, 1). Either accumulator goes over the final colour in two
// draws: dst *= T (fs_*_transmittance, colour factors Zero, Src), then dst += F
// (fs_radiance, One, One); the target's alpha is kept.

#include "peel_counters.wgsl"

// Front peeling's under pass: the layer (colour, alpha −1 = none) and its transmittance.
// Composites: the accumulators of the red, green and blue channel.
@group(0) @binding(0) var source0: texture_2d<f32>;
@group(0) @binding(1) var source1: texture_2d<f32>;
@group(0) @binding(2) var source2: texture_2d<f32>;
// The pass group (oit-peel's Control).
@group(1) @binding(0) var<uniform> pass_info: PassInfo;
@group(1) @binding(1) var<storage, read_write> counters: array<atomic<u32>>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

struct Channels {
    @location(0) r: vec4<f32>,
    @location(1) g: vec4<f32>,
    @location(2) b: vec4<f32>,
}

// One peeled layer under-blended into the three channel accumulators, as `fs_under`
// (peel_composite.wgsl) does into the scalar accumulator; the scan after it counts.
@fragment
fn fs_under_transmit(@builtin(position) p: vec4<f32>) -> Channels {
    let px = vec2<i32>(p.xy);
    let layer = textureLoad(source0, px, 0);
    if layer.a < 0.0 {
        discard;
    }
    let t = textureLoad(source1, px, 0).rgb;
    var out: Channels;
    out.r = vec4<f32>(layer.r, 0.0, 0.0, t.r);
    out.g = vec4<f32>(layer.g, 0.0, 0.0, t.g);
    out.b = vec4<f32>(layer.b, 0.0, 0.0, t.b);
    return out;
}

fn texel(source: texture_2d<f32>, p: vec4<f32>) -> vec4<f32> {
    return textureLoad(source, vec2<i32>(p.xy), 0);
}

// T of front (RGBA) accumulators, for dst *= T.
@fragment
fn fs_front_transmittance(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(texel(source0, p).a, texel(source1, p).a, texel(source2, p).a, 1.0);
}

// Tb of back (RG) accumulators, for dst *= Tb.
@fragment
fn fs_back_transmittance(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(texel(source0, p).g, texel(source1, p).g, texel(source2, p).g, 1.0);
}

// F (or B) of either accumulator, for dst += F.
@fragment
fn fs_radiance(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(texel(source0, p).r, texel(source1, p).r, texel(source2, p).r, 0.0);
}
