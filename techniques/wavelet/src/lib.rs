//! oit-wavelet: wavelet order-independent transparency (Aizenshtein, Smal & McGuire,
//! arXiv 2201.00094, 2022), as Flywheel ships it.
//!
//! Absorbance A = −ln(1 − α) adds along a ray, and a pixel's absorbance as a function of
//! depth is a sum of steps, so its projection on a Haar basis is a sum of per-fragment
//! projections: additive blending, no ordering, no interlock (it runs on WebGPU). Pass 1 finds
//! each pixel's transparent depth interval, pass 2 projects every fragment's step over the
//! normalised depth, pass 3 reconstructs the absorbance in front of each fragment with its own
//! step taken out and accumulates (C·T, α·T), the composite normalises the colour under the
//! exact total coverage.
//!
//! - `wavelet:rank=2|3|4,storage=f16|f32` (defaults 3, f16; see [`Config::DEFAULT`]).
//! - [`math`]: the CPU twin of the basis, line-comparable with shaders/wavelet_math.wgsl.

pub mod math;
mod predict;
mod technique;

pub use technique::{
    COMPOSITE_WGSL, Config, MATH_WGSL, MAX_GROUPS, PASSES_WGSL, Storage, Wavelet, params_words,
};

/// Every WGSL file of this crate (`shaders/`), by file name.
pub const SHADERS: oit_gpu::shaders::Library = &[
    ("wavelet.wgsl", technique::PASSES_WGSL),
    ("wavelet_coefficients.wgsl", technique::COEFFICIENTS_WGSL),
    ("wavelet_composite.wgsl", technique::COMPOSITE_WGSL),
    ("wavelet_math.wgsl", technique::MATH_WGSL),
];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "wavelet",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS],
};

use oit_gpu::TechniqueInfo;

/// The registry entries of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![TechniqueInfo {
        name: "wavelet",
        description: "wavelet OIT (Aizenshtein, Smal & McGuire 2022): absorbance over per-pixel normalised depth on a Haar basis, additive; a depth-interval pass, coefficient pass(es), a shading pass and a composite",
        params: Config::params(),
        transmission: "approximate: composites the scalar opacity `1 − mean(t)`, exact for grey filters only; its coefficients are of the scalar absorbance `−ln(1 − α)`",
        build: |spec| Ok(Box::new(Wavelet::from_spec(spec)?)),
    }]
}

#[cfg(test)]
mod tests {
    use super::*;
    use oit_gpu::TechniqueSpec;

    #[test]
    fn registry_is_valid_and_canonical() {
        let registry = techniques();
        for info in &registry {
            info.validate().unwrap();
        }
        let t = TechniqueSpec::build("wavelet", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "wavelet:rank=3,storage=f16");
        let t = TechniqueSpec::build("wavelet:storage=f32,rank=4", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "wavelet:rank=4,storage=f32");
        let defaults = TechniqueSpec::parse("wavelet", &registry).unwrap();
        assert_eq!(Config::from_spec(&defaults), Ok(Config::DEFAULT));
        for bad in ["wavelet:rank=1", "wavelet:rank=5", "wavelet:storage=f8"] {
            let e = TechniqueSpec::parse(bad, &registry)
                .unwrap_err()
                .to_string();
            assert!(e.contains("rank") || e.contains("storage"), "{bad}: {e}");
        }
        assert!(Config::from_spec(&TechniqueSpec::of("mboit")).is_err());
    }

    /// Bytes per pixel: RG32F interval + N/4 coefficient targets + the accumulator.
    #[test]
    fn bytes_per_pixel_per_configuration() {
        for (rank, f16, f32) in [(2, 32, 56), (3, 48, 88), (4, 80, 152)] {
            let c = |storage| Config {
                rank: math::Rank::of(rank),
                storage,
            };
            assert_eq!(c(Storage::F16).bytes_per_pixel(), f16, "rank {rank}");
            assert_eq!(c(Storage::F32).bytes_per_pixel(), f32, "rank {rank}");
            assert_eq!(c(Storage::F16).groups(), 1 << (rank - 1));
        }
    }

    /// Pass 2 splits into as many geometry passes as the adapter's attachment limits need,
    /// covering every group once.
    #[test]
    fn coefficient_passes_fit_the_adapter() {
        let c = |rank, storage| Config {
            rank: math::Rank::of(rank),
            storage,
        };
        assert_eq!(
            c(3, Storage::F16).coefficient_passes_within(8, 32),
            [(0, 4)]
        );
        assert_eq!(
            c(4, Storage::F16).coefficient_passes_within(8, 32),
            [(0, 4), (4, 4)]
        );
        assert_eq!(
            c(4, Storage::F32).coefficient_passes_within(8, 32),
            [(0, 2), (2, 2), (4, 2), (6, 2)]
        );
        assert_eq!(
            c(4, Storage::F32).coefficient_passes_within(8, 128),
            [(0, 8)]
        );
        assert_eq!(
            c(4, Storage::F16).coefficient_passes_within(4, 128),
            [(0, 4), (4, 4)]
        );
        assert_eq!(
            c(2, Storage::F32).coefficient_passes_within(8, 128),
            [(0, 2)]
        );
    }
}
