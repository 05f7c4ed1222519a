//! oit-wboit: weighted blended order-independent transparency (McGuire & Bavoil 2013) and the
//! weighted average it improved on (Bavoil & Myers 2008).
//!
//! One geometry pass accumulates (premultiplied colour · w, α · w) additively and the revealage
//! Π(1 − α) multiplicatively, depth-tested against the opaque depth without writing it; one
//! full-screen pass composites `avg · (1 − T) + opaque · T` with guards that keep the output
//! finite, and counts how often each guard fires ([`GuardCounts`]).
//!
//! - `wboit:weight=const|alpha|eq7|eq8|eq9|eq10|mcguire2015|range,accum=rgba16f|rgba32f,reveal=r8|r16f|r32f`
//!   (formulas on [`Weight`]; defaults `range`, `rgba16f`, `r16f`, see [`Config::DEFAULT`]).
//! - `weighted-average`: rgba16f (ΣC, Σα) and an r32f count n, `T = (1 − Σα/n)^n`.
//! - [`tail`]: the WGSL, targets and composite that dual depth peeling's `tail=wboit` reuses.

mod additive;
mod guards;
mod predict;
pub mod range;
pub mod tail;
mod technique;

pub use guards::{GUARD_SLOTS, GuardCounts};
pub use range::RangeParams;
pub use technique::{ACCUM_WGSL, Config, Wboit, Weight};

/// Every WGSL file of this crate (`shaders/`), by file name: what its passes' `#include`s
/// resolve in first (`oit_gpu::shaders::resolve`), and what the shader test holds against the
/// folder.
pub const SHADERS: oit_gpu::shaders::Library = &[
    ("wboit_accum.wgsl", technique::ACCUM_WGSL),
    ("wboit_composite.wgsl", tail::COMPOSITE_WGSL),
    ("wboit_tail.wgsl", tail::WGSL),
];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "wboit",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS],
};

use oit_gpu::TechniqueInfo;

/// What both techniques of this crate do with coloured transmittance.
const TRANSMISSION: &str = "approximate, per channel behind: McGuire & Mara 2015's layout (G3D's `DefaultRenderer`): the final colour is a third target of the accumulation pass, blended `(zero, one-minus-src)` with `1 − t`, so whatever lies behind the layers is multiplied by the exact per-channel product `Π t` in any order; the layers' own radiance is still the weighted average under the scalar coverage `1 − Π(1 − mean α)`, and the composite adds it without scaling the colour behind again. Exact for pure filters (τ = 1: max error 6.0e-8 in f32 targets on lavapipe). Needs 3 colour attachments (accumulation, revealage and an Rgba32Float final colour) within the adapter's bytes per sample (28 for the defaults; wgpu's alignment rule), else `1 − mean(t)`. The 2015 form, not the 2016 paper's `(1 − β) ⊙ average`: it keeps a single layer exact, as a filter's `1 − t` per channel is not its coverage";

/// The registry entries of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![
        TechniqueInfo {
            name: "wboit",
            description: "weighted blended OIT (McGuire & Bavoil 2013): one accumulation pass and a guarded full-screen composite",
            params: Config::params(),
            transmission: TRANSMISSION,
            build: |spec| Ok(Box::new(Wboit::new(Config::from_spec(spec)?))),
        },
        TechniqueInfo {
            name: "weighted-average",
            description: "weighted average (Bavoil & Myers 2008): (sum C, sum alpha) and a fragment count n, T = (1 - sum alpha / n)^n",
            params: Vec::new(),
            transmission: TRANSMISSION,
            build: |spec| Ok(Box::new(Wboit::new(Config::from_spec(spec)?))),
        },
    ]
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
        let t = TechniqueSpec::build("wboit", &registry).unwrap();
        assert_eq!(
            t.spec().to_string(),
            "wboit:accum=rgba16f,reveal=r16f,weight=range"
        );
        let t =
            TechniqueSpec::build("wboit:weight=eq7,reveal=r8,accum=rgba32f", &registry).unwrap();
        assert_eq!(
            t.spec().to_string(),
            "wboit:accum=rgba32f,reveal=r8,weight=eq7"
        );
        let defaults = TechniqueSpec::parse("wboit", &registry).unwrap();
        assert_eq!(Config::from_spec(&defaults), Ok(Config::DEFAULT));
        // A hand-built spec with a missing value is refused, not defaulted; one of another
        // technique is refused.
        let bad = TechniqueSpec::of("wboit")
            .with(&Config::ACCUM, tail::AccumFormat::Rgba16f)
            .with(&Config::REVEAL, tail::RevealFormat::R16f);
        let e = Config::from_spec(&bad).unwrap_err();
        assert!(
            e.to_string().contains("weight") && e.to_string().contains("eq10"),
            "{e}"
        );
        assert!((registry[0].build)(&bad).is_err());
        assert!(Config::from_spec(&TechniqueSpec::of("front-peel")).is_err());
        let t = TechniqueSpec::build("weighted-average", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "weighted-average");
        let e = TechniqueSpec::parse("wboit:weight=eq11", &registry).unwrap_err();
        assert!(e.to_string().contains("eq10, mcguire2015, range"), "{e}");
        for (i, w) in Weight::ALL.iter().enumerate() {
            assert_eq!(w.index() as usize, i);
            assert_eq!(Weight::parse(w.name()), Some(*w));
        }
    }
}
