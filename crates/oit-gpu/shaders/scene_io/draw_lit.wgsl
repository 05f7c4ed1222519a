// The per-draw form of the scene pass interface for lit materials (textured or not: an
// untextured one never reads `uv`): draw.wgsl with the world position and normal the lighting
// reads. The unlit forms leave those two out, as lavapipe sets up varyings a fragment stage
// does not read (docs/findings/2026-12-07-peers-at-equal-format.md, "Unlit per-draw forms").

@group(0) @binding(3) var<uniform> draw_material: Material;

struct VertexOut {
    // Invariant so that a depth-only pass and an EQUAL-depth pass produce identical depths.
    @invariant @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) uv: vec2<f32>,
    // World position and normal, read only by lit pipelines (`LIT`).
    @location(2) world: vec3<f32>,
    @location(3) normal: vec3<f32>,
}

// The vertex stage every scene pass shares (passes with their own vertex entry call it too).
fn scene_vertex(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = camera.view_proj * vec4<f32>(v.position, 1.0);
    out.color = v.color;
    out.world = v.position;
    out.normal = v.normal;
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

// The interpolated world position and normal of a lit fragment.
fn surface_position(v: VertexOut) -> vec3<f32> {
    return v.world;
}

fn surface_normal(v: VertexOut) -> vec3<f32> {
    return v.normal;
}
