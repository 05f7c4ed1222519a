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

// The cleared far depth (1, or 0 under reverse-Z).
override FAR_DEPTH: f32 = 1.0;

// `fs_blend` for a pass that tests depth with Equal against a pre-pass: a fragment exactly on
// the far plane is equal to the cleared depth the pre-pass could not beat, but is never
// visible (the far-plane rule: every other pass tests strictly nearer).
@fragment
fn fs_blend_equal(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep || v.clip.z == FAR_DEPTH {
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
