//! Render-pass boilerplate: attachments and the pass itself, so a technique's pass reads as
//! what it loads, clears and stores.

/// A colour attachment that stores its result; `load` is `LoadOp::Load` or a clear colour.
pub fn color(
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load,
            store: wgpu::StoreOp::Store,
        },
    })
}

/// `wgpu::Color` with every channel `value` (clears of accumulators and depth-range targets).
pub fn splat(value: f64) -> wgpu::Color {
    wgpu::Color {
        r: value,
        g: value,
        b: value,
        a: value,
    }
}

/// A depth attachment (no stencil).
pub fn depth(
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<f32>,
    store: wgpu::StoreOp,
) -> Option<wgpu::RenderPassDepthStencilAttachment<'_>> {
    Some(wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations { load, store }),
        stencil_ops: None,
    })
}

/// Begins a render pass without occlusion queries or multiview; `timestamps` is
/// [`PassTimestamps::writes`](crate::PassTimestamps::writes) of the pass's timer entry.
pub fn begin<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    color_attachments: &[Option<wgpu::RenderPassColorAttachment<'_>>],
    depth_stencil_attachment: Option<wgpu::RenderPassDepthStencilAttachment<'_>>,
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments,
        depth_stencil_attachment,
        timestamp_writes: timestamps,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// One full-screen triangle (a [`crate::fullscreen_pipeline`]) over `view`, keeping what it
/// holds (`LoadOp::Load`), no depth: the composite passes every technique ends with. `groups`
/// are bound at 0, 1, … with their dynamic offsets.
pub fn fullscreen(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
    pipeline: &wgpu::RenderPipeline,
    groups: &[(&wgpu::BindGroup, &[u32])],
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
) {
    let mut pass = begin(
        encoder,
        label,
        &[color(view, wgpu::LoadOp::Load)],
        None,
        timestamps,
    );
    pass.set_pipeline(pipeline);
    for (i, (group, offsets)) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, *group, offsets);
    }
    pass.draw(0..3, 0..1);
}
