// Front-to-back depth peeling (Everitt 2001). Per frame, `fs_opaque_bits` stores the bits of the
// visible opaque depth (an EQUAL-depth pass over the opaque draws). Pass k then draws every
// transparent fragment with the strictly-nearer depth test (depth written, target cleared to
// far), so the hardware keeps the nearest fragment the shader did not discard; the shader
// discards fragments not strictly in front of the opaque surface and not strictly behind the
// previous layer. Both depths come from R32Uint colour outputs (the f32 bits), not from depth
// textures or depth copies, which wgpu's GL backend cannot do; the pass has no storage writes.
#include "peel_common.wgsl"

// Bits of the previous layer's window depth (R32Uint: renderable everywhere, R32Float is not on GL).
@group(1) @binding(1) var prev_depth: texture_2d<u32>;

// Bits of the visible opaque surface's window depth (far where there is none).
@group(1) @binding(3) var opaque_depth: texture_2d<u32>;

// The first pass has no previous layer.
override FIRST_LAYER: bool = false;

fn nearer(a: f32, b: f32) -> bool {
    if SCENE_REVERSE_Z {
        return a > b;
    }
    return a < b;
}

struct LayerOut {
    // Premultiplied colour and alpha of the layer's fragment.
    @location(0) color: vec4<f32>,
    // Its window depth, the next pass's "previous layer".
    @location(1) depth: vec4<u32>,
}

// The fragment of this pass's layer, or a discard: not strictly in front of the opaque surface,
// not strictly behind the previous layer, or not kept by the material.
fn layer_fragment(v: VertexOut, front_facing: bool) -> Shaded {
    var shaded: Shaded;
    if !TEST_FIRST {
        shaded = shade(v, front_facing);
        if !shaded.keep {
            discard;
        }
    }
    let z = v.clip.z;
    let px = vec2<i32>(v.clip.xy);
    if !nearer(z, bitcast<f32>(textureLoad(opaque_depth, px, 0).x)) {
        discard;
    }
    if !FIRST_LAYER && !nearer(bitcast<f32>(textureLoad(prev_depth, px, 0).x), z) {
        discard;
    }
    if TEST_FIRST {
        shaded = shade(v, front_facing);
        if !shaded.keep {
            discard;
        }
    }
    return shaded;
}

@fragment
fn fs_layer(v: VertexOut, @builtin(front_facing) front_facing: bool) -> LayerOut {
    let shaded = layer_fragment(v, front_facing);
    var out: LayerOut;
    out.color = vec4<f32>(shaded.color, shaded.alpha);
    out.depth = vec4<u32>(bitcast<u32>(v.clip.z), 0u, 0u, 0u);
    return out;
}

struct LayerTransmitOut {
    // As LayerOut; alpha only marks "a fragment is here" (≥ 0).
    @location(0) color: vec4<f32>,
    @location(1) depth: vec4<u32>,
    // Per-channel transmittance (rgb), for the per-channel under pass (peel_transmit.wgsl).
    @location(2) transmittance: vec4<f32>,
}

// `fs_layer` on scenes with coloured transmission: the layer's rgb transmittance too.
@fragment
fn fs_layer_transmit(v: VertexOut, @builtin(front_facing) front_facing: bool) -> LayerTransmitOut {
    let shaded = layer_fragment(v, front_facing);
    var out: LayerTransmitOut;
    out.color = vec4<f32>(shaded.color, shaded.alpha);
    out.depth = vec4<u32>(bitcast<u32>(v.clip.z), 0u, 0u, 0u);
    out.transmittance = vec4<f32>(shaded.transmittance, 1.0);
    return out;
}

// The opaque draws again, depth-tested EQUAL against the shared opaque depth: the bits of the
// visible opaque depth per pixel.
@fragment
fn fs_opaque_bits(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<u32> {
    if !shade(v, front_facing).keep {
        discard;
    }
    return vec4<u32>(bitcast<u32>(v.clip.z), 0u, 0u, 0u);
}
