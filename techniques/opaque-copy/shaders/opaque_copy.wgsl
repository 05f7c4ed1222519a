// opaque-copy: a transmissive surface filters the copy of the opaque pass's colour at its own
// pixel, out = C + t ⊙ copy (Babylon's refraction texture without an offset or blur).
#include "common.wgsl"

@group(1) @binding(0) var opaque_copy: texture_2d<f32>;

@fragment
fn fs_transmissive(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    let behind = textureLoad(opaque_copy, vec2<i32>(v.clip.xy), 0).rgb;
    return vec4<f32>(s.color + s.transmittance * behind, 1.0);
}
