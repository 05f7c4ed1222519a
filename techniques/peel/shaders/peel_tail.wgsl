// Dual depth peeling's `tail=wboit`: the fragments still inside the key range after the last
// peel pass (the middle layers) accumulated with weighted blended OIT (oit_wboit::tail), to be
// composited between the peeled back layers and the front accumulator.
#include "peel_common.wgsl"
#include "wboit_tail.wgsl"

@group(1) @binding(1) var last_range: texture_2d<f32>;

struct TailOut {
    @location(0) accum: vec4<f32>,
    @location(1) reveal: vec4<f32>,
}

@fragment
fn fs_tail(v: VertexOut, @builtin(front_facing) front_facing: bool) -> TailOut {
    let s = peel_key(v.clip.z);
    let range = textureLoad(last_range, vec2<i32>(v.clip.xy), 0).xy;
    if s < -range.x || s > range.y {
        discard;
    }
    let shaded = shade(v, front_facing);
    if !shaded.keep {
        discard;
    }
    let z = v.clip.z;
    let w = wboit_weight_default(wboit_view_distance_default(z), z, shaded.alpha);
    let a = wboit_accumulate(shaded.color, shaded.alpha, w, wboit_color_scale);
    var out: TailOut;
    out.accum = a.accum;
    out.reveal = a.reveal;
    return out;
}
