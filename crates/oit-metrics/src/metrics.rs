//! [`compare`]: the numbers of `results.json`'s `error` object, and the difference image.

use oit_scene::LinearImage;
use serde::{Deserialize, Serialize};

use crate::MetricsError;
use crate::tonemap::tone_map_pixel;

/// PSNR reported for identical images (and for any RMSE below 1e-10): JSON has no infinity.
pub const PSNR_CAP: f64 = 200.0;

/// Slack of the `over_*` thresholds: an error counts only when it exceeds `t + THRESHOLD_SLACK`.
/// 2⁻²⁰ covers the f32 rounding of an exact 8-bit step on pixel values up to 8 (ulp 2⁻²⁰).
pub const THRESHOLD_SLACK: f64 = 1.0 / 1_048_576.0;

/// Errors of a render against the reference on linear RGB. Field names are the `error` object
/// of the `oit-lab/results/v1` schema; the crate docs define each one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Errors {
    /// Root mean squared error over the RGB channels of finite pixels.
    pub rmse: f64,
    /// `−20·log10(rmse)` dB, peak 1.0, at most [`PSNR_CAP`].
    pub psnr: f64,
    /// Mean absolute error over the RGB channels of finite pixels.
    pub mean_abs: f64,
    /// Largest absolute channel error over finite pixels.
    pub max_abs: f64,
    /// Fraction of all pixels whose max-channel error exceeds 1/255 (non-finite pixels count).
    pub over_1_255: f64,
    /// Fraction of all pixels whose max-channel error exceeds 1/64 (non-finite pixels count).
    pub over_1_64: f64,
    /// Mean ꟻLIP error of the tone-mapped sRGB8 images, in [0, 1].
    pub flip_mean: f64,
    /// Pixels with a NaN or infinite RGB channel (render or reference).
    pub nonfinite: u64,
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
    let (mut sum_sq, mut sum_abs, mut max_abs) = (0.0f64, 0.0f64, 0.0f64);
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
            sum_sq += d * d;
            sum_abs += d;
            pixel_max = pixel_max.max(d);
        }
        max_abs = max_abs.max(pixel_max);
        over255 += u64::from(pixel_max > t255);
        over64 += u64::from(pixel_max > t64);
    }

    let samples = (finite * 3) as f64;
    let (rmse, mean_abs) = if finite == 0 {
        (0.0, 0.0)
    } else {
        ((sum_sq / samples).sqrt(), sum_abs / samples)
    };
    let psnr = if rmse > 0.0 {
        (-20.0 * rmse.log10()).min(PSNR_CAP)
    } else {
        PSNR_CAP
    };
    let total = render.pixels.len() as f64;

    Ok(Errors {
        rmse,
        psnr,
        mean_abs,
        max_abs,
        over_1_255: over255 as f64 / total,
        over_1_64: over64 as f64 / total,
        flip_mean: flip_mean(render, reference),
        nonfinite,
    })
}

/// Mean ꟻLIP of the two images after the fixed tone map. Sizes are checked by the caller.
fn flip_mean(render: &LinearImage, reference: &LinearImage) -> f64 {
    let to_flip = |image: &LinearImage| {
        let bytes: Vec<u8> = image
            .pixels
            .iter()
            .flat_map(|&p| tone_map_pixel(p))
            .collect();
        nv_flip::FlipImageRgb8::with_data(image.width, image.height, &bytes)
    };
    let map = nv_flip::flip(
        to_flip(reference),
        to_flip(render),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let values = map.to_vec();
    values.iter().map(|&v| f64::from(v)).sum::<f64>() / values.len() as f64
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
