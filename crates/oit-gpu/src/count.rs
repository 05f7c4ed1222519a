//! Rasterization conformance: fragments per pixel, counted on the GPU.

use crate::context::Context;
use crate::error::GpuError;
use crate::scene::{GpuScene, ScenePipelineDesc, ScenePipelines, depth_test};

/// Counts per pixel (row-major, top-left origin) every fragment of every draw, opaque and
/// transparent, that survives face culling and the mask cutoff, with no depth test: the GPU
/// twin of `Reference::fragments`. Counts are exact (atomic u32 in a storage buffer).
pub fn count_fragments(ctx: &Context, scene: &GpuScene) -> Result<Vec<u32>, GpuError> {
    let res = scene.scene.resolution;
    let pixels = res.pixel_count() as u64;
    let device = &ctx.device;
    let module = ctx.shader("count_fragments.wgsl", crate::shaders::COUNT_FRAGMENTS)?;
    let target_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("count target"),
        entries: &[
            crate::bind::uniform(0, wgpu::ShaderStages::FRAGMENT),
            crate::bind::storage(1, wgpu::ShaderStages::FRAGMENT, false),
        ],
    });
    let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("count fragments"),
        bind_group_layouts: &[Some(ctx.scene_layout()), Some(&target_layout)],
        immediate_size: 0,
    });
    let desc = ScenePipelineDesc {
        depth: Some(depth_test(wgpu::CompareFunction::Always, false)),
        ..ScenePipelineDesc::new("count fragments", &module, "fs_count")
    };
    let pipelines = ScenePipelines::with_layout(ctx, &desc, &layout);

    use wgpu::util::DeviceExt;
    let size = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("count target size"),
        contents: bytemuck::cast_slice(&[res.width, res.height, 0, 0]),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let counts = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("fragment counts"),
        size: pixels * 4,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: true,
    });
    // Mapped at creation is zero-initialised by wgpu.
    counts.unmap();
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("fragment counts readback"),
        size: pixels * 4,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let target_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("count target"),
        layout: &target_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: size.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: counts.as_entire_binding(),
            },
        ],
    });
    // A render pass needs an attachment; a depth buffer that is never tested nor written.
    let depth = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("count depth"),
        size: wgpu::Extent3d {
            width: res.width,
            height: res.height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Depth32Float,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let depth_view = depth.create_view(&Default::default());
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = crate::pass::begin(
            &mut encoder,
            "count fragments",
            &[],
            crate::pass::depth(
                &depth_view,
                wgpu::LoadOp::Clear(0.0),
                wgpu::StoreOp::Discard,
            ),
            &crate::PassTimestamps::untimed(),
        );
        scene.bind(&mut pass);
        pass.set_bind_group(1, &target_group, &[]);
        for (i, d) in scene.scene.draws.iter().enumerate() {
            if d.vertex_count == 0 {
                continue;
            }
            scene.use_draw(&mut pass, &pipelines, i);
            GpuScene::draw_range(
                &mut pass,
                d.first_vertex..d.first_vertex + d.vertex_count,
                0..1,
            );
        }
    }
    encoder.copy_buffer_to_buffer(&counts, 0, &readback, 0, pixels * 4);
    ctx.queue.submit([encoder.finish()]);
    crate::readback::read_buffer_u32(ctx, &readback, "fragment counts")
}
