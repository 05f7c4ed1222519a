//! Predictions: whether a technique is exact on a scene, and why, before it runs.
//!
//! Each technique models what it does to a pixel's transparent list ([`Technique::predict`]):
//! the order it blends the fragments in, the layers it keeps, the rule it approximates the rest
//! with. The model runs on the exact reference's per-pixel lists ([`PixelLists`]) and is
//! measured against the exact composite of the same lists; that difference decides the verdict.
//! A run is *measured* exact when its largest channel error, relative above 1, is at most
//! [`EXACT_BOUND`] (the `Rgba16Float` target's rounding over deep stacks), so a model predicts
//! exact when it is within [`MODEL_EXACT`] of the exact composite and inexact when it is at
//! least [`MODEL_INEXACT`] away; between the two, target rounding may decide, and the
//! prediction says so (`borderline`) instead of guessing.
//!
//! [`Technique::predict`]: crate::Technique::predict

pub use oit_reference::lists::{
    Layer, ModelError, Pixel, PixelLists, composite, composite_back_to_front,
};

/// A run is exact when its largest channel error, relative above 1, is at most this.
pub const EXACT_BOUND: f64 = 4e-3;
/// A model at most this far from the exact composite predicts an exact run.
pub const MODEL_EXACT: f64 = 1e-3;
/// A model at least this far from the exact composite predicts an inexact run.
pub const MODEL_INEXACT: f64 = 4.0 * EXACT_BOUND;

/// What a prediction says about a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Verdict {
    /// The run's error will be at most [`EXACT_BOUND`].
    Exact,
    /// The run's error will exceed [`EXACT_BOUND`].
    Inexact,
    /// The model's error lies between [`MODEL_EXACT`] and [`MODEL_INEXACT`], or rounding
    /// (undecided cutoffs, precision ties) decides the pixels where the model differs.
    Borderline,
    /// No per-pixel model predicts this technique (e.g. stochastic noise); measured only.
    Unmodelled,
}

impl Verdict {
    /// The word results.json stores: exact, inexact, borderline, unmodelled.
    pub fn label_word(self) -> &'static str {
        match self {
            Verdict::Exact => "exact",
            Verdict::Inexact => "inexact",
            Verdict::Borderline => "borderline",
            Verdict::Unmodelled => "unmodelled",
        }
    }

    /// The word reports print: yes, no, borderline, unmodelled.
    pub fn label(self) -> &'static str {
        match self {
            Verdict::Exact => "yes",
            Verdict::Inexact => "no",
            Verdict::Borderline => "borderline",
            Verdict::Unmodelled => "unmodelled",
        }
    }
}

/// A technique configuration's predicted exactness on one scene, and why.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Prediction {
    pub verdict: Verdict,
    /// One sentence: the condition that holds or fails, with pixel counts.
    pub because: String,
    /// The model's largest difference from the exact composite (relative above 1), where
    /// a model ran.
    pub modelled_error: Option<f64>,
}

impl Prediction {
    /// Exact by construction, for a reason that needs no model run.
    pub fn exact(because: impl Into<String>) -> Self {
        Prediction {
            verdict: Verdict::Exact,
            because: because.into(),
            modelled_error: Some(0.0),
        }
    }

    /// No model: measured only, for the stated reason.
    pub fn unmodelled(because: impl Into<String>) -> Self {
        Prediction {
            verdict: Verdict::Unmodelled,
            because: because.into(),
            modelled_error: None,
        }
    }

    /// The verdict of a model's error: `exact` says why the model is exact, `inexact` what
    /// goes wrong (the model's error is appended to both).
    pub fn from_model(error: &ModelError, exact: &str, inexact: &str) -> Self {
        let e = error.max_relative;
        let at = error
            .worst
            .map(|(x, y)| format!(", worst at pixel ({x}, {y})"))
            .unwrap_or_default();
        let (verdict, because) = if e >= MODEL_INEXACT {
            (
                Verdict::Inexact,
                format!(
                    "{inexact}: {} px differ, by up to {e:.2e}{at}",
                    error.pixels_over
                ),
            )
        } else if e > MODEL_EXACT {
            (
                Verdict::Borderline,
                format!(
                    "{inexact}, but only by {e:.2e} (target rounding decides against the {EXACT_BOUND:e} bound){at}"
                ),
            )
        } else if error.rounding_pixels_over > 0 {
            (
                Verdict::Borderline,
                format!(
                    "{exact}, except on {} px where rounding (an undecided cutoff or a precision tie) decides the order",
                    error.rounding_pixels_over
                ),
            )
        } else {
            (Verdict::Exact, exact.to_string())
        };
        Prediction {
            verdict,
            because,
            modelled_error: Some(e),
        }
    }

    /// Whether a run whose largest channel error (relative above 1) is `measured` agrees:
    /// `None` where the prediction is borderline or unmodelled.
    pub fn agrees(&self, measured: f64) -> Option<bool> {
        match self.verdict {
            Verdict::Exact => Some(measured <= EXACT_BOUND),
            Verdict::Inexact => Some(measured > EXACT_BOUND),
            Verdict::Borderline | Verdict::Unmodelled => None,
        }
    }
}

/// Runs `model` over `lists` with the classification threshold of [`Prediction::from_model`].
pub fn model_error(lists: &PixelLists, model: impl Fn(Pixel<'_>) -> [f64; 3] + Sync) -> ModelError {
    lists.model_error(MODEL_EXACT, |px| (model(px), false))
}

/// [`model_error`] for a model that also says where it is ill-conditioned (f32 rounding on
/// the GPU, ordered differently, may give another answer there): those pixels count as
/// decided by rounding.
pub fn model_error_conditioned(
    lists: &PixelLists,
    model: impl Fn(Pixel<'_>) -> ([f64; 3], bool) + Sync,
) -> ModelError {
    lists.model_error(MODEL_EXACT, model)
}

/// `x` rounded to the nearest binary16 (ties to even), as a blend unit stores it into an
/// `Rgba16Float` or `R16Float` target; beyond the largest finite half, infinite.
pub fn f16_round(x: f32) -> f32 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    let a = x.abs();
    if a >= 65520.0 {
        return f32::INFINITY.copysign(x);
    }
    // Below 2^-14 halves are subnormal: a fixed quantum of 2^-24.
    let exponent = (((a.to_bits() >> 23) & 0xff) as i32 - 127).max(-14);
    let quantum = f32::from_bits(((exponent - 10 + 127) as u32) << 23);
    (x / quantum).round_ties_even() * quantum
}

/// Composites a pixel's layers OVER, back to front, in the order one blending pass receives
/// them: ascending `key` (a draw's position in the pass, then the triangle's), as the blend
/// unit applies fragments in primitive order, into the comparison's `Rgba16Float` colour
/// target: the opaque colour stored in it, each blend computed in f32 and stored as binary16.
pub fn blend_in_order(px: Pixel<'_>, key: impl Fn(&Layer) -> u64) -> [f64; 3] {
    let mut order: Vec<&Layer> = px.layers.iter().collect();
    order.sort_by_key(|l| key(l));
    let mut dst = px.behind.map(|c| f16_round(c as f32));
    for l in order {
        dst = [0, 1, 2].map(|c| f16_round(l.premultiplied[c] + l.transmittance[c] * dst[c]));
    }
    dst.map(f64::from)
}

/// Blend key of draw order: the draw's index, then the triangle's.
pub fn draw_order_key(l: &Layer) -> u64 {
    (u64::from(l.draw) << 32) | u64::from(l.triangle)
}

/// The prediction for one OVER pass in draw order (`unsorted`, and the harness's blend in
/// draw order).
pub fn predict_draw_order(lists: &PixelLists) -> Prediction {
    let error = model_error(lists, |px| blend_in_order(px, draw_order_key));
    Prediction::from_model(
        &error,
        "draw order is back to front wherever the order changes the colour",
        "draw order is not back to front",
    )
}

/// Front-facing of a world-space triangle seen by `scene`'s camera, as a rasterizer decides it
/// (counter-clockwise on screen is front): the sign of its normal against the direction to
/// the eye, in view space (exact for perspective and orthographic cameras alike).
pub fn front_facing(scene: &oit_scene::Scene, p: [[f32; 3]; 3]) -> bool {
    let view = scene.camera.view;
    let v = p.map(|q| view.transform_point3(glam::Vec3::from(q)));
    let n = (v[1] - v[0]).cross(v[2] - v[0]);
    if matches!(
        scene.camera.projection,
        oit_scene::Projection::Orthographic { .. }
    ) {
        n.z > 0.0
    } else {
        n.dot(-v[0]) > 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(e: f64, rounding: u64) -> ModelError {
        ModelError {
            max_relative: e,
            pixels_over: u64::from(e > MODEL_EXACT),
            rounding_pixels_over: rounding,
            worst: (e > 0.0).then_some((1, 2)),
        }
    }

    #[test]
    fn verdicts_split_at_the_model_bounds() {
        let v = |e, r| Prediction::from_model(&model(e, r), "ok", "wrong").verdict;
        assert_eq!(v(0.0, 0), Verdict::Exact);
        assert_eq!(v(MODEL_EXACT, 0), Verdict::Exact);
        assert_eq!(v(MODEL_EXACT * 1.01, 0), Verdict::Borderline);
        assert_eq!(v(MODEL_INEXACT * 0.99, 0), Verdict::Borderline);
        assert_eq!(v(MODEL_INEXACT, 0), Verdict::Inexact);
        assert_eq!(v(0.0, 3), Verdict::Borderline);
        assert_eq!(v(1.0, 3), Verdict::Inexact);
        let p = Prediction::from_model(&model(0.5, 0), "ok", "wrong order");
        assert!(
            p.because.starts_with("wrong order: 1 px differ"),
            "{}",
            p.because
        );
        assert!(p.because.contains("(1, 2)"), "{}", p.because);
    }

    #[test]
    fn f16_rounding_matches_the_half_grid() {
        assert_eq!(f16_round(1.0), 1.0);
        // 1 + 2^-11 is halfway between 1 and 1 + 2^-10: ties to even, down to 1.
        assert_eq!(f16_round(1.0 + 2f32.powi(-11)), 1.0);
        assert_eq!(
            f16_round(1.0 + 3.0 * 2f32.powi(-11)),
            1.0 + 2.0 * 2f32.powi(-10)
        );
        assert_eq!(f16_round(65504.0), 65504.0);
        assert_eq!(f16_round(70000.0), f32::INFINITY);
        assert_eq!(f16_round(2f32.powi(-24)), 2f32.powi(-24));
        assert_eq!(f16_round(2f32.powi(-26)), 0.0);
        for x in [0.1f32, 0.3, 1.7, 123.456, 1e-5, 3e4] {
            let r = f16_round(x);
            let quantum = 2f32.powi((x.log2().floor() as i32).max(-14) - 10);
            assert!((r - x).abs() <= quantum / 2.0, "{x}: {r}");
            assert_eq!(f16_round(r), r, "{x}: rounding is idempotent");
        }
    }

    #[test]
    fn agreement_is_decided_only_for_exact_and_inexact() {
        let exact = Prediction::exact("one layer");
        assert_eq!(exact.agrees(EXACT_BOUND), Some(true));
        assert_eq!(exact.agrees(EXACT_BOUND * 1.5), Some(false));
        let inexact = Prediction::from_model(&model(0.2, 0), "ok", "wrong");
        assert_eq!(inexact.agrees(0.1), Some(true));
        assert_eq!(inexact.agrees(1e-4), Some(false));
        assert_eq!(Prediction::unmodelled("noise").agrees(0.0), None);
    }
}
