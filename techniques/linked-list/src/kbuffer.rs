//! The `k-buffer` technique (NVIDIA's "Loop64"): the K nearest fragments of each pixel kept in
//! one geometry pass by a chain of 64-bit `atomicMax`, the fragment pushed out of a full pixel
//! blended into tail targets; a full-screen resolve composites the K slots and the tail. The
//! slot format and the resolve are twinned here for tests.

use crate::config::TailRule;
use crate::frame::Counters;
use crate::node::{Fragment, pack_opacity, pack_rgb9e5, unpack_opacity, unpack_rgb9e5};
use crate::sizing::{Sizing, check_auto_bytes};
use oit_gpu::wgpu;
use oit_gpu::{
    AutoSizes, Bounded, Caps, Context, FullscreenDesc, GpuError, GpuScene, GpuTimer, LayerCounter,
    MemoryLedger, PREMULTIPLIED_OVER, Param, ParamInfo, RenderStats, ScenePipelineDesc,
    ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec, Unsupported, bind,
    blend, fullscreen_pipeline, pass,
};
use oit_scene::BlendOperator;
use oit_scene::Resolution;

/// shaders/kbuffer64.wgsl.
pub const KBUFFER64_WGSL: &str = include_str!("../shaders/kbuffer64.wgsl");
/// The root module on scenes with coloured transmission: includes kbuffer64.wgsl and adds the
/// two-chain insert and the dual-source resolve.
pub const KBUFFER64_TRANSMIT_WGSL: &str = include_str!("../shaders/kbuffer64_transmit.wgsl");

/// Largest `k`: slots are a per-pixel array the insertion walks.
pub const MAX_K: u64 = 32;

const TAIL_SUM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const TAIL_T_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;
/// Σ a and Π(1 − a) per channel on scenes with coloured transmission.
const TAIL_RGB_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Fragments kept per pixel, `1..=MAX_K`.
pub type K = Bounded<1, { MAX_K as u32 }>;

/// `k-buffer:k=N|auto,tail=average|drop`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct KBufferConfig {
    pub k: Sizing<K>,
    pub tail: TailRule,
}

impl Default for KBufferConfig {
    /// NVIDIA's default of 8 layers.
    fn default() -> Self {
        KBufferConfig {
            k: Self::K.default,
            tail: Self::TAIL.default,
        }
    }
}

impl KBufferConfig {
    pub const K: Param<Sizing<K>> = Param::new(
        "k",
        Sizing::Fixed(K::of(8)),
        "fragments kept per pixel (8 B each). auto: the deepest pixel's count of fragments in front of the opaque surface, from a GPU count pass every frame (timed with the frame), so nothing is pushed out; refused when that is over 32 or the slots over the adapter's storage binding or AUTO_MEMORY_CAP (1 GiB), in MiB",
    );
    pub const TAIL: Param<TailRule> = Param::new(
        "tail",
        TailRule::Average,
        "fragments pushed out of the k slots: average (one layer with coverage 1 - prod(1 - alpha) and the alpha-weighted mean colour) or drop",
    );

    /// The registry's view of the parameters.
    pub fn params() -> Vec<ParamInfo> {
        vec![Self::K.info(), Self::TAIL.info()]
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name("k-buffer")?;
        Ok(KBufferConfig {
            k: Self::K.read(spec)?,
            tail: Self::TAIL.read(spec)?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of("k-buffer")
            .with(&Self::K, self.k)
            .with(&Self::TAIL, self.tail)
    }

    /// Slots (8 B each) and the two tail targets (Rgba16Float + R16Float); `transmit` (scenes
    /// with coloured transmission): a second chain of k opacity slots and three Rgba16Float
    /// tail targets. `None` for `k=auto`, whose k is the scene's (`AutoSizes::k`).
    pub fn bytes_per_pixel(&self, transmit: bool) -> Option<u64> {
        let k = u64::from(self.k.fixed()?);
        Some(if transmit { k * 16 + 24 } else { k * 8 + 10 })
    }
}

/// A slot (`to_slot` of kbuffer64.wgsl): larger is nearer, 0 is empty.
pub fn to_slot(color: [f32; 3], alpha: f32, z: f32, reverse_z: bool) -> u64 {
    let d = if reverse_z { z } else { 1.0 - z };
    let a8 = (alpha.clamp(0.0, 1.0) * 255.0 + 0.5) as u32;
    let hi = (d.to_bits() & 0xFFFF_FF00) | a8;
    (u64::from(hi) << 32) | u64::from(pack_rgb9e5(color))
}

pub fn from_slot(s: u64) -> Fragment {
    Fragment {
        color: unpack_rgb9e5(s as u32),
        opacity: [((s >> 32) as u32 & 255) as f32 / 255.0; 3],
    }
}

/// A fragment's colour and opacity slots on scenes with coloured transmission
/// (`fs_insert_transmit` of kbuffer64_transmit.wgsl): both share the high word, nearness as
/// [`to_slot`] with a hash of the two low words in place of α.
pub fn to_transmit_slots(color: [f32; 3], opacity: [f32; 3], z: f32, reverse_z: bool) -> [u64; 2] {
    let d = if reverse_z { z } else { 1.0 - z };
    let (color_word, sign) = crate::node::pack_signed_rgb9e5(color);
    let opacity_word = pack_opacity(opacity) | sign;
    let h = (color_word.wrapping_mul(0x9E37_79B1) ^ opacity_word.wrapping_mul(0x85EB_CA77)) >> 24;
    let high = u64::from((d.to_bits() & 0xFFFF_FF00) | h) << 32;
    [high | u64::from(color_word), high | u64::from(opacity_word)]
}

/// Whether the k-buffer keeps two chains (colour and opacity slots, kbuffer64_transmit.wgsl) on
/// `scene`: coloured transmission, or `subtract`, whose negative colour needs the opacity
/// slot's sign bit ([`crate::node::NEGATED`]); both resolve per channel with dual-source
/// blending.
pub fn two_chains(scene: &oit_scene::Scene, caps: &Caps) -> bool {
    caps.dual_source_blending
        && (scene.has_coloured_transmission()
            || scene.operators_used().contains(&BlendOperator::Subtract))
}

/// What a pair of transmit slots decodes to.
pub fn from_transmit_slots(s: [u64; 2]) -> Fragment {
    Fragment {
        color: crate::node::unpack_signed_rgb9e5(s[0] as u32, s[1] as u32),
        opacity: unpack_opacity(s[1] as u32),
    }
}

/// [`resolve`] on scenes with coloured transmission: per channel, the tail with exact coverage
/// `1 − Π(1 − a)` and the a-weighted mean colour per channel. Colour and transmittance.
pub fn resolve_transmit(slots: &[[u64; 2]], k: usize, tail: TailRule) -> ([f32; 3], [f32; 3]) {
    let mut sorted = slots.to_vec();
    sorted.sort_unstable_by(|a, b| b[0].cmp(&a[0]));
    let (kept, rest) = sorted.split_at(k.min(sorted.len()));
    let mut c = [0.0f32; 3];
    let mut t = [1.0f32; 3];
    for s in kept {
        let f = from_transmit_slots(*s);
        c = [0, 1, 2].map(|i| c[i] + t[i] * f.color[i]);
        t = [0, 1, 2].map(|i| t[i] * (1.0 - f.opacity[i]));
    }
    if tail == TailRule::Average && !rest.is_empty() {
        let (sum, a_sum, tail_t) =
            rest.iter()
                .fold(([0.0f32; 3], [0.0f32; 3], [1.0f32; 3]), |acc, s| {
                    let f = from_transmit_slots(*s);
                    (
                        [0, 1, 2].map(|i| acc.0[i] + f.color[i]),
                        [0, 1, 2].map(|i| acc.1[i] + f.opacity[i]),
                        [0, 1, 2].map(|i| acc.2[i] * (1.0 - f.opacity[i])),
                    )
                });
        for i in 0..3 {
            if a_sum[i] > 0.0 {
                c[i] += t[i] * sum[i] * ((1.0 - tail_t[i]) / a_sum[i]);
            }
        }
        t = [0, 1, 2].map(|i| t[i] * tail_t[i]);
    }
    (c, t)
}

/// The k-buffer's result for one pixel's slots (any order): the `k` nearest composited front to
/// back, the rest as the averaged tail (or dropped). Premultiplied colour and transmittance.
pub fn resolve(slots: &[u64], k: usize, tail: TailRule) -> ([f32; 3], f32) {
    let mut sorted = slots.to_vec();
    sorted.sort_unstable_by(|a, b| b.cmp(a));
    let (kept, rest) = sorted.split_at(k.min(sorted.len()));
    let mut c = [0.0f32; 3];
    let mut t = 1.0f32;
    for s in kept {
        let f = from_slot(*s);
        c = [0, 1, 2].map(|i| c[i] + t * f.color[i]);
        t *= 1.0 - f.opacity[0];
    }
    if tail == TailRule::Average && !rest.is_empty() {
        let (sum, alpha_sum, tail_t) = rest.iter().fold(([0.0f32; 3], 0.0f32, 1.0f32), |acc, s| {
            let f = from_slot(*s);
            (
                [0, 1, 2].map(|i| acc.0[i] + f.color[i]),
                acc.1 + f.opacity[0],
                acc.2 * (1.0 - f.opacity[0]),
            )
        });
        if alpha_sum > 0.0 {
            c = [0, 1, 2].map(|i| c[i] + t * sum[i] * ((1.0 - tail_t) / alpha_sum));
            t *= tail_t;
        }
    }
    (c, t)
}

/// How the fragments pushed out of the slots are weighted in the averaged tail.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TailWeight {
    /// Every fragment alike (`k-buffer:tail=average`): the α-weighted mean colour.
    Equal,
    /// WBOIT's `range` weight at the fragment's depth (`hybrid`): nearer fragments count more.
    Range,
}

/// CPU twin of `tail_weight` of kbuffer64.wgsl for a `Range`-weighted tail: the `range`
/// weight at the depth the slot's nearness key keeps.
pub fn tail_weight(slot: u64, range: &oit_wboit::RangeParams, camera: &oit_scene::Camera) -> f32 {
    let nearness = f32::from_bits((slot >> 32) as u32 & 0xFFFF_FF00);
    let z = if camera.reverse_z {
        nearness
    } else {
        1.0 - nearness
    };
    range.weight(camera.view_distance(z))
}

/// [`resolve`] with each tail fragment weighted by `weight(slot)`: the K nearest front to
/// back, then the tail with coverage 1 − Π(1 − α) and colour Σ w·C / Σ w·α (the hybrid's).
pub fn resolve_weighted(slots: &[u64], k: usize, weight: impl Fn(u64) -> f32) -> ([f32; 3], f32) {
    let mut sorted = slots.to_vec();
    sorted.sort_unstable_by(|a, b| b.cmp(a));
    let (kept, rest) = sorted.split_at(k.min(sorted.len()));
    let (mut c, mut t) = resolve(kept, k, TailRule::Drop);
    let (sum, alpha_sum, tail_t) = rest.iter().fold(([0.0f32; 3], 0.0f32, 1.0f32), |acc, s| {
        let f = from_slot(*s);
        let w = weight(*s);
        (
            [0, 1, 2].map(|i| acc.0[i] + w * f.color[i]),
            acc.1 + w * f.opacity[0],
            acc.2 * (1.0 - f.opacity[0]),
        )
    });
    if alpha_sum > 0.0 {
        c = [0, 1, 2].map(|i| c[i] + t * sum[i] * ((1.0 - tail_t) / alpha_sum));
        t *= tail_t;
    }
    (c, t)
}

/// The k-buffer on 64-bit atomics.
#[derive(Debug)]
pub struct KBuffer {
    config: KBufferConfig,
    /// How an averaged tail weights its fragments (`Range`: the hybrid).
    weight: TailWeight,
    gpu: Option<Resources>,
    ledger: MemoryLedger,
    /// The count pass (`k=auto` only).
    counter: LayerCounter,
}

#[derive(Debug)]
struct Resources {
    /// Resolution, final colour format, coloured-transmission path, k.
    key: (Resolution, wgpu::TextureFormat, bool, K),
    params: wgpu::Buffer,
    slots: wgpu::Buffer,
    counters: Counters,
    tail_sum: wgpu::TextureView,
    tail_t: wgpu::TextureView,
    /// Σ a per channel (coloured-transmission path only).
    tail_opacity: Option<wgpu::TextureView>,
    insert_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    insert: ScenePipelines,
    resolve: wgpu::RenderPipeline,
}

impl KBuffer {
    pub fn new(config: KBufferConfig) -> Self {
        Self::with_tail_weight(config, TailWeight::Equal)
    }

    /// A k-buffer whose averaged tail weights its fragments by `weight` (`hybrid`).
    pub fn with_tail_weight(config: KBufferConfig, weight: TailWeight) -> Self {
        KBuffer {
            config,
            weight,
            gpu: None,
            ledger: MemoryLedger::new(),
            counter: LayerCounter::new(),
        }
    }

    /// Refuses a spec that does not describe a k-buffer configuration.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(KBufferConfig::from_spec(spec)?))
    }

    pub fn config(&self) -> KBufferConfig {
        self.config
    }

    /// Bytes of the slot buffer at `resolution` (`transmit`: two chains) with the spec's k,
    /// or why the adapter cannot hold it; `k=auto` needs [`KBuffer::slot_bytes_for`].
    pub fn slot_bytes(
        &self,
        caps: &Caps,
        resolution: Resolution,
        transmit: bool,
    ) -> Result<u64, GpuError> {
        match self.config.k {
            Sizing::Fixed(k) => self.slot_bytes_for(k, caps, resolution, transmit),
            Sizing::Auto => Err(GpuError::Mismatch(
                "k=auto: the slots are sized from a count (KBuffer::slot_bytes_for)".into(),
            )),
        }
    }

    /// [`KBuffer::slot_bytes`] for `k` slots a chain; a `k=auto` size over the cap is refused
    /// in MiB.
    pub fn slot_bytes_for(
        &self,
        k: K,
        caps: &Caps,
        resolution: Resolution,
        transmit: bool,
    ) -> Result<u64, GpuError> {
        let pixels = u64::from(resolution.width) * u64::from(resolution.height);
        let chains = if transmit { 2 } else { 1 };
        let bytes = pixels * u64::from(k.get()) * 8 * chains;
        let what = format!("the k-buffer slots (k={k} × {chains} chain(s) × {pixels} px × 8 B)");
        if self.config.k == Sizing::Auto {
            check_auto_bytes(&format!("k=auto: {what}"), bytes, caps)?;
        }
        let limit = caps
            .max_storage_buffer_binding_size
            .min(caps.max_buffer_size);
        if bytes > limit {
            return Err(GpuError::TooLarge {
                what,
                needed: bytes,
                limit,
            });
        }
        Ok(bytes)
    }

    fn resources(
        &mut self,
        ctx: &Context,
        targets: &Targets,
        transmit: bool,
        k: K,
    ) -> Result<(), GpuError> {
        let key = (targets.resolution, targets.color_format, transmit, k);
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        self.gpu = None;
        self.ledger.clear();
        let slot_bytes = self.slot_bytes_for(k, &ctx.caps, targets.resolution, transmit)?;
        let device = &ctx.device;
        let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let mut buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            self.ledger.create_buffer(
                device,
                &wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage,
                    mapped_at_creation: false,
                },
            )
        };
        let params = buffer(
            "k-buffer params",
            48,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let slots = buffer("k-buffer slots", slot_bytes, storage);
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let tail_sum = self
            .ledger
            .create_texture_2d(
                device,
                "k-buffer tail sums",
                targets.resolution,
                TAIL_SUM_FORMAT,
                usage,
                1,
            )
            .create_view(&Default::default());
        let tail_t_format = if transmit {
            TAIL_RGB_FORMAT
        } else {
            TAIL_T_FORMAT
        };
        let tail_t = self
            .ledger
            .create_texture_2d(
                device,
                "k-buffer tail transmittance",
                targets.resolution,
                tail_t_format,
                usage,
                1,
            )
            .create_view(&Default::default());
        let tail_opacity = transmit.then(|| {
            self.ledger
                .create_texture_2d(
                    device,
                    "k-buffer tail opacity sums",
                    targets.resolution,
                    TAIL_RGB_FORMAT,
                    usage,
                    1,
                )
                .create_view(&Default::default())
        });
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("k-buffer"),
            entries: &[
                bind::uniform(0, fragment),
                bind::storage(1, fragment, false),
                bind::storage(2, fragment, false),
                bind::float_texture(3, fragment),
            ],
        });
        let mut resolve_entries = vec![
            bind::uniform(0, fragment),
            bind::storage(1, fragment, false),
            bind::storage(2, fragment, false),
            bind::float_texture(4, fragment),
            bind::float_texture(5, fragment),
        ];
        if transmit {
            resolve_entries.push(bind::float_texture(6, fragment));
        }
        let resolve_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("k-buffer resolve"),
            entries: &resolve_entries,
        });
        let node = crate::list::node_source(crate::list::NODE_WGSL, transmit);
        let module = if transmit {
            ctx.shader_with(
                "kbuffer64_transmit.wgsl",
                KBUFFER64_TRANSMIT_WGSL,
                &[
                    &[("linked_list_node.wgsl", &node)],
                    crate::SHADERS,
                    oit_wboit::SHADERS,
                ],
            )?
        } else {
            ctx.shader_with(
                "kbuffer64.wgsl",
                KBUFFER64_WGSL,
                &[
                    &[("linked_list_node.wgsl", &node)],
                    crate::SHADERS,
                    oit_wboit::SHADERS,
                ],
            )?
        };
        let insert_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("k-buffer insert"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&layout)],
            immediate_size: 0,
        });
        let target = |format, blend| {
            Some(wgpu::ColorTargetState {
                format,
                blend: Some(blend),
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        // Σ(C, α) and Π(1 − α); per channel: Σ(C, count), Σ a and Π(1 − a).
        let tail_targets = if transmit {
            vec![
                target(TAIL_SUM_FORMAT, blend::ADDITIVE),
                target(TAIL_RGB_FORMAT, blend::ADDITIVE),
                target(TAIL_RGB_FORMAT, blend::MULTIPLY_ONE_MINUS_SRC),
            ]
        } else {
            vec![
                target(TAIL_SUM_FORMAT, blend::ADDITIVE),
                target(TAIL_T_FORMAT, blend::MULTIPLY_ONE_MINUS_SRC),
            ]
        };
        let insert = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &tail_targets,
                ..ScenePipelineDesc::new(
                    "k-buffer insert",
                    &module,
                    if transmit {
                        "fs_insert_transmit"
                    } else {
                        "fs_insert"
                    },
                )
            },
            &insert_layout,
        );
        let resolve_pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("k-buffer resolve"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&resolve_layout)],
            immediate_size: 0,
        });
        let over = [Some(wgpu::ColorTargetState {
            format: targets.color_format,
            blend: Some(if transmit {
                crate::list::PER_CHANNEL_OVER
            } else {
                PREMULTIPLIED_OVER
            }),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let resolve = fullscreen_pipeline(
            ctx,
            &FullscreenDesc {
                label: "k-buffer resolve",
                layout: &resolve_pipeline_layout,
                module: &module,
                fragment_entry: if transmit {
                    "fs_resolve_transmit"
                } else {
                    "fs_resolve"
                },
                targets: &over,
                depth: None,
                multisample: Default::default(),
                constants: &[],
            },
        );
        let counters = Counters::new(ctx, &mut self.ledger, "k-buffer");
        self.gpu = Some(Resources {
            key,
            params,
            slots,
            counters,
            tail_sum,
            tail_t,
            tail_opacity,
            insert_layout: layout,
            resolve_layout,
            insert,
            resolve,
        });
        Ok(())
    }
}

impl Technique for KBuffer {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn predict(
        &self,
        scene: &oit_scene::Scene,
        lists: &oit_gpu::predict::PixelLists,
        caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict_kbuffer(self.config, scene, lists, caps)
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        if !caps.int64_atomics {
            return Err(Unsupported::new(format!(
                "the k-buffer reads the value of 64-bit atomicMax (SHADER_INT64 and SHADER_INT64_ATOMIC_ALL_OPS: Vulkan and DX12 only); this {} adapter has none",
                caps.backend.to_str()
            )));
        }
        if caps.max_storage_buffers_per_shader_stage < 2 {
            return Err(Unsupported::new(format!(
                "the k-buffer needs 2 storage buffers in the fragment stage; the adapter allows {}",
                caps.max_storage_buffers_per_shader_stage
            )));
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
        let transmit = two_chains(&scene.scene, &ctx.caps);
        // Count → size → build, as the list does: the count pass is in the frame's GPU time,
        // the wait for its summary in the wall time only.
        let count = if self.config.k == Sizing::Auto {
            Some(self.counter.count(ctx, scene, targets, timer, "k-buffer")?)
        } else {
            None
        };
        let k = self.config.k.per_pixel(
            "k",
            count,
            "the insertion walks up to k slots with a 64-bit atomic each",
        )?;
        self.resources(ctx, targets, transmit, k)?;
        let Some(r) = self.gpu.as_ref() else {
            return Err(GpuError::Mismatch("k-buffer: resources not built".into()));
        };
        let auto_sizes = count.map(|count| AutoSizes {
            count,
            k: Some(k.get()),
            pool_nodes: None,
            sort_max: None,
            sized_bytes: r.slots.size(),
            count_bytes: self.counter.memory_bytes(),
        });
        let weighted = self.weight == TailWeight::Range && self.config.tail == TailRule::Average;
        if weighted && transmit {
            return Err(GpuError::Mismatch(
                "the range-weighted tail is scalar; two-chain scenes are refused by `hybrid`'s support".into(),
            ));
        }
        let tail = match (self.config.tail, weighted) {
            (TailRule::Drop, _) => 0u32,
            (TailRule::Average, false) => 1,
            (TailRule::Average, true) => 2,
        };
        let range = weighted.then(|| oit_wboit::RangeParams::of(&scene.scene));
        let (proj_a, proj_b, ortho) = scene.scene.camera.view_depth_terms();
        let floats = |x: f32| x.to_bits();
        let words: [u32; 12] = [
            targets.resolution.width,
            k.get(),
            u32::from(scene.scene.camera.reverse_z),
            tail,
            floats(range.map_or(0.0, |r| r.z_near)),
            floats(range.map_or(1.0, |r| r.z_far)),
            floats(range.map_or(0.0, |r| r.fall)),
            floats(range.map_or(1.0, |r| r.color_scale)),
            floats(proj_a),
            floats(proj_b),
            u32::from(ortho),
            0,
        ];
        ctx.queue
            .write_buffer(&r.params, 0, bytemuck::cast_slice(&words));
        let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
        let insert_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("k-buffer insert"),
            layout: &r.insert_layout,
            entries: &[
                entry(0, r.params.as_entire_binding()),
                entry(1, r.slots.as_entire_binding()),
                entry(2, r.counters.buffer.as_entire_binding()),
                entry(3, wgpu::BindingResource::TextureView(&targets.depth_view)),
            ],
        });
        let mut resolve_entries = vec![
            entry(0, r.params.as_entire_binding()),
            entry(1, r.slots.as_entire_binding()),
            entry(2, r.counters.buffer.as_entire_binding()),
            entry(4, wgpu::BindingResource::TextureView(&r.tail_sum)),
            entry(5, wgpu::BindingResource::TextureView(&r.tail_t)),
        ];
        if let Some(view) = &r.tail_opacity {
            resolve_entries.push(entry(6, wgpu::BindingResource::TextureView(view)));
        }
        let resolve_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("k-buffer resolve"),
            layout: &r.resolve_layout,
            entries: &resolve_entries,
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&r.slots, 0, None);
        r.counters.clear(&mut encoder);
        {
            let ts = timer.pass("k-buffer insert");
            let mut attachments = vec![pass::color(
                &r.tail_sum,
                wgpu::LoadOp::Clear(pass::splat(0.0)),
            )];
            if let Some(view) = &r.tail_opacity {
                attachments.push(pass::color(view, wgpu::LoadOp::Clear(pass::splat(0.0))));
            }
            attachments.push(pass::color(
                &r.tail_t,
                wgpu::LoadOp::Clear(pass::splat(1.0)),
            ));
            let mut p = pass::begin(&mut encoder, "k-buffer insert", &attachments, None, &ts);
            scene.bind(&mut p);
            p.set_bind_group(1, &insert_group, &[]);
            for i in scene.transparent_draws() {
                scene.draw(&mut p, &r.insert, i);
            }
        }
        let c = r.counters.resolve_and_read(
            ctx,
            encoder,
            timer,
            scene,
            targets,
            &r.resolve,
            &resolve_group,
        )?;
        Ok(RenderStats {
            geometry_passes: 1,
            pixels_with_dropped_layers: u64::from(c[0]),
            pixels_with_approximated_layers: u64::from(c[1]),
            auto_sizes,
            ..Default::default()
        })
    }

    fn work(&self, _caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        // `k=auto` states the largest k (an upper bound, like K itself below).
        let k = self.config.k.fixed().unwrap_or(MAX_K as u32);
        // Scalar slots (one chain; coloured transmission doubles the slots and atomics).
        let tails = texel_bytes(TAIL_SUM_FORMAT) + texel_bytes(TAIL_T_FORMAT);
        let texel = texel_bytes(target);
        Work::new(vec![
            // The count pass of the auto sizes (`oit_gpu::LayerCounter`, pass "k-buffer count"):
            // a fragment in front of the opaque depth (loaded), counted by atomicAdd on its
            // pixel, atomicMax and atomicAdd on the frame's summary.
            PassWork::new("k-buffer count", PassDraws::Transparent)
                .bytes(DEPTH_BYTES, 0)
                .atomics(3.0),
            // A fragment in front of the opaque depth (loaded: the shader's own test): the
            // two tail targets read and written by their blends; atomicMax on the pixel's
            // slots until an empty one, at most K (the n-th fragment of a pixel makes
            // min(n, K)): K is stated, an upper bound.
            PassWork::new("k-buffer insert", PassDraws::Transparent)
                .bytes(DEPTH_BYTES + tails, tails)
                .atomics(f64::from(k)),
            // Per pixel: up to K slots of 8 B loaded (K stated, an upper bound) and the two
            // tail texels, the final texel read and written by the blend. The counters'
            // atomicAdd happen only on pixels with a tail (not counted).
            PassWork::new("k-buffer resolve", PassDraws::FullScreen)
                .bytes(8 * k + tails + texel, texel),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.ledger.total() + self.counter.memory_bytes()
    }

    fn transmission(&self, caps: &Caps) -> Support {
        if !caps.dual_source_blending {
            return Support::Approximate(
                "composites 1 − mean(t) as scalar α, exact for grey filters only (the per-channel resolve dst = C + T ⊙ dst needs dual-source blending, which the adapter lacks)",
            );
        }
        // A second chain of opacity slots (unorm10 per channel) sorted like the colour slots;
        // the averaged tail stays an approximation, per channel, and is reported per pixel.
        Support::Exact
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        match operator {
            // (P, t) with t = 1: what is behind is not dimmed.
            BlendOperator::Over | BlendOperator::Add => Support::Exact,
            // The rgb9e5 colour word holds no sign: the sign bit sits in the opacity slot of
            // the two-chain layout, whose per-channel resolve needs dual-source blending.
            BlendOperator::Subtract if caps.dual_source_blending => Support::Exact,
            BlendOperator::Subtract => Support::Unsupported(
                "its rgb9e5 colour slots hold no sign; the opacity slots that carry it resolve with dual-source blending, which the adapter lacks",
            ),
            // A filter without colour: coloured transmittance with P = 0.
            BlendOperator::Multiply => self.transmission(caps),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn slots_order_by_nearness_to_2_pow_minus_15(
            z1 in 1e-6f32..1.0, z2 in 1e-6f32..1.0, reverse in any::<bool>(), a in 0.0f32..=1.0
        ) {
            let s1 = to_slot([0.5; 3], a, z1, reverse);
            let s2 = to_slot([0.5; 3], 0.25, z2, reverse);
            let (d1, d2) = if reverse { (z1, z2) } else { (1.0 - z1, 1.0 - z2) };
            // Nearness truncated to 15 mantissa bits: distinct beyond 2^-15 relative.
            if d1 > d2 * (1.0 + 2f32.powi(-14)) {
                prop_assert!(s1 > s2);
            }
            prop_assert!(s1 > 0 && s2 > 0);
            let f = from_slot(s1);
            prop_assert!((f.opacity[0] - a).abs() <= 0.5 / 255.0 + 1e-7);
        }
    }

    #[test]
    fn resolve_keeps_the_k_nearest_and_averages_the_rest() {
        let near = to_slot([0.5, 0.0, 0.0], 0.5, 0.8, true);
        let mid = to_slot([0.0, 0.25, 0.0], 0.25, 0.5, true);
        let far = to_slot([0.0, 0.0, 0.75], 0.75, 0.2, true);
        let (c, t) = resolve(&[far, near, mid], 3, TailRule::Average);
        assert_eq!(resolve(&[mid, far, near], 3, TailRule::Drop), (c, t));
        let a = |s| from_slot(s).opacity[0];
        assert_eq!(t, (1.0 - a(near)) * (1.0 - a(mid)) * (1.0 - a(far)));
        let (c1, t1) = resolve(&[far, near, mid], 1, TailRule::Average);
        assert!(
            (t1 - t).abs() < 1e-7,
            "the averaged tail keeps the exact coverage"
        );
        assert!(c1[1] > 0.0 && c1[2] > 0.0, "{c1:?}");
        let (c2, t2) = resolve(&[far, near, mid], 1, TailRule::Drop);
        assert_eq!((c2[1], c2[2], t2), (0.0, 0.0, 1.0 - a(near)));
        assert_eq!(c2[0], from_slot(near).color[0]);
    }

    proptest! {
        /// Both chains sort a fragment's slots alike: they share the high word, and the hash in
        /// it orders fragments at equal nearness by content, not by draw order.
        #[test]
        fn transmit_slots_of_two_fragments_sort_alike_in_both_chains(
            z1 in 0.0f32..1.0, z2 in 0.0f32..1.0, c in 0.0f32..4.0, a in 0.0f32..=1.0,
        ) {
            let p = to_transmit_slots([c, 0.5, 0.25], [a, 1.0 - a, 0.5], z1, true);
            let q = to_transmit_slots([0.5, c, 0.0], [0.25, a, a], z2, true);
            prop_assert_eq!(p[0] >> 32, p[1] >> 32);
            if p[0] >> 32 != q[0] >> 32 {
                prop_assert_eq!(p[0] < q[0], p[1] < q[1]);
            }
            let f = from_transmit_slots(p);
            prop_assert!((f.opacity[1] - (1.0 - a)).abs() <= 0.5 / 1023.0 + 1e-6);
        }
    }
}
