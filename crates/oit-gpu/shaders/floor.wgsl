// The floor of one blended pass: the transparent draws with the cheapest fragment work there is
// (interpolated vertex colour, premultiplied OVER), over the same targets with the same depth test
// as `unsorted`. Not a technique: the harness times it per scene so that every technique's cost
// can be read against what one blended pass costs on the adapter.
#include "common.wgsl"

struct FloorOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
}

@vertex
fn vs_floor(v: VertexIn) -> FloorOut {
    var out: FloorOut;
    out.clip = camera.view_proj * vec4<f32>(v.position, 1.0);
    out.color = v.color;
    return out;
}

@fragment
fn fs_floor(v: FloorOut) -> @location(0) vec4<f32> {
    return vec4<f32>(v.color.rgb * v.color.a, v.color.a);
}
