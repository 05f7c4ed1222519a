//! The `opaque-copy` technique: pipelines, the colour copy and the two passes.

use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MemoryLedger, PREMULTIPLIED_OVER, RenderStats,
    ScenePipelineDesc, ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec,
    Unsupported, bind, depth_test, pass,
};
use oit_scene::BlendOperator;

/// The pass file (includes common.wgsl).
pub(crate) const SHADER: &str = include_str!("../shaders/opaque_copy.wgsl");

/// GPU objects for one (colour format, resolution, reverse-Z) combination.
#[derive(Debug)]
struct Resources {
    key: (wgpu::TextureFormat, oit_scene::Resolution, bool),
    /// The opaque pass's colour, copied before the transmissive surfaces draw.
    copy: wgpu::Texture,
    copy_group: wgpu::BindGroup,
    /// Writes `C + t ⊙ copy`, depth test strictly nearer with depth writes.
    transmissive: ScenePipelines,
    /// OVER blending, depth test strictly nearer, no depth writes.
    blend: ScenePipelines,
}

/// Babylon's transmission technique; see the crate documentation.
#[derive(Debug, Default)]
pub struct OpaqueCopy {
    resources: Option<Resources>,
    ledger: MemoryLedger,
}

impl OpaqueCopy {
    pub const NAME: &'static str = "opaque-copy";

    /// Refuses a spec of another name, or with a parameter (it has none).
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        if spec.name() != Self::NAME {
            return Err(SpecError::WrongTechnique {
                spec: spec.to_string(),
                expected: Self::NAME.to_owned(),
            });
        }
        if let Some(key) = spec.params().keys().next() {
            return Err(SpecError::UnknownKey {
                spec: spec.to_string(),
                name: spec.name().to_owned(),
                key: key.clone(),
                keys: "(none)".to_owned(),
            });
        }
        Ok(Self::default())
    }

    fn resources(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
    ) -> Result<(), GpuError> {
        let key = (
            targets.color_format,
            targets.resolution,
            scene.scene.camera.reverse_z,
        );
        if self.resources.as_ref().is_some_and(|r| r.key == key) {
            return Ok(());
        }
        let device = &ctx.device;
        self.ledger.clear();
        let copy = self.ledger.create_texture_2d(
            device,
            "opaque colour copy",
            targets.resolution,
            targets.color_format,
            wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::TEXTURE_BINDING,
            1,
        );
        let fs = wgpu::ShaderStages::FRAGMENT;
        let group_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("opaque copy"),
            entries: &[bind::float_texture(0, fs)],
        });
        let view = copy.create_view(&Default::default());
        let copy_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("opaque copy"),
            layout: &group_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            }],
        });
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("opaque-copy transmissive"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&group_layout)],
            immediate_size: 0,
        });
        let nearer = scene.depth_nearer();
        let module = ctx.shader_with("opaque_copy.wgsl", SHADER, &[crate::SHADERS])?;
        let transmissive = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &[Some(wgpu::ColorTargetState {
                    format: targets.color_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: Some(depth_test(nearer, true)),
                ..ScenePipelineDesc::new("opaque-copy transmissive", &module, "fs_transmissive")
            },
            &layout,
        );
        let blend_module =
            ctx.shader_with("blend.wgsl", oit_gpu::shaders::BLEND, &[crate::SHADERS])?;
        let blend = ScenePipelines::new(
            ctx,
            &ScenePipelineDesc {
                targets: &[Some(wgpu::ColorTargetState {
                    format: targets.color_format,
                    blend: Some(PREMULTIPLIED_OVER),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: Some(depth_test(nearer, false)),
                ..ScenePipelineDesc::new("opaque-copy blend", &blend_module, "fs_blend")
            },
        );
        self.resources = Some(Resources {
            key,
            copy,
            copy_group,
            transmissive,
            blend,
        });
        Ok(())
    }
}

impl Technique for OpaqueCopy {
    fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of(Self::NAME)
    }

    fn predict(
        &self,
        scene: &oit_scene::Scene,
        lists: &oit_gpu::predict::PixelLists,
        _caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict(scene, lists)
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        caps.require_scene_materials()?;
        Ok(())
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        self.resources(ctx, scene, targets)?;
        let r = self.resources.as_ref().expect("resources built above");
        let s = &scene.scene;
        let cpu = std::time::Instant::now();
        let transmissive: Vec<usize> = (0..s.draws.len())
            .filter(|&i| s.material_of(&s.draws[i]).is_transmissive())
            .collect();
        let blended: Vec<usize> = s
            .babylon_object_order()
            .into_iter()
            .filter(|&i| !s.material_of(&s.draws[i]).is_transmissive())
            .collect();
        let cpu_ms = cpu.elapsed().as_secs_f64() * 1e3;
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_texture(
            targets.color.as_image_copy(),
            r.copy.as_image_copy(),
            r.copy.size(),
        );
        let depth = || {
            pass::depth(
                &targets.depth_view,
                wgpu::LoadOp::Load,
                wgpu::StoreOp::Store,
            )
        };
        {
            let ts = timer.pass("transmissive over the opaque copy");
            let mut p = pass::begin(
                &mut encoder,
                "opaque-copy transmissive",
                &[pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                depth(),
                &ts,
            );
            scene.bind(&mut p);
            p.set_bind_group(1, &r.copy_group, &[]);
            for &i in &transmissive {
                scene.draw(&mut p, &r.transmissive, i);
            }
        }
        {
            let ts = timer.pass("blend");
            let mut p = pass::begin(
                &mut encoder,
                "opaque-copy blend",
                &[pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                depth(),
                &ts,
            );
            scene.bind(&mut p);
            for &i in &blended {
                scene.draw(&mut p, &r.blend, i);
            }
        }
        timer.submit(ctx, encoder)?;
        Ok(RenderStats {
            geometry_passes: 2,
            cpu_ms,
            ..Default::default()
        })
    }

    fn work(&self, _caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        let texel = texel_bytes(target);
        // Not a pass of the timer: the copy of the opaque colour before the passes (a
        // texture-to-texture copy, W·H texels read and written, outside the timestamps).
        Work::new(vec![
            // Depth test and write; the copy's texel read in the shader; the colour written
            // without blending.
            PassWork::new("transmissive over the opaque copy", PassDraws::Transmissive)
                .bytes(DEPTH_BYTES + texel, DEPTH_BYTES + texel),
            // Depth test (no write); the premultiplied over reads and writes the target.
            PassWork::new("blend", PassDraws::NotTransmissive).bytes(DEPTH_BYTES + texel, texel),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    fn transmission(&self, _caps: &Caps) -> Support {
        Support::Approximate(
            "exact for the nearest transmissive surface over opaque content and for transparent surfaces in front of it; what is transparent or transmissive behind it is missing from the copy",
        )
    }

    fn queues(&self) -> oit_gpu::Queues {
        // Objects are drawn in the engine's (group, queue, order, distance) order; no
        // transparent draw writes depth.
        oit_gpu::Queues::Ordered
    }

    fn operator(&self, operator: BlendOperator, _caps: &Caps) -> Support {
        match operator {
            BlendOperator::Over => Support::Approximate(
                "premultiplied over in Babylon's object order; hidden behind the nearest transmissive surface",
            ),
            // (P, α = 0): the shared blend pass's (one, one-minus-src-alpha) gives dst + P.
            BlendOperator::Add | BlendOperator::Subtract => Support::Approximate(
                "blended in Babylon's object order with (one, one-minus-src-alpha), which with α = 0 is dst + P: exact in front of the nearest transmissive surface; behind it hidden by its depth, as every transparent fragment there is",
            ),
            // `Material::is_transmissive`: drawn as glass.
            BlendOperator::Multiply => Support::Approximate(
                "drawn as glass: P = 0 plus its per-channel t times the copy of the opaque colour, writing depth, so it is exact over opaque content and hides transparent and transmissive layers behind it",
            ),
        }
    }
}
