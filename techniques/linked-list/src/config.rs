//! `linked-list:nodes-per-pixel=N,sort-max=N,node=f32|packed,tail=average|drop`.

use crate::node::NodeFormat;
use oit_gpu::{SpecError, TechniqueSpec};

/// Largest `nodes-per-pixel`: the pool is also bounded by the adapter's storage binding size.
pub const MAX_NODES_PER_PIXEL: u64 = 1024;
/// Largest `sort-max`: the window lives in each resolve invocation's registers.
pub const MAX_SORT: u64 = 128;

/// What happens to the fragments behind the sort window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TailRule {
    /// One layer: coverage 1 − Π(1 − α) (exact), colour the α-weighted mean (approximate).
    Average,
    /// Dropped (Bevy, webgpu-samples).
    Drop,
}

impl TailRule {
    pub const NAMES: &'static [&'static str] = &["average", "drop"];

    pub fn name(self) -> &'static str {
        match self {
            TailRule::Average => "average",
            TailRule::Drop => "drop",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "average" => Some(TailRule::Average),
            "drop" => Some(TailRule::Drop),
            _ => None,
        }
    }
}

/// A valid `linked-list` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LinkedListConfig {
    pub nodes_per_pixel: u32,
    pub sort_max: u32,
    pub node: NodeFormat,
    pub tail: TailRule,
}

impl Default for LinkedListConfig {
    fn default() -> Self {
        LinkedListConfig {
            nodes_per_pixel: 16,
            sort_max: 16,
            node: NodeFormat::F32,
            tail: TailRule::Average,
        }
    }
}

impl LinkedListConfig {
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("linked-list")?;
        Ok(LinkedListConfig {
            nodes_per_pixel: spec.integer("nodes-per-pixel", 1, MAX_NODES_PER_PIXEL)? as u32,
            sort_max: spec.integer("sort-max", 1, MAX_SORT)? as u32,
            node: spec.word("node", NodeFormat::NAMES, NodeFormat::parse)?,
            tail: spec.word("tail", TailRule::NAMES, TailRule::parse)?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        let params = [
            ("node", self.node.name().to_owned()),
            ("nodes-per-pixel", self.nodes_per_pixel.to_string()),
            ("sort-max", self.sort_max.to_string()),
            ("tail", self.tail.name().to_owned()),
        ];
        TechniqueSpec {
            name: "linked-list".to_owned(),
            params: params.into_iter().map(|(k, v)| (k.to_owned(), v)).collect(),
        }
    }

    /// Bytes per pixel of the pool, the heads and the lost-fragment counts; `transmit`: with
    /// the rgb-opacity nodes of scenes with coloured transmission.
    pub fn bytes_per_pixel(&self, transmit: bool) -> u64 {
        u64::from(self.nodes_per_pixel) * self.node.bytes(transmit) + 8
    }
}
