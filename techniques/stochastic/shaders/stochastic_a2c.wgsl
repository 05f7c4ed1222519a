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

// Additive and subtractive fragments (P, alpha = 0, t = 1) cover no sample. Drawn after the
// alpha-to-coverage draws, depth-tested per sample without depth writes and added with (one, one)
// blending, each adds P to the samples where no kept layer lies in front of it: after the
// resolve, P times the fraction of samples that see it (Enderton et al.'s accumulation pass with
// the coverage masks as the visibility estimate).
@fragment
fn fs_additive(v: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let s = shade(v, front_facing);
    if !s.keep {
        discard;
    }
    return vec4<f32>(s.color, 0.0);
}
