//! The `per-object` technique: pipelines per method, the weighted targets, and the frame.

use crate::order::{Config, draw_order, runs};
use oit_gpu::pass;
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, FullscreenDesc, GpuError, GpuScene, GpuTimer, MaterialSource, MemoryLedger,
    PREMULTIPLIED_OVER, PassDraws, PassWork, RenderStats, ScenePipelineDesc, ScenePipelines,
    SpecError, Support, Targets, Technique, TechniqueSpec, Unsupported, Work, depth_test,
};
use oit_scene::{BlendOperator, ObjectMethod, Resolution};
use std::time::Instant;

pub(crate) const METHODS_WGSL: &str = include_str!("../shaders/per_object.wgsl");
pub(crate) const DITHER_WGSL: &str = include_str!("../shaders/per_object_dither.wgsl");
pub(crate) const NOISE_WGSL: &str = include_str!("../shaders/per_object_noise.wgsl");
pub(crate) const RESOLVE_WGSL: &str = include_str!("../shaders/per_object_resolve.wgsl");
pub(crate) const TRANSMIT_WGSL: &str = include_str!("../shaders/per_object_transmit.wgsl");

/// pygfx's weighted accumulation target (8 bytes per pixel).
pub const ACCUM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// pygfx's revealage target (1 byte per pixel): quantised to 1/255.
pub const REVEAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;

/// `dst = src0 + src1 ⊙ dst` per channel (dual-source; src1 = the fragment's transmittance).
const PER_CHANNEL_OVER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::Src1,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: PREMULTIPLIED_OVER.alpha,
};

/// (One, One): the weighted accumulation.
const ADD: wgpu::BlendComponent = wgpu::BlendComponent {
    src_factor: wgpu::BlendFactor::One,
    dst_factor: wgpu::BlendFactor::One,
    operation: wgpu::BlendOperation::Add,
};

/// (Zero, 1 − src): the revealage product.
const REVEAL_BLEND: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::OneMinusSrc,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
};

/// Pipelines for one (colour format, reverse-Z, dual-source transmission) combination.
#[derive(Debug)]
struct Pipelines {
    key: (wgpu::TextureFormat, bool, bool),
    solid: ScenePipelines,
    dither: ScenePipelines,
    seed_layout: wgpu::BindGroupLayout,
    /// Without and with a depth write (`Material::depth_write`).
    blend: [ScenePipelines; 2],
    weighted: [ScenePipelines; 2],
    resolve: wgpu::RenderPipeline,
    resolve_layout: wgpu::BindGroupLayout,
}

/// Per uploaded scene: the dither pass's per-draw seeds.
#[derive(Debug)]
struct Seeds {
    scene_id: u64,
    group: wgpu::BindGroup,
}

/// The weighted accumulation and revealage, and the resolve's bind group over them.
#[derive(Debug)]
struct WeightedTargets {
    resolution: Resolution,
    accum_view: wgpu::TextureView,
    reveal_view: wgpu::TextureView,
    group: wgpu::BindGroup,
}

/// pygfx's per-object renderer.
#[derive(Debug)]
pub struct PerObject {
    config: Config,
    pipelines: Option<Pipelines>,
    seeds: Option<Seeds>,
    seeds_ledger: MemoryLedger,
    weighted: Option<WeightedTargets>,
    weighted_ledger: MemoryLedger,
}

impl PerObject {
    pub const NAME: &'static str = "per-object";

    pub fn new(config: Config) -> Self {
        PerObject {
            config,
            pipelines: None,
            seeds: None,
            seeds_ledger: MemoryLedger::new(),
            weighted: None,
            weighted_ledger: MemoryLedger::new(),
        }
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(Config::from_spec(spec)?))
    }

    pub fn config(&self) -> Config {
        self.config
    }

    fn pipelines(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        format: wgpu::TextureFormat,
    ) -> Result<(), GpuError> {
        let transmit = scene.scene.has_transmission() && ctx.caps.dual_source_blending;
        let key = (format, scene.scene.camera.reverse_z, transmit);
        if self.pipelines.as_ref().is_some_and(|p| p.key == key) {
            return Ok(());
        }
        let libraries = &[crate::SHADERS];
        let methods = ctx.shader_with("per_object.wgsl", METHODS_WGSL, libraries)?;
        let dither_module = ctx.shader_with("per_object_dither.wgsl", DITHER_WGSL, libraries)?;
        let blend_module = if transmit {
            ctx.shader_with("per_object_transmit.wgsl", TRANSMIT_WGSL, libraries)?
        } else {
            ctx.shader_with("blend.wgsl", oit_gpu::shaders::BLEND, libraries)?
        };
        let blend_entry = if transmit {
            "fs_blend_transmit"
        } else {
            "fs_blend"
        };
        let nearer = scene.depth_nearer();
        let solid_target = [Some(wgpu::ColorTargetState {
            format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let solid = ScenePipelines::new(
            ctx,
            &ScenePipelineDesc {
                targets: &solid_target,
                depth: Some(depth_test(nearer, true)),
                ..ScenePipelineDesc::new("per-object solid", &methods, "fs_solid")
            },
        );
        let seed_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("per-object dither seeds"),
            entries: &[oit_gpu::bind::storage(0, wgpu::ShaderStages::VERTEX, true)],
        });
        let dither_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("per-object dither"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&seed_layout)],
            immediate_size: 0,
        });
        let dither = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                vertex_entry: "vs_dither",
                // Its vertex outputs repeat the per-vertex interface's fields.
                material: MaterialSource::PerVertex,
                targets: &solid_target,
                depth: Some(depth_test(nearer, true)),
                ..ScenePipelineDesc::new("per-object dither", &dither_module, "fs_dither")
            },
            &dither_layout,
        );
        let blend_target = [Some(wgpu::ColorTargetState {
            format,
            blend: Some(if transmit {
                PER_CHANNEL_OVER
            } else {
                PREMULTIPLIED_OVER
            }),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let blend = |write: bool| {
            ScenePipelines::new(
                ctx,
                &ScenePipelineDesc {
                    targets: &blend_target,
                    depth: Some(depth_test(nearer, write)),
                    ..ScenePipelineDesc::new("per-object blend", &blend_module, blend_entry)
                },
            )
        };
        let weighted_targets = [
            Some(wgpu::ColorTargetState {
                format: ACCUM_FORMAT,
                blend: Some(wgpu::BlendState {
                    color: ADD,
                    alpha: ADD,
                }),
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: REVEAL_FORMAT,
                blend: Some(REVEAL_BLEND),
                write_mask: wgpu::ColorWrites::ALL,
            }),
        ];
        let weighted = |write: bool| {
            ScenePipelines::new(
                ctx,
                &ScenePipelineDesc {
                    targets: &weighted_targets,
                    depth: Some(depth_test(nearer, write)),
                    ..ScenePipelineDesc::new("per-object weighted", &methods, "fs_weighted")
                },
            )
        };
        let resolve_module = ctx.shader("per_object_resolve.wgsl", RESOLVE_WGSL)?;
        let resolve_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("per-object weighted resolve"),
            entries: &[
                oit_gpu::bind::float_texture(0, wgpu::ShaderStages::FRAGMENT),
                oit_gpu::bind::float_texture(1, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let resolve_pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("per-object weighted resolve"),
            bind_group_layouts: &[Some(&resolve_layout)],
            immediate_size: 0,
        });
        let resolve = oit_gpu::fullscreen_pipeline(
            ctx,
            &FullscreenDesc {
                label: "per-object weighted resolve",
                layout: &resolve_pipeline_layout,
                module: &resolve_module,
                fragment_entry: "fs_resolve",
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(PREMULTIPLIED_OVER),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: None,
                multisample: wgpu::MultisampleState::default(),
                constants: &[],
            },
        );
        self.pipelines = Some(Pipelines {
            key,
            solid,
            dither,
            seed_layout,
            blend: [blend(false), blend(true)],
            weighted: [weighted(false), weighted(true)],
            resolve,
            resolve_layout,
        });
        // The bind groups were made for the previous layouts.
        self.seeds = None;
        self.weighted = None;
        Ok(())
    }

    /// The dither pass's seeds of `scene`: per draw, its first vertex and object id.
    fn seeds(&mut self, ctx: &Context, scene: &GpuScene) -> Result<(), GpuError> {
        if self.seeds.as_ref().is_some_and(|s| s.scene_id == scene.id) {
            return Ok(());
        }
        let words: Vec<u32> = scene
            .scene
            .draws
            .iter()
            .flat_map(|d| [d.first_vertex, d.id.wrapping_add(1)])
            .collect();
        let bytes = (words.len() as u64 * 4).max(8);
        if bytes > ctx.caps.max_buffer_size {
            return Err(GpuError::TooLarge {
                what: format!("the dither seeds of {} draws", scene.scene.draws.len()),
                needed: bytes,
                limit: ctx.caps.max_buffer_size,
            });
        }
        self.seeds_ledger.clear();
        let buffer = self.seeds_ledger.create_buffer(
            &ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("per-object dither seeds"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        if !words.is_empty() {
            ctx.queue
                .write_buffer(&buffer, 0, bytemuck::cast_slice(&words));
        }
        let p = self.pipelines.as_ref().ok_or_else(|| {
            GpuError::Mismatch("per-object pipelines missing before the seeds".into())
        })?;
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("per-object dither seeds"),
            layout: &p.seed_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: buffer.as_entire_binding(),
            }],
        });
        self.seeds = Some(Seeds {
            scene_id: scene.id,
            group,
        });
        Ok(())
    }

    /// The weighted targets at `resolution` (made on the first frame with a weighted run).
    fn weighted_targets(&mut self, ctx: &Context, resolution: Resolution) -> Result<(), GpuError> {
        if self
            .weighted
            .as_ref()
            .is_some_and(|w| w.resolution == resolution)
        {
            return Ok(());
        }
        self.weighted_ledger.clear();
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let accum = self.weighted_ledger.create_texture_2d(
            &ctx.device,
            "per-object weighted accumulation",
            resolution,
            ACCUM_FORMAT,
            usage,
            1,
        );
        let reveal = self.weighted_ledger.create_texture_2d(
            &ctx.device,
            "per-object weighted revealage",
            resolution,
            REVEAL_FORMAT,
            usage,
            1,
        );
        let accum_view = accum.create_view(&Default::default());
        let reveal_view = reveal.create_view(&Default::default());
        let p = self.pipelines.as_ref().ok_or_else(|| {
            GpuError::Mismatch("per-object pipelines missing before the weighted targets".into())
        })?;
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("per-object weighted resolve"),
            layout: &p.resolve_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&accum_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&reveal_view),
                },
            ],
        });
        self.weighted = Some(WeightedTargets {
            resolution,
            accum_view,
            reveal_view,
            group,
        });
        Ok(())
    }
}

/// The timer's name of a run's pass (numbered by run: "blended 3").
fn pass_name(method: ObjectMethod) -> &'static str {
    match method {
        ObjectMethod::Opaque => "solid ",
        ObjectMethod::Stochastic => "stochastic ",
        ObjectMethod::Blended => "blended ",
        ObjectMethod::Weighted => "weighted ",
    }
}

const RESOLVE_PASS: &str = "weighted resolve ";

impl Technique for PerObject {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        caps.require_scene_materials()?;
        Ok(())
    }

    fn predict(
        &self,
        scene: &oit_scene::Scene,
        lists: &oit_gpu::predict::PixelLists,
        caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict(self.config, scene, lists, caps)
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        self.pipelines(ctx, scene, targets.color_format)?;
        let cpu = Instant::now();
        let order = draw_order(self.config, &scene.scene);
        let runs = runs(&order);
        let cpu_ms = cpu.elapsed().as_secs_f64() * 1e3;
        if runs.iter().any(|(m, _)| *m == ObjectMethod::Stochastic) {
            self.seeds(ctx, scene)?;
        }
        if runs.iter().any(|(m, _)| *m == ObjectMethod::Weighted) {
            self.weighted_targets(ctx, targets.resolution)?;
        }
        let p = self.pipelines.as_ref().ok_or_else(|| {
            GpuError::Mismatch("per-object pipelines missing after building them".into())
        })?;
        let s = &scene.scene;
        let writes_depth = |i: usize| usize::from(s.material_of(&s.draws[i]).depth_write);
        for (n, (method, draws)) in runs.iter().enumerate() {
            let name = format!("{}{}", pass_name(*method), n + 1);
            let ts = timer.pass(&name);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            let depth = pass::depth(
                &targets.depth_view,
                wgpu::LoadOp::Load,
                wgpu::StoreOp::Store,
            );
            if *method == ObjectMethod::Weighted {
                let w = self.weighted.as_ref().ok_or_else(|| {
                    GpuError::Mismatch("per-object weighted targets missing".into())
                })?;
                {
                    // Cleared per run: each run is resolved on its own (pygfx 0.17 loads the
                    // accumulators instead, so a second weighted run in one frame would
                    // resolve the first one again).
                    let attachments = [
                        pass::color(&w.accum_view, wgpu::LoadOp::Clear(pass::splat(0.0))),
                        pass::color(&w.reveal_view, wgpu::LoadOp::Clear(pass::splat(1.0))),
                    ];
                    let mut rp = pass::begin(&mut encoder, &name, &attachments, depth, &ts);
                    scene.bind(&mut rp);
                    for &i in draws {
                        scene.draw(&mut rp, &p.weighted[writes_depth(i)], i);
                    }
                }
                timer.submit(ctx, encoder)?;
                let resolve_name = format!("{RESOLVE_PASS}{}", n + 1);
                let ts = timer.pass(&resolve_name);
                let mut encoder = ctx.device.create_command_encoder(&Default::default());
                pass::fullscreen(
                    &mut encoder,
                    &resolve_name,
                    &targets.color_view,
                    &p.resolve,
                    &[(&w.group, &[])],
                    &ts,
                );
                timer.submit(ctx, encoder)?;
                continue;
            }
            {
                let attachments = [pass::color(&targets.color_view, wgpu::LoadOp::Load)];
                let mut rp = pass::begin(&mut encoder, &name, &attachments, depth, &ts);
                scene.bind(&mut rp);
                match method {
                    ObjectMethod::Opaque => {
                        for &i in draws {
                            scene.draw(&mut rp, &p.solid, i);
                        }
                    }
                    ObjectMethod::Blended => {
                        for &i in draws {
                            scene.draw(&mut rp, &p.blend[writes_depth(i)], i);
                        }
                    }
                    ObjectMethod::Stochastic => {
                        let seeds = self.seeds.as_ref().ok_or_else(|| {
                            GpuError::Mismatch("per-object dither seeds missing".into())
                        })?;
                        rp.set_bind_group(1, &seeds.group, &[]);
                        for &i in draws {
                            let d = &s.draws[i];
                            if d.vertex_count == 0 {
                                continue;
                            }
                            scene.use_draw(&mut rp, &p.dither, i);
                            // The instance index is the draw's index: the vertex stage reads
                            // its seed with it. Not indexed (GpuScene::draw_range): the face
                            // index is the vertex index over 3, a non-indexed draw's.
                            rp.draw(
                                d.first_vertex..d.first_vertex + d.vertex_count,
                                i as u32..i as u32 + 1,
                            );
                        }
                    }
                    ObjectMethod::Weighted => {}
                }
            }
            timer.submit(ctx, encoder)?;
        }
        Ok(RenderStats {
            geometry_passes: runs.len() as u32,
            cpu_ms,
            ..Default::default()
        })
    }

    fn work(&self, _caps: &Caps, target: wgpu::TextureFormat) -> Work {
        use oit_gpu::work::{DEPTH_BYTES, texel_bytes};
        let t = texel_bytes(target);
        let weighted = texel_bytes(ACCUM_FORMAT) + texel_bytes(REVEAL_FORMAT);
        // Every run is declared as drawing the transparent draws: `Work` is stated without the
        // scene, so the triangles of a run (a subset) are overstated.
        let run = |method| PassWork::numbered(pass_name(method), PassDraws::Transparent);
        Work::new(vec![
            // Depth tested and written, the colour replaced.
            run(ObjectMethod::Opaque).bytes(DEPTH_BYTES, DEPTH_BYTES + t),
            run(ObjectMethod::Stochastic).bytes(DEPTH_BYTES, DEPTH_BYTES + t),
            // Depth tested (written only by depth-writing materials, not counted), the
            // colour blended.
            run(ObjectMethod::Blended).bytes(DEPTH_BYTES + t, t),
            run(ObjectMethod::Weighted).bytes(DEPTH_BYTES + weighted, weighted),
            // Both accumulators read, the colour blended.
            PassWork::numbered(RESOLVE_PASS, PassDraws::FullScreen).bytes(weighted + t, t),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.seeds_ledger.total() + self.weighted_ledger.total()
    }

    fn transmission(&self, caps: &Caps) -> Support {
        let blended_only = self.config.force.method() == Some(ObjectMethod::Blended);
        match (blended_only, caps.dual_source_blending) {
            (true, true) => Support::Exact,
            (true, false) => Support::Approximate(
                "composites 1 − mean(t) as scalar α, exact for grey filters only (the adapter has no dual-source blending for dst = C + t ⊙ dst)",
            ),
            (false, true) => Support::Approximate(
                "blended objects per channel with dual-source blending (exact); weighted, stochastic and opaque objects by the scalar opacity 1 − mean(t)",
            ),
            (false, false) => Support::Approximate(
                "every method by the scalar opacity 1 − mean(t), exact for grey filters only in blended objects (no dual-source blending on this adapter)",
            ),
        }
    }

    fn queues(&self) -> oit_gpu::Queues {
        // pygfx's order: (group, queue, render order, distance), so levels composite in order,
        // and blended objects whose material writes depth write it, hiding later levels.
        oit_gpu::Queues::Exact
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        // Objects with a non-`over` operator are drawn blended under every method.
        match operator {
            // (P, t = 1) added in float by (One, OneMinusSrcAlpha) with α = 0.
            BlendOperator::Over | BlendOperator::Add | BlendOperator::Subtract => Support::Exact,
            BlendOperator::Multiply if caps.dual_source_blending => Support::Exact,
            BlendOperator::Multiply => Support::Approximate(
                "the coloured filter as scalar α = 1 − mean(t) (no dual-source blending on this adapter)",
            ),
        }
    }
}
