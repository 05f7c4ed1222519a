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

/// Whether `ctx` runs on Mesa's llvmpipe (lavapipe, or llvmpipe through GL), the adapter the
/// suite's tolerances are measured on: its output repeats bit for bit, so a twin test may bound
/// it near the measured value and keep the wider, spec-derived margin for other adapters
/// (their FMA contraction and transcendental approximations differ).
pub fn is_llvmpipe(ctx: &Context) -> bool {
    ctx.wgpu_adapter_info()
        .name
        .to_lowercase()
        .contains("llvmpipe")
}

/// Evaluates a WGSL expression on the GPU once per input: `expr` sees `x: vec4<f32>` (one
/// input) and yields an `f32`. It is appended as a compute kernel to `source` (a composed
/// shader, includes resolved), so it calls that shader's own functions — the formulas a CPU
/// twin mirrors — with the constants the passes use. The kernel's buffers sit at group 0,
/// bindings 100 and 101 (free in every pass shader). `uniform`: bytes for a uniform at group 1,
/// binding 0, for functions that read one (e.g. a pass's parameter block). `constants`: values
/// of the shader's `override` constants, as a pass pipeline sets them. A `u32` result comes
/// back bit for bit through `bitcast<f32>(…)` and `f32::to_bits`, or through [`eval_u32`].
pub fn eval_f32(
    ctx: &Context,
    source: &str,
    expr: &str,
    inputs: &[[f32; 4]],
    uniform: Option<&[u8]>,
    constants: &[(&str, f64)],
) -> Result<Vec<f32>, crate::GpuError> {
    let buffer = uniform.map(|bytes| uniform_buffer(ctx, bytes));
    let group1: Vec<wgpu::BindGroupEntry<'_>> = buffer
        .iter()
        .map(|b| wgpu::BindGroupEntry {
            binding: 0,
            resource: b.as_entire_binding(),
        })
        .collect();
    eval_f32_with(ctx, source, expr, inputs, &group1, constants)
}

/// [`eval_f32`] with any resources the shader's functions read bound at group 1: `group1` holds
/// the entries of the kernel's derived layout for that group (only the bindings the called
/// functions use, e.g. a parameter uniform and a lookup texture; empty for none).
pub fn eval_f32_with(
    ctx: &Context,
    source: &str,
    expr: &str,
    inputs: &[[f32; 4]],
    group1: &[wgpu::BindGroupEntry<'_>],
    constants: &[(&str, f64)],
) -> Result<Vec<f32>, crate::GpuError> {
    let words = run_kernel(ctx, source, "f32", expr, inputs, group1, constants)?;
    Ok(words.into_iter().map(f32::from_bits).collect())
}

/// [`eval_f32_with`] for an expression that yields a `u32`, returned word for word: packed
/// encodings (no float round trip, so no bit pattern is a NaN to worry about), and 64-bit
/// values as their two halves (`u32(v >> 32u)`, `u32(v & 0xFFFFFFFFlu)`).
pub fn eval_u32(
    ctx: &Context,
    source: &str,
    expr: &str,
    inputs: &[[f32; 4]],
    group1: &[wgpu::BindGroupEntry<'_>],
    constants: &[(&str, f64)],
) -> Result<Vec<u32>, crate::GpuError> {
    run_kernel(ctx, source, "u32", expr, inputs, group1, constants)
}

/// A uniform buffer holding `bytes`, for a group-1 entry of [`eval_f32_with`] or [`eval_u32`].
pub fn uniform_buffer(ctx: &Context, bytes: &[u8]) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("eval kernel uniform"),
            contents: bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        })
}

/// Runs `expr` (of WGSL type `ty`, `f32` or `u32`) once per input and returns its bits.
fn run_kernel(
    ctx: &Context,
    source: &str,
    ty: &str,
    expr: &str,
    inputs: &[[f32; 4]],
    group1: &[wgpu::BindGroupEntry<'_>],
    constants: &[(&str, f64)],
) -> Result<Vec<u32>, crate::GpuError> {
    use wgpu::util::DeviceExt;
    let code = format!(
        "{source}\n\
         @group(0) @binding(100) var<storage, read> kernel_in: array<vec4<f32>>;\n\
         @group(0) @binding(101) var<storage, read_write> kernel_out: array<u32>;\n\
         @compute @workgroup_size(64)\n\
         fn kernel_main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
             if id.x >= arrayLength(&kernel_out) {{ return; }}\n\
             let x = kernel_in[id.x];\n\
             let result: {ty} = {expr};\n\
             kernel_out[id.x] = bitcast<u32>(result);\n\
         }}\n"
    );
    let device = &ctx.device;
    let module = ctx.wgsl_module("eval kernel", &code);
    let pipeline = ctx.compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("eval kernel"),
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
        label: Some("eval kernel inputs"),
        contents: bytemuck::cast_slice(&flat),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (inputs.len() * 4) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("eval kernel outputs"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("eval kernel readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let io = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("eval kernel io"),
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
    let resources = (!group1.is_empty()).then(|| {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("eval kernel group 1"),
            layout: &pipeline.get_bind_group_layout(1),
            entries: group1,
        })
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &io, &[]);
        if let Some(group) = &resources {
            pass.set_bind_group(1, group, &[]);
        }
        pass.dispatch_workgroups((inputs.len() as u32).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&output, 0, &readback, 0, size);
    ctx.queue.submit([encoder.finish()]);
    let bytes = crate::read_buffer(ctx, &readback, "eval kernel outputs")?;
    Ok(bytes
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

/// A scratch folder for one test under the system's temp dir, `oit-NAME-PID-N`, emptied when
/// made and removed when dropped, so test runs leave nothing behind; a panicking test keeps it
/// and says where, for inspection.
#[derive(Debug)]
pub struct ScratchDir(std::path::PathBuf);

impl ScratchDir {
    pub fn new(name: &str) -> Self {
        static MADE: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = MADE.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("oit-{name}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir)
            .unwrap_or_else(|e| panic!("scratch dir {}: {e}", dir.display()));
        ScratchDir(dir)
    }
}

impl std::ops::Deref for ScratchDir {
    type Target = std::path::Path;

    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for ScratchDir {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::ffi::OsStr> for ScratchDir {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.0.as_os_str()
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("kept {} for inspection", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

#[cfg(test)]
mod scratch_tests {
    use super::ScratchDir;

    #[test]
    fn a_scratch_dir_is_empty_when_made_and_gone_when_dropped() {
        let kept;
        {
            let dir = ScratchDir::new("scratch-test");
            assert_eq!(std::fs::read_dir(&*dir).unwrap().count(), 0);
            std::fs::write(dir.join("file"), b"x").unwrap();
            kept = dir.to_path_buf();
            assert!(kept.join("file").exists());
        }
        assert!(!kept.exists());
    }
}
