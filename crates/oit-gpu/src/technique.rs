//! The one trait every transparency technique implements.

use crate::context::{Caps, Context};
use crate::error::{GpuError, Unsupported};
use crate::scene::GpuScene;
use crate::spec::TechniqueSpec;
use crate::targets::Targets;
use crate::timer::GpuTimer;

/// What a technique did in one frame (results.json `"stats"`, plus `cpu_ms` which the harness
/// reports at the top level of a run).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct RenderStats {
    /// Passes that rasterize scene geometry (the opaque pass not counted).
    pub geometry_passes: u32,
    /// CPU work of the frame, such as sorting, in milliseconds.
    pub cpu_ms: f64,
    /// Layers extracted by peeling techniques (0 for others).
    pub layers_peeled: u64,
    /// Pixels where a bounded technique dropped at least one transparent layer.
    pub pixels_with_dropped_layers: u64,
    /// Pixels where a bounded technique composited some layers by an approximate rule (e.g. a
    /// linked list's averaged tail behind its sort window) instead of dropping them.
    pub pixels_with_approximated_layers: u64,
}

/// A transparency technique. It renders the transparent draws of a [`GpuScene`] over the opaque
/// pass already in `targets` (colour and depth), with every GPU submission going through
/// `timer.submit` and every pass registered with `timer.pass`.
///
/// GPU resources are created lazily on the first `render` (a technique is built from its spec
/// without a device) and cached; `memory_bytes` counts them exactly.
pub trait Technique: std::fmt::Debug {
    /// The canonical configuration (defaults filled in).
    fn spec(&self) -> TechniqueSpec;
    /// `Err` with the reason when this adapter cannot run the technique.
    fn check(&self, caps: &Caps) -> Result<(), Unsupported>;
    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError>;
    /// Bytes of every texture and buffer the technique allocated (shared targets excluded).
    fn memory_bytes(&self) -> u64;
}
