//! `hybrid` (Maule, Comba, Torchelsen & Bastos, "Hybrid Transparency", I3D 2013): the K nearest
//! fragments of a pixel composited exactly, the rest accumulated order-independently with
//! weights — here the k-buffer's slots as the core and its averaged tail with each fragment
//! weighted by WBOIT's `range` weight at its depth (oit_wboit), so the tail leans towards its
//! nearer fragments, as a composite in depth order does. Coverage stays exact (Π(1 − α)).
//! `weight=equal` is the k-buffer's unweighted tail, for comparison at equal K.

use crate::kbuffer::{K, KBuffer, KBufferConfig, TailWeight};
use crate::sizing::Sizing;
use oit_gpu::predict::{PixelLists, model_error};
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, Param, ParamInfo, Prediction, RenderStats,
    SpecError, Support, Targets, Technique, TechniqueSpec, Unsupported,
};
use oit_scene::{BlendOperator, Scene};

oit_gpu::words! {
    /// How the hybrid's tail weights the fragments behind its K slots.
    pub enum HybridWeight {
        /// WBOIT's `range` weight at the fragment's depth (McGuire & Bavoil 2013 with the
        /// scene's transparent depth interval, oit_wboit::RangeParams).
        Range = "range",
        /// Every fragment alike: the k-buffer's `tail=average`.
        Equal = "equal",
    }
}

/// A valid `hybrid` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct HybridConfig {
    pub k: K,
    pub weight: HybridWeight,
}

impl Default for HybridConfig {
    fn default() -> Self {
        HybridConfig {
            k: Self::K.default,
            weight: Self::WEIGHT.default,
        }
    }
}

impl HybridConfig {
    pub const K: Param<K> = Param::new(
        "k",
        K::of(4),
        "fragments composited exactly per pixel (the core: k-buffer slots, 8 B each); the rest go to the weighted tail",
    );
    pub const WEIGHT: Param<HybridWeight> = Param::new(
        "weight",
        HybridWeight::Range,
        "tail weight: range (WBOIT's range weight at each tail fragment's depth) or equal (the k-buffer's average)",
    );

    pub fn params() -> Vec<ParamInfo> {
        vec![Self::K.info(), Self::WEIGHT.info()]
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name(Hybrid::NAME)?;
        Ok(HybridConfig {
            k: Self::K.read(spec)?,
            weight: Self::WEIGHT.read(spec)?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of(Hybrid::NAME)
            .with(&Self::K, self.k)
            .with(&Self::WEIGHT, self.weight)
    }

    /// The k-buffer that renders it: K fixed slots, an averaged tail.
    pub fn kbuffer(&self) -> KBufferConfig {
        KBufferConfig {
            k: Sizing::Fixed(self.k),
            tail: crate::TailRule::Average,
        }
    }

    fn tail_weight(&self) -> TailWeight {
        match self.weight {
            HybridWeight::Range => TailWeight::Range,
            HybridWeight::Equal => TailWeight::Equal,
        }
    }
}

/// Why the hybrid does not run two-chain scenes.
const SCALAR_TAIL: &str = "the hybrid's weighted tail is scalar: scenes with coloured transmission or `subtract` take the k-buffer's two chains, whose tail it does not weight";

/// The hybrid: a k-buffer whose tail is weighted.
#[derive(Debug)]
pub struct Hybrid {
    config: HybridConfig,
    kbuffer: KBuffer,
}

impl Hybrid {
    pub const NAME: &'static str = "hybrid";

    pub fn new(config: HybridConfig) -> Self {
        Hybrid {
            config,
            kbuffer: KBuffer::with_tail_weight(config.kbuffer(), config.tail_weight()),
        }
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(HybridConfig::from_spec(spec)?))
    }

    pub fn config(&self) -> HybridConfig {
        self.config
    }
}

impl Technique for Hybrid {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        self.kbuffer.check(caps)
    }

    fn predict(&self, scene: &Scene, lists: &PixelLists, caps: &Caps) -> Prediction {
        if crate::kbuffer::two_chains(scene, caps) {
            return Prediction::unmodelled(SCALAR_TAIL);
        }
        let k = self.config.k.get() as usize;
        let reverse_z = scene.camera.reverse_z;
        let range = oit_wboit::RangeParams::of(scene);
        let weighted = self.config.weight == HybridWeight::Range;
        let error = model_error(lists, |px| {
            let slots: Vec<u64> = px
                .layers
                .iter()
                .map(|l| crate::kbuffer::to_slot(l.premultiplied, l.alpha, l.depth, reverse_z))
                .collect();
            let (c, t) = crate::kbuffer::resolve_weighted(&slots, k, |s| {
                if weighted {
                    crate::kbuffer::tail_weight(s, &range, &scene.camera)
                } else {
                    1.0
                }
            });
            [0, 1, 2].map(|i| f64::from(c[i]) + f64::from(t) * px.behind[i])
        });
        Prediction::from_model(
            &error,
            &format!(
                "k = {k} slots hold every pixel's {} layers, stored as 64-bit slots",
                lists.max_layers()
            ),
            &format!(
                "layers beyond the {k} nearest are averaged with {} weights, or the slots' rgb9e5 colour and 8-bit α round them",
                oit_gpu::ParamValue::word(self.config.weight)
            ),
        )
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        self.kbuffer.render(ctx, scene, targets, timer)
    }

    fn work(&self, caps: &Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        self.kbuffer.work(caps, target)
    }

    fn memory_bytes(&self) -> u64 {
        self.kbuffer.memory_bytes()
    }

    fn transmission(&self, _caps: &Caps) -> Support {
        Support::Unsupported(SCALAR_TAIL)
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        match operator {
            // In the slots as the k-buffer; in the tail weighted like every tail fragment.
            BlendOperator::Over | BlendOperator::Add => Support::Exact,
            BlendOperator::Subtract | BlendOperator::Multiply => self.transmission(caps),
        }
    }
}
