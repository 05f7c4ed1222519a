// The per-draw form of the scene pass interface for untextured materials (draw.wgsl without
// texture coordinates, which `shade()` then never reads): one varying less to set up per
// triangle, as per-draw draws are those of small triangles.

@group(0) @binding(3) var<uniform> draw_material: Material;

struct VertexOut {
    // Invariant so that a depth-only pass and an EQUAL-depth pass produce identical depths.
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
    // World position and normal, read only by lit pipelines (`LIT`).
    @location(1) world: vec3<f32>,
    @location(2) normal: vec3<f32>,
}

// The vertex stage every scene pass shares (passes with their own vertex entry call it too).
fn scene_vertex(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = camera.view_proj * vec4<f32>(v.position, 1.0);
    out.color = v.color;
    out.world = v.position;
    out.normal = v.normal;
    return out;
}

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    return scene_vertex(v);
}

// The draw's material.
fn material_of(v: VertexOut) -> Material {
    return draw_material;
}

// Never called: pipelines of untextured materials compile the texture code out (`TEXTURED`).
fn texcoord(v: VertexOut) -> vec2<f32> {
    return vec2<f32>(0.0);
}

// The interpolated world position and normal of a lit fragment.
fn surface_position(v: VertexOut) -> vec3<f32> {
    return v.world;
}

fn surface_normal(v: VertexOut) -> vec3<f32> {
    return v.normal;
}
