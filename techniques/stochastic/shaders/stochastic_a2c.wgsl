// Alpha-to-coverage (oit-stochastic `a2c:` technique): MSAA targets seeded from the shared
// single-sample opaque pass, transparent fragments written opaque with depth while the hardware
// turns their α into a sample mask, then the samples resolved into the final colour.
#include "common.wgsl"

// Straight colour and α: alpha-to-coverage keeps ≈ α·N of the N samples (the mask is the
// driver's choice and the same for the same α), each sample then holds this colour opaquely.
@fragment
fn fs_a2c(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep || !(s.alpha > 0.0) {
        discard;
    }
    let straight = s.color / s.alpha;
    return vec4<f32>(clamp(straight, vec3<f32>(-65504.0), vec3<f32>(65504.0)), clamp(s.alpha, 0.0, 1.0));
}
