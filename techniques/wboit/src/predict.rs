//! What `wboit` and `weighted-average` do to a pixel's list, for
//! [`oit_gpu::Technique::predict`]: the weighted average of the layers' colours under the
//! exact coverage `1 − Π(1 − α)` (WBOIT, with the configured weight's CPU twin) or under
//! `1 − (1 − Σα/n)^n` (the weighted average), over what lies behind times `Π t`.
//! Sums and the revealage are rounded to their targets' formats blend by blend, in draw
//! order; the composite's guards and the colour scale's units are not modelled.

use oit_gpu::Prediction;
use oit_gpu::predict::{PixelLists, draw_order_key, f16_round, model_error};
use oit_scene::Scene;

use crate::range::RangeParams;
use crate::tail::{AccumFormat, RevealFormat};
use crate::technique::Config;

/// How a blend stores a value into a target's format.
type Store = fn(f32) -> f32;

pub(crate) fn predict(config: Config, scene: &Scene, lists: &PixelLists) -> Prediction {
    let range = RangeParams::of(scene);
    let camera = &scene.camera;
    let additive: Vec<bool> = (scene.draws.iter())
        .map(|d| scene.material_of(d).operator.is_additive())
        .collect();
    // The configured weight at a layer's depth for coverage `alpha`.
    let weight_at = |depth: f32, alpha: f32| match config {
        Config::Weighted { weight, .. } => {
            let z = camera.view_distance(depth);
            let d = if camera.reverse_z { 1.0 - depth } else { depth };
            weight.eval(z, d, alpha, &range)
        }
        Config::Average => 1.0,
    };
    let error = model_error(lists, |px| {
        if px.layers.is_empty() {
            return px.behind;
        }
        // Additive blends in the accumulation target's format, in draw order.
        let (accum, reveal_store): (Store, Store) = match config {
            Config::Weighted { accum, reveal, .. } => (
                match accum {
                    AccumFormat::Rgba16f => f16_round,
                    AccumFormat::Rgba32f => std::convert::identity,
                },
                match reveal {
                    RevealFormat::R8 => |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() / 255.0,
                    RevealFormat::R16f => f16_round,
                    RevealFormat::R32f => std::convert::identity,
                },
            ),
            Config::Average => (f16_round, std::convert::identity),
        };
        let mut order: Vec<_> = (px.layers.iter())
            .filter(|l| !additive[l.draw as usize])
            .collect();
        order.sort_by_key(|l| draw_order_key(l));
        let (mut sum, mut weights, mut alpha_sum) = ([0.0f32; 3], 0.0f32, 0.0f32);
        let (mut reveal, mut behind_t) = (1.0f32, [1.0f64; 3]);
        let n = order.len() as f64;
        for l in order {
            let w = weight_at(l.depth, l.alpha);
            for c in 0..3 {
                sum[c] = accum(sum[c] + l.premultiplied[c] * w);
                behind_t[c] *= f64::from(l.transmittance[c]);
            }
            match config {
                Config::Weighted { .. } => weights = accum(weights + l.alpha * w),
                Config::Average => alpha_sum = accum(alpha_sum + l.alpha),
            }
            reveal = reveal_store(reveal * (1.0 - l.alpha));
        }
        let (sum, reveal) = (sum.map(f64::from), f64::from(reveal));
        let (weights, alpha_sum) = match config {
            Config::Weighted { .. } => (f64::from(weights), 0.0),
            Config::Average => (f64::from(alpha_sum), f64::from(alpha_sum)),
        };
        let coverage = match config {
            Config::Weighted { .. } => 1.0 - reveal,
            Config::Average if n > 0.0 => 1.0 - (1.0 - alpha_sum / n).powf(n),
            Config::Average => 0.0,
        };
        let avg = |c: usize| if weights > 0.0 { sum[c] / weights } else { 0.0 };
        let mut out = [0, 1, 2].map(|c| avg(c) * coverage + behind_t[c] * px.behind[c]);
        // The additive pass (crate::additive, `fs_additive`).
        for l in px.layers.iter().filter(|l| additive[l.draw as usize]) {
            let visibility = match config {
                _ if coverage <= 0.0 => 1.0,
                Config::Weighted { .. } if weights > 0.0 => {
                    (f64::from(weight_at(l.depth, 1.0)) * coverage / weights).clamp(0.0, 1.0)
                }
                Config::Weighted { .. } => reveal,
                Config::Average => (coverage / alpha_sum).clamp(0.0, 1.0),
            };
            for (o, c) in out.iter_mut().zip(l.premultiplied) {
                *o += f64::from(c) * visibility;
            }
        }
        out
    });
    let name = match config {
        Config::Weighted { .. } => "the weighted average",
        Config::Average => "the plain average",
    };
    Prediction::from_model(
        &error,
        &format!(
            "{name} of each pixel's layers equals their ordered composite (one layer, or layers of one colour)"
        ),
        &format!("{name} of layers of different colours is not their ordered composite"),
    )
}
