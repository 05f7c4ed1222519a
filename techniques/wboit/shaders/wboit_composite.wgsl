// Weighted blended OIT composite: one full-screen triangle over the final colour, with guards
// that keep the output finite and count how often each fires.
//
// Output (avg * (1 - T), T) with blending (one, src-alpha) gives avg * (1 - T) + dst * T.
// With coloured transmission the accumulation pass has already multiplied dst by the
// per-channel product of the transmittances, so the output is (avg * (1 - T), 1): dst is kept.

struct CompositeParams {
    // 0: weighted blended (reveal = prod(1 - alpha)); 1: weighted average (reveal = count n).
    mode: u32,
    // Largest finite value of the accumulation format (what an infinite channel becomes).
    accum_max: f32,
    // Largest average colour written (keeps the final target and its blend finite).
    out_max: f32,
    // Unit the colour sums were accumulated in (a power of two; 1 for LDR colours).
    color_scale: f32,
    // 1 when the accumulation pass modulated the final colour per channel (coloured
    // transmission): the colour behind is then not scaled by T again.
    background_modulated: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var accum_tex: texture_2d<f32>;
@group(0) @binding(1) var reveal_tex: texture_2d<f32>;
@group(0) @binding(2) var<uniform> params: CompositeParams;
@group(0) @binding(3) var<storage, read_write> guards: array<atomic<u32>, 264>;

// Guard counter slots (oit_wboit::GuardCounts reads them in this order).
const G_PIXELS: u32 = 0u;
const G_COVERED: u32 = 1u;
const G_ACCUM_OVERFLOW: u32 = 2u;
const G_ZERO_WEIGHT: u32 = 3u;
const G_AVERAGE_CLAMPED: u32 = 4u;
const G_REVEAL_CLAMPED: u32 = 5u;
const G_REVEAL_LOST: u32 = 6u;
const G_OPAQUE: u32 = 7u;

// `pixels` and `covered` change on (nearly) every pixel. With one counter each, bumped by
// every pixel, the composite took 1.6x as long on lavapipe (each atomic serialised per lane,
// its cache line bouncing between the threads that shade different tiles). So they are spread
// over SPREAD pairs of counters, one 64-byte line per pair, chosen by the pixel's 64x64 tile,
// and `pixels` is counted once per 2x2 block; oit_wboit::GuardCounts adds them up. The counts
// are the same.
const SPREAD: u32 = 16u;
const SPREAD_BASE: u32 = 8u;
const SPREAD_STRIDE: u32 = 16u;

fn spread_slot(xy: vec2<i32>) -> u32 {
    let tile = vec2<u32>(xy) >> vec2<u32>(6u);
    return SPREAD_BASE + ((tile.x + tile.y * 7u) % SPREAD) * SPREAD_STRIDE;
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

@fragment
fn fs_composite(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let xy = vec2<i32>(position.xy);
    var acc = textureLoad(accum_tex, xy, 0);
    let r = textureLoad(reveal_tex, xy, 0).r;
    let slot = spread_slot(xy);
    if ((xy.x | xy.y) & 1) == 0 {
        // This pixel's 2x2 block, cut by the target's edge.
        let size = vec2<i32>(textureDimensions(accum_tex));
        let block = min(vec2<i32>(2), size - xy);
        atomicAdd(&guards[slot + G_PIXELS], u32(block.x * block.y));
    }

    // Overflow shows as Inf (IEEE blending) or as the format's largest finite value (blenders
    // that saturate, as lavapipe does for fp16); both are counted.
    if overflowed(acc.r) || overflowed(acc.g) || overflowed(acc.b) || overflowed(acc.a) {
        atomicAdd(&guards[G_ACCUM_OVERFLOW], 1u);
        acc = vec4<f32>(finite_or(acc.r), finite_or(acc.g), finite_or(acc.b), finite_or(acc.a));
    }

    // Revealage T: stored directly, or (1 - sum alpha / n)^n for the weighted average.
    var t = 1.0;
    var reveal_bad = false;
    if params.mode == 0u {
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
        atomicAdd(&guards[G_REVEAL_CLAMPED], 1u);
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
            atomicAdd(&guards[G_REVEAL_LOST], 1u);
        }
        // Leaves the destination exactly as it is (0 + dst * 1).
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    atomicAdd(&guards[slot + G_COVERED], 1u);
    if t <= 0.0 {
        atomicAdd(&guards[G_OPAQUE], 1u);
    }

    var avg = vec3<f32>(0.0);
    if acc.a > 0.0 {
        avg = acc.rgb / acc.a * params.color_scale;
    } else {
        // Covered, but every weight underflowed to zero: the colour is unknown. Black (the
        // "darker than the inputs" underflow symptom) rather than a division by zero.
        atomicAdd(&guards[G_ZERO_WEIGHT], 1u);
    }
    let bad = non_finite(avg.r) || non_finite(avg.g) || non_finite(avg.b);
    if bad || max(avg.r, max(avg.g, avg.b)) > params.out_max || min(avg.r, min(avg.g, avg.b)) < 0.0 {
        atomicAdd(&guards[G_AVERAGE_CLAMPED], 1u);
        avg = vec3<f32>(finite_or(avg.r), finite_or(avg.g), finite_or(avg.b));
        avg = clamp(avg, vec3<f32>(0.0), vec3<f32>(params.out_max));
    }
    var behind = t;
    if params.background_modulated != 0u {
        behind = 1.0;
    }
    return vec4<f32>(avg * (1.0 - t), behind);
}
