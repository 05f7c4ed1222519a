// Dual depth peeling (Bavoil & Myers 2008) with the peel range test before shading.
//
// The range target holds (-min key, max key) of the fragments still to peel, MAX-blended, cleared
// to EMPTY. Each peel pass reads the previous range: fragments outside it were peeled already
// and are discarded before any shading; a fragment on the near shell is under-blended into the
// front accumulator, one on the far shell is over-blended into the back accumulator (or onto
// the final colour), and one strictly inside writes its key for the next pass.
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

// What this pass does with a fragment inside the previous range (the others are discarded).
struct Peeled {
    // Strictly inside the range: only its key goes on, to the next pass's range.
    inside: bool,
    key: f32,
    // On the near shell (under-blended in front), else on the far shell (over-blended behind).
    near: bool,
    // The material's answer (peeled fragments only).
    shaded: Shaded,
}

fn peel_fragment(v: VertexOut, front_facing: bool) -> Peeled {
    var p: Peeled;
    if !TEST_FIRST {
        p.shaded = shade(v, front_facing);
        if !p.shaded.keep {
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
    p.key = s;
    if s != near && s != far {
        // Still inside: only coverage decides whether it is left for the next pass.
        if TEST_FIRST && !shade(v, front_facing).keep {
            discard;
        }
        p.inside = true;
        mark_pass(pass_info.index);
        return p;
    }
    if TEST_FIRST {
        p.shaded = shade(v, front_facing);
        if !p.shaded.keep {
            discard;
        }
    }
    // A single remaining layer (near == far) is peeled once, as a front layer.
    p.inside = false;
    p.near = s == near;
    atomicAdd(&counters[peeled_word(pass_info.index)], 1u);
    return p;
}

@fragment
fn fs_peel(v: VertexOut, @builtin(front_facing) front_facing: bool) -> PeelOut {
    let p = peel_fragment(v, front_facing);
    var out: PeelOut;
    out.range = vec2<f32>(EMPTY, EMPTY);
    out.front = vec4<f32>(0.0);
    out.back = vec4<f32>(0.0);
    if p.inside {
        out.range = vec2<f32>(-p.key, p.key);
    } else if p.near {
        out.front = vec4<f32>(p.shaded.color, p.shaded.alpha);
    } else {
        out.back = vec4<f32>(p.shaded.color, p.shaded.alpha);
    }
    return out;
}

// Scenes with coloured transmission: one under accumulator and one over accumulator per colour
// channel (peel_transmit.wgsl), each written (C_c, 0, 0, t_c); (0, 0, 0, 1) leaves it unchanged.
struct PeelTransmitOut {
    @location(0) range: vec2<f32>,
    @location(1) front_r: vec4<f32>,
    @location(2) front_g: vec4<f32>,
    @location(3) front_b: vec4<f32>,
    @location(4) back_r: vec4<f32>,
    @location(5) back_g: vec4<f32>,
    @location(6) back_b: vec4<f32>,
}

@fragment
fn fs_peel_transmit(v: VertexOut, @builtin(front_facing) front_facing: bool) -> PeelTransmitOut {
    let p = peel_fragment(v, front_facing);
    let none = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    var out: PeelTransmitOut;
    out.range = vec2<f32>(EMPTY, EMPTY);
    out.front_r = none;
    out.front_g = none;
    out.front_b = none;
    out.back_r = none;
    out.back_g = none;
    out.back_b = none;
    if p.inside {
        out.range = vec2<f32>(-p.key, p.key);
        return out;
    }
    let c = p.shaded.color;
    let t = p.shaded.transmittance;
    let r = vec4<f32>(c.r, 0.0, 0.0, t.r);
    let g = vec4<f32>(c.g, 0.0, 0.0, t.g);
    let b = vec4<f32>(c.b, 0.0, 0.0, t.b);
    if p.near {
        out.front_r = r;
        out.front_g = g;
        out.front_b = b;
    } else {
        out.back_r = r;
        out.back_g = g;
        out.back_b = b;
    }
    return out;
}
