//! `dual-peel`: dual depth peeling with GPU-gated termination and an optional WBOIT tail.
//!
//! Frame: clear the front accumulator; the init pass (depth-tested against the opaque depth,
//! coverage only) MAX-blends (−key, key) of every visible transparent fragment into range 0;
//! peel pass k reads range (k−1) mod 2, writes range k mod 2, under-blends its near-shell
//! fragments into the front accumulator and over-blends its far-shell fragments into the back
//! accumulator (Rgba32Float, where the final colour is a lower precision the adapter can
//! replace), else straight onto the final colour (which holds the opaque image). Later passes
//! need no depth test: a fragment behind the opaque surface is farther than every key of the
//! init range. After the last pass: the back accumulator over the colour, the optional WBOIT
//! tail over what is left, then the front accumulator over the colour.
//!
//! On scenes with coloured transmission the front and back accumulators are three targets
//! each, one per colour channel (shaders/peel_transmit.wgsl): a peel pass writes seven targets,
//! because dual-source blending, which would give a per-channel factor in one target, allows a
//! single target per pass. The WBOIT tail stays scalar.

use crate::config::{DualPeelConfig, PassCount, Tail};
use crate::encoding::KeyParams;
use crate::gpu::{self, Budget, Control, Counters, DrawList, Options, PeelReport, Termination};
use oit_gpu::bind;
use oit_gpu::blend;
use oit_gpu::pass;
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MemoryLedger, PREMULTIPLIED_OVER, RenderStats,
    ScenePipelineDesc, ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec,
    Unsupported, depth_test,
};
use oit_scene::BlendOperator;
use oit_scene::Resolution;
use oit_wboit::tail as wboit;

const EMPTY: f64 = -2.0;

/// Dual depth peeling. Build it from a spec ([`DualPeel::from_spec`]) or a config.
#[derive(Debug)]
pub struct DualPeel {
    config: DualPeelConfig,
    options: Options,
    gpu: Option<Resources>,
    list: Option<DrawList>,
    list_ledger: MemoryLedger,
    tail: Option<TailPass>,
    budget: Budget,
    report: PeelReport,
}

#[derive(Debug)]
struct Resources {
    /// Final colour format, range format, accumulator format, resolution, per-channel path,
    /// the scene's depth direction (reverse-Z: the pipelines take it as a constant, so a scene
    /// of the other direction rebuilds them, and the targets with them).
    key: (
        wgpu::TextureFormat,
        wgpu::TextureFormat,
        wgpu::TextureFormat,
        Resolution,
        bool,
        bool,
    ),
    ledger: MemoryLedger,
    control: Control,
    params: wgpu::Buffer,
    params_scene: Option<u64>,
    range: [wgpu::TextureView; 2],
    whole: Option<wgpu::TextureView>,
    /// Group 1 with `prev_range` = range[j] (and for the naive init, `whole`).
    groups: [wgpu::BindGroup; 2],
    whole_group: Option<wgpu::BindGroup>,
    group_layout: wgpu::BindGroupLayout,
    init: [ScenePipelines; 2],
    peel: ScenePipelines,
    stacks: Stacks,
    count_pipeline: wgpu::ComputePipeline,
    count_layout: wgpu::BindGroupLayout,
    /// Per-pixel peeled count of the current pass (R32Float, additive), the scalar peel
    /// passes' fourth target where it fits ([`count_target_fits`]); elsewhere never written
    /// (zero), the fragments counting themselves atomically.
    peeled: wgpu::TextureView,
    count_target: bool,
    scan_pipeline: wgpu::ComputePipeline,
    /// The scan's group 0 after a pass that wrote range[j].
    scan_groups: [wgpu::BindGroup; 2],
}

/// Where the peel passes blend their near-shell and far-shell layers.
#[derive(Debug)]
enum Stacks {
    /// Scalar alpha: the front accumulator `(Σ C·T, T)` and the back accumulator (or the
    /// final colour).
    Scalar {
        front: wgpu::TextureView,
        composite_group: wgpu::BindGroup,
        front_pipeline: wgpu::RenderPipeline,
        back: Option<BackAccumulator>,
    },
    /// Coloured transmission: one under accumulator and one over accumulator per colour
    /// channel (shaders/peel_transmit.wgsl), so every peel pass writes 7 targets.
    PerChannel {
        front: Box<gpu::Channels>,
        back: Box<gpu::Channels>,
    },
}

/// Format of the per-pixel peeled count.
const COUNT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

/// Whether the scalar peel pass can write the peeled count as a fourth target (R32Float,
/// additive: exact integers, blendable only with `FLOAT32_BLENDABLE`) beside the range, front
/// and back targets of these formats. Where not, each peeled fragment counts itself with an
/// atomic (`COUNT_ATOMIC`), which costs lavapipe a large part of the pass.
fn count_target_fits(
    caps: &Caps,
    range: wgpu::TextureFormat,
    front: wgpu::TextureFormat,
    back: wgpu::TextureFormat,
) -> bool {
    let count = caps.format(COUNT_FORMAT);
    count.renderable
        && count.blendable
        && gpu::attachments_fit(
            caps,
            4,
            wboit::bytes_per_sample(&[range, front, back, COUNT_FORMAT]),
        )
}

/// Why dual peeling cannot composite coloured transmittance per channel on `caps`, if so.
fn per_channel_unsupported(caps: &Caps) -> Option<&'static str> {
    // A peel pass writes the range (up to 8 bytes), three RGBA front accumulators and three RG
    // back accumulators (up to 16 and 8 bytes each).
    (!gpu::attachments_fit(caps, 7, 80)).then_some(
        "composites 1 − mean(t) as scalar α, exact for grey filters only (the per-channel peel pass needs 7 colour attachments of 80 bytes per sample, more than this adapter allows)",
    )
}

/// Far-shell layers over-blended into an Rgba32Float target, composited onto the final colour
/// once at the end. Used where the final colour is not Rgba32Float but the adapter can blend
/// Rgba32Float: over-blending hundreds of far layers straight into an Rgba16Float target rounds
/// once per pass (measured, 16×16 screen-filling stacks at α = 2/L: max error 3.0e-3 at
/// L = 200, 1.3e-2 at L = 1000; with this target both stay below 1e-3, like front peeling).
#[derive(Debug)]
struct BackAccumulator {
    /// Premultiplied colour and coverage `(Σ over, 1 − Π(1 − α))`, cleared to 0.
    view: wgpu::TextureView,
    group: wgpu::BindGroup,
    /// `fs_front` with premultiplied OVER onto the final colour.
    pipeline: wgpu::RenderPipeline,
}

#[derive(Debug)]
struct TailPass {
    scene_id: u64,
    accum: wboit::AccumTargets,
    pipelines: ScenePipelines,
}

impl DualPeel {
    pub fn new(config: DualPeelConfig) -> Self {
        Self::with_options(config, Options::default())
    }

    pub fn with_options(config: DualPeelConfig, options: Options) -> Self {
        Self::build(config, options)
    }

    /// Refuses a spec that does not describe a dual-peel configuration.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(DualPeelConfig::from_spec(spec)?))
    }

    fn build(config: DualPeelConfig, options: Options) -> Self {
        DualPeel {
            config,
            options,
            gpu: None,
            list: None,
            list_ledger: MemoryLedger::new(),
            tail: None,
            budget: Budget::default(),
            report: PeelReport::default(),
        }
    }

    pub fn config(&self) -> DualPeelConfig {
        self.config
    }

    /// Pass-by-pass account of the last frame.
    pub fn last_report(&self) -> &PeelReport {
        &self.report
    }

    fn resources(
        &mut self,
        ctx: &Context,
        config: &DualPeelConfig,
        range_format: wgpu::TextureFormat,
        targets: &Targets,
        per_channel: bool,
        scene_reverse_z: bool,
    ) -> Result<(), GpuError> {
        let accum_format = config.accum.resolve(&ctx.caps, targets.color_format)?;
        let key = (
            targets.color_format,
            range_format,
            accum_format,
            targets.resolution,
            per_channel,
            scene_reverse_z,
        );
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        self.gpu = None;
        self.list = None;
        self.tail = None;
        let device = &ctx.device;
        let mut ledger = MemoryLedger::new();
        let control = Control::new(ctx)?;
        let params = ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("peel key params"),
                size: std::mem::size_of::<KeyParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let res = targets.resolution;
        let range = [0, 1].map(|i| {
            gpu::texture_2d(
                ctx,
                &mut ledger,
                &format!("dual-peel range {i}"),
                res,
                range_format,
            )
            .1
        });
        let transmit = if per_channel {
            Some(gpu::TransmitShader::new(ctx, &control)?)
        } else {
            None
        };
        let channels = transmit.as_ref().map(|shader| {
            [gpu::Side::Front, gpu::Side::Back].map(|side| {
                gpu::Channels::new(
                    ctx,
                    &mut ledger,
                    shader,
                    side,
                    accum_format,
                    targets.color_format,
                    res,
                )
            })
        });
        // Scalar path: far-shell layers go to a back accumulator where the final colour has
        // another (lower) precision, else straight onto the final colour.
        let scalar_back = accum_format != targets.color_format;
        let back_format = if scalar_back {
            accum_format
        } else {
            targets.color_format
        };
        let count_target =
            !per_channel && count_target_fits(&ctx.caps, range_format, accum_format, back_format);
        // Where it is no target the scan still reads it: wgpu creates it zeroed, and nothing
        // writes it (GL cannot render to R32Float at all).
        let peeled = if count_target {
            gpu::texture_2d(
                ctx,
                &mut ledger,
                "dual-peel peeled count",
                res,
                COUNT_FORMAT,
            )
            .1
        } else {
            ledger
                .create_texture_2d(
                    device,
                    "dual-peel peeled count (zero)",
                    res,
                    COUNT_FORMAT,
                    wgpu::TextureUsages::TEXTURE_BINDING,
                    1,
                )
                .create_view(&Default::default())
        };
        let whole = (!self.options.depth_only_init).then(|| {
            gpu::texture_2d(ctx, &mut ledger, "dual-peel whole range", res, range_format).1
        });
        let fs = wgpu::ShaderStages::FRAGMENT;
        let group_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("dual-peel"),
            entries: &[bind::uniform(0, fs), bind::float_texture(1, fs)],
        });
        let group = |view: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("dual-peel"),
                layout: &group_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(view),
                    },
                ],
            })
        };
        let groups = [group(&range[0]), group(&range[1])];
        let whole_group = whole.as_ref().map(group);
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("dual-peel"),
            bind_group_layouts: &[
                Some(ctx.scene_layout()),
                Some(&group_layout),
                Some(&control.pass_layout),
            ],
            immediate_size: 0,
        });
        let module = gpu::shader(ctx, "peel_dual.wgsl", gpu::PEEL_DUAL)?;
        let mut constants = key_constants(
            config,
            range_format,
            self.options.test_before_shading,
            scene_reverse_z,
        );
        constants.push(("COUNT_ATOMIC", if count_target { 0.0 } else { 1.0 }));
        let range_target = Some(wgpu::ColorTargetState {
            format: range_format,
            blend: Some(blend::MAX),
            write_mask: wgpu::ColorWrites::ALL,
        });
        let peel_targets: Vec<Option<wgpu::ColorTargetState>> = match &channels {
            Some([front, back]) => std::iter::once(range_target.clone())
                .chain(front.targets())
                .chain(back.targets())
                .collect(),
            None => vec![
                range_target.clone(),
                Some(wgpu::ColorTargetState {
                    format: accum_format,
                    blend: Some(blend::PREMULTIPLIED_UNDER),
                    write_mask: wgpu::ColorWrites::ALL,
                }),
                Some(wgpu::ColorTargetState {
                    format: back_format,
                    blend: Some(PREMULTIPLIED_OVER),
                    write_mask: wgpu::ColorWrites::ALL,
                }),
            ]
            .into_iter()
            .chain(count_target.then_some(Some(wgpu::ColorTargetState {
                format: COUNT_FORMAT,
                blend: Some(blend::ADDITIVE),
                write_mask: wgpu::ColorWrites::ALL,
            })))
            .collect(),
        };
        let peel_entry = if per_channel {
            "fs_peel_transmit"
        } else {
            "fs_peel"
        };
        let init_targets = if self.options.depth_only_init {
            std::slice::from_ref(&range_target)
        } else {
            &peel_targets[..]
        };
        // Index 0: standard depth (LESS), 1: reverse-Z (GREATER): strictly nearer than opaque.
        let init = [wgpu::CompareFunction::Less, wgpu::CompareFunction::Greater].map(|nearer| {
            ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    targets: init_targets,
                    depth: Some(depth_test(nearer, false)),
                    constants: &constants,
                    ..ScenePipelineDesc::new(
                        "dual-peel init",
                        &module,
                        if self.options.depth_only_init {
                            "fs_init"
                        } else {
                            peel_entry
                        },
                    )
                },
                &layout,
            )
        });
        let peel = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &peel_targets,
                constants: &constants,
                ..ScenePipelineDesc::new("dual-peel peel", &module, peel_entry)
            },
            &layout,
        );
        let stacks = match channels {
            Some([front, back]) => Stacks::PerChannel {
                front: Box::new(front),
                back: Box::new(back),
            },
            None => scalar_stacks(ctx, &mut ledger, &control, accum_format, targets)?,
        };
        let (count_layout, count_pipeline) = control.count_pipeline(
            ctx,
            "cs_count_range",
            bind::float_texture(3, wgpu::ShaderStages::COMPUTE),
        );
        let (scan_layout, scan_pipeline) = control.scan_pipeline(ctx, gpu::Scan::Range);
        let scan_groups = [0, 1].map(|j| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("dual-peel scan"),
                layout: &scan_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::TextureView(&range[j]),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: wgpu::BindingResource::TextureView(&peeled),
                    },
                ],
            })
        });
        self.gpu = Some(Resources {
            key,
            ledger,
            control,
            params,
            params_scene: None,
            range,
            whole,
            groups,
            whole_group,
            group_layout,
            init,
            peel,
            stacks,
            count_pipeline,
            count_layout,
            peeled,
            count_target,
            scan_pipeline,
            scan_groups,
        });
        Ok(())
    }
}

impl Resources {
    /// After pass `k` (0: the init pass), which wrote range[k mod 2]: the scan of that range
    /// and of the peeled count, then the gate where `gate` is given.
    fn scan(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        resolution: Resolution,
        gate: Option<&DrawList>,
        k: u32,
        ts: &oit_gpu::PassTimestamps,
    ) {
        let scan = (&self.scan_pipeline, &self.scan_groups[(k % 2) as usize]);
        self.control.scan(encoder, scan, resolution, gate, k, ts);
    }

    /// The attachments of a peel pass (and of the naive init) after the range: where near-shell
    /// and far-shell layers are blended (the scalar back: its accumulator, else the final
    /// colour), then the peeled count where it is a target.
    fn layer_attachments<'a>(
        &'a self,
        targets: &'a Targets,
    ) -> Vec<Option<wgpu::RenderPassColorAttachment<'a>>> {
        match &self.stacks {
            Stacks::Scalar { front, back, .. } => [
                pass::color(front, wgpu::LoadOp::Load),
                pass::color(
                    back.as_ref().map_or(&targets.color_view, |b| &b.view),
                    wgpu::LoadOp::Load,
                ),
            ]
            .into_iter()
            // Each pass counts afresh.
            .chain(
                self.count_target
                    .then(|| pass::color(&self.peeled, wgpu::LoadOp::Clear(pass::splat(0.0)))),
            )
            .collect(),
            Stacks::PerChannel { front, back } => front
                .attachments()
                .into_iter()
                .chain(back.attachments())
                .collect(),
        }
    }
}

/// The scalar path's front accumulator, its back accumulator where the final colour is not
/// `accum_format`, and their composites.
fn scalar_stacks(
    ctx: &Context,
    ledger: &mut MemoryLedger,
    control: &Control,
    accum_format: wgpu::TextureFormat,
    targets: &Targets,
) -> Result<Stacks, GpuError> {
    let device = &ctx.device;
    let fs = wgpu::ShaderStages::FRAGMENT;
    let res = targets.resolution;
    let front = gpu::texture_2d(ctx, ledger, "dual-peel front", res, accum_format).1;
    let back_view = (accum_format != targets.color_format)
        .then(|| gpu::texture_2d(ctx, ledger, "dual-peel back", res, accum_format).1);
    let composite_module = gpu::shader(ctx, "peel_composite.wgsl", gpu::PEEL_COMPOSITE)?;
    let composite_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("peel composite"),
        entries: &[bind::float_texture(0, fs)],
    });
    let composite_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("dual-peel front composite"),
        layout: &composite_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::TextureView(&front),
        }],
    });
    let composite_pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("peel composite"),
        bind_group_layouts: &[Some(&composite_layout), Some(&control.pass_layout)],
        immediate_size: 0,
    });
    let composite = |label: &str, blend: wgpu::BlendState| {
        oit_gpu::fullscreen_pipeline(
            ctx,
            &oit_gpu::FullscreenDesc {
                label,
                layout: &composite_pipeline_layout,
                module: &composite_module,
                fragment_entry: "fs_front",
                targets: &[Some(wgpu::ColorTargetState {
                    format: targets.color_format,
                    blend: Some(blend),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: None,
                multisample: Default::default(),
                constants: &[],
            },
        )
    };
    let front_pipeline = composite("dual-peel front composite", blend::TRANSMITTANCE_OVER);
    let back = back_view.map(|view| BackAccumulator {
        group: device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("dual-peel back composite"),
            layout: &composite_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            }],
        }),
        pipeline: composite("dual-peel back composite", PREMULTIPLIED_OVER),
        view,
    });
    Ok(Stacks::Scalar {
        front,
        composite_group,
        front_pipeline,
        back,
    })
}

/// Override constants of shaders/peel_common.wgsl for a configuration and a scene's depth
/// direction.
fn key_constants(
    config: &DualPeelConfig,
    range_format: wgpu::TextureFormat,
    test_first: bool,
    scene_reverse_z: bool,
) -> Vec<(&'static str, f64)> {
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    vec![
        ("ENCODING", f64::from(config.encoding.index())),
        ("KEY_REVERSE", flag(config.reverse_z)),
        ("SCENE_REVERSE_Z", flag(scene_reverse_z)),
        (
            "KEY_HALF",
            flag(range_format == wgpu::TextureFormat::Rg16Float),
        ),
        ("TEST_FIRST", flag(test_first)),
    ]
}

/// Clears `view` to `color` with an otherwise empty render pass.
fn clear_pass(encoder: &mut wgpu::CommandEncoder, view: &wgpu::TextureView, color: wgpu::Color) {
    let _ = pass::begin(
        encoder,
        "peel clear",
        &[pass::color(view, wgpu::LoadOp::Clear(color))],
        None,
        &oit_gpu::PassTimestamps::untimed(),
    );
}

impl DualPeel {
    fn control(&self) -> &Control {
        &self.gpu.as_ref().expect("resources built").control
    }

    /// Room for pass slots `0..slots` (the init pass and peel passes `1..slots`).
    fn reserve(&mut self, ctx: &Context, slots: u32) -> Result<(), GpuError> {
        self.gpu
            .as_mut()
            .expect("resources built")
            .control
            .reserve(ctx, slots)
    }

    /// Records peel pass `k` (reads range (k+1) mod 2, writes range k mod 2) and its gate.
    fn peel_pass(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
        k: u32,
        gated: bool,
    ) -> Result<(), GpuError> {
        let g = self.gpu.as_ref().expect("resources built");
        let list = self.list.as_ref().expect("draw list built");
        let ts = timer.pass(&format!("peel {k}"));
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = pass::begin(
                &mut encoder,
                "dual-peel peel",
                &std::iter::once(pass::color(
                    &g.range[(k % 2) as usize],
                    wgpu::LoadOp::Clear(pass::splat(EMPTY)),
                ))
                .chain(g.layer_attachments(targets))
                .collect::<Vec<_>>(),
                None,
                &ts,
            );
            scene.bind(&mut pass);
            pass.set_bind_group(1, &g.groups[((k + 1) % 2) as usize], &[]);
            pass.set_bind_group(2, &g.control.pass_group, &[g.control.offset(k)]);
            list.draw(&mut pass, scene, &g.peel, gated);
        }
        let ts = timer.pass(&format!("scan {k}"));
        g.scan(
            &mut encoder,
            targets.resolution,
            gated.then_some(list),
            k,
            &ts,
        );
        timer.submit(ctx, encoder)
    }
}

impl Technique for DualPeel {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn predict(
        &self,
        scene: &oit_scene::Scene,
        lists: &oit_gpu::predict::PixelLists,
        caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict_dual(self.config, scene, lists, caps)
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        let config = self.config;
        config.depth.resolve(caps)?;
        // The final colour's format does not decide whether an explicit format can blend.
        config
            .accum
            .resolve(caps, wgpu::TextureFormat::Rgba16Float)?;
        if caps.max_storage_buffers_per_shader_stage == 0 {
            return Err(Unsupported::new(
                "the adapter has no storage buffers per shader stage (materials in the vertex stage, peel counters in the fragment stage)",
            ));
        }
        if caps.max_color_attachments < 3 {
            return Err(Unsupported::new("dual peeling needs 3 colour attachments"));
        }
        if config.tail == Tail::Wboit {
            wboit::check_formats(caps, wboit::DEFAULT_ACCUM, wboit::DEFAULT_REVEAL)
                .map_err(|e| Unsupported::new(format!("tail=wboit: {}", e.reason)))?;
        }
        let (_, limit) = crate::max_pass_slots(caps);
        config
            .passes
            .check("passes", crate::max_dual_passes(caps), limit)
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        let config = self.config;
        let range_format = config.depth.resolve(&ctx.caps)?;
        // Only scenes with coloured transmission take the per-channel path: every other scene
        // renders with exactly the scalar pipelines.
        let per_channel =
            scene.scene.has_coloured_transmission() && per_channel_unsupported(&ctx.caps).is_none();
        self.resources(
            ctx,
            &config,
            range_format,
            targets,
            per_channel,
            scene.scene.camera.reverse_z,
        )?;
        if self.list.as_ref().is_none_or(|l| l.scene_id != scene.id) {
            self.list_ledger.clear();
            let control = &self.gpu.as_ref().expect("resources built").control;
            self.list = Some(DrawList::new(ctx, control, scene, &mut self.list_ledger));
        }
        if config.tail == Tail::Wboit
            && self
                .tail
                .as_ref()
                .is_none_or(|t| t.scene_id != scene.id || t.accum.resolution != targets.resolution)
        {
            self.tail = Some(self.tail_pass(ctx, scene, &config, range_format, targets)?);
        }
        let g = self.gpu.as_mut().expect("resources built");
        if g.params_scene != Some(scene.id) {
            ctx.queue.write_buffer(
                &g.params,
                0,
                bytemuck::bytes_of(&KeyParams::new(&scene.scene)),
            );
            g.params_scene = Some(scene.id);
        }
        let g = self.gpu.as_ref().expect("resources built");
        let list = self.list.as_ref().expect("draw list built");
        let gated = self.options.termination == Termination::GpuGated;
        let mut report = PeelReport::default();

        // Frame start: counters zeroed, every draw enabled, front accumulator (0, 0, 0, T = 1).
        list.reset(ctx);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        g.control.clear(&mut encoder);
        match &g.stacks {
            Stacks::Scalar { front, back, .. } => {
                clear_pass(
                    &mut encoder,
                    front,
                    wgpu::Color {
                        r: 0.0,
                        g: 0.0,
                        b: 0.0,
                        a: 1.0,
                    },
                );
                if let Some(back) = back {
                    clear_pass(&mut encoder, &back.view, pass::splat(0.0));
                }
                if g.count_target {
                    // The init pass's scan reads it (the depth-only init does not write it).
                    clear_pass(&mut encoder, &g.peeled, pass::splat(0.0));
                }
            }
            Stacks::PerChannel { front, back } => {
                front.clear(&mut encoder);
                back.clear(&mut encoder);
            }
        }
        if let Some(whole) = &g.whole {
            // The naive init reads "everything is still inside": (−(−3), 3).
            clear_pass(
                &mut encoder,
                whole,
                wgpu::Color {
                    r: 3.0,
                    g: 3.0,
                    b: 3.0,
                    a: 3.0,
                },
            );
        }
        let ts = timer.pass("init");
        {
            let naive = g.whole_group.as_ref();
            let attachments: Vec<_> = std::iter::once(pass::color(
                &g.range[0],
                wgpu::LoadOp::Clear(pass::splat(EMPTY)),
            ))
            .chain(g.layer_attachments(targets))
            .collect();
            let mut pass = pass::begin(
                &mut encoder,
                "dual-peel init",
                if naive.is_some() {
                    &attachments[..]
                } else {
                    &attachments[..1]
                },
                pass::depth(
                    &targets.depth_view,
                    wgpu::LoadOp::Load,
                    wgpu::StoreOp::Store,
                ),
                &ts,
            );
            scene.bind(&mut pass);
            pass.set_bind_group(1, naive.unwrap_or(&g.groups[1]), &[]);
            pass.set_bind_group(2, &g.control.pass_group, &[g.control.offset(0)]);
            let init = &g.init[usize::from(scene.scene.camera.reverse_z)];
            list.draw(&mut pass, scene, init, false);
        }
        let ts = timer.pass("scan 0");
        g.scan(
            &mut encoder,
            targets.resolution,
            gated.then_some(list),
            0,
            &ts,
        );
        timer.submit(ctx, encoder)?;
        report.passes_recorded = 1;

        // Peel passes: pass k uses pass slot k (the init pass slot 0); the slots grow with
        // `recorded`, and `recorded + 1` slots are read (slot `recorded` says whether anything
        // is left after the last pass).
        let max = config.passes.budget(crate::max_dual_passes(&ctx.caps));
        let mut recorded = 0u32;
        let mut counters: Option<Counters> = None;
        match self.options.termination {
            Termination::CpuReadbackPerPass => {
                // Wait for each pass's flag before recording the next.
                let mut c = self.control().read(ctx, 1)?;
                report.readbacks += 1;
                while recorded < max && c.left(recorded) {
                    recorded += 1;
                    self.reserve(ctx, recorded + 1)?;
                    self.peel_pass(ctx, scene, targets, timer, recorded, false)?;
                    c = self.control().read(ctx, recorded + 1)?;
                    report.readbacks += 1;
                }
                counters = Some(c);
            }
            Termination::GpuGated => {
                let initial = match config.passes {
                    PassCount::Fixed(n) => n.get().min(gpu::FIXED_FIRST),
                    PassCount::Auto => 4,
                };
                let mut end = self.budget.first(scene.id, initial, max);
                loop {
                    self.reserve(ctx, end + 1)?;
                    while recorded < end {
                        recorded += 1;
                        self.peel_pass(ctx, scene, targets, timer, recorded, true)?;
                    }
                    if recorded == max {
                        // Nothing more may be recorded: the counters are read once, below.
                        break;
                    }
                    let c = self.control().read(ctx, recorded + 1)?;
                    report.readbacks += 1;
                    let more = c.left(recorded);
                    counters = Some(c);
                    if !more {
                        break;
                    }
                    end = recorded.saturating_add(gpu::more_passes(recorded)).min(max);
                }
            }
        }
        let g = self.gpu.as_ref().expect("resources built");
        let list = self.list.as_ref().expect("draw list built");
        report.passes_recorded += recorded;
        let last = (recorded % 2) as usize;
        // Known from the flags without counting: nothing was left after the last pass.
        let finished = counters.as_ref().is_some_and(|c| !c.left(recorded));

        // The far layers onto the opaque image, before the tail and the front layers.
        match &g.stacks {
            Stacks::Scalar {
                back: Some(back), ..
            } => {
                let ts = timer.pass("back composite");
                let mut encoder = ctx.device.create_command_encoder(&Default::default());
                pass::fullscreen(
                    &mut encoder,
                    "dual-peel back composite",
                    &targets.color_view,
                    &back.pipeline,
                    &[(&back.group, &[]), (&g.control.pass_group, &[0])],
                    &ts,
                );
                timer.submit(ctx, encoder)?;
            }
            Stacks::Scalar { back: None, .. } => {}
            Stacks::PerChannel { back, .. } => {
                let ts = timer.pass("back composite");
                let mut encoder = ctx.device.create_command_encoder(&Default::default());
                back.composite(
                    &mut encoder,
                    "dual-peel back composite per channel",
                    &targets.color_view,
                    &g.control,
                    &ts,
                );
                timer.submit(ctx, encoder)?;
            }
        }

        let mut tail_recorded = false;
        if let (Some(tail), false) = (&self.tail, finished) {
            let ts = timer.pass("tail");
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let [a0, a1] = tail.accum.attachments(true);
                let mut pass =
                    pass::begin(&mut encoder, "dual-peel wboit tail", &[a0, a1], None, &ts);
                scene.bind(&mut pass);
                pass.set_bind_group(1, &g.groups[last], &[]);
                pass.set_bind_group(2, &g.control.pass_group, &[g.control.offset(recorded)]);
                // Gated like a peel pass: skipped on the GPU when the last pass left nothing.
                list.draw(&mut pass, scene, &tail.pipelines, gated);
            }
            timer.submit(ctx, encoder)?;
            wboit::composite(ctx, targets, &tail.accum, timer)?;
            tail_recorded = true;
        }

        let ts = timer.pass("front composite");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        if !finished {
            g.control.dispatch_count(
                ctx,
                &mut encoder,
                "dual-peel dropped count",
                (&g.count_layout, &g.count_pipeline),
                &list.grid,
                &g.range[last],
                targets.resolution,
            );
        }
        match &g.stacks {
            Stacks::Scalar {
                composite_group,
                front_pipeline,
                ..
            } => pass::fullscreen(
                &mut encoder,
                "dual-peel front composite",
                &targets.color_view,
                front_pipeline,
                &[(composite_group, &[]), (&g.control.pass_group, &[0])],
                &ts,
            ),
            Stacks::PerChannel { front, .. } => front.composite(
                &mut encoder,
                "dual-peel front composite per channel",
                &targets.color_view,
                &g.control,
                &ts,
            ),
        }
        timer.submit(ctx, encoder)?;
        let counters = match counters {
            Some(c) if finished => c,
            _ => {
                report.readbacks += 1;
                g.control.read(ctx, recorded + 1)?
            }
        };

        // Pass k > 0 rasterized only if pass k − 1 left something (the gate's rule).
        let peel_run = (1..=recorded).filter(|&k| counters.left(k - 1)).count() as u32;
        report.passes_run = 1 + peel_run;
        report.peeled_per_pass = (0..=recorded).map(|k| counters.peeled(k)).collect();
        report.dropped_pixels = if finished { 0 } else { counters.dropped() };
        report.pass_slots = g.control.capacity();
        let geometry_passes =
            report.passes_run + u32::from(tail_recorded && counters.left(recorded));
        // Next frame: the peel passes that ran (the last of them left nothing, or the budget
        // ended).
        self.budget.remember(scene.id, peel_run.max(1));
        let stats = RenderStats {
            geometry_passes,
            cpu_ms: 0.0,
            layers_peeled: report.peeled_per_pass.iter().map(|&n| u64::from(n)).sum(),
            pixels_with_dropped_layers: u64::from(report.dropped_pixels),
            pixels_with_approximated_layers: 0,
            ..Default::default()
        };
        self.report = report;
        Ok(stats)
    }

    fn memory_bytes(&self) -> u64 {
        self.gpu
            .as_ref()
            .map_or(0, |g| g.ledger.total() + g.control.memory_bytes())
            + self.list_ledger.total()
            + self.tail.as_ref().map_or(0, |t| t.accum.memory_bytes())
    }

    /// Each pass peels the nearest and the farthest layer: half the depth complexity, and one
    /// more that finds nothing left (a fixed budget stops there, plus its tail pass).
    fn work(&self, caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        // The scalar path (coloured transmission stacks per channel: more targets).
        let range_format = self.config.depth.resolve(caps).ok();
        let range = range_format.map_or(0, texel_bytes);
        let accum_format = self
            .config
            .accum
            .resolve(caps, target)
            .unwrap_or_else(|_| gpu::accumulator_format_on(caps, target));
        let accum = texel_bytes(accum_format);
        let final_texel = texel_bytes(target);
        let back_format = if accum_format != target {
            accum_format
        } else {
            target
        };
        // The peeled count's texel, where it is a target (read and written by its blend).
        let count = range_format
            .filter(|&r| count_target_fits(caps, r, accum_format, back_format))
            .map_or(0, |_| texel_bytes(COUNT_FORMAT));
        let mut passes = vec![
            // Depth tested against the opaque depth (no write); the range target's texel read
            // and written by its MAX blend (the naive init, `encoding=whole`, also writes the
            // layer targets: not counted).
            PassWork::new("init", PassDraws::Transparent).bytes(DEPTH_BYTES + range, range),
            // Every fragment the shader keeps (no depth attachment): the previous range loaded,
            // the next range read and written by MAX blending, the front and back
            // accumulators each read and written by their blends (every output blends, a
            // zero contribution included), and the peeled count's where it is a target.
            PassWork::numbered("peel ", PassDraws::Transparent)
                .bytes(2 * range + 2 * accum + count, range + 2 * accum + count),
            // After each pass (the init pass's is `scan 0`): the range it wrote and the peeled
            // count read per pixel, one atomic per workgroup; then the gate.
            PassWork::numbered("scan ", PassDraws::Compute),
            // Per pixel: the back accumulator loaded, the final texel read and written (only
            // where the final colour is not the accumulator's format; else the back layers
            // blend straight into it).
            PassWork::new("back composite", PassDraws::FullScreen)
                .bytes(accum + final_texel, final_texel),
            // Per pixel: the front accumulator loaded, the final texel read and written.
            PassWork::new("front composite", PassDraws::FullScreen)
                .bytes(accum + final_texel, final_texel),
        ];
        if self.config.tail == Tail::Wboit {
            // The fragments left inside the last range: the range loaded, the two WBOIT
            // targets read and written by their additive blends (no depth attachment).
            let accumulate =
                wboit::accumulate_work("tail", wboit::DEFAULT_ACCUM, wboit::DEFAULT_REVEAL);
            passes.push(PassWork {
                bytes_read: accumulate.bytes_read - DEPTH_BYTES + range,
                ..accumulate
            });
            passes.push(wboit::composite_work(
                wboit::DEFAULT_ACCUM,
                wboit::DEFAULT_REVEAL,
                target,
            ));
        }
        Work::new(passes)
    }

    fn planned_passes(&self, depth_complexity: u32) -> Option<u32> {
        let all = depth_complexity.div_ceil(2).saturating_add(1);
        Some(match self.config.passes {
            PassCount::Fixed(n) => n.get().min(all).saturating_add(u32::from(n.get() < all)),
            PassCount::Auto => all,
        })
    }

    fn transmission(&self, caps: &Caps) -> Support {
        if let Some(reason) = per_channel_unsupported(caps) {
            return Support::Approximate(reason);
        }
        // Peeled layers are per channel; the WBOIT tail (oit_wboit::tail) composites scalar
        // α. With `passes=auto` the tail runs only where the adapter's pass bound
        // (`max_dual_passes`, 16 777 214 on lavapipe) cut peeling short, and those pixels are
        // reported as dropped layers.
        if self.config.tail == Tail::Wboit && self.config.passes != PassCount::Auto {
            return Support::Approximate(
                "peeled layers per channel, but the layers left after the last pass go to the WBOIT tail, which composites 1 − mean(t) as scalar α (exact for grey filters only)",
            );
        }
        Support::Exact
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        match operator {
            // (P, t) with t = 1: what is behind is not dimmed.
            BlendOperator::Over | BlendOperator::Add | BlendOperator::Subtract => Support::Exact,
            // A filter without colour: coloured transmittance with P = 0.
            BlendOperator::Multiply => self.transmission(caps),
        }
    }
}

impl DualPeel {
    fn tail_pass(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        config: &DualPeelConfig,
        range_format: wgpu::TextureFormat,
        targets: &Targets,
    ) -> Result<TailPass, GpuError> {
        let g = self.gpu.as_ref().expect("resources built");
        let mut accum = wboit::AccumTargets::new(ctx, targets.resolution)?;
        let module = gpu::shader(ctx, "peel_tail.wgsl", gpu::PEEL_TAIL)?;
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("dual-peel tail"),
            bind_group_layouts: &[
                Some(ctx.scene_layout()),
                Some(&g.group_layout),
                Some(&g.control.pass_layout),
            ],
            immediate_size: 0,
        });
        let mut constants = key_constants(config, range_format, true, scene.scene.camera.reverse_z);
        constants.retain(|(k, _)| *k != "TEST_FIRST");
        constants.extend(accum.prepare(&scene.scene));
        let pipelines = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &accum.color_targets(),
                constants: &constants,
                ..ScenePipelineDesc::new("dual-peel wboit tail", &module, "fs_tail")
            },
            &layout,
        );
        Ok(TailPass {
            scene_id: scene.id,
            accum,
            pipelines,
        })
    }
}
