//! oit-mboit: moment-based order-independent transparency (Münstermann, Kerzner, Kolb, Peters,
//! HPG/i3D 2018).
//!
//! Absorbance A = −ln(1 − α) adds, so pass 1 sums it and its moments of the (log-warped)
//! fragment depth additively; pass 2 reconstructs, per fragment, a bound on the absorbance in
//! front of it from those moments and accumulates (C·T, α·T); the composite normalises the
//! colour and gives it the exact total coverage 1 − exp(−ΣA).
//!
//! - `mboit:moments=power4|power6|power8|trig2|trig3|trig4,storage=f32|f16` (defaults
//!   `power6`, `f32`; see [`Config::DEFAULT`]).
//! - [`math`]: the CPU twin of the reconstruction (`transmittance_at`), line-comparable with
//!   shaders/mboit_math.wgsl.

pub mod math;
mod predict;
mod technique;

pub use math::{MomentKind, Resolve, Storage, transmittance_at};
pub use technique::{
    ACCUM_WGSL, COMPOSITE_WGSL, Config, MATH_WGSL, Mboit, params_words, transparent_depth_interval,
};

/// Every WGSL file of this crate (`shaders/`), by file name: what its passes' `#include`s
/// resolve in first (`oit_gpu::shaders::resolve`), and what the shader test holds against the
/// folder.
pub const SHADERS: oit_gpu::shaders::Library = &[
    ("mboit_accum.wgsl", technique::ACCUM_WGSL),
    ("mboit_composite.wgsl", technique::COMPOSITE_WGSL),
    ("mboit_math.wgsl", technique::MATH_WGSL),
];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "mboit",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS],
};

use oit_gpu::TechniqueInfo;

/// The registry entries of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![TechniqueInfo {
        name: "mboit",
        description: "moment-based OIT (Münstermann et al. 2018): moments of absorbance over log-warped depth, a reconstructed transmittance per fragment, two geometry passes and a composite",
        params: Config::params(),
        transmission: "approximate: composites the scalar opacity `1 − mean(t)`, exact for grey filters only; its moments are of the scalar absorbance `−ln(1 − α)` and a per-channel set of moments is not implemented",
        build: |spec| Ok(Box::new(Mboit::from_spec(spec)?)),
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
        let t = TechniqueSpec::build("mboit", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "mboit:moments=power6,storage=f32");
        let t = TechniqueSpec::build("mboit:storage=f16,moments=trig3", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "mboit:moments=trig3,storage=f16");
        let defaults = TechniqueSpec::parse("mboit", &registry).unwrap();
        assert_eq!(Config::from_spec(&defaults), Ok(Config::DEFAULT));
        // Hand-built specs with a missing value, or of another technique, are refused.
        let bad = TechniqueSpec::of("mboit").with(&Config::STORAGE, Storage::F32);
        let e = Config::from_spec(&bad).unwrap_err();
        assert!(
            e.to_string().contains("moments") && e.to_string().contains("trig4"),
            "{e}"
        );
        assert!((registry[0].build)(&bad).is_err());
        assert!(Config::from_spec(&TechniqueSpec::of("wboit")).is_err());
        let e = TechniqueSpec::parse("mboit:moments=power10", &registry).unwrap_err();
        assert!(e.to_string().contains("power8"), "{e}");
        for (i, k) in MomentKind::ALL.iter().enumerate() {
            assert_eq!(k.index() as usize, i);
            assert_eq!(MomentKind::parse(k.name()), Some(*k));
        }
    }

    /// Bytes per pixel of every configuration: b0, the moments and the (C·T, α·T)
    /// accumulator; pass 1's attachment bytes per sample as WebGPU counts them.
    #[test]
    fn bytes_per_pixel_per_configuration() {
        let expected = [
            (MomentKind::Power4, 36, 20),
            (MomentKind::Power6, 44, 28),
            (MomentKind::Power8, 52, 36),
            (MomentKind::Trig2, 36, 20),
            (MomentKind::Trig3, 44, 28),
            (MomentKind::Trig4, 52, 36),
        ];
        for (moments, bytes, pass1) in expected {
            let c = Config {
                moments,
                storage: Storage::F32,
            };
            assert_eq!(c.bytes_per_pixel(), bytes, "{moments:?}");
            assert_eq!(c.pass1_bytes_per_sample(), pass1, "{moments:?}");
            let h = Config {
                moments,
                storage: Storage::F16,
            };
            assert_eq!(h.bytes_per_pixel(), bytes / 2, "{moments:?}");
            assert_eq!(h.pass1_bytes_per_sample(), pass1 / 2, "{moments:?}");
            // b0 plus the moments, as the paper counts them.
            assert_eq!(4 * (1 + moments.floats() as u64), bytes - 16);
        }
    }
}
