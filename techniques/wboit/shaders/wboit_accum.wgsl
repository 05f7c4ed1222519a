// Weighted blended OIT accumulation pass (one geometry pass, depth-tested against the opaque
// depth, no depth writes) and the weighted-average (Bavoil & Myers 2008) variant.
#include "common.wgsl"
#include "wboit_tail.wgsl"

struct WboitParams {
    // 0 const, 1 alpha, 2 eq7, 3 eq8, 4 eq9, 5 eq10, 6 mcguire2015, 7 range.
    weight: u32,
    // 1 when window depth 1 is near (then the paper's depth d = 1 - window z).
    reverse_z: u32,
    ortho: u32,
    // The `range` weight's fall in bits.
    range_fall: f32,
    // Projection terms for wboit_view_distance.
    proj_a: f32,
    proj_b: f32,
    // The scene's transparent depth interval (view distances) for the `range` weight.
    z_near: f32,
    z_far: f32,
    // Unit of the colour sums (oit_wboit::RangeParams::color_scale; 1 for LDR colours).
    color_scale: f32,
    // 1 for the weighted average (the revealage target then holds the fragment count n).
    average: u32,
    pad1: f32,
    pad2: f32,
}

@group(1) @binding(0) var<uniform> params: WboitParams;

// The accumulate pass's weight (oit_wboit::Weight::index), as a pipeline constant: llvmpipe
// runs every case of a switch on a uniform under masks, a constant folds it to one case
// (2026-12-07, lavapipe, 256², rgba8unorm, 3 interleaved rounds: frames took 0.86–0.96× the
// time on many-layers-64 and particles, every weight). The
// additive pass, on operator scenes only, reads the same value from `params.weight`.
override WBOIT_WEIGHT: u32 = 7u;

// True when the colour scale is 1 (every scene without HDR colours): the pass then divides by
// a constant 1, exactly what reading 1 from `params.color_scale` gives, without the read that
// llvmpipe makes in every step of 8 fragments (8 % of the accumulate pass's fragment
// instructions on 12 000 small billboards, 15 % on 64 screen-filling layers; callgrind,
// 2026-12-08).
override WBOIT_UNIT_SCALE: bool = false;

fn cube(x: f32) -> f32 {
    return x * x * x;
}

// The paper's weights (McGuire & Bavoil 2013, eqs. 7-10), McGuire's 2015 blog form, and ours.
// z is the positive view distance, d the conventional window depth (0 near, 1 far).
fn weight(kind: u32, z: f32, d: f32, alpha: f32) -> f32 {
    switch kind {
        case 0u: {
            return 1.0;
        }
        case 1u: {
            return alpha;
        }
        case 2u: {
            let q = z / 5.0;
            let s = z / 200.0;
            return alpha * clamp(10.0 / (1e-5 + q * q + cube(s) * cube(s)), 1e-2, 3e3);
        }
        case 3u: {
            let s = z / 200.0;
            return alpha * clamp(10.0 / (1e-5 + cube(z / 10.0) + cube(s) * cube(s)), 1e-2, 3e3);
        }
        case 4u: {
            let s = z / 200.0;
            let s2 = s * s;
            return alpha * clamp(0.03 / (1e-5 + s2 * s2), 1e-2, 3e3);
        }
        case 5u: {
            return alpha * max(1e-2, 3e3 * cube(1.0 - d));
        }
        case 6u: {
            let a = min(1.0, alpha) * 8.0 + 0.01;
            let b = 1.0 - 0.95 * d;
            return clamp(cube(a) * 1e8 * cube(b), 1e-2, 3e2);
        }
        default: {
            return wboit_weight_range(z, params.z_near, params.z_far, params.range_fall);
        }
    }
}

struct Outputs {
    @location(0) accum: vec4<f32>,
    @location(1) reveal: vec4<f32>,
}

// The weighted accumulation outputs of a kept fragment (the plain and the coloured pass).
fn weighted(v: VertexOut, s: Shaded) -> WboitAccum {
    let window_z = v.clip.z;
    var d = window_z;
    if params.reverse_z != 0u {
        d = 1.0 - window_z;
    }
    let z = wboit_view_distance(window_z, params.proj_a, params.proj_b, params.ortho != 0u);
    let w = weight(WBOIT_WEIGHT, z, d, s.alpha);
    var color_scale = params.color_scale;
    if WBOIT_UNIT_SCALE {
        color_scale = 1.0;
    }
    return wboit_accumulate(s.color, s.alpha, w, color_scale);
}

@fragment
fn fs_wboit(v: VertexOut, @builtin(front_facing) front_facing: bool) -> Outputs {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    let a = weighted(v, s);
    var out: Outputs;
    out.accum = a.accum;
    out.reveal = a.reveal;
    return out;
}

// Coloured transmission (McGuire & Mara 2015, G3D's layout): the two accumulation outputs of
// `fs_wboit` plus the final colour itself as a third target, blended (zero, one-minus-src) on
// colour only, so the opaque colour behind ends up multiplied by the exact per-channel product
// of the transmittances t (order-independent). The layers' radiance stays the weighted average
// under the scalar coverage 1 - mean(t); the composite then adds it without scaling the colour
// behind again.
struct ColouredOutputs {
    @location(0) accum: vec4<f32>,
    @location(1) reveal: vec4<f32>,
    @location(2) modulate: vec4<f32>,
}

fn modulation(s: Shaded) -> vec4<f32> {
    return vec4<f32>(vec3<f32>(1.0) - s.transmittance, 0.0);
}

@fragment
fn fs_wboit_coloured(v: VertexOut, @builtin(front_facing) front_facing: bool) -> ColouredOutputs {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    let a = weighted(v, s);
    var out: ColouredOutputs;
    out.accum = a.accum;
    out.reveal = a.reveal;
    out.modulate = modulation(s);
    return out;
}

// Weighted average: (sum C, sum alpha) and the fragment count n (additive into .r).
@fragment
fn fs_average(v: VertexOut, @builtin(front_facing) front_facing: bool) -> Outputs {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    var out: Outputs;
    out.accum = vec4<f32>(s.color, s.alpha);
    out.reveal = vec4<f32>(1.0, 0.0, 0.0, 0.0);
    return out;
}

@fragment
fn fs_average_coloured(v: VertexOut, @builtin(front_facing) front_facing: bool) -> ColouredOutputs {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    var out: ColouredOutputs;
    out.accum = vec4<f32>(s.color, s.alpha);
    out.reveal = vec4<f32>(1.0, 0.0, 0.0, 0.0);
    out.modulate = modulation(s);
    return out;
}

// Additive and subtractive fragments (P, alpha = 0, t = 1): a pass after the composite, over the
// final colour with (one, one) blending. The accumulation pass left them out, so their colour is
// not normalised with the over layers'. Each adds P times the visibility the composite gives an
// over layer at its depth: WBOIT's composite shows layer i as C_i * w_i * (1 - T) / sum(alpha w),
// which is the exact transmittance in front of it when w_i is that transmittance (then
// sum(alpha w) = 1 - T); the additive fragment gets the same factor with its own weight (alpha = 1 in
// the weight), at most 1. The weighted average has no depth: every layer is scaled by
// (1 - T) / sum(alpha), and so is the additive one. With no over layer in the pixel it is 1.
@group(2) @binding(0) var additive_accum: texture_2d<f32>;
@group(2) @binding(1) var additive_reveal: texture_2d<f32>;

fn additive_visibility(v: VertexOut) -> f32 {
    let xy = vec2<i32>(v.clip.xy);
    let acc = textureLoad(additive_accum, xy, 0);
    let r = textureLoad(additive_reveal, xy, 0).r;
    if params.average != 0u {
        // r: the fragment count n; acc.a: the sum of alpha.
        if !(r > 0.0) || !(acc.a > 0.0) {
            return 1.0;
        }
        let t = pow(clamp(1.0 - acc.a / r, 0.0, 1.0), r);
        return clamp((1.0 - t) / acc.a, 0.0, 1.0);
    }
    // r: the revealage T; acc.a: sum(alpha w).
    let t = clamp(r, 0.0, 1.0);
    if !(t < 1.0) {
        return 1.0;
    }
    if !(acc.a > 0.0) || acc.a > 3.0e38 {
        // Weights underflowed or overflowed: only the total transmittance is known.
        return t;
    }
    let window_z = v.clip.z;
    var d = window_z;
    if params.reverse_z != 0u {
        d = 1.0 - window_z;
    }
    let z = wboit_view_distance(window_z, params.proj_a, params.proj_b, params.ortho != 0u);
    let w = weight(params.weight, z, d, 1.0);
    return clamp(w * (1.0 - t) / acc.a, 0.0, 1.0);
}

@fragment
fn fs_additive(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    return vec4<f32>(s.color * additive_visibility(v), 0.0);
}
