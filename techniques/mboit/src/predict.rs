//! What `mboit` does to a pixel's list, for [`oit_gpu::Technique::predict`], with the CPU
//! twins of [`crate::math`]: pass 1's moment sums, pass 2's reconstructed transmittance in
//! front of each fragment, the composite's normalised colour under the exact coverage
//! `1 − exp(−ΣA)`. Moment storage rounding (`storage=f16`) is not modelled.

use oit_gpu::Prediction;
use oit_gpu::predict::{PixelLists, model_error_conditioned};
use oit_scene::Scene;

use crate::math::{self, absorbance, fragment_moments, mboit_warp, transmittance_at};
use crate::technique::{Config, transparent_depth_interval};

/// Pixels whose summed absorbance is below this are skipped by pass 2 and the composite
/// (`MBOIT_MIN_B0` of shaders/mboit_composite.wgsl).
const MIN_B0: f32 = 0.001_000_500_3;

pub(crate) fn predict(config: &Config, scene: &Scene, lists: &PixelLists) -> Prediction {
    let r = config.resolve();
    let (z_min, z_max) = transparent_depth_interval(scene);
    let (ln_z_min, scale) = math::warp_terms(z_min, z_max);
    let camera = &scene.camera;
    // The model at the moments as summed, and with them one part in 2^16 larger: where the
    // two differ by more than the exact bound's model margin, the reconstruction is
    // ill-conditioned and f32 rounding decides the GPU's answer.
    let error = model_error_conditioned(lists, |px| {
        let a = pixel(&r, px, (ln_z_min, scale), camera, 1.0);
        let b = pixel(&r, px, (ln_z_min, scale), camera, 1.0 + 2f32.powi(-16));
        let sensitive = (0..3).any(|c| (a[c] - b[c]).abs() > oit_gpu::predict::MODEL_EXACT / 4.0);
        (a, sensitive)
    });
    Prediction::from_model(
        &error,
        "the moments' transmittance bounds weight each pixel's layers as their order does",
        "the reconstructed transmittance misweights layers of different colours",
    )
}

/// One pixel through MBOIT's two passes and composite, its moment sums scaled by `perturb`.
fn pixel(
    r: &math::Resolve,
    px: oit_gpu::predict::Pixel<'_>,
    (ln_z_min, scale): (f32, f32),
    camera: &oit_scene::Camera,
    perturb: f32,
) -> [f64; 3] {
    {
        let warped: Vec<(f32, f32)> = px
            .layers
            .iter()
            .filter_map(|l| {
                let a = absorbance(l.alpha)?;
                Some((
                    a,
                    mboit_warp(camera.view_distance(l.depth), ln_z_min, scale),
                ))
            })
            .collect();
        let (mut b0, mut b) = (0.0f32, [0.0f32; 8]);
        for &(a, zw) in &warped {
            let (m0, m) = fragment_moments(r.kind, zw, a, r.wrapping);
            b0 += m0;
            for (sum, m) in b.iter_mut().zip(m) {
                *sum += m;
            }
        }
        let b = b.map(|m| m * perturb);
        if b0 < MIN_B0 {
            return px.behind;
        }
        let (mut acc, mut acc_a) = ([0.0f64; 3], 0.0f64);
        for (l, zw) in px
            .layers
            .iter()
            .filter(|l| absorbance(l.alpha).is_some())
            .zip(warped.iter().map(|w| w.1))
        {
            let t = f64::from(transmittance_at(r, b0, &b, zw));
            for (sum, c) in acc.iter_mut().zip(l.premultiplied) {
                *sum += f64::from(c) * t;
            }
            acc_a += f64::from(l.alpha) * t;
        }
        let t = (-f64::from(b0)).exp();
        if acc_a <= 0.0 {
            return px.behind.map(|c| c * t);
        }
        [0, 1, 2].map(|c| acc[c] / acc_a * (1.0 - t) + px.behind[c] * t)
    }
}
