//! The final colour and depth targets, and readback of the colour.

use crate::context::Context;
use crate::error::GpuError;
use oit_scene::{LinearImage, Resolution};

/// Format of the final colour target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColorFormat {
    /// Half float: ~1e-3 relative precision, the default (what engines use).
    #[default]
    Rgba16Float,
    /// Full float, to separate a technique's error from the target's rounding. Blending into
    /// it needs `FLOAT32_BLENDABLE`.
    Rgba32Float,
    /// Linear 8-bit UNORM, as VTK's framebuffer and most engines' LDR paths: every blend
    /// clamps to [0, 1] and rounds to a multiple of 1/255.
    Rgba8Unorm,
}

impl ColorFormat {
    /// Every format, in the order `--target-format` lists them.
    pub const ALL: [ColorFormat; 3] = [
        ColorFormat::Rgba8Unorm,
        ColorFormat::Rgba16Float,
        ColorFormat::Rgba32Float,
    ];

    pub fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            ColorFormat::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
            ColorFormat::Rgba32Float => wgpu::TextureFormat::Rgba32Float,
            ColorFormat::Rgba8Unorm => wgpu::TextureFormat::Rgba8Unorm,
        }
    }

    /// The name on the command line and in results.json (WGSL's texel-format spelling).
    pub fn name(self) -> &'static str {
        match self {
            ColorFormat::Rgba8Unorm => "rgba8unorm",
            ColorFormat::Rgba16Float => "rgba16float",
            ColorFormat::Rgba32Float => "rgba32float",
        }
    }

    /// The format named `text` (case-insensitive), or a message listing the names allowed.
    pub fn parse(text: &str) -> Result<ColorFormat, String> {
        let wanted = text.trim().to_ascii_lowercase();
        Self::ALL
            .into_iter()
            .find(|f| f.name() == wanted)
            .ok_or_else(|| {
                format!(
                    "`{text}` is not a target format; allowed: {}",
                    Self::ALL.map(ColorFormat::name).join(", ")
                )
            })
    }

    /// Whether the target clamps to [0, 1] (a UNORM format): anything a technique writes
    /// above 1 or below 0, even in an intermediate blend, is lost.
    pub fn clamps(self) -> bool {
        self == ColorFormat::Rgba8Unorm
    }
}

impl std::fmt::Display for ColorFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Final colour and depth of one frame. The opaque pass clears and fills both; a technique
/// composites its transparent layers into `color`.
#[derive(Debug)]
pub struct Targets {
    pub resolution: Resolution,
    pub color_format: wgpu::TextureFormat,
    pub color: wgpu::Texture,
    pub color_view: wgpu::TextureView,
    /// `Depth32Float`; also bindable as a texture (peeling reads the opaque depth).
    pub depth: wgpu::Texture,
    pub depth_view: wgpu::TextureView,
    bytes: u64,
}

impl Targets {
    pub fn new(
        ctx: &Context,
        resolution: Resolution,
        format: ColorFormat,
    ) -> Result<Targets, GpuError> {
        let color_format = format.texture_format();
        ctx.caps.require_target(color_format, true)?;
        ctx.caps.require_resolution(resolution)?;
        let mut ledger = crate::MemoryLedger::new();
        let color = ledger.create_texture_2d(
            &ctx.device,
            "final colour",
            resolution,
            color_format,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::COPY_DST
                | wgpu::TextureUsages::TEXTURE_BINDING,
            1,
        );
        let depth = ledger.create_texture_2d(
            &ctx.device,
            "depth",
            resolution,
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::COPY_SRC
                | wgpu::TextureUsages::TEXTURE_BINDING,
            1,
        );
        Ok(Targets {
            resolution,
            color_format,
            color_view: color.create_view(&Default::default()),
            color,
            depth_view: depth.create_view(&Default::default()),
            depth,
            bytes: ledger.total(),
        })
    }

    /// Bytes of the shared colour and depth targets (not counted in any technique's memory).
    pub fn memory_bytes(&self) -> u64 {
        self.bytes
    }
}

/// Reads the final colour as linear RGBA f32, top-left origin.
pub fn read_color(ctx: &Context, targets: &Targets) -> Result<LinearImage, GpuError> {
    let bpp = match targets.color_format {
        wgpu::TextureFormat::Rgba8Unorm => 4,
        wgpu::TextureFormat::Rgba16Float => 8,
        wgpu::TextureFormat::Rgba32Float => 16,
        other => {
            return Err(GpuError::Mismatch(format!(
                "cannot read back {other:?} as linear RGBA"
            )));
        }
    };
    let bytes = crate::readback::read_texture(ctx, &targets.color, bpp, "final colour")?;
    let pixels = if bpp == 4 {
        // Linear UNORM: the stored byte n is n / 255 exactly as the blender used it.
        bytes
            .chunks_exact(4)
            .map(|p| std::array::from_fn(|c| f32::from(p[c]) / 255.0))
            .collect()
    } else if bpp == 8 {
        bytes
            .chunks_exact(8)
            .map(|p| {
                std::array::from_fn(|c| f16_to_f32(u16::from_le_bytes([p[2 * c], p[2 * c + 1]])))
            })
            .collect()
    } else {
        bytes
            .chunks_exact(16)
            .map(|p| {
                std::array::from_fn(|c| {
                    f32::from_le_bytes(p[4 * c..4 * c + 4].try_into().unwrap_or([0; 4]))
                })
            })
            .collect()
    };
    Ok(LinearImage {
        width: targets.resolution.width,
        height: targets.resolution.height,
        pixels,
    })
}

/// IEEE 754 binary16 to f32, exact (every half is representable), including subnormals,
/// infinities and NaN.
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = u32::from(h >> 15) << 31;
    let exp = u32::from((h >> 10) & 0x1f);
    let mant = u32::from(h & 0x3ff);
    let bits = match (exp, mant) {
        (0, 0) => sign,
        (0, m) => {
            // Subnormal: value = m · 2^-24, exactly representable as f32.
            let v = m as f32 * (1.0 / 16_777_216.0);
            return if sign != 0 { -v } else { v };
        }
        (0x1f, m) => sign | 0x7f80_0000 | (m << 13),
        (e, m) => sign | ((e + 127 - 15) << 23) | (m << 13),
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::{ColorFormat, f16_to_f32};

    #[test]
    fn format_names_parse_back_and_a_bad_one_lists_the_allowed() {
        for f in ColorFormat::ALL {
            assert_eq!(ColorFormat::parse(f.name()), Ok(f));
            assert_eq!(ColorFormat::parse(&f.name().to_uppercase()), Ok(f));
        }
        assert_eq!(ColorFormat::default(), ColorFormat::Rgba16Float);
        let err = ColorFormat::parse("rgba8").unwrap_err();
        assert!(
            err.contains("`rgba8`") && err.contains("rgba8unorm, rgba16float, rgba32float"),
            "{err}"
        );
    }

    #[test]
    fn half_conversion() {
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x3555), 0.333_251_95);
        assert_eq!(f16_to_f32(0x7bff), 65504.0);
        assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24));
        assert_eq!(f16_to_f32(0x03ff), 1023.0 * 2f32.powi(-24));
        assert_eq!(f16_to_f32(0x8000).to_bits(), 0x8000_0000);
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
        assert!(f16_to_f32(0x7e00).is_nan());
    }
}
