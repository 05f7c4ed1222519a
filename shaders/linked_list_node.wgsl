// Node formats of the linked list (the WGSL twin of oit_linked_list::node). A node in
// registers is three words: `key` orders nodes front to back (smaller is nearer), `c0`/`c1`
// hold the colour; ties on the key are ordered by the colour words, so the sorted order, and
// therefore the result, does not depend on the order fragments arrived in.
//
// f32 (16 B in the pool): key = the window depth's f32 bits (complemented under reverse-Z),
//   c0 = half(C.r) | half(C.g) << 16, c1 = half(C.b) | half(α) << 16.
// packed (12 B, Bevy's layout): key = unorm24(depth) << 8 | unorm8(α), c0 = rgb9e5(C), c1 = 0.

// Set per pipeline: 12-byte packed nodes instead of 16-byte f32 nodes.
override PACKED: bool = false;

struct Node {
    key: u32,
    c0: u32,
    c1: u32,
    next: u32,
}

struct Fragment {
    color: vec3<f32>,
    alpha: f32,
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

fn pack_node(color: vec3<f32>, alpha: f32, z: f32, reverse_z: bool) -> Node {
    var n: Node;
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
    } else {
        // +0 for -0: the sign bit would sort it farthest.
        var bits = bitcast<u32>(z) & 0x7fffffffu;
        if reverse_z {
            bits = ~bits;
        }
        n.key = bits;
        n.c0 = pack2x16float(color.rg);
        n.c1 = pack2x16float(vec2<f32>(color.b, alpha));
    }
    return n;
}

fn unpack_node(n: Node) -> Fragment {
    var f: Fragment;
    if PACKED {
        f.color = unpack_rgb9e5(n.c0);
        f.alpha = f32(n.key & 255u) / 255.0;
    } else {
        let rg = unpack2x16float(n.c0);
        let ba = unpack2x16float(n.c1);
        f.color = vec3<f32>(rg, ba.x);
        f.alpha = ba.y;
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
    return a.c1 < b.c1;
}

// Fragments behind the sort window, composited as one layer: coverage 1 − Π(1 − α) exactly
// (a product does not depend on order), colour the α-weighted average of their colours.
struct Tail {
    color: vec3<f32>,
    alpha_sum: f32,
    transmittance: f32,
    count: u32,
}

fn tail_empty() -> Tail {
    return Tail(vec3<f32>(0.0), 0.0, 1.0, 0u);
}

fn tail_with(t: Tail, n: Node) -> Tail {
    let f = unpack_node(n);
    return Tail(t.color + f.color, t.alpha_sum + f.alpha, t.transmittance * (1.0 - f.alpha), t.count + 1u);
}

fn tail_resolve(t: Tail) -> Fragment {
    var f: Fragment;
    f.alpha = 1.0 - t.transmittance;
    f.color = vec3<f32>(0.0);
    if t.alpha_sum > 0.0 {
        f.color = t.color * (f.alpha / t.alpha_sum);
    }
    return f;
}
