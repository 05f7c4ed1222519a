enable dual_source_blending;
// Blended transparency with coloured transmittance: dual-source blending makes the blend unit
// compute dst = src0 + src1 ⊙ dst (src One, dst Src1), the reference's per-channel OVER. For a
// scalar-alpha fragment src1 = 1 − α, which is what OneMinusSrcAlpha gives.
#include "common.wgsl"

struct TransmitOut {
    @location(0) @blend_src(0) color: vec4<f32>,
    @location(0) @blend_src(1) transmittance: vec4<f32>,
}

fn transmit(s: Shaded) -> TransmitOut {
    var out: TransmitOut;
    out.color = vec4<f32>(s.color, s.alpha);
    out.transmittance = vec4<f32>(s.transmittance, 1.0 - s.alpha);
    return out;
}

@fragment
fn fs_blend_transmit(v: VertexOut, @builtin(front_facing) front_facing: bool) -> TransmitOut {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    return transmit(s);
}

// The cleared far depth (1, or 0 under reverse-Z).
override FAR_DEPTH: f32 = 1.0;

// `fs_blend_transmit` for the EQUAL-depth pass after a pre-pass (see blend.wgsl).
@fragment
fn fs_blend_transmit_equal(v: VertexOut, @builtin(front_facing) front_facing: bool) -> TransmitOut {
    let s = shade(v, front_facing);
    if !s.keep || v.clip.z == FAR_DEPTH {
        discard;
    }
    return transmit(s);
}
