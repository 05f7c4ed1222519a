//! `dual-peel`: dual depth peeling with GPU-gated termination and an optional WBOIT tail.
//!
//! Frame: clear the front accumulator; the init pass (depth-tested against the opaque depth,
//! coverage only) MAX-blends (−key, key) of every visible transparent fragment into range 0;
//! peel pass k reads range (k−1) mod 2, writes range k mod 2, under-blends its near-shell
//! fragments into the front accumulator and over-blends its far-shell fragments straight onto
//! the final colour (which holds the opaque image). Later passes need no depth test: a
//! fragment behind the opaque surface is farther than every key of the init range. After the
//! last pass: optional WBOIT tail over what is left, then front accumulator over the colour.

use crate::MAX_DUAL_PASSES;
use crate::config::{DualPeelConfig, PassCount, Tail};
use crate::encoding::KeyParams;
use crate::error::PeelError;
use crate::gpu::{self, Budget, Control, Counters, DrawList, Options, PeelReport, Termination};
use oit_gpu::bind;
use oit_gpu::blend;
use oit_gpu::pass;
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MemoryLedger, PREMULTIPLIED_OVER, RenderStats,
    ScenePipelineDesc, ScenePipelines, Targets, Technique, TechniqueSpec, Unsupported, depth_test,
};
use oit_scene::Resolution;
use oit_wboit::tail as wboit;

const EMPTY: f64 = -2.0;

/// Dual depth peeling. Build it from a spec ([`DualPeel::from_spec`]) or a config.
#[derive(Debug)]
pub struct DualPeel {
    config: Result<DualPeelConfig, PeelError>,
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
    key: (wgpu::TextureFormat, wgpu::TextureFormat, Resolution),
    ledger: MemoryLedger,
    control: Control,
    params: wgpu::Buffer,
    params_scene: Option<u64>,
    range: [wgpu::TextureView; 2],
    front: wgpu::TextureView,
    whole: Option<wgpu::TextureView>,
    /// Group 1 with `prev_range` = range[j] (and for the naive init, `whole`).
    groups: [wgpu::BindGroup; 2],
    whole_group: Option<wgpu::BindGroup>,
    group_layout: wgpu::BindGroupLayout,
    init: [ScenePipelines; 2],
    peel: ScenePipelines,
    composite_group: wgpu::BindGroup,
    front_pipeline: wgpu::RenderPipeline,
    count_pipeline: wgpu::ComputePipeline,
    count_layout: wgpu::BindGroupLayout,
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
        Self::build(Ok(config), options)
    }

    /// A spec that does not describe a dual-peel configuration gives a technique whose
    /// `check` reports the error.
    pub fn from_spec(spec: &TechniqueSpec) -> Self {
        Self::build(DualPeelConfig::from_spec(spec), Options::default())
    }

    fn build(config: Result<DualPeelConfig, PeelError>, options: Options) -> Self {
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

    pub fn config(&self) -> Result<DualPeelConfig, PeelError> {
        self.config.clone()
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
    ) -> Result<(), GpuError> {
        let key = (targets.color_format, range_format, targets.resolution);
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        self.gpu = None;
        self.list = None;
        self.tail = None;
        let device = &ctx.device;
        let mut ledger = MemoryLedger::new();
        let control = Control::new(ctx, &mut ledger)?;
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
        let accum_format = gpu::accumulator_format(ctx, targets.color_format);
        let front = gpu::texture_2d(ctx, &mut ledger, "dual-peel front", res, accum_format).1;
        let whole = (!self.options.depth_only_init).then(|| {
            gpu::texture_2d(ctx, &mut ledger, "dual-peel whole range", res, range_format).1
        });
        let fs = wgpu::ShaderStages::FRAGMENT;
        let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("dual-peel"),
            entries: &[
                bind::uniform(0, fs),
                bind::float_texture(1, fs),
                bind::storage(2, fs, false),
            ],
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
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: control.counters.as_entire_binding(),
                    },
                ],
            })
        };
        let groups = [group(&range[0]), group(&range[1])];
        let whole_group = whole.as_ref().map(group);
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("dual-peel"),
            bind_group_layouts: &[
                Some(ctx.scene_layout()),
                Some(&group_layout),
                Some(&control.pass_layout),
            ],
            immediate_size: 0,
        });
        let module = gpu::shader(ctx, "peel_dual.wgsl", gpu::PEEL_DUAL)?;
        let constants = key_constants(config, range_format, self.options.test_before_shading);
        let range_target = Some(wgpu::ColorTargetState {
            format: range_format,
            blend: Some(blend::MAX),
            write_mask: wgpu::ColorWrites::ALL,
        });
        let peel_targets = [
            range_target.clone(),
            Some(wgpu::ColorTargetState {
                format: accum_format,
                blend: Some(blend::PREMULTIPLIED_UNDER),
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: targets.color_format,
                blend: Some(PREMULTIPLIED_OVER),
                write_mask: wgpu::ColorWrites::ALL,
            }),
        ];
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
                            "fs_peel"
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
                ..ScenePipelineDesc::new("dual-peel peel", &module, "fs_peel")
            },
            &layout,
        );
        let composite_module = gpu::shader(ctx, "peel_composite.wgsl", gpu::PEEL_COMPOSITE)?;
        let composite_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("peel composite"),
            entries: &[bind::float_texture(0, fs), bind::storage(1, fs, false)],
        });
        let composite_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("dual-peel front composite"),
            layout: &composite_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&front),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: control.counters.as_entire_binding(),
                },
            ],
        });
        let composite_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("peel composite"),
                bind_group_layouts: &[Some(&composite_layout), Some(&control.pass_layout)],
                immediate_size: 0,
            });
        let front_pipeline = oit_gpu::fullscreen_pipeline(
            ctx,
            &oit_gpu::FullscreenDesc {
                label: "fs_front",
                layout: &composite_pipeline_layout,
                module: &composite_module,
                fragment_entry: "fs_front",
                targets: &[Some(wgpu::ColorTargetState {
                    format: targets.color_format,
                    blend: Some(blend::TRANSMITTANCE_OVER),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: None,
                multisample: Default::default(),
            },
        );
        let (count_layout, count_pipeline) = control.count_pipeline(
            ctx,
            "cs_count_range",
            bind::float_texture(3, wgpu::ShaderStages::COMPUTE),
        );
        self.gpu = Some(Resources {
            key,
            ledger,
            control,
            params,
            params_scene: None,
            range,
            front,
            whole,
            groups,
            whole_group,
            group_layout,
            init,
            peel,
            composite_group,
            front_pipeline,
            count_pipeline,
            count_layout,
        });
        Ok(())
    }
}

/// Override constants of shaders/peel_common.wgsl for a configuration.
fn key_constants(
    config: &DualPeelConfig,
    range_format: wgpu::TextureFormat,
    test_first: bool,
) -> Vec<(&'static str, f64)> {
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    vec![
        ("ENCODING", f64::from(config.encoding.index())),
        ("KEY_REVERSE", flag(config.reverse_z)),
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
        None,
    );
}

impl DualPeel {
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
                &[
                    pass::color(
                        &g.range[(k % 2) as usize],
                        wgpu::LoadOp::Clear(pass::splat(EMPTY)),
                    ),
                    pass::color(&g.front, wgpu::LoadOp::Load),
                    pass::color(&targets.color_view, wgpu::LoadOp::Load),
                ],
                None,
                ts.writes(),
            );
            scene.bind(&mut pass);
            pass.set_bind_group(1, &g.groups[((k + 1) % 2) as usize], &[]);
            pass.set_bind_group(2, &g.control.pass_group, &[g.control.offset(k)]);
            list.draw(&mut pass, scene, &g.peel, gated);
        }
        if gated {
            g.control.gate(&mut encoder, list, k);
        }
        timer.submit(ctx, encoder)
    }
}

impl Technique for DualPeel {
    fn spec(&self) -> TechniqueSpec {
        match &self.config {
            Ok(c) => c.spec(),
            Err(_) => TechniqueSpec {
                name: "dual-peel".to_owned(),
                params: Default::default(),
            },
        }
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        let config = self
            .config
            .as_ref()
            .map_err(|e| Unsupported::new(e.to_string()))?;
        config.depth.resolve(caps)?;
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
        Ok(())
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        let config = self
            .config
            .clone()
            .map_err(|e| Unsupported::new(e.to_string()))?;
        let range_format = config.depth.resolve(&ctx.caps)?;
        self.resources(ctx, &config, range_format, targets)?;
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
        clear_pass(
            &mut encoder,
            &g.front,
            wgpu::Color {
                r: 0.0,
                g: 0.0,
                b: 0.0,
                a: 1.0,
            },
        );
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
            let attachments = [
                pass::color(&g.range[0], wgpu::LoadOp::Clear(pass::splat(EMPTY))),
                pass::color(&g.front, wgpu::LoadOp::Load),
                pass::color(&targets.color_view, wgpu::LoadOp::Load),
            ];
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
                ts.writes(),
            );
            scene.bind(&mut pass);
            pass.set_bind_group(1, naive.unwrap_or(&g.groups[1]), &[]);
            pass.set_bind_group(2, &g.control.pass_group, &[g.control.offset(0)]);
            let init = &g.init[usize::from(scene.scene.camera.reverse_z)];
            list.draw(&mut pass, scene, init, false);
        }
        if gated {
            g.control.gate(&mut encoder, list, 0);
        }
        timer.submit(ctx, encoder)?;
        report.passes_recorded = 1;

        // Peel passes.
        let max = config.passes.budget(MAX_DUAL_PASSES);
        let mut recorded = 0u32;
        let mut counters: Option<Counters> = None;
        match self.options.termination {
            Termination::CpuReadbackPerPass => {
                // Wait for each pass's flag before recording the next.
                let mut c = g.control.read(ctx)?;
                report.readbacks += 1;
                while recorded < max && c.left(recorded) {
                    recorded += 1;
                    self.peel_pass(ctx, scene, targets, timer, recorded, false)?;
                    c = g.control.read(ctx)?;
                    report.readbacks += 1;
                }
                counters = Some(c);
            }
            Termination::GpuGated => {
                let first = match config.passes {
                    PassCount::Fixed(n) => n.min(max),
                    PassCount::Auto => self.budget.first(scene.id, 4, max),
                };
                while recorded < first {
                    recorded += 1;
                    self.peel_pass(ctx, scene, targets, timer, recorded, true)?;
                }
                if config.passes == PassCount::Auto {
                    loop {
                        let c = g.control.read(ctx)?;
                        report.readbacks += 1;
                        let more = c.left(recorded) && recorded < max;
                        counters = Some(c);
                        if !more {
                            break;
                        }
                        for _ in 0..gpu::CHUNK.min(max - recorded) {
                            recorded += 1;
                            self.peel_pass(ctx, scene, targets, timer, recorded, true)?;
                        }
                    }
                }
            }
        }
        report.passes_recorded += recorded;
        let last = (recorded % 2) as usize;
        // Known from the flags without counting: nothing was left after the last pass.
        let finished = counters.as_ref().is_some_and(|c| !c.left(recorded));

        let mut tail_recorded = false;
        if let (Some(tail), false) = (&self.tail, finished) {
            let ts = timer.pass("tail");
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let [a0, a1] = tail.accum.attachments(true);
                let mut pass = pass::begin(
                    &mut encoder,
                    "dual-peel wboit tail",
                    &[a0, a1],
                    None,
                    ts.writes(),
                );
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
        {
            let mut pass = pass::begin(
                &mut encoder,
                "dual-peel front composite",
                &[pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                None,
                ts.writes(),
            );
            pass.set_pipeline(&g.front_pipeline);
            pass.set_bind_group(0, &g.composite_group, &[]);
            pass.set_bind_group(1, &g.control.pass_group, &[0]);
            pass.draw(0..3, 0..1);
        }
        timer.submit(ctx, encoder)?;
        let counters = match counters {
            Some(c) if finished => c,
            _ => {
                report.readbacks += 1;
                g.control.read(ctx)?
            }
        };

        // Pass k > 0 rasterized only if pass k − 1 left something (the gate's rule).
        let peel_run = (1..=recorded).filter(|&k| counters.left(k - 1)).count() as u32;
        report.passes_run = 1 + peel_run;
        report.peeled_per_pass = (0..=recorded).map(|k| counters.peeled(k)).collect();
        report.dropped_pixels = if finished { 0 } else { counters.dropped() };
        let geometry_passes =
            report.passes_run + u32::from(tail_recorded && counters.left(recorded));
        if config.passes == PassCount::Auto {
            self.budget.remember(scene.id, peel_run.max(1));
        }
        let stats = RenderStats {
            geometry_passes,
            cpu_ms: 0.0,
            layers_peeled: report.peeled_per_pass.iter().map(|&n| u64::from(n)).sum(),
            pixels_with_dropped_layers: u64::from(report.dropped_pixels),
        };
        self.report = report;
        Ok(stats)
    }

    fn memory_bytes(&self) -> u64 {
        self.gpu.as_ref().map_or(0, |g| g.ledger.total())
            + self.list_ledger.total()
            + self.tail.as_ref().map_or(0, |t| t.accum.memory_bytes())
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
        let layout = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("dual-peel tail"),
                bind_group_layouts: &[
                    Some(ctx.scene_layout()),
                    Some(&g.group_layout),
                    Some(&g.control.pass_layout),
                ],
                immediate_size: 0,
            });
        let mut constants = key_constants(config, range_format, true);
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
