//! [`compare`]: the numbers of `results.json`'s `error` object, and the difference image.

use oit_scene::LinearImage;
use serde::{Deserialize, Serialize};

use crate::MetricsError;
use crate::flip::{self, DEFAULT_PPD, luminance};
use crate::ssim::ssim;
use crate::tonemap::{srgb_oetf, tone_map};

/// PSNR reported for identical images (and for any RMSE below 1e-10): JSON has no infinity.
pub const PSNR_CAP: f64 = 200.0;

/// Slack of the `over_*` thresholds: an error counts only when it exceeds `t + THRESHOLD_SLACK`.
/// 2⁻²⁰ covers the f32 rounding of an exact 8-bit step on pixel values up to 8 (ulp 2⁻²⁰).
pub const THRESHOLD_SLACK: f64 = 1.0 / 1_048_576.0;

/// Errors of a render against the reference on linear RGB. Field names are the `error` object
/// of the `oit-lab/results/v1` schema; the crate docs define each one. Fields added after the
/// first results were published carry `#[serde(default)]`, so older `results.json` files still
/// parse (they read as `hdr = false`, no HDR-ꟻLIP, `relmse = 0`, `ssim = 0`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Errors {
    /// Root mean squared error over the RGB channels of finite pixels.
    pub rmse: f64,
    /// `−20·log10(rmse)` dB, peak 1.0, at most [`PSNR_CAP`].
    pub psnr: f64,
    /// Mean absolute error over the RGB channels of finite pixels.
    pub mean_abs: f64,
    /// Largest absolute channel error over finite pixels.
    pub max_abs: f64,
    /// Largest channel error relative above 1, `|x − y| / max(1, |y|)`, `y` the reference,
    /// over finite pixels: the measure a run is called exact by (`oit_gpu::predict`), which
    /// HDR values above 1 do not inflate.
    #[serde(default)]
    pub max_relative: f64,
    /// Fraction of all pixels whose max-channel error exceeds 1/255 (non-finite pixels count).
    pub over_1_255: f64,
    /// Fraction of all pixels whose max-channel error exceeds 1/64 (non-finite pixels count).
    pub over_1_64: f64,
    /// Mean LDR-ꟻLIP of the Reinhard tone-mapped images, unquantised (linear f32), in [0, 1].
    pub flip_mean: f64,
    /// Pixels with a NaN or infinite RGB channel (render or reference).
    pub nonfinite: u64,
    /// The reference is HDR: some finite reference channel exceeds 1. Decides which ꟻLIP
    /// [`Errors::headline_flip`] reports.
    #[serde(default)]
    pub hdr: bool,
    /// Mean HDR-ꟻLIP (ACES tone map, exposures bracketed from the reference), in [0, 1];
    /// computed only when [`Errors::hdr`] is set, `null` otherwise.
    #[serde(default)]
    pub hdr_flip_mean: Option<f64>,
    /// Relative MSE: mean over the RGB channels of finite pixels of `(x − y)² / (y² + 0.01)`,
    /// `y` the reference.
    #[serde(default)]
    pub relmse: f64,
    /// Mean SSIM (Wang et al. 2004) of the tone-mapped, sRGB-encoded luminance, in [−1, 1]
    /// (1 = identical).
    #[serde(default)]
    pub ssim: f64,
}

impl Errors {
    /// The ꟻLIP number a report should show, and its name: HDR-ꟻLIP for an HDR reference
    /// (`("HDR-FLIP", hdr_flip_mean)`), otherwise LDR-ꟻLIP after the fixed Reinhard tone map
    /// (`("LDR-FLIP", flip_mean)`). Reports print the name next to the number.
    pub fn headline_flip(&self) -> (f64, &'static str) {
        match (self.hdr, self.hdr_flip_mean) {
            (true, Some(v)) => (v, "HDR-FLIP"),
            _ => (self.flip_mean, "LDR-FLIP"),
        }
    }
}

/// `pixels.len()` must be `width*height`: the fields are public, so a caller can break it.
pub(crate) fn check_image(image: &LinearImage, role: &'static str) -> Result<(), MetricsError> {
    let expected = u64::from(image.width) * u64::from(image.height);
    if image.pixels.len() as u64 != expected {
        return Err(MetricsError::PixelCount {
            image: role,
            width: image.width,
            height: image.height,
            expected,
            len: image.pixels.len(),
        });
    }
    Ok(())
}

pub(crate) fn check_pair(
    render: &LinearImage,
    reference: &LinearImage,
) -> Result<(), MetricsError> {
    check_image(render, "render")?;
    check_image(reference, "reference")?;
    if (render.width, render.height) != (reference.width, reference.height) {
        return Err(MetricsError::SizeMismatch {
            render: (render.width, render.height),
            reference: (reference.width, reference.height),
        });
    }
    Ok(())
}

fn rgb_finite(p: &[f32; 4]) -> bool {
    p[..3].iter().all(|c| c.is_finite())
}

/// Max over RGB of `|render − reference|` in f64, or `None` when either pixel is non-finite.
pub(crate) fn max_channel_error(r: &[f32; 4], g: &[f32; 4]) -> Option<f64> {
    if !rgb_finite(r) || !rgb_finite(g) {
        return None;
    }
    Some(
        (0..3)
            .map(|c| (f64::from(r[c]) - f64::from(g[c])).abs())
            .fold(0.0, f64::max),
    )
}

/// Measures `render` against `reference` (same size, alpha ignored). See the crate docs for
/// every definition, the non-finite policy, the threshold slack and the tone map used for FLIP.
pub fn compare(render: &LinearImage, reference: &LinearImage) -> Result<Errors, MetricsError> {
    check_pair(render, reference)?;
    if render.pixels.is_empty() {
        return Err(MetricsError::Empty {
            image: "render",
            width: render.width,
            height: render.height,
        });
    }

    let t255 = 1.0 / 255.0 + THRESHOLD_SLACK;
    let t64 = 1.0 / 64.0 + THRESHOLD_SLACK;
    let (mut sum_sq, mut sum_abs, mut max_abs, mut sum_rel) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut max_relative = 0.0f64;
    let (mut finite, mut nonfinite, mut over255, mut over64) = (0u64, 0u64, 0u64, 0u64);
    for (r, g) in render.pixels.iter().zip(&reference.pixels) {
        if !rgb_finite(r) || !rgb_finite(g) {
            nonfinite += 1;
            over255 += 1;
            over64 += 1;
            continue;
        }
        finite += 1;
        let mut pixel_max = 0.0f64;
        for c in 0..3 {
            let d = (f64::from(r[c]) - f64::from(g[c])).abs();
            let y = f64::from(g[c]);
            sum_sq += d * d;
            sum_rel += d * d / (y * y + 0.01);
            sum_abs += d;
            pixel_max = pixel_max.max(d);
            max_relative = max_relative.max(d / y.abs().max(1.0));
        }
        max_abs = max_abs.max(pixel_max);
        over255 += u64::from(pixel_max > t255);
        over64 += u64::from(pixel_max > t64);
    }

    let samples = (finite * 3) as f64;
    let (rmse, mean_abs, relmse) = if finite == 0 {
        (0.0, 0.0, 0.0)
    } else {
        (
            (sum_sq / samples).sqrt(),
            sum_abs / samples,
            sum_rel / samples,
        )
    };
    let psnr = if rmse > 0.0 {
        (-20.0 * rmse.log10()).min(PSNR_CAP)
    } else {
        PSNR_CAP
    };
    let total = render.pixels.len() as f64;
    let perceptual = Perceptual::measure(render, reference);

    Ok(Errors {
        rmse,
        psnr,
        mean_abs,
        max_abs,
        max_relative,
        over_1_255: over255 as f64 / total,
        over_1_64: over64 as f64 / total,
        flip_mean: perceptual.flip_mean,
        nonfinite,
        hdr: perceptual.hdr_flip_mean.is_some(),
        hdr_flip_mean: perceptual.hdr_flip_mean,
        relmse,
        ssim: perceptual.ssim,
    })
}

/// True when some finite channel of the reference exceeds 1 (the scene is HDR).
pub(crate) fn reference_is_hdr(reference: &LinearImage) -> bool {
    reference
        .pixels
        .iter()
        .filter(|p| rgb_finite(p))
        .any(|p| p[..3].iter().any(|&c| c > 1.0))
}

/// Linear RGB after the fixed Reinhard tone map, unquantised; a pixel with a non-finite channel
/// becomes cyan (0, 1, 1), the colour previews give it.
fn tone_mapped(image: &LinearImage) -> Vec<[f32; 3]> {
    image
        .pixels
        .iter()
        .map(|p| {
            if rgb_finite(p) {
                [tone_map(p[0]), tone_map(p[1]), tone_map(p[2])]
            } else {
                [0.0, 1.0, 1.0]
            }
        })
        .collect()
}

/// The metrics that model the eye: ꟻLIP, HDR-ꟻLIP and SSIM. Sizes are checked by the caller.
struct Perceptual {
    flip_mean: f64,
    hdr_flip_mean: Option<f64>,
    ssim: f64,
}

impl Perceptual {
    fn measure(render: &LinearImage, reference: &LinearImage) -> Self {
        let (w, h) = (render.width as usize, render.height as usize);
        let tm_render = tone_mapped(render);
        let tm_reference = tone_mapped(reference);
        let flip_mean = flip::mean(&flip::flip_ldr(
            &tm_reference,
            &tm_render,
            w,
            h,
            DEFAULT_PPD,
        ));

        let hdr_flip_mean = reference_is_hdr(reference).then(|| {
            let rgb = |image: &LinearImage| -> Vec<[f32; 3]> {
                image.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect()
            };
            let map = flip::flip_hdr(&rgb(reference), &rgb(render), w, h, DEFAULT_PPD).map;
            flip::mean(&map)
        });

        let luma =
            |tm: &[[f32; 3]]| -> Vec<f32> { tm.iter().map(|&p| srgb_oetf(luminance(p))).collect() };
        let ssim = ssim(&luma(&tm_render), &luma(&tm_reference), w, h);
        Self {
            flip_mean,
            hdr_flip_mean,
            ssim,
        }
    }
}

/// Per-channel `|render − reference|` of RGB, with alpha 1 so that viewers show it unmasked.
/// NaN and infinities propagate (the EXR shows where they are). Sizes must match.
pub fn diff_image(
    render: &LinearImage,
    reference: &LinearImage,
) -> Result<LinearImage, MetricsError> {
    check_pair(render, reference)?;
    let pixels = render
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(r, g)| {
            [
                (r[0] - g[0]).abs(),
                (r[1] - g[1]).abs(),
                (r[2] - g[2]).abs(),
                1.0,
            ]
        })
        .collect();
    Ok(LinearImage {
        width: render.width,
        height: render.height,
        pixels,
    })
}
