//! The one fixed tone map from linear HDR to sRGB8 (crate docs give the formula and the why).

use oit_scene::LinearImage;

use crate::MetricsError;
use crate::metrics::check_image;

/// Colour of a pixel with a NaN or infinite RGB channel, in previews and heat maps. Cyan is
/// outside the heat map's warm ramp, so a non-finite pixel never reads as a large error.
pub const NONFINITE_SRGB8: [u8; 3] = [0, 255, 255];

/// An 8-bit sRGB image (no alpha), row-major from the top-left: previews and heat maps.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Srgb8Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[u8; 3]>,
}

impl Srgb8Image {
    /// The pixel at column `x`, row `y` (row 0 is the top).
    pub fn get(&self, x: u32, y: u32) -> [u8; 3] {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Tightly packed RGB bytes, as PNG encoders want them.
    pub fn as_bytes(&self) -> Vec<u8> {
        self.pixels.iter().flatten().copied().collect()
    }
}

/// Per-channel Reinhard tone map `max(x,0) / (1 + max(x,0))`, exposure 1: maps [0, ∞) onto
/// [0, 1) monotonically, so no HDR value clips. NaN maps to 0 and +∞ to 1 (callers that care
/// about non-finite pixels check before; see [`preview_srgb8`]).
pub fn tone_map(x: f32) -> f32 {
    if x.is_nan() || x <= 0.0 {
        0.0
    } else if x == f32::INFINITY {
        1.0
    } else {
        // In f64 so that very large x does not round to exactly 1 before it must.
        let x = f64::from(x);
        (x / (1.0 + x)) as f32
    }
}

/// The sRGB opto-electronic transfer function (IEC 61966-2-1): linear [0, 1] → encoded [0, 1].
/// Input is clamped to [0, 1] (NaN → 0). Not gamma 2.2: the linear toe below 0.0031308 matters
/// for the dark, faint layers OIT error lives in.
pub fn srgb_oetf(linear: f32) -> f32 {
    let y = f64::from(if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    });
    let s = if y <= 0.003_130_8 {
        12.92 * y
    } else {
        1.055 * y.powf(1.0 / 2.4) - 0.055
    };
    s as f32
}

/// Linear [0, 1] → sRGB8 code value: [`srgb_oetf`], then round to nearest (`0.5` rounds up).
pub fn encode_srgb8(linear: f32) -> u8 {
    let s = f64::from(srgb_oetf(linear));
    (s * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

/// One linear RGB pixel → sRGB8 through the fixed tone map; alpha ignored.
pub(crate) fn tone_map_pixel(p: [f32; 4]) -> [u8; 3] {
    if p[..3].iter().any(|c| !c.is_finite()) {
        return NONFINITE_SRGB8;
    }
    [
        encode_srgb8(tone_map(p[0])),
        encode_srgb8(tone_map(p[1])),
        encode_srgb8(tone_map(p[2])),
    ]
}

/// The image as it is shown in PNG previews: [`tone_map`], [`srgb_oetf`],
/// 8-bit; pixels with a non-finite RGB channel become [`NONFINITE_SRGB8`]. Alpha is ignored.
pub fn preview_srgb8(image: &LinearImage) -> Result<Srgb8Image, MetricsError> {
    check_image(image, "preview")?;
    Ok(Srgb8Image {
        width: image.width,
        height: image.height,
        pixels: image.pixels.iter().map(|&p| tone_map_pixel(p)).collect(),
    })
}
