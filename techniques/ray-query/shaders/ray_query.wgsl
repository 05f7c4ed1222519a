enable wgpu_ray_query;
// Ray-traced transparency with ray queries: one ray per pixel centre (the reference's sample
// point) from the near plane to the far plane, through an acceleration structure of the
// scene's transparent triangles (none flagged opaque). Each trace collects the K nearest
// candidate hits in a private array without confirming any, composites them front to back with
// `shade_at` (material, cutoff, texture, operator, coloured transmission, as every exact
// technique), then traces again from the K-th hit until a trace finds fewer than K (every
// layer composited: exact) or the transmittance is at most MIN_TRANSMITTANCE. The opaque
// surface is the shared opaque pass's: rays end at its depth and its colour is behind.
//
// Order of hits: nearer t first; equal t, the higher rank first (rank = (draw id, triangle
// index) order, as the reference breaks ties: the later-drawn fragment in front).
#include "common.wgsl"

// Hits collected per trace (the `k` parameter, at most MAX_K).
override RAY_K: u32 = 8u;
const MAX_K: u32 = 32u;
// Tracing stops once every channel of the transmittance is at most this (0: only when nothing
// behind can show).
override MIN_TRANSMITTANCE: f32 = 0.0;

struct RayParams {
    // The inverse of `camera.view_proj`, computed in f64 and rounded.
    inv_view_proj: mat4x4<f32>,
    // Window depth of the near plane and of the far plane (reverse-Z: 1 and 0).
    near_depth: f32,
    far_depth: f32,
    width: f32,
    height: f32,
    // 1 with reverse-Z (nearer is larger depth).
    reverse_z: u32,
    // Transparent triangles in the acceleration structure: bounds the traces of a pixel.
    triangle_count: u32,
    pad0: u32,
    pad1: u32,
}

// Per transparent triangle, by primitive index: x = its first vertex in the scene's vertex
// buffer, y = its rank, z = its draw.
@group(1) @binding(0) var tlas: acceleration_structure;
@group(1) @binding(1) var<uniform> trace_params: RayParams;
@group(1) @binding(2) var<storage, read> triangles: array<vec4<u32>>;
// The scene's vertex buffer (`oit_gpu::scene`: 13 words per vertex).
@group(1) @binding(3) var<storage, read> vertex_words: array<u32>;
// The opaque pass's colour (copied) and depth.
@group(1) @binding(4) var opaque_color: texture_2d<f32>;
@group(1) @binding(5) var opaque_depth: texture_depth_2d;

const VERTEX_WORDS: u32 = 13u;
// Relative difference of t under which two hits of one draw are one point (a shared edge).
const SAME_POINT: f32 = 1.0 / 1048576.0;

fn vertex_at(i: u32) -> VertexIn {
    let b = i * VERTEX_WORDS;
    var v: VertexIn;
    v.position = vec3<f32>(
        bitcast<f32>(vertex_words[b]),
        bitcast<f32>(vertex_words[b + 1u]),
        bitcast<f32>(vertex_words[b + 2u]),
    );
    v.material = vertex_words[b + 3u];
    v.color = vec4<f32>(
        bitcast<f32>(vertex_words[b + 4u]),
        bitcast<f32>(vertex_words[b + 5u]),
        bitcast<f32>(vertex_words[b + 6u]),
        bitcast<f32>(vertex_words[b + 7u]),
    );
    v.uv = vec2<f32>(bitcast<f32>(vertex_words[b + 8u]), bitcast<f32>(vertex_words[b + 9u]));
    v.normal = vec3<f32>(
        bitcast<f32>(vertex_words[b + 10u]),
        bitcast<f32>(vertex_words[b + 11u]),
        bitcast<f32>(vertex_words[b + 12u]),
    );
    return v;
}

// A ray through window position `p` (pixel units): from the near plane (t = 0) to the far
// plane (t = 1), both unprojected, so that t orders points as their window depth does.
struct PixelRay {
    origin: vec3<f32>,
    dir: vec3<f32>,
}

fn pixel_ray(p: vec2<f32>) -> PixelRay {
    let ndc = vec2<f32>(p.x / trace_params.width * 2.0 - 1.0, 1.0 - p.y / trace_params.height * 2.0);
    let a = trace_params.inv_view_proj * vec4<f32>(ndc, trace_params.near_depth, 1.0);
    let b = trace_params.inv_view_proj * vec4<f32>(ndc, trace_params.far_depth, 1.0);
    var r: PixelRay;
    r.origin = a.xyz / a.w;
    r.dir = b.xyz / b.w - r.origin;
    return r;
}

fn nearer(a: f32, b: f32) -> bool {
    return select((a < b), (a > b), trace_params.reverse_z != 0u);
}

// Window depth of the point at `t` on `r`.
fn window_depth(r: PixelRay, t: f32) -> f32 {
    let c = camera.view_proj * vec4<f32>(r.origin + t * r.dir, 1.0);
    return c.z / c.w;
}

// The ray parameter where `r` reaches window depth `d` (clip space is linear in t), a little
// beyond so that the exact test `nearer` decides the hits close to it; 1 past the far plane.
fn t_at_depth(r: PixelRay, d: f32) -> f32 {
    let c0 = camera.view_proj * vec4<f32>(r.origin, 1.0);
    let c1 = camera.view_proj * vec4<f32>(r.origin + r.dir, 1.0);
    let t = (d * c0.w - c0.z) / ((c1.z - c0.z) - d * (c1.w - c0.w));
    if !(t >= 0.0 && t < 1.0) {
        return 1.0;
    }
    return min(t * (1.0 + 1.0 / 1024.0) + 1.0 / 1048576.0, 1.0);
}

// Barycentrics (b1, b2) of the point where the line `o + t d` meets the plane of (p0, p1,
// p2), inside the triangle or not (Möller–Trumbore without the bounds).
fn plane_barycentrics(p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let q = cross(d, e2);
    let inv = 1.0 / dot(e1, q);
    let s = o - p0;
    let r = cross(s, e1);
    return vec2<f32>(dot(s, q), dot(d, r)) * inv;
}

// Whether two hits are one point of a surface: the same draw, triangles that share an edge
// (two vertices), t equal up to rounding — a ray through the shared edge meets both, and the
// rasterizer's fill rule gives the pixel to one of them.
fn same_point(draw_a: u32, t_a: f32, tri_a: u32, draw_b: u32, t_b: f32, tri_b: u32) -> bool {
    if draw_a != draw_b || tri_a == tri_b || abs(t_a - t_b) > SAME_POINT * t_b {
        return false;
    }
    let a = triangles[tri_a].x;
    let b = triangles[tri_b].x;
    var equal = 0u;
    for (var i = 0u; i < 3u; i++) {
        let p = vertex_at(a + i).position;
        for (var j = 0u; j < 3u; j++) {
            equal += u32(all(p == vertex_at(b + j).position));
        }
    }
    return equal >= 2u;
}

struct Hit {
    t: f32,
    rank: u32,
    draw: u32,
    triangle: u32,
    barycentrics: vec2<f32>,
}

// Whether hit (ta, ra) comes before (tb, rb) front to back.
fn before(ta: f32, ra: u32, tb: f32, rb: u32) -> bool {
    return ta < tb || (ta == tb && ra > rb);
}

// What triangle `tri` contributes where ray `r` of pixel `px` meets it at `b`.
fn shade_hit(tri: u32, b: vec2<f32>, r: PixelRay, px: vec2<f32>) -> Shaded {
    let first = triangles[tri].x;
    let i0 = vertex_at(first);
    let i1 = vertex_at(first + 1u);
    let i2 = vertex_at(first + 2u);
    let o0 = scene_vertex(i0);
    let o1 = scene_vertex(i1);
    let o2 = scene_vertex(i2);
    // The material is the draw's (every vertex of a draw has it): the first vertex's.
    // Attributes as a0 + (a1 − a0)·b1 + (a2 − a0)·b2, the plane form rasterizers interpolate
    // in: exact for a constant attribute (an alpha equal to its cutoff stays equal).
    var v = o0;
    v.color = o0.color + (o1.color - o0.color) * b.x + (o2.color - o0.color) * b.y;
    v.uv = o0.uv + (o1.uv - o0.uv) * b.x + (o2.uv - o0.uv) * b.y;
    v.world = o0.world + (o1.world - o0.world) * b.x + (o2.world - o0.world) * b.y;
    v.normal = o0.normal + (o1.normal - o0.normal) * b.x + (o2.normal - o0.normal) * b.y;
    // Counter-clockwise is front: the right-handed normal faces the viewer, against the ray.
    let front = dot(cross(i1.position - i0.position, i2.position - i0.position), r.dir) < 0.0;
    var grad = vec4<f32>(0.0);
    if TEXTURED {
        // Fine derivatives as a 2×2 quad takes them: differences across the quad's pixel
        // pairs, the texture coordinates of the triangle's plane at each pixel centre.
        let q = floor(px * 0.5) * 2.0 + vec2<f32>(0.5);
        var uvq: array<vec2<f32>, 3>;
        let corners = array<vec2<f32>, 3>(q, q + vec2<f32>(1.0, 0.0), q + vec2<f32>(0.0, 1.0));
        for (var k = 0u; k < 3u; k++) {
            let rk = pixel_ray(corners[k]);
            let bk = plane_barycentrics(i0.position, i1.position, i2.position, rk.origin, rk.dir);
            uvq[k] = i0.uv + (i1.uv - i0.uv) * bk.x + (i2.uv - i0.uv) * bk.y;
        }
        grad = vec4<f32>(uvq[1] - uvq[0], uvq[2] - uvq[0]);
    }
    return shade_at(v, front, grad);
}

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs_trace(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let xy = vec2<i32>(position.xy);
    let behind = textureLoad(opaque_color, xy, 0).rgb;
    let opaque = textureLoad(opaque_depth, xy, 0);
    let r = pixel_ray(position.xy);
    let t_max = t_at_depth(r, opaque);
    var color = vec3<f32>(0.0);
    var transmittance = vec3<f32>(1.0);
    var hits: array<Hit, MAX_K>;
    // The last hit composited: the next trace takes only hits after it.
    var from_t = 0.0;
    var from_rank = 0u;
    var from_draw = 0xffffffffu;
    var from_triangle = 0u;
    var started = false;
    // Each trace composites at least one new hit, so this bound is never what stops a pixel.
    // Declared outside the loop and initialised again per trace: a `ray_query` declared in the
    // loop body lost the device on lavapipe 25.0.7 (docs/findings/2026-12-07-ray-query.md).
    var rq: ray_query;
    for (var trace = 0u; trace <= trace_params.triangle_count; trace++) {
        rayQueryInitialize(&rq, tlas, RayDesc(0u, 0xffu, from_t, t_max, r.origin, r.dir));
        var n = 0u;
        while rayQueryProceed(&rq) {
            let h = rayQueryGetCandidateIntersection(&rq);
            if h.kind != RAY_QUERY_INTERSECTION_TRIANGLE {
                continue;
            }
            let rank = triangles[h.primitive_index].y;
            let draw = triangles[h.primitive_index].z;
            if started && (!before(from_t, from_rank, h.t, rank)
                || same_point(from_draw, from_t, from_triangle, draw, h.t, h.primitive_index)) {
                continue;
            }
            if !nearer(window_depth(r, h.t), opaque) {
                continue;
            }
            // Insertion into the sorted K nearest; the second hit of a shared edge is not kept.
            var duplicate = false;
            for (var j = 0u; j < n; j++) {
                duplicate = duplicate || same_point(hits[j].draw, hits[j].t, hits[j].triangle,
                    draw, h.t, h.primitive_index);
            }
            if duplicate || (n == RAY_K && !before(h.t, rank, hits[n - 1u].t, hits[n - 1u].rank)) {
                continue;
            }
            var i = min(n, RAY_K - 1u);
            n = min(n + 1u, RAY_K);
            while i > 0u && before(h.t, rank, hits[i - 1u].t, hits[i - 1u].rank) {
                hits[i] = hits[i - 1u];
                i -= 1u;
            }
            hits[i] = Hit(h.t, rank, draw, h.primitive_index, h.barycentrics);
        }
        for (var j = 0u; j < n; j++) {
            let s = shade_hit(hits[j].triangle, hits[j].barycentrics, r, position.xy);
            if s.keep {
                color += transmittance * s.color;
                transmittance *= s.transmittance;
            }
        }
        if n < RAY_K || all(transmittance <= vec3<f32>(MIN_TRANSMITTANCE)) {
            break;
        }
        from_t = hits[n - 1u].t;
        from_rank = hits[n - 1u].rank;
        from_draw = hits[n - 1u].draw;
        from_triangle = hits[n - 1u].triangle;
        started = true;
    }
    return vec4<f32>(color + transmittance * behind, 1.0);
}
