//! results.json's per-run `counts` (docs/results-schema.md, "counts"): the work of one frame in
//! units that mean the same on every GPU — samples that passed the depth test (occlusion
//! queries), bytes and atomics from the formats each technique states per pass, triangles
//! submitted, full-screen passes. Times depend on the adapter; these do not.

use serde::{Deserialize, Serialize};

/// One frame's work, counted in a frame of its own after the timed ones.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RunCounts {
    /// Samples that passed the depth test and were not discarded, summed over the passes that
    /// draw scene geometry (the shared opaque pass included): fragments on single-sampled
    /// targets, samples on multisampled ones.
    pub fragments: u64,
    /// Bytes read and written: per pass, its samples × the bytes its technique states per
    /// fragment, plus any per-fragment reads of another pass's fragments.
    pub bytes: u64,
    /// Atomic read-modify-write operations: per pass, its samples × the atomics stated.
    pub atomics: f64,
    /// Σ over geometry passes of the triangles each submits.
    pub triangle_passes: u64,
    /// Passes that draw scene geometry (the shared opaque pass included).
    pub geometry_passes: u32,
    /// Full-screen passes (composites, resolves, seeds).
    pub fullscreen_passes: u32,
    /// Pixels × `fullscreen_passes`.
    pub fullscreen_pixels: u64,
    /// Passes the technique did not declare in `Technique::work`: their samples are in no sum
    /// above (empty when every pass is declared).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub undeclared_passes: Vec<String>,
    /// Per pass, in the order the frame made them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub passes: Vec<PassCounts>,
}

/// One pass of the counted frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PassCounts {
    pub name: String,
    /// What the pass draws: `transparent`, `transparent-double-sided-twice`, `transmissive`,
    /// `not-transmissive`, `opaque`, `full-screen`, `compute`; absent when undeclared.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub draws: Option<String>,
    /// The pass's occlusion count; absent for a pass that began no query (a compute pass).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<u64>,
    /// Bytes read and written by the pass, as stated × samples.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bytes: Option<u64>,
    /// Atomics of the pass, as stated × samples.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub atomics: Option<f64>,
    /// Triangles the pass submits (0 for full-screen and compute passes).
    #[serde(default)]
    pub triangles: u64,
}
