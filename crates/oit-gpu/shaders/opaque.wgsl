// Shared opaque pass: opaque and mask draws write colour and depth.
#include "common.wgsl"

@fragment
fn fs_opaque(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    return vec4<f32>(s.color, 1.0);
}
