// Averaging of `spp` stochastic frames (oit-stochastic). Frame k is combined with the result
// of frames 0..k (ping-pong between two textures, no blending needed): out = previous · a +
// frame · b. With Rgba32Float: a running sum (a = b = 1) and the last frame writes sum / spp
// into the final colour target. Where Rgba32Float cannot be rendered: a running mean in
// Rgba16Float (a = k/(k+1), b = 1/(k+1)).

struct Accumulate {
    previous_weight: f32,
    frame_weight: f32,
    // 0 for the first frame (no previous result to read).
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
    var out = textureLoad(frame_color, p, 0) * accumulate.frame_weight;
    if accumulate.has_previous != 0u {
        out = textureLoad(previous_sum, p, 0) * accumulate.previous_weight + out;
    }
    return out;
}
