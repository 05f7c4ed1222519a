// Rasterization conformance: counts every fragment that survives face culling and the mask
// cutoff, with no depth test, into one u32 per pixel.
#include "common.wgsl"

struct Target {
    width: u32,
    height: u32,
}

@group(1) @binding(0) var<uniform> target_size: Target;
@group(1) @binding(1) var<storage, read_write> counts: array<atomic<u32>>;

@fragment
fn fs_count(v: VertexOut, @builtin(front_facing) front_facing: bool) {
    let s = shade(v, front_facing);
    // Count before (instead of) discarding: a discarded invocation may not write storage.
    if s.keep {
        let x = u32(v.clip.x);
        let y = u32(v.clip.y);
        atomicAdd(&counts[y * target_size.width + x], 1u);
    } else {
        discard;
    }
}
