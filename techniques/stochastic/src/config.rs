//! Parameters of the two techniques, read from a validated [`TechniqueSpec`].

use oit_gpu::{Bounded, Param, ParamInfo, SpecError, TechniqueSpec};

oit_gpu::words! {
    /// Where a fragment's survival threshold comes from.
    pub enum Pattern {
        /// A fresh hash per pixel, seed and frame: independent thresholds, the textbook estimator.
        White = "white",
        /// The project's 64×64 void-and-cluster blue-noise tile.
        Blue = "blue",
        /// 4×4 ordered dither (17 coverage levels).
        Bayer4 = "bayer4",
        /// 8×8 ordered dither (65 coverage levels).
        Bayer8 = "bayer8",
        /// 16×16 ordered dither (257 coverage levels).
        Bayer16 = "bayer16",
        /// 32×32 ordered dither (1025 coverage levels).
        Bayer32 = "bayer32",
        /// 64×64 ordered dither (4097 coverage levels).
        Bayer64 = "bayer64",
        /// 128×128 ordered dither (16 385 coverage levels).
        Bayer128 = "bayer128",
        /// 256×256 ordered dither (65 537 coverage levels).
        Bayer256 = "bayer256",
        /// Wyman & McGuire 2017 hashed alpha testing on the world position, with the CDF
        /// correction.
        Hashed = "hashed",
        /// Spatiotemporal blue noise (Wolfe et al. 2022): 32 slices of 64×64, each spatially
        /// blue, every pixel's sequence over the slices blue in time; frame t reads a slice.
        Stbn = "stbn",
    }
}

impl Pattern {
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
            Pattern::White | Pattern::Blue | Pattern::Hashed | Pattern::Stbn => None,
        }
    }

    /// Side of the threshold table a tiled pattern reads (`None` for procedural patterns).
    /// Always a power of two: the shader wraps coordinates with a mask. At most 2^16: the
    /// seed shifts the tile by 16 bits in x and 16 in y.
    pub fn tile(self) -> Option<u32> {
        match self {
            Pattern::Blue => Some(crate::pattern::BLUE_NOISE_SIDE as u32),
            Pattern::Stbn => Some(crate::stbn::STBN_SIDE as u32),
            Pattern::White | Pattern::Hashed => None,
            bayer => bayer.bayer_side(),
        }
    }

    /// Slices of the threshold table stacked vertically: [`crate::stbn::STBN_SLICES`] for
    /// `stbn`, 1 for the other tiled patterns (and for the placeholder of procedural ones).
    pub fn slices(self) -> u32 {
        match self {
            Pattern::Stbn => crate::stbn::STBN_SLICES as u32,
            _ => 1,
        }
    }

    /// Width and height in texels of the R32Float threshold texture the dither pass binds:
    /// `tile × tile·slices` (a one-texel placeholder for procedural patterns, which read none).
    pub fn table_size(self) -> (u32, u32) {
        let t = self.tile().unwrap_or(1);
        (t, t * self.slices())
    }

    /// Bytes of the R32Float threshold texture the dither pass binds.
    pub fn table_bytes(self) -> u64 {
        let (w, h) = self.table_size();
        u64::from(w) * u64::from(h) * 4
    }
}

oit_gpu::words! {
    /// How the pattern is decorrelated between layers.
    pub enum Seed {
        /// One offset per draw, from its stable id.
        Object = "object",
        /// One offset per triangle (draw id and triangle).
        Primitive = "primitive",
        /// No offset: every layer sees the same screen-fixed pattern (the classic screen door,
        /// kept to show the correlation failure).
        None = "none",
    }
}

/// Largest `spp`: a budget, not an adapter limit. Each sample is two geometry passes, so 128
/// samples are 256 passes a frame, where the noise (∝ 1/√spp) is 1/11 of one sample's.
pub const MAX_SPP: u64 = 128;

/// Frames averaged per image, `1..=MAX_SPP`.
pub type Spp = Bounded<1, { MAX_SPP as u32 }>;

/// `stochastic:pattern=…,seed=…,spp=N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct StochasticConfig {
    pub pattern: Pattern,
    pub seed: Seed,
    /// Frames averaged (each with its own pattern shift).
    pub spp: Spp,
}

oit_gpu::words! {
    /// MSAA samples per pixel of `a2c`.
    pub enum Samples {
        Four = "4",
        Eight = "8",
    }
}

impl Samples {
    /// The sample count.
    pub fn count(self) -> u32 {
        match self {
            Samples::Four => 4,
            Samples::Eight => 8,
        }
    }
}

/// `a2c:samples=4|8`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct A2cConfig {
    pub samples: Samples,
}

impl StochasticConfig {
    pub const PATTERN: Param<Pattern> = Param::new(
        "pattern",
        Pattern::Blue,
        "threshold pattern: white noise, 64x64 void-and-cluster blue noise, Bayer 4x4 to 256x256, hashed alpha (Wyman & McGuire 2017), or 64x64x32 spatiotemporal blue noise (Wolfe et al. 2022)",
    );
    pub const SEED: Param<Seed> = Param::new(
        "seed",
        Seed::Object,
        "pattern offset per object (draw id), per primitive (draw id and triangle), or none (same pattern on every layer)",
    );
    pub const SPP: Param<Spp> = Param::new(
        "spp",
        Spp::of(1),
        "frames averaged; sample k of animation frame t is sub-frame t*spp+k: an R2 tile shift and golden-ratio rotation (tiled), a fresh hash (white, hashed), or STBN slice (t*spp+k) mod 32 (R2-shifted per period)",
    );

    /// The registry's view of the parameters.
    pub fn params() -> Vec<ParamInfo> {
        vec![Self::PATTERN.info(), Self::SEED.info(), Self::SPP.info()]
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("stochastic")?;
        Ok(StochasticConfig {
            pattern: Self::PATTERN.read(spec)?,
            seed: Self::SEED.read(spec)?,
            spp: Self::SPP.read(spec)?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of("stochastic")
            .with(&Self::PATTERN, self.pattern)
            .with(&Self::SEED, self.seed)
            .with(&Self::SPP, self.spp)
    }
}

impl A2cConfig {
    pub const SAMPLES: Param<Samples> = Param::new(
        "samples",
        Samples::Four,
        "MSAA samples per pixel (the adapter must support the count for the colour and depth formats)",
    );

    /// The registry's view of the parameters.
    pub fn params() -> Vec<ParamInfo> {
        vec![Self::SAMPLES.info()]
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("a2c")?;
        Ok(A2cConfig {
            samples: Self::SAMPLES.read(spec)?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of("a2c").with(&Self::SAMPLES, self.samples)
    }
}
