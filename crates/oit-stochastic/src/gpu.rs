//! Resource helpers shared by the two techniques: draw order and instance ids, bind group
//! entries, and the seed pass.

use oit_gpu::bind;
use oit_gpu::wgpu;
use oit_gpu::{Context, GpuError, GpuScene, ScenePipelines};

/// The scene's transparent draws in REVERSE draw order: with a strictly-nearer depth test the
/// first survivor at a depth keeps it, so among exactly coplanar survivors the later draw wins,
/// which is the reference's tie rule.
pub(crate) fn reversed_transparent_draws(scene: &GpuScene) -> Vec<usize> {
    let mut order = scene.transparent_draws();
    order.reverse();
    order
}

/// Draws one scene draw as instance `draw.id` (the vertex stage reads it as the object seed).
pub(crate) fn draw_with_id(
    pass: &mut wgpu::RenderPass<'_>,
    scene: &GpuScene,
    pipelines: &ScenePipelines,
    index: usize,
) {
    let d = &scene.scene.draws[index];
    if d.vertex_count == 0 {
        return;
    }
    scene.use_draw(pass, pipelines, index);
    pass.draw(
        d.first_vertex..d.first_vertex + d.vertex_count,
        d.id..d.id + 1,
    );
}

/// WGSL of the fullscreen pass that copies the opaque pass's colour and depth into other
/// targets (the multisampled ones of `a2c`, the per-frame ones of `stochastic:spp=N`).
pub const SEED_WGSL: &str = include_str!("../../../shaders/stochastic_seed.wgsl");

/// A fullscreen pass writing the opaque colour and depth (read from the final targets) into
/// other targets. A draw rather than `copy_texture_to_texture`: wgpu's GL backend leaves a
/// depth copy undone without an error.
#[derive(Debug)]
pub(crate) struct SeedPass {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    /// The same copy of the depth alone (colour writes off), when asked for
    /// ([`SeedPass::with_depth_reset`]).
    depth_reset: Option<wgpu::RenderPipeline>,
}

impl SeedPass {
    pub fn new(
        ctx: &Context,
        color_format: wgpu::TextureFormat,
        multisample: wgpu::MultisampleState,
    ) -> Result<Self, GpuError> {
        Self::build(ctx, color_format, multisample, false)
    }

    /// [`SeedPass::new`] plus the depth-only copy of [`SeedPass::draw_depth_reset`].
    pub fn with_depth_reset(
        ctx: &Context,
        color_format: wgpu::TextureFormat,
    ) -> Result<Self, GpuError> {
        Self::build(ctx, color_format, Default::default(), true)
    }

    fn build(
        ctx: &Context,
        color_format: wgpu::TextureFormat,
        multisample: wgpu::MultisampleState,
        depth_reset: bool,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        // Depth32Float is bound as an unfilterable float texture (WebGPU allows it): GLSL has
        // no texelFetch of depth (shadow) textures.
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stochastic seed"),
            entries: &[
                bind::float_texture(0, wgpu::ShaderStages::FRAGMENT),
                bind::float_texture(1, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let module = ctx.shader("stochastic_seed.wgsl", SEED_WGSL)?;
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("stochastic seed"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let seed = |label, write_mask| {
            oit_gpu::fullscreen_pipeline(
                ctx,
                &oit_gpu::FullscreenDesc {
                    label,
                    layout: &pipeline_layout,
                    module: &module,
                    fragment_entry: "fs_seed",
                    targets: &[Some(wgpu::ColorTargetState {
                        format: color_format,
                        blend: None,
                        write_mask,
                    })],
                    depth: Some(oit_gpu::depth_test(wgpu::CompareFunction::Always, true)),
                    multisample,
                },
            )
        };
        let pipeline = seed("stochastic seed", wgpu::ColorWrites::ALL);
        let depth_reset =
            depth_reset.then(|| seed("stochastic depth reset", wgpu::ColorWrites::empty()));
        Ok(SeedPass {
            layout,
            pipeline,
            depth_reset,
        })
    }

    /// Puts the opaque depth back and leaves the colour as it is (between the per-channel
    /// dither passes of coloured transmission). Needs a pass built `with_depth_reset`.
    pub fn draw_depth_reset(&self, pass: &mut wgpu::RenderPass<'_>, bind_group: &wgpu::BindGroup) {
        let pipeline = self
            .depth_reset
            .as_ref()
            .expect("SeedPass built with_depth_reset");
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.draw(0..3, 0..1);
    }

    /// The bind group reading `targets` (made per frame: targets are the caller's).
    pub fn bind_group(&self, ctx: &Context, targets: &oit_gpu::Targets) -> wgpu::BindGroup {
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("stochastic seed"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&targets.color_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&targets.depth_view),
                },
            ],
        })
    }

    /// Draws the copy into the pass's attachments (which must be those it was built for).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, bind_group: &wgpu::BindGroup) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}
