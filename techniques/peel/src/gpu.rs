//! GPU machinery shared by both peelers: shader composition, pipelines with several colour
//! targets, the per-frame counters, the pass-index uniform, and the GPU-side termination gate.

use oit_gpu::bind;
use oit_gpu::wgpu;
use oit_gpu::{Caps, Context, GpuError, GpuScene, MemoryLedger, ScenePipelines};

/// Counter words before the per-pass records (shaders/peel_counters.wgsl): word 0 counts the
/// pixels that lost layers.
pub const COUNTER_HEADER_WORDS: u32 = 1;
/// Counter words per pass (shaders/peel_counters.wgsl): "pass i left something for pass i + 1",
/// then the fragments pass i composited.
pub const COUNTER_WORDS_PER_PASS: u32 = 2;
const DROPPED_WORD: u32 = 0;

fn left_word(pass: u32) -> u64 {
    u64::from(COUNTER_HEADER_WORDS) + u64::from(COUNTER_WORDS_PER_PASS) * u64::from(pass)
}

/// Pass slots (counter records and pass indices) allocated before the first frame; more are
/// allocated when a frame needs them.
const INITIAL_SLOTS: u32 = 64;

/// Bytes of one pass index record: 16 (`PassInfo`) at the adapter's dynamic-offset alignment.
fn pass_stride(caps: &Caps) -> u32 {
    caps.min_uniform_buffer_offset_alignment.max(16)
}

/// Most pass slots the adapter allows, and the limit that sets it. Each pass has a 16-byte
/// index record at its own dynamic uniform offset (`min_uniform_buffer_offset_alignment`
/// apart, in one buffer of at most `max_buffer_size` bytes, offsets being u32) and
/// `COUNTER_WORDS_PER_PASS` counter words in one storage binding of at most
/// `max_storage_buffer_binding_size` bytes. Nothing else in the crate bounds the pass count.
pub fn max_pass_slots(caps: &Caps) -> (u32, &'static str) {
    let stride = u64::from(pass_stride(caps));
    let by_indices = (caps.max_buffer_size / stride).min(u64::from(u32::MAX) / stride + 1);
    let counter_bytes = caps
        .max_storage_buffer_binding_size
        .min(caps.max_buffer_size);
    let by_counters = (counter_bytes / 4).saturating_sub(u64::from(COUNTER_HEADER_WORDS))
        / u64::from(COUNTER_WORDS_PER_PASS);
    let (slots, limit) = if by_indices <= by_counters {
        (
            by_indices,
            "max_buffer_size / min_uniform_buffer_offset_alignment (one pass-index slot per pass)",
        )
    } else {
        (
            by_counters,
            "max_storage_buffer_binding_size (8 counter bytes per pass)",
        )
    };
    (slots.min(u64::from(u32::MAX)) as u32, limit)
}

pub(crate) const PEEL_COUNTERS: &str = include_str!("../shaders/peel_counters.wgsl");
pub(crate) const PEEL_COMMON: &str = include_str!("../shaders/peel_common.wgsl");
pub(crate) const PEEL_DUAL: &str = include_str!("../shaders/peel_dual.wgsl");
pub(crate) const PEEL_FRONT: &str = include_str!("../shaders/peel_front.wgsl");
pub(crate) const PEEL_COMPOSITE: &str = include_str!("../shaders/peel_composite.wgsl");
pub(crate) const PEEL_GATE: &str = include_str!("../shaders/peel_gate.wgsl");
pub(crate) const PEEL_TAIL: &str = include_str!("../shaders/peel_tail.wgsl");
pub(crate) const PEEL_TRANSMIT: &str = include_str!("../shaders/peel_transmit.wgsl");

/// How `auto` (and a fixed count larger than needed) stops.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Termination {
    /// Indirect draws whose instance counts a compute pass sets from the previous pass's
    /// "something left" flag: no CPU wait per pass. A frame records as many passes as the
    /// previous frame ran and reads the flags back once, with the stats; only when that budget
    /// was too small does it record more (one extra round trip per chunk).
    #[default]
    GpuGated,
    /// The classic loop: submit a pass, wait for its flag on the CPU, decide. Direct draws.
    /// Kept to measure what the stall costs.
    CpuReadbackPerPass,
}

/// Implementation switches that are not part of the technique spec: the measured ablations
/// and the termination strategy.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    pub termination: Termination,
    /// Range test before any shading (`false` shades every fragment first, as Babylon.js).
    pub test_before_shading: bool,
    /// Dual peeling: init pass with one (−min, max) target and coverage only (`false` runs the
    /// full peel shader with all three targets, as a naive port of the SDK sample does).
    pub depth_only_init: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            termination: Termination::GpuGated,
            test_before_shading: true,
            depth_only_init: true,
        }
    }
}

/// What the last frame did, pass by pass (more detail than [`oit_gpu::RenderStats`]).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct PeelReport {
    /// Geometry passes recorded (including ones the gate skipped), init pass included.
    pub passes_recorded: u32,
    /// Geometry passes that rasterized (not skipped by the gate), init pass included.
    pub passes_run: u32,
    /// CPU waits for GPU results in the frame (stats readback included).
    pub readbacks: u32,
    /// Fragments composited by each recorded pass (index 0 is the init pass for dual peeling).
    pub peeled_per_pass: Vec<u32>,
    /// Pixels where layers were left after the last pass.
    pub dropped_pixels: u32,
    /// Pass slots (counter records and pass indices) allocated after the frame: grown when a
    /// frame needed more, never shrunk.
    pub pass_slots: u32,
}

/// A module of this crate's WGSL: `#include` resolves in this crate's shaders, then oit-wboit's
/// (its tail) and oit-gpu's shared modules.
pub(crate) fn shader(
    ctx: &Context,
    name: &str,
    source: &str,
) -> Result<wgpu::ShaderModule, GpuError> {
    ctx.shader_with(name, source, crate::FAMILY.shaders)
}

/// Format of the front-to-back (under) accumulator and of a peeled layer: Rgba32Float where the
/// adapter can render and blend it, else the final colour's format. Why: under-blending
/// multiplies the transmittance into the accumulator once per layer, so an f16 accumulator
/// compounds its rounding over the layers (measured on many-layers-64 at 128² with the default
/// Rgba16Float target: RMSE 4.2e-3 for exact peeling, against 5.2e-4 for sorted OVER blending,
/// which rounds each layer into the target only once).
pub(crate) fn accumulator_format(
    ctx: &Context,
    final_format: wgpu::TextureFormat,
) -> wgpu::TextureFormat {
    accumulator_format_on(&ctx.caps, final_format)
}

/// [`accumulator_format`] from the adapter's caps alone.
pub(crate) fn accumulator_format_on(
    caps: &oit_gpu::Caps,
    final_format: wgpu::TextureFormat,
) -> wgpu::TextureFormat {
    let f32_caps = caps.format(wgpu::TextureFormat::Rgba32Float);
    if f32_caps.renderable && f32_caps.blendable {
        wgpu::TextureFormat::Rgba32Float
    } else {
        final_format
    }
}

/// Under-blend into the front accumulator of one colour channel, `(F, 0, 0, T)` cleared to
/// `(0, 0, 0, 1)`, from a layer `(C, 0, 0, t)` of that channel: colour `dst + src · dst.a`,
/// alpha `dst.a · t` (shaders/peel_transmit.wgsl).
pub(crate) const CHANNEL_UNDER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::DstAlpha,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::SrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
};

/// Over-blend into the back accumulator of one colour channel, an RG target `(B, Tb)` cleared to
/// `(0, 1)`, from a layer `(C, 0, 0, t)`: `dst = src + t · dst`, i.e. `B = C + t·B`,
/// `Tb = t·Tb` (the output's alpha is a blend input even though the target has none).
pub(crate) const CHANNEL_OVER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::SrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::SrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
};

/// Keeps the target's alpha (the composites write colour only).
const KEEP_ALPHA: wgpu::BlendComponent = wgpu::BlendComponent {
    src_factor: wgpu::BlendFactor::Zero,
    dst_factor: wgpu::BlendFactor::One,
    operation: wgpu::BlendOperation::Add,
};

/// `dst.rgb *= src.rgb`: the per-channel transmittance of a stack over what is behind it.
const MULTIPLY_RGB: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::Src,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: KEEP_ALPHA,
};

/// `dst.rgb += src.rgb`: the stack's radiance after [`MULTIPLY_RGB`].
const ADD_RGB: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: KEEP_ALPHA,
};

/// Whether a pass writing `targets` per-channel accumulators of `bytes` (at most) fits the
/// adapter's colour attachments.
pub(crate) fn attachments_fit(caps: &Caps, targets: u32, bytes: u32) -> bool {
    caps.max_color_attachments >= targets && caps.max_color_attachment_bytes_per_sample >= bytes
}

/// Which stack a set of [`Channels`] accumulates, and so its layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Side {
    /// Layers nearest first (under): RGBA `(F, 0, 0, T)` per channel.
    Front,
    /// Layers farthest first (over): RG `(B, Tb)` per channel.
    Back,
}

/// The shader module and layouts of the per-channel full-screen passes
/// (shaders/peel_transmit.wgsl).
#[derive(Debug)]
pub(crate) struct TransmitShader {
    pub module: wgpu::ShaderModule,
    /// Group 0: three float textures.
    pub layout: wgpu::BindGroupLayout,
    /// Group 0, then the pass group.
    pub pipeline_layout: wgpu::PipelineLayout,
}

impl TransmitShader {
    pub fn new(ctx: &Context, control: &Control) -> Result<Self, GpuError> {
        let fs = wgpu::ShaderStages::FRAGMENT;
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("peel per-channel"),
            entries: &[
                bind::float_texture(0, fs),
                bind::float_texture(1, fs),
                bind::float_texture(2, fs),
            ],
        });
        let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("peel per-channel"),
            bind_group_layouts: &[Some(&layout), Some(&control.pass_layout)],
            immediate_size: 0,
        });
        Ok(TransmitShader {
            module: shader(ctx, "peel_transmit.wgsl", PEEL_TRANSMIT)?,
            layout,
            pipeline_layout,
        })
    }

    /// Group 0 with `views` at bindings 0, 1, 2.
    pub fn group(&self, ctx: &Context, views: [&wgpu::TextureView; 3]) -> wgpu::BindGroup {
        let entries = [0, 1, 2].map(|i| wgpu::BindGroupEntry {
            binding: i,
            resource: wgpu::BindingResource::TextureView(views[i as usize]),
        });
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("peel per-channel"),
            layout: &self.layout,
            entries: &entries,
        })
    }

    /// A full-screen pipeline of `entry` writing `targets`.
    pub fn pipeline(
        &self,
        ctx: &Context,
        entry: &str,
        targets: &[Option<wgpu::ColorTargetState>],
    ) -> wgpu::RenderPipeline {
        oit_gpu::fullscreen_pipeline(
            ctx,
            &oit_gpu::FullscreenDesc {
                label: entry,
                layout: &self.pipeline_layout,
                module: &self.module,
                fragment_entry: entry,
                targets,
                depth: None,
                multisample: Default::default(),
                constants: &[],
            },
        )
    }
}

/// Three accumulators, one per colour channel, of a stack of layers with coloured
/// transmittance (shaders/peel_transmit.wgsl), and the two draws that put the stack over the
/// final colour: `dst = F + T ⊙ dst` per channel. One target per channel because a blend unit
/// multiplies a channel only by values of its own target, and dual-source blending (which
/// would give a per-channel factor) allows only one target per pass.
#[derive(Debug)]
pub(crate) struct Channels {
    pub side: Side,
    pub format: wgpu::TextureFormat,
    pub views: [wgpu::TextureView; 3],
    group: wgpu::BindGroup,
    multiply: wgpu::RenderPipeline,
    add: wgpu::RenderPipeline,
}

impl Channels {
    /// `accum_format` is the RGBA accumulator format ([`accumulator_format`]); a back stack
    /// uses its two-channel counterpart.
    pub fn new(
        ctx: &Context,
        ledger: &mut MemoryLedger,
        shader: &TransmitShader,
        side: Side,
        accum_format: wgpu::TextureFormat,
        final_format: wgpu::TextureFormat,
        resolution: oit_scene::Resolution,
    ) -> Self {
        let format = match (side, accum_format) {
            (Side::Front, f) => f,
            (Side::Back, wgpu::TextureFormat::Rgba32Float) => wgpu::TextureFormat::Rg32Float,
            (Side::Back, wgpu::TextureFormat::Rgba8Unorm) => wgpu::TextureFormat::Rg8Unorm,
            (Side::Back, _) => wgpu::TextureFormat::Rg16Float,
        };
        let views = ["r", "g", "b"].map(|c| {
            texture_2d(
                ctx,
                ledger,
                &format!("peel {side:?} accumulator {c}"),
                resolution,
                format,
            )
            .1
        });
        let group = shader.group(ctx, [&views[0], &views[1], &views[2]]);
        let target = |blend| {
            [Some(wgpu::ColorTargetState {
                format: final_format,
                blend: Some(blend),
                write_mask: wgpu::ColorWrites::ALL,
            })]
        };
        let transmittance = match side {
            Side::Front => "fs_front_transmittance",
            Side::Back => "fs_back_transmittance",
        };
        Channels {
            side,
            format,
            multiply: shader.pipeline(ctx, transmittance, &target(MULTIPLY_RGB)),
            add: shader.pipeline(ctx, "fs_radiance", &target(ADD_RGB)),
            views,
            group,
        }
    }

    /// The three targets a pass blends layers into (under for the front, over for the back).
    pub fn targets(&self) -> [Option<wgpu::ColorTargetState>; 3] {
        let blend = match self.side {
            Side::Front => CHANNEL_UNDER,
            Side::Back => CHANNEL_OVER,
        };
        [0, 1, 2].map(|_| {
            Some(wgpu::ColorTargetState {
                format: self.format,
                blend: Some(blend),
                write_mask: wgpu::ColorWrites::ALL,
            })
        })
    }

    /// The attachments of a pass that blends into them (kept: `LoadOp::Load`).
    pub fn attachments(&self) -> [Option<wgpu::RenderPassColorAttachment<'_>>; 3] {
        [0, 1, 2].map(|i| oit_gpu::pass::color(&self.views[i], wgpu::LoadOp::Load))
    }

    /// Clears every channel to the empty stack: F = 0, T = 1.
    pub fn clear(&self, encoder: &mut wgpu::CommandEncoder) {
        let empty = wgpu::Color {
            r: 0.0,
            g: if self.side == Side::Back { 1.0 } else { 0.0 },
            b: 0.0,
            a: 1.0,
        };
        for view in &self.views {
            let _ = oit_gpu::pass::begin(
                encoder,
                "peel per-channel clear",
                &[oit_gpu::pass::color(view, wgpu::LoadOp::Clear(empty))],
                None,
                &oit_gpu::PassTimestamps::untimed(),
            );
        }
    }

    /// The stack over `target`: `dst *= T`, then `dst += F`, per channel (two draws of one
    /// pass); the target's alpha is kept.
    pub fn composite(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        target: &wgpu::TextureView,
        control: &Control,
        timer_entry: &oit_gpu::PassTimestamps,
    ) {
        let mut pass = oit_gpu::pass::begin(
            encoder,
            label,
            &[oit_gpu::pass::color(target, wgpu::LoadOp::Load)],
            None,
            timer_entry,
        );
        pass.set_bind_group(0, &self.group, &[]);
        pass.set_bind_group(1, &control.pass_group, &[0]);
        pass.set_pipeline(&self.multiply);
        pass.draw(0..3, 0..1);
        pass.set_pipeline(&self.add);
        pass.draw(0..3, 0..1);
    }
}

pub(crate) fn texture_2d(
    ctx: &Context,
    ledger: &mut MemoryLedger,
    label: &str,
    resolution: oit_scene::Resolution,
    format: wgpu::TextureFormat,
) -> (wgpu::Texture, wgpu::TextureView) {
    let t = ledger.create_texture_2d(
        &ctx.device,
        label,
        resolution,
        format,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        1,
    );
    let v = t.create_view(&Default::default());
    (t, v)
}

/// Counters, pass-index uniform, gate and count pipelines: everything that does not depend on
/// the scene. The indirect argument buffer is per scene ([`DrawList`]). The counters and the
/// pass indices live in one bind group (`pass_group`, group 2 of the scene passes, group 1 of
/// the full-screen and compute passes), so growing them replaces that group and nothing else.
#[derive(Debug)]
pub(crate) struct Control {
    /// The counters, their readback and the pass indices (replaced when they grow).
    ledger: MemoryLedger,
    /// Pass slots allocated.
    capacity: u32,
    max_slots: (u32, &'static str),
    counters: wgpu::Buffer,
    readback: wgpu::Buffer,
    /// Kept with the bind group that reads it.
    _pass_buffer: wgpu::Buffer,
    pass_stride: u32,
    pub pass_layout: wgpu::BindGroupLayout,
    pub pass_group: wgpu::BindGroup,
    gate_module: wgpu::ShaderModule,
    gate_layout: wgpu::BindGroupLayout,
    gate_pipeline: wgpu::ComputePipeline,
}

/// The counters, their readback, the pass indices and their bind group for `capacity` slots.
struct Slots {
    ledger: MemoryLedger,
    counters: wgpu::Buffer,
    readback: wgpu::Buffer,
    pass_buffer: wgpu::Buffer,
    pass_group: wgpu::BindGroup,
}

impl Slots {
    fn new(ctx: &Context, layout: &wgpu::BindGroupLayout, stride: u32, capacity: u32) -> Self {
        let device = &ctx.device;
        let mut ledger = MemoryLedger::new();
        let counter_bytes = counter_bytes(capacity);
        let counters = ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("peel counters"),
                size: counter_bytes,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let readback = ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("peel counters readback"),
                size: counter_bytes,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            },
        );
        // One 16-byte PassInfo per pass index at the dynamic-offset alignment.
        let words_per_slot = (stride / 4) as usize;
        let mut words = vec![0u32; words_per_slot * capacity as usize];
        for i in 0..capacity {
            words[i as usize * words_per_slot] = i;
        }
        let pass_buffer = ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("peel pass indices"),
                size: u64::from(stride) * u64::from(capacity),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        ctx.queue
            .write_buffer(&pass_buffer, 0, bytemuck::cast_slice(&words));
        let pass_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("peel pass group"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &pass_buffer,
                        offset: 0,
                        size: wgpu::BufferSize::new(16),
                    }),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: counters.as_entire_binding(),
                },
            ],
        });
        Slots {
            ledger,
            counters,
            readback,
            pass_buffer,
            pass_group,
        }
    }
}

/// What the scan after a pass reads (shaders/peel_gate.wgsl).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scan {
    /// Dual peeling: the range the pass wrote (binding 3) and its peeled count (binding 4).
    Range,
    /// Front peeling: the layer texture (binding 3).
    Layer,
}

/// Pixels per side of the block one invocation of `cs_scan_range` reads (`SCAN_BLOCK` in
/// shaders/peel_gate.wgsl; workgroups are 8×8 invocations).
const SCAN_BLOCK: u32 = 4;

/// Bytes of the counters for `slots` passes.
fn counter_bytes(slots: u32) -> u64 {
    left_word(slots) * 4
}

impl Control {
    pub fn new(ctx: &Context) -> Result<Self, GpuError> {
        let max_slots = max_pass_slots(&ctx.caps);
        let capacity = INITIAL_SLOTS.min(max_slots.0);
        let pass_stride = pass_stride(&ctx.caps);
        let all = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let pass_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("peel pass group"),
            entries: &[
                bind::dynamic_uniform(0, all, 16),
                bind::storage(1, all, false),
            ],
        });
        let slots = Slots::new(ctx, &pass_layout, pass_stride, capacity);
        let gate_module = shader(ctx, "peel_gate.wgsl", PEEL_GATE)?;
        let cs = wgpu::ShaderStages::COMPUTE;
        let gate_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("peel gate"),
            entries: &[bind::storage(1, cs, false), bind::uniform(2, cs)],
        });
        let gate_pipeline =
            compute_pipeline(ctx, &gate_module, &[&gate_layout, &pass_layout], "cs_gate");
        Ok(Control {
            ledger: slots.ledger,
            capacity,
            max_slots,
            counters: slots.counters,
            readback: slots.readback,
            _pass_buffer: slots.pass_buffer,
            pass_stride,
            pass_layout,
            pass_group: slots.pass_group,
            gate_module,
            gate_layout,
            gate_pipeline,
        })
    }

    /// Pass slots allocated now.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Bytes of the counters, their readback and the pass indices.
    pub fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    /// Makes room for pass indices `0..slots`, keeping the counts already written this frame:
    /// a larger set of buffers (at least double, at most the adapter's bound) replaces the
    /// pass group, and the old counters are copied into the new ones on the queue, after the
    /// passes already submitted. Fails only beyond [`max_pass_slots`] (which `check` and the
    /// `auto` budgets stay within).
    pub fn reserve(&mut self, ctx: &Context, slots: u32) -> Result<(), GpuError> {
        if slots <= self.capacity {
            return Ok(());
        }
        let (max, limit) = self.max_slots;
        if slots > max {
            return Err(GpuError::TooMany {
                what: format!("depth-peeling passes (adapter limit: {limit})"),
                needed: u64::from(slots),
                limit: u64::from(max),
            });
        }
        let capacity = slots.max(self.capacity.saturating_mul(2)).min(max);
        let grown = Slots::new(ctx, &self.pass_layout, self.pass_stride, capacity);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(
            &self.counters,
            0,
            &grown.counters,
            0,
            counter_bytes(self.capacity),
        );
        ctx.queue.submit([encoder.finish()]);
        self.ledger = grown.ledger;
        self.capacity = capacity;
        self.counters = grown.counters;
        self.readback = grown.readback;
        self._pass_buffer = grown.pass_buffer;
        self.pass_group = grown.pass_group;
        Ok(())
    }

    /// The dynamic offset that selects pass index `i` (within [`Control::capacity`]).
    pub fn offset(&self, i: u32) -> u32 {
        debug_assert!(i < self.capacity, "pass {i} beyond {} slots", self.capacity);
        i * self.pass_stride
    }

    /// Zeroes the counters at the start of a frame.
    pub fn clear(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.counters, 0, None);
    }

    /// The scan of peel_gate.wgsl that `scan` names, with its group-0 layout.
    pub fn scan_pipeline(
        &self,
        ctx: &Context,
        scan: Scan,
    ) -> (wgpu::BindGroupLayout, wgpu::ComputePipeline) {
        let cs = wgpu::ShaderStages::COMPUTE;
        match scan {
            Scan::Range => self.gate_module_pipeline(
                ctx,
                "cs_scan_range",
                &[bind::float_texture(3, cs), bind::float_texture(4, cs)],
            ),
            Scan::Layer => {
                self.gate_module_pipeline(ctx, "cs_scan_layer", &[bind::float_texture(3, cs)])
            }
        }
    }

    /// After pass `i`: the scan (`scan` and its group 0 from [`Control::scan_pipeline`]) sets
    /// "pass i left something" and adds the pass's composited count, then, with `gate`, the
    /// gate turns the flag into the next pass's instance counts. One compute pass, timed as
    /// `ts`.
    #[allow(clippy::too_many_arguments)] // each is a distinct GPU resource of the pass
    pub fn scan(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scan: (&wgpu::ComputePipeline, &wgpu::BindGroup),
        resolution: oit_scene::Resolution,
        gate: Option<&DrawList>,
        i: u32,
        ts: &oit_gpu::PassTimestamps,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("peel scan"),
            timestamp_writes: ts.compute_writes(),
        });
        pass.set_pipeline(scan.0);
        pass.set_bind_group(0, scan.1, &[]);
        pass.set_bind_group(1, &self.pass_group, &[self.offset(i)]);
        let pixels = SCAN_BLOCK * 8;
        pass.dispatch_workgroups(
            resolution.width.div_ceil(pixels),
            resolution.height.div_ceil(pixels),
            1,
        );
        if let Some(list) = gate {
            pass.set_pipeline(&self.gate_pipeline);
            pass.set_bind_group(0, &list.gate_group, &[]);
            pass.set_bind_group(1, &self.pass_group, &[self.offset(i)]);
            pass.dispatch_workgroups((list.draws.len() as u32).div_ceil(64).max(1), 1, 1);
        }
    }

    /// A count pipeline of peel_gate.wgsl (`cs_count_range` or `cs_count_layer`) with the
    /// layout its bindings need.
    pub fn count_pipeline(
        &self,
        ctx: &Context,
        entry: &str,
        extra: wgpu::BindGroupLayoutEntry,
    ) -> (wgpu::BindGroupLayout, wgpu::ComputePipeline) {
        let cs = wgpu::ShaderStages::COMPUTE;
        self.gate_module_pipeline(ctx, entry, &[bind::uniform(2, cs), extra])
    }

    /// Entry point `entry` of peel_gate.wgsl with a group 0 of `entries` and the pass group.
    fn gate_module_pipeline(
        &self,
        ctx: &Context,
        entry: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> (wgpu::BindGroupLayout, wgpu::ComputePipeline) {
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(entry),
            entries,
        });
        let pipeline =
            compute_pipeline(ctx, &self.gate_module, &[&layout, &self.pass_layout], entry);
        (layout, pipeline)
    }

    /// Records the compute pass that counts the pixels a budget-limited frame left layers on
    /// (`pixels_with_dropped_layers`): `count` is a pipeline from [`Control::count_pipeline`],
    /// `texture` what its entry point reads (the last range, or the detection pass's layer).
    #[allow(clippy::too_many_arguments)] // each is a distinct GPU resource of the pass
    pub fn dispatch_count(
        &self,
        ctx: &Context,
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        count: (&wgpu::BindGroupLayout, &wgpu::ComputePipeline),
        grid: &wgpu::Buffer,
        texture: &wgpu::TextureView,
        resolution: oit_scene::Resolution,
    ) {
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout: count.0,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: grid.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(texture),
                },
            ],
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: None,
        });
        pass.set_pipeline(count.1);
        pass.set_bind_group(0, &group, &[]);
        pass.set_bind_group(1, &self.pass_group, &[0]);
        pass.dispatch_workgroups(
            resolution.width.div_ceil(8),
            resolution.height.div_ceil(8),
            1,
        );
    }

    /// Copies back the counters of passes `0..slots` and the dropped-pixel count (waits for
    /// the GPU).
    pub fn read(&self, ctx: &Context, slots: u32) -> Result<Counters, GpuError> {
        let bytes = counter_bytes(slots.min(self.capacity));
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&self.counters, 0, &self.readback, 0, bytes);
        ctx.queue.submit([encoder.finish()]);
        let mut words = oit_gpu::read_buffer_u32(ctx, &self.readback, "peel counters")?;
        words.truncate((bytes / 4) as usize);
        Ok(Counters { words })
    }
}

fn compute_pipeline(
    ctx: &Context,
    module: &wgpu::ShaderModule,
    groups: &[&wgpu::BindGroupLayout],
    entry: &str,
) -> wgpu::ComputePipeline {
    let groups: Vec<Option<&wgpu::BindGroupLayout>> = groups.iter().map(|g| Some(*g)).collect();
    let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(entry),
        bind_group_layouts: &groups,
        immediate_size: 0,
    });
    ctx.compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(&layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// The counters of one frame, read back.
#[derive(Debug, Clone)]
pub(crate) struct Counters {
    words: Vec<u32>,
}

impl Counters {
    fn word(&self, index: u64) -> u32 {
        usize::try_from(index)
            .ok()
            .and_then(|i| self.words.get(i))
            .copied()
            .unwrap_or(0)
    }

    /// Pass `i` left something for pass `i + 1`.
    pub fn left(&self, i: u32) -> bool {
        self.word(left_word(i)) != 0
    }

    pub fn peeled(&self, i: u32) -> u32 {
        self.word(left_word(i) + 1)
    }

    pub fn dropped(&self) -> u32 {
        self.word(u64::from(DROPPED_WORD))
    }
}

/// Bytes of one draw's indirect arguments ([`GpuScene::indirect_args`]).
const INDIRECT_ARGS_BYTES: u64 = 20;

/// The transparent draws of one scene and their indirect arguments.
#[derive(Debug)]
pub(crate) struct DrawList {
    pub scene_id: u64,
    /// Indices into `scene.draws`, draw order, empty draws removed.
    pub draws: Vec<usize>,
    pub args: wgpu::Buffer,
    initial: Vec<u32>,
    pub grid: wgpu::Buffer,
    gate_group: wgpu::BindGroup,
}

impl DrawList {
    pub fn new(
        ctx: &Context,
        control: &Control,
        scene: &GpuScene,
        ledger: &mut MemoryLedger,
    ) -> Self {
        let draws: Vec<usize> = scene
            .transparent_draws()
            .into_iter()
            .filter(|&i| scene.scene.draws[i].vertex_count > 0)
            .collect();
        let mut initial = Vec::with_capacity(draws.len().max(1) * 4);
        for &i in &draws {
            let d = &scene.scene.draws[i];
            initial.extend(GpuScene::indirect_args(d));
        }
        if initial.is_empty() {
            initial.extend([0; 5]);
        }
        let args = ledger.create_buffer(
            &ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("peel indirect draws"),
                size: initial.len() as u64 * 4,
                usage: wgpu::BufferUsages::INDIRECT
                    | wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let res = scene.scene.resolution;
        let grid = ledger.create_buffer(
            &ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("peel grid"),
                size: 16,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        ctx.queue.write_buffer(
            &grid,
            0,
            bytemuck::cast_slice(&[res.width, res.height, draws.len() as u32, 0]),
        );
        let gate_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("peel gate"),
            layout: &control.gate_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: args.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: grid.as_entire_binding(),
                },
            ],
        });
        DrawList {
            scene_id: scene.id,
            draws,
            args,
            initial,
            grid,
            gate_group,
        }
    }

    /// Every draw enabled again (start of a frame).
    pub fn reset(&self, ctx: &Context) {
        ctx.queue
            .write_buffer(&self.args, 0, bytemuck::cast_slice(&self.initial));
    }

    /// Draws every transparent draw: indirect (gated) or direct.
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        scene: &GpuScene,
        pipelines: &ScenePipelines,
        indirect: bool,
    ) {
        for (slot, &i) in self.draws.iter().enumerate() {
            let d = &scene.scene.draws[i];
            scene.use_draw(pass, pipelines, i);
            if indirect {
                pass.draw_indexed_indirect(&self.args, slot as u64 * INDIRECT_ARGS_BYTES);
            } else {
                GpuScene::draw_range(pass, d.first_vertex..d.first_vertex + d.vertex_count, 0..1);
            }
        }
    }
}

/// How many passes the next frame records: what this scene needed last time.
#[derive(Debug, Default)]
pub(crate) struct Budget {
    scene_id: Option<u64>,
    passes: u32,
}

impl Budget {
    /// Passes to record first (at least 1, at most `max`): last frame's count for the same
    /// scene, else `initial`.
    pub fn first(&self, scene_id: u64, initial: u32, max: u32) -> u32 {
        let n = if self.scene_id == Some(scene_id) {
            self.passes
        } else {
            initial
        };
        n.clamp(1, max)
    }

    pub fn remember(&mut self, scene_id: u64, passes: u32) {
        self.scene_id = Some(scene_id);
        self.passes = passes;
    }
}

/// Passes the first frame of a scene records for a fixed budget before asking the GPU whether
/// more are needed: budgets up to this record all their passes at once (one readback per
/// frame, as before), a budget far above the scene's depth complexity (any N is allowed up
/// to the adapter's bound) does not record thousands of empty passes.
pub(crate) const FIXED_FIRST: u32 = 64;

/// Passes recorded after a readback found the budget too small: at least 8, and half of what
/// the frame recorded so far, so a scene with L layers needs O(log L) readbacks on its first
/// frame and wastes at most a third of the recorded passes (gated off, they rasterize nothing).
pub(crate) fn more_passes(recorded: u32) -> u32 {
    (recorded / 2).max(8)
}
