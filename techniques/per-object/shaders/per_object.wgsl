// pygfx's `solid` and `weighted_blend` methods (oit-per-object `opaque` and `weighted`).
#include "common.wgsl"

// `opaque`: the straight colour with α forced to 1 (pygfx `solid`), written with depth. Where
// α = 0 the straight colour is not recoverable from P = α·c and the fragment writes P.
@fragment
fn fs_solid(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    return vec4<f32>(select(s.color, s.color / s.alpha, s.alpha > 0.0), 1.0);
}

struct WeightedOut {
    // Blended One + One into rgba16float.
    @location(0) accum: vec4<f32>,
    // Blended Zero + (1 − src) into the revealage (cleared to 1).
    @location(1) reveal: vec4<f32>,
}

// `weighted`: pygfx's weighted_blend with its default weight w = α: accum += (rgb·α, α)·w
// (P = rgb·α is the premultiplied colour), reveal ·= 1 − α. No depth term.
@fragment
fn fs_weighted(v: VertexOut, @builtin(front_facing) front_facing: bool) -> WeightedOut {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    let weight = s.alpha;
    var out: WeightedOut;
    out.accum = vec4<f32>(s.color, s.alpha) * weight;
    out.reveal = vec4<f32>(s.alpha);
    return out;
}
