//! Sizing from a count: how many transparent fragments a stored-fragment technique will have to
//! hold, counted on the GPU before it builds its storage (`k-buffer:k=auto`,
//! `linked-list:nodes-per-pixel=auto,sort-max=auto`). The conformance twin
//! ([`crate::count_fragments`]) counts every fragment with no depth test and reads every pixel
//! back; this pass counts what an insert pass stores and reads back 16 bytes.

use crate::context::Context;
use crate::error::GpuError;
use crate::memory::MemoryLedger;
use crate::scene::{GpuScene, ScenePipelineDesc, ScenePipelines};
use crate::targets::Targets;
use crate::timer::GpuTimer;
use oit_scene::Resolution;

/// What a count pass found: the transparent fragments strictly in front of the opaque surface
/// that survive culling and the mask cutoff, which is what an insert pass stores.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct LayerCount {
    /// All pixels together.
    pub fragments: u64,
    /// The deepest pixel's.
    pub max_per_pixel: u32,
}

/// The sizes a technique chose for its `auto` parameters in one frame, from a [`LayerCount`],
/// and what they cost (results.json `stats.auto_sizes`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct AutoSizes {
    pub count: LayerCount,
    /// `k-buffer:k=auto`: slots per pixel.
    pub k: Option<u32>,
    /// `linked-list:nodes-per-pixel=auto`: nodes in the pool.
    pub pool_nodes: Option<u64>,
    /// `linked-list:sort-max=auto`: fragments sorted per pixel.
    pub sort_max: Option<u32>,
    /// Bytes of the storage these sizes set (the k-buffer's slots, the list's node pool).
    pub sized_bytes: u64,
    /// Bytes the count pass keeps (a u32 per pixel, its parameters and summary).
    pub count_bytes: u64,
}

/// `bytes` in MiB with one decimal, as refusals state sizes.
pub fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / f64::from(1u32 << 20))
}

/// The count pass of one technique, built on first use and kept for the resolution and final
/// colour format it was built for.
#[derive(Debug, Default)]
pub struct LayerCounter {
    gpu: Option<Resources>,
    ledger: MemoryLedger,
}

#[derive(Debug)]
struct Resources {
    key: (Resolution, wgpu::TextureFormat),
    params: wgpu::Buffer,
    counts: wgpu::Buffer,
    summary: wgpu::Buffer,
    readback: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    pipelines: ScenePipelines,
}

impl LayerCounter {
    pub fn new() -> Self {
        Self::default()
    }

    /// Bytes of every buffer the counter allocated (0 before its first count).
    pub fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    /// The per-pixel counts the last [`LayerCounter::count`] left on the GPU (a u32 per pixel,
    /// row by row; storage and copy source), for a technique that builds on them, such as the
    /// prefix-sum A-buffer's scan. `None` before the first count.
    pub fn counts(&self) -> Option<&wgpu::Buffer> {
        self.gpu.as_ref().map(|g| &g.counts)
    }

    fn resources(&mut self, ctx: &Context, targets: &Targets) -> Result<&Resources, GpuError> {
        let key = (targets.resolution, targets.color_format);
        if !self.gpu.as_ref().is_some_and(|g| g.key == key) {
            self.gpu = None;
            self.ledger.clear();
            self.gpu = Some(build(ctx, targets, &mut self.ledger)?);
        }
        self.gpu
            .as_ref()
            .ok_or_else(|| GpuError::Mismatch("layer counter: resources not built".into()))
    }
}

/// The count pass's buffers and pipelines for `targets`, or why the adapter cannot hold them.
fn build(
    ctx: &Context,
    targets: &Targets,
    ledger: &mut MemoryLedger,
) -> Result<Resources, GpuError> {
    let key = (targets.resolution, targets.color_format);
    let pixels = targets.resolution.pixel_count() as u64;
    let count_bytes = pixels * 4;
    let limit = ctx
        .caps
        .max_storage_buffer_binding_size
        .min(ctx.caps.max_buffer_size);
    if count_bytes > limit {
        return Err(GpuError::TooLarge {
            what: format!("the per-pixel fragment counts ({pixels} px × 4 B)"),
            needed: count_bytes,
            limit,
        });
    }
    let device = &ctx.device;
    let mut buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
        ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            },
        )
    };
    let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
    let params = buffer(
        "layer count params",
        16,
        wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    );
    let counts = buffer(
        "layer counts",
        count_bytes,
        storage | wgpu::BufferUsages::COPY_SRC,
    );
    let summary = buffer(
        "layer count summary",
        16,
        storage | wgpu::BufferUsages::COPY_SRC,
    );
    let readback = buffer(
        "layer count readback",
        16,
        wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
    );
    let fragment = wgpu::ShaderStages::FRAGMENT;
    let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("layer count"),
        entries: &[
            crate::bind::uniform(0, fragment),
            crate::bind::storage(1, fragment, false),
            crate::bind::storage(2, fragment, false),
            crate::bind::float_texture(3, fragment),
        ],
    });
    let module = ctx.shader("count_layers.wgsl", crate::shaders::COUNT_LAYERS)?;
    let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("layer count"),
        bind_group_layouts: &[Some(ctx.scene_layout()), Some(&layout)],
        immediate_size: 0,
    });
    // The pass needs an attachment; nothing is written to it.
    let untouched = [Some(wgpu::ColorTargetState {
        format: targets.color_format,
        blend: None,
        write_mask: wgpu::ColorWrites::empty(),
    })];
    let pipelines = ScenePipelines::with_layout(
        ctx,
        &ScenePipelineDesc {
            targets: &untouched,
            ..ScenePipelineDesc::new("layer count", &module, "fs_count_layers")
        },
        &pipeline_layout,
    );
    Ok(Resources {
        key,
        params,
        counts,
        summary,
        readback,
        layout,
        pipelines,
    })
}

impl LayerCounter {
    /// Counts the transparent fragments of `scene` in front of the opaque depth already in
    /// `targets`: one geometry pass registered with `timer` as `"{label} count"` and submitted
    /// through it, then a wait for its 16-byte summary (the GPU idles while the CPU reads it;
    /// that gap is in the frame's wall time, not in its GPU passes).
    pub fn count(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
        label: &str,
    ) -> Result<LayerCount, GpuError> {
        let r = self.resources(ctx, targets)?;
        let words: [u32; 4] = [
            targets.resolution.width,
            u32::from(scene.scene.camera.reverse_z),
            0,
            0,
        ];
        ctx.queue
            .write_buffer(&r.params, 0, bytemuck::cast_slice(&words));
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("layer count"),
            layout: &r.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: r.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: r.counts.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: r.summary.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&targets.depth_view),
                },
            ],
        });
        let name = format!("{label} count");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&r.counts, 0, None);
        encoder.clear_buffer(&r.summary, 0, None);
        {
            let ts = timer.pass(&name);
            let mut p = crate::pass::begin(
                &mut encoder,
                &name,
                &[crate::pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                None,
                &ts,
            );
            scene.bind(&mut p);
            p.set_bind_group(1, &group, &[]);
            for i in scene.transparent_draws() {
                scene.draw(&mut p, &r.pipelines, i);
            }
        }
        encoder.copy_buffer_to_buffer(&r.summary, 0, &r.readback, 0, 16);
        timer.submit(ctx, encoder)?;
        let s = crate::readback::read_buffer_u32(ctx, &r.readback, &name)?;
        let word = |i: usize| s.get(i).copied().unwrap_or(0);
        Ok(LayerCount {
            fragments: u64::from(word(2)) << 32 | u64::from(word(1)),
            max_per_pixel: word(0),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mib_has_one_decimal() {
        assert_eq!(mib(128 << 20), "128.0 MiB");
        assert_eq!(mib(3 << 19), "1.5 MiB");
        assert_eq!(mib(0), "0.0 MiB");
    }
}
