// Blended transparency: premultiplied colour for OVER blending (src One, dst OneMinusSrcAlpha),
// and a depth-only entry for depth pre-passes that honours mask-blend discards.
#include "common.wgsl"

@fragment
fn fs_blend(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    return vec4<f32>(s.color, s.alpha);
}

@fragment
fn fs_depth_only(v: VertexOut, @builtin(front_facing) front_facing: bool) {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
}
