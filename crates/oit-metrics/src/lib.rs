//! oit-metrics: how far a render is from the reference, and the files that show it.
//!
//! Every number oit-lab reports is computed here, on **linear RGB** (alpha is ignored: the
//! final composite is opaque, see DESIGN.md), from two [`LinearImage`]s of the same size.
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
//! | `flip_mean`  | mean of the ꟻLIP error map of the two tone-mapped sRGB8 images (see below) |
//! | `nonfinite`  | number of pixels with a NaN or ±∞ RGB channel in the render (or the reference) |
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
//! # The one tone map (previews and FLIP)
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
//! FLIP uses [`nv_flip::DEFAULT_PIXELS_PER_DEGREE`] (67 pixels per degree: a 0.7 m wide
//! 3840-pixel monitor seen from 0.7 m, the ꟻLIP default). The mean is taken over every pixel of
//! the error map in f64; non-finite pixels take part as cyan, since FLIP filters neighbourhoods
//! and cannot skip a pixel.
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
mod tonemap;

use std::path::PathBuf;

pub use flip::{
    DEFAULT_PPD, Exposures, HdrFlip, aces, flip_hdr, flip_ldr, hdr_exposures, luminance,
    mean as flip_map_mean, pixels_per_degree,
};
pub use heatmap::{error_color, heatmap, heatmap_legend};
pub use io::{
    ChannelImage, ExrChannel, ExrLayer, read_exr_channel, read_exr_rgba, write_atomic,
    write_atomic_bytes, write_exr, write_png_preview, write_png_srgb8,
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
