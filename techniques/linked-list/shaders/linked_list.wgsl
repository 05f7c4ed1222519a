// Per-pixel linked lists (Yang et al. 2010). The insert pass appends every transparent fragment
// in front of the opaque surface to its pixel's list (one atomic counter allocates nodes from a
// fixed pool; a full pool loses the fragment and counts it). The resolve pass keeps the
// SORT_MAX nearest fragments of a pixel sorted, composites them front to back, and composites
// what is behind them with the tail rule.
#include "common.wgsl"
#include "linked_list_node.wgsl"

struct ListParams {
    width: u32,
    // Nodes in the pool.
    capacity: u32,
    // 1 when window depth 1 is near (keys flip so that smaller is nearer).
    reverse_z: u32,
    // 0 drop, 1 average.
    tail: u32,
}

@group(1) @binding(0) var<uniform> params: ListParams;
// Node index + 1 of each pixel's most recent fragment; 0 ends a list (cleared every frame).
@group(1) @binding(1) var<storage, read_write> heads: array<atomic<u32>>;
@group(1) @binding(2) var<storage, read_write> nodes: array<u32>;
// [0] nodes allocated; [1] pixels that lost fragments or dropped layers; [2] pixels whose tail
// was approximated; [3] unused.
@group(1) @binding(3) var<storage, read_write> counters: array<atomic<u32>, 4>;
// Fragments each pixel lost to a full pool.
@group(1) @binding(4) var<storage, read_write> lost: array<atomic<u32>>;
@group(1) @binding(5) var opaque_depth: texture_2d<f32>;

// The sort window (`sort_max`). Function-scope arrays need a constant size, so the crate
// rewrites this line for each configuration.
const SORT_MAX: u32 = 16u;

// Words of a node in the pool: key, colour words (c0; c1 unless packed scalar; c2 for f32
// with TRANSMIT), next.
fn node_words() -> u32 {
    var words = 4u;
    if PACKED {
        words = 3u;
    }
    if TRANSMIT {
        words += 1u;
    }
    return words;
}

fn store_node(index: u32, n: Node, next: u32) {
    let words = node_words();
    let base = index * words;
    nodes[base] = n.key;
    nodes[base + 1u] = n.c0;
    if words > 3u {
        nodes[base + 2u] = n.c1;
    }
    if words > 4u {
        nodes[base + 3u] = n.c2;
    }
    nodes[base + words - 1u] = next;
}

fn load_node(index: u32) -> Node {
    let words = node_words();
    let base = index * words;
    var n: Node;
    n.key = nodes[base];
    n.c0 = nodes[base + 1u];
    n.c1 = 0u;
    n.c2 = 0u;
    if words > 3u {
        n.c1 = nodes[base + 2u];
    }
    if words > 4u {
        n.c2 = nodes[base + 3u];
    }
    n.next = nodes[base + words - 1u];
    return n;
}


fn nearer(z: f32, than: f32) -> bool {
    if params.reverse_z != 0u {
        return z > than;
    }
    return z < than;
}

// Side effects happen before a late depth test, so the opaque test is the shader's own (the
// pass has no depth attachment): strictly nearer, as the hardware test of every other pass.
@fragment
fn fs_insert(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    let px = vec2<u32>(v.clip.xy);
    let z = v.clip.z;
    if !s.keep || !nearer(z, textureLoad(opaque_depth, px, 0).x) {
        discard;
    }
    let p = px.y * params.width + px.x;
    let index = atomicAdd(&counters[0], 1u);
    if index >= params.capacity {
        atomicAdd(&lost[p], 1u);
        discard;
    }
    let node = pack_node(s.color, s.alpha, 1.0 - s.transmittance, z, params.reverse_z != 0u);
    let next = atomicExchange(&heads[p], index + 1u);
    store_node(index, node, next);
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

fn resolve_pixel(position: vec4<f32>) -> Resolved {
    let px = vec2<u32>(position.xy);
    let p = px.y * params.width + px.x;
    var window: array<Node, SORT_MAX>;
    var count = 0u;
    var tail = tail_empty();
    var i = atomicLoad(&heads[p]);
    while i != 0u {
        let n = load_node(i - 1u);
        i = n.next;
        var incoming = n;
        if count == SORT_MAX {
            // The window is full: the farthest of it and the newcomer goes to the tail.
            if node_before(incoming, window[SORT_MAX - 1u]) {
                let evicted = window[SORT_MAX - 1u];
                count -= 1u;
                tail = tail_with(tail, evicted);
            } else {
                tail = tail_with(tail, incoming);
                continue;
            }
        }
        // Insertion sort, nearest first. The guard is its own `if`: Mesa's GLSL compiler (llvmpipe
        // GL, Mesa 22.3) miscompiles the guarded read of `window[j - 1u]` when guard and read share
        // one condition (`j > 0u && ...` or `j == 0u || ...`), leaving every slot but the first
        // unwritten.
        var j = count;
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
        count += 1u;
    }
    var c = vec3<f32>(0.0);
    var t = vec3<f32>(1.0);
    for (var k = 0u; k < count; k += 1u) {
        let f = unpack_node(window[k]);
        c += t * f.color;
        t *= 1.0 - f.opacity;
    }
    let lost_here = atomicLoad(&lost[p]) > 0u;
    let tail_here = tail.count > 0u;
    if tail_here && params.tail == 1u {
        let r = tail_resolve(tail);
        c += t * r.color;
        t *= 1.0 - r.opacity;
    }
    if lost_here || (tail_here && params.tail == 0u) {
        atomicAdd(&counters[1], 1u);
    } else if tail_here {
        atomicAdd(&counters[2], 1u);
    }
    return Resolved(c, t);
}

// Output (C, 1 - T) blended premultiplied OVER onto the final colour.
@fragment
fn fs_resolve(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let r = resolve_pixel(position);
    return vec4<f32>(r.color, 1.0 - r.transmittance.x);
}
