//! Render-pass boilerplate: attachments and the pass itself, so a technique's pass reads as
//! what it loads, clears and stores.

use crate::timer::PassTimestamps;

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

/// A render pass begun by [`begin`]: derefs to the `wgpu::RenderPass`, and on drop ends the
/// pass's occlusion query (wgpu refuses a pass that ends with one still open).
#[derive(Debug)]
pub struct CountedPass<'e> {
    pass: wgpu::RenderPass<'e>,
    counting: bool,
}

impl<'e> std::ops::Deref for CountedPass<'e> {
    type Target = wgpu::RenderPass<'e>;
    fn deref(&self) -> &Self::Target {
        &self.pass
    }
}

impl std::ops::DerefMut for CountedPass<'_> {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.pass
    }
}

impl Drop for CountedPass<'_> {
    fn drop(&mut self) {
        if self.counting {
            self.pass.end_occlusion_query();
        }
    }
}

/// Begins a render pass with the timestamp writes of `timer_entry` (the pass's
/// [`GpuTimer::pass`](crate::GpuTimer::pass)) and, on a counting timer, its occlusion query
/// around everything the pass draws; [`PassTimestamps::untimed`] for neither. No multiview.
pub fn begin<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    color_attachments: &[Option<wgpu::RenderPassColorAttachment<'_>>],
    depth_stencil_attachment: Option<wgpu::RenderPassDepthStencilAttachment<'_>>,
    timer_entry: &PassTimestamps,
) -> CountedPass<'e> {
    begin_with(
        encoder,
        wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments,
            depth_stencil_attachment,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        },
        timer_entry,
    )
}

/// [`begin`] for a pass that needs its own descriptor (store ops other than `Store`): its
/// `timestamp_writes` and `occlusion_query_set` are replaced by `timer_entry`'s.
pub fn begin_with<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    descriptor: wgpu::RenderPassDescriptor<'_>,
    timer_entry: &PassTimestamps,
) -> CountedPass<'e> {
    let occlusion = timer_entry.begin_occlusion();
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        timestamp_writes: timer_entry.writes(),
        occlusion_query_set: occlusion.map(|(set, _)| set),
        ..descriptor
    });
    if let Some((_, index)) = occlusion {
        pass.begin_occlusion_query(index);
    }
    CountedPass {
        pass,
        counting: occlusion.is_some(),
    }
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
    timer_entry: &PassTimestamps,
) {
    let mut pass = begin(
        encoder,
        label,
        &[color(view, wgpu::LoadOp::Load)],
        None,
        timer_entry,
    );
    pass.set_pipeline(pipeline);
    for (i, (group, offsets)) in groups.iter().enumerate() {
        pass.set_bind_group(i as u32, *group, offsets);
    }
    pass.draw(0..3, 0..1);
}
