// Stochastic transparency by dithered alpha testing (oit-stochastic `stochastic:` technique).
//
// Every transparent fragment survives with probability α: it is kept when its coverage exceeds
// a threshold in [0, 1) from a pattern (white noise, a tiled blue-noise or Bayer array, or
// Wyman & McGuire's hashed alpha), and is then written as an OPAQUE fragment with its straight
// colour and its depth. The nearest survivor wins the depth test, so the expected colour is
// Σ c_i α_i Π_{j<i}(1 − α_j) + Π(1 − α_j) C_o: the exact composite, in expectation.
//
// Coloured transmission: a scene whose filters differ per channel is dithered once per colour
// channel (the pipeline constant CHANNEL, a colour write mask for that channel, the depth reset
// to the opaque depth before each). In channel c a transmissive fragment survives with
// probability 1 − t_c and writes C_c / (1 − t_c), so the channel's expected value is
// Σ C_i,c Π_{j<i} t_j,c + Π t_j,c C_o,c: the per-channel composite, in expectation.
#include "common.wgsl"

// One sub-frame's parameters (bound with a dynamic offset, one entry per averaged sample).
struct Dither {
    // 0 white, 1 tiled table (blue noise or Bayer), 2 hashed alpha, 3 spatiotemporal blue noise.
    pattern: u32,
    // 0 none (same pattern on every layer), 1 per object, 2 per primitive.
    seed_mode: u32,
    // Side of the threshold table (tiled patterns; a power of two).
    tile: u32,
    // Sub-frame: animation frame × spp + sample (white and hashed hash it in).
    frame: u32,
    // R2 shift of the tile for this sub-frame (STBN: for its period), in pixels.
    frame_offset: vec2<u32>,
    // Golden-ratio rotation of the threshold value for this sub-frame (tiled patterns; 0 for
    // STBN).
    rotation: f32,
    // Wyman & McGuire's hash scale (1 as in Falcor: one hash cell per pixel).
    hash_scale: f32,
    // First row of this sub-frame's slice in the table (STBN stacks its slices vertically;
    // 0 for the other patterns).
    slice_row: u32,
}

@group(1) @binding(0) var<uniform> dither: Dither;
// `tile²` thresholds (rank + ½)/tile², one R32Float texel each (a texture, not a storage
// buffer: the per-fragment read is several times cheaper on CPU rasterizers); STBN stacks its
// slices of `tile²` vertically.
@group(1) @binding(1) var table: texture_2d<f32>;

// 0, 1, 2: the colour channel this pass dithers (coloured transmission); 3: all at once by α.
override CHANNEL: u32 = 3u;

const PATTERN_WHITE: u32 = 0u;
const PATTERN_TILED: u32 = 1u;
const PATTERN_HASHED: u32 = 2u;
const PATTERN_STBN: u32 = 3u;
const SEED_NONE: u32 = 0u;
const SEED_OBJECT: u32 = 1u;

struct StochasticOut {
    @invariant @builtin(position) clip: vec4<f32>,
    // The fields of `VertexOut` (common.wgsl), which an entry-point struct cannot nest.
    @location(0) color: vec4<f32>,
    @location(1) @interpolate(flat) base_alpha: vec4<f32>,
    @location(2) @interpolate(flat) factors: vec3<f32>,
    @location(3) @interpolate(flat) flags: u32,
    @location(4) uv: vec2<f32>,
    @location(5) @interpolate(flat) emissive: vec3<f32>,
    @location(6) @interpolate(flat) textures: vec4<u32>,
    // World position: the scene's vertices are already in world space and every instance is its
    // own draw, so this is the stable per-surface coordinate hashed alpha needs (object space
    // up to a rigid transform per object).
    @location(7) world: vec3<f32>,
    // Pattern seed: 0, the draw id's hash, or the hash of the draw id and triangle.
    @location(8) @interpolate(flat) seed: u32,
    // `VertexOut.surface` and `VertexOut.normal` (lit materials; `world` above is its `world`).
    @location(9) @interpolate(flat) surface: vec3<f32>,
    @location(10) normal: vec3<f32>,
}

// PCG hash (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering").
fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// pcg4d from the same paper: four well-mixed words from four inputs.
fn pcg4d(a: vec4<u32>) -> vec4<u32> {
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

// Uniform in [0, 1) with 24 bits, exactly representable in f32.
fn unit(h: u32) -> f32 {
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

// The instance index carries the draw id (each draw is issued as instance `id..id + 1`); the
// vertex index of a non-indexed triangle list is unique per triangle after dividing by 3.
@vertex
fn vs_stochastic(
    v: VertexIn,
    @builtin(vertex_index) vertex: u32,
    @builtin(instance_index) draw_id: u32,
) -> StochasticOut {
    let base = scene_vertex(v);
    var out: StochasticOut;
    out.clip = base.clip;
    out.color = base.color;
    out.base_alpha = base.base_alpha;
    out.factors = base.factors;
    out.flags = base.flags;
    out.uv = base.uv;
    out.emissive = base.emissive;
    out.textures = base.textures;
    out.world = v.position;
    out.surface = base.surface;
    out.normal = base.normal;
    let object_seed = pcg(draw_id + 1u);
    if dither.seed_mode == SEED_NONE {
        out.seed = 0u;
    } else if dither.seed_mode == SEED_OBJECT {
        out.seed = object_seed;
    } else {
        out.seed = pcg(object_seed ^ pcg(vertex / 3u + 1u));
    }
    return out;
}

// Tiled table lookup. The seed shifts the tile toroidally (16 bits each for x and y); sub-frame
// k shifts it along the R2 sequence (all layers alike) and rotates the threshold value
// (Cranley–Patterson): by k/φ when every layer shares the pattern (seed none), and by a hash
// of (seed, k) for k ≥ 1 otherwise. A rotation common to all layers would keep two layers'
// threshold differences fixed from frame to frame; for a structured table (Bayer) the average
// then converges to a biased value. Sub-frame 0 is the plain pattern.
// STBN reads the slice of sub-frame k (its rows from `slice_row`), shifted by the R2 offset of
// its period and not rotated: each pixel's values over the slices are the blue sequence, and
// the seed shift already gives every layer another pixel's sequence.
fn tiled_threshold(pixel: vec2<u32>, seed: u32) -> f32 {
    let t = dither.tile;
    // Tiles are powers of two: a mask instead of `%` (integer division is slow on CPU
    // rasterizers, where it is not vectorized).
    let mask = vec2<u32>(t - 1u);
    let seed_shift = vec2<u32>(seed & 0xffffu, seed >> 16u);
    let q = (pixel + seed_shift + dither.frame_offset) & mask;
    var rotation = dither.rotation;
    if dither.pattern == PATTERN_TILED && dither.seed_mode != SEED_NONE && dither.frame > 0u {
        rotation = unit(pcg(seed ^ pcg(dither.frame + 0x632be5abu)));
    }
    return fract(textureLoad(table, vec2<u32>(q.x, q.y + dither.slice_row), 0).r + rotation);
}

fn white_threshold(pixel: vec2<u32>, seed: u32) -> f32 {
    return unit(pcg4d(vec4<u32>(pixel, seed, dither.frame)).x);
}

// Hash of an integer lattice cell (replaces the sin-based h3 of the paper, which loses
// precision far from the origin), salted with the seed and the frame.
fn cell_hash(cell: vec3<f32>, seed: u32) -> f32 {
    let c = bitcast<vec3<u32>>(vec3<i32>(cell));
    let h = pcg4d(vec4<u32>(c, seed ^ pcg(dither.frame + 0x9e3779b9u)));
    return unit(h.x);
}

// Wyman & McGuire 2017, isotropic hashed alpha threshold with the CDF correction. `dx`, `dy`
// are the screen derivatives of `p`, taken in uniform control flow by the caller.
fn hashed_threshold(p: vec3<f32>, dx: vec3<f32>, dy: vec3<f32>, seed: u32) -> f32 {
    let max_deriv = max(max(length(dx), length(dy)), 1e-30);
    let pix_scale = 1.0 / (dither.hash_scale * max_deriv);
    let l = log2(pix_scale);
    // Two hash lattices at the power-of-two scales around one cell per pixel, blended so the
    // noise neither swims nor pops as the scale changes.
    let lo = cell_hash(floor(exp2(floor(l)) * p), seed);
    let hi = cell_hash(floor(exp2(ceil(l)) * p), seed);
    let f = fract(l);
    let x = mix(lo, hi, f);
    // A blend of two uniforms is not uniform: map it through the blend's CDF.
    let a = min(f, 1.0 - f);
    var t: f32;
    if x < a {
        t = x * x / (2.0 * a * (1.0 - a));
    } else if x < 1.0 - a {
        t = (x - 0.5 * a) / (1.0 - a);
    } else {
        t = 1.0 - (1.0 - x) * (1.0 - x) / (2.0 * a * (1.0 - a));
    }
    return clamp(t, 1e-6, 1.0);
}

@fragment
fn fs_stochastic(v: StochasticOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    // Derivatives first, while control flow is still uniform.
    let dx = dpdx(v.world);
    let dy = dpdy(v.world);
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
    // The coverage this pass tests: α, or for a transmissive material in a per-channel pass
    // that channel's opacity 1 − t (scalar-alpha materials keep α bit for bit).
    var opacity = s.alpha;
    let m = material_of(base);
    if CHANNEL < 3u && (m.transmission > 0.0 || m.blend_operator == OPERATOR_MULTIPLY) {
        // `min`: with CHANNEL = 3 a constant index past the vector's end fails validation,
        // even where the branch is never taken.
        opacity = 1.0 - s.transmittance[min(CHANNEL, 2u)];
    }
    let pixel = vec2<u32>(v.clip.xy);
    var survive: bool;
    if dither.pattern == PATTERN_WHITE {
        survive = opacity > white_threshold(pixel, v.seed);
    } else if dither.pattern == PATTERN_TILED || dither.pattern == PATTERN_STBN {
        survive = opacity > tiled_threshold(pixel, v.seed);
    } else {
        // The paper's test: discard when α < threshold, threshold in [1e-6, 1].
        survive = opacity >= hashed_threshold(v.world, dx, dy, v.seed);
    }
    if !survive {
        discard;
    }
    // Survivors have opacity > 0. Straight colour, clamped to the largest finite half so a
    // tiny opacity under a premultiplied colour cannot overflow a Rgba16Float target.
    let straight = s.color / opacity;
    return vec4<f32>(clamp(straight, vec3<f32>(-65504.0), vec3<f32>(65504.0)), 1.0);
}

// Additive and subtractive fragments (P, alpha = 0, t = 1) never survive the dither. After the
// dithered draws of a sub-frame (or of one channel) they are drawn depth-tested against the
// survivors without depth writes and added with (one, one) blending (the channel's write mask
// in a per-channel pass): one lands exactly when no survivor lies in front of it, which happens
// with probability prod(1 - alpha_j) (per channel prod t_j) over the layers in front. Enderton et
// al.'s accumulation pass with the stochastic depth as the visibility test: the exact composite
// in expectation.
@fragment
fn fs_additive(v: StochasticOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
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
    return vec4<f32>(s.color, 0.0);
}
