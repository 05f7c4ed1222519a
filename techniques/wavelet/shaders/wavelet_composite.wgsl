// Wavelet OIT composite: one full-screen triangle over the final colour. Total coverage is
// 1 - exp(-A_total), A_total the last cell's average (the exact sum of the pixel's
// absorbance, up to the coefficients' storage); the colour is pass 3's transmittance-weighted
// average acc.rgb / acc.a. Output (avg * (1 - T), T), blended (one, src-alpha).
#include "wavelet_math.wgsl"

override WAVELET_RANK: u32 = 3u;

@group(0) @binding(0) var accum_tex: texture_2d<f32>;
@group(0) @binding(1) var coefficients0: texture_2d<f32>;
@group(0) @binding(2) var coefficients1: texture_2d<f32>;
@group(0) @binding(3) var coefficients2: texture_2d<f32>;
@group(0) @binding(4) var coefficients3: texture_2d<f32>;
@group(0) @binding(5) var coefficients4: texture_2d<f32>;
@group(0) @binding(6) var coefficients5: texture_2d<f32>;
@group(0) @binding(7) var coefficients6: texture_2d<f32>;
@group(0) @binding(8) var coefficients7: texture_2d<f32>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

fn put(c: ptr<function, array<f32, 32>>, group: u32, v: vec4<f32>) {
    (*c)[4u * group] = v.x;
    (*c)[4u * group + 1u] = v.y;
    (*c)[4u * group + 2u] = v.z;
    (*c)[4u * group + 3u] = v.w;
}

@fragment
fn fs_composite(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let xy = vec2<i32>(position.xy);
    let acc = textureLoad(accum_tex, xy, 0);
    // No fragment was shaded here (or its weights underflowed): the destination stays.
    if !(acc.a > 0.0) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    var c: array<f32, 32>;
    let groups = wavelet_coefficient_count(WAVELET_RANK) / 4u;
    put(&c, 0u, textureLoad(coefficients0, xy, 0));
    put(&c, 1u, textureLoad(coefficients1, xy, 0));
    if groups > 2u {
        put(&c, 2u, textureLoad(coefficients2, xy, 0));
        put(&c, 3u, textureLoad(coefficients3, xy, 0));
    }
    if groups > 4u {
        put(&c, 4u, textureLoad(coefficients4, xy, 0));
        put(&c, 5u, textureLoad(coefficients5, xy, 0));
        put(&c, 6u, textureLoad(coefficients6, xy, 0));
        put(&c, 7u, textureLoad(coefficients7, xy, 0));
    }
    let t = wavelet_transmittance(wavelet_total_absorbance(&c, WAVELET_RANK));
    return vec4<f32>(acc.rgb / acc.a * (1.0 - t), t);
}
