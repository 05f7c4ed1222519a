//! Technique configurations and their spec strings.

use crate::encoding::DepthEncoding;
use oit_gpu::wgpu::TextureFormat;
use oit_gpu::{Caps, SpecError, TechniqueSpec, Unsupported};

/// How many passes (layers for front peeling) to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassCount {
    /// At most this many; a frame stops early when nothing is left (passes with nothing to
    /// peel are not recorded, or skipped on the GPU).
    Fixed(u32),
    /// Until nothing is left (bounded only by the adapter: [`crate::max_pass_slots`]).
    Auto,
}

impl PassCount {
    /// Any count a u32 holds parses; whether the adapter can record that many passes is the
    /// technique's `check` (the bound is the adapter's, not the spec's).
    fn parse(spec: &TechniqueSpec, key: &'static str) -> Result<Self, SpecError> {
        let max = u32::MAX;
        spec.value(key, &format!("an integer 1..={max}, auto"), |v| {
            if v == "auto" {
                return Some(PassCount::Auto);
            }
            v.parse::<u32>()
                .ok()
                .filter(|n| *n >= 1)
                .map(PassCount::Fixed)
        })
    }

    fn name(self) -> String {
        match self {
            PassCount::Fixed(n) => n.to_string(),
            PassCount::Auto => "auto".to_owned(),
        }
    }

    /// Unsupported when a fixed count is more than the adapter allows (`max`, set by the
    /// adapter limit `limit`).
    pub(crate) fn check(self, key: &str, max: u32, limit: &str) -> Result<(), Unsupported> {
        match self {
            _ if max == 0 => Err(Unsupported::new(format!(
                "{key}: this adapter allows no peel pass (limited by its {limit})"
            ))),
            PassCount::Fixed(n) if n > max => Err(Unsupported::new(format!(
                "{key}={n}: this adapter allows at most {max} (limited by its {limit})"
            ))),
            _ => Ok(()),
        }
    }

    /// The most passes this setting may record on an adapter that allows `max`.
    pub fn budget(self, max: u32) -> u32 {
        match self {
            PassCount::Fixed(n) => n.min(max),
            PassCount::Auto => max,
        }
    }
}

/// Format of the dual-peel (−min, max) key range target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DepthFormat {
    /// `Rg32Float` where the adapter can blend it, else `Rg16Float`.
    Auto,
    Rg32f,
    /// Keys are rounded to binary16 in the shader before every comparison.
    Rg16f,
}

impl DepthFormat {
    pub const NAMES: &'static [&'static str] = &["auto", "rg32f", "rg16f"];

    pub fn name(self) -> &'static str {
        match self {
            DepthFormat::Auto => "auto",
            DepthFormat::Rg32f => "rg32f",
            DepthFormat::Rg16f => "rg16f",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "auto" => Some(DepthFormat::Auto),
            "rg32f" => Some(DepthFormat::Rg32f),
            "rg16f" => Some(DepthFormat::Rg16f),
            _ => None,
        }
    }

    /// The texture format this setting uses on an adapter, or why it cannot run there.
    /// MAX blending needs a blendable format; for `Rg32Float` that is `FLOAT32_BLENDABLE` plus
    /// the format's own blendable flag (not "filterable", which Babylon keys on).
    pub fn resolve(self, caps: &Caps) -> Result<TextureFormat, Unsupported> {
        let with = |format: TextureFormat| {
            caps.require_target(format, true)
                .map(|()| format)
                .map_err(|e| Unsupported::new(format!("depth={}: {}", self.name(), e.reason)))
        };
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

/// What happens to the layers still left after the last dual-peel pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tail {
    /// Dropped (Babylon.js); counted in `pixels_with_dropped_layers`.
    Drop,
    /// Composited between the front and back layers by one weighted blended OIT pass
    /// (`oit_wboit::tail`).
    Wboit,
}

impl Tail {
    pub const NAMES: &'static [&'static str] = &["drop", "wboit"];

    pub fn name(self) -> &'static str {
        match self {
            Tail::Drop => "drop",
            Tail::Wboit => "wboit",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "drop" => Some(Tail::Drop),
            "wboit" => Some(Tail::Wboit),
            _ => None,
        }
    }
}

/// `dual-peel:passes=N|auto,depth=auto|rg32f|rg16f,reverse-z=on|off,tail=drop|wboit,encoding=window|linear|log`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DualPeelConfig {
    pub passes: PassCount,
    pub depth: DepthFormat,
    /// The stored key grows toward the viewer.
    pub reverse_z: bool,
    pub tail: Tail,
    pub encoding: DepthEncoding,
}

impl Default for DualPeelConfig {
    /// Babylon.js's configuration: 5 passes (10 layers), layers beyond dropped.
    fn default() -> Self {
        DualPeelConfig {
            passes: PassCount::Fixed(5),
            depth: DepthFormat::Auto,
            reverse_z: true,
            tail: Tail::Drop,
            encoding: DepthEncoding::Window,
        }
    }
}

impl DualPeelConfig {
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("dual-peel")?;
        Ok(DualPeelConfig {
            passes: PassCount::parse(spec, "passes")?,
            depth: spec.word("depth", DepthFormat::NAMES, DepthFormat::parse)?,
            reverse_z: spec.word("reverse-z", &["on", "off"], |s| Some(s == "on"))?,
            tail: spec.word("tail", Tail::NAMES, Tail::parse)?,
            encoding: spec.word("encoding", DepthEncoding::NAMES, DepthEncoding::parse)?,
        })
    }

    /// The canonical spec (every key present).
    pub fn spec(&self) -> TechniqueSpec {
        let params = [
            ("depth", self.depth.name().to_owned()),
            ("encoding", self.encoding.name().to_owned()),
            ("passes", self.passes.name()),
            (
                "reverse-z",
                if self.reverse_z { "on" } else { "off" }.to_owned(),
            ),
            ("tail", self.tail.name().to_owned()),
        ];
        TechniqueSpec {
            name: "dual-peel".to_owned(),
            params: params.into_iter().map(|(k, v)| (k.to_owned(), v)).collect(),
        }
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
            layers: PassCount::Auto,
        }
    }
}

impl FrontPeelConfig {
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("front-peel")?;
        Ok(FrontPeelConfig {
            layers: PassCount::parse(spec, "layers")?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec {
            name: "front-peel".to_owned(),
            params: [("layers".to_owned(), self.layers.name())]
                .into_iter()
                .collect(),
        }
    }
}
