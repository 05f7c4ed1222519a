//! oit-sorted: the blended baselines every OIT technique is measured against.
//!
//! All five draw the transparent geometry with premultiplied OVER blending (src One, dst
//! OneMinusSrcAlpha) over the shared opaque pass, depth-tested against the opaque depth
//! (strictly nearer) without writing depth, except where noted:
//!
//! - `unsorted`: transparent draws in draw order. The baseline every cost is divided by.
//! - `sorted-object`: draws sorted as Babylon does ([`object_order`]).
//! - `sorted-triangle`: every transparent triangle sorted back to front by the view depth of its
//!   centroid, each frame, on the CPU ([`DepthSorter`]); (render group, queue) levels first.
//! - `depth-prepass`: a depth-only pass of the transparent geometry (writes depth; mask-blend
//!   discards honoured), then an EQUAL-depth blended pass: only the nearest transparent layer.
//! - `cull-split`: in sorted-object order, each double-sided object's back faces, then its
//!   front faces (Babylon's separateCullingPass); single-sided objects draw their front faces.

mod predict;
mod sort;
mod technique;

pub use sort::{
    DepthSorter, back_to_front_key, centroid, object_order, ordered_bits, radix_sort_pairs,
};
pub use technique::{Blended, Kind};

/// Every WGSL file of this crate (`shaders/`), by file name: what its passes' `#include`s
/// resolve in first (`oit_gpu::shaders::resolve`), and what the shader test holds against the
/// folder.
pub const SHADERS: oit_gpu::shaders::Library =
    &[("blend_transmit.wgsl", technique::BLEND_TRANSMIT)];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "sorted",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS],
};

use oit_gpu::TechniqueInfo;

/// What every technique of this crate does with coloured transmittance.
const TRANSMISSION: &str = "**exact** per channel with dual-source blending (`dst = C + t ⊙ dst`, `techniques/sorted/shaders/blend_transmit.wgsl`) where the adapter has it (lavapipe does); else approximate: the scalar opacity `1 − mean(t)`. The technique's own order errors remain";

/// The registry entries of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    Kind::ALL
        .iter()
        .map(|&kind| TechniqueInfo {
            name: kind.name(),
            description: kind.description(),
            params: Vec::new(),
            transmission: TRANSMISSION,
            build: |spec| Ok(Box::new(Blended::from_spec(spec)?)),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use oit_gpu::{SpecError, TechniqueSpec};

    #[test]
    fn every_kind_builds_from_its_own_name_and_nothing_else() {
        for info in techniques() {
            info.validate().unwrap();
            let t = (info.build)(&info.default_spec()).unwrap();
            assert_eq!(t.spec().to_string(), info.name);
        }
        // A parameter these techniques do not have, set by hand with a declaration of its own.
        const LAYERS: oit_gpu::Param<oit_gpu::Bounded<1, 8>> = oit_gpu::Param::new(
            "layers",
            oit_gpu::Bounded::of(3),
            "not a parameter of unsorted",
        );
        let spec = TechniqueSpec::of("unsorted").with(&LAYERS, oit_gpu::Bounded::of(3));
        let e = Blended::from_spec(&spec).unwrap_err();
        assert!(matches!(e, SpecError::UnknownKey { .. }), "{e}");
        let e = Blended::from_spec(&TechniqueSpec::of("wboit")).unwrap_err();
        assert!(
            matches!(e, SpecError::WrongTechnique { .. }) && e.to_string().contains("cull-split"),
            "{e}"
        );
    }
}
