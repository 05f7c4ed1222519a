// Front-to-back depth peeling (Everitt 2001): each pass keeps, per pixel, the nearest fragment
// strictly behind the previous pass's layer and strictly in front of the opaque surface (the
// hardware depth test against a depth target cleared to the far plane picks the nearest), and
// writes its premultiplied colour to a layer texture that peel_composite.wgsl under-blends.
#include "peel_common.wgsl"

@group(1) @binding(1) var prev_depth: texture_depth_2d;
@group(1) @binding(3) var opaque_depth: texture_depth_2d;
// Per pixel: candidates the counting pass saw (more than one means layers were left behind).
@group(1) @binding(4) var<storage, read_write> candidates: array<atomic<u32>>;

// The first pass has no previous layer.
override FIRST_LAYER: bool = false;
// The last recorded pass counts candidates per pixel (for pixels_with_dropped_layers).
override COUNT_CANDIDATES: bool = false;

fn nearer(a: f32, b: f32) -> bool {
    if peel.scene_reverse_z != 0u {
        return a > b;
    }
    return a < b;
}

@fragment
fn fs_layer(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    var shaded: Shaded;
    if !TEST_FIRST {
        shaded = shade(v, front_facing);
        if !shaded.keep {
            discard;
        }
    }
    let z = v.clip.z;
    let px = vec2<i32>(v.clip.xy);
    if !nearer(z, textureLoad(opaque_depth, px, 0)) {
        discard;
    }
    if !FIRST_LAYER && !nearer(textureLoad(prev_depth, px, 0), z) {
        discard;
    }
    if TEST_FIRST {
        shaded = shade(v, front_facing);
        if !shaded.keep {
            discard;
        }
    }
    mark_pass(pass_info.index);
    if COUNT_CANDIDATES {
        atomicAdd(&candidates[u32(px.y) * peel.width + u32(px.x)], 1u);
    }
    return vec4<f32>(shaded.color, shaded.alpha);
}
