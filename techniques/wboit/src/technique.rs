//! The `wboit` and `weighted-average` techniques: one accumulation pass over the transparent
//! draws, then the shared guarded composite of [`crate::tail`].

use crate::additive::{AdditivePass, is_additive};
use crate::guards::GuardCounts;
use crate::range::RangeParams;
use crate::tail::{self, AccumFormat, AccumTargets, CompositeMode, RevealFormat};
use oit_gpu::pass;
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MemoryLedger, Param, ParamInfo, RenderStats,
    ScenePipelineDesc, ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec,
    Unsupported, depth_test,
};
use oit_scene::BlendOperator;

/// The accumulation pass (shaders/wboit_accum.wgsl; includes common.wgsl and the tail).
pub const ACCUM_WGSL: &str = include_str!("../shaders/wboit_accum.wgsl");

oit_gpu::words! {
    /// The weight functions. z is the positive view distance, d the conventional window depth
    /// (0 at near, 1 at far; `1 − window z` under reverse-Z), α the fragment's coverage.
    pub enum Weight {
        /// w = 1: Eq. 5 of the paper without depth weights.
        Const = "const",
        /// w = α (pygfx's default).
        Alpha = "alpha",
        /// Eq. 7: α·clamp(10 / (1e-5 + (z/5)² + (z/200)⁶), 1e-2, 3e3).
        Eq7 = "eq7",
        /// Eq. 8: α·clamp(10 / (1e-5 + (z/10)³ + (z/200)⁶), 1e-2, 3e3).
        Eq8 = "eq8",
        /// Eq. 9: α·clamp(0.03 / (1e-5 + (z/200)⁴), 1e-2, 3e3).
        Eq9 = "eq9",
        /// Eq. 10: α·max(1e-2, 3e3·(1 − d)³).
        Eq10 = "eq10",
        /// McGuire 2015: a = 8·min(1, α) + 0.01, b = 1 − 0.95·d, w = clamp(a³·1e8·b³, 1e-2, 3e2).
        McGuire2015 = "mcguire2015",
        /// Ours: an estimate of the transmittance in front of the fragment, w = 256·2^(−fall·t),
        /// t = position of z in the scene's transparent depth interval (0 near end, 1 far end),
        /// fall = the scene's mean absorbance in bits in front of the farthest fragment where
        /// fragments overlap, at most 21 and at most what keeps α·w of the scene's faintest layer a
        /// normal fp16 number ([`RangeParams`], [`crate::range::fall_cap`]). No α factor (the
        /// transmittance is the exact weight). At most 256: with colour sums in units of the
        /// scene's colour scale, 255 layers of α = 1 still fit in fp16.
        Range = "range",
}
}

impl Weight {
    /// The `weight` switch value in the shader.
    pub fn index(self) -> u32 {
        Self::ALL.iter().position(|&w| w == self).unwrap_or(0) as u32
    }

    /// CPU twin of the shader's `weight` (for tests and documentation tables).
    pub fn eval(self, z: f32, d: f32, alpha: f32, range: &RangeParams) -> f32 {
        let cube = |x: f32| x * x * x;
        match self {
            Weight::Const => 1.0,
            Weight::Alpha => alpha,
            Weight::Eq7 => {
                let s = z / 200.0;
                alpha * (10.0 / (1e-5 + (z / 5.0).powi(2) + cube(s) * cube(s))).clamp(1e-2, 3e3)
            }
            Weight::Eq8 => {
                let s = z / 200.0;
                alpha * (10.0 / (1e-5 + cube(z / 10.0) + cube(s) * cube(s))).clamp(1e-2, 3e3)
            }
            Weight::Eq9 => alpha * (0.03 / (1e-5 + (z / 200.0).powi(4))).clamp(1e-2, 3e3),
            Weight::Eq10 => alpha * (3e3 * cube(1.0 - d)).max(1e-2),
            Weight::McGuire2015 => {
                let a = alpha.min(1.0) * 8.0 + 0.01;
                let b = 1.0 - 0.95 * d;
                (cube(a) * 1e8 * cube(b)).clamp(1e-2, 3e2)
            }
            Weight::Range => range.weight(z),
        }
    }
}

/// A `wboit` or `weighted-average` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Config {
    Weighted {
        weight: Weight,
        accum: AccumFormat,
        reveal: RevealFormat,
    },
    /// Bavoil & Myers 2008: rgba16f (ΣC, Σα) and an r32f fragment count.
    Average,
}

impl Config {
    /// The defaults: `range` (bounded for fp16 on every depth range), `rgba16f` (blendable on
    /// every adapter), `r16f` (keeps α = 1/512 layers that R8 drops).
    pub const DEFAULT: Config = Config::Weighted {
        weight: Self::WEIGHT.default,
        accum: Self::ACCUM.default,
        reveal: Self::REVEAL.default,
    };

    pub const WEIGHT: Param<Weight> = Param::new(
        "weight",
        Weight::Range,
        "depth weight: const (1), alpha, the paper's eq7-eq10, mcguire2015 (the 1e8 form), range (ours: estimated transmittance from the scene's transparent depth interval and mean absorbance, fp16-bounded)",
    );
    pub const ACCUM: Param<AccumFormat> = Param::new(
        "accum",
        tail::DEFAULT_ACCUM,
        "accumulation format (rgba32f needs FLOAT32_BLENDABLE)",
    );
    pub const REVEAL: Param<RevealFormat> = Param::new(
        "reveal",
        tail::DEFAULT_REVEAL,
        "revealage format (r8 loses alpha < 1/510; r32f needs FLOAT32_BLENDABLE)",
    );

    /// The registry's view of `wboit`'s parameters (`weighted-average` has none).
    pub fn params() -> Vec<ParamInfo> {
        vec![Self::WEIGHT.info(), Self::ACCUM.info(), Self::REVEAL.info()]
    }

    pub fn spec(&self) -> TechniqueSpec {
        match *self {
            Config::Weighted {
                weight,
                accum,
                reveal,
            } => TechniqueSpec::of("wboit")
                .with(&Self::WEIGHT, weight)
                .with(&Self::ACCUM, accum)
                .with(&Self::REVEAL, reveal),
            Config::Average => TechniqueSpec::of("weighted-average"),
        }
    }

    /// Refuses a spec that is neither `wboit` with every parameter nor `weighted-average`.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Config, SpecError> {
        if spec.name() == "weighted-average" {
            return Ok(Config::Average);
        }
        spec.expect_name("wboit")?;
        Ok(Config::Weighted {
            weight: Self::WEIGHT.read(spec)?,
            accum: Self::ACCUM.read(spec)?,
            reveal: Self::REVEAL.read(spec)?,
        })
    }

    /// Why this configuration cannot modulate a final colour of `color` per channel on
    /// `caps` (McGuire & Mara's coloured transmission), if so.
    pub fn modulation_unsupported(
        &self,
        caps: &Caps,
        color: wgpu::TextureFormat,
    ) -> Option<String> {
        let (_, accum, reveal) = self.formats();
        tail::modulation_unsupported(caps, accum, reveal, color)
    }

    fn formats(&self) -> (CompositeMode, AccumFormat, RevealFormat) {
        match *self {
            Config::Weighted { accum, reveal, .. } => (CompositeMode::Weighted, accum, reveal),
            Config::Average => (
                CompositeMode::Average,
                AccumFormat::Rgba16f,
                RevealFormat::R32f,
            ),
        }
    }
}

/// The widest final colour format: whether the per-channel modulation target fits is judged
/// for it, so one configuration composites the same way on every final target.
const WIDEST_COLOR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

#[derive(Debug)]
struct Pipelines {
    reverse_z: bool,
    /// The final colour format when the pass also modulates it per channel (coloured
    /// transmission), else `None`.
    modulated: Option<wgpu::TextureFormat>,
    /// Built with the override `WBOIT_UNIT_SCALE` (the colour scale is 1).
    unit_scale: bool,
    scene: ScenePipelines,
}

/// Weighted blended OIT or the weighted average.
#[derive(Debug)]
pub struct Wboit {
    config: Config,
    accum: Option<AccumTargets>,
    pipelines: Option<Pipelines>,
    params: Option<(wgpu::Buffer, wgpu::BindGroupLayout, wgpu::BindGroup)>,
    /// `range` inputs of the last scene (by `GpuScene::id`): computed once per scene.
    range: Option<(u64, RangeParams)>,
    /// The pass of additive and subtractive draws (built for the first scene that has them).
    additive: Option<AdditivePass>,
    ledger: MemoryLedger,
}

impl Wboit {
    pub fn new(config: Config) -> Self {
        Wboit {
            config,
            accum: None,
            pipelines: None,
            params: None,
            range: None,
            additive: None,
            ledger: MemoryLedger::new(),
        }
    }

    pub fn config(&self) -> Config {
        self.config
    }

    /// The guard counts of the last rendered frame (waits for the GPU). `None` before the
    /// first frame.
    pub fn last_guard_counts(&self, ctx: &Context) -> Result<Option<GuardCounts>, GpuError> {
        self.accum.as_ref().map(|a| a.guard_counts(ctx)).transpose()
    }

    /// The accumulation targets (after the first frame), e.g. to read them back in tests.
    pub fn accum_targets(&self) -> Option<&AccumTargets> {
        self.accum.as_ref()
    }

    /// The `range` weight's inputs for `scene` (cached per uploaded scene).
    fn range(&mut self, scene: &GpuScene) -> RangeParams {
        match self.range {
            Some((id, r)) if id == scene.id => r,
            _ => {
                let r = RangeParams::of(&scene.scene);
                self.range = Some((scene.id, r));
                r
            }
        }
    }

    /// `modulated`: the final colour format when the pass modulates it per channel;
    /// `unit_scale`: whether the colour scale is 1.
    fn ensure(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        modulated: Option<wgpu::TextureFormat>,
        unit_scale: bool,
    ) -> Result<(), GpuError> {
        let (mode, accum, reveal) = self.config.formats();
        let res = scene.scene.resolution;
        if self.accum.as_ref().is_none_or(|a| a.resolution != res) {
            let targets = AccumTargets::with_formats(ctx, res, mode, accum, reveal)?;
            if let Some(pass) = &mut self.additive {
                pass.rebind(ctx, &targets);
            }
            self.accum = Some(targets);
        }
        if self.params.is_none() {
            let buffer = self.ledger.create_buffer(
                &ctx.device,
                &wgpu::BufferDescriptor {
                    label: Some("wboit weight params"),
                    size: 48,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                },
            );
            let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("wboit weight params"),
                entries: &[oit_gpu::bind::uniform(0, wgpu::ShaderStages::FRAGMENT)],
            });
            let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wboit weight params"),
                layout: &layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                }],
            });
            self.params = Some((buffer, layout, group));
        }
        let reverse_z = scene.scene.camera.reverse_z;
        if self.pipelines.as_ref().is_none_or(|p| {
            p.reverse_z != reverse_z || p.modulated != modulated || p.unit_scale != unit_scale
        }) {
            let accum = self
                .accum
                .as_ref()
                .expect("accumulation targets built above");
            let (_, layout, _) = self.params.as_ref().expect("params built above");
            let module = ctx.shader_with("wboit_accum.wgsl", ACCUM_WGSL, &[crate::SHADERS])?;
            let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("wboit accumulate"),
                bind_group_layouts: &[Some(ctx.scene_layout()), Some(layout)],
                immediate_size: 0,
            });
            let entry = match (self.config, modulated) {
                (Config::Weighted { .. }, None) => "fs_wboit",
                (Config::Average, None) => "fs_average",
                (Config::Weighted { .. }, Some(_)) => "fs_wboit_coloured",
                (Config::Average, Some(_)) => "fs_average_coloured",
            };
            let targets: Vec<_> = match modulated {
                None => accum.color_targets().to_vec(),
                Some(color) => accum.modulating_color_targets(color).to_vec(),
            };
            // The shared vertex stage of common.wgsl, depth tested strictly nearer than the
            // opaque depth, no depth writes.
            let weight = match self.config {
                Config::Weighted { weight, .. } => weight,
                Config::Average => Weight::Const,
            };
            let constants = [
                ("WBOIT_WEIGHT", f64::from(weight.index())),
                ("WBOIT_UNIT_SCALE", if unit_scale { 1.0 } else { 0.0 }),
            ];
            let pipelines = ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    targets: &targets,
                    depth: Some(depth_test(scene.depth_nearer(), false)),
                    constants: &constants,
                    ..ScenePipelineDesc::new("wboit accumulate", &module, entry)
                },
                &pipeline_layout,
            );
            self.pipelines = Some(Pipelines {
                reverse_z,
                modulated,
                unit_scale,
                scene: pipelines,
            });
        }
        Ok(())
    }
}

impl Technique for Wboit {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn predict(
        &self,
        scene: &oit_scene::Scene,
        lists: &oit_gpu::predict::PixelLists,
        _caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict(self.config, scene, lists)
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        let (_, accum, reveal) = self.config.formats();
        tail::check_formats(caps, accum, reveal)
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        // Coloured transmission: the final colour is a third target, multiplied per channel
        // (decided for the widest final target, as `transmission` reports it).
        let modulated = (scene.scene.has_coloured_transmission()
            && self
                .config
                .modulation_unsupported(&ctx.caps, WIDEST_COLOR)
                .is_none())
        .then_some(targets.color_format);
        let range = self.range(scene);
        // The weighted average accumulates unweighted colour, unscaled.
        let (weight, color_scale) = match self.config {
            Config::Weighted { weight, .. } => (weight.index(), range.color_scale),
            Config::Average => (Weight::Const.index(), 1.0),
        };
        self.ensure(ctx, scene, modulated, color_scale == 1.0)?;
        // Additive and subtractive draws are left out of the sums (crate::additive).
        let (additive, draws): (Vec<usize>, Vec<usize>) = scene
            .transparent_draws()
            .into_iter()
            .partition(|&i| is_additive(scene, i));
        if !additive.is_empty()
            && self
                .additive
                .as_ref()
                .is_none_or(|p| !p.fits(scene, targets))
        {
            let (_, layout, _) = self.params.as_ref().expect("params built in ensure");
            let accum = self.accum.as_ref().expect("targets built in ensure");
            self.additive = Some(AdditivePass::new(ctx, scene, targets, layout, accum)?);
        }
        let s = &scene.scene;
        let (a, b, ortho) = s.camera.view_depth_terms();
        let words: [u32; 12] = [
            weight,
            u32::from(s.camera.reverse_z),
            u32::from(ortho),
            range.fall.to_bits(),
            a.to_bits(),
            b.to_bits(),
            range.z_near.to_bits(),
            range.z_far.to_bits(),
            color_scale.to_bits(),
            u32::from(self.config == Config::Average),
            0,
            0,
        ];
        let (params, _, group) = self.params.as_ref().expect("params built in ensure");
        ctx.queue
            .write_buffer(params, 0, bytemuck::cast_slice(&words));
        let accum = self.accum.as_mut().expect("targets built in ensure");
        accum.set_color_scale(color_scale);
        accum.set_background_modulated(modulated.is_some());
        let accum = &*accum;
        let pipelines = self.pipelines.as_ref().expect("pipelines built in ensure");
        let ts = timer.pass("wboit accumulate");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut attachments = accum.attachments(true).to_vec();
            if modulated.is_some() {
                attachments.push(pass::color(&targets.color_view, wgpu::LoadOp::Load));
            }
            let mut pass = pass::begin(
                &mut encoder,
                "wboit accumulate",
                &attachments,
                pass::depth(
                    &targets.depth_view,
                    wgpu::LoadOp::Load,
                    wgpu::StoreOp::Store,
                ),
                &ts,
            );
            scene.bind(&mut pass);
            pass.set_bind_group(1, group, &[]);
            for &i in &draws {
                scene.draw(&mut pass, &pipelines.scene, i);
            }
        }
        timer.submit(ctx, encoder)?;
        tail::composite(ctx, targets, accum, timer)?;
        let mut geometry_passes = 1;
        if let (false, Some(pass)) = (additive.is_empty(), &self.additive) {
            let ts = timer.pass("wboit additive");
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            pass.draw(&mut encoder, scene, targets, group, &additive, &ts);
            timer.submit(ctx, encoder)?;
            geometry_passes = 2;
        }
        Ok(RenderStats {
            geometry_passes,
            ..Default::default()
        })
    }

    fn work(&self, _caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        let (_, accum, reveal) = self.config.formats();
        // On a scene with coloured transmission the accumulation also multiplies a third,
        // modulated target (the final colour's format): not counted here.
        oit_gpu::Work::new(vec![
            tail::accumulate_work("wboit accumulate", accum, reveal),
            tail::composite_work(accum, reveal, target),
            crate::additive::work(accum, reveal, target),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.ledger.total() + self.accum.as_ref().map_or(0, AccumTargets::memory_bytes)
    }

    fn transmission(&self, caps: &Caps) -> Support {
        match self.config.modulation_unsupported(caps, WIDEST_COLOR) {
            None => Support::Approximate(
                "McGuire & Mara 2015: what lies behind is multiplied by the exact per-channel product of the layers' transmittances (a third, modulated target); the layers' own radiance is the weighted average under the scalar coverage 1 − mean(t)",
            ),
            Some(_) => Support::Approximate(
                "composites 1 − mean(t) as scalar α, exact for grey filters only (McGuire & Mara's per-channel modulation target does not fit this adapter's colour attachments with these formats)",
            ),
        }
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        let modulated = self
            .config
            .modulation_unsupported(caps, WIDEST_COLOR)
            .is_none();
        match (operator, self.config) {
            (BlendOperator::Over, _) => Support::Approximate(
                "the order-independent weighted average under the exact coverage (the technique itself)",
            ),
            // (P, t = 1): crate::additive.
            (BlendOperator::Add | BlendOperator::Subtract, Config::Weighted { .. }) => {
                Support::Approximate(
                    "kept out of the weighted sums and added after the composite, scaled by the visibility the composite gives an over layer at its depth, w(z)·(1 − Π(1 − α))/Σαw with the weight at α = 1, at most 1 (1 where the pixel has no over layer): exact alone or in front of every layer when the weight falls with depth, WBOIT's estimate behind layers, scalar behind multiply filters",
                )
            }
            (BlendOperator::Add | BlendOperator::Subtract, Config::Average) => {
                Support::Approximate(
                    "kept out of the average and added after the composite, scaled by (1 − T)/Σα, the factor the average gives every layer (1 where the pixel has no over layer): exact alone, depth-blind behind layers",
                )
            }
            // A filter without colour: coloured transmittance with P = 0.
            (BlendOperator::Multiply, _) if modulated => Support::Approximate(
                "a colourless filter: what lies behind the transparent layers is multiplied by its exact per-channel t (McGuire & Mara's modulation target); layers and additive light behind it are dimmed by its scalar coverage 1 − mean(t) through the weighted average, not tinted",
            ),
            (BlendOperator::Multiply, _) => Support::Approximate(
                "a colourless filter composited as the scalar coverage 1 − mean(t) (the per-channel modulation target does not fit this adapter's colour attachments): grey, exact for grey filters only",
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The clamp crossings of the paper's weights as tabulated in the anchors (computed there
    /// independently): eq7 caps below z = 0.29 and floors above 158, eq8 1.49 and 100, eq9
    /// floors above 263; the 1e8 form sits at its 3e2 cap for α = 0.1 at every depth.
    #[test]
    fn paper_weights_cross_their_clamps_where_tabulated() {
        let r = RangeParams {
            z_near: 1.0,
            z_far: 2.0,
            fall: 1.0,
            color_scale: 1.0,
        };
        let w = |weight: Weight, z: f32| weight.eval(z, 0.5, 1.0, &r);
        assert_eq!(w(Weight::Eq7, 0.28), 3e3);
        assert!(w(Weight::Eq7, 0.30) < 3e3);
        assert!(w(Weight::Eq7, 157.0) > 1e-2);
        assert_eq!(w(Weight::Eq7, 159.0), 1e-2);
        assert_eq!(w(Weight::Eq8, 1.48), 3e3);
        assert!(w(Weight::Eq8, 1.50) < 3e3);
        assert!(w(Weight::Eq8, 99.0) > 1e-2);
        assert_eq!(w(Weight::Eq8, 101.0), 1e-2);
        assert!(w(Weight::Eq9, 262.0) > 1e-2);
        assert_eq!(w(Weight::Eq9, 264.0), 1e-2);
        for d in [0.0, 0.5, 0.99, 1.0] {
            assert_eq!(Weight::McGuire2015.eval(1.0, d, 0.1, &r), 3e2, "d = {d}");
        }
        // Eq. 10 on window depth: 3e3 at the near plane, the 1e-2 floor at the far plane.
        assert_eq!(Weight::Eq10.eval(1.0, 0.0, 1.0, &r), 3e3);
        assert_eq!(Weight::Eq10.eval(1.0, 1.0, 1.0, &r), 1e-2);
        assert_eq!(Weight::Const.eval(7.0, 0.3, 0.2, &r), 1.0);
        assert_eq!(Weight::Alpha.eval(7.0, 0.3, 0.2, &r), 0.2);
        assert_eq!(Weight::Range.eval(2.0, 0.3, 1.0, &r), 128.0);
        assert_eq!(
            Weight::Range.eval(1.0, 0.3, 0.2, &r),
            256.0,
            "no alpha factor"
        );
    }
}
