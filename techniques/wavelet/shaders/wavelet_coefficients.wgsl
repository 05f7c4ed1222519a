// The pixel's Haar coefficients, N / 4 RGBA targets bound at group 2, bindings 1-8 (binding 0
// is the including pass's own: the depth interval, or the composite's accumulator). Groups
// beyond the rank's are never read; the technique binds the first target in their place.
#include "wavelet_math.wgsl"

@group(2) @binding(1) var coefficients0: texture_2d<f32>;
@group(2) @binding(2) var coefficients1: texture_2d<f32>;
@group(2) @binding(3) var coefficients2: texture_2d<f32>;
@group(2) @binding(4) var coefficients3: texture_2d<f32>;
@group(2) @binding(5) var coefficients4: texture_2d<f32>;
@group(2) @binding(6) var coefficients5: texture_2d<f32>;
@group(2) @binding(7) var coefficients6: texture_2d<f32>;
@group(2) @binding(8) var coefficients7: texture_2d<f32>;

fn put_group(c: ptr<function, array<f32, 32>>, group: u32, v: vec4<f32>) {
    (*c)[4u * group] = v.x;
    (*c)[4u * group + 1u] = v.y;
    (*c)[4u * group + 2u] = v.z;
    (*c)[4u * group + 3u] = v.w;
}

fn load_coefficients(rank: u32, xy: vec2<i32>) -> array<f32, 32> {
    var c: array<f32, 32>;
    let groups = wavelet_coefficient_count(rank) / 4u;
    put_group(&c, 0u, textureLoad(coefficients0, xy, 0));
    put_group(&c, 1u, textureLoad(coefficients1, xy, 0));
    if groups > 2u {
        put_group(&c, 2u, textureLoad(coefficients2, xy, 0));
        put_group(&c, 3u, textureLoad(coefficients3, xy, 0));
    }
    if groups > 4u {
        put_group(&c, 4u, textureLoad(coefficients4, xy, 0));
        put_group(&c, 5u, textureLoad(coefficients5, xy, 0));
        put_group(&c, 6u, textureLoad(coefficients6, xy, 0));
        put_group(&c, 7u, textureLoad(coefficients7, xy, 0));
    }
    return c;
}
