// Prefix-sum A-buffer (Maule, Comba, Torchelsen & Bastos 2013, "dynamic fragment buffer"):
// after the count pass (oit_gpu's count_layers.wgsl) and the exclusive scan of its per-pixel
// counts (prefix_sum.wgsl), every pixel owns the slots [offsets[p], offsets[p + 1]) of one
// array sized to the frame's fragments. The fill pass writes each transparent fragment in front
// of the opaque surface into its pixel's range; the resolve sorts the range and composites it
// front to back. Nothing is bounded per pixel, so nothing is dropped or averaged; fragments the
// fill finds beyond the count (none, when both passes rasterise alike) are lost and counted.
// CPU twin of the resolve: `oit_linked_list::node::resolve` with a window of every fragment.
#include "common.wgsl"
#include "linked_list_node.wgsl"

struct AbufferParams {
    width: u32,
    // 1 when window depth 1 is near (keys flip so that smaller is nearer).
    reverse_z: u32,
    pad0: u32,
    pad1: u32,
}

@group(1) @binding(0) var<uniform> params: AbufferParams;
// Exclusive prefix sum of the counts, one entry more than pixels: offsets[pixels] is the total.
@group(1) @binding(1) var<storage, read> offsets: array<u32>;
// The count pass's per-pixel counts, counted down by the fill: what is left is the number of
// counted slots no fragment filled (0 when the passes agree; past the count it wraps, > size).
@group(1) @binding(2) var<storage, read_write> left: array<atomic<u32>>;
@group(1) @binding(3) var<storage, read_write> nodes: array<u32>;
// [0] fragments lost (the fill found more than the count); [1] pixels that lost any; [2], [3]
// unused.
@group(1) @binding(4) var<storage, read_write> counters: array<atomic<u32>, 4>;
@group(1) @binding(5) var opaque_depth: texture_2d<f32>;

// Registers hold a pixel's fragments up to this many; deeper pixels sort in place in `nodes`.
const LOCAL_MAX: u32 = 16u;

// Words of a node: key and colour words (c0; c1 unless packed scalar; c2 for f32 with
// TRANSMIT). No `next`: a pixel's nodes are contiguous.
fn node_words() -> u32 {
    var words = 3u;
    if PACKED {
        words = 2u;
    }
    if TRANSMIT {
        words += 1u;
    }
    return words;
}

fn store_node(index: u32, n: Node) {
    let words = node_words();
    let base = index * words;
    nodes[base] = n.key;
    nodes[base + 1u] = n.c0;
    if words > 2u {
        nodes[base + 2u] = n.c1;
    }
    if words > 3u {
        nodes[base + 3u] = n.c2;
    }
}

fn load_node(index: u32) -> Node {
    let words = node_words();
    let base = index * words;
    var n: Node;
    n.key = nodes[base];
    n.c0 = nodes[base + 1u];
    n.c1 = 0u;
    n.c2 = 0u;
    n.next = 0u;
    if words > 2u {
        n.c1 = nodes[base + 2u];
    }
    if words > 3u {
        n.c2 = nodes[base + 3u];
    }
    return n;
}

fn nearer(z: f32, than: f32) -> bool {
    if params.reverse_z != 0u {
        return z > than;
    }
    return z < than;
}

// The test of the count pass, which sized the ranges: kept by `shade`, strictly nearer than
// the opaque depth (the shader's own test; the pass has no depth attachment).
@fragment
fn fs_fill(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    let px = vec2<u32>(v.clip.xy);
    let z = v.clip.z;
    if !s.keep || !nearer(z, textureLoad(opaque_depth, px, 0).x) {
        discard;
    }
    let p = px.y * params.width + px.x;
    let start = offsets[p];
    let size = offsets[p + 1u] - start;
    // This fragment's place, counted down from the end of the range.
    let n = atomicSub(&left[p], 1u);
    if n == 0u || n > size {
        atomicAdd(&counters[0], 1u);
        discard;
    }
    store_node(start + n - 1u, pack_node(s.color, s.alpha, 1.0 - s.transmittance, z, params.reverse_z != 0u));
    // Nothing is written to the attachment (its write mask is empty).
    return vec4<f32>(0.0);
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

// A pixel's stack: premultiplied colour and per-channel transmittance (all three equal for
// scalar nodes).
struct Resolved {
    color: vec3<f32>,
    transmittance: vec3<f32>,
}

// Shell sort of nodes[begin, end) in place, nearest first (Ciura's gaps): for pixels deeper
// than the registers hold. Any correct sort gives the same order: node_before is total up to
// identical nodes.
fn sort_in_place(begin: u32, end: u32) {
    let n = end - begin;
    var gaps = array<u32, 8>(701u, 301u, 132u, 57u, 23u, 10u, 4u, 1u);
    for (var g = 0u; g < 8u; g += 1u) {
        let gap = gaps[g];
        if gap >= n {
            continue;
        }
        for (var i = gap; i < n; i += 1u) {
            let incoming = load_node(begin + i);
            var j = i;
            loop {
                if j < gap {
                    break;
                }
                let before = load_node(begin + j - gap);
                if !node_before(incoming, before) {
                    break;
                }
                store_node(begin + j, before);
                j -= gap;
            }
            store_node(begin + j, incoming);
        }
    }
}

fn resolve_pixel(position: vec4<f32>) -> Resolved {
    let px = vec2<u32>(position.xy);
    let p = px.y * params.width + px.x;
    let end = offsets[p + 1u];
    let size = end - offsets[p];
    let unfilled = atomicLoad(&left[p]);
    // Filled from the end down: the first `unfilled` slots are empty unless the count wrapped.
    var begin = offsets[p];
    if unfilled <= size {
        begin += unfilled;
    } else {
        atomicAdd(&counters[1], 1u);
    }
    let count = end - begin;
    var c = vec3<f32>(0.0);
    var t = vec3<f32>(1.0);
    if count <= LOCAL_MAX {
        var window: array<Node, LOCAL_MAX>;
        for (var k = 0u; k < count; k += 1u) {
            let incoming = load_node(begin + k);
            // Insertion sort, nearest first; the guard is its own `if` (Mesa's GLSL compiler
            // miscompiles a guard that shares its condition with the read: linked_list.wgsl).
            var j = k;
            loop {
                if j == 0u {
                    break;
                }
                if !node_before(incoming, window[j - 1u]) {
                    break;
                }
                window[j] = window[j - 1u];
                j -= 1u;
            }
            window[j] = incoming;
        }
        for (var k = 0u; k < count; k += 1u) {
            let f = unpack_node(window[k]);
            c += t * f.color;
            t *= 1.0 - f.opacity;
        }
    } else {
        sort_in_place(begin, end);
        for (var k = begin; k < end; k += 1u) {
            let f = unpack_node(load_node(k));
            c += t * f.color;
            t *= 1.0 - f.opacity;
        }
    }
    return Resolved(c, t);
}

// Output (C, 1 - T) blended premultiplied OVER onto the final colour.
@fragment
fn fs_resolve(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let r = resolve_pixel(position);
    return vec4<f32>(r.color, 1.0 - r.transmittance.x);
}
