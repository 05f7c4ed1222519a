//! Helpers for GPU tests in every crate.

use crate::context::{Context, ContextOptions};

/// Environment variable that turns a missing adapter into a test failure (CI sets it to 1).
pub const REQUIRE_GPU_ENV: &str = "OIT_REQUIRE_GPU";

/// A context on the default adapter, or `None` (with a message) when there is none. With
/// `OIT_REQUIRE_GPU=1` a missing adapter panics instead, so CI cannot pass by skipping.
pub fn context_or_skip(test_name: &str) -> Option<Context> {
    match Context::new(&ContextOptions::default()) {
        Ok(ctx) => Some(ctx),
        Err(e) => {
            if std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1") {
                panic!("{test_name}: {REQUIRE_GPU_ENV}=1 but no usable GPU adapter: {e}");
            }
            eprintln!("skipped {test_name}: no GPU adapter (install mesa-vulkan-drivers): {e}");
            None
        }
    }
}

/// A context on wgpu's GL backend (llvmpipe through EGL in CI), or `None` with a message. With
/// `OIT_REQUIRE_GPU=1` a missing GL adapter panics, like a missing Vulkan one: the GL fallback
/// paths are tested in CI, never skipped there.
pub fn gl_context_or_skip(test_name: &str) -> Option<Context> {
    match Context::new(&ContextOptions {
        backend: crate::Backend::Gl,
        adapter: None,
    }) {
        Ok(ctx) => Some(ctx),
        Err(e) => {
            if std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1") {
                panic!("{test_name}: {REQUIRE_GPU_ENV}=1 but no GL adapter: {e}");
            }
            eprintln!(
                "skipped {test_name}: no GL adapter (install libegl-mesa0 libgl1-mesa-dri): {e}"
            );
            None
        }
    }
}

/// Evaluates a WGSL expression on the GPU once per input: `expr` sees `x: vec4<f32>` (one
/// input) and yields an `f32`. It is appended as a compute kernel to `source` (a composed
/// shader, includes resolved), so it calls that shader's own functions — the formulas a CPU
/// twin mirrors — with the constants the passes use. The kernel's buffers sit at group 0,
/// bindings 100 and 101 (free in every pass shader). `uniform`: bytes for a uniform at group 1,
/// binding 0, for functions that read one (e.g. a pass's parameter block). `constants`: values
/// of the shader's `override` constants, as a pass pipeline sets them. A `u32` result comes
/// back bit for bit through `bitcast<f32>(…)` and `f32::to_bits`.
pub fn eval_f32(
    ctx: &Context,
    source: &str,
    expr: &str,
    inputs: &[[f32; 4]],
    uniform: Option<&[u8]>,
    constants: &[(&str, f64)],
) -> Result<Vec<f32>, crate::GpuError> {
    use wgpu::util::DeviceExt;
    let code = format!(
        "{source}\n\
         @group(0) @binding(100) var<storage, read> kernel_in: array<vec4<f32>>;\n\
         @group(0) @binding(101) var<storage, read_write> kernel_out: array<f32>;\n\
         @compute @workgroup_size(64)\n\
         fn kernel_main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
             if id.x >= arrayLength(&kernel_out) {{ return; }}\n\
             let x = kernel_in[id.x];\n\
             kernel_out[id.x] = {expr};\n\
         }}\n"
    );
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("eval_f32 kernel"),
        source: wgpu::ShaderSource::Wgsl(code.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("eval_f32 kernel"),
        layout: None,
        module: &module,
        entry_point: Some("kernel_main"),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants,
            ..Default::default()
        },
        cache: None,
    });
    let flat: Vec<f32> = inputs.iter().flatten().copied().collect();
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("eval_f32 inputs"),
        contents: bytemuck::cast_slice(&flat),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (inputs.len() * 4) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("eval_f32 outputs"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("eval_f32 readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let io = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("eval_f32 io"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 100,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 101,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let params = uniform.map(|bytes| {
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("eval_f32 uniform"),
            contents: bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("eval_f32 uniform"),
            layout: &pipeline.get_bind_group_layout(1),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: buffer.as_entire_binding(),
            }],
        })
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &io, &[]);
        if let Some(group) = &params {
            pass.set_bind_group(1, group, &[]);
        }
        pass.dispatch_workgroups((inputs.len() as u32).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, size);
    ctx.queue.submit([encoder.finish()]);
    let bytes = crate::read_buffer(ctx, &readback, "eval_f32 outputs")?;
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}
