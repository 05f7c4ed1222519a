//! Error heat maps for PNG previews: log-scaled max-channel error through a colour map defined
//! by a formula in Oklab (Björn Ottosson's perceptual space), so its lightness is monotone.

use std::f64::consts::PI;
use std::sync::OnceLock;

use oit_scene::LinearImage;

use crate::MetricsError;
use crate::metrics::{check_pair, max_channel_error};
use crate::tonemap::{NONFINITE_SRGB8, Srgb8Image, encode_srgb8};

/// Smallest error the map distinguishes from zero (t = 0).
const LOG_MIN: f64 = -4.0;
/// Largest error the map distinguishes (t = 1).
const LOG_MAX: f64 = 0.0;

/// Position on the colour map of an error: `(log10(e) + 4) / 4`, clamped to [0, 1].
fn error_to_t(error: f64) -> f64 {
    if error > 10f64.powf(LOG_MIN) {
        ((error.log10() - LOG_MIN) / (LOG_MAX - LOG_MIN)).min(1.0)
    } else {
        0.0
    }
}

/// Oklab → linear sRGB (matrices from Ottosson, "A perceptual color space for image processing").
fn oklab_to_linear_srgb(l: f64, a: f64, b: f64) -> [f64; 3] {
    let l_ = l + 0.396_337_777_4 * a + 0.215_803_757_3 * b;
    let m_ = l - 0.105_561_345_8 * a - 0.063_854_172_8 * b;
    let s_ = l - 0.089_484_177_5 * a - 1.291_485_548_0 * b;
    let (l3, m3, s3) = (l_ * l_ * l_, m_ * m_ * m_, s_ * s_ * s_);
    [
        4.076_741_662_1 * l3 - 3.307_711_591_3 * m3 + 0.230_969_929_2 * s3,
        -1.268_438_004_6 * l3 + 2.609_757_401_1 * m3 - 0.341_319_396_5 * s3,
        -0.004_196_086_3 * l3 - 0.703_418_614_7 * m3 + 1.707_614_701_0 * s3,
    ]
}

/// The colour map at `t` in [0, 1], as linear sRGB inside the gamut. In OkLCh:
/// lightness `L = 0.15 + 0.80·t`, chroma `C = 0.02 + 0.15·sin(π·t)`, hue `h = 290° + 170°·t`
/// (violet → pink-red → orange → yellow). Chroma is scaled down (bisection) until the colour
/// fits in sRGB, which keeps `L`, so lightness still rises with `t`.
fn colormap_linear(t: f64) -> [f64; 3] {
    let l = 0.15 + 0.80 * t;
    let c = 0.02 + 0.15 * (PI * t).sin();
    let h = (290.0 + 170.0 * t).to_radians();
    let at = |k: f64| oklab_to_linear_srgb(l, k * c * h.cos(), k * c * h.sin());
    let inside = |rgb: [f64; 3]| rgb.iter().all(|&v| (0.0..=1.0).contains(&v));
    if inside(at(1.0)) {
        return at(1.0);
    }
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if inside(at(mid)) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // `lo` is inside unless even grey is not (it is, for L in (0, 1)); clamp guards rounding.
    at(lo).map(|v| v.clamp(0.0, 1.0))
}

/// Entries of the colour table: 4096 steps over four decades is 1/1024 decade per step, far
/// finer than 8-bit output can show.
const TABLE_SIZE: usize = 4096;

/// The colour map sampled once from [`colormap_linear`] (the gamut bisection is too slow to run
/// per pixel on megapixel frames) and encoded to sRGB8.
fn table() -> &'static [[u8; 3]] {
    static TABLE: OnceLock<Vec<[u8; 3]>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..TABLE_SIZE)
            .map(|i| {
                let t = i as f64 / (TABLE_SIZE - 1) as f64;
                colormap_linear(t).map(|v| encode_srgb8(v as f32))
            })
            .collect()
    })
}

/// The heat-map colour of an absolute error (legend in the crate docs): 1e-4 or less (and 0)
/// is the darkest colour, 1 or more the lightest, log scale between; NaN/∞ is cyan.
pub fn error_color(error: f64) -> [u8; 3] {
    if !error.is_finite() {
        return NONFINITE_SRGB8;
    }
    let index = (error_to_t(error) * (TABLE_SIZE - 1) as f64).round() as usize;
    table()[index.min(TABLE_SIZE - 1)]
}

/// Heat map of the max-channel absolute RGB error of `render` against `reference` (alpha
/// ignored); pixels with a non-finite channel in either image are cyan. Sizes must match.
pub fn heatmap(render: &LinearImage, reference: &LinearImage) -> Result<Srgb8Image, MetricsError> {
    check_pair(render, reference)?;
    let pixels = render
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(r, g)| match max_channel_error(r, g) {
            Some(e) => error_color(e),
            None => NONFINITE_SRGB8,
        })
        .collect();
    Ok(Srgb8Image {
        width: render.width,
        height: render.height,
        pixels,
    })
}

/// A horizontal legend bar for [`heatmap`]: column `x` shows the colour of the error
/// `10^(4·x/(width−1) − 4)`, i.e. 1e-4 at the left edge, 1 at the right, a decade per quarter.
/// Every row is the same. A width of 1 shows the colour of 1e-4.
pub fn heatmap_legend(width: u32, height: u32) -> Srgb8Image {
    let row: Vec<[u8; 3]> = (0..width)
        .map(|x| {
            let t = if width > 1 {
                f64::from(x) / f64::from(width - 1)
            } else {
                0.0
            };
            error_color(10f64.powf(LOG_MIN + (LOG_MAX - LOG_MIN) * t))
        })
        .collect();
    let pixels = (0..height).flat_map(|_| row.iter().copied()).collect();
    Srgb8Image {
        width,
        height,
        pixels,
    }
}

/// Layer counts at or above this get the lightest colour of [`count_map`].
pub const COUNT_MAX: u32 = 255;

/// Position on the colour map of a layer count: `log2(1 + n) / 8`, so 0 is the darkest colour,
/// 1, 3, 7, 15, 31, 63, 127 and 255 (or more) step up by an eighth each.
fn count_to_t(count: u32) -> f64 {
    (f64::from(count.min(COUNT_MAX)) + 1.0).log2() / (f64::from(COUNT_MAX) + 1.0).log2()
}

/// The colour of a per-pixel layer count (the reference's `layers`), on the same perceptual
/// map as the error heat maps.
pub fn count_color(count: u32) -> [u8; 3] {
    let index = (count_to_t(count) * (TABLE_SIZE - 1) as f64).round() as usize;
    table()[index.min(TABLE_SIZE - 1)]
}

/// A picture of per-pixel counts (row-major, `width` a row), e.g. the transparent layers the
/// reference composited at each pixel; [`count_legend`] is its key.
pub fn count_map(counts: &[u32], width: u32) -> Srgb8Image {
    let width = width.max(1);
    Srgb8Image {
        width,
        height: (counts.len() / width as usize) as u32,
        pixels: counts.iter().map(|&n| count_color(n)).collect(),
    }
}

/// A horizontal legend bar for [`count_map`]: column `x` shows the colour of the count
/// `2^(8·x/(width−1)) − 1`, 0 at the left edge, 255 at the right.
pub fn count_legend(width: u32, height: u32) -> Srgb8Image {
    let row: Vec<[u8; 3]> = (0..width)
        .map(|x| {
            let t = if width > 1 {
                f64::from(x) / f64::from(width - 1)
            } else {
                0.0
            };
            let index = (t * (TABLE_SIZE - 1) as f64).round() as usize;
            table()[index.min(TABLE_SIZE - 1)]
        })
        .collect();
    let pixels = (0..height).flat_map(|_| row.iter().copied()).collect();
    Srgb8Image {
        width,
        height,
        pixels,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative luminance of an sRGB8 colour (decoded with the exact sRGB EOTF).
    fn luminance(c: [u8; 3]) -> f64 {
        let lin = |v: u8| {
            let s = f64::from(v) / 255.0;
            if s <= 0.04045 {
                s / 12.92
            } else {
                ((s + 0.055) / 1.055).powf(2.4)
            }
        };
        0.2126 * lin(c[0]) + 0.7152 * lin(c[1]) + 0.0722 * lin(c[2])
    }

    #[test]
    fn luminance_rises_strictly_along_the_map() {
        let colours: Vec<[u8; 3]> = (0..=64)
            .map(|i| error_color(10f64.powf(-4.0 + 4.0 * f64::from(i) / 64.0)))
            .collect();
        for pair in colours.windows(2) {
            assert!(
                luminance(pair[1]) > luminance(pair[0]),
                "{:?} -> {:?} is not lighter",
                pair[0],
                pair[1]
            );
        }
        assert!(
            luminance(colours[0]) < 0.02,
            "low end {:?} is not near black",
            colours[0]
        );
        assert!(
            luminance(colours[64]) > 0.8,
            "high end {:?} is not near white",
            colours[64]
        );
    }

    #[test]
    fn in_gamut_everywhere_and_hue_warm_in_the_middle() {
        for i in 0..=100 {
            let rgb = colormap_linear(f64::from(i) / 100.0);
            assert!(
                rgb.iter().all(|v| (0.0..=1.0).contains(v)),
                "t={i}: {rgb:?}"
            );
        }
        // 1e-2 sits in the middle of the map: red must dominate blue and green there.
        let mid = error_color(1e-2);
        assert!(
            mid[0] > mid[1] && mid[0] > mid[2],
            "1e-2 colour {mid:?} is not red-dominant"
        );
    }

    #[test]
    fn clamps_outside_the_decades_and_marks_nonfinite() {
        assert_eq!(error_color(0.0), error_color(1e-4));
        assert_eq!(error_color(1e-9), error_color(1e-4));
        assert_eq!(error_color(5.0), error_color(1.0));
        assert_ne!(error_color(1e-3), error_color(1e-4));
        assert_eq!(error_color(f64::NAN), NONFINITE_SRGB8);
        assert_eq!(error_color(f64::INFINITY), NONFINITE_SRGB8);
        // cyan is never produced by the map itself
        for i in 0..=256 {
            assert_ne!(
                error_color(10f64.powf(-4.0 + f64::from(i) / 64.0)),
                NONFINITE_SRGB8
            );
        }
    }

    #[test]
    fn table_matches_the_formula_at_the_decades() {
        for (e, t) in [
            (1e-4, 0.0),
            (1e-3, 0.25),
            (1e-2, 0.5),
            (1e-1, 0.75),
            (1.0, 1.0),
        ] {
            let direct = colormap_linear(t).map(|v| encode_srgb8(v as f32));
            assert_eq!(error_color(e), direct, "e = {e}");
        }
    }

    #[test]
    fn error_to_t_puts_decades_on_quarters() {
        for (e, t) in [
            (1e-4, 0.0),
            (1e-3, 0.25),
            (1e-2, 0.5),
            (1e-1, 0.75),
            (1.0, 1.0),
        ] {
            assert!(
                (error_to_t(e) - t).abs() < 1e-12,
                "e={e}: {}",
                error_to_t(e)
            );
        }
    }

    #[test]
    fn legend_runs_from_low_to_high() {
        let legend = heatmap_legend(257, 3);
        assert_eq!(
            (legend.width, legend.height, legend.pixels.len()),
            (257, 3, 771)
        );
        assert_eq!(legend.get(0, 0), error_color(1e-4));
        assert_eq!(legend.get(128, 2), error_color(1e-2));
        assert_eq!(legend.get(256, 1), error_color(1.0));
    }

    /// More layers is lighter, every count from 0 to [`COUNT_MAX`], and counts above it are
    /// the lightest colour; the legend's ends are the ends of the map.
    #[test]
    fn count_colours_rise_with_the_count() {
        for n in 0..COUNT_MAX {
            assert!(
                luminance(count_color(n + 1)) >= luminance(count_color(n)),
                "{n} layers"
            );
        }
        assert!(luminance(count_color(8)) > luminance(count_color(1)));
        assert_eq!(count_color(10_000), count_color(COUNT_MAX));
        let legend = count_legend(64, 2);
        assert_eq!(legend.get(0, 1), count_color(0));
        assert_eq!(legend.get(63, 0), count_color(COUNT_MAX));
        let map = count_map(&[0, 1, 2, 64, 300, 0], 3);
        assert_eq!((map.width, map.height), (3, 2));
        assert_eq!(map.get(1, 1), count_color(COUNT_MAX));
    }
}
