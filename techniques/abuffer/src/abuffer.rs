//! The `abuffer` technique: count, scan, fill, sort — an exactly sized fragment array.

use crate::scan::PrefixSum;
use oit_gpu::wgpu;
use oit_gpu::{
    AutoSizes, Caps, Context, FullscreenDesc, GpuError, GpuScene, GpuTimer, LayerCounter,
    MemoryLedger, PREMULTIPLIED_OVER, Param, ParamInfo, RenderStats, ScenePipelineDesc,
    ScenePipelines, SpecError, Support, Targets, Technique, TechniqueSpec, Unsupported, bind,
    fullscreen_pipeline, mib, pass, read_buffer_u32,
};
use oit_linked_list::{NodeFormat, PER_CHANNEL_OVER};
use oit_scene::{BlendOperator, Resolution};

/// shaders/abuffer.wgsl (fill and resolve) and its dual-source root.
pub const WGSL: &str = include_str!("../shaders/abuffer.wgsl");
pub const TRANSMIT_WGSL: &str = include_str!("../shaders/abuffer_transmit.wgsl");

/// The most bytes the fragment array may take, whatever the adapter allows (as the stored-
/// fragment techniques' `auto` sizes: `oit_linked_list::AUTO_MEMORY_CAP`); the adapter's own
/// limit on one storage binding applies too, and the smaller decides.
pub const MEMORY_CAP: u64 = oit_linked_list::AUTO_MEMORY_CAP;

/// A valid `abuffer` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AbufferConfig {
    pub node: NodeFormat,
}

impl Default for AbufferConfig {
    fn default() -> Self {
        AbufferConfig {
            node: Self::NODE.default,
        }
    }
}

impl AbufferConfig {
    pub const NODE: Param<NodeFormat> = Param::new(
        "node",
        NodeFormat::F32,
        "f32: 12 B per fragment (f32 depth, binary16 colour and alpha); packed: 8 B (unorm24 depth, unorm8 alpha, rgb9e5 colour); 4 B more each on scenes with coloured transmission",
    );

    pub fn params() -> Vec<ParamInfo> {
        vec![Self::NODE.info()]
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        spec.expect_name(Abuffer::NAME)?;
        Ok(AbufferConfig {
            node: Self::NODE.read(spec)?,
        })
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of(Abuffer::NAME).with(&Self::NODE, self.node)
    }

    /// Bytes of one stored fragment: the list's node without its `next` index.
    pub fn fragment_bytes(&self, transmit: bool) -> u64 {
        self.node.bytes(transmit) - 4
    }
}

/// The prefix-sum A-buffer.
#[derive(Debug)]
pub struct Abuffer {
    config: AbufferConfig,
    gpu: Option<Resources>,
    ledger: MemoryLedger,
    /// The fragment array, apart from the rest: it follows the frame's count.
    array: Option<FragmentArray>,
    array_ledger: MemoryLedger,
    counter: LayerCounter,
}

#[derive(Debug)]
struct FragmentArray {
    fragments: u64,
    nodes: wgpu::Buffer,
}

#[derive(Debug)]
struct Resources {
    /// Resolution, final colour format, rgb-opacity nodes.
    key: (Resolution, wgpu::TextureFormat, bool),
    params: wgpu::Buffer,
    offsets: wgpu::Buffer,
    counters: wgpu::Buffer,
    readback: wgpu::Buffer,
    scan: PrefixSum,
    layout: wgpu::BindGroupLayout,
    fill: ScenePipelines,
    resolve: wgpu::RenderPipeline,
}

impl Abuffer {
    pub const NAME: &'static str = "abuffer";

    pub fn new(config: AbufferConfig) -> Self {
        Abuffer {
            config,
            gpu: None,
            ledger: MemoryLedger::new(),
            array: None,
            array_ledger: MemoryLedger::new(),
            counter: LayerCounter::new(),
        }
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(AbufferConfig::from_spec(spec)?))
    }

    pub fn config(&self) -> AbufferConfig {
        self.config
    }

    /// Bytes of the fragment array for `fragments` fragments, or the refusal (in MiB) when it
    /// is over the adapter's largest storage binding or [`MEMORY_CAP`].
    pub fn array_bytes(
        &self,
        caps: &Caps,
        fragments: u64,
        transmit: bool,
    ) -> Result<u64, GpuError> {
        let per = self.config.fragment_bytes(transmit);
        let bytes = fragments.max(1).saturating_mul(per);
        let binding = caps
            .max_storage_buffer_binding_size
            .min(caps.max_buffer_size);
        let (cap, cap_name) = if binding < MEMORY_CAP {
            (binding, "the adapter's largest storage binding".to_owned())
        } else {
            (
                MEMORY_CAP,
                format!(
                    "MEMORY_CAP, the A-buffer's own cap (the adapter binds up to {})",
                    mib(binding)
                ),
            )
        };
        if bytes > cap || fragments >= u64::from(u32::MAX) {
            return Err(GpuError::OverMemoryCap {
                what: format!(
                    "the A-buffer's fragment array ({fragments} fragments in front of the opaque surface × {per} B)"
                ),
                needed: bytes,
                cap,
                cap_name,
            });
        }
        Ok(bytes)
    }

    fn fragment_array(&mut self, ctx: &Context, fragments: u64, bytes: u64) {
        if self
            .array
            .as_ref()
            .is_some_and(|a| a.fragments == fragments)
        {
            return;
        }
        self.array = None;
        self.array_ledger.clear();
        let nodes = self.array_ledger.create_buffer(
            &ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("abuffer fragments"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            },
        );
        self.array = Some(FragmentArray { fragments, nodes });
    }

    fn resources(
        &mut self,
        ctx: &Context,
        targets: &Targets,
        transmit: bool,
    ) -> Result<(), GpuError> {
        let key = (targets.resolution, targets.color_format, transmit);
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        self.gpu = None;
        self.ledger.clear();
        let pixels = targets.resolution.pixel_count() as u64;
        let device = &ctx.device;
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
            "abuffer params",
            16,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        // One entry more than pixels: the scan leaves the total there, the end of the last range.
        let offsets = buffer(
            "abuffer offsets",
            (pixels + 1) * 4,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        );
        let counters = buffer(
            "abuffer counters",
            16,
            wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
        );
        let readback = buffer(
            "abuffer counters readback",
            16,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        );
        let scan = PrefixSum::new(ctx, &mut self.ledger, &offsets, pixels as usize + 1)?;
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("abuffer"),
            entries: &[
                bind::uniform(0, fragment),
                bind::storage(1, fragment, true),
                bind::storage(2, fragment, false),
                bind::storage(3, fragment, false),
                bind::storage(4, fragment, false),
                bind::float_texture(5, fragment),
            ],
        });
        let node = oit_linked_list::node_module(self.config.node, transmit);
        let module = if transmit {
            ctx.shader_with(
                "abuffer_transmit.wgsl",
                TRANSMIT_WGSL,
                &[&[("linked_list_node.wgsl", &node)], crate::SHADERS],
            )?
        } else {
            ctx.shader_with(
                "abuffer.wgsl",
                WGSL,
                &[&[("linked_list_node.wgsl", &node)], crate::SHADERS],
            )?
        };
        let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("abuffer"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&layout)],
            immediate_size: 0,
        });
        // The pass needs an attachment; nothing is written to it (the array is the output).
        let untouched = [Some(wgpu::ColorTargetState {
            format: targets.color_format,
            blend: None,
            write_mask: wgpu::ColorWrites::empty(),
        })];
        let fill = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &untouched,
                ..ScenePipelineDesc::new("abuffer fill", &module, "fs_fill")
            },
            &pipeline_layout,
        );
        let over = [Some(wgpu::ColorTargetState {
            format: targets.color_format,
            blend: Some(if transmit {
                PER_CHANNEL_OVER
            } else {
                PREMULTIPLIED_OVER
            }),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let resolve = fullscreen_pipeline(
            ctx,
            &FullscreenDesc {
                label: "abuffer resolve",
                layout: &pipeline_layout,
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
        self.gpu = Some(Resources {
            key,
            params,
            offsets,
            counters,
            readback,
            scan,
            layout,
            fill,
            resolve,
        });
        Ok(())
    }
}

impl Technique for Abuffer {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        if caps.max_storage_buffers_per_shader_stage < 4 {
            return Err(Unsupported::new(format!(
                "the A-buffer needs 4 storage buffers in the fragment stage; the adapter allows {}",
                caps.max_storage_buffers_per_shader_stage
            )));
        }
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
        let transmit = oit_linked_list::stores_opacity(self.config.node, &scene.scene, &ctx.caps);
        // Count → scan → fill → sort. The count's 16-byte summary sizes the array (the wait for
        // it is in the wall time, not in the GPU passes).
        let count = self.counter.count(ctx, scene, targets, timer, Self::NAME)?;
        let bytes = self.array_bytes(&ctx.caps, count.fragments, transmit)?;
        self.resources(ctx, targets, transmit)?;
        self.fragment_array(ctx, count.fragments, bytes);
        let (Some(r), Some(array), Some(counts)) = (
            self.gpu.as_ref(),
            self.array.as_ref(),
            self.counter.counts(),
        ) else {
            return Err(GpuError::Mismatch("abuffer: resources not built".into()));
        };
        let pixels = targets.resolution.pixel_count() as u64;
        let words: [u32; 4] = [
            targets.resolution.width,
            u32::from(scene.scene.camera.reverse_z),
            0,
            0,
        ];
        ctx.queue
            .write_buffer(&r.params, 0, bytemuck::cast_slice(&words));
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("abuffer"),
            layout: &r.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: r.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: r.offsets.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: counts.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: array.nodes.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: r.counters.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(&targets.depth_view),
                },
            ],
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(counts, 0, &r.offsets, 0, pixels * 4);
        encoder.clear_buffer(&r.offsets, pixels * 4, Some(4));
        encoder.clear_buffer(&r.counters, 0, None);
        {
            let ts = timer.pass("abuffer scan");
            let mut p = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("abuffer scan"),
                timestamp_writes: ts.compute_writes(),
            });
            r.scan.record(&mut p);
        }
        {
            let ts = timer.pass("abuffer fill");
            let mut p = pass::begin(
                &mut encoder,
                "abuffer fill",
                &[pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                None,
                &ts,
            );
            scene.bind(&mut p);
            p.set_bind_group(1, &group, &[]);
            for i in scene.transparent_draws() {
                scene.draw(&mut p, &r.fill, i);
            }
        }
        {
            let ts = timer.pass("abuffer resolve");
            pass::fullscreen(
                &mut encoder,
                "abuffer resolve",
                &targets.color_view,
                &r.resolve,
                &[(&scene.bind_group, &[0]), (&group, &[])],
                &ts,
            );
        }
        encoder.copy_buffer_to_buffer(&r.counters, 0, &r.readback, 0, 16);
        timer.submit(ctx, encoder)?;
        let c = read_buffer_u32(ctx, &r.readback, "abuffer counters")?;
        let pixels_lost = u64::from(c.get(1).copied().unwrap_or(0));
        Ok(RenderStats {
            geometry_passes: 2,
            pixels_with_dropped_layers: pixels_lost,
            auto_sizes: Some(AutoSizes {
                count,
                k: None,
                pool_nodes: Some(count.fragments),
                sort_max: None,
                sized_bytes: bytes,
                count_bytes: self.counter.memory_bytes(),
            }),
            ..Default::default()
        })
    }

    fn work(&self, _caps: &Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        // Scalar fragments; on a scene with coloured transmission one word more.
        let node = self.config.fragment_bytes(false) as u32;
        let texel = texel_bytes(target);
        Work::new(vec![
            // `oit_gpu::LayerCounter`: the opaque depth loaded; atomicAdd on the pixel's count,
            // atomicMax and atomicAdd on the frame's summary.
            PassWork::new("abuffer count", PassDraws::Transparent)
                .bytes(DEPTH_BYTES, 0)
                .atomics(3.0),
            // Reduce-then-scan over the counts: no fragments.
            PassWork::new("abuffer scan", PassDraws::Compute),
            // A stored fragment: the opaque depth and its pixel's two offsets loaded, its node
            // written; atomicSub on the pixel's count.
            PassWork::new("abuffer fill", PassDraws::Transparent)
                .bytes(DEPTH_BYTES + 8, node)
                .atomics(1.0),
            // Per pixel: two offsets and the count left loaded, the final texel read and
            // written by the blend; per stored fragment its node read (pixels deeper than the
            // registers also sort in place: more reads and writes, not counted).
            PassWork::new("abuffer resolve", PassDraws::FullScreen)
                .bytes(12 + texel, texel)
                .reads_fragments_of("abuffer fill", node),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.ledger.total() + self.array_ledger.total() + self.counter.memory_bytes()
    }

    fn transmission(&self, caps: &Caps) -> Support {
        // The list's nodes, so the list's support.
        oit_linked_list::node_transmission(caps)
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        oit_linked_list::node_operator(self.config.node, operator, caps)
    }
}
