//! The `linked-list` technique: insert pass, resolve pass, per-pixel accounting.

use crate::config::{LinkedListConfig, SortMax, TailRule};
use crate::frame::Counters;
use crate::node::NodeFormat;
use crate::sizing::{Sizing, check_auto_bytes};
use oit_gpu::wgpu;
use oit_gpu::{
    AutoSizes, Caps, Context, FullscreenDesc, GpuError, GpuScene, GpuTimer, LayerCount,
    LayerCounter, MemoryLedger, PREMULTIPLIED_OVER, RenderStats, ScenePipelineDesc, ScenePipelines,
    SpecError, Support, Targets, Technique, TechniqueSpec, Unsupported, bind, fullscreen_pipeline,
    pass,
};
use oit_scene::BlendOperator;
use oit_scene::Resolution;

/// shaders/linked_list.wgsl and its node module.
pub const WGSL: &str = include_str!("../shaders/linked_list.wgsl");
pub const NODE_WGSL: &str = include_str!("../shaders/linked_list_node.wgsl");
/// The root module on scenes with coloured transmission: includes linked_list.wgsl and adds the
/// dual-source resolve.
pub const TRANSMIT_WGSL: &str = include_str!("../shaders/linked_list_transmit.wgsl");

/// The lines of the shaders the crate rewrites per configuration (checked by a test).
pub(crate) const SORT_MAX_LINE: &str = "const SORT_MAX: u32 = 16u;";
pub(crate) const PACKED_LINE: &str = "override PACKED: bool = false;";
pub(crate) const TRANSMIT_LINE: &str = "override TRANSMIT: bool = false;";

/// `dst = src0 + src1 ⊙ dst` per channel (src1 = the stack's rgb transmittance); alpha as
/// premultiplied OVER. Needs dual-source blending, hence one target.
pub const PER_CHANNEL_OVER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::Src1,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: PREMULTIPLIED_OVER.alpha,
};

/// The node module for `transmit` nodes (rgb opacity) or scalar ones: the flag becomes a
/// constant, so the scalar pipelines compile to the code they always had.
pub(crate) fn node_source(node: &str, transmit: bool) -> String {
    node.replace(
        TRANSMIT_LINE,
        &format!("const TRANSMIT: bool = {transmit};"),
    )
}

/// The shader sources for `config` with a sort window of `sort_max` (the spec's, or the one
/// `sort-max=auto` counted): the window size, the node format and whether nodes store rgb
/// opacity (`transmit`) are constants.
pub fn shader_sources(
    config: &LinkedListConfig,
    sort_max: SortMax,
    transmit: bool,
) -> (String, String) {
    let list = WGSL.replace(
        SORT_MAX_LINE,
        &format!("const SORT_MAX: u32 = {}u;", sort_max.get()),
    );
    (list, node_module(config.node, transmit))
}

/// Whether a scene takes the per-channel path: coloured transmission on an adapter with
/// dual-source blending. Every other scene keeps the scalar nodes and resolve.
pub(crate) fn per_channel(scene: &oit_scene::Scene, caps: &Caps) -> bool {
    scene.has_coloured_transmission() && caps.dual_source_blending
}

/// Whether the list stores nodes in the transmit layout on `scene`: see [`stores_opacity`].
pub(crate) fn node_layout_transmits(
    config: &LinkedListConfig,
    scene: &oit_scene::Scene,
    caps: &Caps,
) -> bool {
    stores_opacity(config.node, scene, caps)
}

/// Whether nodes of `format` take the transmit layout (rgb opacity, resolved with dual-source
/// blending) on `scene`: the per-channel path, or packed nodes on a scene that subtracts,
/// whose sign only the 16-byte packed node has a bit for (`NEGATED` of linked_list_node.wgsl).
pub fn stores_opacity(format: NodeFormat, scene: &oit_scene::Scene, caps: &Caps) -> bool {
    per_channel(scene, caps)
        || (format == NodeFormat::Packed
            && caps.dual_source_blending
            && scene.operators_used().contains(&BlendOperator::Subtract))
}

/// linked_list_node.wgsl for nodes of `format`, with rgb opacity when `transmit`: the node
/// module other stored-fragment techniques include (the prefix-sum A-buffer).
pub fn node_module(format: NodeFormat, transmit: bool) -> String {
    let node = NODE_WGSL.replace(
        PACKED_LINE,
        &format!("const PACKED: bool = {};", format == NodeFormat::Packed),
    );
    node_source(&node, transmit)
}

/// Per-pixel linked lists with a bounded sort window.
#[derive(Debug)]
pub struct LinkedList {
    config: LinkedListConfig,
    gpu: Option<Resources>,
    ledger: MemoryLedger,
    /// The node pool, apart from the rest: an `auto` pool follows the scene's fragment count
    /// without rebuilding the pipelines.
    pool: Option<Pool>,
    pool_ledger: MemoryLedger,
    /// The count pass (`auto` sizes only).
    counter: LayerCounter,
    last: FrameCounts,
}

#[derive(Debug)]
struct Pool {
    capacity: u32,
    nodes: wgpu::Buffer,
}

/// What the last frame's resolve counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FrameCounts {
    /// Nodes the insert pass asked for (more than the pool when fragments were lost).
    pub fragments: u64,
    /// Pixels that lost fragments to a full pool, or dropped their tail (`tail=drop`).
    pub pixels_dropped: u64,
    /// Pixels whose fragments behind the window were averaged (`tail=average`).
    pub pixels_tail_averaged: u64,
}

#[derive(Debug)]
struct Resources {
    /// Resolution, final colour format, rgb-opacity nodes, sort window.
    key: (Resolution, wgpu::TextureFormat, bool, SortMax),
    params: wgpu::Buffer,
    heads: wgpu::Buffer,
    lost: wgpu::Buffer,
    counters: Counters,
    layout: wgpu::BindGroupLayout,
    insert: ScenePipelines,
    resolve: wgpu::RenderPipeline,
}

impl LinkedList {
    pub fn new(config: LinkedListConfig) -> Self {
        LinkedList {
            config,
            gpu: None,
            ledger: MemoryLedger::new(),
            pool: None,
            pool_ledger: MemoryLedger::new(),
            counter: LayerCounter::new(),
            last: FrameCounts::default(),
        }
    }

    /// Refuses a spec that does not describe a linked-list configuration.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(LinkedListConfig::from_spec(spec)?))
    }

    pub fn config(&self) -> LinkedListConfig {
        self.config
    }

    /// The counts of the last rendered frame.
    pub fn last_counts(&self) -> FrameCounts {
        self.last
    }

    /// Node pool size (nodes, bytes) at `resolution` (`transmit`: rgb-opacity nodes), or why
    /// the adapter cannot hold it; `nodes-per-pixel=auto` needs [`LinkedList::auto_pool`].
    pub fn pool(
        &self,
        caps: &Caps,
        resolution: Resolution,
        transmit: bool,
    ) -> Result<(u32, u64), GpuError> {
        let Sizing::Fixed(nodes_per_pixel) = self.config.nodes_per_pixel else {
            return Err(GpuError::Mismatch(
                "nodes-per-pixel=auto: the pool is sized from a count (LinkedList::auto_pool)"
                    .into(),
            ));
        };
        let pixels = u64::from(resolution.width) * u64::from(resolution.height);
        let capacity = pixels * u64::from(nodes_per_pixel.get());
        let node_bytes = self.config.node.bytes(transmit);
        let bytes = capacity * node_bytes;
        let limit = caps
            .max_storage_buffer_binding_size
            .min(caps.max_buffer_size);
        if bytes > limit || capacity > u64::from(u32::MAX) {
            return Err(GpuError::TooLarge {
                what: format!(
                    "the node pool ({nodes_per_pixel} nodes-per-pixel × {pixels} px × {node_bytes} B)"
                ),
                needed: bytes,
                limit,
            });
        }
        Ok((capacity as u32, bytes))
    }

    /// The pool `nodes-per-pixel=auto` takes for `count`: a node for every counted fragment
    /// (at least one), or the refusal, in MiB, when that is over the cap.
    pub fn auto_pool(
        &self,
        caps: &Caps,
        count: LayerCount,
        transmit: bool,
    ) -> Result<(u32, u64), GpuError> {
        let nodes = count.fragments.max(1);
        let node_bytes = self.config.node.bytes(transmit);
        let bytes = nodes.saturating_mul(node_bytes);
        check_auto_bytes(
            &format!(
                "the node pool of linked-list:nodes-per-pixel=auto ({} fragments in front of the opaque surface × {node_bytes} B)",
                count.fragments
            ),
            bytes,
            caps,
        )?;
        // Heads store index + 1, so the last index must stay below u32::MAX.
        let capacity = u32::try_from(nodes)
            .ok()
            .filter(|&n| n < u32::MAX)
            .ok_or_else(|| GpuError::TooMany {
                what: "the node pool's indices (u32)".into(),
                needed: nodes,
                limit: u64::from(u32::MAX - 1),
            })?;
        Ok((capacity, bytes))
    }

    /// The node pool for this frame (`capacity` nodes of `bytes`), kept while it is the same.
    fn pool_buffer(&mut self, ctx: &Context, capacity: u32, bytes: u64) {
        if self.pool.as_ref().is_some_and(|p| p.capacity == capacity) {
            return;
        }
        self.pool = None;
        self.pool_ledger.clear();
        let nodes = self.pool_ledger.create_buffer(
            &ctx.device,
            &wgpu::BufferDescriptor {
                label: Some("linked-list node pool"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        self.pool = Some(Pool { capacity, nodes });
    }

    fn resources(
        &mut self,
        ctx: &Context,
        targets: &Targets,
        transmit: bool,
        sort_max: SortMax,
    ) -> Result<(), GpuError> {
        let key = (targets.resolution, targets.color_format, transmit, sort_max);
        if self.gpu.as_ref().is_some_and(|g| g.key == key) {
            return Ok(());
        }
        self.gpu = None;
        self.ledger.clear();
        let pixels = u64::from(targets.resolution.width) * u64::from(targets.resolution.height);
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
            "linked-list params",
            16,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let heads = buffer("linked-list heads", pixels * 4, storage);
        let lost = buffer("linked-list lost fragments", pixels * 4, storage);
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("linked-list"),
            entries: &[
                bind::uniform(0, fragment),
                bind::storage(1, fragment, false),
                bind::storage(2, fragment, false),
                bind::storage(3, fragment, false),
                bind::storage(4, fragment, false),
                bind::float_texture(5, fragment),
            ],
        });
        let (list_src, node_src) = shader_sources(&self.config, sort_max, transmit);
        let module = if transmit {
            ctx.shader_with(
                "linked_list_transmit.wgsl",
                TRANSMIT_WGSL,
                &[
                    &[
                        ("linked_list.wgsl", &list_src),
                        ("linked_list_node.wgsl", &node_src),
                    ],
                    crate::SHADERS,
                ],
            )?
        } else {
            ctx.shader_with(
                "linked_list.wgsl",
                &list_src,
                &[&[("linked_list_node.wgsl", &node_src)], crate::SHADERS],
            )?
        };
        let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("linked-list"),
            bind_group_layouts: &[Some(ctx.scene_layout()), Some(&layout)],
            immediate_size: 0,
        });
        // The pass needs an attachment; nothing is written to it (the lists are the output).
        let untouched = [Some(wgpu::ColorTargetState {
            format: targets.color_format,
            blend: None,
            write_mask: wgpu::ColorWrites::empty(),
        })];
        let insert = ScenePipelines::with_layout(
            ctx,
            &ScenePipelineDesc {
                targets: &untouched,
                ..ScenePipelineDesc::new("linked-list insert", &module, "fs_insert")
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
                label: "linked-list resolve",
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
        let counters = Counters::new(ctx, &mut self.ledger, "linked-list");
        self.gpu = Some(Resources {
            key,
            params,
            heads,
            lost,
            counters,
            layout,
            insert,
            resolve,
        });
        Ok(())
    }
}

impl Technique for LinkedList {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn predict(
        &self,
        scene: &oit_scene::Scene,
        lists: &oit_gpu::predict::PixelLists,
        caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict_list(self.config, scene, lists, caps)
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        if caps.max_storage_buffers_per_shader_stage < 4 {
            return Err(Unsupported::new(format!(
                "linked lists need 4 storage buffers in the fragment stage; the adapter allows {}",
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
        let transmit = node_layout_transmits(&self.config, &scene.scene, &ctx.caps);
        // Count → size → build: the count pass is one more geometry pass in the frame's GPU
        // time; the wait for its 16-byte summary is in the wall time only.
        let count = if self.config.counts() {
            Some(
                self.counter
                    .count(ctx, scene, targets, timer, "linked-list")?,
            )
        } else {
            None
        };
        let sort_max = self.config.sort_max.per_pixel(
            "sort-max",
            count,
            "the window lives in each resolve invocation's registers",
        )?;
        let (capacity, pool_bytes) = match (self.config.nodes_per_pixel, count) {
            (Sizing::Auto, Some(count)) => self.auto_pool(&ctx.caps, count, transmit)?,
            _ => self.pool(&ctx.caps, targets.resolution, transmit)?,
        };
        self.resources(ctx, targets, transmit, sort_max)?;
        self.pool_buffer(ctx, capacity, pool_bytes);
        let auto_sizes = count.map(|count| AutoSizes {
            count,
            k: None,
            pool_nodes: (self.config.nodes_per_pixel == Sizing::Auto)
                .then_some(u64::from(capacity)),
            sort_max: (self.config.sort_max == Sizing::Auto).then_some(sort_max.get()),
            sized_bytes: pool_bytes,
            count_bytes: self.counter.memory_bytes(),
        });
        let (Some(r), Some(pool)) = (self.gpu.as_ref(), self.pool.as_ref()) else {
            return Err(GpuError::Mismatch(
                "linked-list: resources not built".into(),
            ));
        };
        let words: [u32; 4] = [
            targets.resolution.width,
            pool.capacity,
            u32::from(scene.scene.camera.reverse_z),
            u32::from(self.config.tail == TailRule::Average),
        ];
        ctx.queue
            .write_buffer(&r.params, 0, bytemuck::cast_slice(&words));
        let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("linked-list"),
            layout: &r.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: r.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: r.heads.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: pool.nodes.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: r.counters.buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: r.lost.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(&targets.depth_view),
                },
            ],
        });
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&r.heads, 0, None);
        encoder.clear_buffer(&r.lost, 0, None);
        r.counters.clear(&mut encoder);
        {
            let ts = timer.pass("linked-list insert");
            let mut p = pass::begin(
                &mut encoder,
                "linked-list insert",
                &[pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                None,
                &ts,
            );
            scene.bind(&mut p);
            p.set_bind_group(1, &group, &[]);
            for i in scene.transparent_draws() {
                scene.draw(&mut p, &r.insert, i);
            }
        }
        let c = r
            .counters
            .resolve_and_read(ctx, encoder, timer, scene, targets, &r.resolve, &group)?;
        self.last = FrameCounts {
            fragments: u64::from(c[0]),
            pixels_dropped: u64::from(c[1]),
            pixels_tail_averaged: u64::from(c[2]),
        };
        Ok(RenderStats {
            geometry_passes: 1,
            pixels_with_dropped_layers: self.last.pixels_dropped,
            pixels_with_approximated_layers: self.last.pixels_tail_averaged,
            auto_sizes,
            ..Default::default()
        })
    }

    fn work(&self, _caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        // Scalar nodes; on a scene with coloured transmission a node carries 4 B more.
        let node = self.config.node.bytes(false) as u32;
        let texel = texel_bytes(target);
        Work::new(vec![
            // The count pass of the auto sizes (`oit_gpu::LayerCounter`, pass "linked-list count"):
            // a fragment in front of the opaque depth (loaded), counted by atomicAdd on its
            // pixel, atomicMax and atomicAdd on the frame's summary.
            PassWork::new("linked-list count", PassDraws::Transparent)
                .bytes(DEPTH_BYTES, 0)
                .atomics(3.0),
            // A fragment that is stored (the rest are discarded, uncounted): the opaque depth
            // loaded (the shader's own test, no depth attachment), its node written; the
            // allocation's atomicAdd and the head's atomicExchange. Nothing is written to the
            // attachment (empty write mask).
            PassWork::new("linked-list insert", PassDraws::Transparent)
                .bytes(DEPTH_BYTES, node)
                .atomics(2.0),
            // Per pixel: the head and the lost-node count loaded (4 B each), the final texel
            // read and written by the blend; per stored fragment its node read. The dropped and
            // averaged counters' atomicAdd happen only on pixels that drop or average a tail
            // (not counted).
            PassWork::new("linked-list resolve", PassDraws::FullScreen)
                .bytes(8 + texel, texel)
                .reads_fragments_of("linked-list insert", node),
        ])
    }

    fn memory_bytes(&self) -> u64 {
        self.ledger.total() + self.pool_ledger.total() + self.counter.memory_bytes()
    }

    fn transmission(&self, caps: &Caps) -> Support {
        node_transmission(caps)
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        node_operator(self.config.node, operator, caps)
    }
}

/// What stored nodes do with coloured transmission on an adapter with `caps` (the list's and
/// the A-buffer's): per channel, exact up to their storage, with dual-source blending.
pub fn node_transmission(caps: &Caps) -> Support {
    if !caps.dual_source_blending {
        return Support::Approximate(
            "composites 1 − mean(t) as scalar α, exact for grey filters only (the per-channel resolve dst = C + T ⊙ dst needs dual-source blending, which the adapter lacks)",
        );
    }
    // Nodes store rgb opacity: binary16 (f32 nodes) or unorm10 (packed), as they store α.
    // An averaged tail stays an approximation, per channel, and is reported per pixel.
    Support::Exact
}

/// What nodes of `format` do with `operator` on an adapter with `caps` (the list's and the
/// A-buffer's).
pub fn node_operator(format: NodeFormat, operator: BlendOperator, caps: &Caps) -> Support {
    match operator {
        // (P, t) with t = 1: what is behind is not dimmed.
        BlendOperator::Over | BlendOperator::Add => Support::Exact,
        // binary16 holds the sign; rgb9e5 does not, and only the 16-byte packed node (the
        // transmit layout, resolved with dual-source blending) has a bit for it.
        BlendOperator::Subtract if format == NodeFormat::F32 || caps.dual_source_blending => {
            Support::Exact
        }
        BlendOperator::Subtract => Support::Unsupported(
            "packed nodes store rgb9e5 colour, which holds no sign; the 16-byte node that carries it resolves with dual-source blending, which the adapter lacks",
        ),
        // A filter without colour: coloured transmittance with P = 0.
        BlendOperator::Multiply => node_transmission(caps),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rewritten_lines_exist_in_the_shaders() {
        assert_eq!(WGSL.matches(SORT_MAX_LINE).count(), 1);
        assert_eq!(NODE_WGSL.matches(PACKED_LINE).count(), 1);
        assert_eq!(NODE_WGSL.matches(TRANSMIT_LINE).count(), 1);
        let config = LinkedListConfig {
            node: NodeFormat::Packed,
            ..Default::default()
        };
        let (list, node) = shader_sources(&config, crate::SortMax::of(37), true);
        assert!(list.contains("const SORT_MAX: u32 = 37u;") && !list.contains(SORT_MAX_LINE));
        assert!(node.contains("const PACKED: bool = true;"));
        assert!(node.contains("const TRANSMIT: bool = true;"));
        let (_, scalar) = shader_sources(&config, crate::SortMax::of(37), false);
        assert!(scalar.contains("const TRANSMIT: bool = false;"));
    }
}
