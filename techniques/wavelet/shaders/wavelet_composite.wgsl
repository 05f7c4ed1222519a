// Wavelet OIT composite: one full-screen triangle over the final colour. Total coverage is
// 1 - exp(-A_total), A_total the last cell's average (the exact sum of the pixel's
// absorbance, up to the coefficients' storage); the colour is pass 3's transmittance-weighted
// average acc.rgb / acc.a. Output (avg * (1 - T), T), blended (one, src-alpha).
#include "wavelet_math.wgsl"
#include "wavelet_coefficients.wgsl"

override WAVELET_RANK: u32 = 3u;

// Group 2 as in the geometry passes, so both include wavelet_coefficients.wgsl.
@group(2) @binding(0) var accum_tex: texture_2d<f32>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs_composite(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let xy = vec2<i32>(position.xy);
    let acc = textureLoad(accum_tex, xy, 0);
    // No fragment was shaded here (or its weights underflowed): the destination stays.
    if !(acc.a > 0.0) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    var c = load_coefficients(WAVELET_RANK, xy);
    let t = wavelet_transmittance(wavelet_total_absorbance(&c, WAVELET_RANK));
    return vec4<f32>(acc.rgb / acc.a * (1.0 - t), t);
}
