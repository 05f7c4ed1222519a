//! oit-metrics: how far a render is from the reference, and the files that show it.
//!
//! Every number oit-lab reports is computed here, on **linear RGB** (alpha is ignored: the
//! final composite is opaque), from two [`LinearImage`]s of the same size.
//!
//! # Metrics ([`compare`] → [`Errors`], the `error` object of `results.json`)
//!
//! Let `d = render.rgb − reference.rgb` per channel, computed in f64 (exact for f32 inputs).
//!
//! | field        | definition |
//! |--------------|------------|
//! | `rmse`       | `sqrt(mean(d²))` over the 3 channels of every finite pixel |
//! | `psnr`       | `−20·log10(rmse)` dB with peak 1.0, capped at [`PSNR_CAP`] = 200 dB (identical images) |
//! | `mean_abs`   | `mean(|d|)` over the 3 channels of every finite pixel |
//! | `max_abs`    | `max(|d|)` over every channel of every finite pixel |
//! | `over_1_255` | fraction of **all** pixels whose max-channel `|d|` exceeds 1/255 |
//! | `over_1_64`  | fraction of **all** pixels whose max-channel `|d|` exceeds 1/64 |
//! | `flip_mean`  | mean LDR-ꟻLIP of the two Reinhard tone-mapped images, **unquantised** (see below) |
//! | `nonfinite`  | number of pixels with a NaN or ±∞ RGB channel in the render (or the reference) |
//! | `hdr`        | the reference is HDR: some finite reference channel exceeds 1.0 |
//! | `hdr_flip_mean` | mean HDR-ꟻLIP of the two linear images when `hdr`, else `null` (see below) |
//! | `relmse`     | `mean((x − y)² / (y² + 0.01))` over the 3 channels of every finite pixel, `x` render, `y` reference |
//! | `ssim`       | mean SSIM of the tone-mapped, sRGB-encoded luminance (see below); 1 = identical |
//!
//! `hdr`, `hdr_flip_mean`, `relmse` and `ssim` were added later (issue 10) and carry
//! `#[serde(default)]`: a `results.json` written before reads as `hdr = false`,
//! `hdr_flip_mean = null`, `relmse = 0`, `ssim = 0`. `flip_mean` changed meaning at the same
//! time: before, it was ꟻLIP (nv-flip, v1.2) of the 8-bit sRGB previews at 67.0 pixels per
//! degree, where a 1e-4 difference that crosses an 8-bit code reads ≈ 0.03 and one that does
//! not reads 0; old and new values are not comparable for near-identical images.
//!
//! **Which ꟻLIP a report shows**: [`Errors::headline_flip`] returns `hdr_flip_mean` named
//! `"HDR-FLIP"` when the reference is HDR, else `flip_mean` named `"LDR-FLIP"`; reports print
//! the name with the number. Reinhard squeezes 10–1000 into [0.91, 1), so on HDR scenes LDR-ꟻLIP
//! barely moves (`hdr-emissive`, `unsorted` at 64×64: LDR-ꟻLIP 0.0033 with a max error of 13.4;
//! HDR-ꟻLIP 0.0232).
//!
//! **Non-finite pixels** (any RGB channel NaN or infinite in either image) are counted in
//! `nonfinite`, left out of `rmse`, `mean_abs` and `max_abs` (so one NaN does not turn every
//! number into NaN, which JSON cannot hold), and counted as over both thresholds. If no pixel is
//! finite, `rmse`, `mean_abs` and `max_abs` are 0 and `psnr` is the cap: read `nonfinite` first.
//!
//! **Thresholds** compare with a slack of [`THRESHOLD_SLACK`] (2⁻²⁰ ≈ 9.5e-7): an error counts as
//! over `t` only when `|d| > t + 2⁻²⁰`. Why: `t = 1/255` is not an f32 value, and a render that is
//! exactly one 8-bit step away from the reference, both stored as f32, differs from 1/255 by f32
//! rounding (up to a few ulps of the pixel value). The slack is far below any real error step.
//!
//! **PSNR** is always finite so that `results.json` stays plain JSON: identical images (and any
//! RMSE below 1e-10) report [`PSNR_CAP`].
//!
//! # The one tone map (previews, LDR-ꟻLIP and SSIM)
//!
//! Linear HDR → sRGB8, per channel, identical for render and reference:
//!
//! ```text
//! x' = max(x, 0)                   (negative light is not displayable)
//! y  = x' / (1 + x')               (Reinhard, exposure 1: [0, ∞) → [0, 1), never clips)
//! s  = 12.92·y                     if y ≤ 0.0031308
//!      1.055·y^(1/2.4) − 0.055     otherwise              (the sRGB OETF, IEC 61966-2-1)
//! v  = round(255·s)                (8-bit)
//! ```
//!
//! A pixel with any non-finite RGB channel becomes [`NONFINITE_SRGB8`] (cyan) instead.
//! Why Reinhard: it is fixed (no per-image exposure, so the same error always scores the same),
//! monotone, and never clips, so the `hdr-emissive` scene (radiances 10–1000) still has contrast:
//! 1 → 188, 10 → 245, 100 → 254. The price is that low dynamic range content uses the lower
//! three quarters of the 8-bit range (linear 1.0 → 188), so FLIP is a little less sensitive on
//! it than on an untonemapped sRGB image. Absolute HDR error is what `rmse`/`max_abs` are for.
//!
//! LDR-ꟻLIP and SSIM use the first two lines only: `y` in f32, not encoded, not rounded.
//!
//! # ꟻLIP ([`flip_ldr`], [`flip_hdr`])
//!
//! This crate's own implementation of ꟻLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator
//! for Alternating Images") and HDR-ꟻLIP (Andersson et al. 2021, "Visualizing Errors in Rendered
//! High Dynamic Range Images"), on f32 input, with the constants and the clamp-to-edge borders
//! of NVIDIA's reference implementation v1.6; [`flip_ldr`] lists the steps.
//! - **`flip_mean`**: [`flip_ldr`] of the Reinhard tone-mapped images (`y` above; a pixel with a
//!   non-finite channel is cyan (0, 1, 1)), as linear RGB, at [`DEFAULT_PPD`] = 67.0206 pixels
//!   per degree (0.7 m wide 3840-pixel monitor seen from 0.7 m, the ꟻLIP tool's default).
//! - **`hdr_flip_mean`**: [`flip_hdr`] of the linear images at [`DEFAULT_PPD`]. Exposures come
//!   from the reference ([`hdr_exposures`]): with `x85` the input the ACES curve (Narkowicz fit
//!   with the 0.6 pre-exposure folded in, [`aces`]) maps to 0.85 (≈ 2.1189), `start =
//!   log2(x85 / Y_max)`, `stop = log2(x85 / Y_median)` (luminance `Y = 0.2126R + 0.7152G +
//!   0.0722B`, upper median), `count = max(2, ceil(stop − start))` evenly spaced. At each
//!   exposure `c` both images are scaled by `2^c`, tone mapped with ACES per channel, clamped to
//!   [0, 1] and compared with LDR-ꟻLIP; each pixel keeps its largest error. Negative channels
//!   count as 0; a non-finite pixel is cyan at every exposure and does not enter `Y_max` or
//!   `Y_median`. Where over half the reference is black (`Y_median = 0`; NVIDIA's tool then runs
//!   with an infinite stop exposure), the median of the positive luminances replaces it; an
//!   all-black reference gets the single exposure 0. Computed only for an HDR reference, since
//!   its cost is `count` LDR-ꟻLIP evaluations.
//! - Means are arithmetic, over every pixel of the map, in f64.
//!
//! **Agreement with NVIDIA's implementation** (`xtask/flip-check/check.py`, flip-evaluator 1.7,
//! `evaluate(ref, test, "LDR" | "HDR", inputsRGB=False, applyMagma=False)`, same PPD), on seven
//! synthetic pairs (independent noise; a 97×61 noisy gradient with ±0.05 noise; flat fields 0.5
//! and 0.02 against +1e-4; an edge-shifted square; log-uniform HDR noise 0.01–1000 with ±20 %;
//! highlights 10–1000 at 60 %) and three 64×64 oit-lab renders (`hdr-emissive` `unsorted` and
//! `sorted-object`, `alpha-099-stack` `sorted-object`): |mean difference| at most 1.5e-6 (LDR)
//! and 2.5e-6 (HDR), per-pixel difference at most 5.4e-5 (LDR) and 2.2e-5 (HDR); HDR exposure
//! ranges and counts identical. The residue is f32 rounding in a different summation order,
//! largest on near-identical images, where ꟻLIP raises tiny colour distances to the power 0.7.
//! Against **nv-flip** 0.1.2 (ꟻLIP v1.2 on sRGB8, PPD 67.0; `tests/flip.rs`), on 8-bit input
//! decoded to linear: |mean difference| ≤ 1e-7 and per-pixel ≤ 3.6e-6 — the v1.2 and v1.6
//! pipelines are the same computation, v1.2 only decodes sRGB itself.
//!
//! **No quantisation floor**: on a flat field, +1e-4 now scores 1.1e-3 at 0.5, 2.2e-3 at 0.18,
//! 7.2e-3 at 0.02 (ꟻLIP's own response: the 0.7 power makes small differences count), and ten
//! times less offset scores five times less; through sRGB8 the same pairs scored 0 or, where the
//! offset crossed a code boundary, ≈ 0.03 (0.0294 at 0.4076: now 1.3e-3). `alpha-099-stack`
//! `sorted-object` (RMSE 9.4e-5) went from 0.0368 to 0.0011.
//!
//! **Cost** (release, one thread, best of 30, 256×256): LDR-ꟻLIP ≈ 9 ms; HDR-ꟻLIP ≈ 9 ms per
//! exposure (`hdr-emissive` needs 9). rayon splits rows across threads. The filters are
//! separable (two passes of 19–21 taps) and the per-pixel colour step is vectorised
//! (`flip::fast`: cube root, log2, exp2 and pow in plain arithmetic).
//!
//! # SSIM ([`ssim`])
//!
//! Wang, Bovik, Sheikh and Simoncelli 2004, on one channel: an 11×11 Gaussian window of σ = 1.5,
//! `K1 = 0.01`, `K2 = 0.03`, dynamic range 1, population (weighted) variances; the mean is over
//! the pixels whose window fits in the image (all pixels, with clamp-to-edge windows, for images
//! smaller than 11). `ssim` feeds it `srgb_oetf(0.2126R + 0.7152G + 0.0722B)` of the Reinhard
//! tone-mapped images (non-finite pixels cyan). Agrees with scikit-image's
//! `structural_similarity(gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
//! data_range=1)` to 2e-13 (`check.py`). On HDR scenes it inherits Reinhard's compression of
//! highlights (`hdr-emissive` `unsorted`: 0.999998).
//!
//! # Heat map legend ([`heatmap`], [`heatmap_legend`])
//!
//! Each pixel shows its max-channel error `e` on a log scale: `t = (log10(e) + 4) / 4` clamped to
//! [0, 1], so the five decades 1e-4, 1e-3, 1e-2, 1e-1, 1 sit at t = 0, ¼, ½, ¾, 1. Colours run
//! near-black violet (≤ 1e-4, including exact 0) → purple (1e-3) → red-pink (1e-2) → orange
//! (1e-1) → pale yellow (≥ 1); lightness rises strictly with `t`. Non-finite pixels are cyan
//! ([`NONFINITE_SRGB8`]), which the map never produces. The map is a formula in OkLCh
//! (Ottosson's Oklab in polar form), not a copied table: `L = 0.15 + 0.80·t`,
//! `C = 0.02 + 0.15·sin(π·t)`, `h = 290° + 170°·t`, with chroma scaled down until the colour fits
//! in sRGB (which keeps `L`), then the sRGB OETF; it is sampled once into 4096 entries.
//!
//! # Files
//!
//! Every file is written through [`write_atomic`]: a temporary file in the same directory,
//! flushed and synced, then renamed over the target, so an interrupted run never leaves a
//! truncated file under the target name. EXR files ([`write_exr`]) hold one part per
//! [`ExrLayer`] with linear f32 `R`, `G`, `B`, `A` and optional extra single-channel images.

mod flip;
mod heatmap;
mod io;
mod metrics;
mod ssim;
pub mod temporal;
mod tonemap;

use std::path::PathBuf;

pub use flip::{
    DEFAULT_PPD, Exposures, HdrFlip, aces, flip_hdr, flip_ldr, hdr_exposures, luminance,
    mean as flip_map_mean, pixels_per_degree,
};
pub use heatmap::{
    COUNT_MAX, count_color, count_legend, count_map, error_color, heatmap, heatmap_legend,
};
pub use io::{
    AtomicFile, ChannelImage, ExrChannel, ExrLayer, read_exr_channel, read_exr_rgba,
    remove_stale_temporaries, write_atomic, write_atomic_bytes, write_exr, write_png_preview,
    write_png_srgb8,
};
pub use metrics::{Errors, PSNR_CAP, THRESHOLD_SLACK, compare, diff_image};
pub use oit_scene::LinearImage;
pub use ssim::ssim;
pub use tonemap::{NONFINITE_SRGB8, Srgb8Image, encode_srgb8, preview_srgb8, srgb_oetf, tone_map};

/// Everything that can go wrong in this crate. File errors name the file.
#[derive(Debug, thiserror::Error)]
pub enum MetricsError {
    #[error(
        "image size mismatch: render is {}x{}, reference is {}x{} (they must be equal)",
        render.0, render.1, reference.0, reference.1
    )]
    SizeMismatch {
        render: (u32, u32),
        reference: (u32, u32),
    },

    #[error(
        "{image} image claims {width}x{height} = {expected} pixels but holds {len} (pixels must be width*height)"
    )]
    PixelCount {
        image: &'static str,
        width: u32,
        height: u32,
        expected: u64,
        len: usize,
    },

    #[error("{image} image is empty ({width}x{height}); metrics need at least one pixel")]
    Empty {
        image: &'static str,
        width: u32,
        height: u32,
    },

    #[error("{}: {what}", path.display())]
    InvalidOutput { path: PathBuf, what: String },

    #[error("writing {}: {source}", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },

    #[error("reading {}: {source}", path.display())]
    ReadExr {
        path: PathBuf,
        source: exr::error::Error,
    },

    #[error("{}: no layer named {layer:?}; the file has {available:?}", path.display())]
    MissingLayer {
        path: PathBuf,
        layer: String,
        available: Vec<String>,
    },

    #[error(
        "{}: layer {layer:?} has no channel {channel:?}; it has {available:?}",
        path.display()
    )]
    MissingChannel {
        path: PathBuf,
        layer: String,
        channel: String,
        available: Vec<String>,
    },
}
