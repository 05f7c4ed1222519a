// Moment-based OIT geometry passes, both depth-tested strictly nearer than the opaque depth
// without depth writes, additive (one, one) blending:
// - fs_moments (pass 1): b0 = sum A and A times the moments of the warped depth, A = -ln(1 - alpha)
//   clamped to 10, into an R target (b0), an RGBA target (4 floats) and, for 6 and 8 moments, an
//   RG or RGBA target (the rest);
// - fs_resolve (pass 2): reads the pixel's moments (textureLoad), reconstructs the
//   transmittance T in front of the fragment and adds (premultiplied colour * T, alpha * T).
#include "common.wgsl"
#include "mboit_math.wgsl"

// oit_mboit::MomentKind::index: 0 power4, 1 power6, 2 power8, 3 trig2, 4 trig3, 5 trig4.
override MBOIT_KIND: u32 = 1u;

struct MboitParams {
    // Projection terms that turn window depth back into view distance (a = proj[2][2],
    // b = proj[3][2]); ortho = 1 for an orthographic camera.
    proj_a: f32,
    proj_b: f32,
    ortho: u32,
    moment_bias: f32,
    // Log depth warp: z' = (ln z - ln_z_min) * warp_scale - 1.
    ln_z_min: f32,
    warp_scale: f32,
    overestimation: f32,
    pad: f32,
    // Power moments: the bias vector for b1..b8.
    bias_lo: vec4<f32>,
    bias_hi: vec4<f32>,
    // (theta, pi - theta / 2, 1 / (7 - b), 1 - 7 / (7 - b)), see oit_mboit::math.
    wrapping: vec4<f32>,
}

@group(1) @binding(0) var<uniform> params: MboitParams;
@group(2) @binding(0) var b0_tex: texture_2d<f32>;
@group(2) @binding(1) var moments_lo_tex: texture_2d<f32>;
@group(2) @binding(2) var moments_hi_tex: texture_2d<f32>;

fn view_distance(window_z: f32) -> f32 {
    if params.ortho != 0u {
        return (params.proj_b - window_z) / params.proj_a;
    }
    return params.proj_b / (window_z + params.proj_a);
}

fn warped_depth(window_z: f32) -> f32 {
    return mboit_warp(view_distance(window_z), params.ln_z_min, params.warp_scale);
}

struct Moments {
    @location(0) b0: vec4<f32>,
    @location(1) lo: vec4<f32>,
    @location(2) hi: vec4<f32>,
}

@fragment
fn fs_moments(v: VertexOut, @builtin(front_facing) front_facing: bool) -> Moments {
    let s = shade(v, front_facing);
    let a = mboit_absorbance(s.alpha);
    if !s.keep || a < 0.0 {
        discard;
    }
    let b = mboit_fragment_moments(MBOIT_KIND, warped_depth(v.clip.z), a, params.wrapping);
    var out: Moments;
    out.b0 = vec4<f32>(a, 0.0, 0.0, 0.0);
    out.lo = vec4<f32>(b[0], b[1], b[2], b[3]);
    out.hi = vec4<f32>(b[4], b[5], b[6], b[7]);
    return out;
}

@fragment
fn fs_resolve(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep || mboit_absorbance(s.alpha) < 0.0 {
        discard;
    }
    let xy = vec2<i32>(v.clip.xy);
    let b0 = textureLoad(b0_tex, xy, 0).r;
    if b0 < MBOIT_MIN_B0 {
        discard;
    }
    let lo = textureLoad(moments_lo_tex, xy, 0);
    let hi = textureLoad(moments_hi_tex, xy, 0);
    let b = array<f32, 8>(lo.x, lo.y, lo.z, lo.w, hi.x, hi.y, hi.z, hi.w);
    let bias = array<f32, 8>(
        params.bias_lo.x, params.bias_lo.y, params.bias_lo.z, params.bias_lo.w,
        params.bias_hi.x, params.bias_hi.y, params.bias_hi.z, params.bias_hi.w,
    );
    let t = mboit_transmittance_at(MBOIT_KIND, b0, b, warped_depth(v.clip.z), params.moment_bias, bias, params.overestimation, params.wrapping);
    return vec4<f32>(s.color * t, s.alpha * t);
}

// Additive and subtractive fragments (P, alpha = 0, t = 1), pass 3, after the composite: they add
// nothing to the moments and are left out of pass 2, so their colour is not normalised with the
// over layers'. Each adds P times the transmittance the moments reconstruct in front of it
// (1 where the pixel has no absorbance), over the final colour with (one, one) blending.
@fragment
fn fs_additive(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    let xy = vec2<i32>(v.clip.xy);
    let b0 = textureLoad(b0_tex, xy, 0).r;
    var t = 1.0;
    if b0 >= MBOIT_MIN_B0 {
        let lo = textureLoad(moments_lo_tex, xy, 0);
        let hi = textureLoad(moments_hi_tex, xy, 0);
        let b = array<f32, 8>(lo.x, lo.y, lo.z, lo.w, hi.x, hi.y, hi.z, hi.w);
        let bias = array<f32, 8>(
            params.bias_lo.x, params.bias_lo.y, params.bias_lo.z, params.bias_lo.w,
            params.bias_hi.x, params.bias_hi.y, params.bias_hi.z, params.bias_hi.w,
        );
        t = mboit_transmittance_at(MBOIT_KIND, b0, b, warped_depth(v.clip.z), params.moment_bias, bias, params.overestimation, params.wrapping);
    }
    return vec4<f32>(s.color * t, 0.0);
}
