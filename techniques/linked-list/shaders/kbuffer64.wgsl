// k-buffer on 64-bit atomics (NVIDIA's "Loop64"): one geometry pass keeps each pixel's K
// nearest fragments, sorted, in K u64 slots; the fragment a full pixel pushes out (the farthest
// of the K + 1) goes to the tail targets by hardware blending. Needs
// SHADER_INT64_ATOMIC_ALL_OPS: the insertion reads the value atomicMax returns.
//
// A slot is (nearness | unorm8 α) << 32 | rgb9e5 premultiplied colour, where nearness is the f32
// bits of the distance from the far plane in window depth (z under reverse-Z, 1 − z otherwise,
// exact for z ≥ 0.5) with the low 8 mantissa bits replaced by α: larger is nearer, to 2^-15 of
// the value, and the cleared value 0 is "empty" (every stored fragment is strictly nearer than
// the far plane, so its nearness is > 0).
//
// With TRANSMIT (scenes with coloured transmission, see kbuffer64_transmit.wgsl) a pixel has
// two chains of K slots: colour slots as above and opacity slots whose low word is the
// per-channel opacity 1 − t as 3 × unorm10. Both of a fragment's slots share the high word,
// whose low byte is then a hash of the two low words instead of α: the chains sort alike, so
// slot i of both holds the same fragment (unless two fragments tie on nearness and hash).
//
// `hybrid` (Maule, Comba, Torchelsen & Bastos 2013: the K nearest exact, the rest weighted
// blended) is this pass with tail = 2: a fragment pushed out enters the tail sums weighted by
// WBOIT's `range` weight at its depth (wboit_tail.wgsl, oit_wboit::RangeParams), so nearer
// tail fragments count more than farther ones; coverage stays the exact 1 − Π(1 − α).
#include "common.wgsl"
#include "linked_list_node.wgsl"
#include "wboit_tail.wgsl"

struct KParams {
    width: u32,
    k: u32,
    // 1 when window depth 1 is near.
    reverse_z: u32,
    // 0 drop, 1 average, 2 average weighted by the `range` weight (hybrid).
    tail: u32,
    // The `range` weight's scene inputs (hybrid; 1 for colour_scale otherwise): the
    // transparent depth interval as view distances, the fall in bits, the unit of the colour
    // sums (a power of two, multiplied back in the resolve).
    z_near: f32,
    z_far: f32,
    fall: f32,
    color_scale: f32,
    // The projection terms of `wboit_view_distance`; ortho 1 for an orthographic camera.
    proj_a: f32,
    proj_b: f32,
    ortho: u32,
    // `slab`'s coverage samples per pixel (slab.wgsl); 0 for the k-buffer and the hybrid.
    samples: u32,
}

@group(1) @binding(0) var<uniform> params: KParams;
@group(1) @binding(1) var<storage, read_write> slots: array<atomic<u64>>;
// [0] pixels that dropped a tail; [1] pixels whose tail was averaged.
@group(1) @binding(2) var<storage, read_write> counters: array<atomic<u32>, 4>;
@group(1) @binding(3) var opaque_depth: texture_2d<f32>;
// Resolve only: (Σ C, Σ α) and Π(1 − α) of the tail.
@group(1) @binding(4) var tail_sum: texture_2d<f32>;
@group(1) @binding(5) var tail_transmittance: texture_2d<f32>;

fn nearer(z: f32, than: f32) -> bool {
    if params.reverse_z != 0u {
        return z > than;
    }
    return z < than;
}

// Chain slots per pixel: 1, or 2 with TRANSMIT (colour, then opacity).
fn pixel_base(px: vec2<u32>) -> u32 {
    var chains = 1u;
    if TRANSMIT {
        chains = 2u;
    }
    return (px.y * params.width + px.x) * params.k * chains;
}

// Keeps `cur` among the K largest of slots[first .. first + K]; returns what is pushed out
// (0: nothing).
fn insert_chain(first: u32, value: u64) -> u64 {
    var cur = value;
    for (var i = 0u; i < params.k; i += 1u) {
        let old = atomicMax(&slots[first + i], cur);
        if old == 0lu {
            // Landed in an empty slot: nothing is pushed out.
            return 0lu;
        }
        // The slot keeps the nearer (larger); carry the farther on.
        cur = select(cur, old, old < cur);
    }
    return cur;
}

fn to_slot(color: vec3<f32>, alpha: f32, z: f32) -> u64 {
    var d = 1.0 - z;
    if params.reverse_z != 0u {
        d = z;
    }
    let a8 = u32(clamp(alpha, 0.0, 1.0) * 255.0 + 0.5);
    let hi = (bitcast<u32>(d) & 0xFFFFFF00u) | a8;
    return (u64(hi) << 32u) | u64(pack_rgb9e5(color));
}

fn from_slot(s: u64) -> Fragment {
    var f: Fragment;
    f.color = unpack_rgb9e5(u32(s & 0xFFFFFFFFlu));
    f.opacity = vec3<f32>(f32(u32(s >> 32u) & 255u) / 255.0);
    return f;
}

// The weight of a slot pushed out into the tail: 1, or for the hybrid the `range` weight at
// the slot's depth (its nearness is window depth to 2^-15). CPU twin:
// `oit_linked_list::kbuffer::tail_weight`.
fn tail_weight(s: u64) -> f32 {
    if params.tail != 2u {
        return 1.0;
    }
    let nearness = bitcast<f32>(u32(s >> 32u) & 0xFFFFFF00u);
    var z = 1.0 - nearness;
    if params.reverse_z != 0u {
        z = nearness;
    }
    let view_z = wboit_view_distance(z, params.proj_a, params.proj_b, params.ortho != 0u);
    return wboit_weight_range(view_z, params.z_near, params.z_far, params.fall);
}

struct TailOut {
    // Added: (C / colour scale, α), times the tail weight, of the fragment pushed out, or 0.
    @location(0) sum: vec4<f32>,
    // Multiplied in as (1 − src): α of the fragment pushed out, or 0.
    @location(1) transmittance: vec4<f32>,
}

// The opaque test is the shader's own (the pass has no depth attachment): the atomics are side
// effects, which a late depth test would not undo.
@fragment
fn fs_insert(v: VertexOut, @builtin(front_facing) front_facing: bool) -> TailOut {
    let s = shade(v, front_facing);
    let px = vec2<u32>(v.clip.xy);
    let z = v.clip.z;
    if !s.keep || !nearer(z, textureLoad(opaque_depth, px, 0).x) {
        discard;
    }
    let cur = insert_chain(pixel_base(px), to_slot(s.color, s.alpha, z));
    var out: TailOut;
    out.sum = vec4<f32>(0.0);
    out.transmittance = vec4<f32>(0.0);
    if cur != 0lu {
        let f = from_slot(cur);
        let w = tail_weight(cur);
        out.sum = vec4<f32>(f.color * (w / params.color_scale), f.opacity.x * w);
        out.transmittance = vec4<f32>(f.opacity.x);
    }
    return out;
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

// The K slots front to back, then the tail as one layer (coverage 1 − Π(1 − α), the α-weighted
// mean colour, each fragment also weighted by its tail weight) or nothing; (C, 1 − T) blended
// premultiplied OVER onto the final colour.
@fragment
fn fs_resolve(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
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
    if sum.a > 0.0 {
        if params.tail != 0u {
            let tail_t = textureLoad(tail_transmittance, px, 0).r;
            c += t * sum.rgb * (params.color_scale * (1.0 - tail_t) / sum.a);
            t *= tail_t;
            atomicAdd(&counters[1], 1u);
        } else {
            atomicAdd(&counters[0], 1u);
        }
    }
    return vec4<f32>(c, 1.0 - t);
}
