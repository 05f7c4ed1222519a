// Dual depth peeling (Bavoil & Myers 2008) with the peel range test before shading.
//
// The range target holds (-min key, max key) of the fragments still to peel, MAX-blended, cleared
// to EMPTY. Each peel pass reads the previous range: fragments outside it were peeled already
// and are discarded before any shading; a fragment on the near shell is under-blended into the
// front accumulator, one on the far shell is over-blended into the back accumulator (or onto
// the final colour), and one strictly inside writes its key for the next pass.
//
// No pass touches the counters per fragment: after each pass a compute pass (`cs_scan_range`,
// peel_gate.wgsl) reads the range it wrote (anything left for the next pass?) and the count
// target (fragments peeled). On lavapipe an atomic in these fragment stages, even a load that
// almost never stores, took 40 % of every pass (2026-12-07, many-layers-64 at 128²: init 9.5 ->
// 3.4 ms, peel 15.5 -> 9.0 ms without them).
#include "peel_common.wgsl"

@group(1) @binding(1) var prev_range: texture_2d<f32>;

// Identity of MAX blending for keys in [0, 1]: "nothing left".
const EMPTY: f32 = -2.0;

// True where the adapter has no room for the count target (`oit_peel` falls back when a
// fourth colour attachment does not fit): each peeled fragment then counts itself atomically.
override COUNT_ATOMIC: bool = false;

// Init pass: no material colour, only coverage (mask-blend cutoff, face rule), depth-tested
// against the opaque depth. Writes the key range of every visible transparent fragment.
@fragment
fn fs_init(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec2<f32> {
    if !shade(v, front_facing).keep {
        discard;
    }
    let s = peel_key(v.clip.z);
    return vec2<f32>(-s, s);
}

struct PeelOut {
    @location(0) range: vec2<f32>,
    @location(1) front: vec4<f32>,
    @location(2) back: vec4<f32>,
    // 1 for a peeled fragment (additive into R32Float: this pass's peeled count per pixel).
    @location(3) peeled: vec4<f32>,
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
    return p;
}

// Counts one peeled fragment in the pass's counter (the paths without a count target).
fn count_peeled_atomically() {
    atomicAdd(&counters[peeled_word(pass_info.index)], 1u);
}

@fragment
fn fs_peel(v: VertexOut, @builtin(front_facing) front_facing: bool) -> PeelOut {
    let p = peel_fragment(v, front_facing);
    var out: PeelOut;
    out.range = vec2<f32>(EMPTY, EMPTY);
    out.front = vec4<f32>(0.0);
    out.back = vec4<f32>(0.0);
    out.peeled = vec4<f32>(0.0);
    if p.inside {
        out.range = vec2<f32>(-p.key, p.key);
        return out;
    }
    if COUNT_ATOMIC {
        count_peeled_atomically();
    }
    out.peeled.x = 1.0;
    if p.near {
        out.front = vec4<f32>(p.shaded.color, p.shaded.alpha);
    } else {
        out.back = vec4<f32>(p.shaded.color, p.shaded.alpha);
    }
    return out;
}

// Scenes with coloured transmission: one under accumulator and one over accumulator per colour
// channel (peel_transmit.wgsl), each written (C_c, 0, 0, t_c); (0, 0, 0, 1) leaves it unchanged.
// Seven targets leave no room for a count target: peeled fragments are counted atomically.
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
    count_peeled_atomically();
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
