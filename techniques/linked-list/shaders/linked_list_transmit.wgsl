enable dual_source_blending;
// The linked list on scenes with coloured transmission: nodes store rgb opacity (TRANSMIT, see
// linked_list_node.wgsl) and the resolve puts the stack over the final colour per channel with
// dual-source blending, dst = C + T ⊙ dst (blend One, Src1). The resolve has one target, which
// dual-source blending requires.
#include "linked_list.wgsl"

struct TransmitOut {
    @location(0) @blend_src(0) color: vec4<f32>,
    @location(0) @blend_src(1) transmittance: vec4<f32>,
}

@fragment
fn fs_resolve_transmit(@builtin(position) position: vec4<f32>) -> TransmitOut {
    let r = resolve_pixel(position);
    let t = r.transmittance;
    let mean = (t.r + t.g + t.b) * (1.0 / 3.0);
    var out: TransmitOut;
    out.color = vec4<f32>(r.color, 1.0 - mean);
    out.transmittance = vec4<f32>(t, mean);
    return out;
}
