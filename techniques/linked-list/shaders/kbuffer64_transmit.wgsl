enable dual_source_blending;
// The k-buffer on scenes with coloured transmission (TRANSMIT, see kbuffer64.wgsl): a pixel
// has a chain of K colour slots and a chain of K opacity slots. A fragment's two slots share
// the high word (nearness, and a hash of both low words in place of α), so both chains keep
// the same K fragments in the same order, and the fragments pushed out of either are the same
// set: the tail sums (Σ C and a count from the colour chain, Σ a and Π(1 − a) from the opacity
// chain) are sums over one set. The resolve composites per channel and puts the stack over the
// final colour with dual-source blending, dst = C + T ⊙ dst (blend One, Src1).
//
// Scenes that `subtract` take this layout too: rgb9e5 holds no sign, so a colour slot stores
// |C| and its opacity slot's bit 31 (`NEGATED`, unused by the three unorm10) says C < 0.
#include "kbuffer64.wgsl"

// Resolve only: Σ a (rgb) of the tail.
@group(1) @binding(6) var tail_opacity: texture_2d<f32>;

// The shared high word: nearness as `to_slot`, its low byte a hash of the colour and opacity
// words (order-independent, so ties sort the same in both chains).
fn transmit_high(z: f32, color_word: u32, opacity_word: u32) -> u32 {
    var d = 1.0 - z;
    if params.reverse_z != 0u {
        d = z;
    }
    let h = ((color_word * 0x9E3779B1u) ^ (opacity_word * 0x85EBCA77u)) >> 24u;
    return (bitcast<u32>(d) & 0xFFFFFF00u) | h;
}

// The colour of an rgb9e5 word, negated where the opacity word `flags` has `NEGATED`.
fn signed_color(color_word: u32, flags: u32) -> vec3<f32> {
    let c = unpack_rgb9e5(color_word);
    return select(c, -c, (flags & NEGATED) != 0u);
}

struct TransmitTailOut {
    // Added: (C, 1) of the colour slot pushed out, or 0 (alpha counts the tail).
    @location(0) sum: vec4<f32>,
    // Added: (a, 0) of the opacity slot pushed out, or 0.
    @location(1) opacity: vec4<f32>,
    // Multiplied in as (1 − src): (a, 0) of the opacity slot pushed out, or 0.
    @location(2) transmittance: vec4<f32>,
}

@fragment
fn fs_insert_transmit(v: VertexOut, @builtin(front_facing) front_facing: bool) -> TransmitTailOut {
    let s = shade(v, front_facing);
    let px = vec2<u32>(v.clip.xy);
    let z = v.clip.z;
    if !s.keep || !nearer(z, textureLoad(opaque_depth, px, 0).x) {
        discard;
    }
    let base = pixel_base(px);
    let negated = is_negated(s.color);
    let color_word = pack_rgb9e5(select(s.color, -s.color, negated));
    let opacity_word = pack_opacity(1.0 - s.transmittance) | select(0u, NEGATED, negated);
    let high = u64(transmit_high(z, color_word, opacity_word)) << 32u;
    let out_color = insert_chain(base, high | u64(color_word));
    let out_opacity = insert_chain(base + params.k, high | u64(opacity_word));
    var out: TransmitTailOut;
    out.sum = vec4<f32>(0.0);
    out.opacity = vec4<f32>(0.0);
    out.transmittance = vec4<f32>(0.0);
    if out_color != 0lu {
        // Both chains push out the same fragment: its sign is in the opacity slot.
        let flags = u32(out_opacity & 0xFFFFFFFFlu);
        out.sum = vec4<f32>(signed_color(u32(out_color & 0xFFFFFFFFlu), flags), 1.0);
    }
    if out_opacity != 0lu {
        let a = unpack_opacity(u32(out_opacity & 0xFFFFFFFFlu));
        out.opacity = vec4<f32>(a, 0.0);
        out.transmittance = vec4<f32>(a, 0.0);
    }
    return out;
}

struct TransmitOut {
    @location(0) @blend_src(0) color: vec4<f32>,
    @location(0) @blend_src(1) transmittance: vec4<f32>,
}

// The K slots front to back per channel, then the tail as one layer per channel (coverage
// 1 − Π(1 − a), the a-weighted mean colour) or nothing.
@fragment
fn fs_resolve_transmit(@builtin(position) position: vec4<f32>) -> TransmitOut {
    let px = vec2<u32>(position.xy);
    let base = pixel_base(px);
    var c = vec3<f32>(0.0);
    var t = vec3<f32>(1.0);
    for (var i = 0u; i < params.k; i += 1u) {
        let color_slot = atomicLoad(&slots[base + i]);
        if color_slot == 0lu {
            break;
        }
        let opacity_slot = atomicLoad(&slots[base + params.k + i]);
        c += t * signed_color(u32(color_slot & 0xFFFFFFFFlu), u32(opacity_slot & 0xFFFFFFFFlu));
        t *= 1.0 - unpack_opacity(u32(opacity_slot & 0xFFFFFFFFlu));
    }
    let sum = textureLoad(tail_sum, px, 0);
    if sum.a > 0.0 {
        if params.tail == 1u {
            let a_sum = textureLoad(tail_opacity, px, 0).rgb;
            let tail_t = textureLoad(tail_transmittance, px, 0).rgb;
            for (var ch = 0u; ch < 3u; ch += 1u) {
                if a_sum[ch] > 0.0 {
                    c[ch] += t[ch] * sum[ch] * ((1.0 - tail_t[ch]) / a_sum[ch]);
                }
            }
            t *= tail_t;
            atomicAdd(&counters[1], 1u);
        } else {
            atomicAdd(&counters[0], 1u);
        }
    }
    let mean = (t.r + t.g + t.b) * (1.0 / 3.0);
    var out: TransmitOut;
    out.color = vec4<f32>(c, 1.0 - mean);
    out.transmittance = vec4<f32>(t, mean);
    return out;
}
