// Weighted blended OIT tail (McGuire & Bavoil 2013): the weight and the two accumulation outputs.
//
// Shared by the `wboit` technique and by `dual-peel:tail=wboit` (oit_wboit::tail::WGSL is this
// file). It has no bindings and no includes; a pass appends it to its own source. Scene-dependent
// values come either as function arguments or as the pipeline-overridable constants below.

// The `range` weight's scene inputs (oit_wboit::RangeParams), for callers that use
// `wboit_weight_default`: the transparent depth interval [near, far] as view distances and the
// fall in bits; and the unit of the colour sums (a power of two, 1 for LDR colours), which the
// composite multiplies back. Set them with oit_wboit::tail::AccumTargets::prepare(scene).
override wboit_z_near: f32 = 0.1;
override wboit_z_far: f32 = 1000.0;
override wboit_range_fall: f32 = 8.0;
override wboit_color_scale: f32 = 1.0;
// The projection terms that turn window depth back into view distance (see
// `wboit_view_distance`); the defaults are a standard perspective with near 0.1, far 1000.
override wboit_proj_a: f32 = -1.0001;
override wboit_proj_b: f32 = -0.10001;
override wboit_ortho: bool = false;

// Largest `range` weight: 2^8, so 255 layers of alpha 1 and colour at most the colour scale
// still fit in fp16 (65504).
const WBOIT_RANGE_MAX: f32 = 256.0;
// Largest fall (bits): the smallest weight 256 * 2^-21 = 2^-13 stays a normal fp16 number. The
// CPU lowers the scene's fall further so that alpha * w of its faintest layer stays normal too
// (oit_wboit::range::fall_cap).
const WBOIT_RANGE_MAX_FALL: f32 = 21.0;

// View distance (positive, along the view axis) of a fragment from its window depth, for the
// f32 projection matrix `proj` of the camera: a = proj[2][2], b = proj[3][2]. Perspective
// (either depth direction): window z = -a + b / dist. Orthographic: window z = b - a * dist.
fn wboit_view_distance(window_z: f32, a: f32, b: f32, ortho: bool) -> f32 {
    if ortho {
        return (b - window_z) / a;
    }
    return b / (window_z + a);
}

// `wboit_view_distance` with the overridable constants.
fn wboit_view_distance_default(window_z: f32) -> f32 {
    return wboit_view_distance(window_z, wboit_proj_a, wboit_proj_b, wboit_ortho);
}

// The `range` weight: an estimate of the transmittance in front of the fragment. t is the
// fragment's position in the transparent interval (0 at the near end, 1 at the far end) and
// `fall` the absorbance in bits the scene puts in front of its farthest fragments (see
// oit_wboit::RangeParams), assumed spread evenly over the interval:
// w = 256 * 2^(-fall * t), fall clamped to [0, 21]. No alpha factor: alpha already enters the
// sums (C = alpha * c and alpha * w), and the exact weight is the transmittance alone.
fn wboit_weight_range(view_z: f32, z_near: f32, z_far: f32, fall: f32) -> f32 {
    let span = z_far - z_near;
    var t = 0.0;
    if span > 0.0 {
        t = clamp((view_z - z_near) / span, 0.0, 1.0);
    }
    return WBOIT_RANGE_MAX * exp2(-clamp(fall, 0.0, WBOIT_RANGE_MAX_FALL) * t);
}

// The default weight (the `range` weight with the overridable constants). `window_z` and
// `alpha` are unused by this weight; they are in the signature so the default can change
// without callers.
fn wboit_weight_default(view_z: f32, window_z: f32, alpha: f32) -> f32 {
    return wboit_weight_range(view_z, wboit_z_near, wboit_z_far, wboit_range_fall);
}

// The two accumulation outputs of one fragment: location 0 (additive) gets
// (premultiplied colour / color_scale * w, alpha * w); location 1 (blend zero, one-minus-src)
// gets alpha in .r, so it holds the revealage prod(1 - alpha). `color_scale` is a power of two
// (exact to divide by) that keeps HDR colour sums inside fp16; the composite multiplies it back.
struct WboitAccum {
    accum: vec4<f32>,
    reveal: vec4<f32>,
}

fn wboit_accumulate(premultiplied: vec3<f32>, alpha: f32, weight: f32, color_scale: f32) -> WboitAccum {
    var out: WboitAccum;
    out.accum = vec4<f32>(premultiplied * (weight / color_scale), alpha * weight);
    out.reveal = vec4<f32>(alpha, 0.0, 0.0, 0.0);
    return out;
}
