//! The `wavelet` technique: pass 1 finds each pixel's transparent depth interval, pass 2
//! projects every fragment's absorbance step on the Haar basis (additive), pass 3
//! reconstructs the absorbance in front of each fragment and accumulates the weighted colour,
//! and a full-screen composite puts the result over the opaque colour under the exact
//! coverage.

use crate::math::{self, Rank};
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MemoryLedger, Param, ParamInfo, RenderStats,
    ScenePipelineDesc, ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec,
    Unsupported, bind, blend, depth_test, pass,
};
use oit_scene::{BlendOperator, Resolution, Scene};

/// The basis (shaders/wavelet_math.wgsl; no bindings, no includes).
pub const MATH_WGSL: &str = include_str!("../shaders/wavelet_math.wgsl");
/// The geometry passes (shaders/wavelet.wgsl; includes common.wgsl and the math).
pub const PASSES_WGSL: &str = include_str!("../shaders/wavelet.wgsl");
/// The pixel's coefficient textures and their loading, shared by the shading, additive and
/// composite passes (shaders/wavelet_coefficients.wgsl).
pub const COEFFICIENTS_WGSL: &str = include_str!("../shaders/wavelet_coefficients.wgsl");
/// The composite (shaders/wavelet_composite.wgsl; includes the math and the coefficients).
pub const COMPOSITE_WGSL: &str = include_str!("../shaders/wavelet_composite.wgsl");

/// Coefficient targets the shaders declare (rank 4: 32 coefficients, 4 per RGBA target).
pub const MAX_GROUPS: u32 = 8;

oit_gpu::words! {
    /// Precision of the coefficient targets (and of the colour accumulator).
    pub enum Storage {
        F16 = "f16",
        F32 = "f32",
    }
}

/// A valid `wavelet` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Config {
    pub rank: Rank,
    pub storage: Storage,
}

impl Config {
    /// Flywheel's: rank 3 (16 coefficients), binary16 targets.
    pub const DEFAULT: Config = Config {
        rank: Self::RANK.default,
        storage: Self::STORAGE.default,
    };

    pub const RANK: Param<Rank> = Param::new(
        "rank",
        Rank::of(3),
        "Haar levels 0..=rank: 2^(rank+1) coefficients (8, 16 or 32), the depth resolution of the absorbance per pixel",
    );
    pub const STORAGE: Param<Storage> = Param::new(
        "storage",
        Storage::F16,
        "f16: RGBA16F coefficients and accumulator (Flywheel's); f32: RGBA32F (needs FLOAT32_BLENDABLE)",
    );

    pub fn params() -> Vec<ParamInfo> {
        vec![Self::RANK.info(), Self::STORAGE.info()]
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of("wavelet")
            .with(&Self::RANK, self.rank)
            .with(&Self::STORAGE, self.storage)
    }

    /// Refuses a spec that is not `wavelet` with every parameter valid.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Config, SpecError> {
        spec.expect_name("wavelet")?;
        Ok(Config {
            rank: Self::RANK.read(spec)?,
            storage: Self::STORAGE.read(spec)?,
        })
    }

    /// RGBA coefficient targets: N / 4.
    pub fn groups(&self) -> u32 {
        math::coefficient_count(self.rank.get()) / 4
    }

    /// Format of the coefficient targets and of the accumulator.
    pub fn format(&self) -> wgpu::TextureFormat {
        match self.storage {
            Storage::F16 => wgpu::TextureFormat::Rgba16Float,
            Storage::F32 => wgpu::TextureFormat::Rgba32Float,
        }
    }

    /// Bytes per pixel: the RG32F depth interval, the coefficients and the accumulator.
    pub fn bytes_per_pixel(&self) -> u64 {
        let texel = u64::from(self.format().block_copy_size(None).unwrap_or(0));
        8 + (u64::from(self.groups()) + 1) * texel
    }

    /// Pass 2's geometry passes on `caps`: (first group, groups) each.
    pub fn coefficient_passes(&self, caps: &Caps) -> Vec<(u32, u32)> {
        self.coefficient_passes_within(
            caps.max_color_attachments,
            caps.max_color_attachment_bytes_per_sample,
        )
    }

    /// Pass 2's geometry passes within `attachments` colour targets and `bytes_per_sample`
    /// bytes of them a pass: as many groups a pass as both allow (WebGPU's defaults, 8 and
    /// 32 bytes, take four RGBA16F or two RGBA32F targets).
    pub fn coefficient_passes_within(
        &self,
        attachments: u32,
        bytes_per_sample: u32,
    ) -> Vec<(u32, u32)> {
        let cost = self.format().target_pixel_byte_cost().unwrap_or(16).max(1);
        let per = (attachments.min(MAX_GROUPS))
            .min(bytes_per_sample / cost)
            .max(1);
        (0..self.groups())
            .step_by(per as usize)
            .map(|first| (first, per.min(self.groups() - first)))
            .collect()
    }
}

/// Bytes of the uniform block `WaveletParams`.
const PARAMS_BYTES: u64 = 16;

/// The contents of the `WaveletParams` uniform for `scene`.
pub fn params_words(scene: &Scene) -> [u32; 4] {
    let (a, b, ortho) = scene.camera.view_depth_terms();
    [a.to_bits(), b.to_bits(), u32::from(ortho), 0]
}

/// Value both channels of the depth interval target are cleared to (below any −z).
const RANGE_CLEAR: f64 = -1.0e30;

#[derive(Debug)]
struct PixelTargets {
    resolution: Resolution,
    range_view: wgpu::TextureView,
    coefficient_views: Vec<wgpu::TextureView>,
    accum_view: wgpu::TextureView,
    /// Pass 2's view of the interval; pass 3's and the additive pass's of the interval and the
    /// coefficients; the composite's of the accumulator and the coefficients.
    range_group: wgpu::BindGroup,
    resolve_group: wgpu::BindGroup,
    composite_group: wgpu::BindGroup,
    ledger: MemoryLedger,
}

#[derive(Debug)]
struct Pipelines {
    key: (bool, Vec<(u32, u32)>),
    range: ScenePipelines,
    coefficients: Vec<ScenePipelines>,
    shade: ScenePipelines,
}

#[derive(Debug)]
struct Shared {
    params: wgpu::Buffer,
    params_group: wgpu::BindGroup,
    params_layout: wgpu::BindGroupLayout,
    range_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    composite_layout: wgpu::BindGroupLayout,
    /// Groups 0 and 1 of the composite, which reads only group 2.
    empty_layout: wgpu::BindGroupLayout,
    empty_group: wgpu::BindGroup,
    ledger: MemoryLedger,
}

/// Wavelet order-independent transparency.
#[derive(Debug)]
pub struct Wavelet {
    config: Config,
    shared: Option<Shared>,
    pixels: Option<PixelTargets>,
    pipelines: Option<Pipelines>,
    composite: Option<(wgpu::TextureFormat, wgpu::RenderPipeline)>,
    additive: Option<((wgpu::TextureFormat, bool), ScenePipelines)>,
}

impl Wavelet {
    pub fn new(config: Config) -> Self {
        Wavelet {
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

    fn constants(&self) -> [(&'static str, f64); 1] {
        [("WAVELET_RANK", f64::from(self.config.rank.get()))]
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
                    label: Some("wavelet params"),
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
            let params_layout = layout("wavelet params", &[bind::uniform(0, fs)]);
            let range_layout = layout("wavelet range", &[bind::float_texture(0, fs)]);
            let textures: Vec<wgpu::BindGroupLayoutEntry> = (0..=MAX_GROUPS)
                .map(|b| bind::float_texture(b, fs))
                .collect();
            let resolve_layout = layout("wavelet coefficients", &textures);
            let composite_layout = layout("wavelet composite", &textures);
            let empty_layout = layout("wavelet empty", &[]);
            let empty_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wavelet empty"),
                layout: &empty_layout,
                entries: &[],
            });
            let params_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wavelet params"),
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
                range_layout,
                resolve_layout,
                composite_layout,
                empty_layout,
                empty_group,
                ledger,
            });
        }
        let shared = self.shared.as_ref().expect("built above");
        if self.pixels.as_ref().is_none_or(|p| p.resolution != res) {
            let mut ledger = MemoryLedger::new();
            let usage =
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
            let mut texture = |label: &str, format| {
                ledger
                    .create_texture_2d(&ctx.device, label, res, format, usage, 1)
                    .create_view(&Default::default())
            };
            let range_view = texture("wavelet depth interval", wgpu::TextureFormat::Rg32Float);
            let coefficient_views: Vec<wgpu::TextureView> = (0..self.config.groups())
                .map(|g| texture(&format!("wavelet coefficients {g}"), self.config.format()))
                .collect();
            let accum_view = texture("wavelet accumulation", self.config.format());
            fn entry(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
                wgpu::BindGroupEntry {
                    binding,
                    resource: wgpu::BindingResource::TextureView(view),
                }
            }
            // Groups beyond the rank's are never read (`load_coefficients`); the first
            // coefficient view stands in for them.
            let coefficient = |g: u32| {
                coefficient_views
                    .get(g as usize)
                    .unwrap_or(&coefficient_views[0])
            };
            let with_coefficients = |first| -> Vec<wgpu::BindGroupEntry> {
                std::iter::once(entry(0, first))
                    .chain((0..MAX_GROUPS).map(|g| entry(g + 1, coefficient(g))))
                    .collect()
            };
            let range_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wavelet range"),
                layout: &shared.range_layout,
                entries: &[entry(0, &range_view)],
            });
            let resolve_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wavelet coefficients"),
                layout: &shared.resolve_layout,
                entries: &with_coefficients(&range_view),
            });
            let composite_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wavelet composite"),
                layout: &shared.composite_layout,
                entries: &with_coefficients(&accum_view),
            });
            self.pixels = Some(PixelTargets {
                resolution: res,
                range_view,
                coefficient_views,
                accum_view,
                range_group,
                resolve_group,
                composite_group,
                ledger,
            });
        }
        let key = (
            scene.scene.camera.reverse_z,
            self.config.coefficient_passes(&ctx.caps),
        );
        if self.pipelines.as_ref().is_none_or(|p| p.key != key) {
            let module = ctx.shader_with("wavelet.wgsl", PASSES_WGSL, &[crate::SHADERS])?;
            let depth = Some(depth_test(scene.depth_nearer(), false));
            let target = |format, blend| {
                Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(blend),
                    write_mask: wgpu::ColorWrites::ALL,
                })
            };
            let layout = |label, groups: &[Option<&wgpu::BindGroupLayout>]| {
                ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some(label),
                    bind_group_layouts: groups,
                    immediate_size: 0,
                })
            };
            let rank = self.constants();
            let range = ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    targets: &[target(wgpu::TextureFormat::Rg32Float, blend::MAX)],
                    depth: depth.clone(),
                    constants: &rank,
                    ..ScenePipelineDesc::new("wavelet range", &module, "fs_range")
                },
                &layout(
                    "wavelet range",
                    &[Some(ctx.scene_layout()), Some(&shared.params_layout)],
                ),
            );
            let coefficients_layout = layout(
                "wavelet coefficients",
                &[
                    Some(ctx.scene_layout()),
                    Some(&shared.params_layout),
                    Some(&shared.range_layout),
                ],
            );
            let coefficients = (key.1.iter())
                .map(|&(first, count)| {
                    let mut targets: Vec<Option<wgpu::ColorTargetState>> = (0..count)
                        .map(|_| target(self.config.format(), blend::ADDITIVE))
                        .collect();
                    targets.resize(MAX_GROUPS as usize, None);
                    let constants = [rank[0], ("WAVELET_FIRST_GROUP", f64::from(first))];
                    ScenePipelines::with_layout(
                        ctx,
                        &ScenePipelineDesc {
                            targets: &targets,
                            depth: depth.clone(),
                            constants: &constants,
                            ..ScenePipelineDesc::new(
                                "wavelet coefficients",
                                &module,
                                "fs_coefficients",
                            )
                        },
                        &coefficients_layout,
                    )
                })
                .collect();
            let shade = ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    targets: &[target(self.config.format(), blend::ADDITIVE)],
                    depth,
                    constants: &rank,
                    ..ScenePipelineDesc::new("wavelet shade", &module, "fs_shade")
                },
                &layout(
                    "wavelet shade",
                    &[
                        Some(ctx.scene_layout()),
                        Some(&shared.params_layout),
                        Some(&shared.resolve_layout),
                    ],
                ),
            );
            self.pipelines = Some(Pipelines {
                key,
                range,
                coefficients,
                shade,
            });
        }
        Ok(())
    }

    /// The additive pass (`fs_additive`): pass 3's bindings, (one, one) onto the final colour.
    fn additive_pipelines(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
    ) -> Result<ScenePipelines, GpuError> {
        let shared = self.shared.as_ref().expect("built in ensure");
        let module = ctx.shader_with("wavelet.wgsl", PASSES_WGSL, &[crate::SHADERS])?;
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wavelet additive"),
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
                constants: &self.constants(),
                ..ScenePipelineDesc::new("wavelet additive", &module, "fs_additive")
            },
            &layout,
        ))
    }

    fn composite_pipeline(
        &mut self,
        ctx: &Context,
        format: wgpu::TextureFormat,
    ) -> Result<wgpu::RenderPipeline, GpuError> {
        if let Some((f, p)) = &self.composite
            && *f == format
        {
            return Ok(p.clone());
        }
        let shared = self.shared.as_ref().expect("built in ensure");
        let module =
            ctx.shader_with("wavelet_composite.wgsl", COMPOSITE_WGSL, &[crate::SHADERS])?;
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("wavelet composite"),
            // Group 2, as in the geometry passes (shaders/wavelet_coefficients.wgsl).
            bind_group_layouts: &[
                Some(&shared.empty_layout),
                Some(&shared.empty_layout),
                Some(&shared.composite_layout),
            ],
            immediate_size: 0,
        });
        let constants = self.constants();
        let pipeline = oit_gpu::fullscreen_pipeline(
            ctx,
            &oit_gpu::FullscreenDesc {
                label: "wavelet composite",
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
                constants: &constants,
            },
        );
        self.composite = Some((format, pipeline.clone()));
        Ok(pipeline)
    }
}

/// Timer and work names of pass 2's geometry passes.
fn coefficient_pass_name(index: usize, passes: usize) -> String {
    if passes == 1 {
        "wavelet coefficients".to_owned()
    } else {
        format!("wavelet coefficients {}/{passes}", index + 1)
    }
}

impl Technique for Wavelet {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn predict(
        &self,
        scene: &Scene,
        lists: &oit_gpu::predict::PixelLists,
        _caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict(&self.config, scene, lists)
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        let spec = self.config.spec();
        let refuse = |e: Unsupported| Unsupported::new(format!("{spec}: {}", e.reason));
        caps.require_target(wgpu::TextureFormat::Rg32Float, true)
            .map_err(|e| {
                Unsupported::new(format!(
                    "{spec}: the depth interval is MAX-blended into RG32F: {}",
                    e.reason
                ))
            })?;
        caps.require_target(self.config.format(), true)
            .map_err(refuse)?;
        if caps.max_color_attachments < MAX_GROUPS {
            return Err(Unsupported::new(format!(
                "{spec}: the coefficient pass declares {MAX_GROUPS} colour outputs, the adapter allows {} attachments",
                caps.max_color_attachments
            )));
        }
        if caps.max_color_attachment_bytes_per_sample
            < self.config.format().target_pixel_byte_cost().unwrap_or(16)
        {
            return Err(Unsupported::new(format!(
                "{spec}: one coefficient target exceeds the adapter's {} colour-attachment bytes per sample",
                caps.max_color_attachment_bytes_per_sample
            )));
        }
        // The shading pass reads 9 textures: within WebGPU's guaranteed 16 per stage.
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
                "wavelet: the scene is {} but the final colour is {}",
                scene.scene.resolution, targets.resolution
            )));
        }
        self.ensure(ctx, scene)?;
        let composite = self.composite_pipeline(ctx, targets.color_format)?;
        let shared = self.shared.as_ref().expect("built in ensure");
        let pixels = self.pixels.as_ref().expect("built in ensure");
        let pipelines = self.pipelines.as_ref().expect("built in ensure");
        let words = params_words(&scene.scene);
        ctx.queue
            .write_buffer(&shared.params, 0, bytemuck::cast_slice(&words));
        // Additive and subtractive draws add no absorbance: the additive pass adds them after
        // the composite.
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
        let zero = wgpu::LoadOp::Clear(pass::splat(0.0));

        let ts = timer.pass("wavelet range");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let attachments = [pass::color(
                &pixels.range_view,
                wgpu::LoadOp::Clear(pass::splat(RANGE_CLEAR)),
            )];
            let mut p = pass::begin(&mut encoder, "wavelet range", &attachments, depth(), &ts);
            scene.bind(&mut p);
            p.set_bind_group(1, &shared.params_group, &[]);
            for &i in &draws {
                scene.draw(&mut p, &pipelines.range, i);
            }
        }
        timer.submit(ctx, encoder)?;

        let passes = &pipelines.key.1;
        for (n, (&(first, count), coefficients)) in
            passes.iter().zip(&pipelines.coefficients).enumerate()
        {
            let name = coefficient_pass_name(n, passes.len());
            let ts = timer.pass(&name);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let mut attachments: Vec<_> = (pixels.coefficient_views.iter())
                    .skip(first as usize)
                    .take(count as usize)
                    .map(|v| pass::color(v, zero))
                    .collect();
                attachments.resize(MAX_GROUPS as usize, None);
                let mut p = pass::begin(&mut encoder, &name, &attachments, depth(), &ts);
                scene.bind(&mut p);
                p.set_bind_group(1, &shared.params_group, &[]);
                p.set_bind_group(2, &pixels.range_group, &[]);
                for &i in &draws {
                    scene.draw(&mut p, coefficients, i);
                }
            }
            timer.submit(ctx, encoder)?;
        }

        let ts = timer.pass("wavelet shade");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let attachments = [pass::color(&pixels.accum_view, zero)];
            let mut p = pass::begin(&mut encoder, "wavelet shade", &attachments, depth(), &ts);
            scene.bind(&mut p);
            p.set_bind_group(1, &shared.params_group, &[]);
            p.set_bind_group(2, &pixels.resolve_group, &[]);
            for &i in &draws {
                scene.draw(&mut p, &pipelines.shade, i);
            }
        }
        timer.submit(ctx, encoder)?;

        let ts = timer.pass("wavelet composite");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        pass::fullscreen(
            &mut encoder,
            "wavelet composite",
            &targets.color_view,
            &composite,
            &[
                (&shared.empty_group, &[]),
                (&shared.empty_group, &[]),
                (&pixels.composite_group, &[]),
            ],
            &ts,
        );
        timer.submit(ctx, encoder)?;
        let mut geometry_passes = 2 + passes.len() as u32;
        if !additive.is_empty() {
            let key = (targets.color_format, scene.scene.camera.reverse_z);
            if self.additive.as_ref().is_none_or(|(k, _)| *k != key) {
                self.additive = Some((key, self.additive_pipelines(ctx, scene, targets)?));
            }
            let (_, additive_pipelines) = self.additive.as_ref().expect("built above");
            let shared = self.shared.as_ref().expect("built in ensure");
            let pixels = self.pixels.as_ref().expect("built in ensure");
            let ts = timer.pass("wavelet additive");
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            {
                let attachments = [pass::color(&targets.color_view, wgpu::LoadOp::Load)];
                let mut p =
                    pass::begin(&mut encoder, "wavelet additive", &attachments, depth(), &ts);
                scene.bind(&mut p);
                p.set_bind_group(1, &shared.params_group, &[]);
                p.set_bind_group(2, &pixels.resolve_group, &[]);
                for &i in &additive {
                    scene.draw(&mut p, additive_pipelines, i);
                }
            }
            timer.submit(ctx, encoder)?;
            geometry_passes += 1;
        }
        Ok(RenderStats {
            geometry_passes,
            ..Default::default()
        })
    }

    fn work(&self, caps: &Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        let range = texel_bytes(wgpu::TextureFormat::Rg32Float);
        let group = texel_bytes(self.config.format());
        let coefficients = group * self.config.groups();
        let final_texel = texel_bytes(target);
        let passes = self.config.coefficient_passes(caps);
        let mut work = vec![
            // Depth test; the interval texel read and written by its MAX blend.
            PassWork::new("wavelet range", PassDraws::Transparent)
                .bytes(DEPTH_BYTES + range, range),
        ];
        for (n, &(_, count)) in passes.iter().enumerate() {
            // Depth test, the interval loaded; each of this pass's coefficient texels read
            // and written by its additive blend.
            work.push(
                PassWork::new(
                    coefficient_pass_name(n, passes.len()),
                    PassDraws::Transparent,
                )
                .bytes(DEPTH_BYTES + range + count * group, count * group),
            );
        }
        work.extend([
            // Depth test; the interval and every coefficient loaded; the accumulator texel
            // read and written by its additive blend.
            PassWork::new("wavelet shade", PassDraws::Transparent)
                .bytes(DEPTH_BYTES + range + coefficients + group, group),
            // Per pixel: the accumulator and the coefficients loaded, the final texel read
            // and written by the blend.
            PassWork::new("wavelet composite", PassDraws::FullScreen)
                .bytes(group + coefficients + final_texel, final_texel),
            // Only on scenes with additive or subtractive draws.
            PassWork::new("wavelet additive", PassDraws::Additive).bytes(
                DEPTH_BYTES + range + coefficients + final_texel,
                final_texel,
            ),
        ]);
        Work::new(work)
    }

    fn memory_bytes(&self) -> u64 {
        self.shared.as_ref().map_or(0, |s| s.ledger.total())
            + self.pixels.as_ref().map_or(0, |p| p.ledger.total())
    }

    fn transmission(&self, _caps: &Caps) -> Support {
        Support::Approximate(
            "composites 1 − mean(t) as scalar α, exact for grey filters only (its coefficients are of the scalar absorbance −ln(1 − α); per-channel coefficients are not implemented)",
        )
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        match operator {
            BlendOperator::Over => Support::Approximate(
                "weighted by the transmittance the Haar coefficients reconstruct in front of each fragment, normalised under the exact coverage (the technique itself)",
            ),
            BlendOperator::Add | BlendOperator::Subtract => Support::Approximate(
                "no absorbance, kept out of the normalised sum; added after the composite, scaled by the transmittance the coefficients reconstruct at its depth (clamped into the pixel's interval): scalar, so a multiply filter in front dims it by 1 − mean(t) rather than tinting it",
            ),
            BlendOperator::Multiply => self.transmission(caps),
        }
    }
}
