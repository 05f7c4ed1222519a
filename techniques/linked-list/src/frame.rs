//! What both techniques of the crate share around their own passes: the per-frame counters the
//! resolve writes (and their readback), and the resolve pass itself.

use oit_gpu::wgpu;
use oit_gpu::{
    Context, GpuError, GpuScene, GpuTimer, MemoryLedger, Targets, pass, read_buffer_u32,
};

/// Four u32 counters in a storage buffer, cleared every frame, read back after it.
#[derive(Debug)]
pub(crate) struct Counters {
    pub(crate) buffer: wgpu::Buffer,
    readback: wgpu::Buffer,
    label: &'static str,
}

impl Counters {
    pub(crate) fn new(ctx: &Context, ledger: &mut MemoryLedger, label: &'static str) -> Self {
        let mut make = |name: String, usage| {
            ledger.create_buffer(
                &ctx.device,
                &wgpu::BufferDescriptor {
                    label: Some(&name),
                    size: 16,
                    usage,
                    mapped_at_creation: false,
                },
            )
        };
        Counters {
            buffer: make(
                format!("{label} counters"),
                wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC,
            ),
            readback: make(
                format!("{label} counters readback"),
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
            label,
        }
    }

    pub(crate) fn clear(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.buffer, 0, None);
    }

    /// Records the full-screen `resolve` over the final colour (scene group 0, `group` 1), then
    /// submits the frame and returns the counters it left.
    #[allow(
        clippy::too_many_arguments,
        reason = "one call per technique, all distinct"
    )]
    pub(crate) fn resolve_and_read(
        &self,
        ctx: &Context,
        mut encoder: wgpu::CommandEncoder,
        timer: &mut GpuTimer,
        scene: &GpuScene,
        targets: &Targets,
        resolve: &wgpu::RenderPipeline,
        group: &wgpu::BindGroup,
    ) -> Result<[u32; 4], GpuError> {
        let name = format!("{} resolve", self.label);
        let ts = timer.pass(&name);
        pass::fullscreen(
            &mut encoder,
            &name,
            &targets.color_view,
            resolve,
            &[(&scene.bind_group, &[0]), (group, &[])],
            &ts,
        );
        encoder.copy_buffer_to_buffer(&self.buffer, 0, &self.readback, 0, 16);
        timer.submit(ctx, encoder)?;
        let c = read_buffer_u32(ctx, &self.readback, &format!("{} counters", self.label))?;
        Ok([c[0], c[1], c[2], c[3]])
    }
}
