// Averaging of `spp` stochastic frames (oit-stochastic): frame k's colour is added to the
// running f32 sum of frames 0..k (ping-pong between two Rgba32Float textures, no blending
// needed), and the last frame writes sum / spp into the final colour target.

struct Accumulate {
    // 1 while summing; 1/spp for the last frame.
    scale: f32,
    // 0 for the first frame (no previous sum to read).
    has_previous: u32,
}

@group(0) @binding(0) var frame_color: texture_2d<f32>;
@group(0) @binding(1) var previous_sum: texture_2d<f32>;
@group(0) @binding(2) var<uniform> accumulate: Accumulate;

// One triangle covering the viewport.
@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(i & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs_accumulate(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let p = vec2<i32>(position.xy);
    var sum = textureLoad(frame_color, p, 0);
    if accumulate.has_previous != 0u {
        sum = textureLoad(previous_sum, p, 0) + sum;
    }
    return sum * accumulate.scale;
}
