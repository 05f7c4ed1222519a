// SLAB, stochastic layered alpha blending (Wyman, HPG 2016), in an order-independent form: the
// k-buffer's K nearest fragments per pixel exact, the fragments behind them composited as
// stochastic transparency (Enderton, Sintorn, Shirley & Luebke 2010) over S coverage samples.
// Wyman merges overflowing fragments into the last layer with an ordered read-modify-write,
// which needs fragment-shader interlock; WebGPU has none, so here the merge is replaced by
// passes whose result does not depend on the order fragments arrive in:
//
// 1. `fs_insert` of kbuffer64.wgsl (tail = drop): each pixel's K nearest fragments, sorted, in
//    K u64 slots (64-bit atomicMax chain).
// 2. `fs_slab_cover`: a fragment whose slot is strictly smaller (farther) than the pixel's
//    final K-th slot is in the tail. Its coverage mask of S samples holds
//    n = floor(α·S + u) samples (u uniform from the fragment's hash, so E[n] = α·S) chosen by a
//    hash-driven partial Fisher–Yates shuffle; it writes its nearness into every covered
//    sample with atomicMax (larger is nearer: an atomicMin of depth), a stochastic depth
//    buffer of the tail.
// 3. `fs_slab_accumulate`: a tail fragment's visibility is Enderton et al.'s accumulation-pass
//    estimate, the fraction of the S samples whose nearest tail fragment is not nearer than it
//    (a lookup in the stochastic depth buffer, as their "stochastic shadow map from the
//    camera"); (vis·C, vis·α) is added and Π(1 − α) multiplied into the tail targets.
// 4. `fs_slab_resolve`: the K slots front to back, then the tail with Enderton's alpha
//    correction, Σ vis·C / Σ vis·α · (1 − Π(1 − α)), then the background by T·Π(1 − α).
//
// The hash seeds a fragment's mask from its pixel and its content (nearness bits, slot), not
// from a draw or primitive id: the masks, the stochastic depth and every visibility are the
// same in any draw order. Only the tail targets' additive and multiplicative blends round in
// arrival order (binary16), as the k-buffer's averaged tail does.
//
// CPU twins: `oit_linked_list::slab::{mask, visibility, tail_color, resolve}`.
#include "kbuffer64.wgsl"

// S u32 per pixel: the nearness bits of the nearest tail fragment covering each sample
// (0: none).
@group(1) @binding(6) var<storage, read_write> samples: array<atomic<u32>>;

// PCG hash (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering").
fn slab_pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// pcg4d from the same paper: four well-mixed words from four inputs.
fn slab_pcg4d(a: vec4<u32>) -> vec4<u32> {
    var v = a * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v = v ^ (v >> vec4<u32>(16u));
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

// A fragment's nearness as full f32 bits (`to_slot` keeps them to 2^-15): larger is nearer,
// and > 0 for every fragment in front of the far plane.
fn slab_nearness(z: f32) -> u32 {
    var d = 1.0 - z;
    if params.reverse_z != 0u {
        d = z;
    }
    return bitcast<u32>(d);
}

// The hash input of a fragment: its pixel, its nearness and its slot's two words.
fn slab_seed(px: vec2<u32>, nearness: u32, slot: u64) -> vec4<u32> {
    return vec4<u32>(px.x, px.y, nearness, u32(slot >> 32u) ^ u32(slot & 0xFFFFFFFFlu));
}

// The coverage mask of S ≤ 32 samples: n = floor(α·S + u) of them, u the hash's top 24 bits
// over 2^24, in integers (α as 24-bit fixed point): E[n] = α·S to 2^-24. The n samples are
// the first n of a partial Fisher–Yates shuffle of 0..S driven by the hash.
fn slab_mask(seed: vec4<u32>, alpha: f32, s: u32) -> u32 {
    let h = slab_pcg4d(seed);
    let a24 = u32(clamp(alpha, 0.0, 1.0) * 16777216.0);
    let n = min((a24 * s + (h.x >> 8u)) >> 24u, s);
    var order: array<u32, 32>;
    for (var i = 0u; i < s; i += 1u) {
        order[i] = i;
    }
    var state = h.y;
    var mask = 0u;
    for (var j = 0u; j < n; j += 1u) {
        state = slab_pcg(state);
        let r = j + state % (s - j);
        let pick = order[r];
        order[r] = order[j];
        mask |= 1u << pick;
    }
    return mask;
}

fn slab_sample_base(px: vec2<u32>) -> u32 {
    return (px.y * params.width + px.x) * params.samples;
}

// Whether a fragment whose slot is `slot` lies behind its pixel's K slots: the K-th slot is
// taken and `slot` is strictly smaller. A fragment held in a slot has a slot ≥ the K-th, so it
// never enters the tail; a pushed-out exact duplicate of the K-th slot (equal nearness key,
// 8-bit α and rgb9e5 colour) does not either, so ties are never counted twice.
fn slab_in_tail(px: vec2<u32>, slot: u64) -> bool {
    let kth = atomicLoad(&slots[pixel_base(px) + params.k - 1u]);
    return kth != 0lu && slot < kth;
}

// Whether sample value `stored` leaves a tail fragment of nearness `nearness` visible: no tail
// fragment covering the sample is nearer (an exact tie counts as visible).
fn slab_sample_visible(stored: u32, nearness: u32) -> bool {
    return stored <= nearness;
}

// Enderton et al.'s visibility of a tail fragment: the fraction of the pixel's S samples that
// leave it visible. The pixel's nearest tail fragment sees 1.
fn slab_visibility(first: u32, nearness: u32, s: u32) -> f32 {
    var seen = 0u;
    for (var i = 0u; i < s; i += 1u) {
        seen += select(0u, 1u, slab_sample_visible(atomicLoad(&samples[first + i]), nearness));
    }
    return f32(seen) / f32(s);
}

// The tail's premultiplied colour from its sums: Σ vis·C scaled to the exact coverage
// 1 − Π(1 − α) by Σ vis·α (Enderton et al.'s alpha correction); with no coverage at all (only
// additive fragments, α = 0) the sum itself.
fn slab_tail_color(sum: vec4<f32>, tail_t: f32) -> vec3<f32> {
    if sum.a > 0.0 {
        return sum.rgb * ((1.0 - tail_t) / sum.a);
    }
    return sum.rgb;
}

struct SlabFragment {
    keep: bool,
    px: vec2<u32>,
    slot: u64,
    nearness: u32,
    color: vec3<f32>,
    alpha: f32,
}

// Shades `v` and tests it as `fs_insert` does: kept by its material, in front of the opaque
// surface, and behind the pixel's K slots.
fn slab_tail_fragment(v: VertexOut, front_facing: bool) -> SlabFragment {
    let s = shade(v, front_facing);
    var f: SlabFragment;
    f.px = vec2<u32>(v.clip.xy);
    f.keep = false;
    if !s.keep || !nearer(v.clip.z, textureLoad(opaque_depth, f.px, 0).x) {
        return f;
    }
    f.slot = to_slot(s.color, s.alpha, v.clip.z);
    f.keep = slab_in_tail(f.px, f.slot);
    f.nearness = slab_nearness(v.clip.z);
    f.color = s.color;
    f.alpha = s.alpha;
    return f;
}

// Pass 2: the tail's stochastic depth. Colour targets are attached with no write mask.
@fragment
fn fs_slab_cover(v: VertexOut, @builtin(front_facing) front_facing: bool) -> TailOut {
    let f = slab_tail_fragment(v, front_facing);
    if !f.keep {
        discard;
    }
    let mask = slab_mask(slab_seed(f.px, f.nearness, f.slot), f.alpha, params.samples);
    let first = slab_sample_base(f.px);
    for (var i = 0u; i < params.samples; i += 1u) {
        if ((mask >> i) & 1u) != 0u {
            atomicMax(&samples[first + i], f.nearness);
        }
    }
    var out: TailOut;
    out.sum = vec4<f32>(0.0);
    out.transmittance = vec4<f32>(0.0);
    return out;
}

// Pass 3: (vis·C, vis·α) added, α multiplied in as (1 − α).
@fragment
fn fs_slab_accumulate(v: VertexOut, @builtin(front_facing) front_facing: bool) -> TailOut {
    let f = slab_tail_fragment(v, front_facing);
    if !f.keep {
        discard;
    }
    let vis = slab_visibility(slab_sample_base(f.px), f.nearness, params.samples);
    var out: TailOut;
    out.sum = vec4<f32>(f.color * vis, f.alpha * vis);
    out.transmittance = vec4<f32>(f.alpha);
    return out;
}

// The K slots front to back, then the tail (`slab_tail_color`, coverage 1 − Π(1 − α)); (C,
// 1 − T) blended premultiplied OVER onto the final colour. counters[1]: pixels with a tail.
@fragment
fn fs_slab_resolve(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let px = vec2<u32>(position.xy);
    let base = pixel_base(px);
    var c = vec3<f32>(0.0);
    var t = 1.0;
    for (var i = 0u; i < params.k; i += 1u) {
        let s = atomicLoad(&slots[base + i]);
        if s == 0lu {
            break;
        }
        let f = from_slot(s);
        c += t * f.color;
        t *= 1.0 - f.opacity.x;
    }
    let sum = textureLoad(tail_sum, px, 0);
    let tail_t = textureLoad(tail_transmittance, px, 0).r;
    if sum.a > 0.0 || tail_t < 1.0 || any(sum.rgb != vec3<f32>(0.0)) {
        c += t * slab_tail_color(sum, tail_t);
        t *= tail_t;
        atomicAdd(&counters[1], 1u);
    }
    return vec4<f32>(c, 1.0 - t);
}
