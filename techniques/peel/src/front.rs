//! `front-peel`: front-to-back depth peeling (Everitt 2001) with GPU-gated termination.
//!
//! Per frame, one EQUAL-depth pass over the opaque draws stores the bits of the visible opaque
//! depth in an R32Uint target. Pass k renders every transparent draw with the strictly-nearer
//! test and depth writes into its own depth target cleared to far, so the hardware keeps the
//! nearest fragment the shader kept; the shader discards fragments not strictly in front of the
//! opaque surface and not strictly behind layer k−1, whose depth bits it reads from an R32Uint
//! colour output of pass k−1 (bit-exact: all are the fragment's own `@invariant` window depth).
//! No depth-texture reads and no depth copies, so it also runs on wgpu's GL backend. The
//! layer's colour goes to a layer texture that a full-screen pass under-blends into the front
//! accumulator (and flags "layer k exists", which gates pass k+1); after the last pass the
//! accumulator goes over the final colour. When the layer budget may have cut layers off, one
//! more (gated) pass detects them for `pixels_with_dropped_layers`. Equal-depth fragments are
//! one layer: the first drawn wins (strict test in draw order) and the others are lost,
//! deterministically.
//!
//! On scenes with coloured transmission the layer pass also writes the layer's rgb
//! transmittance, and the under pass blends the layer into three accumulators, one per colour
//! channel (`F_c += T_c·C_c`, `T_c *= t_c`; shaders/peel_transmit.wgsl), which go over the final
//! colour as `dst = F + T ⊙ dst`. Every other scene renders with the scalar pipelines.

use crate::config::{FrontPeelConfig, PassCount};
use crate::encoding::KeyParams;
use crate::gpu::{self, Budget, Control, Counters, DrawList, Options, PeelReport, Termination};
use oit_gpu::bind;
use oit_gpu::blend;
use oit_gpu::pass;
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MemoryLedger, RenderStats, ScenePipelineDesc,
    ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec, Unsupported, depth_test,
};
use oit_scene::BlendOperator;
use oit_scene::Resolution;

/// Front-to-back depth peeling.
#[derive(Debug)]
pub struct FrontPeel {
    config: FrontPeelConfig,
    options: Options,
    gpu: Option<Resources>,
    list: Option<DrawList>,
    list_ledger: MemoryLedger,
    budget: Budget,
    report: PeelReport,
}

impl FrontPeel {
    pub fn new(config: FrontPeelConfig) -> Self {
        Self::with_options(config, Options::default())
    }

    pub fn with_options(config: FrontPeelConfig, options: Options) -> Self {
        Self::build(config, options)
    }

    /// Refuses a spec that does not describe a front-peel configuration.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(FrontPeelConfig::from_spec(spec)?))
    }

    fn build(config: FrontPeelConfig, options: Options) -> Self {
        FrontPeel {
            config,
            options,
            gpu: None,
            list: None,
            list_ledger: MemoryLedger::new(),
            budget: Budget::default(),
            report: PeelReport::default(),
        }
    }

    pub fn config(&self) -> FrontPeelConfig {
        self.config
    }

    /// Pass-by-pass account of the last frame.
    pub fn last_report(&self) -> &PeelReport {
        &self.report
    }
}

#[derive(Debug)]
struct Resources {
    /// Final colour format, resolution, reverse-Z, per-channel path.
    key: (wgpu::TextureFormat, Resolution, bool, bool),
    ledger: MemoryLedger,
    control: Control,
    params: wgpu::Buffer,
    params_scene: Option<u64>,
    /// Depth target of the layer passes (cleared to far each pass).
    depth: wgpu::TextureView,
    /// Bits of the visible opaque depth (R32Uint).
    opaque_bits: wgpu::TextureView,
    /// Group-0-only pipelines of `fs_opaque_bits` (EQUAL against the shared opaque depth).
    opaque_pipelines: ScenePipelines,
    /// Bits of layer k's window depth in `prev[k % 2]` (cleared to the far plane).
    prev: [wgpu::TextureView; 2],
    layer: wgpu::TextureView,
    /// Group 1 with `prev_depth` = prev[j].
    groups: [wgpu::BindGroup; 2],
    /// `[first layer]`.
    layer_pipelines: [ScenePipelines; 2],
    under: Under,
    count_pipeline: wgpu::ComputePipeline,
    count_layout: wgpu::BindGroupLayout,
    /// `cs_scan_layer` over `layer` after each under pass: the pass's flag and count.
    scan_pipeline: wgpu::ComputePipeline,
    scan_group: wgpu::BindGroup,
}

/// How peeled layers are accumulated and put over the final colour.
#[derive(Debug)]
enum Under {
    /// Scalar alpha: one accumulator `(Σ C·T, T)`, under-blended by `fs_under`.
    Scalar {
        accum: wgpu::TextureView,
        under_group: wgpu::BindGroup,
        final_group: wgpu::BindGroup,
        under_pipeline: wgpu::RenderPipeline,
        front_pipeline: wgpu::RenderPipeline,
    },
    /// Coloured transmission: the layer pass also writes the layer's rgb transmittance to
    /// `layer_t`, and `fs_under_transmit` under-blends the layer into one accumulator per
    /// colour channel (shaders/peel_transmit.wgsl).
    PerChannel {
        layer_t: wgpu::TextureView,
        accum: Box<gpu::Channels>,
        under_group: wgpu::BindGroup,
        under_pipeline: wgpu::RenderPipeline,
    },
}

/// Why front peeling cannot composite coloured transmittance per channel on `caps`, if so.
fn per_channel_unsupported(caps: &Caps) -> Option<&'static str> {
    // The under pass writes three RGBA accumulators of up to 16 bytes each; the layer pass
    // three targets (layer, depth bits, transmittance).
    (!gpu::attachments_fit(caps, 3, 48)).then_some(
        "composites 1 − mean(t) as scalar α, exact for grey filters only (the per-channel under-blend needs 3 colour attachments of 48 bytes per sample, more than this adapter allows)",
    )
}

/// What a layer pass does besides rendering its layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PassRole {
    /// Under-blend the layer into the accumulator (a peel pass).
    Peel,
    /// Leave the layer in its texture for the dropped-pixel count (the detection pass).
    Detect,
}

impl FrontPeel {
    fn resources(
        &mut self,
        ctx: &Context,
        targets: &Targets,
        reverse_z: bool,
        per_channel: bool,
    ) -> Result<(), GpuError> {
        let key = (
            targets.color_format,
            targets.resolution,
            reverse_z,
            per_channel,
        );
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        self.gpu = None;
        self.list = None;
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
        let depth_texture = ledger.create_texture_2d(
            device,
            "front-peel depth",
            res,
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
            1,
        );
        let depth = depth_texture.create_view(&Default::default());
        let opaque_bits = gpu::texture_2d(
            ctx,
            &mut ledger,
            "front-peel opaque depth bits",
            res,
            wgpu::TextureFormat::R32Uint,
        )
        .1;
        let prev = [0, 1].map(|i| {
            gpu::texture_2d(
                ctx,
                &mut ledger,
                &format!("front-peel layer depth {i}"),
                res,
                wgpu::TextureFormat::R32Uint,
            )
            .1
        });
        let accum_format = gpu::accumulator_format(ctx, targets.color_format);
        let layer = gpu::texture_2d(ctx, &mut ledger, "front-peel layer", res, accum_format).1;
        let fs = wgpu::ShaderStages::FRAGMENT;
        let uint_texture = |binding| bind::texture(binding, fs, wgpu::TextureSampleType::Uint);
        let group_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("front-peel"),
            entries: &[bind::uniform(0, fs), uint_texture(1), uint_texture(3)],
        });
        let groups = [0, 1].map(|j| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("front-peel"),
                layout: &group_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&prev[j]),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::TextureView(&opaque_bits),
                    },
                ],
            })
        });
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("front-peel"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&group_layout)],
            immediate_size: 0,
        });
        let module = gpu::shader(ctx, "peel_front.wgsl", gpu::PEEL_FRONT)?;
        let unblended = |format| {
            Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        // Layer, its depth bits, and on the per-channel path its transmittance.
        let layer_targets = [
            unblended(accum_format),
            unblended(wgpu::TextureFormat::R32Uint),
            unblended(accum_format),
        ];
        let (layer_targets, layer_entry) = if per_channel {
            (&layer_targets[..], "fs_layer_transmit")
        } else {
            (&layer_targets[..2], "fs_layer")
        };
        let nearer = if reverse_z {
            wgpu::CompareFunction::Greater
        } else {
            wgpu::CompareFunction::Less
        };
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let test_first = self.options.test_before_shading;
        let layer_pipelines = [false, true].map(|first| {
            ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    targets: layer_targets,
                    depth: Some(depth_test(nearer, true)),
                    constants: &[
                        ("FIRST_LAYER", flag(first)),
                        ("TEST_FIRST", flag(test_first)),
                        ("SCENE_REVERSE_Z", flag(reverse_z)),
                    ],
                    ..ScenePipelineDesc::new("front-peel layer", &module, layer_entry)
                },
                &layout,
            )
        });
        let opaque_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("front-peel opaque depth bits"),
            bind_group_layouts: &[Some(ctx.scene_layout())],
            immediate_size: 0,
        });
        let opaque_pipelines = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &[layer_targets[1].clone()],
                depth: Some(depth_test(wgpu::CompareFunction::Equal, false)),
                constants: &[("SCENE_REVERSE_Z", flag(reverse_z))],
                ..ScenePipelineDesc::new("front-peel opaque depth bits", &module, "fs_opaque_bits")
            },
            &opaque_layout,
        );
        let under = if per_channel {
            let shader = gpu::TransmitShader::new(ctx, &control)?;
            let layer_t = gpu::texture_2d(
                ctx,
                &mut ledger,
                "front-peel layer transmittance",
                res,
                accum_format,
            )
            .1;
            let accum = Box::new(gpu::Channels::new(
                ctx,
                &mut ledger,
                &shader,
                gpu::Side::Front,
                accum_format,
                targets.color_format,
                res,
            ));
            Under::PerChannel {
                under_group: shader.group(ctx, [&layer, &layer_t, &layer_t]),
                under_pipeline: shader.pipeline(ctx, "fs_under_transmit", &accum.targets()),
                layer_t,
                accum,
            }
        } else {
            Self::scalar_under(ctx, &mut ledger, &control, &layer, accum_format, targets)?
        };
        let (count_layout, count_pipeline) = control.count_pipeline(
            ctx,
            "cs_count_layer",
            bind::float_texture(3, wgpu::ShaderStages::COMPUTE),
        );
        let (scan_layout, scan_pipeline) = control.scan_pipeline(ctx, gpu::Scan::Layer);
        let scan_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("front-peel scan"),
            layout: &scan_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::TextureView(&layer),
            }],
        });
        self.gpu = Some(Resources {
            key,
            ledger,
            control,
            params,
            params_scene: None,
            depth,
            opaque_bits,
            opaque_pipelines,
            prev,
            layer,
            groups,
            layer_pipelines,
            under,
            count_pipeline,
            count_layout,
            scan_pipeline,
            scan_group,
        });
        Ok(())
    }

    /// The scalar-alpha accumulator of `layer` and its two full-screen passes.
    fn scalar_under(
        ctx: &Context,
        ledger: &mut MemoryLedger,
        control: &Control,
        layer: &wgpu::TextureView,
        accum_format: wgpu::TextureFormat,
        targets: &Targets,
    ) -> Result<Under, GpuError> {
        let device = &ctx.device;
        let fs = wgpu::ShaderStages::FRAGMENT;
        let accum = gpu::texture_2d(
            ctx,
            ledger,
            "front-peel accumulator",
            targets.resolution,
            accum_format,
        )
        .1;
        let composite_module = gpu::shader(ctx, "peel_composite.wgsl", gpu::PEEL_COMPOSITE)?;
        let composite_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("peel composite"),
            entries: &[bind::float_texture(0, fs)],
        });
        let composite_group = |view: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("front-peel composite"),
                layout: &composite_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(view),
                }],
            })
        };
        let under_group = composite_group(layer);
        let final_group = composite_group(&accum);
        let composite_pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("peel composite"),
            bind_group_layouts: &[Some(&composite_layout), Some(&control.pass_layout)],
            immediate_size: 0,
        });
        let fullscreen = |entry: &str, format: wgpu::TextureFormat, blend: wgpu::BlendState| {
            oit_gpu::fullscreen_pipeline(
                ctx,
                &oit_gpu::FullscreenDesc {
                    label: entry,
                    layout: &composite_pipeline_layout,
                    module: &composite_module,
                    fragment_entry: entry,
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: Some(blend),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                    depth: None,
                    multisample: Default::default(),
                    constants: &[],
                },
            )
        };
        Ok(Under::Scalar {
            under_pipeline: fullscreen("fs_under", accum_format, blend::PREMULTIPLIED_UNDER),
            front_pipeline: fullscreen("fs_front", targets.color_format, blend::TRANSMITTANCE_OVER),
            accum,
            under_group,
            final_group,
        })
    }

    fn control(&self) -> &Control {
        &self.gpu.as_ref().expect("resources built").control
    }

    /// Room for pass slots `0..slots` (layer passes `0..slots`).
    fn reserve(&mut self, ctx: &Context, slots: u32) -> Result<(), GpuError> {
        self.gpu
            .as_mut()
            .expect("resources built")
            .control
            .reserve(ctx, slots)
    }

    /// Records layer pass `k` (0-based): opaque depth copy, the layer, then (peel) its
    /// under-composite and gate.
    fn layer_pass(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        timer: &mut GpuTimer,
        k: u32,
        role: PassRole,
        gated: bool,
    ) -> Result<(), GpuError> {
        let g = self.gpu.as_ref().expect("resources built");
        let list = self.list.as_ref().expect("draw list built");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let ts = timer.pass(&match role {
            PassRole::Peel => format!("layer {}", k + 1),
            PassRole::Detect => "detect".to_owned(),
        });
        // The far plane's f32 bits (exact in f64): no later fragment is "behind" it.
        let far = f64::from(scene.scene.camera.far_depth().to_bits());
        {
            let layer_t = match &g.under {
                // Read only where the layer exists, i.e. where this pass wrote it.
                Under::PerChannel { layer_t, .. } => {
                    pass::color(layer_t, wgpu::LoadOp::Clear(pass::splat(1.0)))
                }
                Under::Scalar { .. } => None,
            };
            let attachments = [
                Some(wgpu::RenderPassColorAttachment {
                    view: &g.layer,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        // Alpha −1 marks "no fragment" for the composite and the count.
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: 0.0,
                            g: 0.0,
                            b: 0.0,
                            a: -1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                }),
                Some(wgpu::RenderPassColorAttachment {
                    view: &g.prev[(k % 2) as usize],
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        // Far: no later fragment is "behind" a pixel without a layer.
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: far,
                            g: far,
                            b: far,
                            a: far,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                }),
                layer_t,
            ];
            let used = if attachments[2].is_some() { 3 } else { 2 };
            let mut pass = pass::begin(
                &mut encoder,
                "front-peel layer",
                &attachments[..used],
                pass::depth(
                    &g.depth,
                    wgpu::LoadOp::Clear(scene.scene.camera.far_depth()),
                    wgpu::StoreOp::Discard,
                ),
                &ts,
            );
            scene.bind(&mut pass);
            pass.set_bind_group(1, &g.groups[((k + 1) % 2) as usize], &[]);
            list.draw(
                &mut pass,
                scene,
                &g.layer_pipelines[usize::from(k == 0)],
                gated,
            );
        }
        if role == PassRole::Peel {
            let ts = timer.pass(&format!("under {}", k + 1));
            let offset = g.control.offset(k);
            match &g.under {
                Under::Scalar {
                    accum,
                    under_group,
                    under_pipeline,
                    ..
                } => pass::fullscreen(
                    &mut encoder,
                    "front-peel under",
                    accum,
                    under_pipeline,
                    &[(under_group, &[]), (&g.control.pass_group, &[offset])],
                    &ts,
                ),
                Under::PerChannel {
                    accum,
                    under_group,
                    under_pipeline,
                    ..
                } => {
                    let mut pass = pass::begin(
                        &mut encoder,
                        "front-peel under per channel",
                        &accum.attachments(),
                        None,
                        &ts,
                    );
                    pass.set_pipeline(under_pipeline);
                    pass.set_bind_group(0, under_group, &[]);
                    pass.set_bind_group(1, &g.control.pass_group, &[offset]);
                    pass.draw(0..3, 0..1);
                }
            }
            let ts = timer.pass(&format!("scan {}", k + 1));
            g.control.scan(
                &mut encoder,
                (&g.scan_pipeline, &g.scan_group),
                g.key.1,
                gated.then_some(list),
                k,
                &ts,
            );
        }
        timer.submit(ctx, encoder)
    }
}

impl Technique for FrontPeel {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn predict(
        &self,
        _scene: &oit_scene::Scene,
        lists: &oit_gpu::predict::PixelLists,
        _caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict_front(self.config, lists)
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        if caps.max_storage_buffers_per_shader_stage == 0 {
            return Err(Unsupported::new(
                "the adapter has no storage buffers per shader stage (materials in the vertex stage, peel counters in the fragment stage)",
            ));
        }
        if caps.max_color_attachments < 2 {
            return Err(Unsupported::new("front peeling needs 2 colour attachments"));
        }
        let (_, limit) = crate::max_pass_slots(caps);
        self.config
            .layers
            .check("layers", crate::max_front_layers(caps), limit)
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        let config = self.config;
        // Only scenes with coloured transmission take the per-channel path: every other scene
        // renders with exactly the scalar pipelines.
        let per_channel =
            scene.scene.has_coloured_transmission() && per_channel_unsupported(&ctx.caps).is_none();
        self.resources(ctx, targets, scene.scene.camera.reverse_z, per_channel)?;
        if self.list.as_ref().is_none_or(|l| l.scene_id != scene.id) {
            self.list_ledger.clear();
            let control = &self.gpu.as_ref().expect("resources built").control;
            self.list = Some(DrawList::new(ctx, control, scene, &mut self.list_ledger));
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
        let max = config.layers.budget(crate::max_front_layers(&ctx.caps));
        let gated = self.options.termination == Termination::GpuGated;
        let mut report = PeelReport::default();

        list.reset(ctx);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        g.control.clear(&mut encoder);
        match &g.under {
            Under::Scalar { accum, .. } => {
                let _ = pass::begin(
                    &mut encoder,
                    "front-peel clear",
                    &[pass::color(
                        accum,
                        wgpu::LoadOp::Clear(wgpu::Color {
                            r: 0.0,
                            g: 0.0,
                            b: 0.0,
                            a: 1.0,
                        }),
                    )],
                    None,
                    &oit_gpu::PassTimestamps::untimed(),
                );
            }
            Under::PerChannel { accum, .. } => accum.clear(&mut encoder),
        }
        let far_bits = f64::from(scene.scene.camera.far_depth().to_bits());
        let ts = timer.pass("opaque depth bits");
        {
            let mut pass = pass::begin(
                &mut encoder,
                "front-peel opaque depth bits",
                &[pass::color(
                    &g.opaque_bits,
                    wgpu::LoadOp::Clear(wgpu::Color {
                        r: far_bits,
                        g: far_bits,
                        b: far_bits,
                        a: far_bits,
                    }),
                )],
                pass::depth(
                    &targets.depth_view,
                    wgpu::LoadOp::Load,
                    wgpu::StoreOp::Store,
                ),
                &ts,
            );
            scene.bind(&mut pass);
            for i in scene.opaque_draws() {
                scene.draw(&mut pass, &g.opaque_pipelines, i);
            }
        }
        timer.submit(ctx, encoder)?;

        // Layer pass k uses pass slot k; the slots grow with `recorded`.
        let mut recorded = 0u32;
        let mut counters: Option<Counters> = None;
        if gated {
            let initial = match config.layers {
                PassCount::Fixed(n) => n.get().min(gpu::FIXED_FIRST),
                PassCount::Auto => 8,
            };
            let mut end = self.budget.first(scene.id, initial, max);
            loop {
                self.reserve(ctx, end)?;
                while recorded < end {
                    self.layer_pass(ctx, scene, timer, recorded, PassRole::Peel, true)?;
                    recorded += 1;
                }
                if recorded == max {
                    // Nothing more may be recorded: the counters are read once, below.
                    break;
                }
                let c = self.control().read(ctx, recorded)?;
                report.readbacks += 1;
                let more = c.left(recorded - 1);
                counters = Some(c);
                if !more {
                    break;
                }
                end = recorded.saturating_add(gpu::more_passes(recorded)).min(max);
            }
        } else {
            loop {
                self.reserve(ctx, recorded + 1)?;
                self.layer_pass(ctx, scene, timer, recorded, PassRole::Peel, false)?;
                recorded += 1;
                let c = self.control().read(ctx, recorded)?;
                report.readbacks += 1;
                let more = recorded < max && c.left(recorded - 1);
                counters = Some(c);
                if !more {
                    break;
                }
            }
        }
        let g = self.gpu.as_ref().expect("resources built");
        let list = self.list.as_ref().expect("draw list built");
        // Known from the flags: the last pass found no layer, so nothing was cut off.
        let finished = counters.as_ref().is_some_and(|c| !c.left(recorded - 1));
        let detect = !finished;
        let ts = timer.pass("front composite");
        if detect {
            // Gated like a peel pass: skipped on the GPU when the last pass found no layer.
            self.layer_pass(ctx, scene, timer, recorded, PassRole::Detect, gated)?;
        }
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        if detect {
            g.control.dispatch_count(
                ctx,
                &mut encoder,
                "front-peel dropped count",
                (&g.count_layout, &g.count_pipeline),
                &list.grid,
                &g.layer,
                targets.resolution,
            );
        }
        match &g.under {
            Under::Scalar {
                final_group,
                front_pipeline,
                ..
            } => pass::fullscreen(
                &mut encoder,
                "front-peel composite",
                &targets.color_view,
                front_pipeline,
                &[(final_group, &[]), (&g.control.pass_group, &[0])],
                &ts,
            ),
            Under::PerChannel { accum, .. } => accum.composite(
                &mut encoder,
                "front-peel composite per channel",
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
                g.control.read(ctx, recorded)?
            }
        };

        // Pass k > 0 (the detection pass included) rasterized only if layer k − 1 exists.
        let total = recorded + u32::from(detect);
        let run = 1 + (1..total).filter(|&k| counters.left(k - 1)).count() as u32;
        report.passes_recorded = total;
        // The opaque-depth pass rasterizes (opaque) scene geometry too.
        report.passes_run = run + 1;
        report.peeled_per_pass = (0..recorded).map(|k| counters.peeled(k)).collect();
        report.dropped_pixels = if finished { 0 } else { counters.dropped() };
        report.pass_slots = g.control.capacity();
        // Next frame: the passes that ran (the last of them found nothing, or the budget ended).
        self.budget.remember(scene.id, recorded.min(run));
        let stats = RenderStats {
            geometry_passes: run + 1,
            cpu_ms: 0.0,
            layers_peeled: report.peeled_per_pass.iter().map(|&n| u64::from(n)).sum(),
            pixels_with_dropped_layers: u64::from(report.dropped_pixels),
            pixels_with_approximated_layers: 0,
            ..Default::default()
        };
        self.report = report;
        Ok(stats)
    }

    fn work(&self, caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        // The scalar path (coloured transmission adds a layer-transmittance target).
        let layer = texel_bytes(gpu::accumulator_format_on(caps, target));
        let final_texel = texel_bytes(target);
        // R32Uint depth bits: the previous layer's and the opaque surface's.
        const BITS: u32 = 4;
        // A fragment behind the previous layer that passes the pass's own nearest-first depth
        // test (a later nearer one passes again): its depth tested and written, both depth
        // bits loaded, the layer colour and its depth bits written without blending.
        let layer_pass = |p: PassWork| p.bytes(DEPTH_BYTES + 2 * BITS, DEPTH_BYTES + layer + BITS);
        Work::new(vec![
            // The opaque draws once more: depth tested against the opaque pass's (no write),
            // their depth bits written.
            PassWork::new("opaque depth bits", PassDraws::Opaque).bytes(DEPTH_BYTES, BITS),
            layer_pass(PassWork::numbered("layer ", PassDraws::Transparent)),
            // The pass after the last layer's cap, to find pixels with layers left.
            layer_pass(PassWork::new("detect", PassDraws::Transparent)),
            // Per pixel with a layer: the layer loaded, the accumulator read and written by
            // the under blend.
            PassWork::numbered("under ", PassDraws::FullScreen).bytes(2 * layer, layer),
            // After each under pass: the layer texture read per pixel, one atomic per
            // workgroup per counter; then the gate.
            PassWork::numbered("scan ", PassDraws::Compute),
            // Per pixel: the accumulator loaded, the final texel read and written by the blend.
            PassWork::new("front composite", PassDraws::FullScreen)
                .bytes(layer + final_texel, final_texel),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.gpu
            .as_ref()
            .map_or(0, |g| g.ledger.total() + g.control.memory_bytes())
            + self.list_ledger.total()
    }

    /// One pass per layer, and one more that finds nothing left (or, with a fixed budget
    /// below the depth complexity, the detection pass that counts what was dropped).
    fn planned_passes(&self, depth_complexity: u32) -> Option<u32> {
        let all = depth_complexity.saturating_add(1);
        Some(match self.config.layers {
            PassCount::Fixed(n) => n.get().min(all).saturating_add(u32::from(n.get() < all)),
            PassCount::Auto => all,
        })
    }

    fn transmission(&self, caps: &Caps) -> Support {
        // Per channel: one under accumulator per colour channel (`Under::PerChannel`).
        match per_channel_unsupported(caps) {
            None => Support::Exact,
            Some(reason) => Support::Approximate(reason),
        }
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
