// Copies the opaque pass's colour and depth into other targets with a fullscreen triangle
// (oit-stochastic): into every sample of the multisampled targets of `a2c:` (the fragment runs
// once per pixel and writes all covered samples), and into the per-frame targets of
// `stochastic:spp=N`. A draw rather than copy_texture_to_texture, which does not copy depth on
// the GL backend.

@group(0) @binding(0) var opaque_color: texture_2d<f32>;
// Depth32Float bound as an unfilterable float texture (WebGPU allows it): GLSL, for the GL
// backend, has no texelFetch of depth (shadow) textures.
@group(0) @binding(1) var opaque_depth: texture_2d<f32>;

struct SeedOut {
    @location(0) color: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

// One triangle covering the viewport.
@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(i & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

@fragment
fn fs_seed(@builtin(position) position: vec4<f32>) -> SeedOut {
    let p = vec2<i32>(position.xy);
    var out: SeedOut;
    out.color = textureLoad(opaque_color, p, 0);
    out.depth = textureLoad(opaque_depth, p, 0).x;
    return out;
}
