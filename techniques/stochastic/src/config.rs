//! Parameters of the two techniques, read from a validated [`TechniqueSpec`].

use oit_gpu::{Allowed, ParamInfo, SpecError, TechniqueSpec};

/// Where a fragment's survival threshold comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Pattern {
    /// A fresh hash per pixel, seed and frame: independent thresholds, the textbook estimator.
    White,
    /// The project's 64×64 void-and-cluster blue-noise tile.
    Blue,
    /// 4×4 ordered dither (17 coverage levels).
    Bayer4,
    /// 8×8 ordered dither (65 coverage levels).
    Bayer8,
    /// 16×16 ordered dither (257 coverage levels).
    Bayer16,
    /// 32×32 ordered dither (1025 coverage levels).
    Bayer32,
    /// 64×64 ordered dither (4097 coverage levels).
    Bayer64,
    /// 128×128 ordered dither (16 385 coverage levels).
    Bayer128,
    /// 256×256 ordered dither (65 537 coverage levels).
    Bayer256,
    /// Wyman & McGuire 2017 hashed alpha testing on the world position, with the CDF correction.
    Hashed,
}

impl Pattern {
    pub const ALL: [Pattern; 10] = [
        Pattern::White,
        Pattern::Blue,
        Pattern::Bayer4,
        Pattern::Bayer8,
        Pattern::Bayer16,
        Pattern::Bayer32,
        Pattern::Bayer64,
        Pattern::Bayer128,
        Pattern::Bayer256,
        Pattern::Hashed,
    ];
    pub const NAMES: &'static [&'static str] = &[
        "white", "blue", "bayer4", "bayer8", "bayer16", "bayer32", "bayer64", "bayer128",
        "bayer256", "hashed",
    ];

    pub fn name(self) -> &'static str {
        match self {
            Pattern::White => "white",
            Pattern::Blue => "blue",
            Pattern::Bayer4 => "bayer4",
            Pattern::Bayer8 => "bayer8",
            Pattern::Bayer16 => "bayer16",
            Pattern::Bayer32 => "bayer32",
            Pattern::Bayer64 => "bayer64",
            Pattern::Bayer128 => "bayer128",
            Pattern::Bayer256 => "bayer256",
            Pattern::Hashed => "hashed",
        }
    }

    /// Side of the Bayer matrix (`None` for the other patterns).
    pub fn bayer_side(self) -> Option<u32> {
        match self {
            Pattern::Bayer4 => Some(4),
            Pattern::Bayer8 => Some(8),
            Pattern::Bayer16 => Some(16),
            Pattern::Bayer32 => Some(32),
            Pattern::Bayer64 => Some(64),
            Pattern::Bayer128 => Some(128),
            Pattern::Bayer256 => Some(256),
            Pattern::White | Pattern::Blue | Pattern::Hashed => None,
        }
    }

    /// Side of the threshold table a tiled pattern reads (`None` for procedural patterns).
    /// Always a power of two: the shader wraps coordinates with a mask. At most 2^16: the
    /// seed shifts the tile by 16 bits in x and 16 in y.
    pub fn tile(self) -> Option<u32> {
        match self {
            Pattern::Blue => Some(crate::pattern::BLUE_NOISE_SIDE as u32),
            Pattern::White | Pattern::Hashed => None,
            bayer => bayer.bayer_side(),
        }
    }

    /// Bytes of the R32Float threshold texture the dither pass binds (a one-texel placeholder
    /// for procedural patterns, which read none).
    pub fn table_bytes(self) -> u64 {
        self.tile().map_or(4, |t| u64::from(t) * u64::from(t) * 4)
    }
}

/// How the pattern is decorrelated between layers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Seed {
    /// No offset: every layer sees the same screen-fixed pattern (the classic screen door,
    /// kept to show the correlation failure).
    None,
    /// One offset per draw, from its stable id.
    Object,
    /// One offset per triangle (draw id and triangle).
    Primitive,
}

impl Seed {
    pub const NAMES: &'static [&'static str] = &["object", "primitive", "none"];

    pub fn name(self) -> &'static str {
        match self {
            Seed::None => "none",
            Seed::Object => "object",
            Seed::Primitive => "primitive",
        }
    }
}

/// Largest `spp`: a budget, not an adapter limit. Each sample is two geometry passes, so 128
/// samples are 256 passes a frame, where the noise (∝ 1/√spp) is 1/11 of one sample's.
pub const MAX_SPP: u64 = 128;

/// `stochastic:pattern=…,seed=…,spp=N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct StochasticConfig {
    pub pattern: Pattern,
    pub seed: Seed,
    /// Frames averaged (each with its own pattern shift).
    pub spp: u32,
}

/// `a2c:samples=4|8`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct A2cConfig {
    pub samples: u32,
}

pub(crate) fn stochastic_params() -> Vec<ParamInfo> {
    vec![
        ParamInfo {
            key: "pattern",
            description: "threshold pattern: white noise, 64x64 void-and-cluster blue noise, Bayer 4x4 to 256x256, or hashed alpha (Wyman & McGuire 2017)",
            default: "blue",
            allowed: Allowed::Values(Pattern::NAMES),
        },
        ParamInfo {
            key: "seed",
            description: "pattern offset per object (draw id), per primitive (draw id and triangle), or none (same pattern on every layer)",
            default: "object",
            allowed: Allowed::Values(Seed::NAMES),
        },
        ParamInfo {
            key: "spp",
            description: "frames averaged, each with an R2 tile shift and golden-ratio rotation (tiled) or a fresh hash (white, hashed)",
            default: "1",
            allowed: Allowed::Integer {
                min: 1,
                max: MAX_SPP,
                words: &[],
            },
        },
    ]
}

pub(crate) fn a2c_params() -> Vec<ParamInfo> {
    vec![ParamInfo {
        key: "samples",
        description: "MSAA samples per pixel (the adapter must support the count for the colour and depth formats)",
        default: "4",
        allowed: Allowed::Values(&["4", "8"]),
    }]
}

impl StochasticConfig {
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("stochastic")?;
        let pattern = spec.word("pattern", Pattern::NAMES, |p| {
            Pattern::ALL.into_iter().find(|x| x.name() == p)
        })?;
        let seed = spec.word("seed", Seed::NAMES, |s| match s {
            "none" => Some(Seed::None),
            "primitive" => Some(Seed::Primitive),
            "object" => Some(Seed::Object),
            _ => None,
        })?;
        let spp = spec.integer("spp", 1, MAX_SPP)? as u32;
        Ok(StochasticConfig { pattern, seed, spp })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec {
            name: "stochastic".into(),
            params: [
                ("pattern", self.pattern.name().to_owned()),
                ("seed", self.seed.name().to_owned()),
                ("spp", self.spp.to_string()),
            ]
            .into_iter()
            .map(|(k, v)| (k.to_owned(), v))
            .collect(),
        }
    }
}

impl A2cConfig {
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("a2c")?;
        let samples = spec.word("samples", &["4", "8"], |s| s.parse().ok())?;
        Ok(A2cConfig { samples })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec {
            name: "a2c".into(),
            params: [("samples".to_owned(), self.samples.to_string())]
                .into_iter()
                .collect(),
        }
    }
}
