enable dual_source_blending;
// `blended` objects on scenes with coloured transmittance: dual-source blending computes
// dst = src0 + src1 ⊙ dst (src One, dst Src1) per channel, the reference's composite of one
// fragment; for scalar-alpha fragments src1 = 1 − α, what OneMinusSrcAlpha gives.
#include "common.wgsl"

struct TransmitOut {
    @location(0) @blend_src(0) color: vec4<f32>,
    @location(0) @blend_src(1) transmittance: vec4<f32>,
}

@fragment
fn fs_blend_transmit(v: VertexOut, @builtin(front_facing) front_facing: bool) -> TransmitOut {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    var out: TransmitOut;
    out.color = vec4<f32>(s.color, s.alpha);
    out.transmittance = vec4<f32>(s.transmittance, 1.0 - s.alpha);
    return out;
}
