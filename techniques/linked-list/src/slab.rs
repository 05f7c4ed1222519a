//! `slab`: stochastic layered alpha blending (Wyman, "Exploring and expanding the continuum of
//! OIT algorithms", HPG 2016) in a form that is correct without fragment-shader interlock.
//! Wyman keeps K layers per pixel and merges overflowing fragments into the last one with an
//! ordered read-modify-write; WebGPU has no interlock (gpuweb #395), so that merge would race
//! and depend on arrival order. Here the continuum is built from order-independent passes:
//! the k-buffer's pass keeps each pixel's K nearest fragments exactly, and the fragments behind
//! them are composited as stochastic transparency (Enderton et al. 2010) over S coverage
//! samples — a stochastic depth pass, an accumulation pass with Enderton's visibility estimate
//! and alpha correction, and a resolve (shaders/slab.wgsl). K ≥ a pixel's layer count is the
//! k-buffer; K = 1 is stochastic transparency with S samples behind one exact layer.
//!
//! The CPU twins of the shader's new formulas are here: [`mask`], [`visibility`],
//! [`tail_color`], and [`resolve`], the whole pixel (the model of `predict`).

use crate::frame::Counters;
use crate::kbuffer::{self, K};
use oit_gpu::predict::{PixelLists, model_error};
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, FullscreenDesc, GpuError, GpuScene, GpuTimer, MemoryLedger, PREMULTIPLIED_OVER,
    Param, ParamInfo, Prediction, RenderStats, ScenePipelineDesc, ScenePipelines, SpecError,
    Support, Targets, Technique, TechniqueSpec, Unsupported, Verdict, bind, blend,
    fullscreen_pipeline, pass,
};
use oit_scene::{BlendOperator, Resolution, Scene};

/// shaders/slab.wgsl.
pub const SLAB_WGSL: &str = include_str!("../shaders/slab.wgsl");

const TAIL_SUM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const TAIL_T_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;

oit_gpu::words! {
    /// Coverage samples per pixel of the stochastic tail.
    pub enum SlabSamples {
        Eight = "8",
        Sixteen = "16",
        ThirtyTwo = "32",
    }
}

impl SlabSamples {
    /// The sample count S.
    pub fn count(self) -> u32 {
        match self {
            SlabSamples::Eight => 8,
            SlabSamples::Sixteen => 16,
            SlabSamples::ThirtyTwo => 32,
        }
    }
}

/// A valid `slab` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SlabConfig {
    pub k: K,
    pub samples: SlabSamples,
}

impl Default for SlabConfig {
    fn default() -> Self {
        SlabConfig {
            k: Self::K.default,
            samples: Self::SAMPLES.default,
        }
    }
}

impl SlabConfig {
    pub const K: Param<K> = Param::new(
        "k",
        K::of(4),
        "fragments composited exactly per pixel (k-buffer slots, 8 B each); the fragments behind them are the stochastic tail",
    );
    pub const SAMPLES: Param<SlabSamples> = Param::new(
        "samples",
        SlabSamples::Eight,
        "coverage samples per pixel of the stochastic tail (4 B each): a tail fragment covers about alpha x samples of them",
    );

    pub fn params() -> Vec<ParamInfo> {
        vec![Self::K.info(), Self::SAMPLES.info()]
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name(Slab::NAME)?;
        Ok(SlabConfig {
            k: Self::K.read(spec)?,
            samples: Self::SAMPLES.read(spec)?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of(Slab::NAME)
            .with(&Self::K, self.k)
            .with(&Self::SAMPLES, self.samples)
    }

    /// Slots (8 B each), samples (4 B each) and the two tail targets (Rgba16Float + R16Float).
    pub fn bytes_per_pixel(&self) -> u64 {
        u64::from(self.k.get()) * 8 + u64::from(self.samples.count()) * 4 + 10
    }
}

// ---- CPU twins of shaders/slab.wgsl ----

/// `slab_pcg` (PCG, Jarzynski & Olano 2020).
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// `slab_pcg4d`.
pub fn pcg4d(a: [u32; 4]) -> [u32; 4] {
    let mut v = a.map(|x| x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223));
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
    v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
    v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    v = v.map(|x| x ^ (x >> 16));
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
    v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
    v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    v
}

/// `slab_nearness`: full f32 bits of the distance from the far plane, larger is nearer.
pub fn nearness(z: f32, reverse_z: bool) -> u32 {
    (if reverse_z { z } else { 1.0 - z }).to_bits()
}

/// `slab_seed`: the hash input of a fragment (pixel, nearness, the slot's words).
pub fn seed(px: [u32; 2], nearness: u32, slot: u64) -> [u32; 4] {
    [px[0], px[1], nearness, (slot >> 32) as u32 ^ slot as u32]
}

/// `slab_mask`: n = ⌊α·S + u⌋ samples of S (integer arithmetic, α in 24-bit fixed point, u the
/// hash's top 24 bits), the first n of a hash-driven partial Fisher–Yates shuffle of 0..S.
pub fn mask(seed: [u32; 4], alpha: f32, s: u32) -> u32 {
    let h = pcg4d(seed);
    let a24 = (alpha.clamp(0.0, 1.0) * 16_777_216.0) as u32;
    let n = ((a24 * s + (h[0] >> 8)) >> 24).min(s);
    let mut order: [u32; 32] = std::array::from_fn(|i| i as u32);
    let mut state = h[1];
    let mut mask = 0u32;
    for j in 0..n {
        state = pcg(state);
        let r = j + state % (s - j);
        let pick = order[r as usize];
        order[r as usize] = order[j as usize];
        mask |= 1 << pick;
    }
    mask
}

/// `slab_visibility`: the fraction of the samples `stored` (nearness of the nearest tail
/// fragment covering each, 0 for none) that no nearer tail fragment covers.
pub fn visibility(stored: &[u32], nearness: u32) -> f32 {
    let seen = stored.iter().filter(|&&x| x <= nearness).count() as u32;
    seen as f32 / stored.len() as f32
}

/// `slab_tail_color`: Σ vis·C · (1 − Π(1 − α)) / Σ vis·α, or Σ vis·C where Σ vis·α = 0.
pub fn tail_color(sum: [f32; 4], tail_t: f32) -> [f32; 3] {
    if sum[3] > 0.0 {
        [0, 1, 2].map(|i| sum[i] * ((1.0 - tail_t) / sum[3]))
    } else {
        [sum[0], sum[1], sum[2]]
    }
}

/// One transparent fragment of a pixel, as the passes see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TailInput {
    /// Premultiplied colour.
    pub color: [f32; 3],
    pub alpha: f32,
    /// Window depth.
    pub z: f32,
}

/// The pixel `px`'s result through all four passes (any fragment order): the K nearest slots
/// front to back (`kbuffer::resolve`, tail dropped), the fragments strictly behind the K-th
/// slot as the stochastic tail of S samples, sums in f32 (the GPU's tail targets are
/// binary16). Premultiplied colour, transmittance, and whether the pixel had a tail.
pub fn resolve(
    fragments: &[TailInput],
    px: [u32; 2],
    k: usize,
    s: u32,
    reverse_z: bool,
) -> ([f32; 3], f32, bool) {
    let slot_of = |f: &TailInput| kbuffer::to_slot(f.color, f.alpha, f.z, reverse_z);
    let mut slots: Vec<u64> = fragments.iter().map(slot_of).collect();
    slots.sort_unstable_by(|a, b| b.cmp(a));
    let (mut c, mut t) = kbuffer::resolve(&slots, k, crate::TailRule::Drop);
    let Some(&kth) = slots.get(k - 1) else {
        return (c, t, false);
    };
    let tail: Vec<(&TailInput, u64, u32)> = fragments
        .iter()
        .map(|f| (f, slot_of(f), nearness(f.z, reverse_z)))
        .filter(|(_, slot, _)| *slot < kth)
        .collect();
    if tail.is_empty() {
        return (c, t, false);
    }
    let mut stored = vec![0u32; s as usize];
    for (f, slot, near) in &tail {
        let m = mask(seed(px, *near, *slot), f.alpha, s);
        for (i, x) in stored.iter_mut().enumerate() {
            if m >> i & 1 != 0 {
                *x = (*x).max(*near);
            }
        }
    }
    let mut sum = [0.0f32; 4];
    let mut tail_t = 1.0f32;
    for (f, _, near) in &tail {
        let vis = visibility(&stored, *near);
        let weighted = [f.color[0], f.color[1], f.color[2], f.alpha].map(|x| x * vis);
        sum = [0, 1, 2, 3].map(|i| sum[i] + weighted[i]);
        tail_t *= 1.0 - f.alpha;
    }
    let tc = tail_color(sum, tail_t);
    c = [0, 1, 2].map(|i| c[i] + t * tc[i]);
    t *= tail_t;
    (c, t, true)
}

/// Why `slab` does not run two-chain scenes.
const SCALAR_TAIL: &str = "slab's stochastic tail is scalar (one coverage mask per fragment): scenes with coloured transmission or `subtract` take the k-buffer's two chains, which it does not extend";

/// SLAB: the k-buffer's K slots and a stochastic tail of S samples.
#[derive(Debug)]
pub struct Slab {
    config: SlabConfig,
    gpu: Option<Resources>,
    ledger: MemoryLedger,
}

#[derive(Debug)]
struct Resources {
    key: (Resolution, wgpu::TextureFormat),
    params: wgpu::Buffer,
    slots: wgpu::Buffer,
    samples: wgpu::Buffer,
    counters: Counters,
    tail_sum: wgpu::TextureView,
    tail_t: wgpu::TextureView,
    layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    insert: ScenePipelines,
    cover: ScenePipelines,
    accumulate: ScenePipelines,
    resolve: wgpu::RenderPipeline,
}

impl Slab {
    pub const NAME: &'static str = "slab";

    pub fn new(config: SlabConfig) -> Self {
        Slab {
            config,
            gpu: None,
            ledger: MemoryLedger::new(),
        }
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(SlabConfig::from_spec(spec)?))
    }

    pub fn config(&self) -> SlabConfig {
        self.config
    }

    fn buffer_bytes(&self, caps: &Caps, resolution: Resolution) -> Result<(u64, u64), GpuError> {
        let pixels = u64::from(resolution.width) * u64::from(resolution.height);
        let k = self.config.k.get();
        let s = self.config.samples.count();
        let limit = caps
            .max_storage_buffer_binding_size
            .min(caps.max_buffer_size);
        let slots = pixels * u64::from(k) * 8;
        let samples = pixels * u64::from(s) * 4;
        for (what, bytes) in [
            (format!("the slab slots (k={k} × {pixels} px × 8 B)"), slots),
            (
                format!("the slab samples (samples={s} × {pixels} px × 4 B)"),
                samples,
            ),
        ] {
            if bytes > limit {
                return Err(GpuError::TooLarge {
                    what,
                    needed: bytes,
                    limit,
                });
            }
        }
        Ok((slots, samples))
    }

    fn resources(&mut self, ctx: &Context, targets: &Targets) -> Result<(), GpuError> {
        let key = (targets.resolution, targets.color_format);
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        self.gpu = None;
        self.ledger.clear();
        let (slot_bytes, sample_bytes) = self.buffer_bytes(&ctx.caps, targets.resolution)?;
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
            "slab params",
            48,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let slots = buffer("slab slots", slot_bytes, storage);
        let samples = buffer("slab samples", sample_bytes, storage);
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let mut texture = |label: &str, format| {
            self.ledger
                .create_texture_2d(device, label, targets.resolution, format, usage, 1)
                .create_view(&Default::default())
        };
        let tail_sum = texture("slab tail sums", TAIL_SUM_FORMAT);
        let tail_t = texture("slab tail transmittance", TAIL_T_FORMAT);
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("slab"),
            entries: &[
                bind::uniform(0, fragment),
                bind::storage(1, fragment, false),
                bind::storage(2, fragment, false),
                bind::float_texture(3, fragment),
                bind::storage(6, fragment, false),
            ],
        });
        let resolve_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("slab resolve"),
            entries: &[
                bind::uniform(0, fragment),
                bind::storage(1, fragment, false),
                bind::storage(2, fragment, false),
                bind::float_texture(4, fragment),
                bind::float_texture(5, fragment),
            ],
        });
        let node = crate::list::node_source(crate::list::NODE_WGSL, false);
        let module = ctx.shader_with(
            "slab.wgsl",
            SLAB_WGSL,
            &[
                &[("linked_list_node.wgsl", &node)],
                crate::SHADERS,
                oit_wboit::SHADERS,
            ],
        )?;
        let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("slab geometry"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&layout)],
            immediate_size: 0,
        });
        let target = |format, blend: Option<wgpu::BlendState>| {
            Some(wgpu::ColorTargetState {
                format,
                blend,
                write_mask: if blend.is_some() {
                    wgpu::ColorWrites::ALL
                } else {
                    wgpu::ColorWrites::empty()
                },
            })
        };
        // Passes 1 and 2 write only storage: the tail targets stay attached, unwritten.
        let silent = [target(TAIL_SUM_FORMAT, None), target(TAIL_T_FORMAT, None)];
        let blended = [
            target(TAIL_SUM_FORMAT, Some(blend::ADDITIVE)),
            target(TAIL_T_FORMAT, Some(blend::MULTIPLY_ONE_MINUS_SRC)),
        ];
        let pipelines = |label, entry, targets: &[Option<wgpu::ColorTargetState>]| {
            ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    targets,
                    ..ScenePipelineDesc::new(label, &module, entry)
                },
                &pipeline_layout,
            )
        };
        let insert = pipelines("slab insert", "fs_insert", &silent);
        let cover = pipelines("slab cover", "fs_slab_cover", &silent);
        let accumulate = pipelines("slab accumulate", "fs_slab_accumulate", &blended);
        let resolve_pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("slab resolve"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&resolve_layout)],
            immediate_size: 0,
        });
        let over = [Some(wgpu::ColorTargetState {
            format: targets.color_format,
            blend: Some(PREMULTIPLIED_OVER),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let resolve = fullscreen_pipeline(
            ctx,
            &FullscreenDesc {
                label: "slab resolve",
                layout: &resolve_pipeline_layout,
                module: &module,
                fragment_entry: "fs_slab_resolve",
                targets: &over,
                depth: None,
                multisample: Default::default(),
                constants: &[],
            },
        );
        let counters = Counters::new(ctx, &mut self.ledger, "slab");
        self.gpu = Some(Resources {
            key,
            params,
            slots,
            samples,
            counters,
            tail_sum,
            tail_t,
            layout,
            resolve_layout,
            insert,
            cover,
            accumulate,
            resolve,
        });
        Ok(())
    }
}

impl Technique for Slab {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        if !caps.int64_atomics {
            return Err(Unsupported::new(format!(
                "slab's K slots are the k-buffer's, which reads the value of 64-bit atomicMax (SHADER_INT64 and SHADER_INT64_ATOMIC_ALL_OPS: Vulkan and DX12 only); this {} adapter has none",
                caps.backend.to_str()
            )));
        }
        if caps.max_storage_buffers_per_shader_stage < 3 {
            return Err(Unsupported::new(format!(
                "slab needs 3 storage buffers in the fragment stage (slots, counters, samples); the adapter allows {}",
                caps.max_storage_buffers_per_shader_stage
            )));
        }
        Ok(())
    }

    fn predict(&self, scene: &Scene, lists: &PixelLists, caps: &Caps) -> Prediction {
        if kbuffer::two_chains(scene, caps) {
            return Prediction::unmodelled(SCALAR_TAIL);
        }
        let k = self.config.k.get() as usize;
        let s = self.config.samples.count();
        let reverse_z = scene.camera.reverse_z;
        // The model hashes as the GPU does, but knows no pixel position and the reference's
        // depths, not the rasterizer's bits: its masks are other draws of the same
        // distribution.
        let error = model_error(lists, |px| {
            let fragments: Vec<TailInput> = px
                .layers
                .iter()
                .map(|l| TailInput {
                    color: l.premultiplied,
                    alpha: l.alpha,
                    z: l.depth,
                })
                .collect();
            let (c, t, _) = resolve(&fragments, [0, 0], k, s, reverse_z);
            [0, 1, 2].map(|i| f64::from(c[i]) + f64::from(t) * px.behind[i])
        });
        let layers = lists.max_layers();
        let mut p = Prediction::from_model(
            &error,
            &format!("k = {k} slots hold every pixel's {layers} layers, stored as 64-bit slots"),
            &format!(
                "layers beyond the {k} nearest are composited stochastically over {s} samples, or the slots' rgb9e5 colour and 8-bit α round them"
            ),
        );
        if layers as usize > k && p.verdict == Verdict::Exact {
            // Exact in the model's draw of the masks (an α = 1 layer in front of the tail, or
            // a tail of one colour); another draw of the same distribution may differ.
            p.verdict = Verdict::Borderline;
            p.because = format!(
                "pixels deeper than k = {k} go through the stochastic tail, exact in the model's masks but decided by the GPU's hash: {}",
                p.because
            );
        }
        p
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        if kbuffer::two_chains(&scene.scene, &ctx.caps) {
            return Err(GpuError::Mismatch(format!(
                "{SCALAR_TAIL}; refused by slab's support"
            )));
        }
        self.resources(ctx, targets)?;
        let Some(r) = self.gpu.as_ref() else {
            return Err(GpuError::Mismatch("slab: resources not built".into()));
        };
        let (proj_a, proj_b, ortho) = scene.scene.camera.view_depth_terms();
        let words: [u32; 12] = [
            targets.resolution.width,
            self.config.k.get(),
            u32::from(scene.scene.camera.reverse_z),
            // The k-buffer's insert with tail = drop (its tail outputs are not written).
            0,
            0.0f32.to_bits(),
            1.0f32.to_bits(),
            0.0f32.to_bits(),
            1.0f32.to_bits(),
            proj_a.to_bits(),
            proj_b.to_bits(),
            u32::from(ortho),
            self.config.samples.count(),
        ];
        ctx.queue
            .write_buffer(&r.params, 0, bytemuck::cast_slice(&words));
        let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("slab"),
            layout: &r.layout,
            entries: &[
                entry(0, r.params.as_entire_binding()),
                entry(1, r.slots.as_entire_binding()),
                entry(2, r.counters.buffer.as_entire_binding()),
                entry(3, wgpu::BindingResource::TextureView(&targets.depth_view)),
                entry(6, r.samples.as_entire_binding()),
            ],
        });
        let resolve_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("slab resolve"),
            layout: &r.resolve_layout,
            entries: &[
                entry(0, r.params.as_entire_binding()),
                entry(1, r.slots.as_entire_binding()),
                entry(2, r.counters.buffer.as_entire_binding()),
                entry(4, wgpu::BindingResource::TextureView(&r.tail_sum)),
                entry(5, wgpu::BindingResource::TextureView(&r.tail_t)),
            ],
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&r.slots, 0, None);
        encoder.clear_buffer(&r.samples, 0, None);
        r.counters.clear(&mut encoder);
        for (name, pipelines, first) in [
            ("slab insert", &r.insert, true),
            ("slab cover", &r.cover, false),
            ("slab accumulate", &r.accumulate, false),
        ] {
            let ts = timer.pass(name);
            let (sum_load, t_load) = if first {
                (
                    wgpu::LoadOp::Clear(pass::splat(0.0)),
                    wgpu::LoadOp::Clear(pass::splat(1.0)),
                )
            } else {
                (wgpu::LoadOp::Load, wgpu::LoadOp::Load)
            };
            let attachments = [
                pass::color(&r.tail_sum, sum_load),
                pass::color(&r.tail_t, t_load),
            ];
            let mut p = pass::begin(&mut encoder, name, &attachments, None, &ts);
            scene.bind(&mut p);
            p.set_bind_group(1, &group, &[]);
            for i in scene.transparent_draws() {
                scene.draw(&mut p, pipelines, i);
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
            geometry_passes: 3,
            pixels_with_approximated_layers: u64::from(c[1]),
            ..Default::default()
        })
    }

    fn work(&self, _caps: &Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        let k = self.config.k.get();
        let s = self.config.samples.count();
        let tails = texel_bytes(TAIL_SUM_FORMAT) + texel_bytes(TAIL_T_FORMAT);
        let texel = texel_bytes(target);
        Work::new(vec![
            // The k-buffer's insert (tail = drop): the opaque depth loaded, atomicMax on the
            // pixel's slots until an empty one, at most K (an upper bound); the tail targets
            // are attached with no write mask.
            PassWork::new("slab insert", PassDraws::Transparent)
                .bytes(DEPTH_BYTES, 0)
                .atomics(f64::from(k)),
            // Every fragment: the opaque depth and the K-th slot loaded (one 64-bit atomicLoad);
            // a tail fragment's atomicMax on each covered sample, at most S (an upper bound:
            // about α·S).
            PassWork::new("slab cover", PassDraws::Transparent)
                .bytes(DEPTH_BYTES, 0)
                .atomics(1.0 + f64::from(s)),
            // Every fragment: the opaque depth and the K-th slot; a tail fragment loads its S
            // samples (atomicLoad, upper bound: every fragment counted) and blends the two
            // tail targets.
            PassWork::new("slab accumulate", PassDraws::Transparent)
                .bytes(DEPTH_BYTES + tails, tails)
                .atomics(1.0 + f64::from(s)),
            // Per pixel: up to K slots of 8 B (K stated, an upper bound), the two tail texels,
            // the final texel read and written by the blend.
            PassWork::new("slab resolve", PassDraws::FullScreen)
                .bytes(8 * k + tails + texel, texel),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    fn transmission(&self, _caps: &Caps) -> Support {
        Support::Unsupported(SCALAR_TAIL)
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        match operator {
            BlendOperator::Over => Support::Exact,
            // In the slots as the k-buffer. In the tail a fragment with α = 0 covers no
            // sample, and its vis·P is added: scaled by the alpha correction where the tail
            // has coverage, as every tail colour is.
            BlendOperator::Add => Support::Approximate(
                "exact in the K slots; behind them it covers no sample and adds vis·P, vis the stochastic estimate of the transmittance in front of it, scaled with the tail by the alpha correction (1 − Π(1 − α))/Σ vis·α",
            ),
            BlendOperator::Subtract | BlendOperator::Multiply => self.transmission(caps),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_cover_about_alpha_times_s_samples_and_are_unbiased() {
        for s in [8u32, 16, 32] {
            for alpha in [0.0f32, 0.1, 0.37, 0.5, 0.9, 1.0] {
                let mut total = 0u64;
                let trials = 4000u32;
                for i in 0..trials {
                    let m = mask([i, 7, 0x3f00_0000 + i, i * 31], alpha, s);
                    let n = m.count_ones();
                    assert!(s == 32 || m >> s == 0, "bits beyond S: {m:#x}");
                    let exact = alpha * s as f32;
                    assert!(
                        n == exact.floor() as u32 || n == exact.ceil() as u32,
                        "S {s} α {alpha}: {n} bits"
                    );
                    total += u64::from(n);
                }
                let mean = total as f64 / f64::from(trials);
                let expected = f64::from(alpha) * f64::from(s);
                assert!(
                    (mean - expected).abs() < 0.02 * f64::from(s),
                    "S {s} α {alpha}: mean {mean}"
                );
            }
        }
    }

    #[test]
    fn every_sample_is_covered_about_equally() {
        let s = 16;
        let mut hits = [0u32; 16];
        for i in 0..16000u32 {
            let m = mask([i, i ^ 5, 1000 + i, 3], 0.25, s);
            for (b, h) in hits.iter_mut().enumerate() {
                *h += m >> b & 1;
            }
        }
        // 16000 masks of 4 bits over 16 samples: 4000 each in expectation.
        for h in hits {
            assert!((3800..4200).contains(&h), "{hits:?}");
        }
    }

    #[test]
    fn visibility_counts_samples_no_nearer_fragment_covers() {
        assert_eq!(visibility(&[0, 5, 9, 3], 5), 0.75);
        assert_eq!(visibility(&[0; 8], 1), 1.0);
        assert_eq!(tail_color([1.0, 0.5, 0.0, 0.5], 0.5), [1.0, 0.5, 0.0]);
        assert_eq!(tail_color([0.25, 0.0, 0.0, 0.0], 1.0), [0.25, 0.0, 0.0]);
    }

    fn layers(n: usize, alpha: f32) -> Vec<TailInput> {
        (0..n)
            .map(|i| TailInput {
                color: [alpha * (i % 3) as f32 / 2.0, alpha * 0.5, alpha],
                alpha,
                z: 0.2 + 0.6 * i as f32 / n as f32,
            })
            .collect()
    }

    #[test]
    fn at_k_the_layer_count_it_is_the_kbuffer_and_order_never_matters() {
        let f = layers(6, 0.4);
        let slots: Vec<u64> = f
            .iter()
            .map(|l| kbuffer::to_slot(l.color, l.alpha, l.z, false))
            .collect();
        let (c, t, tail) = resolve(&f, [3, 4], 6, 8, false);
        assert!(!tail);
        assert_eq!((c, t), kbuffer::resolve(&slots, 6, crate::TailRule::Drop));
        let mut reversed = f.clone();
        reversed.reverse();
        for k in [1, 2, 4] {
            assert_eq!(
                resolve(&f, [3, 4], k, 8, false),
                resolve(&reversed, [3, 4], k, 8, false)
            );
            assert!(resolve(&f, [3, 4], k, 8, false).2);
        }
    }

    #[test]
    fn the_tail_keeps_exact_coverage_and_converges_with_more_samples() {
        let f = layers(12, 0.3);
        let exact = resolve(&f, [0, 0], 12, 8, false);
        // K = 1: the slot keeps the nearest α in 8 bits, the tail the rest in f32.
        let a8 = kbuffer::from_slot(kbuffer::to_slot(f[0].color, f[0].alpha, f[0].z, false));
        let coverage =
            (1.0 - a8.opacity[0]) * f[1..].iter().map(|l| 1.0 - l.alpha).product::<f32>();
        let mut error = [0.0f64; 3];
        for (e, s) in error.iter_mut().zip([8u32, 16, 32]) {
            for p in 0..64u32 {
                let (c, t, _) = resolve(&f, [p, 1], 1, s, false);
                assert!(
                    (t - coverage).abs() < 1e-6,
                    "coverage is exact: {t} {coverage}"
                );
                *e += (0..3)
                    .map(|i| f64::from(c[i] - exact.0[i]).powi(2))
                    .sum::<f64>();
            }
        }
        assert!(error[2] < error[0], "{error:?}");
    }
}
