//! `front-peel`: front-to-back depth peeling (Everitt 2001) with GPU-gated termination.
//!
//! Pass k renders every transparent draw with the hardware depth test (strictly nearer, depth
//! written) into depth k mod 2 cleared to the far plane; the shader discards fragments not
//! strictly in front of the opaque depth and not strictly behind depth (k−1) mod 2, so the
//! test keeps the k-th nearest surface. Its colour goes to a layer texture that a full-screen
//! pass under-blends into the front accumulator; after the last pass the accumulator goes over
//! the final colour. Equal-depth fragments are one layer: the first drawn wins (strict depth
//! test in draw order) and the others are lost, deterministically.

use crate::MAX_FRONT_LAYERS;
use crate::config::{FrontPeelConfig, PassCount};
use crate::encoding::KeyParams;
use crate::error::PeelError;
use crate::gpu::{
    self, Budget, Control, Counters, DrawList, Options, PeelReport, PipelineDesc, Termination,
};
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MemoryLedger, RenderStats, ScenePipelines,
    Targets, Technique, TechniqueSpec, Unsupported,
};
use oit_scene::Resolution;

/// Front-to-back depth peeling.
#[derive(Debug)]
pub struct FrontPeel {
    config: Result<FrontPeelConfig, PeelError>,
    options: Options,
    gpu: Option<Resources>,
    list: Option<DrawList>,
    list_ledger: MemoryLedger,
    budget: Budget,
    report: PeelReport,
}

#[derive(Debug)]
struct Resources {
    key: (wgpu::TextureFormat, Resolution, bool),
    ledger: MemoryLedger,
    control: Control,
    params: wgpu::Buffer,
    params_scene: Option<u64>,
    depth: [wgpu::TextureView; 2],
    layer: wgpu::TextureView,
    accum: wgpu::TextureView,
    candidates: wgpu::Buffer,
    group_layout: wgpu::BindGroupLayout,
    /// `[first layer][count candidates]`.
    layer_pipelines: [[ScenePipelines; 2]; 2],
    under_group: wgpu::BindGroup,
    final_group: wgpu::BindGroup,
    under_pipeline: wgpu::RenderPipeline,
    front_pipeline: wgpu::RenderPipeline,
    count_pipeline: wgpu::ComputePipeline,
    count_layout: wgpu::BindGroupLayout,
}

impl FrontPeel {
    pub fn new(config: FrontPeelConfig) -> Self {
        Self::with_options(config, Options::default())
    }

    pub fn with_options(config: FrontPeelConfig, options: Options) -> Self {
        Self::build(Ok(config), options)
    }

    /// A spec that does not describe a front-peel configuration gives a technique whose
    /// `check` reports the error.
    pub fn from_spec(spec: &TechniqueSpec) -> Self {
        Self::build(FrontPeelConfig::from_spec(spec), Options::default())
    }

    fn build(config: Result<FrontPeelConfig, PeelError>, options: Options) -> Self {
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

    pub fn config(&self) -> Result<FrontPeelConfig, PeelError> {
        self.config.clone()
    }

    /// Pass-by-pass account of the last frame.
    pub fn last_report(&self) -> &PeelReport {
        &self.report
    }

    fn resources(
        &mut self,
        ctx: &Context,
        targets: &Targets,
        reverse_z: bool,
    ) -> Result<(), GpuError> {
        let key = (targets.color_format, targets.resolution, reverse_z);
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        self.gpu = None;
        self.list = None;
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
        let depth = [0, 1].map(|i| {
            gpu::texture_2d(
                ctx,
                &mut ledger,
                &format!("front-peel depth {i}"),
                res,
                wgpu::TextureFormat::Depth32Float,
            )
            .1
        });
        let layer = gpu::texture_2d(
            ctx,
            &mut ledger,
            "front-peel layer",
            res,
            targets.color_format,
        )
        .1;
        let accum = gpu::texture_2d(
            ctx,
            &mut ledger,
            "front-peel accumulator",
            res,
            targets.color_format,
        )
        .1;
        let candidates = ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("front-peel candidates"),
                size: res.pixel_count() as u64 * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let fs = wgpu::ShaderStages::FRAGMENT;
        let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("front-peel"),
            entries: &[
                gpu::uniform_entry(0, fs, false),
                gpu::texture_entry(1, fs, true),
                gpu::storage_entry(2, fs),
                gpu::texture_entry(3, fs, true),
                gpu::storage_entry(4, fs),
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("front-peel"),
            bind_group_layouts: &[
                Some(ctx.scene_layout()),
                Some(&group_layout),
                Some(&control.pass_layout),
            ],
            immediate_size: 0,
        });
        let module = gpu::shader(ctx, "peel_front.wgsl", gpu::PEEL_FRONT)?;
        let target = [Some(wgpu::ColorTargetState {
            format: targets.color_format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let nearer = if reverse_z {
            wgpu::CompareFunction::Greater
        } else {
            wgpu::CompareFunction::Less
        };
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let test_first = self.options.test_before_shading;
        let layer_pipelines = [false, true].map(|first| {
            [false, true].map(|count| {
                gpu::scene_pipelines(
                    ctx,
                    &PipelineDesc {
                        label: "front-peel layer",
                        module: &module,
                        layout: &layout,
                        fragment_entry: "fs_layer",
                        targets: &target,
                        depth: Some(wgpu::DepthStencilState {
                            format: wgpu::TextureFormat::Depth32Float,
                            depth_write_enabled: Some(true),
                            depth_compare: Some(nearer),
                            stencil: Default::default(),
                            bias: Default::default(),
                        }),
                        constants: &[
                            ("FIRST_LAYER", flag(first)),
                            ("COUNT_CANDIDATES", flag(count)),
                            ("TEST_FIRST", flag(test_first)),
                        ],
                    },
                )
            })
        });
        let composite_module = gpu::shader(ctx, "peel_composite.wgsl", gpu::PEEL_COMPOSITE)?;
        let composite_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("peel composite"),
            entries: &[gpu::texture_entry(0, fs, false), gpu::storage_entry(1, fs)],
        });
        let composite_group = |view: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("front-peel composite"),
                layout: &composite_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: control.counters.as_entire_binding(),
                    },
                ],
            })
        };
        let under_group = composite_group(&layer);
        let final_group = composite_group(&accum);
        let composite_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("peel composite"),
                bind_group_layouts: &[Some(&composite_layout), Some(&control.pass_layout)],
                immediate_size: 0,
            });
        let fullscreen = |entry: &str, blend: wgpu::BlendState| {
            gpu::fullscreen_pipeline(
                ctx,
                &composite_module,
                &composite_pipeline_layout,
                entry,
                wgpu::ColorTargetState {
                    format: targets.color_format,
                    blend: Some(blend),
                    write_mask: wgpu::ColorWrites::ALL,
                },
            )
        };
        let under_pipeline = fullscreen("fs_under", gpu::UNDER);
        let front_pipeline = fullscreen("fs_front", gpu::FRONT_OVER);
        let (count_layout, count_pipeline) = control.count_pipeline(
            ctx,
            "cs_count_candidates",
            gpu::storage_entry(4, wgpu::ShaderStages::COMPUTE),
        );
        self.gpu = Some(Resources {
            key,
            ledger,
            control,
            params,
            params_scene: None,
            depth,
            layer,
            accum,
            candidates,
            group_layout,
            layer_pipelines,
            under_group,
            final_group,
            under_pipeline,
            front_pipeline,
            count_pipeline,
            count_layout,
        });
        Ok(())
    }

    /// Records layer pass `k` (0-based), its under-composite and its gate.
    #[allow(
        clippy::too_many_arguments,
        reason = "one frame's state, passed explicitly"
    )]
    fn layer_pass(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        groups: &[wgpu::BindGroup; 2],
        timer: &mut GpuTimer,
        k: u32,
        count: bool,
        gated: bool,
    ) -> Result<(), GpuError> {
        let g = self.gpu.as_ref().expect("resources built");
        let list = self.list.as_ref().expect("draw list built");
        let ts = timer.pass(&format!("layer {}", k + 1));
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        if count {
            encoder.clear_buffer(&g.candidates, 0, None);
        }
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("front-peel layer"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &g.layer,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        // Alpha −1 marks "no fragment" for the composite.
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: 0.0,
                            g: 0.0,
                            b: 0.0,
                            a: -1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &g.depth[(k % 2) as usize],
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(scene.scene.camera.far_depth()),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: ts.writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            scene.bind(&mut pass);
            pass.set_bind_group(1, &groups[((k + 1) % 2) as usize], &[]);
            pass.set_bind_group(2, &g.control.pass_group, &[g.control.offset(k)]);
            let pipelines = &g.layer_pipelines[usize::from(k == 0)][usize::from(count)];
            list.draw(&mut pass, scene, pipelines, gated);
        }
        let ts = timer.pass(&format!("under {}", k + 1));
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("front-peel under"),
                color_attachments: &[load_attachment(&g.accum)],
                depth_stencil_attachment: None,
                timestamp_writes: ts.writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&g.under_pipeline);
            pass.set_bind_group(0, &g.under_group, &[]);
            pass.set_bind_group(1, &g.control.pass_group, &[g.control.offset(k)]);
            pass.draw(0..3, 0..1);
        }
        if gated {
            g.control.gate(&mut encoder, list, k);
        }
        timer.submit(ctx, encoder)
    }
}

fn load_attachment(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Store,
        },
    })
}

impl Technique for FrontPeel {
    fn spec(&self) -> TechniqueSpec {
        match &self.config {
            Ok(c) => c.spec(),
            Err(_) => TechniqueSpec {
                name: "front-peel".to_owned(),
                params: Default::default(),
            },
        }
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        self.config
            .as_ref()
            .map_err(|e| Unsupported::new(e.to_string()))?;
        if caps.max_storage_buffers_per_shader_stage < 3 {
            return Err(Unsupported::new(
                "the adapter has fewer than 3 storage buffers per fragment shader (materials, peel counters, candidates)",
            ));
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
        // `Caps` does not say which backend it describes, so this check lives here.
        if ctx.wgpu_adapter_info().backend == wgpu::Backend::Gl {
            return Err(Unsupported::new(
                "front-peel reads depth textures in the fragment shader, which wgpu's GL backend cannot translate (textureLoad from depth textures is not supported in GLSL)",
            )
            .into());
        }
        self.resources(ctx, targets, scene.scene.camera.reverse_z)?;
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
        // Group 1 names the opaque depth of these targets, so it is built per frame.
        let groups = [0, 1].map(|j| {
            ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("front-peel"),
                layout: &g.group_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: g.params.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&g.depth[j]),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: g.control.counters.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: wgpu::BindingResource::TextureView(&targets.depth_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: g.candidates.as_entire_binding(),
                    },
                ],
            })
        });
        let max = config.layers.budget(MAX_FRONT_LAYERS);
        let mut report = PeelReport::default();

        list.reset(ctx);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        g.control.clear(&mut encoder);
        let _ = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("front-peel clear"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &g.accum,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: 0.0,
                        g: 0.0,
                        b: 0.0,
                        a: 1.0,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        ctx.queue.submit([encoder.finish()]);

        let mut recorded = 0u32;
        let counters: Counters;
        match self.options.termination {
            Termination::CpuReadbackPerPass => loop {
                self.layer_pass(
                    ctx,
                    scene,
                    &groups,
                    timer,
                    recorded,
                    recorded + 1 == max,
                    false,
                )?;
                recorded += 1;
                let c = g.control.read(ctx)?;
                report.readbacks += 1;
                if recorded == max || !c.left(recorded - 1) {
                    counters = c;
                    break;
                }
            },
            Termination::GpuGated => {
                let mut end = match config.layers {
                    PassCount::Fixed(n) => n.min(max),
                    PassCount::Auto => self.budget.first(scene.id, 8, max),
                };
                loop {
                    while recorded < end {
                        self.layer_pass(
                            ctx,
                            scene,
                            &groups,
                            timer,
                            recorded,
                            recorded + 1 == end,
                            true,
                        )?;
                        recorded += 1;
                    }
                    let c = g.control.read(ctx)?;
                    report.readbacks += 1;
                    if config.layers == PassCount::Auto && c.left(recorded - 1) && recorded < max {
                        end = (recorded + gpu::CHUNK).min(max);
                        continue;
                    }
                    counters = c;
                    break;
                }
            }
        }
        report.passes_recorded = recorded;
        let finished = !counters.left(recorded - 1);

        let ts = timer.pass("front composite");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        if !finished {
            let count_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("front-peel count"),
                layout: &g.count_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: g.control.counters.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: list.grid.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: g.candidates.as_entire_binding(),
                    },
                ],
            });
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("front-peel dropped count"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&g.count_pipeline);
            pass.set_bind_group(0, &count_group, &[]);
            let res = targets.resolution;
            pass.dispatch_workgroups(res.width.div_ceil(8), res.height.div_ceil(8), 1);
        }
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("front-peel composite"),
                color_attachments: &[load_attachment(&targets.color_view)],
                depth_stencil_attachment: None,
                timestamp_writes: ts.writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&g.front_pipeline);
            pass.set_bind_group(0, &g.final_group, &[]);
            pass.set_bind_group(1, &g.control.pass_group, &[0]);
            pass.draw(0..3, 0..1);
        }
        timer.submit(ctx, encoder)?;
        let dropped = if finished {
            0
        } else {
            report.readbacks += 1;
            g.control.read(ctx)?.dropped()
        };

        // Layer pass k > 0 rasterized only if pass k − 1 found a layer.
        let run = 1 + (1..recorded).filter(|&k| counters.left(k - 1)).count() as u32;
        report.passes_run = run;
        report.peeled_per_pass = (0..recorded).map(|k| counters.peeled(k)).collect();
        report.dropped_pixels = dropped;
        if config.layers == PassCount::Auto {
            self.budget.remember(scene.id, run);
        }
        let stats = RenderStats {
            geometry_passes: run,
            cpu_ms: 0.0,
            layers_peeled: report.peeled_per_pass.iter().map(|&n| u64::from(n)).sum(),
            pixels_with_dropped_layers: u64::from(dropped),
        };
        self.report = report;
        Ok(stats)
    }

    fn memory_bytes(&self) -> u64 {
        self.gpu.as_ref().map_or(0, |g| g.ledger.total()) + self.list_ledger.total()
    }
}
