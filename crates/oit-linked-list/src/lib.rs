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

mod config;
mod list;
pub mod node;

pub use config::{LinkedListConfig, MAX_NODES_PER_PIXEL, MAX_SORT, TailRule};
pub use list::{LinkedList, WGSL};
pub use node::NodeFormat;

use oit_gpu::{Allowed, ParamInfo, TechniqueInfo};

/// The registry entries of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![TechniqueInfo {
        name: "linked-list",
        description: "per-pixel linked lists (Yang et al. 2010): every fragment stored from a node pool, the sort_max nearest sorted per pixel, the rest by the tail rule; exact when pool and window hold every fragment",
        params: vec![
            ParamInfo {
                key: "nodes-per-pixel",
                description: "node pool size as an average per pixel (Bevy's fragments_per_pixel_average); fragments past a full pool are lost and counted",
                default: "16",
                allowed: Allowed::Integer {
                    min: 1,
                    max: MAX_NODES_PER_PIXEL,
                    words: &[],
                },
            },
            ParamInfo {
                key: "sort-max",
                description: "fragments kept sorted per pixel in the resolve; those behind go to the tail rule",
                default: "16",
                allowed: Allowed::Integer {
                    min: 1,
                    max: MAX_SORT,
                    words: &[],
                },
            },
            ParamInfo {
                key: "node",
                description: "f32: 16 B nodes (f32 depth, binary16 colour and alpha); packed: 12 B nodes (Bevy: unorm24 depth, unorm8 alpha, rgb9e5 colour)",
                default: "f32",
                allowed: Allowed::Values(NodeFormat::NAMES),
            },
            ParamInfo {
                key: "tail",
                description: "fragments behind the sort window: average (one layer with coverage 1 - prod(1 - alpha) and the alpha-weighted mean colour) or drop",
                default: "average",
                allowed: Allowed::Values(TailRule::NAMES),
            },
        ],
        build: |spec| Ok(Box::new(LinkedList::from_spec(spec)?)),
    }]
}
