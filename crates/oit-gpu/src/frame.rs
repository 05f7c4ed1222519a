//! One frame: the shared opaque pass, then a technique.

use crate::context::Context;
use crate::error::GpuError;
use crate::scene::GpuScene;
use crate::targets::Targets;
use crate::technique::{RenderStats, Technique};
use crate::timer::{FrameTimings, GpuTimer};

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrameResult {
    pub stats: RenderStats,
    pub timings: FrameTimings,
}

/// Renders one frame into `targets`: checks the technique against the adapter, clears colour
/// to `scene.background` and depth to the far plane, draws the opaque and mask draws (pass
/// "opaque"), then lets the technique composite the transparent draws. Read the result with
/// [`crate::read_color`].
pub fn render_frame(
    ctx: &Context,
    scene: &GpuScene,
    technique: &mut dyn Technique,
    targets: &Targets,
    timer: &mut GpuTimer,
) -> Result<FrameResult, GpuError> {
    if targets.resolution != scene.scene.resolution {
        return Err(GpuError::Mismatch(format!(
            "targets are {} but scene {:?} is {}",
            targets.resolution, scene.scene.name, scene.scene.resolution
        )));
    }
    crate::technique::check_scene(technique, &ctx.caps, &scene.scene)?;
    timer.begin_frame();
    opaque_pass(ctx, scene, targets, timer)?;
    let stats = technique.render(ctx, scene, targets, timer)?;
    let timings = timer.end_frame(ctx)?;
    Ok(FrameResult { stats, timings })
}

/// The shared opaque pass (also usable on its own, e.g. to render only the occluders).
pub fn opaque_pass(
    ctx: &Context,
    scene: &GpuScene,
    targets: &Targets,
    timer: &mut GpuTimer,
) -> Result<(), GpuError> {
    let pipelines = scene.opaque_pipelines(ctx, targets.color_format)?;
    let [r, g, b] = scene.scene.background.map(f64::from);
    let ts = timer.pass("opaque");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    {
        let mut pass = crate::pass::begin(
            &mut encoder,
            "opaque",
            &[crate::pass::color(
                &targets.color_view,
                wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }),
            )],
            crate::pass::depth(
                &targets.depth_view,
                wgpu::LoadOp::Clear(scene.scene.camera.far_depth()),
                wgpu::StoreOp::Store,
            ),
            &ts,
        );
        scene.bind(&mut pass);
        for i in scene.opaque_draws() {
            scene.draw(&mut pass, &pipelines, i);
        }
    }
    timer.submit(ctx, encoder)
}
