// The per-draw form of the scene pass interface for unlit textured materials, composed in place of
// shaders/scene_io/vertex.wgsl by `oit_gpu::ScenePipelines` for draws of small triangles: the
// fragment stage reads the draw's material from `draw_material`, a uniform at the draw's
// dynamic offset (`oit_gpu::GpuScene::use_draw`), and nothing about it travels per vertex. On
// lavapipe 12 000 small billboards drew at 2.4× the floor with the per-vertex form, each flat
// varying costing per-triangle setup; a uniform read costs per fragment instead, which loses on
// large triangles. The values are the same bits either way.

@group(0) @binding(3) var<uniform> draw_material: Material;

struct VertexOut {
    // Invariant so that a depth-only pass and an EQUAL-depth pass produce identical depths.
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) uv: vec2<f32>,
}

// The vertex stage every scene pass shares (passes with their own vertex entry call it too).
fn scene_vertex(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = camera.view_proj * vec4<f32>(v.position, 1.0);
    out.color = v.color;
    out.uv = v.uv;
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

// The interpolated texture coordinates.
fn texcoord(v: VertexOut) -> vec2<f32> {
    return v.uv;
}

// Never called: lit materials use draw_lit.wgsl. These forms carry no world position or normal:
// lavapipe sets up varyings a fragment stage does not read, and the two cost 12 000 unlit
// billboards a quarter of their blending time (docs/findings/2026-12-07-peers-at-equal-format.md,
// "Unlit per-draw forms").
fn surface_position(v: VertexOut) -> vec3<f32> {
    return vec3<f32>(0.0);
}

fn surface_normal(v: VertexOut) -> vec3<f32> {
    return vec3<f32>(0.0, 0.0, 1.0);
}
