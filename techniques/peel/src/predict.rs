//! What the two peels do to a pixel's list, for [`oit_gpu::Technique::predict`].
//!
//! `front-peel` peels one depth per pass, nearest first: fragments at one depth are one layer,
//! the first drawn kept (strict depth test in draw order) and the others lost. `dual-peel`
//! peels the nearest and the farthest remaining *key* per pass (keys as `peel_key` stores
//! them: encoded, perhaps rounded to binary16), every fragment at that key blended in draw
//! order; what is left after the last pass is dropped or goes to the WBOIT tail.

use oit_gpu::predict::{
    Layer, PixelLists, composite, composite_back_to_front, draw_order_key, model_error,
};
use oit_gpu::{Caps, Prediction, Verdict};
use oit_scene::Scene;

use crate::config::{DepthFormat, DualPeelConfig, FrontPeelConfig, PassCount, Tail};
use crate::encoding::{KeyParams, peel_key};

fn pass_limit(count: PassCount) -> Option<usize> {
    match count {
        PassCount::Fixed(n) => Some(n.get() as usize),
        PassCount::Auto => None,
    }
}

pub(crate) fn predict_front(config: FrontPeelConfig, lists: &PixelLists) -> Prediction {
    let limit = pass_limit(config.layers);
    let error = model_error(lists, |px| {
        let mut peeled: Vec<Layer> = Vec::with_capacity(px.layers.len());
        let mut at = 0;
        while at < px.layers.len() && limit.is_none_or(|n| peeled.len() < n) {
            let depth = px.layers[at].depth;
            let end = at
                + px.layers[at..]
                    .iter()
                    .take_while(|l| l.depth == depth)
                    .count();
            let first = px.layers[at..end]
                .iter()
                .min_by_key(|l| draw_order_key(l))
                .copied();
            peeled.extend(first);
            at = end;
        }
        composite(peeled.iter(), px.behind)
    });
    let layers = lists.max_layers();
    let exact = match limit {
        Some(n) => format!(
            "{n} passes peel every pixel's {layers} layers, none at equal depth where it matters"
        ),
        None => format!("auto peels all {layers} layers, none at equal depth where it matters"),
    };
    Prediction::from_model(
        &error,
        &exact,
        match limit {
            Some(n) if (n as u32) < layers => {
                "layers beyond the last pass are dropped, or fragments at equal depth are lost"
            }
            _ => "fragments at equal depth are one layer: all but the first drawn are lost",
        },
    )
}

pub(crate) fn predict_dual(
    config: DualPeelConfig,
    scene: &Scene,
    lists: &PixelLists,
    caps: &Caps,
) -> Prediction {
    if let Some(rounding) = config.accum.rounding() {
        return Prediction::unmodelled(format!(
            "{rounding}; the model composites in f64 and does not round"
        ));
    }
    let half = matches!(
        config.depth.resolve(caps),
        Ok(oit_gpu::wgpu::TextureFormat::Rg16Float)
    ) || config.depth == DepthFormat::Rg16f;
    let params = KeyParams::new(scene);
    let limit = pass_limit(config.passes);
    let tail_rule = config.tail;
    let tails = std::sync::atomic::AtomicU64::new(0);
    let error = model_error(lists, |px| {
        // Nearness: larger is nearer, whichever way the stored key grows.
        let near = |l: &Layer| {
            let k = peel_key(&params, config.encoding, config.reverse_z, half, l.depth);
            if config.reverse_z { k } else { -k }
        };
        let mut rest: Vec<(f32, Layer)> = px.layers.iter().map(|l| (near(l), *l)).collect();
        rest.sort_by_key(|(_, l)| draw_order_key(l));
        let (mut front, mut back) = (Vec::new(), Vec::new());
        let mut passes = 0;
        while !rest.is_empty() && limit.is_none_or(|n| passes < n) {
            passes += 1;
            let hi = rest.iter().map(|r| r.0).fold(f32::NEG_INFINITY, f32::max);
            let lo = rest.iter().map(|r| r.0).fold(f32::INFINITY, f32::min);
            // In draw order: the front shell under-blended, the back shell over-blended.
            front.extend(rest.iter().filter(|r| r.0 == hi).map(|r| r.1));
            if lo != hi {
                back.push(
                    rest.iter()
                        .filter(|r| r.0 == lo)
                        .map(|r| r.1)
                        .collect::<Vec<_>>(),
                );
            }
            rest.retain(|r| r.0 != hi && r.0 != lo);
        }
        let mut behind = px.behind;
        // Back shells: each pass's over-blended onto what the earlier passes left.
        for shell in &back {
            behind = composite_back_to_front(shell.iter(), behind);
        }
        if !rest.is_empty() && tail_rule == Tail::Wboit {
            tails.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            behind = weighted_average(rest.iter().map(|r| &r.1), behind);
        }
        composite(front.iter(), behind)
    });
    let layers = lists.max_layers();
    let passes = match limit {
        Some(n) => format!("{n} passes"),
        None => "auto".to_string(),
    };
    let mut p = Prediction::from_model(
        &error,
        &format!(
            "{passes} peel every pixel's {layers} layers from both ends, no two at one key where it matters"
        ),
        "layers left in the middle after the last pass, or fragments sharing a key, are lost or merged",
    );
    let tails = tails.into_inner();
    if tails > 0 && p.verdict != Verdict::Unmodelled {
        // The WBOIT tail's weights are not modelled (an equal-weight average stands in).
        p.verdict = Verdict::Borderline;
        p.because = format!(
            "{} (the WBOIT tail on {tails} px is modelled as an equal-weight average)",
            p.because
        );
    }
    p
}

/// The tail as an equal-weight average: colour Σ C / Σ α, coverage 1 − Π (1 − α), over `behind`.
fn weighted_average<'a>(layers: impl Iterator<Item = &'a Layer>, behind: [f64; 3]) -> [f64; 3] {
    let (mut sum, mut alpha, mut t) = ([0.0f64; 3], 0.0f64, 1.0f64);
    for l in layers {
        for (sum, c) in sum.iter_mut().zip(l.premultiplied) {
            *sum += f64::from(c);
        }
        alpha += f64::from(l.alpha);
        t *= 1.0 - f64::from(l.alpha);
    }
    if alpha <= 0.0 {
        return behind;
    }
    [0, 1, 2].map(|c| sum[c] / alpha * (1.0 - t) + t * behind[c])
}
