//! Additive and subtractive fragments (`BlendOperator::Add`/`Subtract`: `P`, α = 0, t = 1) in
//! `wboit` and `weighted-average`: left out of the accumulation pass and drawn after the
//! composite, each adding `P` times the visibility the composite gives an over layer at its
//! depth (`fs_additive` in shaders/wboit_accum.wgsl). Scenes without these operators never
//! build or run this pass.

use crate::tail::AccumTargets;
use oit_gpu::wgpu;
use oit_gpu::{
    Context, GpuScene, ScenePipelineDesc, ScenePipelines, Targets, bind, blend, depth_test, pass,
};

/// Whether draw `i` of `scene` adds or subtracts its colour (no coverage of its own).
pub(crate) fn is_additive(scene: &GpuScene, i: usize) -> bool {
    let s = &scene.scene;
    s.material_of(&s.draws[i]).operator.is_additive()
}

/// The pass's pipeline for one final colour format and depth direction, and the group that
/// binds the accumulation and revealage targets it reads.
#[derive(Debug)]
pub(crate) struct AdditivePass {
    key: (wgpu::TextureFormat, bool),
    pipelines: ScenePipelines,
    layout: wgpu::BindGroupLayout,
    group: wgpu::BindGroup,
}

impl AdditivePass {
    /// `params_layout`: the weight parameters' group (group 1 of the accumulation pass).
    pub(crate) fn new(
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        params_layout: &wgpu::BindGroupLayout,
        accum: &AccumTargets,
    ) -> Result<Self, oit_gpu::GpuError> {
        let fs = wgpu::ShaderStages::FRAGMENT;
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wboit additive"),
            entries: &[bind::float_texture(0, fs), bind::float_texture(1, fs)],
        });
        let module = ctx.shader_with(
            "wboit_accum.wgsl",
            crate::technique::ACCUM_WGSL,
            &[crate::SHADERS],
        )?;
        let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wboit additive"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(params_layout), Some(&layout)],
            immediate_size: 0,
        });
        let pipelines = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &[Some(wgpu::ColorTargetState {
                    format: targets.color_format,
                    blend: Some(blend::ADDITIVE),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: Some(depth_test(scene.depth_nearer(), false)),
                ..ScenePipelineDesc::new("wboit additive", &module, "fs_additive")
            },
            &pipeline_layout,
        );
        let group = Self::group(ctx, &layout, accum);
        Ok(AdditivePass {
            key: (targets.color_format, scene.scene.camera.reverse_z),
            pipelines,
            layout,
            group,
        })
    }

    fn group(
        ctx: &Context,
        layout: &wgpu::BindGroupLayout,
        accum: &AccumTargets,
    ) -> wgpu::BindGroup {
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wboit additive"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&accum.accum_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&accum.reveal_view),
                },
            ],
        })
    }

    /// Whether this pass was built for `targets`' format and `scene`'s depth direction.
    pub(crate) fn fits(&self, scene: &GpuScene, targets: &Targets) -> bool {
        self.key == (targets.color_format, scene.scene.camera.reverse_z)
    }

    /// Rebinds the targets (they are rebuilt when the resolution changes).
    pub(crate) fn rebind(&mut self, ctx: &Context, accum: &AccumTargets) {
        self.group = Self::group(ctx, &self.layout, accum);
    }

    /// Draws `draws` (the additive ones) over the composited final colour.
    pub(crate) fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        targets: &Targets,
        params_group: &wgpu::BindGroup,
        draws: &[usize],
        ts: &oit_gpu::PassTimestamps,
    ) {
        let attachments = [pass::color(&targets.color_view, wgpu::LoadOp::Load)];
        let mut p = pass::begin(
            encoder,
            "wboit additive",
            &attachments,
            pass::depth(
                &targets.depth_view,
                wgpu::LoadOp::Load,
                wgpu::StoreOp::Store,
            ),
            ts,
        );
        scene.bind(&mut p);
        p.set_bind_group(1, params_group, &[]);
        p.set_bind_group(2, &self.group, &[]);
        for &i in draws {
            scene.draw(&mut p, &self.pipelines, i);
        }
    }
}

/// The pass's declared work (runs only on scenes with additive or subtractive draws): per
/// fragment the depth test, the accumulation and revealage texels loaded, and the final texel
/// read and written by its additive blend.
pub(crate) fn work(
    accum: crate::tail::AccumFormat,
    reveal: crate::tail::RevealFormat,
    target: wgpu::TextureFormat,
) -> oit_gpu::PassWork {
    use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, texel_bytes};
    let read = texel_bytes(accum.texture_format()) + texel_bytes(reveal.texture_format());
    let final_texel = texel_bytes(target);
    PassWork::new("wboit additive", PassDraws::Additive)
        .bytes(DEPTH_BYTES + read + final_texel, final_texel)
}
