// Wavelet OIT geometry passes, all depth-tested strictly nearer than the opaque depth without
// depth writes:
// - fs_range (pass 1): (-z, z) of the fragment's view distance, MAX-blended into an RG32F
//   target: the pixel's transparent interval [z_min, z_max], which normalises depth;
// - fs_coefficients (pass 2, once per group of targets the adapter can write at once): the
//   Haar coefficients of the fragment's absorbance step, four per RGBA target, additive;
// - fs_shade (pass 3): reads the pixel's coefficients, reconstructs the absorbance in front of
//   the fragment with its own step taken out, adds (premultiplied colour * T, alpha * T);
// - fs_additive (after the composite, scenes with add/subtract operators only).
#include "common.wgsl"
#include "wavelet_math.wgsl"
#include "wavelet_coefficients.wgsl"

// Rank 2, 3 or 4: N = 2^(rank + 1) coefficients in N / 4 RGBA targets.
override WAVELET_RANK: u32 = 3u;
// Pass 2: the first target (group of four coefficients) this pipeline writes at location 0.
override WAVELET_FIRST_GROUP: u32 = 0u;

struct WaveletParams {
    // Projection terms that turn window depth back into view distance (a = proj[2][2],
    // b = proj[3][2]); ortho = 1 for an orthographic camera.
    proj_a: f32,
    proj_b: f32,
    ortho: u32,
    pad: u32,
}

@group(1) @binding(0) var<uniform> params: WaveletParams;
@group(2) @binding(0) var range_tex: texture_2d<f32>;

fn view_distance(window_z: f32) -> f32 {
    if params.ortho != 0u {
        return (params.proj_b - window_z) / params.proj_a;
    }
    return params.proj_b / (window_z + params.proj_a);
}

// The fragment's depth normalised into its pixel's transparent interval.
fn pixel_depth(xy: vec2<i32>, window_z: f32) -> f32 {
    let range = textureLoad(range_tex, xy, 0);
    return wavelet_normalized_depth(view_distance(window_z), -range.x, range.y);
}

@fragment
fn fs_range(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep || wavelet_absorbance(s.alpha) < 0.0 {
        discard;
    }
    let z = view_distance(v.clip.z);
    return vec4<f32>(-z, z, 0.0, 0.0);
}

fn group_of(c: ptr<function, array<f32, 32>>, location: u32) -> vec4<f32> {
    let g = WAVELET_FIRST_GROUP + location;
    if g >= wavelet_coefficient_count(WAVELET_RANK) / 4u {
        return vec4<f32>(0.0);
    }
    return vec4<f32>((*c)[4u * g], (*c)[4u * g + 1u], (*c)[4u * g + 2u], (*c)[4u * g + 3u]);
}

struct Coefficients {
    @location(0) g0: vec4<f32>,
    @location(1) g1: vec4<f32>,
    @location(2) g2: vec4<f32>,
    @location(3) g3: vec4<f32>,
    @location(4) g4: vec4<f32>,
    @location(5) g5: vec4<f32>,
    @location(6) g6: vec4<f32>,
    @location(7) g7: vec4<f32>,
}

@fragment
fn fs_coefficients(v: VertexOut, @builtin(front_facing) front_facing: bool) -> Coefficients {
    let s = shade(v, front_facing);
    let a = wavelet_absorbance(s.alpha);
    if !s.keep || a < 0.0 {
        discard;
    }
    var c: array<f32, 32>;
    wavelet_project(&c, WAVELET_RANK, a, pixel_depth(vec2<i32>(v.clip.xy), v.clip.z));
    var out: Coefficients;
    out.g0 = group_of(&c, 0u);
    out.g1 = group_of(&c, 1u);
    out.g2 = group_of(&c, 2u);
    out.g3 = group_of(&c, 3u);
    out.g4 = group_of(&c, 4u);
    out.g5 = group_of(&c, 5u);
    out.g6 = group_of(&c, 6u);
    out.g7 = group_of(&c, 7u);
    return out;
}

@fragment
fn fs_shade(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    let a = wavelet_absorbance(s.alpha);
    if !s.keep || a < 0.0 {
        discard;
    }
    let xy = vec2<i32>(v.clip.xy);
    var c = load_coefficients(WAVELET_RANK, xy);
    let t = wavelet_transmittance(wavelet_absorbance_before(&c, WAVELET_RANK, pixel_depth(xy, v.clip.z), a));
    return vec4<f32>(s.color * t, s.alpha * t);
}

// Additive and subtractive fragments (P, alpha = 0, t = 1), after the composite: they add no
// absorbance and are left out of passes 1-3. Each adds P times the transmittance the
// coefficients reconstruct in front of it (its depth clamped into the pixel's interval; 1
// where the pixel has no absorbance), with (one, one) blending.
@fragment
fn fs_additive(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    let xy = vec2<i32>(v.clip.xy);
    var c = load_coefficients(WAVELET_RANK, xy);
    let t = wavelet_transmittance(wavelet_absorbance_at(&c, WAVELET_RANK, pixel_depth(xy, v.clip.z)));
    return vec4<f32>(s.color * t, 0.0);
}
