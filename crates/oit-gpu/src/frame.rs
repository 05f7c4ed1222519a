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
    technique.check(&ctx.caps)?;
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
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("opaque"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &targets.color_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(scene.scene.camera.far_depth()),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: ts.writes(),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        scene.bind(&mut pass);
        for i in scene.opaque_draws() {
            scene.draw(&mut pass, &pipelines, i);
        }
    }
    timer.submit(ctx, encoder)
}
