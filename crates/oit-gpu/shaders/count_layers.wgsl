// Sizing for the stored-fragment techniques: the transparent fragments their insert pass stores
// (kept by `shade`, strictly nearer than the opaque depth; the test is the shader's own, as in
// their insert passes, which have no depth attachment), counted per pixel. The deepest pixel
// and the total go to `summary`, which is all the CPU reads back.
#include "common.wgsl"

struct CountParams {
    width: u32,
    // 1 when window depth 1 is near.
    reverse_z: u32,
    pad0: u32,
    pad1: u32,
}

@group(1) @binding(0) var<uniform> params: CountParams;
@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;
// [0] the most fragments in one pixel; [1] and [2] the total, low and high word.
@group(1) @binding(2) var<storage, read_write> summary: array<atomic<u32>, 4>;
@group(1) @binding(3) var opaque_depth: texture_2d<f32>;

@fragment
fn fs_count_layers(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    let px = vec2<u32>(v.clip.xy);
    let z = v.clip.z;
    let opaque = textureLoad(opaque_depth, px, 0).x;
    var in_front = z < opaque;
    if params.reverse_z != 0u {
        in_front = z > opaque;
    }
    if !s.keep || !in_front {
        discard;
    }
    let n = atomicAdd(&counts[px.y * params.width + px.x], 1u) + 1u;
    atomicMax(&summary[0], n);
    if atomicAdd(&summary[1], 1u) == 0xFFFFFFFFu {
        atomicAdd(&summary[2], 1u);
    }
    // Nothing is written to the attachment (its write mask is empty).
    return vec4<f32>(0.0);
}
