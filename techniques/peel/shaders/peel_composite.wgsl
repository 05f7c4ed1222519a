// Full-screen passes of depth peeling: under-blend one peeled layer into the front accumulator
// (front-to-back peeling) and composite the front accumulator over the final colour.
//
// The front accumulator holds (Σ C_i T_i, T) with T the transmittance so far, cleared to
// (0, 0, 0, 1). Under blending: colour src·DstAlpha + dst, alpha dst·(1 − src.a).

#include "peel_counters.wgsl"

@group(0) @binding(0) var source: texture_2d<f32>;
// The pass group (oit-peel's Control).
@group(1) @binding(0) var<uniform> pass_info: PassInfo;
@group(1) @binding(1) var<storage, read_write> counters: array<atomic<u32>>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

// One peeled layer (alpha < 0 marks "no fragment here"), under-blended. The scan after it
// (`cs_scan_layer`, peel_gate.wgsl) counts the layer and flags "layer i exists".
@fragment
fn fs_under(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let layer = textureLoad(source, vec2<i32>(p.xy), 0);
    if layer.a < 0.0 {
        discard;
    }
    return layer;
}

// The front accumulator over the final colour: blend src + dst·SrcAlpha gives F + T·C_behind.
@fragment
fn fs_front(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return textureLoad(source, vec2<i32>(p.xy), 0);
}
