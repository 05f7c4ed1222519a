//! oit-abuffer: the prefix-sum A-buffer (Maule, Comba, Torchelsen & Bastos 2013, "A survey of
//! raster-based transparency techniques" and their dynamic fragment buffer; Crassin's
//! "fragment-parallel" A-buffer is the same idea).
//!
//! One frame: (1) a geometry pass counts each pixel's transparent fragments in front of the
//! opaque surface (`oit_gpu::LayerCounter`, whose 16-byte summary sizes the array); (2) an
//! exclusive prefix sum of the counts gives each pixel its range of one array sized to the
//! frame's fragments ([`scan`]); (3) a second geometry pass fills the ranges; (4) a full-screen
//! resolve sorts each range (in registers up to 16 fragments, in place beyond) and composites
//! it front to back. Nothing is bounded per pixel: it never drops, averages or overflows, and
//! needs no pointer chasing. Nodes are the linked list's (`oit_linked_list::node`) without the
//! `next` index, so its CPU twins model the resolve.

mod abuffer;
mod predict;
pub mod scan;

pub use abuffer::{Abuffer, AbufferConfig, MEMORY_CAP};

/// Every WGSL file of this crate (`shaders/`), by file name.
pub const SHADERS: oit_gpu::shaders::Library = &[
    ("abuffer.wgsl", abuffer::WGSL),
    ("abuffer_transmit.wgsl", abuffer::TRANSMIT_WGSL),
    ("prefix_sum.wgsl", scan::WGSL),
];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it: its passes include the
/// linked list's node module.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "abuffer",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS, oit_linked_list::SHADERS],
};

use oit_gpu::TechniqueInfo;

/// The registry entry of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![TechniqueInfo {
        name: Abuffer::NAME,
        description: "prefix-sum A-buffer (Maule et al. 2013): count fragments per pixel, exclusive scan, fill one exactly sized array, sort and composite each pixel's range; exact up to its node format, never drops",
        params: AbufferConfig::params(),
        transmission: "**exact** per channel up to its storage with dual-source blending: fragments store rgb opacity `1 − t` (binary16 in `f32` nodes, unorm10 in `packed`), the resolve composites per channel and blends `dst = C + T ⊙ dst`. Without dual-source blending approximate: `1 − mean(t)`",
        build: |spec| Ok(Box::new(Abuffer::from_spec(spec)?)),
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
        let t = TechniqueSpec::build("abuffer", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "abuffer:node=f32");
        let t = TechniqueSpec::build("abuffer:node=packed", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "abuffer:node=packed");
        let e = TechniqueSpec::parse("abuffer:node=f16", &registry).unwrap_err();
        assert!(e.to_string().contains("allowed"), "{e}");
        assert!(Abuffer::from_spec(&TechniqueSpec::of("linked-list")).is_err());
    }

    #[test]
    fn fragments_are_list_nodes_without_their_link() {
        use oit_linked_list::NodeFormat;
        let f32 = AbufferConfig::default();
        assert_eq!(
            (f32.fragment_bytes(false), f32.fragment_bytes(true)),
            (12, 16)
        );
        let packed = AbufferConfig {
            node: NodeFormat::Packed,
        };
        assert_eq!(
            (packed.fragment_bytes(false), packed.fragment_bytes(true)),
            (8, 12)
        );
    }
}
