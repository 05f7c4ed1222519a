//! oit-gpu: the GPU spine every transparency technique plugs into.
//!
//! - [`Context`]: adapter choice, device with the optional features techniques can use, and
//!   the [`Caps`] a technique reads to say "unsupported here because …".
//! - [`GpuScene`]: the [`oit_scene::Scene`] uploaded once; shared pipeline builder.
//! - [`Targets`] and [`read_color`]: the final colour (`Rgba16Float` or `Rgba32Float`) and
//!   `Depth32Float` depth, and readback to [`oit_scene::LinearImage`]; [`read_buffer`] and
//!   [`read_texture`] for any other result a technique or test reads back.
//! - [`render_frame`]: the shared opaque pass followed by one [`Technique`].
//! - [`GpuTimer`]: per-pass GPU time from timestamp queries, or wall-clock when the adapter has
//!   none (and the result says which).
//! - [`blend`] states and [`fullscreen_pipeline`]: what composites and copies share.
//! - [`bind`]: bind group layout entries.
//! - [`pass`]: attachments and render-pass boilerplate.
//! - [`memory`]: exact byte counts of what a technique allocates.
//! - [`TechniqueSpec`]: `name[:key=value,…]` parsing against a registry, canonical strings.
//! - [`count_fragments`]: the rasterization conformance pass.
//! - [`predict`]: whether a technique is exact on a scene, and why, from its model of a pixel.
//! - [`LayerCounter`]: the fragments a stored-fragment technique will hold, counted before it
//!   sizes its storage (`auto` parameters, [`AutoSizes`]).
//! - [`work`]: per pass, the bytes and atomics a technique's formats imply per fragment.
//! - [`Floor`]: one blended pass with the cheapest fragment work, the yardstick of every cost.

pub mod bind;
pub mod blend;
mod context;
mod count;
mod error;
mod floor;
mod frame;
mod layer_count;
pub mod made;
pub mod memory;
pub mod pass;
mod pipeline;
pub mod predict;
pub mod queues;
mod readback;
mod scene;
mod scope;
pub mod shaders;
mod spec;
mod targets;
mod technique;
pub mod testing;
pub mod texels;
mod timer;
pub mod work;

pub use blend::PREMULTIPLIED_OVER;
pub use context::{
    AdapterSummary, Backend, Caps, Context, ContextOptions, FormatCaps, PROBED_FORMATS,
};
pub use count::count_fragments;
pub use error::{GpuError, Unsupported};
pub use floor::{BlendShading, DrawOrderBlend, FLOOR_NAME, Floor};
pub use frame::{FrameResult, opaque_pass, render_frame};
pub use layer_count::{AutoSizes, LayerCount, LayerCounter, mib};
pub use memory::MemoryLedger;
pub use pass::CountedPass;
pub use pipeline::{FullscreenDesc, fullscreen_pipeline};
pub use predict::{Prediction, Verdict};
pub use queues::{Queues, predict_with_queues};
pub use readback::{read_buffer, read_buffer_u32, read_texture};
pub use scene::{
    CullRule, GpuScene, MATERIAL_STRIDE, MATERIAL_UNIFORM_STRIDE, MaterialSource, SceneBytes,
    ScenePipelineDesc, ScenePipelines, VERTEX_STRIDE, depth_test, vertex_layout,
};
pub use scope::ContainedError;
pub use spec::{
    Allowed, Bounded, Family, Param, ParamInfo, ParamValue, SpecError, TechniqueInfo, TechniqueSpec,
};
pub use targets::{ColorFormat, Targets, f16_to_f32, read_color};
pub use technique::{RenderStats, Support, Technique, check_scene};
pub use timer::{
    FrameTimings, GpuTimer, PASSES_PER_QUERY_SET, PassFragments, PassTimestamps, PassTiming,
    TimingSource, occlusion_counts_samples,
};
pub use work::{PassDraws, PassWork, Work};

/// Re-exported so technique crates use exactly the wgpu version this crate was built with.
pub use wgpu;
