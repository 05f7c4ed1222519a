// pygfx's `dither` method (oit-per-object `stochastic`): a fragment whose α is below 1 − 1e-6
// and below the pseudo-blue threshold of its seeded pixel is discarded; the rest are written
// opaque (α = 1, blend One/Zero) with their straight colour and depth.
#include "common.wgsl"
#include "per_object_noise.wgsl"

// Per draw (indexed by the instance index, which is the draw's index): its first vertex and
// its object id (the draw id + 1: pygfx numbers objects from 1).
struct DrawSeed {
    first_vertex: u32,
    object_id: u32,
}

@group(1) @binding(0) var<storage, read> draw_seeds: array<DrawSeed>;

struct DitherOut {
    @invariant @builtin(position) clip: vec4<f32>,
    // The fields of `VertexOut` (common.wgsl), which an entry-point struct cannot nest.
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) base_alpha: vec4<f32>,
    @location(2) @interpolate(flat) factors: vec3<f32>,
    @location(3) @interpolate(flat) flags: u32,
    @location(4) uv: vec2<f32>,
    @location(5) @interpolate(flat) emissive: vec3<f32>,
    @location(6) @interpolate(flat) textures: vec4<u32>,
    @location(7) @interpolate(flat) surface: vec3<f32>,
    @location(8) world: vec3<f32>,
    @location(9) normal: vec3<f32>,
    // The element seed's pixel offset of this triangle.
    @location(10) @interpolate(flat) offset: vec2<u32>,
}

@vertex
fn vs_dither(
    v: VertexIn,
    @builtin(vertex_index) vertex: u32,
    @builtin(instance_index) draw: u32,
) -> DitherOut {
    let base = scene_vertex(v);
    let seed = draw_seeds[draw];
    var out: DitherOut;
    out.clip = base.clip;
    out.color = base.color;
    out.base_alpha = base.base_alpha;
    out.factors = base.factors;
    out.flags = base.flags;
    out.uv = base.uv;
    out.emissive = base.emissive;
    out.textures = base.textures;
    out.surface = base.surface;
    out.world = base.world;
    out.normal = base.normal;
    // The face index within the object (pygfx's `elementIndex` of a mesh).
    out.offset = element_offset(seed.object_id, (vertex - seed.first_vertex) / 3u);
    return out;
}

@fragment
fn fs_dither(v: DitherOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    var base: VertexOut;
    base.clip = v.clip;
    base.color = v.color;
    base.base_alpha = v.base_alpha;
    base.factors = v.factors;
    base.flags = v.flags;
    base.uv = v.uv;
    base.emissive = v.emissive;
    base.textures = v.textures;
    base.surface = v.surface;
    base.world = v.world;
    base.normal = v.normal;
    let s = shade(base, front_facing);
    if !s.keep {
        discard;
    }
    let alpha = s.alpha;
    if alpha < 1.0 {
        let threshold = pseudo_blue(vec2<u32>(v.clip.xy) + v.offset);
        if alpha < 1.0 - 1e-6 && alpha < threshold {
            discard;
        }
    }
    // Survivors are opaque: the straight colour (pygfx colours are straight; ours P = α·c).
    return vec4<f32>(select(s.color, s.color / alpha, alpha > 0.0), 1.0);
}
