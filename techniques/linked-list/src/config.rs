//! `linked-list:nodes-per-pixel=N|auto,sort-max=N|auto,node=f32|packed,tail=average|drop`.

use crate::node::NodeFormat;
use crate::sizing::Sizing;
use oit_gpu::{Bounded, Param, ParamInfo, SpecError, TechniqueSpec};

/// Largest `nodes-per-pixel`: the pool is also bounded by the adapter's storage binding size.
pub const MAX_NODES_PER_PIXEL: u64 = 1024;
/// Largest `sort-max`: the window lives in each resolve invocation's registers.
pub const MAX_SORT: u64 = 128;

oit_gpu::words! {
    /// What happens to the fragments behind the sort window.
    pub enum TailRule {
        /// One layer: coverage 1 − Π(1 − α) (exact), colour the α-weighted mean (approximate).
        Average = "average",
        /// Dropped (Bevy, webgpu-samples).
        Drop = "drop",
    }
}

/// Node pool size as an average per pixel, `1..=MAX_NODES_PER_PIXEL`.
pub type NodesPerPixel = Bounded<1, { MAX_NODES_PER_PIXEL as u32 }>;
/// Fragments sorted per pixel in the resolve, `1..=MAX_SORT`.
pub type SortMax = Bounded<1, { MAX_SORT as u32 }>;

/// A valid `linked-list` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LinkedListConfig {
    pub nodes_per_pixel: Sizing<NodesPerPixel>,
    pub sort_max: Sizing<SortMax>,
    pub node: NodeFormat,
    pub tail: TailRule,
}

impl Default for LinkedListConfig {
    fn default() -> Self {
        LinkedListConfig {
            nodes_per_pixel: Self::NODES_PER_PIXEL.default,
            sort_max: Self::SORT_MAX.default,
            node: Self::NODE.default,
            tail: Self::TAIL.default,
        }
    }
}

impl LinkedListConfig {
    pub const NODES_PER_PIXEL: Param<Sizing<NodesPerPixel>> = Param::new(
        "nodes-per-pixel",
        Sizing::Fixed(NodesPerPixel::of(16)),
        "node pool size as an average per pixel (Bevy's fragments_per_pixel_average); fragments past a full pool are lost and counted. auto: a pool of exactly the fragments a GPU count pass finds in front of the opaque surface, counted every frame (the count pass is timed with the frame); refused in MiB over the adapter's storage binding or AUTO_MEMORY_CAP (1 GiB)",
    );
    pub const SORT_MAX: Param<Sizing<SortMax>> = Param::new(
        "sort-max",
        Sizing::Fixed(SortMax::of(16)),
        "fragments kept sorted per pixel in the resolve; those behind go to the tail rule. auto: the deepest pixel's count from the GPU count pass, so no tail; refused when that is over 128",
    );
    pub const NODE: Param<NodeFormat> = Param::new(
        "node",
        NodeFormat::F32,
        "f32: 16 B nodes (f32 depth, binary16 colour and alpha); packed: 12 B nodes (Bevy: unorm24 depth, unorm8 alpha, rgb9e5 colour)",
    );
    pub const TAIL: Param<TailRule> = Param::new(
        "tail",
        TailRule::Average,
        "fragments behind the sort window: average (one layer with coverage 1 - prod(1 - alpha) and the alpha-weighted mean colour) or drop",
    );

    /// The registry's view of the parameters.
    pub fn params() -> Vec<ParamInfo> {
        vec![
            Self::NODES_PER_PIXEL.info(),
            Self::SORT_MAX.info(),
            Self::NODE.info(),
            Self::TAIL.info(),
        ]
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("linked-list")?;
        Ok(LinkedListConfig {
            nodes_per_pixel: Self::NODES_PER_PIXEL.read(spec)?,
            sort_max: Self::SORT_MAX.read(spec)?,
            node: Self::NODE.read(spec)?,
            tail: Self::TAIL.read(spec)?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of("linked-list")
            .with(&Self::NODES_PER_PIXEL, self.nodes_per_pixel)
            .with(&Self::SORT_MAX, self.sort_max)
            .with(&Self::NODE, self.node)
            .with(&Self::TAIL, self.tail)
    }

    /// Bytes per pixel of the pool, the heads and the lost-fragment counts; `transmit`: with
    /// the rgb-opacity nodes of scenes with coloured transmission. `None` for an `auto` pool,
    /// whose size is the scene's (`AutoSizes::sized_bytes`).
    pub fn bytes_per_pixel(&self, transmit: bool) -> Option<u64> {
        let nodes = self.nodes_per_pixel.fixed()?;
        Some(u64::from(nodes) * self.node.bytes(transmit) + 8)
    }

    /// Whether a frame needs the count pass first.
    pub fn counts(&self) -> bool {
        self.nodes_per_pixel == Sizing::Auto || self.sort_max == Sizing::Auto
    }
}
