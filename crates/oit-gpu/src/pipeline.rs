//! Full-screen passes: one triangle covering the target, no vertex buffers (composites,
//! copies, resolves).

use crate::context::Context;

/// Everything that differs between full-screen pipelines. The module must define
/// `vs_fullscreen` (vertex index 0..3 to a triangle covering clip space).
#[derive(Debug)]
pub struct FullscreenDesc<'a> {
    pub label: &'a str,
    pub layout: &'a wgpu::PipelineLayout,
    pub module: &'a wgpu::ShaderModule,
    pub fragment_entry: &'a str,
    pub targets: &'a [Option<wgpu::ColorTargetState>],
    /// `None` for passes without a depth attachment.
    pub depth: Option<wgpu::DepthStencilState>,
    /// Must match the attachments' sample count.
    pub multisample: wgpu::MultisampleState,
    /// The shader's pipeline override constants (both stages get them).
    pub constants: &'a [(&'a str, f64)],
}

/// A full-screen triangle pipeline (draw it with `pass.draw(0..3, 0..1)`). No culling, so the
/// shader's winding does not matter.
pub fn fullscreen_pipeline(ctx: &Context, desc: &FullscreenDesc<'_>) -> wgpu::RenderPipeline {
    let options = wgpu::PipelineCompilationOptions {
        constants: desc.constants,
        ..Default::default()
    };
    ctx.render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(desc.label),
        layout: Some(desc.layout),
        vertex: wgpu::VertexState {
            module: desc.module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: options.clone(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: desc.depth.clone(),
        multisample: desc.multisample,
        fragment: Some(wgpu::FragmentState {
            module: desc.module,
            entry_point: Some(desc.fragment_entry),
            compilation_options: options,
            targets: desc.targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}
