enable dual_source_blending;
// The A-buffer on scenes with coloured transmission (or packed nodes on scenes that subtract):
// nodes store rgb opacity (TRANSMIT of linked_list_node.wgsl) and the resolve puts the stack
// over the final colour per channel with dual-source blending, dst = C + T ⊙ dst (blend One,
// Src1), as linked_list_transmit.wgsl does for the lists.
#include "abuffer.wgsl"

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
