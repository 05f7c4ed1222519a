// Weighted blended OIT tail (McGuire & Bavoil 2013): the weight and the two accumulation outputs.
//
// Shared by the `wboit` technique and by `dual-peel:tail=wboit` (oit_wboit::tail::WGSL is this
// file). It has no bindings and no includes; a pass appends it to its own source. Scene-dependent
// values come either as function arguments or as the pipeline-overridable constants below.

// The transparent depth interval [near, far] of the `range` weight as view distances, for callers
// that use `wboit_weight_default` (set them with oit_wboit::tail::pipeline_constants(scene)).
override wboit_z_near: f32 = 0.1;
override wboit_z_far: f32 = 1000.0;
// The projection terms that turn window depth back into view distance (see
// `wboit_view_distance`); the defaults are a standard perspective with near 0.1, far 1000.
override wboit_proj_a: f32 = -1.0001;
override wboit_proj_b: f32 = -0.10001;
override wboit_ortho: bool = false;

// Largest `range` weight: 2^8, so 255 layers of alpha 1 and colour 1 still fit in fp16 (65504).
const WBOIT_RANGE_MAX: f32 = 256.0;
// Doublings the `range` weight falls across the interval (nearest 256, farthest 256 / 2^K).
const WBOIT_RANGE_FALL: f32 = 8.0;

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

// The `range` weight: t is the fragment's position in the transparent interval on a log scale
// (0 at the near end, 1 at the far end) and w = alpha * 256 * 2^(-8 t). A log scale gives every
// decade of a huge interval the same share of the curve; 256 keeps fp16 sums finite for 255
// opaque layers and 1 = 256 / 2^8 keeps alpha = 1/512 contributions (2e-3) normal in fp16.
fn wboit_weight_range(view_z: f32, alpha: f32, z_near: f32, z_far: f32) -> f32 {
    let lo = log2(max(z_near, 1e-30));
    let span = log2(max(z_far, z_near)) - lo;
    var t = 0.0;
    if span > 1e-6 {
        t = clamp((log2(max(view_z, 1e-30)) - lo) / span, 0.0, 1.0);
    }
    return alpha * WBOIT_RANGE_MAX * exp2(-WBOIT_RANGE_FALL * t);
}

// The default weight (the `range` weight over [wboit_z_near, wboit_z_far]). `window_z` is
// unused by this weight; it is in the signature so the default can change without callers.
fn wboit_weight_default(view_z: f32, window_z: f32, alpha: f32) -> f32 {
    return wboit_weight_range(view_z, alpha, wboit_z_near, wboit_z_far);
}

// The two accumulation outputs of one fragment: location 0 (additive) gets
// (premultiplied colour * w, alpha * w); location 1 (blend zero, one-minus-src) gets alpha in .r,
// so it holds the revealage prod(1 - alpha).
struct WboitAccum {
    accum: vec4<f32>,
    reveal: vec4<f32>,
}

fn wboit_accumulate(premultiplied: vec3<f32>, alpha: f32, weight: f32) -> WboitAccum {
    var out: WboitAccum;
    out.accum = vec4<f32>(premultiplied * weight, alpha * weight);
    out.reveal = vec4<f32>(alpha, 0.0, 0.0, 0.0);
    return out;
}
