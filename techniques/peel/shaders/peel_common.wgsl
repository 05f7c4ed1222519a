// Shared by the depth-peeling passes (oit-peel): the peel key, i.e. the monotonic depth encoding
// every pass of one frame computes from the fragment's window depth and compares with the values
// earlier passes stored, plus the bindings of the per-frame counters and the pass index.
//
// Window depth `clip.z` is @invariant (common.wgsl), and the key is a pure function of it, so
// every pass computes bit-identical keys for the same fragment: equality tests are exact.
#include "common.wgsl"
#include "peel_counters.wgsl"

struct PeelParams {
    // View distance from window depth z: perspective 1/d = a·z + b, orthographic d = a·z + b.
    depth_a: f32,
    depth_b: f32,
    perspective: u32,
    // The scene's own depth direction (1: reverse-Z, near → 1). The passes read it as the
    // constant SCENE_REVERSE_Z; the field stays for the CPU twin (oit_peel::encoding).
    scene_reverse_z: u32,
    // The scene's transparent view-distance interval and ln(d_max / d_min).
    d_min: f32,
    d_max: f32,
    log_span: f32,
    // Render target width (row stride of per-pixel buffers).
    width: u32,
}

@group(1) @binding(0) var<uniform> peel: PeelParams;
// The pass group (oit-peel's Control): pass index and counters (peel_counters.wgsl).
@group(2) @binding(0) var<uniform> pass_info: PassInfo;
@group(2) @binding(1) var<storage, read_write> counters: array<atomic<u32>>;

// 0 window depth, 1 linear view distance, 2 logarithmic view distance (over [d_min, d_max]).
override ENCODING: u32 = 0u;
// The scene's own depth direction (`peel.scene_reverse_z`), as a constant with no default so that
// every pipeline names it: llvmpipe reads a uniform again in every step of 8 fragments, and this
// read was 5.5 % of dual peeling's peel pass on 12 000 small billboards (callgrind, 2026-12-08).
override SCENE_REVERSE_Z: bool;
// The stored key grows toward the viewer (near → 1) when true.
override KEY_REVERSE: bool = true;
// Round the key to binary16 (RG16F storage) so equality tests against stored values are exact;
// the log encoding is instead quantized uniformly over the f16 bit patterns (half_uniform).
override KEY_HALF: bool = false;
// The ablation switch: false shades every fragment before the peel range test (as Babylon does).
override TEST_FIRST: bool = true;

fn view_distance(z: f32) -> f32 {
    let lin = peel.depth_a * z + peel.depth_b;
    if peel.perspective != 0u {
        return 1.0 / lin;
    }
    return lin;
}

// Bit patterns of the smallest normal binary16 (2^-14) and of 1.0.
const HALF_NORMAL_MIN_BITS: f32 = 1024.0;
const HALF_ONE_BITS: f32 = 15360.0;

// t in [0, 1] spread uniformly over the bit patterns of the 14336 normal binary16 values in
// [2^-14, 1]. Positive floats order like their bit patterns, so MAX blending and the equality
// tests still see a monotonic key, but with fixed-point spacing (1/14336) instead of f16's
// relative spacing. Subnormals are avoided: blending may flush them.
fn half_uniform(t: f32) -> f32 {
    let bits = u32(round(HALF_NORMAL_MIN_BITS + clamp(t, 0.0, 1.0) * (HALF_ONE_BITS - HALF_NORMAL_MIN_BITS)));
    return unpack2x16float(bits).x;
}

fn peel_key(z: f32) -> f32 {
    var s: f32;
    if ENCODING == 0u {
        if SCENE_REVERSE_Z == KEY_REVERSE {
            s = z;
        } else {
            s = 1.0 - z;
        }
    } else {
        let d = clamp(view_distance(z), peel.d_min, peel.d_max);
        if ENCODING == 1u {
            let span = peel.d_max - peel.d_min;
            if KEY_REVERSE {
                s = (peel.d_max - d) / span;
            } else {
                s = (d - peel.d_min) / span;
            }
        } else {
            if KEY_REVERSE {
                s = log(peel.d_max / d) / peel.log_span;
            } else {
                s = log(d / peel.d_min) / peel.log_span;
            }
        }
    }
    if KEY_HALF {
        if ENCODING == 2u {
            s = half_uniform(s);
        } else {
            s = unpack2x16float(pack2x16float(vec2<f32>(s, 0.0))).x;
        }
    }
    return s;
}
