// The per-vertex form of the scene pass interface (included by common.wgsl): the vertex stage
// reads the vertex's material from the table and passes it on as flat varyings, copied
// bit-exactly from the provoking vertex. One draw call may mix materials (sorted-triangle's
// stream). Cheap per fragment, but each flat location costs a CPU rasterizer per-triangle setup
// like an interpolated one: shaders/scene_io/draw.wgsl is the form for draws of small triangles.

struct VertexOut {
    // Invariant so that a depth-only pass and an EQUAL-depth pass produce identical depths.
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
    // The vertex's material. Reading the storage table per fragment instead cost about 10× the
    // rest of the fragment on CPU rasterizers (lavapipe).
    @location(1) @interpolate(flat) base_alpha: vec4<f32>,
    // x = cutoff, y = intensity, z = transmission.
    @location(2) @interpolate(flat) factors: vec3<f32>,
    // mode | premultiplied << 2 | double_sided << 3 | wrap << 4 (24 bits) | blend operator << 28
    // (see `material_flags`).
    @location(3) @interpolate(flat) flags: u32,
    @location(4) uv: vec2<f32>,
    @location(5) @interpolate(flat) emissive: vec3<f32>,
    @location(6) @interpolate(flat) textures: vec4<u32>,
    // Lighting: x = metallic, y = roughness, z = the specular code; then the world position
    // and normal, interpolated. Unlit pipelines (`LIT` false) never read them, and the
    // pipeline's linker drops what its fragment stage does not read.
    @location(7) @interpolate(flat) surface: vec3<f32>,
    @location(8) world: vec3<f32>,
    @location(9) normal: vec3<f32>,
}

fn material_flags(m: Material) -> u32 {
    return m.mode | (m.premultiplied << 2u) | (m.double_sided << 3u) | (m.wrap << 4u)
        | (m.blend_operator << 28u);
}

// The vertex stage every scene pass shares (passes with their own vertex entry call it too).
fn scene_vertex(v: VertexIn) -> VertexOut {
    let m = materials[v.material];
    var out: VertexOut;
    out.clip = camera.view_proj * vec4<f32>(v.position, 1.0);
    out.color = v.color;
    out.base_alpha = m.base_alpha;
    out.factors = vec3<f32>(m.cutoff, m.intensity, m.transmission);
    out.flags = material_flags(m);
    out.uv = v.uv;
    out.emissive = m.emissive;
    out.textures = m.textures;
    out.surface = vec3<f32>(m.metallic, m.roughness, f32(m.specular));
    out.world = v.position;
    out.normal = v.normal;
    return out;
}

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    return scene_vertex(v);
}

// The material as the vertex stage passed it: the same values as `materials[v.material]`.
fn material_of(v: VertexOut) -> Material {
    var m: Material;
    m.base_alpha = v.base_alpha;
    m.emissive = v.emissive;
    m.mode = v.flags & 3u;
    m.cutoff = v.factors.x;
    m.premultiplied = (v.flags >> 2u) & 1u;
    m.intensity = v.factors.y;
    m.transmission = v.factors.z;
    m.double_sided = (v.flags >> 3u) & 1u;
    m.textures = v.textures;
    m.wrap = (v.flags >> 4u) & 0xffffffu;
    m.blend_operator = v.flags >> 28u;
    m.metallic = v.surface.x;
    m.roughness = v.surface.y;
    m.specular = u32(v.surface.z);
    return m;
}

// The interpolated world position and normal of a lit fragment.
fn surface_position(v: VertexOut) -> vec3<f32> {
    return v.world;
}

fn surface_normal(v: VertexOut) -> vec3<f32> {
    return v.normal;
}

// The interpolated texture coordinates.
fn texcoord(v: VertexOut) -> vec2<f32> {
    return v.uv;
}
