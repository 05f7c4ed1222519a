// Moment-based OIT composite: one full-screen triangle over the final colour. Total coverage is
// 1 - exp(-b0) (exact: absorbance adds), the colour is the transmittance-weighted average
// acc.rgb / acc.a of pass 2. Output (avg * (1 - T), T) with T = exp(-b0), blended
// (one, src-alpha): avg * (1 - T) + dst * T, the published
// (src-alpha, one-minus-src-alpha) rule in this project's TRANSMITTANCE_OVER form.

@group(0) @binding(0) var b0_tex: texture_2d<f32>;
@group(0) @binding(1) var accum_tex: texture_2d<f32>;

const MBOIT_MIN_B0: f32 = 0.00100050033;

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs_composite(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let xy = vec2<i32>(position.xy);
    let b0 = textureLoad(b0_tex, xy, 0).r;
    let acc = textureLoad(accum_tex, xy, 0);
    // Pass 2 skipped these pixels (at most 0.1 % coverage): the destination stays as it is.
    if !(b0 >= MBOIT_MIN_B0) || !(acc.a > 0.0) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let t = exp(-b0);
    return vec4<f32>(acc.rgb / acc.a * (1.0 - t), t);
}
