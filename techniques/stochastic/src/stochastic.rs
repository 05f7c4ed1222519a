//! `stochastic:pattern=…,seed=…,spp=N`: dithered alpha testing, optionally averaged over frames.

use crate::config::{Pattern, Seed, StochasticConfig};
use crate::gpu;
use crate::pattern;
use oit_gpu::bind;
use oit_gpu::pass;
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, GpuError, GpuScene, GpuTimer, MaterialSource, MemoryLedger, RenderStats,
    ScenePipelineDesc, ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec,
    Unsupported,
};
use oit_scene::BlendOperator;
use oit_scene::Resolution;

/// WGSL of the dither pass.
pub const DITHER_WGSL: &str = include_str!("../shaders/stochastic_dither.wgsl");
/// WGSL of the frame averaging pass.
pub const ACCUMULATE_WGSL: &str = include_str!("../shaders/stochastic_accumulate.wgsl");

/// Bytes of `struct Dither` in stochastic_dither.wgsl: nine 4-byte words, padded to the
/// struct's 8-byte alignment (its `vec2<u32>`).
const DITHER_UNIFORM_BYTES: u64 = 40;
/// [`dither_words`]' length: `DITHER_UNIFORM_BYTES / 4`.
pub const DITHER_WORDS: usize = 10;
/// Bytes of `struct Accumulate` in stochastic_accumulate.wgsl.
const ACCUMULATE_UNIFORM_BYTES: u64 = 12;
/// Format of the running sum of frames: f32, so 128 frames add without visible rounding.
const SUM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Fallback where Rgba32Float cannot be rendered to (e.g. the GL backend): a running mean in
/// half floats (a sum would lose precision as it grows; the mean stays in the colour range).
const HALF_SUM_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The `stochastic` technique.
#[derive(Debug)]
pub struct Stochastic {
    config: StochasticConfig,
    gpu: Option<Resources>,
    ledger: MemoryLedger,
    /// Use the half-float running mean even where Rgba32Float is renderable.
    force_half_sums: bool,
    order: gpu::DrawOrder,
}

/// Everything allocated for one (colour format, depth direction, resolution, coloured
/// transmission).
#[derive(Debug)]
struct Resources {
    key: (wgpu::TextureFormat, bool, Resolution, bool, bool),
    dither: ScenePipelines,
    /// Scenes with additive or subtractive draws: their pass after the dithered draws
    /// (`fs_additive`), for all channels and, with coloured transmission, per channel.
    additive: Option<(ScenePipelines, Option<[ScenePipelines; 3]>)>,
    /// Coloured transmission: one dither pipeline per colour channel (`CHANNEL` = 0, 1, 2,
    /// writing that channel only), each frame dithered three times.
    channels: Option<[ScenePipelines; 3]>,
    dither_bind_group: wgpu::BindGroup,
    dither_stride: u64,
    /// The per-sample `struct Dither` entries, and the animation frame they were written for
    /// (rewritten when a scene of another frame is rendered).
    dither_buffer: wgpu::Buffer,
    dither_frame: u32,
    frames: Option<FrameResources>,
}

/// For `spp > 1` or coloured transmission: where each frame renders and where frames are
/// summed.
#[derive(Debug)]
struct FrameResources {
    /// Fills each frame's targets with the opaque pass (and resets the depth between the
    /// per-channel passes).
    seed: gpu::SeedPass,
    color_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    sum_views: [wgpu::TextureView; 2],
    /// `bind_groups[p]` reads the frame and sum `1 − p` (the sum of the previous frames).
    bind_groups: [wgpu::BindGroup; 2],
    accumulate_stride: u64,
    to_sum: wgpu::RenderPipeline,
    to_final: wgpu::RenderPipeline,
}

impl Stochastic {
    pub fn new(config: StochasticConfig) -> Self {
        Stochastic {
            config,
            gpu: None,
            ledger: MemoryLedger::new(),
            force_half_sums: false,
            order: gpu::DrawOrder::default(),
        }
    }

    /// Refuses a spec that does not describe a stochastic configuration.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(StochasticConfig::from_spec(spec)?))
    }

    /// Averages frames as a running mean in Rgba16Float (what adapters that cannot render
    /// Rgba32Float get automatically) instead of an f32 sum: to compare the two paths.
    pub fn with_half_float_sums(mut self) -> Self {
        self.force_half_sums = true;
        self.gpu = None;
        self
    }

    /// Issues the dither draws in plain reverse draw order instead of nearest first where no
    /// depth tie can depend on it (see [`crate::dither_order`]): the same image, more
    /// fragments shaded. To compare the two.
    pub fn in_reverse_draw_order(mut self) -> Self {
        self.order = gpu::DrawOrder::reverse_only();
        self
    }

    /// The format frames are averaged in for `spp > 1` on this adapter.
    pub fn sum_format(&self, caps: &Caps) -> wgpu::TextureFormat {
        if self.force_half_sums || caps.require_target(SUM_FORMAT, false).is_err() {
            HALF_SUM_FORMAT
        } else {
            SUM_FORMAT
        }
    }

    pub fn config(&self) -> StochasticConfig {
        self.config
    }

    /// The per-sample uniform entries of animation frame `frame` (`struct Dither` at
    /// `stride`-byte offsets): sample k is sub-frame `frame·spp + k`.
    fn dither_uniforms(config: &StochasticConfig, frame: u32, stride: u64) -> Vec<u8> {
        let spp = config.spp.get();
        let mut bytes = vec![0u8; (stride * u64::from(spp)) as usize];
        for k in 0..spp {
            let words = dither_words(config, pattern::sub_frame(frame, spp, k));
            let start = (stride * u64::from(k)) as usize;
            bytes[start..start + DITHER_UNIFORM_BYTES as usize]
                .copy_from_slice(bytemuck::cast_slice(&words));
        }
        bytes
    }

    fn prepare(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        config: &StochasticConfig,
    ) -> Result<(), GpuError> {
        let coloured = scene.scene.has_coloured_transmission();
        let has_additive = (scene.scene.operators_used().iter()).any(|&op| op.is_additive());
        let key = (
            targets.color_format,
            scene.scene.camera.reverse_z,
            targets.resolution,
            coloured,
            has_additive,
        );
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        self.gpu = None;
        self.ledger.clear();
        let sum_format = self.sum_format(&ctx.caps);
        let device = &ctx.device;
        let ledger = &mut self.ledger;

        // Dither pass: group 0 = scene, group 1 = per-frame uniform + threshold table. The table
        // is an R32Float texture read with textureLoad: on CPU rasterizers a per-fragment
        // storage-buffer read costs several times the rest of the dither shader.
        let dither_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stochastic dither"),
            entries: &[
                bind::dynamic_uniform(0, wgpu::ShaderStages::VERTEX_FRAGMENT, DITHER_UNIFORM_BYTES),
                bind::float_texture(1, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let dither_stride = bind::uniform_stride(ctx, DITHER_UNIFORM_BYTES);
        let dither_frame = scene.scene.frame;
        let uniforms = Self::dither_uniforms(config, dither_frame, dither_stride);
        let dither_buffer = ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("stochastic frame parameters"),
                size: uniforms.len() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        ctx.queue.write_buffer(&dither_buffer, 0, &uniforms);
        let table = pattern::table(config.pattern);
        let (side, rows) = config.pattern.table_size();
        let table_texture = ledger.create_texture_2d(
            device,
            "stochastic threshold table",
            oit_scene::Resolution {
                width: side,
                height: rows,
            },
            wgpu::TextureFormat::R32Float,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            1,
        );
        ctx.queue.write_texture(
            table_texture.as_image_copy(),
            bytemuck::cast_slice(&table),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(side * 4),
                rows_per_image: Some(rows),
            },
            wgpu::Extent3d {
                width: side,
                height: rows,
                depth_or_array_layers: 1,
            },
        );
        let table_view = table_texture.create_view(&Default::default());
        let dither_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("stochastic dither"),
            layout: &dither_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &dither_buffer,
                        offset: 0,
                        size: wgpu::BufferSize::new(DITHER_UNIFORM_BYTES),
                    }),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&table_view),
                },
            ],
        });
        let module = ctx.shader_with("stochastic_dither.wgsl", DITHER_WGSL, &[crate::SHADERS])?;
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("stochastic dither"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&dither_layout)],
            immediate_size: 0,
        });
        let dither_pipelines = |label, write_mask, channel: u32, additive: bool| {
            let (entry, blend, depth_write) = if additive {
                ("fs_additive", Some(oit_gpu::blend::ADDITIVE), false)
            } else {
                ("fs_stochastic", None, true)
            };
            ScenePipelines::with_layout(
                ctx,
                &ScenePipelineDesc {
                    vertex_entry: "vs_stochastic",
                    // Its vertex outputs repeat the per-vertex interface's fields.
                    material: MaterialSource::PerVertex,
                    targets: &[Some(wgpu::ColorTargetState {
                        format: targets.color_format,
                        blend,
                        write_mask,
                    })],
                    depth: Some(oit_gpu::depth_test(scene.depth_nearer(), depth_write)),
                    constants: &[("CHANNEL", f64::from(channel))],
                    ..ScenePipelineDesc::new(label, &module, entry)
                },
                &layout,
            )
        };
        let per_channel = |additive: bool| {
            [
                dither_pipelines("stochastic dither red", wgpu::ColorWrites::RED, 0, additive),
                dither_pipelines(
                    "stochastic dither green",
                    wgpu::ColorWrites::GREEN,
                    1,
                    additive,
                ),
                dither_pipelines(
                    "stochastic dither blue",
                    wgpu::ColorWrites::BLUE,
                    2,
                    additive,
                ),
            ]
        };
        let dither = dither_pipelines("stochastic dither", wgpu::ColorWrites::ALL, 3, false);
        let channels = coloured.then(|| per_channel(false));
        let additive = has_additive.then(|| {
            (
                dither_pipelines("stochastic additive", wgpu::ColorWrites::ALL, 3, true),
                coloured.then(|| per_channel(true)),
            )
        });
        let frames = if config.spp.get() > 1 || coloured {
            Some(Self::frame_resources(
                ctx,
                ledger,
                targets,
                config.spp.get(),
                sum_format,
            )?)
        } else {
            None
        };
        self.gpu = Some(Resources {
            key,
            dither,
            additive,
            channels,
            dither_bind_group,
            dither_stride,
            dither_buffer,
            dither_frame,
            frames,
        });
        Ok(())
    }

    fn frame_resources(
        ctx: &Context,
        ledger: &mut MemoryLedger,
        targets: &Targets,
        spp: u32,
        sum_format: wgpu::TextureFormat,
    ) -> Result<FrameResources, GpuError> {
        let device = &ctx.device;
        let texture = |ledger: &mut MemoryLedger, label, format, usage| {
            ledger.create_texture_2d(device, label, targets.resolution, format, usage, 1)
        };
        use wgpu::TextureUsages as U;
        let color = texture(
            ledger,
            "stochastic frame colour",
            targets.color_format,
            U::RENDER_ATTACHMENT | U::TEXTURE_BINDING,
        );
        let depth = texture(
            ledger,
            "stochastic frame depth",
            wgpu::TextureFormat::Depth32Float,
            U::RENDER_ATTACHMENT,
        );
        let sums = [
            texture(
                ledger,
                "stochastic sum a",
                sum_format,
                U::RENDER_ATTACHMENT | U::TEXTURE_BINDING,
            ),
            texture(
                ledger,
                "stochastic sum b",
                sum_format,
                U::RENDER_ATTACHMENT | U::TEXTURE_BINDING,
            ),
        ];
        let accumulate_stride = bind::uniform_stride(ctx, ACCUMULATE_UNIFORM_BYTES);
        let uniform = ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("stochastic accumulate parameters"),
                size: accumulate_stride * u64::from(spp),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stochastic accumulate"),
            entries: &[
                bind::float_texture(0, wgpu::ShaderStages::FRAGMENT),
                bind::float_texture(1, wgpu::ShaderStages::FRAGMENT),
                bind::dynamic_uniform(2, wgpu::ShaderStages::FRAGMENT, ACCUMULATE_UNIFORM_BYTES),
            ],
        });
        let color_view = color.create_view(&Default::default());
        let sum_views = [
            sums[0].create_view(&Default::default()),
            sums[1].create_view(&Default::default()),
        ];
        let bind_group = |previous: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("stochastic accumulate"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&color_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(previous),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &uniform,
                            offset: 0,
                            size: wgpu::BufferSize::new(ACCUMULATE_UNIFORM_BYTES),
                        }),
                    },
                ],
            })
        };
        let bind_groups = [bind_group(&sum_views[1]), bind_group(&sum_views[0])];
        let module = ctx.shader_with(
            "stochastic_accumulate.wgsl",
            ACCUMULATE_WGSL,
            &[crate::SHADERS],
        )?;
        let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("stochastic accumulate"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |format| {
            oit_gpu::fullscreen_pipeline(
                ctx,
                &oit_gpu::FullscreenDesc {
                    label: "stochastic accumulate",
                    layout: &pipeline_layout,
                    module: &module,
                    fragment_entry: "fs_accumulate",
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                    depth: None,
                    multisample: Default::default(),
                    constants: &[],
                },
            )
        };
        // One entry per frame k: out = previous · a + frame · b.
        // f32: a running sum (a = b = 1), the last frame scales it by 1/spp.
        // f16: a running mean, a = k/(k+1), b = 1/(k+1), so values stay in the colour range.
        let stride = accumulate_stride as usize;
        let mut data = vec![0u8; stride * spp as usize];
        for k in 0..spp {
            let (a, b) = if sum_format == SUM_FORMAT {
                if k + 1 == spp {
                    (1.0 / spp as f32, 1.0 / spp as f32)
                } else {
                    (1.0, 1.0)
                }
            } else {
                (k as f32 / (k + 1) as f32, 1.0 / (k + 1) as f32)
            };
            let words: [u32; 3] = [a.to_bits(), b.to_bits(), u32::from(k > 0)];
            let at = k as usize * stride;
            data[at..at + 12].copy_from_slice(bytemuck::cast_slice(&words));
        }
        ctx.queue.write_buffer(&uniform, 0, &data);
        let depth_view = depth.create_view(&Default::default());
        Ok(FrameResources {
            to_sum: pipeline(sum_format),
            to_final: pipeline(targets.color_format),
            seed: gpu::SeedPass::with_depth_reset(ctx, targets.color_format)?,
            color_view,
            depth_view,
            sum_views,
            bind_groups,
            accumulate_stride,
        })
    }
}

/// `struct Dither` of stochastic_dither.wgsl for sub-frame `k` of `config` (sample k of
/// animation frame t is sub-frame `t·spp + k`, [`pattern::sub_frame`]), as its words (the last
/// one padding).
pub fn dither_words(config: &StochasticConfig, k: u32) -> [u32; DITHER_WORDS] {
    let tile = config.pattern.tile().unwrap_or(1);
    let (offset, rotation, slice_row) = if config.pattern == Pattern::Stbn {
        let (slice, offset) = pattern::stbn_frame(k);
        (offset, 0.0, slice * tile)
    } else {
        let (offset, rotation) = pattern::frame_shift(k, tile);
        (offset, rotation, 0)
    };
    [
        match config.pattern {
            Pattern::White => 0,
            Pattern::Blue
            | Pattern::Bayer4
            | Pattern::Bayer8
            | Pattern::Bayer16
            | Pattern::Bayer32
            | Pattern::Bayer64
            | Pattern::Bayer128
            | Pattern::Bayer256 => 1,
            Pattern::Hashed => 2,
            Pattern::Stbn => 3,
        },
        match config.seed {
            Seed::None => 0,
            Seed::Object => 1,
            Seed::Primitive => 2,
        },
        tile,
        k,
        offset[0],
        offset[1],
        rotation.to_bits(),
        1.0f32.to_bits(),
        slice_row,
        0,
    ]
}

fn load_store<T>(load: wgpu::LoadOp<T>) -> wgpu::Operations<T> {
    wgpu::Operations {
        load,
        store: wgpu::StoreOp::Store,
    }
}

/// Entries of the threshold table `pattern` uploads (for the memory accounting test).
#[cfg(test)]
pub(crate) fn table_len(pattern: Pattern) -> usize {
    pattern::table(pattern).len()
}

impl Technique for Stochastic {
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
            "stochastic transparency's error is sampling noise of its pattern, which no per-pixel rule predicts: measured only",
        )
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        let config = self.config;
        caps.require_scene_materials()?;
        let (side, rows) = config.pattern.table_size();
        if side.max(rows) > caps.max_texture_dimension_2d {
            return Err(Unsupported::new(format!(
                "the {} threshold table is {side}×{rows} texels; the adapter's 2D textures are at most {} wide",
                config.pattern.name(),
                caps.max_texture_dimension_2d
            )));
        }
        if config.spp.get() > 1 {
            caps.require_target(HALF_SUM_FORMAT, false)?;
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
        self.prepare(ctx, scene, targets, &config)?;
        let r = self.gpu.as_mut().expect("resources prepared above");
        // Another animation frame: the samples' sub-frames move on (frame 0 is what `prepare`
        // wrote).
        if r.dither_frame != scene.scene.frame {
            r.dither_frame = scene.scene.frame;
            let uniforms = Self::dither_uniforms(&config, r.dither_frame, r.dither_stride);
            ctx.queue.write_buffer(&r.dither_buffer, 0, &uniforms);
        }
        let r = &*r;
        // Additive and subtractive draws never survive the dither: they are drawn after it,
        // depth-tested against the survivors (`fs_additive`).
        let (additive_draws, order): (Vec<usize>, Vec<usize>) =
            self.order.of(scene).iter().copied().partition(|&i| {
                let s = &scene.scene;
                s.material_of(&s.draws[i]).operator.is_additive()
            });
        let draw_pass = |encoder: &mut wgpu::CommandEncoder,
                         timer: &mut GpuTimer,
                         name: &str,
                         color: &wgpu::TextureView,
                         depth: &wgpu::TextureView,
                         frame: u32,
                         seed: Option<(&gpu::SeedPass, &wgpu::BindGroup)>| {
            // Per-frame targets are cleared and then filled with the opaque pass by the seed
            // draw; the final targets already hold it.
            let load_color = match seed {
                Some(_) => wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                None => wgpu::LoadOp::Load,
            };
            let load_depth = match seed {
                Some(_) => wgpu::LoadOp::Clear(scene.scene.camera.far_depth()),
                None => wgpu::LoadOp::Load,
            };
            let ts = timer.pass(name);
            let mut pass = pass::begin_with(
                encoder,
                wgpu::RenderPassDescriptor {
                    label: Some(name),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: color,
                        depth_slice: None,
                        resolve_target: None,
                        ops: load_store(load_color),
                    })],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: depth,
                        depth_ops: Some(load_store(load_depth)),
                        stencil_ops: None,
                    }),
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                },
                &ts,
            );
            if let Some((seed, group)) = seed {
                seed.draw(&mut pass, group);
            }
            let offset = (r.dither_stride * u64::from(frame)) as u32;
            let dither = |pass: &mut wgpu::RenderPass<'_>,
                          pipelines: &ScenePipelines,
                          additive: Option<&ScenePipelines>| {
                scene.bind(pass);
                pass.set_bind_group(1, &r.dither_bind_group, &[offset]);
                for &i in &order {
                    gpu::draw_with_id(pass, scene, pipelines, i);
                }
                if let Some(additive) = additive {
                    for &i in &additive_draws {
                        gpu::draw_with_id(pass, scene, additive, i);
                    }
                }
            };
            match (&r.channels, seed) {
                // Coloured transmission: each channel dithered from the opaque depth.
                (Some(channels), Some((seed, group))) => {
                    for (c, pipelines) in channels.iter().enumerate() {
                        if c != 0 {
                            seed.draw_depth_reset(&mut pass, group);
                        }
                        let additive = (r.additive.as_ref())
                            .and_then(|(_, channels)| channels.as_ref())
                            .map(|channels| &channels[c]);
                        dither(&mut pass, pipelines, additive);
                    }
                }
                _ => dither(
                    &mut pass,
                    &r.dither,
                    r.additive.as_ref().map(|(all, _)| all),
                ),
            }
        };
        let passes_per_frame = if r.channels.is_some() { 3 } else { 1 };
        let stats = RenderStats {
            geometry_passes: config.spp.get() * passes_per_frame,
            ..Default::default()
        };
        let Some(f) = &r.frames else {
            // One frame: dither straight into the final targets over the opaque pass.
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            draw_pass(
                &mut encoder,
                timer,
                "stochastic",
                &targets.color_view,
                &targets.depth_view,
                0,
                None,
            );
            timer.submit(ctx, encoder)?;
            return Ok(stats);
        };
        let seed_group = f.seed.bind_group(ctx, targets);
        for k in 0..config.spp.get() {
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            draw_pass(
                &mut encoder,
                timer,
                &format!("stochastic frame {k}"),
                &f.color_view,
                &f.depth_view,
                k,
                Some((&f.seed, &seed_group)),
            );
            let last = k + 1 == config.spp.get();
            let parity = (k % 2) as usize;
            let (target, pipeline) = if last {
                (&targets.color_view, &f.to_final)
            } else {
                (&f.sum_views[parity], &f.to_sum)
            };
            let entry = u64::from(k);
            let name = format!("accumulate frame {k}");
            let ts = timer.pass(&name);
            {
                let mut pass = pass::begin(
                    &mut encoder,
                    &name,
                    &[Some(wgpu::RenderPassColorAttachment {
                        view: target,
                        depth_slice: None,
                        resolve_target: None,
                        ops: load_store(wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT)),
                    })],
                    None,
                    &ts,
                );
                pass.set_pipeline(pipeline);
                let offset = (f.accumulate_stride * entry) as u32;
                pass.set_bind_group(0, &f.bind_groups[parity], &[offset]);
                pass.draw(0..3, 0..1);
            }
            timer.submit(ctx, encoder)?;
        }
        Ok(stats)
    }

    fn work(&self, caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        let texel = texel_bytes(target);
        // A kept fragment (the dither discards the rest, uncounted): the depth test reads and
        // the surviving fragment writes depth, and writes its colour without blending.
        let dithered = |name: &str, numbered: bool| {
            let p = if numbered {
                PassWork::numbered(name, PassDraws::Transparent)
            } else {
                PassWork::new(name, PassDraws::Transparent)
            };
            p.bytes(DEPTH_BYTES, DEPTH_BYTES + texel)
        };
        let sum = texel_bytes(self.sum_format(caps));
        Work::new(vec![
            // One frame straight into the final targets (spp=1 on a scene without coloured
            // transmission).
            dithered("stochastic", false),
            // Per frame (spp > 1, or coloured transmission): a seed draw copies the opaque colour and depth into the frame's
            // targets first; its W·H samples are in this pass's count and priced as
            // fragments (an overstatement of the seed's bytes, 2 × 4 + texel read and written).
            dithered("stochastic frame ", true),
            // Per pixel: the frame's colour and the running sum loaded, the new sum (or, last,
            // the final texel) written without blending (the sum format stated for both).
            PassWork::numbered("accumulate frame ", PassDraws::FullScreen).bytes(texel + sum, sum),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    fn transmission(&self, _caps: &Caps) -> Support {
        // Per channel in expectation, as its scalar compositing is: one dither pass per colour
        // channel, where a fragment survives with that channel's opacity 1 − t_c.
        Support::Exact
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        match operator {
            // Exact in expectation, as its compositing of `over` is.
            BlendOperator::Over => Support::Exact,
            // (P, t = 1): drawn after each sub-frame's (or channel's) dithered layers,
            // depth-tested against the survivors without writing depth and added (`fs_additive`):
            // it lands when no survivor lies in front of it, with probability Π(1 − α) (per
            // channel Π t) of the layers in front — Enderton et al.'s accumulation pass.
            BlendOperator::Add | BlendOperator::Subtract => Support::Exact,
            // A filter without colour: dithered per channel with opacity 1 − t_c.
            BlendOperator::Multiply => self.transmission(caps),
        }
    }
}

impl Stochastic {
    /// `(label, bytes)` of every allocation (empty before the first render).
    pub fn memory_entries(&self) -> &[(String, u64)] {
        self.ledger.entries()
    }
}
