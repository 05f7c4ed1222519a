// Weighted blended OIT composite: one full-screen triangle over the final colour, with guards
// that keep the output finite, and a compute pass that counts how often each guard fires.
//
// Output (avg * (1 - T), T) with blending (one, src-alpha) gives avg * (1 - T) + dst * T.
// With coloured transmission the accumulation pass has already multiplied dst by the
// per-channel product of the transmittances, so the output is (avg * (1 - T), 1): dst is kept.
//
// Both entry points run `composite_pixel`: `fs_composite` (the timed pass) keeps its colour and
// the compiler drops the guard bits; `cs_count_guards` (untimed, after it, over the same
// targets) keeps the bits and counts them. Counting with atomics inside the timed pass made it
// 2.7x as long on lavapipe (llvmpipe runs each atomic lane by lane): 2.56 -> 0.94 ms at 256²,
// 2026-12-07.

struct CompositeParams {
    // Largest finite value of the accumulation format (what an infinite channel becomes).
    accum_max: f32,
    // Largest average colour written (keeps the final target and its blend finite).
    out_max: f32,
    // Unit the colour sums were accumulated in (a power of two; 1 for LDR colours).
    color_scale: f32,
    pad0: u32,
}

// The weighted average (Bavoil & Myers: the revealage target holds the count n) rather than
// weighted blended (it holds T = prod(1 - alpha)): `oit_wboit::tail::CompositeMode`. A
// pipeline constant: llvmpipe runs both sides of a branch on a uniform under masks.
override AVERAGE: bool = false;
// The accumulation pass modulated the final colour per channel (coloured transmission): the
// colour behind is then not scaled by T again.
override BACKGROUND_MODULATED: bool = false;

@group(0) @binding(0) var accum_tex: texture_2d<f32>;
@group(0) @binding(1) var reveal_tex: texture_2d<f32>;
@group(0) @binding(2) var<uniform> params: CompositeParams;
@group(0) @binding(3) var<storage, read_write> guards: array<atomic<u32>, 8>;

// Guard counter slots (oit_wboit::GuardCounts reads them in this order); bit i of
// `Composited::guards` is slot i.
const G_PIXELS: u32 = 0u;
const G_COVERED: u32 = 1u;
const G_ACCUM_OVERFLOW: u32 = 2u;
const G_ZERO_WEIGHT: u32 = 3u;
const G_AVERAGE_CLAMPED: u32 = 4u;
const G_REVEAL_CLAMPED: u32 = 5u;
const G_REVEAL_LOST: u32 = 6u;
const G_OPAQUE: u32 = 7u;
const GUARD_COUNT: u32 = 8u;

fn bit(slot: u32) -> u32 {
    return 1u << slot;
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

// Exponent bits all set: Inf or NaN. Tested on the bits because WGSL lets compilers assume
// floats are finite, which may fold `x != x` away.
fn non_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) == 0x7f800000u;
}

fn is_nan(x: f32) -> bool {
    return non_finite(x) && (bitcast<u32>(x) & 0x007fffffu) != 0u;
}

fn overflowed(x: f32) -> bool {
    return non_finite(x) || abs(x) >= params.accum_max;
}

// +Inf -> accum_max, NaN and -Inf -> 0.
fn finite_or(x: f32) -> f32 {
    if !non_finite(x) {
        return x;
    }
    if is_nan(x) || x < 0.0 {
        return 0.0;
    }
    return params.accum_max;
}

// The composite's output for pixel `xy` and the guards that fired there.
struct Composited {
    color: vec4<f32>,
    guards: u32,
}

fn composite_pixel(xy: vec2<i32>) -> Composited {
    var acc = textureLoad(accum_tex, xy, 0);
    let r = textureLoad(reveal_tex, xy, 0).r;
    var fired = bit(G_PIXELS);

    // Overflow shows as Inf (IEEE blending) or as the format's largest finite value (blenders
    // that saturate, as lavapipe does for fp16); both are counted.
    if overflowed(acc.r) || overflowed(acc.g) || overflowed(acc.b) || overflowed(acc.a) {
        fired |= bit(G_ACCUM_OVERFLOW);
        acc = vec4<f32>(finite_or(acc.r), finite_or(acc.g), finite_or(acc.b), finite_or(acc.a));
    }

    // Revealage T: stored directly, or (1 - sum alpha / n)^n for the weighted average.
    var t = 1.0;
    var reveal_bad = false;
    if !AVERAGE {
        t = r;
        reveal_bad = non_finite(r) || r < 0.0 || r > 1.0;
    } else {
        let n = r;
        if non_finite(n) || n < 0.0 {
            reveal_bad = true;
        } else if n > 0.0 {
            let mean = acc.a / n;
            reveal_bad = mean < 0.0 || mean > 1.0;
            t = pow(clamp(1.0 - mean, 0.0, 1.0), n);
        }
    }
    if reveal_bad {
        fired |= bit(G_REVEAL_CLAMPED);
        if is_nan(t) {
            t = 0.0;
        }
        t = clamp(t, 0.0, 1.0);
    }

    let weighted = acc.a != 0.0 || acc.r != 0.0 || acc.g != 0.0 || acc.b != 0.0;
    if t >= 1.0 {
        if weighted {
            // Fragments were accumulated but the revealage never moved: their coverage is lost
            // (R8 revealage with alpha < 1/510), so they cannot show.
            fired |= bit(G_REVEAL_LOST);
        }
        // Leaves the destination exactly as it is (0 + dst * 1).
        return Composited(vec4<f32>(0.0, 0.0, 0.0, 1.0), fired);
    }
    fired |= bit(G_COVERED);
    if t <= 0.0 {
        fired |= bit(G_OPAQUE);
    }

    var avg = vec3<f32>(0.0);
    if acc.a > 0.0 {
        avg = acc.rgb / acc.a * params.color_scale;
    } else {
        // Covered, but every weight underflowed to zero: the colour is unknown. Black (the
        // "darker than the inputs" underflow symptom) rather than a division by zero.
        fired |= bit(G_ZERO_WEIGHT);
    }
    let bad = non_finite(avg.r) || non_finite(avg.g) || non_finite(avg.b);
    if bad || max(avg.r, max(avg.g, avg.b)) > params.out_max || min(avg.r, min(avg.g, avg.b)) < 0.0 {
        fired |= bit(G_AVERAGE_CLAMPED);
        avg = vec3<f32>(finite_or(avg.r), finite_or(avg.g), finite_or(avg.b));
        avg = clamp(avg, vec3<f32>(0.0), vec3<f32>(params.out_max));
    }
    var behind = t;
    if BACKGROUND_MODULATED {
        behind = 1.0;
    }
    return Composited(vec4<f32>(avg * (1.0 - t), behind), fired);
}

@fragment
fn fs_composite(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    return composite_pixel(vec2<i32>(position.xy)).color;
}

// Per-workgroup sums first, then one global atomic per counter and workgroup.
var<workgroup> group_counts: array<atomic<u32>, 8>;

@compute @workgroup_size(8, 8)
fn cs_count_guards(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    if local < GUARD_COUNT {
        atomicStore(&group_counts[local], 0u);
    }
    workgroupBarrier();
    let size = textureDimensions(accum_tex);
    if all(id.xy < size) {
        let fired = composite_pixel(vec2<i32>(id.xy)).guards;
        for (var slot = 0u; slot < GUARD_COUNT; slot++) {
            if (fired & bit(slot)) != 0u {
                atomicAdd(&group_counts[slot], 1u);
            }
        }
    }
    workgroupBarrier();
    if local < GUARD_COUNT {
        let n = atomicLoad(&group_counts[local]);
        if n != 0u {
            atomicAdd(&guards[local], n);
        }
    }
}
