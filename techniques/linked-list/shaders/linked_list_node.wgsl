// Node formats of the linked list (the WGSL twin of oit_linked_list::node). A node in
// registers is three words: `key` orders nodes front to back (smaller is nearer), `c0`/`c1`
// hold the colour; ties on the key are ordered by the colour words, so the sorted order, and
// therefore the result, does not depend on the order fragments arrived in.
//
// f32 (16 B in the pool): key = the window depth's f32 bits (complemented under reverse-Z),
//   c0 = half(C.r) | half(C.g) << 16, c1 = half(C.b) | half(α) << 16.
// packed (12 B, Bevy's layout): key = unorm24(depth) << 8 | unorm8(α), c0 = rgb9e5(C), c1 = 0.
//
// With TRANSMIT (scenes with coloured transmission) a node stores the per-channel opacity
// a = 1 − t instead of α (1 − t rather than t: binary16 and unorm keep their precision near
// opacity 0, i.e. t near 1, as they do for α):
// f32 (20 B): c0 = half(C.r) | half(C.g) << 16, c1 = half(C.b) | half(a.r) << 16,
//   c2 = half(a.g) | half(a.b) << 16.
// packed (16 B): key as packed (its α byte is unorm8(1 − mean(t)), a tie-break only), c0 =
//   rgb9e5(C), c1 = unorm10(a.r) | unorm10(a.g) << 10 | unorm10(a.b) << 20.
//
// rgb9e5 holds no sign: a packed TRANSMIT node stores |C| and sets bit 31 of c1 (unused by
// the unorm10) when C is negative (`subtract`, whose colour is −α·c in every channel). The
// 12-byte scalar node has no spare bit, so packed nodes take the TRANSMIT layout on scenes
// that subtract (`oit_linked_list::list::node_layout`).

// Set per pipeline: 12-byte packed nodes instead of 16-byte f32 nodes.
override PACKED: bool = false;
// Set per pipeline: nodes store rgb opacity (scenes with coloured transmission).
override TRANSMIT: bool = false;

struct Node {
    key: u32,
    c0: u32,
    c1: u32,
    c2: u32,
    next: u32,
}

struct Fragment {
    color: vec3<f32>,
    // Per-channel opacity 1 − t: α in every channel for scalar nodes.
    opacity: vec3<f32>,
}

const RGB9E5_MAX: f32 = 65408.0;
const UNORM24_MAX: f32 = 16777215.0;

// Shared-exponent RGB (EXT_texture_shared_exponent) with the exponent from the f32 bits, so
// no log2 rounding decides it.
fn pack_rgb9e5(c: vec3<f32>) -> u32 {
    let rc = clamp(c, vec3<f32>(0.0), vec3<f32>(RGB9E5_MAX));
    let m = max(rc.r, max(rc.g, rc.b));
    // floor(log2(m)) for normal m; the smallest shared exponent below 2^-15.
    let e_floor = max(i32((bitcast<u32>(m) >> 23u) & 0xffu) - 127, -16);
    var e_shared = e_floor + 16;
    var scale = ldexp(1.0, 24 - e_shared);
    if floor(m * scale + 0.5) >= 512.0 {
        e_shared += 1;
        scale *= 0.5;
    }
    let q = vec3<u32>(floor(rc * scale + 0.5));
    return q.r | (q.g << 9u) | (q.b << 18u) | (u32(e_shared) << 27u);
}

fn unpack_rgb9e5(w: u32) -> vec3<f32> {
    let scale = ldexp(1.0, i32(w >> 27u) - 24);
    let q = vec3<u32>(w & 511u, (w >> 9u) & 511u, (w >> 18u) & 511u);
    return vec3<f32>(q) * scale;
}

const UNORM10_MAX: f32 = 1023.0;

// Bit 31 of a packed node's c1 (and of a k-buffer opacity slot's low word): the colour is
// negated (`subtract`).
const NEGATED: u32 = 0x80000000u;

// Whether a shaded colour is negative: every channel of a `subtract` fragment is −α·c ≤ 0,
// every other fragment's is ≥ 0.
fn is_negated(c: vec3<f32>) -> bool {
    return c.r + c.g + c.b < 0.0;
}

fn unorm10(x: f32) -> u32 {
    return u32(clamp(x, 0.0, 1.0) * UNORM10_MAX + 0.5);
}

// Per-channel opacity as 3 × unorm10 (packed transmit nodes, the k-buffer's opacity slots).
fn pack_opacity(a: vec3<f32>) -> u32 {
    return unorm10(a.r) | (unorm10(a.g) << 10u) | (unorm10(a.b) << 20u);
}

fn unpack_opacity(w: u32) -> vec3<f32> {
    let q = vec3<u32>(w & 1023u, (w >> 10u) & 1023u, (w >> 20u) & 1023u);
    return vec3<f32>(q) / UNORM10_MAX;
}

// `opacity` (1 − t per channel) is stored only with TRANSMIT; scalar nodes store `alpha`.
fn pack_node(color: vec3<f32>, alpha: f32, opacity: vec3<f32>, z: f32, reverse_z: bool) -> Node {
    var n: Node;
    n.c2 = 0u;
    if PACKED {
        // z = 1 gives 2^24 - 0.5 + 0.5, which f32 rounds to 2^24: clamp to 24 bits (else the
        // key wraps, and a fragment on the reverse-Z near plane sorts farthest).
        var d = min(u32(clamp(z, 0.0, 1.0) * UNORM24_MAX + 0.5), 16777215u);
        if reverse_z {
            d = 16777215u - d;
        }
        n.key = (d << 8u) | u32(clamp(alpha, 0.0, 1.0) * 255.0 + 0.5);
        n.c0 = pack_rgb9e5(color);
        n.c1 = 0u;
        if TRANSMIT {
            let negated = is_negated(color);
            n.c0 = pack_rgb9e5(select(color, -color, negated));
            n.c1 = pack_opacity(opacity) | select(0u, NEGATED, negated);
        }
    } else {
        // +0 for -0: the sign bit would sort it farthest.
        var bits = bitcast<u32>(z) & 0x7fffffffu;
        if reverse_z {
            bits = ~bits;
        }
        n.key = bits;
        n.c0 = pack2x16float(color.rg);
        if TRANSMIT {
            n.c1 = pack2x16float(vec2<f32>(color.b, opacity.r));
            n.c2 = pack2x16float(opacity.gb);
        } else {
            n.c1 = pack2x16float(vec2<f32>(color.b, alpha));
        }
    }
    return n;
}

fn unpack_node(n: Node) -> Fragment {
    var f: Fragment;
    if PACKED {
        f.color = unpack_rgb9e5(n.c0);
        if (n.c1 & NEGATED) != 0u {
            f.color = -f.color;
        }
        if TRANSMIT {
            f.opacity = unpack_opacity(n.c1);
        } else {
            f.opacity = vec3<f32>(f32(n.key & 255u) / 255.0);
        }
    } else {
        let rg = unpack2x16float(n.c0);
        let ba = unpack2x16float(n.c1);
        f.color = vec3<f32>(rg, ba.x);
        f.opacity = vec3<f32>(ba.y);
        if TRANSMIT {
            f.opacity = vec3<f32>(ba.y, unpack2x16float(n.c2));
        }
    }
    return f;
}

fn node_before(a: Node, b: Node) -> bool {
    if a.key != b.key {
        return a.key < b.key;
    }
    if a.c0 != b.c0 {
        return a.c0 < b.c0;
    }
    if a.c1 != b.c1 {
        return a.c1 < b.c1;
    }
    return a.c2 < b.c2;
}

// Fragments behind the sort window, composited as one layer, per channel: coverage
// 1 − Π(1 − a) exactly (a product does not depend on order), colour the a-weighted average of
// their colours (a = α in every channel for scalar nodes).
struct Tail {
    color: vec3<f32>,
    alpha_sum: vec3<f32>,
    transmittance: vec3<f32>,
    count: u32,
}

fn tail_empty() -> Tail {
    return Tail(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(1.0), 0u);
}

fn tail_with(t: Tail, n: Node) -> Tail {
    let f = unpack_node(n);
    return Tail(t.color + f.color, t.alpha_sum + f.opacity, t.transmittance * (1.0 - f.opacity), t.count + 1u);
}

fn tail_resolve(t: Tail) -> Fragment {
    var f: Fragment;
    f.opacity = 1.0 - t.transmittance;
    f.color = vec3<f32>(0.0);
    for (var c = 0u; c < 3u; c += 1u) {
        if t.alpha_sum[c] > 0.0 {
            f.color[c] = t.color[c] * (f.opacity[c] / t.alpha_sum[c]);
        }
    }
    return f;
}
