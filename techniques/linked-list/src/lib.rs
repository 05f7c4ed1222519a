//! oit-linked-list: stored-fragment OIT, the method engines use today (Bevy's OIT, NVIDIA's
//! vk_order_independent_transparency).
//!
//! `linked-list` (Yang et al. 2010): one geometry pass appends every transparent fragment in
//! front of the opaque surface to its pixel's list, nodes allocated from a fixed pool by one
//! atomic counter; a full-screen resolve keeps the `sort_max` nearest fragments of each pixel
//! sorted (insertion sort; ties ordered by the stored colour, so the result is independent of
//! the order fragments arrived in), composites them front to back, and composites the fragments
//! behind them by the tail rule. With a pool and window that hold every fragment it is exact.
//! Fragments lost to a full pool and pixels whose tail was dropped or averaged are counted per
//! pixel and reported (`pixels_with_dropped_layers`, `pixels_with_approximated_layers`).
//! On scenes with coloured transmission (and dual-source blending) nodes store rgb opacity
//! `1 − t`, one word more, and the resolve composites per channel.
//!
//! `k-buffer` (NVIDIA's "Loop64"): no pool — each pixel keeps its `k` nearest fragments, sorted,
//! in `k` u64 slots updated by a chain of 64-bit `atomicMax` in one geometry pass; the fragment
//! a full pixel pushes out goes to two tail targets by hardware blending (Σ(C, α) and Π(1 − α)),
//! which the resolve composites behind the slots with the same averaged-tail rule (or drops).
//!
//! `slab` (Wyman 2016's stochastic layered alpha blending, without interlock): the k-buffer's K
//! slots, and behind them stochastic transparency over S coverage samples per pixel
//! (src/slab.rs).

mod config;
mod frame;
mod hybrid;
pub mod kbuffer;
mod list;
pub mod node;
mod predict;
mod sizing;
pub mod slab;

pub use config::{
    LinkedListConfig, MAX_NODES_PER_PIXEL, MAX_SORT, NodesPerPixel, SortMax, TailRule,
};
pub use hybrid::{Hybrid, HybridConfig, HybridWeight};
pub use kbuffer::{K, KBuffer, KBufferConfig, MAX_K, TailWeight};
pub use list::{
    FrameCounts, LinkedList, NODE_WGSL, PER_CHANNEL_OVER, WGSL, node_module, node_operator,
    node_transmission, stores_opacity,
};
pub use node::NodeFormat;
pub use sizing::{AUTO_MEMORY_CAP, Sizing};
pub use slab::{Slab, SlabConfig, SlabSamples};

/// Every WGSL file of this crate (`shaders/`), by file name: what its passes' `#include`s
/// resolve in first (`oit_gpu::shaders::resolve`), and what the shader test holds against the
/// folder.
pub const SHADERS: oit_gpu::shaders::Library = &[
    ("kbuffer64.wgsl", kbuffer::KBUFFER64_WGSL),
    ("kbuffer64_transmit.wgsl", kbuffer::KBUFFER64_TRANSMIT_WGSL),
    ("linked_list.wgsl", list::WGSL),
    ("linked_list_node.wgsl", list::NODE_WGSL),
    ("linked_list_transmit.wgsl", list::TRANSMIT_WGSL),
    ("slab.wgsl", slab::SLAB_WGSL),
];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "linked-list",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS, oit_wboit::SHADERS],
};

use oit_gpu::TechniqueInfo;

/// The registry entries of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![
        TechniqueInfo {
            name: "linked-list",
            description: "per-pixel linked lists (Yang et al. 2010): every fragment stored from a node pool, the sort_max nearest sorted per pixel, the rest by the tail rule; exact when pool and window hold every fragment",
            params: LinkedListConfig::params(),
            transmission: "**exact** per channel up to its storage with dual-source blending: list nodes store rgb opacity `1 − t` (binary16 in `f32` nodes, 20 B; unorm10 in `packed` nodes, 16 B), the resolve composites per channel and blends `dst = C + T ⊙ dst`; an averaged tail is per channel and still reported. Without dual-source blending approximate: `1 − mean(t)`",
            build: |spec| Ok(Box::new(LinkedList::from_spec(spec)?)),
        },
        TechniqueInfo {
            name: "k-buffer",
            description: "k-buffer on 64-bit atomics (NVIDIA's Loop64): the k nearest fragments per pixel kept sorted in one geometry pass by an atomicMax chain on (depth, packed colour) keys, the fragments pushed out averaged into one layer or dropped; needs SHADER_INT64_ATOMIC_ALL_OPS (Vulkan, DX12)",
            params: KBufferConfig::params(),
            transmission: "**exact** per channel up to its storage with dual-source blending: a second chain of opacity slots `1 − t` (unorm10) sorted like the colour slots, composited per channel and blended `dst = C + T ⊙ dst`; an averaged tail is per channel and still reported. Without dual-source blending approximate: `1 − mean(t)`",
            build: |spec| Ok(Box::new(KBuffer::from_spec(spec)?)),
        },
        TechniqueInfo {
            name: "hybrid",
            description: "hybrid transparency (Maule et al. 2013): the k nearest fragments per pixel exact in k-buffer slots, the rest averaged with WBOIT's range weight at their depth (coverage exact); needs SHADER_INT64_ATOMIC_ALL_OPS (Vulkan, DX12)",
            params: HybridConfig::params(),
            transmission: "no: its weighted tail is scalar; scenes with coloured transmission (or `subtract`) take the k-buffer's two chains, whose tail it does not weight",
            build: |spec| Ok(Box::new(Hybrid::from_spec(spec)?)),
        },
        TechniqueInfo {
            name: "slab",
            description: "stochastic layered alpha blending (Wyman 2016) without interlock: the k nearest fragments per pixel exact in k-buffer slots, the rest as stochastic transparency (Enderton et al. 2010) over S coverage samples, alpha-corrected; k slides from stochastic to the k-buffer; needs SHADER_INT64_ATOMIC_ALL_OPS (Vulkan, DX12)",
            params: SlabConfig::params(),
            transmission: "no: its stochastic tail is scalar (one coverage mask per fragment); scenes with coloured transmission (or `subtract`) take the k-buffer's two chains, which it does not extend",
            build: |spec| Ok(Box::new(Slab::from_spec(spec)?)),
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use oit_gpu::{SpecError, TechniqueSpec};

    #[test]
    fn registry_is_valid_canonical_and_refuses_hand_built_bad_specs() {
        let registry = techniques();
        for info in &registry {
            info.validate().unwrap();
        }
        let t = TechniqueSpec::build("linked-list", &registry).unwrap();
        assert_eq!(
            t.spec().to_string(),
            "linked-list:node=f32,nodes-per-pixel=16,sort-max=16,tail=average"
        );
        let t = TechniqueSpec::build("k-buffer:k=16,tail=drop", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "k-buffer:k=16,tail=drop");
        let t = TechniqueSpec::build("slab", &registry).unwrap();
        assert_eq!(t.spec().to_string(), "slab:k=4,samples=8");
        for bad in [
            "linked-list:sort-max=0",
            "linked-list:sort-max=129",
            "linked-list:nodes-per-pixel=1025",
            "linked-list:node=f16",
            "k-buffer:k=0",
            "k-buffer:k=33",
            "k-buffer:tail=sort",
            "slab:k=0",
            "slab:k=33",
            "slab:samples=4",
            "slab:samples=64",
        ] {
            let e = TechniqueSpec::parse(bad, &registry).unwrap_err();
            assert!(e.to_string().contains("allowed"), "{bad}: {e}");
        }
        // Hand-built: a parameter missing, or another technique's spec.
        let spec = TechniqueSpec::of("k-buffer").with(&KBufferConfig::TAIL, TailRule::Drop);
        assert!(matches!(
            KBuffer::from_spec(&spec),
            Err(SpecError::Missing { .. })
        ));
        let other = TechniqueSpec::of("linked-list");
        assert!(LinkedList::from_spec(&other).is_err());
        assert!(matches!(
            KBufferConfig::from_spec(&other),
            Err(SpecError::WrongTechnique { .. })
        ));
    }
}
