//! The peel key: what the dual-peel range target stores, as a function of window depth.
//!
//! Every pass compares keys its own shader computed, so any strictly monotonic function of
//! depth works; what differs is how many distinct values survive rounding to the storage format
//! (f16 in the `rg16f` path). This module is the CPU twin of `peel_key` in
//! shaders/peel_common.wgsl (same f32 operations in the same order) and computes the uniform
//! block the shader reads.

use oit_scene::{Camera, Projection, Scene};

oit_gpu::words! {
    /// How the stored key is derived from the fragment's window depth `z`.
    pub enum DepthEncoding {
        /// `z` itself, or `1 − z` when the key direction differs from the scene's depth
        /// direction.
        Window = "window",
        /// View distance, linear over the scene's transparent interval `[d_min, d_max]`.
        Linear = "linear",
        /// `t = ln(d / d_min) / ln(d_max / d_min)`: equal relative depth steps get equal key
        /// steps. In the `rg16f` path `t` is spread uniformly over the f16 bit patterns
        /// ([`half_uniform`]), a 1/14336 fixed-point log depth, instead of being rounded to the
        /// nearest f16.
        Log = "log",
    }
}

impl DepthEncoding {
    /// The shader's `ENCODING` override value.
    pub fn index(self) -> u32 {
        match self {
            DepthEncoding::Window => 0,
            DepthEncoding::Linear => 1,
            DepthEncoding::Log => 2,
        }
    }
}

/// The `PeelParams` uniform of shaders/peel_common.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct KeyParams {
    /// View distance from window depth: perspective `1/d = a·z + b`, orthographic `d = a·z + b`.
    pub depth_a: f32,
    pub depth_b: f32,
    pub perspective: u32,
    pub scene_reverse_z: u32,
    /// The transparent geometry's view-distance interval (clamped to the camera's near/far).
    pub d_min: f32,
    pub d_max: f32,
    /// `ln(d_max / d_min)`.
    pub log_span: f32,
    pub width: u32,
}

impl KeyParams {
    pub fn new(scene: &Scene) -> Self {
        let camera = &scene.camera;
        let (depth_a, depth_b, perspective) = depth_to_distance(camera);
        let (mut d_min, mut d_max) = (f32::INFINITY, f32::NEG_INFINITY);
        for draw in &scene.draws {
            if !scene.material_of(draw).mode.is_transparent() {
                continue;
            }
            for v in &scene.vertices[draw.vertex_range()] {
                let view = camera.view.transform_point3(glam::Vec3::from(v.position));
                let d = (-view.z).clamp(camera.near, camera.far);
                d_min = d_min.min(d);
                d_max = d_max.max(d);
            }
        }
        if !d_min.is_finite() {
            (d_min, d_max) = (camera.near, camera.far);
        }
        // A flat interval (one plane facing the camera) still needs a non-zero span.
        if d_max <= d_min * (1.0 + 1e-6) {
            d_max = d_min * 1.001 + 1e-6;
        }
        KeyParams {
            depth_a,
            depth_b,
            perspective: u32::from(perspective),
            scene_reverse_z: u32::from(camera.reverse_z),
            d_min,
            d_max,
            log_span: (d_max / d_min).ln(),
            width: scene.resolution.width,
        }
    }

    /// View distance of window depth `z` (the shader's `view_distance`).
    pub fn view_distance(&self, z: f32) -> f32 {
        let lin = self.depth_a * z + self.depth_b;
        if self.perspective != 0 {
            1.0 / lin
        } else {
            lin
        }
    }
}

/// The projection's depth row inverted: window z → view distance d along the view axis.
/// glam's right-handed projections put view z = −d; with `P = camera.proj` (column-major),
/// window z = (P₂₂·(−d) + P₃₂) / w where w = d (perspective) or 1 (orthographic).
fn depth_to_distance(camera: &Camera) -> (f32, f32, bool) {
    let p22 = camera.proj.z_axis.z;
    let p32 = camera.proj.w_axis.z;
    match camera.projection {
        // z = −P₂₂ + P₃₂/d  ⇒  1/d = z/P₃₂ + P₂₂/P₃₂.
        Projection::Perspective { .. } => (1.0 / p32, p22 / p32, true),
        // z = −P₂₂·d + P₃₂  ⇒  d = −z/P₂₂ + P₃₂/P₂₂.
        Projection::Orthographic { .. } => (-1.0 / p22, p32 / p22, false),
    }
}

/// IEEE binary16 rounding (to nearest, ties to even) of an f32, returned as f32: what the
/// shader's `unpack2x16float(pack2x16float(s))` computes on adapters that round to nearest.
pub fn f16_round(x: f32) -> f32 {
    oit_gpu::f16_to_f32(f32_to_f16_bits(x))
}

fn f32_to_f16_bits(x: f32) -> u16 {
    let b = x.to_bits();
    let sign = ((b >> 16) & 0x8000) as u16;
    let exp = ((b >> 23) & 0xff) as i32;
    let man = b & 0x7f_ffff;
    if exp == 255 {
        return sign | 0x7c00 | if man != 0 { 0x200 } else { 0 };
    }
    let e = exp - 127 + 15;
    if e >= 31 {
        return sign | 0x7c00;
    }
    let round = |value: u32, rem: u32, halfway: u32| {
        if rem > halfway || (rem == halfway && value & 1 == 1) {
            value + 1
        } else {
            value
        }
    };
    if e <= 0 {
        if e < -10 {
            return sign;
        }
        let m = man | 0x80_0000;
        let shift = (14 - e) as u32;
        let half = round(m >> shift, m & ((1 << shift) - 1), 1 << (shift - 1));
        return sign | half as u16;
    }
    // A carry out of the mantissa rounds up into the exponent, as it should.
    let half = round(((e as u32) << 10) | (man >> 13), man & 0x1fff, 0x1000);
    sign | half as u16
}

/// The key of window depth `z` (CPU twin of `peel_key` in shaders/peel_common.wgsl).
pub fn peel_key(
    params: &KeyParams,
    encoding: DepthEncoding,
    key_reverse: bool,
    half: bool,
    z: f32,
) -> f32 {
    let s = match encoding {
        DepthEncoding::Window => {
            if (params.scene_reverse_z != 0) == key_reverse {
                z
            } else {
                1.0 - z
            }
        }
        DepthEncoding::Linear | DepthEncoding::Log => {
            let d = params.view_distance(z).clamp(params.d_min, params.d_max);
            match (encoding, key_reverse) {
                (DepthEncoding::Linear, true) => (params.d_max - d) / (params.d_max - params.d_min),
                (DepthEncoding::Linear, false) => {
                    (d - params.d_min) / (params.d_max - params.d_min)
                }
                (_, true) => (params.d_max / d).ln() / params.log_span,
                (_, false) => (d / params.d_min).ln() / params.log_span,
            }
        }
    };
    match (half, encoding) {
        (false, _) => s,
        (true, DepthEncoding::Log) => half_uniform(s),
        (true, _) => f16_round(s),
    }
}

/// `t ∈ [0, 1]` spread uniformly over the bit patterns of the normal binary16 values in
/// `[2^-14, 1]` (CPU twin of `half_uniform` in shaders/peel_common.wgsl): fixed-point spacing
/// 1/14336 inside a float format, since positive floats order like their bit patterns.
pub fn half_uniform(t: f32) -> f32 {
    const MIN_BITS: f32 = 1024.0;
    const ONE_BITS: f32 = 15360.0;
    let bits = (MIN_BITS + t.clamp(0.0, 1.0) * (ONE_BITS - MIN_BITS)).round() as u16;
    oit_gpu::f16_to_f32(bits)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(reverse_z: bool, projection: Projection) -> Camera {
        Camera::new(
            glam::Vec3::ZERO,
            glam::Vec3::new(0.0, 0.0, -1.0),
            glam::Vec3::Y,
            projection,
            0.5,
            200.0,
            reverse_z,
            1.0,
        )
    }

    #[test]
    fn window_depth_inverts_to_view_distance() {
        for reverse in [false, true] {
            for projection in [
                Projection::Perspective {
                    fov_y_degrees: 60.0,
                },
                Projection::Orthographic { height: 4.0 },
            ] {
                let cam = camera(reverse, projection);
                let (a, b, persp) = depth_to_distance(&cam);
                for d in [0.5f32, 1.0, 7.5, 120.0, 200.0] {
                    let c = cam.clip(glam::Vec3::new(0.0, 0.0, -d));
                    let z = c.z / c.w;
                    let lin = a * z + b;
                    let back = if persp { 1.0 / lin } else { lin };
                    assert!(
                        (back - d).abs() <= 1e-4 * d.max(1.0) * if persp { d } else { 1.0 },
                        "reverse {reverse} {projection:?}: d {d} -> z {z} -> {back}"
                    );
                }
            }
        }
    }

    #[test]
    fn half_rounding_matches_binary16() {
        assert_eq!(f16_round(1.0), 1.0);
        assert_eq!(f16_round(0.1), 0.099_975_586);
        assert_eq!(f16_round(-0.333_333), -0.333_251_95);
        // 1 + 2^-11 is halfway between 1 and 1 + 2^-10: ties to even gives 1.
        assert_eq!(f16_round(1.0 + 2f32.powi(-11)), 1.0);
        assert_eq!(
            f16_round(1.0 + 3.0 * 2f32.powi(-11)),
            1.0 + 2.0 * 2f32.powi(-10)
        );
        // Subnormal spacing 2^-24.
        assert_eq!(f16_round(3.0 * 2f32.powi(-24)), 3.0 * 2f32.powi(-24));
        assert_eq!(f16_round(1e-9), 0.0);
        assert_eq!(half_uniform(0.0), 2f32.powi(-14));
        assert_eq!(half_uniform(1.0), 1.0);
        // Neighbouring steps are neighbouring f16 values, ordered.
        let step = 1.0 / 14336.0;
        assert!(half_uniform(0.5 + step) > half_uniform(0.5));
        assert_eq!(half_uniform(0.5 + step * 0.4), half_uniform(0.5));
    }

    #[test]
    fn keys_are_monotonic_in_the_requested_direction() {
        let cam = camera(
            true,
            Projection::Perspective {
                fov_y_degrees: 60.0,
            },
        );
        let params = KeyParams {
            depth_a: depth_to_distance(&cam).0,
            depth_b: depth_to_distance(&cam).1,
            perspective: 1,
            scene_reverse_z: 1,
            d_min: 1.0,
            d_max: 100.0,
            log_span: 100f32.ln(),
            width: 1,
        };
        for &encoding in DepthEncoding::ALL {
            for reverse in [false, true] {
                let keys: Vec<f32> = [1.0f32, 2.0, 10.0, 50.0, 100.0]
                    .iter()
                    .map(|&d| {
                        let c = cam.clip(glam::Vec3::new(0.0, 0.0, -d));
                        peel_key(&params, encoding, reverse, false, c.z / c.w)
                    })
                    .collect();
                for w in keys.windows(2) {
                    assert!(
                        if reverse { w[0] > w[1] } else { w[0] < w[1] },
                        "{encoding:?} reverse {reverse}: {keys:?}"
                    );
                }
                assert!(
                    keys.iter().all(|k| (-1e-5..=1.0 + 1e-5).contains(k)),
                    "{keys:?}"
                );
            }
        }
    }
}
