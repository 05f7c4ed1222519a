//! One scene's trouble stays in that scene: its GPU errors and panics are contained
//! ([`oit_gpu::Context::contain`]), the GPU resources it dropped are released before the next
//! scene starts (the context keeps its modules and pipelines for the next techniques:
//! `oit_gpu::Context::made_objects`), and its peak memory is recorded.

use oit_gpu::{ContainedError, Context};
use oit_results::Results;

use crate::HarnessError;
use crate::peak::ScenePeak;

/// `work` with the device's errors and panics returned as errors; `what` says what stopped
/// ("the scene", "the run").
pub(crate) fn contained<T>(
    ctx: &Context,
    what: &str,
    work: impl FnOnce() -> Result<T, HarnessError>,
) -> Result<T, HarnessError> {
    ctx.contain(what, work).map_err(ContainedError::into_inner)
}

/// The end of a scene, finished or failed: waits for the GPU so that wgpu frees what the
/// scene's uploads, targets and techniques held (it frees dropped resources only when it
/// polls, and the next scene computes its reference before touching the GPU), then records
/// the scene's peak in its entry of `results.scenes` (the last one).
pub(crate) fn finish_scene(ctx: &Context, results: &mut Results, peak: ScenePeak) {
    // A device that cannot even wait fails the next scene with its own error.
    let _ = ctx.wait();
    if let Some(entry) = results.scenes.last_mut() {
        entry.peak_memory_bytes = peak.finish();
    }
}
