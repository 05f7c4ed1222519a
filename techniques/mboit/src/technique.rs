//! The `mboit` technique: pass 1 accumulates the moments of absorbance, pass 2 reconstructs
//! each fragment's transmittance from them and accumulates the weighted colour, and a
//! full-screen composite puts the result over the opaque colour.

use crate::math::{self, MomentKind, Resolve, Storage};
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MemoryLedger, Param, ParamInfo, RenderStats,
    ScenePipelineDesc, ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec,
    Unsupported, bind, blend, depth_test, pass,
};
use oit_scene::BlendOperator;
use oit_scene::{Resolution, Scene};

/// The reconstruction (shaders/mboit_math.wgsl; no bindings, no includes).
pub const MATH_WGSL: &str = include_str!("../shaders/mboit_math.wgsl");
/// Both geometry passes (shaders/mboit_accum.wgsl; includes common.wgsl and the math).
pub const ACCUM_WGSL: &str = include_str!("../shaders/mboit_accum.wgsl");
/// The composite (shaders/mboit_composite.wgsl).
pub const COMPOSITE_WGSL: &str = include_str!("../shaders/mboit_composite.wgsl");

/// A valid `mboit` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Config {
    pub moments: MomentKind,
    pub storage: Storage,
}

impl Config {
    /// The paper's recommendation: 6 power moments; fp32 storage (exact additive sums).
    pub const DEFAULT: Config = Config {
        moments: Self::MOMENTS.default,
        storage: Self::STORAGE.default,
    };

    pub const MOMENTS: Param<MomentKind> = Param::new(
        "moments",
        MomentKind::Power6,
        "power4/6/8: 4, 6 or 8 power moments (Hankel bounds, 2-4 roots); trig2/3/4: 2, 3 or 4 trigonometric moments (Toeplitz bounds, wrapping zone 0.1 pi)",
    );
    pub const STORAGE: Param<Storage> = Param::new(
        "storage",
        Storage::F32,
        "f32: 32-bit float moments (needs FLOAT32_BLENDABLE); f16: 16-bit float moments with the paper's 16-bit biases, still additive blending (no pixel sync)",
    );

    /// The registry's view of the parameters.
    pub fn params() -> Vec<ParamInfo> {
        vec![Self::MOMENTS.info(), Self::STORAGE.info()]
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of("mboit")
            .with(&Self::MOMENTS, self.moments)
            .with(&Self::STORAGE, self.storage)
    }

    /// Refuses a spec that is not `mboit` with every parameter valid.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Config, SpecError> {
        spec.expect_name("mboit")?;
        Ok(Config {
            moments: Self::MOMENTS.read(spec)?,
            storage: Self::STORAGE.read(spec)?,
        })
    }

    /// Formats of the pass-1 targets: b0, the first four floats, and the rest (none for 4
    /// power or 2 trigonometric moments, two floats for 6 / 3, four for 8 / 4).
    pub fn moment_formats(&self) -> Vec<wgpu::TextureFormat> {
        use wgpu::TextureFormat as F;
        let (r, rg, rgba) = match self.storage {
            Storage::F32 => (F::R32Float, F::Rg32Float, F::Rgba32Float),
            Storage::F16 => (F::R16Float, F::Rg16Float, F::Rgba16Float),
        };
        match self.moments.order() {
            3 => vec![r, rgba],
            4 => vec![r, rgba, rg],
            _ => vec![r, rgba, rgba],
        }
    }

    /// Format of the pass-2 accumulator (premultiplied colour · T, α · T).
    pub fn accum_format(&self) -> wgpu::TextureFormat {
        match self.storage {
            Storage::F32 => wgpu::TextureFormat::Rgba32Float,
            Storage::F16 => wgpu::TextureFormat::Rgba16Float,
        }
    }

    /// Bytes per pixel of every per-pixel texture (moments and accumulator).
    pub fn bytes_per_pixel(&self) -> u64 {
        self.moment_formats()
            .into_iter()
            .chain([self.accum_format()])
            .map(|f| u64::from(f.block_copy_size(None).unwrap_or(0)))
            .sum()
    }

    /// Colour-attachment bytes per sample of pass 1 as WebGPU counts them (each target's
    /// render-target cost after aligning the running total to its component alignment).
    pub fn pass1_bytes_per_sample(&self) -> u32 {
        let mut total = 0u32;
        for f in self.moment_formats() {
            let align = f.target_component_alignment().unwrap_or(1);
            total = total.div_ceil(align) * align + f.target_pixel_byte_cost().unwrap_or(0);
        }
        total
    }

    pub fn resolve(&self) -> Resolve {
        Resolve::new(self.moments, self.storage)
    }
}

/// Bytes of the uniform block `MboitParams`.
const PARAMS_BYTES: u64 = 80;

/// The log warp's bounds: the transparent geometry's view-depth interval; the log needs z > 0,
/// and an orthographic camera may put its near plane at 0.
pub fn transparent_depth_interval(scene: &Scene) -> (f32, f32) {
    scene.transparent_view_depth_interval(1e-6)
}

/// The contents of the `MboitParams` uniform for `scene`.
pub fn params_words(config: &Config, scene: &Scene) -> [u32; 20] {
    let (a, b, ortho) = scene.camera.view_depth_terms();
    let (z_min, z_max) = transparent_depth_interval(scene);
    let (ln_z_min, scale) = math::warp_terms(z_min, z_max);
    let r = config.resolve();
    let mut w = [0u32; 20];
    w[0] = a.to_bits();
    w[1] = b.to_bits();
    w[2] = u32::from(ortho);
    w[3] = r.moment_bias.to_bits();
    w[4] = ln_z_min.to_bits();
    w[5] = scale.to_bits();
    w[6] = r.overestimation.to_bits();
    for (i, v) in r.bias_vector.iter().enumerate() {
        w[8 + i] = v.to_bits();
    }
    for (i, v) in r.wrapping.iter().enumerate() {
        w[16 + i] = v.to_bits();
    }
    w
}

/// Per-pixel textures of one resolution.
#[derive(Debug)]
struct PixelTargets {
    resolution: Resolution,
    moment_views: Vec<wgpu::TextureView>,
    accum_view: wgpu::TextureView,
    /// Pass 2's view of the moments (group 2) and the composite's of b0 and the accumulator.
    resolve_group: wgpu::BindGroup,
    composite_group: wgpu::BindGroup,
    ledger: MemoryLedger,
}

#[derive(Debug)]
struct Pipelines {
    reverse_z: bool,
    moments: ScenePipelines,
    resolve: ScenePipelines,
}

#[derive(Debug)]
struct Shared {
    params: wgpu::Buffer,
    params_group: wgpu::BindGroup,
    params_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    composite_layout: wgpu::BindGroupLayout,
    ledger: MemoryLedger,
}

/// Moment-based order-independent transparency.
#[derive(Debug)]
pub struct Mboit {
    config: Config,
    shared: Option<Shared>,
    pixels: Option<PixelTargets>,
    pipelines: Option<Pipelines>,
    composite: Option<(wgpu::TextureFormat, wgpu::RenderPipeline)>,
    /// Pass 3 of additive and subtractive draws, per final colour format and depth direction
    /// (built for the first scene that has them).
    additive: Option<((wgpu::TextureFormat, bool), ScenePipelines)>,
}

impl Mboit {
    pub fn new(config: Config) -> Self {
        Mboit {
            config,
            shared: None,
            pixels: None,
            pipelines: None,
            composite: None,
            additive: None,
        }
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(Config::from_spec(spec)?))
    }

    pub fn config(&self) -> Config {
        self.config
    }

    fn ensure(&mut self, ctx: &Context, scene: &GpuScene) -> Result<(), GpuError> {
        self.check(&ctx.caps)?;
        let res = scene.scene.resolution;
        ctx.caps.require_resolution(res)?;
        let fs = wgpu::ShaderStages::FRAGMENT;
        if self.shared.is_none() {
            let mut ledger = MemoryLedger::new();
            let params = ledger.create_buffer(
                &ctx.device,
                &wgpu::BufferDescriptor {
                    label: Some("mboit params"),
                    size: PARAMS_BYTES,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                },
            );
            let layout = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
                ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(label),
                    entries,
                })
            };
            let params_layout = layout("mboit params", &[bind::uniform(0, fs)]);
            let resolve_layout = layout(
                "mboit moments",
                &[
                    bind::float_texture(0, fs),
                    bind::float_texture(1, fs),
                    bind::float_texture(2, fs),
                ],
            );
            let composite_layout = layout(
                "mboit composite",
                &[bind::float_texture(0, fs), bind::float_texture(1, fs)],
            );
            let params_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("mboit params"),
                layout: &params_layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params.as_entire_binding(),
                }],
            });
            self.shared = Some(Shared {
                params,
                params_group,
                params_layout,
                resolve_layout,
                composite_layout,
                ledger,
            });
        }
        let shared = self.shared.as_ref().expect("built above");
        if self.pixels.as_ref().is_none_or(|p| p.resolution != res) {
            let mut ledger = MemoryLedger::new();
            let usage =
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
            let moment_views: Vec<wgpu::TextureView> = (self.config.moment_formats().iter())
                .enumerate()
                .map(|(i, &f)| {
                    ledger
                        .create_texture_2d(
                            &ctx.device,
                            &format!("mboit moments {i}"),
                            res,
                            f,
                            usage,
                            1,
                        )
                        .create_view(&Default::default())
                })
                .collect();
            let accum_view = ledger
                .create_texture_2d(
                    &ctx.device,
                    "mboit accumulation",
                    res,
                    self.config.accum_format(),
                    usage,
                    1,
                )
                .create_view(&Default::default());
            // With 4 power / 2 trigonometric moments there is no third target; the shader
            // ignores the third texture then, so the second stands in for it.
            let hi = moment_views.get(2).unwrap_or(&moment_views[1]);
            let entry = |binding, view| wgpu::BindGroupEntry {
                binding,
                resource: wgpu::BindingResource::TextureView(view),
            };
            let resolve_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("mboit moments"),
                layout: &shared.resolve_layout,
                entries: &[
                    entry(0, &moment_views[0]),
                    entry(1, &moment_views[1]),
                    entry(2, hi),
                ],
            });
            let composite_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("mboit composite"),
                layout: &shared.composite_layout,
                entries: &[entry(0, &moment_views[0]), entry(1, &accum_view)],
            });
            self.pixels = Some(PixelTargets {
                resolution: res,
                moment_views,
                accum_view,
                resolve_group,
                composite_group,
                ledger,
            });
        }
        let reverse_z = scene.scene.camera.reverse_z;
        if self
            .pipelines
            .as_ref()
            .is_none_or(|p| p.reverse_z != reverse_z)
        {
            let module = ctx.shader_with("mboit_accum.wgsl", ACCUM_WGSL, &[crate::SHADERS])?;
            let constants = [("MBOIT_KIND", f64::from(self.config.moments.index()))];
            let depth = Some(depth_test(scene.depth_nearer(), false));
            let additive = |format| {
                Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(blend::ADDITIVE),
                    write_mask: wgpu::ColorWrites::ALL,
                })
            };
            let mut moment_targets: Vec<Option<wgpu::ColorTargetState>> = self
                .config
                .moment_formats()
                .into_iter()
                .map(additive)
                .collect();
            moment_targets.resize(3, None);
            let layout = |label, groups: &[Option<&wgpu::BindGroupLayout>]| {
                ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some(label),
                    bind_group_layouts: groups,
                    immediate_size: 0,
                })
            };
            let moments = ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    targets: &moment_targets,
                    depth: depth.clone(),
                    constants: &constants,
                    ..ScenePipelineDesc::new("mboit moments", &module, "fs_moments")
                },
                &layout(
                    "mboit moments",
                    &[Some(ctx.scene_layout()), Some(&shared.params_layout)],
                ),
            );
            let resolve = ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    targets: &[additive(self.config.accum_format())],
                    depth,
                    constants: &constants,
                    ..ScenePipelineDesc::new("mboit resolve", &module, "fs_resolve")
                },
                &layout(
                    "mboit resolve",
                    &[
                        Some(ctx.scene_layout()),
                        Some(&shared.params_layout),
                        Some(&shared.resolve_layout),
                    ],
                ),
            );
            self.pipelines = Some(Pipelines {
                reverse_z,
                moments,
                resolve,
            });
        }
        Ok(())
    }

    /// Pass 3 (`fs_additive`): the resolve pass's bindings, (one, one) onto the final colour.
    fn additive_pipelines(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
    ) -> Result<ScenePipelines, GpuError> {
        let shared = self.shared.as_ref().expect("built in ensure");
        let module = ctx.shader_with("mboit_accum.wgsl", ACCUM_WGSL, &[crate::SHADERS])?;
        let constants = [("MBOIT_KIND", f64::from(self.config.moments.index()))];
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mboit additive"),
            bind_group_layouts: &[
                Some(ctx.scene_layout()),
                Some(&shared.params_layout),
                Some(&shared.resolve_layout),
            ],
            immediate_size: 0,
        });
        Ok(ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &[Some(wgpu::ColorTargetState {
                    format: targets.color_format,
                    blend: Some(blend::ADDITIVE),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: Some(depth_test(scene.depth_nearer(), false)),
                constants: &constants,
                ..ScenePipelineDesc::new("mboit additive", &module, "fs_additive")
            },
            &layout,
        ))
    }

    fn composite_pipeline(
        &mut self,
        ctx: &Context,
        format: wgpu::TextureFormat,
    ) -> wgpu::RenderPipeline {
        if let Some((f, p)) = &self.composite
            && *f == format
        {
            return p.clone();
        }
        let shared = self.shared.as_ref().expect("built in ensure");
        let module = ctx.wgsl_module("mboit_composite.wgsl", COMPOSITE_WGSL);
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mboit composite"),
            bind_group_layouts: &[Some(&shared.composite_layout)],
            immediate_size: 0,
        });
        let pipeline = oit_gpu::fullscreen_pipeline(
            ctx,
            &oit_gpu::FullscreenDesc {
                label: "mboit composite",
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
                constants: &[],
            },
        );
        self.composite = Some((format, pipeline.clone()));
        pipeline
    }
}

impl Technique for Mboit {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn predict(
        &self,
        scene: &oit_scene::Scene,
        lists: &oit_gpu::predict::PixelLists,
        _caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict(&self.config, scene, lists)
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        let spec = self.config.spec();
        for f in self
            .config
            .moment_formats()
            .into_iter()
            .chain([self.config.accum_format()])
        {
            caps.require_target(f, true)
                .map_err(|e| Unsupported::new(format!("{spec}: {}", e.reason)))?;
        }
        let attachments = self.config.moment_formats().len() as u32;
        if caps.max_color_attachments < attachments {
            return Err(Unsupported::new(format!(
                "{spec}: pass 1 needs {attachments} colour attachments, the adapter allows {}",
                caps.max_color_attachments
            )));
        }
        let bytes = self.config.pass1_bytes_per_sample();
        if caps.max_color_attachment_bytes_per_sample < bytes {
            return Err(Unsupported::new(format!(
                "{spec}: pass 1 writes {bytes} colour-attachment bytes per sample, the adapter allows {}",
                caps.max_color_attachment_bytes_per_sample
            )));
        }
        if caps.max_storage_buffers_per_shader_stage == 0 {
            return Err(Unsupported::new(
                "the adapter has no storage buffers per shader stage (scene materials in the vertex stage)",
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
        if targets.resolution != scene.scene.resolution {
            return Err(GpuError::Mismatch(format!(
                "mboit: the scene is {} but the final colour is {}",
                scene.scene.resolution, targets.resolution
            )));
        }
        self.ensure(ctx, scene)?;
        let composite = self.composite_pipeline(ctx, targets.color_format);
        let shared = self.shared.as_ref().expect("built in ensure");
        let pixels = self.pixels.as_ref().expect("built in ensure");
        let pipelines = self.pipelines.as_ref().expect("built in ensure");
        let words = params_words(&self.config, &scene.scene);
        ctx.queue
            .write_buffer(&shared.params, 0, bytemuck::cast_slice(&words));
        // Additive and subtractive draws add no absorbance and are left out of the
        // normalised sum: pass 3 adds them after the composite.
        let (additive, draws): (Vec<usize>, Vec<usize>) =
            scene.transparent_draws().into_iter().partition(|&i| {
                let s = &scene.scene;
                s.material_of(&s.draws[i]).operator.is_additive()
            });
        let depth = || {
            pass::depth(
                &targets.depth_view,
                wgpu::LoadOp::Load,
                wgpu::StoreOp::Store,
            )
        };
        let clear = wgpu::LoadOp::Clear(pass::splat(0.0));

        let ts = timer.pass("mboit moments");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            // Padded to the pipeline's three locations (the third unused with 3-root orders).
            let mut attachments: Vec<_> = (pixels.moment_views.iter())
                .map(|v| pass::color(v, clear))
                .collect();
            attachments.resize(3, None);
            let mut p = pass::begin(&mut encoder, "mboit moments", &attachments, depth(), &ts);
            scene.bind(&mut p);
            p.set_bind_group(1, &shared.params_group, &[]);
            for &i in &draws {
                scene.draw(&mut p, &pipelines.moments, i);
            }
        }
        timer.submit(ctx, encoder)?;

        let ts = timer.pass("mboit resolve");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let attachments = [pass::color(&pixels.accum_view, clear)];
            let mut p = pass::begin(&mut encoder, "mboit resolve", &attachments, depth(), &ts);
            scene.bind(&mut p);
            p.set_bind_group(1, &shared.params_group, &[]);
            p.set_bind_group(2, &pixels.resolve_group, &[]);
            for &i in &draws {
                scene.draw(&mut p, &pipelines.resolve, i);
            }
        }
        timer.submit(ctx, encoder)?;

        let ts = timer.pass("mboit composite");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        pass::fullscreen(
            &mut encoder,
            "mboit composite",
            &targets.color_view,
            &composite,
            &[(&pixels.composite_group, &[])],
            &ts,
        );
        timer.submit(ctx, encoder)?;
        let mut geometry_passes = 2;
        if !additive.is_empty() {
            let key = (targets.color_format, scene.scene.camera.reverse_z);
            if self.additive.as_ref().is_none_or(|(k, _)| *k != key) {
                self.additive = Some((key, self.additive_pipelines(ctx, scene, targets)?));
            }
            let (_, additive_pipelines) = self.additive.as_ref().expect("built above");
            let shared = self.shared.as_ref().expect("built in ensure");
            let pixels = self.pixels.as_ref().expect("built in ensure");
            let ts = timer.pass("mboit additive");
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let attachments = [pass::color(&targets.color_view, wgpu::LoadOp::Load)];
                let mut p = pass::begin(&mut encoder, "mboit additive", &attachments, depth(), &ts);
                scene.bind(&mut p);
                p.set_bind_group(1, &shared.params_group, &[]);
                p.set_bind_group(2, &pixels.resolve_group, &[]);
                for &i in &additive {
                    scene.draw(&mut p, additive_pipelines, i);
                }
            }
            timer.submit(ctx, encoder)?;
            geometry_passes = 3;
        }
        Ok(RenderStats {
            geometry_passes,
            ..Default::default()
        })
    }

    fn work(&self, _caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        let moment_formats = self.config.moment_formats();
        let moments: u32 = moment_formats.iter().map(|&f| texel_bytes(f)).sum();
        let b0 = moment_formats.first().map_or(0, |&f| texel_bytes(f));
        let accum = texel_bytes(self.config.accum_format());
        let final_texel = texel_bytes(target);
        Work::new(vec![
            // Depth test; every moment target's texel read and written by its additive blend.
            PassWork::new("mboit moments", PassDraws::Transparent)
                .bytes(DEPTH_BYTES + moments, moments),
            // Depth test; the pixel's moments loaded (every moment texture); the accumulation
            // texel read and written by its additive blend.
            PassWork::new("mboit resolve", PassDraws::Transparent)
                .bytes(DEPTH_BYTES + moments + accum, accum),
            // Per pixel: the zeroth moment and the accumulation loaded, the final texel read
            // and written by the blend.
            PassWork::new("mboit composite", PassDraws::FullScreen)
                .bytes(b0 + accum + final_texel, final_texel),
            // Only on scenes with additive or subtractive draws: depth test, the pixel's
            // moments loaded, the final texel read and written by the additive blend.
            PassWork::new("mboit additive", PassDraws::Additive)
                .bytes(DEPTH_BYTES + moments + final_texel, final_texel),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.shared.as_ref().map_or(0, |s| s.ledger.total())
            + self.pixels.as_ref().map_or(0, |p| p.ledger.total())
    }

    fn transmission(&self, _caps: &Caps) -> Support {
        // Scalar alpha: the shader's `Shaded.alpha` is 1 − mean(t) for transmissive fragments.
        Support::Approximate(
            "composites 1 − mean(t) as scalar α, exact for grey filters only (its moments are of the scalar absorbance −ln(1 − α); a per-channel set of moments is not implemented)",
        )
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        match operator {
            BlendOperator::Over => Support::Approximate(
                "weighted by the transmittance the moments reconstruct, normalised under the exact coverage (the technique itself)",
            ),
            // (P, t = 1): pass 3 (`fs_additive`).
            BlendOperator::Add | BlendOperator::Subtract => Support::Approximate(
                "no absorbance, kept out of the normalised sum; added after the composite, scaled by the transmittance the moments reconstruct in front of it (1 where the pixel has no absorbance): the moments' estimate, scalar, so a multiply filter in front dims it by 1 − mean(t) rather than tinting it",
            ),
            // A filter without colour: coloured transmittance with P = 0.
            BlendOperator::Multiply => self.transmission(caps),
        }
    }
}
