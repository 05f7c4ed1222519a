// Dual depth peeling (Bavoil & Myers 2008) with the peel range test before shading.
//
// The range target holds (-min key, max key) of the fragments still to peel, MAX-blended, cleared
// to EMPTY. Each peel pass reads the previous range: fragments outside it were peeled already
// and are discarded before any shading; a fragment on the near shell is under-blended into the
// front accumulator, one on the far shell is over-blended straight onto the final colour, and
// one strictly inside writes its key for the next pass.
#include "peel_common.wgsl"

@group(1) @binding(1) var prev_range: texture_2d<f32>;

// Identity of MAX blending for keys in [0, 1]: "nothing left".
const EMPTY: f32 = -2.0;

// Init pass: no material colour, only coverage (mask-blend cutoff, face rule), depth-tested
// against the opaque depth. Writes the key range of every visible transparent fragment.
@fragment
fn fs_init(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec2<f32> {
    if !shade(v, front_facing).keep {
        discard;
    }
    let s = peel_key(v.clip.z);
    mark_pass(pass_info.index);
    return vec2<f32>(-s, s);
}

struct PeelOut {
    @location(0) range: vec2<f32>,
    @location(1) front: vec4<f32>,
    @location(2) back: vec4<f32>,
}

@fragment
fn fs_peel(v: VertexOut, @builtin(front_facing) front_facing: bool) -> PeelOut {
    var shaded: Shaded;
    if !TEST_FIRST {
        shaded = shade(v, front_facing);
        if !shaded.keep {
            discard;
        }
    }
    let s = peel_key(v.clip.z);
    let prev = textureLoad(prev_range, vec2<i32>(v.clip.xy), 0).xy;
    let lo = -prev.x;
    let hi = prev.y;
    if s < lo || s > hi {
        discard;
    }
    var near = lo;
    var far = hi;
    if KEY_REVERSE {
        near = hi;
        far = lo;
    }
    var out: PeelOut;
    out.range = vec2<f32>(EMPTY, EMPTY);
    out.front = vec4<f32>(0.0);
    out.back = vec4<f32>(0.0);
    if s != near && s != far {
        // Still inside: only coverage decides whether it is left for the next pass.
        if TEST_FIRST && !shade(v, front_facing).keep {
            discard;
        }
        out.range = vec2<f32>(-s, s);
        mark_pass(pass_info.index);
        return out;
    }
    if TEST_FIRST {
        shaded = shade(v, front_facing);
        if !shaded.keep {
            discard;
        }
    }
    // A single remaining layer (near == far) is peeled once, as a front layer.
    if s == near {
        out.front = vec4<f32>(shaded.color, shaded.alpha);
    } else {
        out.back = vec4<f32>(shaded.color, shaded.alpha);
    }
    atomicAdd(&counters[peeled_word(pass_info.index)], 1u);
    return out;
}
