//! The one trait every transparency technique implements.

use crate::context::{Caps, Context};
use crate::error::{GpuError, Unsupported};
use crate::predict::{PixelLists, Prediction};
use crate::scene::GpuScene;
use crate::spec::TechniqueSpec;
use crate::targets::Targets;
use crate::timer::GpuTimer;
use oit_scene::{BlendOperator, Scene};

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
    /// The sizes `auto` parameters chose this frame from a count pass (`None` for fixed sizes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_sizes: Option<crate::AutoSizes>,
    /// Wall-clock milliseconds of GPU work done once per scene before its frames and kept
    /// across them (`ray-query`'s acceleration-structure build), apart from the frame's
    /// pass timings; `None` for techniques without such work.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub setup_ms: Option<f64>,
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
    /// `Err` with the reason (naming the format) when the technique cannot composite into a
    /// final colour target of `format` (e.g. it needs values outside a UNORM target's [0, 1]
    /// between passes); checked before a run builds anything. Every technique composites into
    /// the float formats; the default accepts every format.
    fn check_target(&self, format: wgpu::TextureFormat, caps: &Caps) -> Result<(), Unsupported> {
        let _ = (format, caps);
        Ok(())
    }
    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError>;
    /// Bytes of every texture and buffer the technique allocated (shared targets excluded).
    fn memory_bytes(&self) -> u64;
    /// What the technique does with coloured transmittance ([`Scene::has_transmission`]) on
    /// an adapter with `caps` (e.g. dual-source blending).
    fn transmission(&self, caps: &Caps) -> Support;
    /// How it composites fragments of a non-`over` [`BlendOperator`] on an adapter with `caps`
    /// (README "Blend operators"): `Exact` applies the operator's `(P, t)` per fragment as the
    /// reference does; `Approximate` says what it does instead (reported per run); `Unsupported`
    /// skips scenes that use the operator, with the reason.
    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support;
    /// What it does with render queues on a scene where they change the answer
    /// ([`Scene::has_queue_effects`], docs/scene-format.md "Render queues"): by default it
    /// composites by depth alone ([`crate::Queues::Ignored`]).
    fn queues(&self) -> crate::Queues {
        crate::Queues::Ignored
    }
    /// Whether this configuration is exact on `scene`, and why, from a model of what it does
    /// to each pixel's transparent list (`lists`, the exact reference's) on an adapter with
    /// `caps` ([`crate::predict`]). The harness checks it against the measured error of every
    /// run.
    fn predict(&self, scene: &Scene, lists: &PixelLists, caps: &Caps) -> Prediction;
    /// What each of its passes reads, writes and does atomically per fragment, stated from the
    /// formats it uses on an adapter with `caps` when the final target is `target` (results.json
    /// `counts`, with the
    /// occlusion counts of a counted frame). Every pass the technique registers with
    /// `timer.pass` has one entry; a pass without one is reported as undeclared (the default
    /// declares nothing, for test doubles).
    fn work(&self, caps: &crate::Caps, target: wgpu::TextureFormat) -> crate::work::Work {
        let _ = (caps, target);
        crate::work::Work::default()
    }
    /// Geometry passes one frame will make on a scene whose deepest pixel has
    /// `depth_complexity` transparent layers, for techniques whose pass count grows with it
    /// (depth peeling); `None` for the rest. The harness prices it before a run starts, so a
    /// run that could never finish within its budget is not started.
    fn planned_passes(&self, depth_complexity: u32) -> Option<u32> {
        let _ = depth_complexity;
        None
    }
}

/// How exactly a technique composites a kind of fragment: coloured transmittance (`t` per
/// channel rather than `1 − α`, README "Coloured transmission") or a blend operator (README
/// "Blend operators").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Support {
    /// Composites `C + t ⊙ behind` per channel as the reference does (up to its storage).
    Exact,
    /// Per channel, by the stated approximation.
    Approximate(&'static str),
    /// Scalar alpha only: skipped on scenes with transmission, for the stated reason.
    Unsupported(&'static str),
}

impl Support {
    /// The short word for tables: exact, approximate or no.
    pub fn label(self) -> &'static str {
        match self {
            Support::Exact => "exact",
            Support::Approximate(_) => "approximate",
            Support::Unsupported(_) => "no",
        }
    }
}

/// Whether `technique` can render `scene` on this adapter: its own [`Technique::check`], then,
/// on a scene with coloured transmission, its [`Support`].
pub fn check_scene(
    technique: &dyn Technique,
    caps: &Caps,
    scene: &Scene,
) -> Result<(), Unsupported> {
    technique.check(caps)?;
    for operator in scene.operators_used() {
        if let Support::Unsupported(reason) = technique.operator(operator, caps) {
            return Err(Unsupported::new(format!(
                "the scene blends with `{}`, which {} does not composite: {reason}",
                operator.name(),
                technique.spec().name()
            )));
        }
    }
    if scene.has_transmission()
        && let Support::Unsupported(reason) = technique.transmission(caps)
    {
        return Err(Unsupported::new(format!(
            "the scene has coloured transmission, which {} does not composite: {reason}",
            technique.spec().name()
        )));
    }
    Ok(())
}
