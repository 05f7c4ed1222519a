//! What `wavelet` does to a pixel's list, for [`oit_gpu::Technique::predict`], with the CPU
//! twins of [`crate::math`]: pass 1's interval, pass 2's coefficient sums (rounded to binary16
//! blend by blend in draw order for `storage=f16`), pass 3's transmittance in front of each
//! fragment, the composite's normalised colour under the total coverage, and the additive pass.

use oit_gpu::predict::{Layer, Pixel, PixelLists, draw_order_key, f16_round};
use oit_gpu::{Prediction, Verdict};
use oit_scene::{Camera, Scene};

use crate::math::{self, MAX_COEFFICIENTS};
use crate::technique::{Config, Storage};

pub(crate) fn predict(config: &Config, scene: &Scene, lists: &PixelLists) -> Prediction {
    let additive: Vec<bool> = (scene.draws.iter())
        .map(|d| scene.material_of(d).operator.is_additive())
        .collect();
    let camera = &scene.camera;
    // Where a fragment sits on a cell boundary or the coefficients' rounding could move the
    // answer, the GPU's own rounding decides: probe the depths a few ulps either way and the
    // coefficients a rounding step up.
    let step = match config.storage {
        Storage::F32 => 2f32.powi(-14),
        Storage::F16 => 2f32.powi(-9),
    };
    let error = oit_gpu::predict::model_error_conditioned(lists, |px| {
        let at = |probe| pixel(config, px, camera, &additive, probe);
        let a = at(Probe::None);
        let sensitive = [Probe::Scale(step), Probe::Depth(step), Probe::Depth(-step)]
            .into_iter()
            .any(|probe| {
                let b = at(probe);
                (0..3).any(|c| (a[c] - b[c]).abs() > oit_gpu::predict::MODEL_EXACT / 4.0)
            });
        (a, sensitive)
    });
    let mut p = Prediction::from_model(
        &error,
        "the reconstructed absorbance weights each pixel's layers as their order does",
        "the Haar reconstruction misweights layers of different colours",
    );
    if p.verdict == Verdict::Exact {
        // The normalised composite is exact where every pixel has one colour or one layer;
        // the GPU's exp/log and cell boundaries are not modelled bit for bit, so never more
        // than not contradicted.
        p.verdict = Verdict::Borderline;
        p.because = format!(
            "{}, but the GPU's transcendental functions and depth round trip are not modelled bit for bit",
            p.because
        );
    }
    p
}

#[derive(Clone, Copy)]
enum Probe {
    None,
    /// Every coefficient times 1 + ε.
    Scale(f32),
    /// Every normalised depth plus ε.
    Depth(f32),
}

/// One pixel through the wavelet passes.
fn pixel(
    config: &Config,
    px: Pixel<'_>,
    camera: &Camera,
    additive: &[bool],
    probe: Probe,
) -> [f64; 3] {
    let rank = config.rank.get();
    let store = match config.storage {
        Storage::F32 => std::convert::identity,
        Storage::F16 => f16_round,
    };
    let is_additive = |l: &Layer| additive[l.draw as usize];
    let mut kept: Vec<(&Layer, f32)> = (px.layers.iter())
        .filter(|l| !is_additive(l))
        .filter_map(|l| Some((l, math::absorbance(l.alpha)?)))
        .collect();
    kept.sort_by_key(|(l, _)| draw_order_key(l));
    // Pass 1: MAX blending in f32 is exact.
    let z = |l: &Layer| camera.view_distance(l.depth);
    let z_min = kept.iter().map(|(l, _)| z(l)).fold(f32::INFINITY, f32::min);
    let z_max = (kept.iter().map(|(l, _)| z(l))).fold(f32::NEG_INFINITY, f32::max);
    let shift = match probe {
        Probe::Depth(e) => e,
        _ => 0.0,
    };
    let depth = |l: &Layer| (math::normalized_depth(z(l), z_min, z_max) + shift).clamp(0.0, 1.0);
    // Pass 2: each fragment's coefficients added to the targets in draw order.
    let mut c = [0.0f32; MAX_COEFFICIENTS];
    for &(l, a) in &kept {
        let mut own = [0.0f32; MAX_COEFFICIENTS];
        math::project(&mut own, rank, a, depth(l));
        for (sum, v) in c.iter_mut().zip(own) {
            *sum = store(*sum + v);
        }
    }
    if let Probe::Scale(e) = probe {
        c = c.map(|v| v * (1.0 + e));
    }
    // Pass 3 and the composite.
    let (mut acc, mut acc_a) = ([0.0f32; 3], 0.0f32);
    for &(l, a) in &kept {
        let t = math::transmittance(math::absorbance_before(&c, rank, depth(l), a));
        for (sum, p) in acc.iter_mut().zip(l.premultiplied) {
            *sum = store(*sum + p * t);
        }
        acc_a = store(acc_a + l.alpha * t);
    }
    let mut out = px.behind;
    if acc_a > 0.0 {
        let t = f64::from(math::transmittance(math::total_absorbance(&c, rank)));
        let acc_a = f64::from(acc_a);
        out = [0, 1, 2].map(|k| f64::from(acc[k]) / acc_a * (1.0 - t) + px.behind[k] * t);
    }
    // The additive pass, over the final colour.
    for l in px.layers.iter().filter(|l| is_additive(l)) {
        let t = math::transmittance(math::absorbance_at(&c, rank, depth(l)));
        for (o, p) in out.iter_mut().zip(l.premultiplied) {
            *o += f64::from(p * t);
        }
    }
    out
}
