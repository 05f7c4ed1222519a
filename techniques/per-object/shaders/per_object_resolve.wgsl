// pygfx's weighted resolve (engine/blender.py `perform_weighted_resolve_pass`): after a run of
// weighted objects, one full-screen triangle writes the weighted average colour with coverage
// 1 − reveal, premultiplied, blended One + (1 − src α) over the colour target.

@group(0) @binding(0) var accum_texture: texture_2d<f32>;
@group(0) @binding(1) var reveal_texture: texture_2d<f32>;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs_resolve(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(position.xy);
    let accum = textureLoad(accum_texture, pixel, 0);
    let reveal = textureLoad(reveal_texture, pixel, 0).r;
    // No weighted fragment here: leave the colour as it is.
    if reveal >= 1.0 {
        discard;
    }
    let average = accum.rgb / max(accum.a, 1e-6);
    let coverage = 1.0 - reveal;
    return vec4<f32>(average * coverage, coverage);
}
