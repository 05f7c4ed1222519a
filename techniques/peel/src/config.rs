//! Technique configurations and their spec strings.

use crate::encoding::DepthEncoding;
use oit_gpu::wgpu::TextureFormat;
use oit_gpu::{
    Allowed, Bounded, Caps, Param, ParamInfo, ParamValue, SpecError, TechniqueSpec, Unsupported,
};

/// A fixed number of passes (layers for front peeling): at least 1. Whether the adapter can
/// record that many is the technique's `check` (the bound is the adapter's, not the spec's).
pub type Passes = Bounded<1, { u32::MAX }>;

/// How many passes (layers for front peeling) to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassCount {
    /// At most this many; a frame stops early when nothing is left (passes with nothing to
    /// peel are not recorded, or skipped on the GPU).
    Fixed(Passes),
    /// Until nothing is left (bounded only by the adapter: [`crate::max_pass_slots`]).
    Auto,
}

impl ParamValue for PassCount {
    fn allowed() -> Allowed {
        Allowed::Integer {
            min: 1,
            max: u64::from(u32::MAX),
            words: &["auto"],
        }
    }
    fn from_word(word: &str) -> Option<Self> {
        if word == "auto" {
            return Some(PassCount::Auto);
        }
        Passes::from_word(word).map(PassCount::Fixed)
    }
    fn word(self) -> String {
        match self {
            PassCount::Fixed(n) => n.word(),
            PassCount::Auto => "auto".to_owned(),
        }
    }
}

impl PassCount {
    /// Unsupported when a fixed count is more than the adapter allows (`max`, set by the
    /// adapter limit `limit`).
    pub(crate) fn check(self, key: &str, max: u32, limit: &str) -> Result<(), Unsupported> {
        match self {
            _ if max == 0 => Err(Unsupported::new(format!(
                "{key}: this adapter allows no peel pass (limited by its {limit})"
            ))),
            PassCount::Fixed(n) if n.get() > max => Err(Unsupported::new(format!(
                "{key}={n}: this adapter allows at most {max} (limited by its {limit})"
            ))),
            _ => Ok(()),
        }
    }

    /// The most passes this setting may record on an adapter that allows `max`.
    pub fn budget(self, max: u32) -> u32 {
        match self {
            PassCount::Fixed(n) => n.get().min(max),
            PassCount::Auto => max,
        }
    }
}

/// `format` where the adapter can render and blend it, else why `key=word` cannot run there.
fn blended_target(
    caps: &Caps,
    key: &str,
    word: &str,
    format: TextureFormat,
) -> Result<TextureFormat, Unsupported> {
    caps.require_target(format, true)
        .map(|()| format)
        .map_err(|e| Unsupported::new(format!("{key}={word}: {}", e.reason)))
}

oit_gpu::words! {
    /// Format of the dual-peel (−min, max) key range target.
    pub enum DepthFormat {
        /// `Rg32Float` where the adapter can blend it, else `Rg16Float`.
        Auto = "auto",
        Rg32f = "rg32f",
        /// Keys are rounded to binary16 in the shader before every comparison.
        Rg16f = "rg16f",
    }
}

impl DepthFormat {
    /// The texture format this setting uses on an adapter, or why it cannot run there.
    /// MAX blending needs a blendable format; for `Rg32Float` that is `FLOAT32_BLENDABLE` plus
    /// the format's own blendable flag (not "filterable", which Babylon keys on).
    pub fn resolve(self, caps: &Caps) -> Result<TextureFormat, Unsupported> {
        let with = |format| blended_target(caps, "depth", self.name(), format);
        match self {
            DepthFormat::Rg32f => with(TextureFormat::Rg32Float),
            DepthFormat::Rg16f => with(TextureFormat::Rg16Float),
            DepthFormat::Auto => {
                if caps.format(TextureFormat::Rg32Float).blendable {
                    Ok(TextureFormat::Rg32Float)
                } else {
                    with(TextureFormat::Rg16Float)
                }
            }
        }
    }
}

oit_gpu::words! {
    /// Format of dual peeling's front and back colour accumulators.
    pub enum AccumFormat {
        /// `Rgba32Float` where the adapter can blend it, else the final colour's format.
        Auto = "auto",
        Rgba32f = "rgba32f",
        /// Half floats: each blend rounds to binary16 (11 significant bits).
        Rgba16f = "rgba16f",
        /// 8-bit UNORM, as VTK's dual depth peeling: each blend rounds to 1/255 and clamps
        /// to [0, 1].
        Rgba8 = "rgba8",
    }
}

impl AccumFormat {
    /// The texture format of the RGBA accumulators on an adapter when the final colour is
    /// `final_format`, or why it cannot run there (every accumulator is blended).
    pub fn resolve(
        self,
        caps: &Caps,
        final_format: TextureFormat,
    ) -> Result<TextureFormat, Unsupported> {
        let with = |format| blended_target(caps, "accum", self.name(), format);
        match self {
            AccumFormat::Auto => Ok(crate::gpu::accumulator_format_on(caps, final_format)),
            AccumFormat::Rgba32f => with(TextureFormat::Rgba32Float),
            AccumFormat::Rgba16f => with(TextureFormat::Rgba16Float),
            AccumFormat::Rgba8 => with(TextureFormat::Rgba8Unorm),
        }
    }

    /// Why accumulators of this setting are not exact, where they are not: `None` for float
    /// accumulators at least as precise as f32 (or the final colour's own format).
    pub fn rounding(self) -> Option<&'static str> {
        match self {
            AccumFormat::Auto | AccumFormat::Rgba32f => None,
            AccumFormat::Rgba16f => {
                Some("accum=rgba16f: every blend into the accumulators rounds to binary16")
            }
            AccumFormat::Rgba8 => Some(
                "accum=rgba8: every blend into the accumulators rounds to 1/255 and clamps to [0, 1]",
            ),
        }
    }
}

oit_gpu::words! {
    /// What happens to the layers still left after the last dual-peel pass.
    pub enum Tail {
        /// Dropped (Babylon.js); counted in `pixels_with_dropped_layers`.
        Drop = "drop",
        /// Composited between the front and back layers by one weighted blended OIT pass
        /// (`oit_wboit::tail`).
        Wboit = "wboit",
    }
}

oit_gpu::words! {
    /// Whether dual peeling's stored key grows toward the viewer.
    pub enum ReverseZ {
        On = "on",
        Off = "off",
    }
}

/// `dual-peel:passes=N|auto,depth=auto|rg32f|rg16f,accum=auto|rgba32f|rgba16f|rgba8,reverse-z=on|off,tail=drop|wboit,encoding=window|linear|log`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DualPeelConfig {
    pub passes: PassCount,
    pub depth: DepthFormat,
    pub accum: AccumFormat,
    /// The stored key grows toward the viewer.
    pub reverse_z: bool,
    pub tail: Tail,
    pub encoding: DepthEncoding,
}

impl Default for DualPeelConfig {
    /// Babylon.js's configuration: 5 passes (10 layers), layers beyond dropped.
    fn default() -> Self {
        DualPeelConfig {
            passes: Self::PASSES.default,
            depth: Self::DEPTH.default,
            accum: Self::ACCUM.default,
            reverse_z: Self::REVERSE_Z.default == ReverseZ::On,
            tail: Self::TAIL.default,
            encoding: Self::ENCODING.default,
        }
    }
}

impl DualPeelConfig {
    pub const PASSES: Param<PassCount> = Param::new(
        "passes",
        PassCount::Fixed(Passes::of(5)),
        "peel passes after the init pass (2 layers each; Babylon's default is 5), or auto: exactly ceil(L/2), GPU-gated. No fixed cap: per-pass counters and pass indices grow with the frame, bounded only by the adapter (8 counter bytes per pass within max_storage_buffer_binding_size, one pass-index slot per pass within max_buffer_size; lavapipe: 16777214 passes, set by its 128 MiB storage binding size); a larger N is reported as unsupported there",
    );
    pub const DEPTH: Param<DepthFormat> = Param::new(
        "depth",
        DepthFormat::Auto,
        "range target format: rg32f needs blendable 32-bit float targets; auto picks rg32f where the adapter can blend it, else rg16f (keys rounded to f16)",
    );
    pub const ACCUM: Param<AccumFormat> = Param::new(
        "accum",
        AccumFormat::Auto,
        "front and back colour accumulators: auto is rgba32f where the adapter can blend it, else the final colour's format; rgba16f and rgba8 (VTK's 8-bit accumulators) trade precision for blend cost, and their rounding is reported",
    );
    pub const REVERSE_Z: Param<ReverseZ> = Param::new(
        "reverse-z",
        ReverseZ::On,
        "stored key grows toward the viewer (independent of the scene's own depth buffer)",
    );
    pub const TAIL: Param<Tail> = Param::new(
        "tail",
        Tail::Drop,
        "layers left after the last pass: drop them, or composite them with weighted blended OIT",
    );
    pub const ENCODING: Param<DepthEncoding> = Param::new(
        "encoding",
        DepthEncoding::Window,
        "stored key: window depth, or linear / logarithmic view distance over the scene's transparent depth interval",
    );

    /// The registry's view of the parameters.
    pub fn params() -> Vec<ParamInfo> {
        vec![
            Self::PASSES.info(),
            Self::DEPTH.info(),
            Self::ACCUM.info(),
            Self::REVERSE_Z.info(),
            Self::TAIL.info(),
            Self::ENCODING.info(),
        ]
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("dual-peel")?;
        Ok(DualPeelConfig {
            passes: Self::PASSES.read(spec)?,
            depth: Self::DEPTH.read(spec)?,
            accum: Self::ACCUM.read(spec)?,
            reverse_z: Self::REVERSE_Z.read(spec)? == ReverseZ::On,
            tail: Self::TAIL.read(spec)?,
            encoding: Self::ENCODING.read(spec)?,
        })
    }

    /// The canonical spec (every key present).
    pub fn spec(&self) -> TechniqueSpec {
        let reverse_z = if self.reverse_z {
            ReverseZ::On
        } else {
            ReverseZ::Off
        };
        TechniqueSpec::of("dual-peel")
            .with(&Self::PASSES, self.passes)
            .with(&Self::DEPTH, self.depth)
            .with(&Self::ACCUM, self.accum)
            .with(&Self::REVERSE_Z, reverse_z)
            .with(&Self::TAIL, self.tail)
            .with(&Self::ENCODING, self.encoding)
    }
}

/// `front-peel:layers=N|auto`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrontPeelConfig {
    pub layers: PassCount,
}

impl Default for FrontPeelConfig {
    fn default() -> Self {
        FrontPeelConfig {
            layers: Self::LAYERS.default,
        }
    }
}

impl FrontPeelConfig {
    pub const LAYERS: Param<PassCount> = Param::new(
        "layers",
        PassCount::Auto,
        "layers to peel (one geometry pass each), or auto: until a pass finds nothing (GPU-gated indirect draws). No fixed cap: per-layer counters and pass indices grow with the frame, bounded only by the adapter (8 counter bytes per layer within max_storage_buffer_binding_size, one pass-index slot per layer within max_buffer_size; lavapipe: 16777215 layers, set by its 128 MiB storage binding size); a larger N is reported as unsupported there",
    );

    /// The registry's view of the parameters.
    pub fn params() -> Vec<ParamInfo> {
        vec![Self::LAYERS.info()]
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("front-peel")?;
        Ok(FrontPeelConfig {
            layers: Self::LAYERS.read(spec)?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of("front-peel").with(&Self::LAYERS, self.layers)
    }
}
