//! The floor: what one blended pass over a scene's transparent draws costs on this adapter.
//!
//! The pass draws the same transparent draws as `unsorted`, in draw order, over the same targets
//! with the same depth test and face culling, but with the cheapest fragment work there is: the
//! interpolated vertex colour, premultiplied, OVER-blended. No technique can blend every
//! transparent fragment once for less, so `cost × floor` says how far a technique is from that
//! limit, independent of how heavy the scene's geometry is. It is a measurement, not a
//! technique (its image ignores materials): the harness times it per scene.

use crate::blend::PREMULTIPLIED_OVER;
use crate::context::{Caps, Context};
use crate::error::{GpuError, Unsupported};
use crate::predict::{PixelLists, Prediction};
use crate::scene::{GpuScene, MaterialSource, ScenePipelineDesc, ScenePipelines, depth_test};
use crate::spec::TechniqueSpec;
use crate::targets::Targets;
use crate::technique::Support;
use crate::technique::{RenderStats, Technique};
use crate::timer::GpuTimer;

/// The name the floor goes by in reports.
pub const FLOOR_NAME: &str = "floor";

/// What a [`DrawOrderBlend`] pass computes per fragment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlendShading {
    /// Interpolated vertex colour, premultiplied (shaders/floor.wgsl): the floor.
    VertexColour,
    /// The material rule `shade()` (shaders/blend.wgsl `fs_blend`): what `unsorted` draws, for
    /// tests and examples that cannot depend on the technique crates.
    Material,
}

/// One premultiplied-OVER pass over the transparent draws in draw order, after the shared
/// opaque pass, as a [`Technique`] so that it is timed exactly like one. Not in any registry.
#[derive(Debug)]
pub struct DrawOrderBlend {
    shading: BlendShading,
    pipelines: Option<((wgpu::TextureFormat, bool), ScenePipelines)>,
}

/// The floor (see the module docs).
pub type Floor = DrawOrderBlend;

impl DrawOrderBlend {
    /// The floor: vertex colour only.
    pub fn new() -> Self {
        Self::with(BlendShading::VertexColour)
    }

    pub fn with(shading: BlendShading) -> Self {
        DrawOrderBlend {
            shading,
            pipelines: None,
        }
    }
}

impl Default for DrawOrderBlend {
    fn default() -> Self {
        Self::new()
    }
}

impl Technique for DrawOrderBlend {
    fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of(match self.shading {
            BlendShading::VertexColour => FLOOR_NAME,
            BlendShading::Material => "blend-in-draw-order",
        })
    }

    fn check(&self, _caps: &Caps) -> Result<(), Unsupported> {
        Ok(())
    }

    fn predict(&self, _scene: &oit_scene::Scene, lists: &PixelLists, _caps: &Caps) -> Prediction {
        match self.shading {
            BlendShading::VertexColour => Prediction::unmodelled(
                "the floor is a cost yardstick: its image is vertex colour, not the materials",
            ),
            BlendShading::Material => crate::predict::predict_draw_order(lists),
        }
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        let key = (targets.color_format, scene.scene.camera.reverse_z);
        if self.pipelines.as_ref().is_none_or(|(k, _)| *k != key) {
            let (module, vertex_entry, fragment_entry) = match self.shading {
                BlendShading::VertexColour => (
                    ctx.shader("floor.wgsl", crate::shaders::FLOOR)?,
                    "vs_floor",
                    "fs_floor",
                ),
                BlendShading::Material => (
                    ctx.shader("blend.wgsl", crate::shaders::BLEND)?,
                    "vs_main",
                    "fs_blend",
                ),
            };
            let color = [Some(wgpu::ColorTargetState {
                format: targets.color_format,
                blend: Some(PREMULTIPLIED_OVER),
                write_mask: wgpu::ColorWrites::ALL,
            })];
            let desc = ScenePipelineDesc {
                vertex_entry,
                // The floor's own vertex stage carries no material.
                material: match self.shading {
                    BlendShading::VertexColour => MaterialSource::PerVertex,
                    BlendShading::Material => MaterialSource::PerDraw,
                },
                targets: &color,
                depth: Some(depth_test(scene.depth_nearer(), false)),
                ..ScenePipelineDesc::new("draw-order blend", &module, fragment_entry)
            };
            self.pipelines = Some((key, ScenePipelines::new(ctx, &desc)));
        }
        let (_, pipelines) = self.pipelines.as_ref().expect("built above");
        let label = match self.shading {
            BlendShading::VertexColour => FLOOR_NAME,
            BlendShading::Material => "blend",
        };
        let ts = timer.pass(label);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = crate::pass::begin(
                &mut encoder,
                label,
                &[crate::pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                crate::pass::depth(
                    &targets.depth_view,
                    wgpu::LoadOp::Load,
                    wgpu::StoreOp::Store,
                ),
                &ts,
            );
            scene.bind(&mut pass);
            for i in scene.transparent_draws() {
                scene.draw(&mut pass, pipelines, i);
            }
        }
        timer.submit(ctx, encoder)?;
        Ok(RenderStats {
            geometry_passes: 1,
            ..Default::default()
        })
    }

    fn memory_bytes(&self) -> u64 {
        0
    }

    fn work(&self, _caps: &crate::Caps, target: wgpu::TextureFormat) -> crate::work::Work {
        use crate::work::{DEPTH_BYTES, PassDraws, PassWork, Work, blend};
        let label = match self.shading {
            BlendShading::VertexColour => FLOOR_NAME,
            BlendShading::Material => "blend",
        };
        let (dst_read, dst_written) = blend(target);
        // The depth test reads the opaque depth (no write); the blend reads and writes the
        // target texel.
        Work::new(vec![
            PassWork::new(label, PassDraws::Transparent).bytes(DEPTH_BYTES + dst_read, dst_written),
        ])
    }

    fn transmission(&self, _caps: &Caps) -> Support {
        // Runs on every scene: it is a timing yardstick whose image is never compared.
        Support::Approximate("a timing yardstick: vertex colour and scalar OVER")
    }

    fn operator(&self, _operator: oit_scene::BlendOperator, _caps: &Caps) -> Support {
        Support::Approximate("a timing yardstick: vertex colour and scalar OVER")
    }
}
