//! The weighted blended OIT tail, shared by the `wboit` technique and by dual depth peeling's
//! `tail=wboit`: the WGSL weight and accumulation functions, the two accumulation targets with
//! their blend states, and the guarded full-screen composite. Both users call these same
//! functions, so the tail is one piece of code.
//!
//! A peel pass that accumulates its leftover layers:
//!
//! 1. appends [`WGSL`] to its shader source and, per fragment, writes
//!    `wboit_accumulate(C, alpha, wboit_weight_default(wboit_view_distance_default(z), z, alpha), wboit_color_scale)`'s
//!    `accum` to the attachment of [`AccumTargets::attachments`]`[0]` and `reveal` to `[1]`;
//! 2. builds its pipeline with [`AccumTargets::color_targets`] and the override constants
//!    [`AccumTargets::prepare`] returns for the scene (depth interval, projection, colour scale;
//!    it also tells the composite the colour scale);
//! 3. calls [`composite`] once after the last accumulation pass.

use crate::guards::{GUARD_SLOTS, GuardCounts};
use crate::range::RangeParams;
use oit_gpu::bind;
use oit_gpu::blend;
use oit_gpu::pass;
use oit_gpu::wgpu;
use oit_gpu::{Context, GpuError, GpuTimer, MemoryLedger, Targets, Unsupported};
use oit_scene::{Resolution, Scene};
use std::sync::Mutex;

/// WGSL with no bindings and no includes (shaders/wboit_tail.wgsl). It defines:
///
/// - `fn wboit_weight_default(view_z: f32, window_z: f32, alpha: f32) -> f32`: the `range`
///   weight with the scene inputs in the override constants `wboit_z_near`, `wboit_z_far`,
///   `wboit_range_fall` (defaults 0.1, 1000, 8);
/// - `fn wboit_weight_range(view_z, z_near, z_far, fall) -> f32`: the same with the inputs
///   passed explicitly ([`RangeParams`]);
/// - `override wboit_color_scale: f32` (default 1): the unit of the colour sums;
/// - `fn wboit_view_distance(window_z, a, b, ortho: bool) -> f32` and
///   `fn wboit_view_distance_default(window_z) -> f32` (overrides `wboit_proj_a`,
///   `wboit_proj_b`, `wboit_ortho`): the positive view distance from window depth;
/// - `struct WboitAccum { accum: vec4<f32>, reveal: vec4<f32> }` and
///   `fn wboit_accumulate(premultiplied: vec3<f32>, alpha: f32, weight: f32, color_scale: f32) -> WboitAccum`
///   (colour sums in units of `color_scale`, which the composite multiplies back).
pub const WGSL: &str = include_str!("../shaders/wboit_tail.wgsl");

/// The composite pass (shaders/wboit_composite.wgsl).
pub const COMPOSITE_WGSL: &str = include_str!("../shaders/wboit_composite.wgsl");

oit_gpu::words! {
    /// Accumulation target format: (premultiplied colour · w, α · w), additive.
    pub enum AccumFormat {
        /// Blendable everywhere; overflows at 65504 (hdr-emissive, deep α = 1 stacks).
        Rgba16f = "rgba16f",
        /// Needs `FLOAT32_BLENDABLE`.
        Rgba32f = "rgba32f",
    }
}

impl AccumFormat {
    pub fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            AccumFormat::Rgba16f => wgpu::TextureFormat::Rgba16Float,
            AccumFormat::Rgba32f => wgpu::TextureFormat::Rgba32Float,
        }
    }

    /// Largest finite value: what the composite puts in place of an infinite channel.
    pub fn max_finite(self) -> f32 {
        match self {
            AccumFormat::Rgba16f => 65504.0,
            AccumFormat::Rgba32f => f32::MAX,
        }
    }
}

oit_gpu::words! {
    /// Revealage format: Π(1 − α) by (zero, one-minus-src) blending (or the fragment count of
    /// the weighted average, additive).
    pub enum RevealFormat {
        /// 8-bit unorm: each blend rounds to 1/255, so α < 1/510 never moves it.
        R8 = "r8",
        R16f = "r16f",
        /// Needs `FLOAT32_BLENDABLE`.
        R32f = "r32f",
    }
}

impl RevealFormat {
    pub fn texture_format(self) -> wgpu::TextureFormat {
        match self {
            RevealFormat::R8 => wgpu::TextureFormat::R8Unorm,
            RevealFormat::R16f => wgpu::TextureFormat::R16Float,
            RevealFormat::R32f => wgpu::TextureFormat::R32Float,
        }
    }
}

/// How the composite turns the two targets into coverage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CompositeMode {
    /// McGuire & Bavoil 2013: the second target is the revealage T = Π(1 − α).
    Weighted,
    /// Bavoil & Myers 2008: the second target is the fragment count n and T = (1 − Σα/n)^n.
    Average,
}

impl CompositeMode {
    /// The composite shader's `AVERAGE` constant.
    fn average_constant(self) -> f64 {
        match self {
            CompositeMode::Weighted => 0.0,
            CompositeMode::Average => 1.0,
        }
    }
}

/// The formats of the tail's default targets: fp16 accumulation (blendable on every adapter)
/// and fp16 revealage (keeps α = 1/512 layers that R8 loses).
pub const DEFAULT_ACCUM: AccumFormat = AccumFormat::Rgba16f;
pub const DEFAULT_REVEAL: RevealFormat = RevealFormat::R16f;

/// `Ok` when this adapter can blend into both targets.
pub fn check_formats(
    caps: &oit_gpu::Caps,
    accum: AccumFormat,
    reveal: RevealFormat,
) -> Result<(), Unsupported> {
    caps.require_target(accum.texture_format(), true)
        .map_err(|e| Unsupported::new(format!("accum={}: {}", accum.name(), e.reason)))?;
    caps.require_target(reveal.texture_format(), true)
        .map_err(|e| Unsupported::new(format!("reveal={}: {}", reveal.name(), e.reason)))?;
    if caps.max_storage_buffers_per_shader_stage == 0 {
        return Err(Unsupported::new(
            "the adapter has no storage buffers per shader stage (scene materials in the vertex stage, guard counters in the fragment stage)",
        ));
    }
    if caps.max_color_attachments < 2 {
        return Err(Unsupported::new(
            "the adapter has fewer than 2 colour attachments",
        ));
    }
    Ok(())
}

/// Bytes per sample of colour attachments of `formats` as wgpu validates them against
/// `max_color_attachment_bytes_per_sample`: each format's byte cost at its component alignment.
pub fn bytes_per_sample(formats: &[wgpu::TextureFormat]) -> u32 {
    formats.iter().fold(0, |total, f| {
        let cost = f.target_pixel_byte_cost().unwrap_or(16);
        let align = f.target_component_alignment().unwrap_or(4);
        total.next_multiple_of(align) + cost
    })
}

/// Why the coloured accumulation pass (accumulation, revealage and the final colour as a
/// third, modulated target) cannot run with these formats on `caps`, if so.
pub fn modulation_unsupported(
    caps: &oit_gpu::Caps,
    accum: AccumFormat,
    reveal: RevealFormat,
    color: wgpu::TextureFormat,
) -> Option<String> {
    let bytes = bytes_per_sample(&[accum.texture_format(), reveal.texture_format(), color]);
    if caps.max_color_attachments < 3 {
        return Some(format!(
            "the per-channel modulation target needs 3 colour attachments, the adapter has {}",
            caps.max_color_attachments
        ));
    }
    (bytes > caps.max_color_attachment_bytes_per_sample).then(|| {
        format!(
            "the per-channel modulation target needs {bytes} colour bytes per sample ({} + {} + {color:?}), the adapter allows {}",
            accum.name(),
            reveal.name(),
            caps.max_color_attachment_bytes_per_sample
        )
    })
}

/// Blend of the modulation target (the final colour, McGuire & Mara 2015): colour
/// `dst · (1 − src)` with `src = 1 − t`, so the colour behind is multiplied by each layer's
/// transmittance per channel; alpha kept.
pub const MODULATE: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::OneMinusSrc,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};

/// The composite pipeline for one final colour format and background rule.
#[derive(Debug)]
struct CompositePipeline {
    format: wgpu::TextureFormat,
    background_modulated: bool,
    pipeline: wgpu::RenderPipeline,
}

/// The accumulation and revealage textures, the composite's uniform, bind group and guard
/// counters, the cached composite pipeline and the guard-counting pipeline.
#[derive(Debug)]
pub struct AccumTargets {
    pub resolution: Resolution,
    pub mode: CompositeMode,
    pub accum_format: AccumFormat,
    pub reveal_format: RevealFormat,
    pub accum: wgpu::Texture,
    pub accum_view: wgpu::TextureView,
    pub reveal: wgpu::Texture,
    pub reveal_view: wgpu::TextureView,
    params: wgpu::Buffer,
    guards: wgpu::Buffer,
    guards_readback: wgpu::Buffer,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    pipeline: Mutex<Option<CompositePipeline>>,
    count_guards: wgpu::ComputePipeline,
    /// Unit of the colour sums, multiplied back by the composite (1 unless set).
    color_scale: f32,
    /// Whether the accumulation pass multiplied the final colour by the transmittances per
    /// channel ([`MODULATE`]); the composite then leaves the colour behind as it is.
    background_modulated: bool,
    ledger: MemoryLedger,
}

impl AccumTargets {
    /// The default targets: weighted blended, `rgba16f` accumulation, `r16f` revealage.
    pub fn new(ctx: &Context, resolution: Resolution) -> Result<Self, GpuError> {
        Self::with_formats(
            ctx,
            resolution,
            CompositeMode::Weighted,
            DEFAULT_ACCUM,
            DEFAULT_REVEAL,
        )
    }

    pub fn with_formats(
        ctx: &Context,
        resolution: Resolution,
        mode: CompositeMode,
        accum_format: AccumFormat,
        reveal_format: RevealFormat,
    ) -> Result<Self, GpuError> {
        check_formats(&ctx.caps, accum_format, reveal_format)?;
        ctx.caps.require_resolution(resolution)?;
        let mut ledger = MemoryLedger::new();
        let mut texture = |label, format| {
            ledger.create_texture_2d(
                &ctx.device,
                label,
                resolution,
                format,
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                1,
            )
        };
        let accum = texture("wboit accumulation", accum_format.texture_format());
        let reveal = texture("wboit revealage", reveal_format.texture_format());
        let params = ledger.create_buffer(
            &ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("wboit composite params"),
                size: COMPOSITE_PARAMS_BYTES,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let guard_bytes = u64::from(GUARD_SLOTS) * 4;
        let guards = ledger.create_buffer(
            &ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("wboit guard counters"),
                size: guard_bytes,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let guards_readback = ledger.create_buffer(
            &ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("wboit guard readback"),
                size: guard_bytes,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            },
        );
        let accum_view = accum.create_view(&Default::default());
        let reveal_view = reveal.create_view(&Default::default());
        // The composite (fragment) and the guard count (compute) read the same bindings; only
        // the count writes the counters.
        let both = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("wboit composite"),
            entries: &[
                bind::float_texture(0, both),
                bind::float_texture(1, both),
                bind::uniform(2, both),
                bind::storage(3, wgpu::ShaderStages::COMPUTE, false),
            ],
        });
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("wboit composite"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&accum_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&reveal_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: guards.as_entire_binding(),
                },
            ],
        });
        let count_guards = ctx.compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("wboit guard count"),
            layout: Some(&composite_layout(ctx, &layout)),
            module: &ctx.wgsl_module("wboit_composite.wgsl", COMPOSITE_WGSL),
            entry_point: Some("cs_count_guards"),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &[("AVERAGE", mode.average_constant())],
                ..Default::default()
            },
            cache: None,
        });
        Ok(AccumTargets {
            resolution,
            mode,
            accum_format,
            reveal_format,
            accum,
            accum_view,
            reveal,
            reveal_view,
            params,
            guards,
            guards_readback,
            layout,
            bind_group,
            pipeline: Mutex::new(None),
            count_guards,
            color_scale: 1.0,
            background_modulated: false,
            ledger,
        })
    }

    /// Bytes of both textures, the composite uniform and the guard counters (and their
    /// readback copy).
    pub fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    /// Bytes per pixel of the two textures alone.
    pub fn bytes_per_pixel(&self) -> u64 {
        let texel = |f: wgpu::TextureFormat| u64::from(f.block_copy_size(None).unwrap_or(0));
        texel(self.accum_format.texture_format()) + texel(self.reveal_format.texture_format())
    }

    /// Colour target states for an accumulation pipeline: location 0 additive
    /// (one, one), location 1 multiplicative revealage (zero, one-minus-src) or, for the
    /// weighted average, an additive count.
    pub fn color_targets(&self) -> [Option<wgpu::ColorTargetState>; 2] {
        let reveal = match self.mode {
            CompositeMode::Weighted => blend::MULTIPLY_ONE_MINUS_SRC,
            CompositeMode::Average => blend::ADDITIVE,
        };
        [
            Some(wgpu::ColorTargetState {
                format: self.accum_format.texture_format(),
                blend: Some(blend::ADDITIVE),
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: self.reveal_format.texture_format(),
                blend: Some(reveal),
                write_mask: wgpu::ColorWrites::ALL,
            }),
        ]
    }

    /// [`Self::color_targets`] plus the final colour (`color`) as the per-channel modulation
    /// target ([`MODULATE`]), for a pass that writes `1 − t` to location 2.
    pub fn modulating_color_targets(
        &self,
        color: wgpu::TextureFormat,
    ) -> [Option<wgpu::ColorTargetState>; 3] {
        let [accum, reveal] = self.color_targets();
        [
            accum,
            reveal,
            Some(wgpu::ColorTargetState {
                format: color,
                blend: Some(MODULATE),
                write_mask: wgpu::ColorWrites::ALL,
            }),
        ]
    }

    /// Tells [`composite`] whether the accumulation pass modulated the final colour per
    /// channel (then the colour behind is not scaled by the revealage again). Off unless set.
    pub fn set_background_modulated(&mut self, modulated: bool) {
        self.background_modulated = modulated;
    }

    pub fn background_modulated(&self) -> bool {
        self.background_modulated
    }

    /// The two colour attachments; `clear` sets accumulation to 0 and revealage to 1 (the
    /// count of the weighted average to 0), otherwise they are loaded.
    pub fn attachments(&self, clear: bool) -> [Option<wgpu::RenderPassColorAttachment<'_>>; 2] {
        let reveal_clear = match self.mode {
            CompositeMode::Weighted => 1.0,
            CompositeMode::Average => 0.0,
        };
        let load = |value: f64| {
            if clear {
                wgpu::LoadOp::Clear(pass::splat(value))
            } else {
                wgpu::LoadOp::Load
            }
        };
        [
            pass::color(&self.accum_view, load(0.0)),
            pass::color(&self.reveal_view, load(reveal_clear)),
        ]
    }

    /// The unit the accumulation pass divided the colour sums by, which [`composite`]
    /// multiplies back ([`RangeParams::color_scale`]; 1, the default, for LDR colours). A pass
    /// must accumulate with the same value it sets here.
    pub fn set_color_scale(&mut self, scale: f32) {
        self.color_scale = scale;
    }

    pub fn color_scale(&self) -> f32 {
        self.color_scale
    }

    /// For a pass that uses `wboit_weight_default` and `wboit_color_scale`: computes the scene's
    /// [`RangeParams`], sets the colour scale the composite multiplies back, and returns the
    /// override constants of [`WGSL`] for `wgpu::PipelineCompilationOptions::constants` (depth
    /// interval, fall, colour scale, projection). One call keeps the shader's colour unit and
    /// the composite's in step.
    pub fn prepare(&mut self, scene: &Scene) -> Vec<(&'static str, f64)> {
        let range = RangeParams::of(scene);
        self.set_color_scale(range.color_scale);
        let (a, b, ortho) = scene.camera.view_depth_terms();
        vec![
            ("wboit_z_near", f64::from(range.z_near)),
            ("wboit_z_far", f64::from(range.z_far)),
            ("wboit_range_fall", f64::from(range.fall)),
            ("wboit_color_scale", f64::from(range.color_scale)),
            ("wboit_proj_a", f64::from(a)),
            ("wboit_proj_b", f64::from(b)),
            ("wboit_ortho", if ortho { 1.0 } else { 0.0 }),
        ]
    }

    /// The guard counts of the last [`composite`] over these targets (waits for the GPU).
    pub fn guard_counts(&self, ctx: &Context) -> Result<GuardCounts, GpuError> {
        let words = oit_gpu::read_buffer_u32(ctx, &self.guards_readback, "wboit guard counters")?;
        Ok(GuardCounts::from_slots(&words))
    }

    fn pipeline(&self, ctx: &Context, format: wgpu::TextureFormat) -> wgpu::RenderPipeline {
        let mut cache = self.pipeline.lock().unwrap_or_else(|e| e.into_inner());
        let modulated = self.background_modulated;
        if let Some(p) = cache
            .as_ref()
            .filter(|p| p.format == format && p.background_modulated == modulated)
        {
            return p.pipeline.clone();
        }
        let module = ctx.wgsl_module("wboit_composite.wgsl", COMPOSITE_WGSL);
        let layout = composite_layout(ctx, &self.layout);
        let pipeline = oit_gpu::fullscreen_pipeline(
            ctx,
            &oit_gpu::FullscreenDesc {
                label: "wboit composite",
                layout: &layout,
                module: &module,
                fragment_entry: "fs_composite",
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(blend::TRANSMITTANCE_OVER),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: None,
                multisample: Default::default(),
                constants: &[
                    ("AVERAGE", self.mode.average_constant()),
                    ("BACKGROUND_MODULATED", f64::from(u8::from(modulated))),
                ],
            },
        );
        *cache = Some(CompositePipeline {
            format,
            background_modulated: modulated,
            pipeline: pipeline.clone(),
        });
        pipeline
    }
}

/// Bytes of the composite's uniform (`CompositeParams` in shaders/wboit_composite.wgsl).
pub const COMPOSITE_PARAMS_BYTES: u64 = 16;

/// The pipeline layout of the composite and of the guard count (group 0 only).
fn composite_layout(ctx: &Context, group: &wgpu::BindGroupLayout) -> wgpu::PipelineLayout {
    ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("wboit composite"),
        bind_group_layouts: &[Some(group)],
        immediate_size: 0,
    })
}

/// Largest average colour the composite writes into a final target of `format`: half of fp16's
/// maximum, so `avg · (1 − T) + dst · T` cannot overflow for any dst ≤ 32752.
fn out_max(format: wgpu::TextureFormat) -> f32 {
    match format {
        wgpu::TextureFormat::Rgba32Float => 1e30,
        _ => 32752.0,
    }
}

/// The composite's work per pixel (one full-screen triangle, pass "wboit composite"): the two
/// accumulation texels loaded, the final target's texel read and written by the blend. The
/// guard count that follows it is not part of the timed frame and not declared.
pub fn composite_work(
    accum: AccumFormat,
    reveal: RevealFormat,
    target: wgpu::TextureFormat,
) -> oit_gpu::PassWork {
    use oit_gpu::work::{PassDraws, PassWork, texel_bytes};
    let loads = texel_bytes(accum.texture_format()) + texel_bytes(reveal.texture_format());
    PassWork::new("wboit composite", PassDraws::FullScreen)
        .bytes(loads + texel_bytes(target), texel_bytes(target))
}

/// The accumulation's work per fragment: the depth test (read, no write) and the two additive
/// blends, each reading and writing its target's texel.
pub fn accumulate_work(name: &str, accum: AccumFormat, reveal: RevealFormat) -> oit_gpu::PassWork {
    use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, texel_bytes};
    let targets = texel_bytes(accum.texture_format()) + texel_bytes(reveal.texture_format());
    PassWork::new(name, PassDraws::Transparent).bytes(DEPTH_BYTES + targets, targets)
}

/// The guarded full-screen composite of `accum` over `targets.color` (pass "wboit composite"),
/// then, untimed ([`GpuTimer::submit_untimed`]), the guard count: a compute pass that runs the
/// composite's own per-pixel function over the same targets, counts every guard that fires and
/// copies the counts for [`AccumTargets::guard_counts`].
pub fn composite(
    ctx: &Context,
    targets: &Targets,
    accum: &AccumTargets,
    timer: &mut GpuTimer,
) -> Result<(), GpuError> {
    if targets.resolution != accum.resolution {
        return Err(GpuError::Mismatch(format!(
            "wboit accumulation targets are {} but the final colour is {}",
            accum.resolution, targets.resolution
        )));
    }
    let pipeline = accum.pipeline(ctx, targets.color_format);
    let params: [u32; 4] = [
        accum.accum_format.max_finite().to_bits(),
        out_max(targets.color_format).to_bits(),
        accum.color_scale.to_bits(),
        0,
    ];
    ctx.queue
        .write_buffer(&accum.params, 0, bytemuck::cast_slice(&params));
    let ts = timer.pass("wboit composite");
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    pass::fullscreen(
        &mut encoder,
        "wboit composite",
        &targets.color_view,
        &pipeline,
        &[(&accum.bind_group, &[])],
        &ts,
    );
    timer.submit(ctx, encoder)?;

    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.clear_buffer(&accum.guards, 0, None);
    {
        let mut count = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("wboit guard count"),
            timestamp_writes: None,
        });
        count.set_pipeline(&accum.count_guards);
        count.set_bind_group(0, &accum.bind_group, &[]);
        let res = accum.resolution;
        count.dispatch_workgroups(res.width.div_ceil(8), res.height.div_ceil(8), 1);
    }
    encoder.copy_buffer_to_buffer(
        &accum.guards,
        0,
        &accum.guards_readback,
        0,
        u64::from(GUARD_SLOTS) * 4,
    );
    timer.submit_untimed(ctx, encoder)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use oit_scene::{Camera, Projection};

    /// `view_distance` inverts the camera's own projection for every projection kind.
    #[test]
    fn view_distance_round_trips_through_the_projection() {
        for (projection, reverse_z) in [
            (
                Projection::Perspective {
                    fov_y_degrees: 45.0,
                },
                true,
            ),
            (
                Projection::Perspective {
                    fov_y_degrees: 60.0,
                },
                false,
            ),
            (Projection::Orthographic { height: 4.0 }, true),
            (Projection::Orthographic { height: 4.0 }, false),
        ] {
            let cam = Camera::new(
                Vec3::new(1.0, 2.0, 5.0),
                Vec3::ZERO,
                Vec3::Y,
                projection,
                0.1,
                100.0,
                reverse_z,
                1.5,
            );
            let forward = (cam.target - cam.eye).normalize();
            let side = forward.cross(Vec3::Y).normalize();
            for dist in [0.2f32, 1.0, 5.0, 30.0, 90.0] {
                let clip = cam.clip(cam.eye + forward * dist + side * 0.1);
                let window_z = clip.z / clip.w;
                let back = cam.view_distance(window_z);
                assert!(
                    (back - dist).abs() <= 2e-3 * dist.max(1.0),
                    "{projection:?} reverse_z={reverse_z}: {dist} -> z {window_z} -> {back}"
                );
            }
        }
    }

    #[test]
    fn formats_and_names() {
        for n in AccumFormat::WORDS {
            assert_eq!(AccumFormat::parse(n).map(AccumFormat::name), Some(*n));
        }
        for n in RevealFormat::WORDS {
            assert_eq!(RevealFormat::parse(n).map(RevealFormat::name), Some(*n));
        }
        assert_eq!(AccumFormat::parse("rgba8"), None);
        assert_eq!(
            DEFAULT_ACCUM.texture_format().block_copy_size(None),
            Some(8)
        );
        assert_eq!(
            DEFAULT_REVEAL.texture_format().block_copy_size(None),
            Some(2)
        );
    }

    #[test]
    fn the_tail_wgsl_stands_alone_and_composes() {
        // No bindings or includes of its own, so a peel shader can append it.
        assert!(!WGSL.contains("@group") && !WGSL.contains("#include"));
        for name in [
            "fn wboit_weight_default(view_z: f32, window_z: f32, alpha: f32) -> f32",
            "fn wboit_accumulate(premultiplied: vec3<f32>, alpha: f32, weight: f32, color_scale: f32) -> WboitAccum",
            "fn wboit_view_distance_default(window_z: f32) -> f32",
        ] {
            assert!(WGSL.contains(name), "{name}");
        }
        let constants = [
            "wboit_z_near",
            "wboit_z_far",
            "wboit_range_fall",
            "wboit_color_scale",
            "wboit_proj_a",
            "wboit_proj_b",
            "wboit_ortho",
        ];
        for c in constants {
            assert!(WGSL.contains(&format!("override {c}:")), "{c}");
        }
        assert!(
            crate::range::MAX_WEIGHT == 256.0 && WGSL.contains("WBOIT_RANGE_MAX: f32 = 256.0;")
        );
        assert!(
            crate::range::MAX_FALL == 21.0 && WGSL.contains("WBOIT_RANGE_MAX_FALL: f32 = 21.0;")
        );
    }
}
