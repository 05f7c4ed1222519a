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
use crate::scene::{GpuScene, ScenePipelineDesc, ScenePipelines, depth_test};
use crate::spec::TechniqueSpec;
use crate::targets::Targets;
use crate::technique::{RenderStats, Technique};
use crate::timer::GpuTimer;

/// The name the floor goes by in reports.
pub const FLOOR_NAME: &str = "floor";

/// The floor pass, as a [`Technique`] so that it is timed exactly like one (opaque pass
/// included). Not in any registry.
#[derive(Debug, Default)]
pub struct Floor {
    pipelines: Option<((wgpu::TextureFormat, bool), ScenePipelines)>,
}

impl Floor {
    pub fn new() -> Self {
        Self::default()
    }
}

impl Technique for Floor {
    fn spec(&self) -> TechniqueSpec {
        TechniqueSpec {
            name: FLOOR_NAME.to_owned(),
            params: Default::default(),
        }
    }

    fn check(&self, _caps: &Caps) -> Result<(), Unsupported> {
        Ok(())
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
            let module = ctx.shader("floor.wgsl", crate::shaders::FLOOR)?;
            let color = [Some(wgpu::ColorTargetState {
                format: targets.color_format,
                blend: Some(PREMULTIPLIED_OVER),
                write_mask: wgpu::ColorWrites::ALL,
            })];
            let desc = ScenePipelineDesc {
                vertex_entry: "vs_floor",
                targets: &color,
                depth: Some(depth_test(scene.depth_nearer(), false)),
                ..ScenePipelineDesc::new("floor", &module, "fs_floor")
            };
            self.pipelines = Some((key, ScenePipelines::new(ctx, &desc)));
        }
        let (_, pipelines) = self.pipelines.as_ref().expect("built above");
        let ts = timer.pass("floor");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = crate::pass::begin(
                &mut encoder,
                "floor",
                &[crate::pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                crate::pass::depth(
                    &targets.depth_view,
                    wgpu::LoadOp::Load,
                    wgpu::StoreOp::Store,
                ),
                ts.writes(),
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
}
