//! `a2c:samples=4|8`: MSAA alpha-to-coverage.
//!
//! The opaque pass is single-sampled (shared by all techniques), so its colour and depth are
//! copied into every sample of multisampled targets first; transparent draws then write
//! opaque fragments with depth while alpha-to-coverage keeps ≈ α·N of the N samples; the
//! colour is resolved (sample average) into the final target.
//!
//! Compared with the single-sample reference: inside a triangle every sample is covered and
//! the only difference is the driver's α → mask quantisation (N + 1 levels, the same mask for
//! the same α, so equal-α layers correlate). Along transparent triangle edges, MSAA covers a
//! fraction of a pixel's samples where the reference takes all-or-nothing at the pixel centre:
//! the resolve blends across the edge (anti-aliasing the reference does not have). Opaque
//! edges come from the single-sample pass and stay aliased exactly as in the reference.

use crate::config::{A2cConfig, Samples};
use crate::gpu;
use oit_gpu::pass;
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MemoryLedger, RenderStats, ScenePipelineDesc,
    ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec, Unsupported,
};
use oit_scene::BlendOperator;
use oit_scene::Resolution;

/// WGSL of the alpha-to-coverage pass.
pub const A2C_WGSL: &str = include_str!("../shaders/stochastic_a2c.wgsl");

/// The `a2c` technique.
#[derive(Debug)]
pub struct AlphaToCoverage {
    config: A2cConfig,
    gpu: Option<Resources>,
    ledger: MemoryLedger,
    order: gpu::DrawOrder,
}

#[derive(Debug)]
struct Resources {
    key: (wgpu::TextureFormat, bool, Resolution, bool),
    /// Scenes with additive or subtractive draws: their pipeline (`fs_additive`), drawn after
    /// the alpha-to-coverage draws in the same pass.
    additive: Option<ScenePipelines>,
    color_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    seed: gpu::SeedPass,
    a2c: ScenePipelines,
}

/// Whether `format` can be multisampled `samples`× (and resolved, for colour) on this device.
fn multisample_supported(
    ctx: &Context,
    format: wgpu::TextureFormat,
    samples: u32,
    resolve: bool,
) -> bool {
    let features = if ctx.caps.adapter_specific_format_features {
        ctx.adapter.get_texture_format_features(format)
    } else {
        format.guaranteed_format_features(ctx.device.features())
    };
    features.flags.sample_count_supported(samples)
        && (!resolve
            || features
                .flags
                .contains(wgpu::TextureFormatFeatureFlags::MULTISAMPLE_RESOLVE))
}

impl AlphaToCoverage {
    pub fn new(config: A2cConfig) -> Self {
        AlphaToCoverage {
            config,
            gpu: None,
            ledger: MemoryLedger::new(),
            order: gpu::DrawOrder::default(),
        }
    }

    /// Issues the draws in plain reverse draw order instead of nearest first where no depth
    /// tie can depend on it (see [`crate::dither_order`]): the same image, more fragments
    /// shaded. To compare the two.
    pub fn in_reverse_draw_order(mut self) -> Self {
        self.order = gpu::DrawOrder::reverse_only();
        self
    }

    /// Refuses a spec that does not describe an a2c configuration.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(A2cConfig::from_spec(spec)?))
    }

    /// `Err` with the reason when this device cannot multisample the final colour format and
    /// Depth32Float `samples`× (format features, as wgpu validates them).
    pub fn supported(
        ctx: &Context,
        color: wgpu::TextureFormat,
        samples: u32,
    ) -> Result<(), Unsupported> {
        for (format, resolve) in [(color, true), (wgpu::TextureFormat::Depth32Float, false)] {
            if !multisample_supported(ctx, format, samples, resolve) {
                return Err(Unsupported::new(format!(
                    "the adapter cannot {} {format:?} with {samples} samples{}",
                    if resolve {
                        "multisample and resolve"
                    } else {
                        "multisample"
                    },
                    if ctx.caps.adapter_specific_format_features {
                        ""
                    } else {
                        " (no TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES: only WebGPU's 4x is guaranteed)"
                    }
                )));
            }
        }
        Ok(())
    }

    fn prepare(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        samples: u32,
    ) -> Result<(), GpuError> {
        let has_additive = (scene.scene.operators_used().iter()).any(|&op| op.is_additive());
        let key = (
            targets.color_format,
            scene.scene.camera.reverse_z,
            targets.resolution,
            has_additive,
        );
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        Self::supported(ctx, targets.color_format, samples)?;
        self.gpu = None;
        self.ledger.clear();
        let device = &ctx.device;
        let mut texture = |label, format| {
            self.ledger.create_texture_2d(
                device,
                label,
                targets.resolution,
                format,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
                samples,
            )
        };
        let color = texture("a2c msaa colour", targets.color_format);
        let depth = texture("a2c msaa depth", wgpu::TextureFormat::Depth32Float);
        let multisample = wgpu::MultisampleState {
            count: samples,
            mask: !0,
            alpha_to_coverage_enabled: false,
        };
        let seed = gpu::SeedPass::new(ctx, targets.color_format, multisample)?;
        let module = ctx.shader_with("stochastic_a2c.wgsl", A2C_WGSL, &[crate::SHADERS])?;
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("a2c"),
            bind_group_layouts: &[Some(ctx.scene_layout())],
            immediate_size: 0,
        });
        let a2c = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &[Some(wgpu::ColorTargetState {
                    format: targets.color_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: Some(oit_gpu::depth_test(scene.depth_nearer(), true)),
                multisample: wgpu::MultisampleState {
                    alpha_to_coverage_enabled: true,
                    ..multisample
                },
                ..ScenePipelineDesc::new("a2c", &module, "fs_a2c")
            },
            &layout,
        );
        let additive = has_additive.then(|| {
            ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    targets: &[Some(wgpu::ColorTargetState {
                        format: targets.color_format,
                        blend: Some(oit_gpu::blend::ADDITIVE),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                    depth: Some(oit_gpu::depth_test(scene.depth_nearer(), false)),
                    multisample,
                    ..ScenePipelineDesc::new("a2c additive", &module, "fs_additive")
                },
                &layout,
            )
        });
        self.gpu = Some(Resources {
            key,
            additive,
            color_view: color.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            seed,
            a2c,
        });
        Ok(())
    }

    /// `(label, bytes)` of every allocation (empty before the first render).
    pub fn memory_entries(&self) -> &[(String, u64)] {
        self.ledger.entries()
    }
}

impl Technique for AlphaToCoverage {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn predict(
        &self,
        _scene: &oit_scene::Scene,
        _lists: &oit_gpu::predict::PixelLists,
        _caps: &Caps,
    ) -> oit_gpu::Prediction {
        oit_gpu::Prediction::unmodelled(
            "alpha to coverage quantises α to the sample mask's dither, which no per-pixel rule predicts: measured only",
        )
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        let config = self.config;
        caps.require_scene_materials()?;
        // Caps only records 4x; the exact test for the target's format runs in `render`.
        let depth = caps.format(wgpu::TextureFormat::Depth32Float);
        if config.samples == Samples::Four && !depth.multisample_x4 {
            return Err(Unsupported::new(
                "the adapter cannot multisample Depth32Float 4x",
            ));
        }
        if config.samples == Samples::Eight && !caps.adapter_specific_format_features {
            return Err(Unsupported::new(
                "8x MSAA needs TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES (WebGPU guarantees only 4x)",
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
        let config = self.config;
        self.prepare(ctx, scene, targets, config.samples.count())?;
        let r = self.gpu.as_ref().expect("resources prepared above");
        let seed_group = r.seed.bind_group(ctx, targets);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let ts = timer.pass("a2c seed msaa");
        {
            let mut pass = pass::begin(
                &mut encoder,
                "a2c seed msaa",
                &[pass::color(
                    &r.color_view,
                    wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                )],
                pass::depth(
                    &r.depth_view,
                    wgpu::LoadOp::Clear(scene.scene.camera.far_depth()),
                    wgpu::StoreOp::Store,
                ),
                &ts,
            );
            r.seed.draw(&mut pass, &seed_group);
        }
        let ts = timer.pass("a2c");
        {
            let mut pass = pass::begin(
                &mut encoder,
                "a2c",
                &[Some(wgpu::RenderPassColorAttachment {
                    view: &r.color_view,
                    depth_slice: None,
                    resolve_target: Some(&targets.color_view),
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Discard,
                    },
                })],
                pass::depth(&r.depth_view, wgpu::LoadOp::Load, wgpu::StoreOp::Discard),
                &ts,
            );
            scene.bind(&mut pass);
            // Additive and subtractive draws cover no sample: drawn after the others,
            // depth-tested per sample (`fs_additive`).
            let (additive, order): (Vec<usize>, Vec<usize>) =
                self.order.of(scene).iter().copied().partition(|&i| {
                    let s = &scene.scene;
                    s.material_of(&s.draws[i]).operator.is_additive()
                });
            for &i in &order {
                gpu::draw_with_id(&mut pass, scene, &r.a2c, i);
            }
            if let Some(pipelines) = &r.additive {
                for &i in &additive {
                    gpu::draw_with_id(&mut pass, scene, pipelines, i);
                }
            }
        }
        timer.submit(ctx, encoder)?;
        Ok(RenderStats {
            geometry_passes: 1,
            ..Default::default()
        })
    }

    fn work(&self, _caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        // Occlusion queries count samples on the multisampled targets: every number here is
        // per sample.
        let samples = self.config.samples.count();
        let texel = texel_bytes(target);
        Work::new(vec![
            // The opaque colour and depth loaded once per pixel (shared by its samples, the
            // division rounds down at 8 samples) and written to every sample. The multisample
            // resolve at the end of the "a2c" pass (S texels read, one written per pixel) is
            // priced here, on the seed's W·H·S samples, because that pass's count holds only
            // the scene's samples.
            PassWork::new("a2c seed msaa", PassDraws::FullScreen).bytes(
                (texel + DEPTH_BYTES) / samples + texel,
                DEPTH_BYTES + texel + texel / samples,
            ),
            // A covered sample: depth test and write, colour written without blending.
            PassWork::new("a2c", PassDraws::Transparent).bytes(DEPTH_BYTES, DEPTH_BYTES + texel),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    fn transmission(&self, _caps: &Caps) -> Support {
        // Scalar alpha: the shader's `Shaded.alpha` is 1 − mean(t) for transmissive fragments.
        Support::Approximate(
            "composites 1 − mean(t) as scalar α, exact for grey filters only (coverage samples are decided by the scalar α; no per-channel scheme is implemented)",
        )
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        match operator {
            BlendOperator::Over => Support::Approximate(
                "coverage quantised to the driver's sample masks (the technique itself)",
            ),
            // (P, t = 1): `fs_additive` after the alpha-to-coverage draws.
            BlendOperator::Add | BlendOperator::Subtract => Support::Approximate(
                "covers no sample; drawn after the other layers, depth-tested per sample without writing depth and added, so after the resolve it is scaled by the fraction of samples no kept layer covers in front of it: the quantised, correlated masks' estimate of the transmittance (Enderton et al.'s accumulation pass)",
            ),
            // A filter without colour: coloured transmittance with P = 0.
            BlendOperator::Multiply => self.transmission(caps),
        }
    }
}
