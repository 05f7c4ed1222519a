//! The five blended techniques, one implementation with a `Kind` switch: they share pipelines,
//! the blend state and the pass structure, and differ only in which draws go in which order.

use crate::sort::{DepthSorter, centroid, object_order};
use oit_gpu::pass;
use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, CullRule, GpuError, GpuScene, GpuTimer, MaterialSource, MemoryLedger,
    PREMULTIPLIED_OVER, PassDraws, PassWork, RenderStats, ScenePipelineDesc, ScenePipelines,
    SpecError, Support, Targets, Technique, TechniqueSpec, Unsupported, Work, depth_test,
};
use oit_scene::BlendOperator;
use std::collections::BTreeMap;
use std::time::Instant;

/// Dual-source blending for coloured transmittance (shaders/blend_transmit.wgsl).
pub(crate) const BLEND_TRANSMIT: &str = include_str!("../shaders/blend_transmit.wgsl");

/// `dst = src0 + src1 ⊙ dst` per channel (src1 = the fragment's transmittance); alpha as
/// [`PREMULTIPLIED_OVER`].
const PER_CHANNEL_OVER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::Src1,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: PREMULTIPLIED_OVER.alpha,
};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    Unsorted,
    SortedObject,
    SortedTriangle,
    DepthPrepass,
    CullSplit,
}

impl Kind {
    pub const ALL: [Kind; 5] = [
        Kind::Unsorted,
        Kind::SortedObject,
        Kind::SortedTriangle,
        Kind::DepthPrepass,
        Kind::CullSplit,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Kind::Unsorted => "unsorted",
            Kind::SortedObject => "sorted-object",
            Kind::SortedTriangle => "sorted-triangle",
            Kind::DepthPrepass => "depth-prepass",
            Kind::CullSplit => "cull-split",
        }
    }

    pub fn description(self) -> &'static str {
        match self {
            Kind::Unsorted => "OVER blending in draw order (the cost baseline)",
            Kind::SortedObject => {
                "OVER blending, objects sorted by render group, alpha index, then bounding-sphere distance (far first), as Babylon"
            }
            Kind::SortedTriangle => {
                "OVER blending, every transparent triangle radix-sorted back to front by centroid view depth on the CPU each frame"
            }
            Kind::DepthPrepass => {
                "depth-only pass of the transparent geometry, then EQUAL-depth blending: only the nearest transparent layer"
            }
            Kind::CullSplit => {
                "sorted-object order, each double-sided object drawn back faces then front faces (Babylon separateCullingPass)"
            }
        }
    }
}

/// Pipelines for one (colour format, reverse-Z, coloured transmission) combination.
#[derive(Debug)]
struct Pipelines {
    key: (wgpu::TextureFormat, bool, bool),
    /// Blending, depth test strictly nearer, no depth write, culling by material.
    blend: ScenePipelines,
    /// Same without fixed-function culling (the shader still discards back faces of
    /// single-sided materials): one pipeline for a globally sorted triangle stream.
    blend_unculled: Option<ScenePipelines>,
    /// Depth-only, strictly nearer, writes depth.
    depth_only: Option<ScenePipelines>,
    /// Blending where depth EQUALS the prepass depth.
    blend_equal: Option<ScenePipelines>,
    /// Back faces only (front culled) and front faces only (back culled).
    back_faces: Option<ScenePipelines>,
    front_faces: Option<ScenePipelines>,
}

/// Per-scene data of `sorted-triangle`.
#[derive(Debug)]
struct TriangleStream {
    scene_id: u64,
    /// Per (render group, queue) level (ascending): first vertex of each transparent triangle
    /// and its centroid.
    groups: Vec<(Vec<u32>, Vec<glam::Vec3>)>,
    triangles: usize,
    indices: Vec<u32>,
    index_buffer: wgpu::Buffer,
    sorter: DepthSorter,
}

/// One of the blended baselines.
#[derive(Debug)]
pub struct Blended {
    kind: Kind,
    pipelines: Option<Pipelines>,
    stream: Option<TriangleStream>,
    ledger: MemoryLedger,
}

impl Blended {
    pub fn new(kind: Kind) -> Self {
        Blended {
            kind,
            pipelines: None,
            stream: None,
            ledger: MemoryLedger::new(),
        }
    }

    /// Refuses a spec that names no blended baseline, or gives one a parameter (they have none).
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        let kind = Kind::ALL
            .into_iter()
            .find(|k| k.name() == spec.name())
            .ok_or_else(|| SpecError::WrongTechnique {
                spec: spec.to_string(),
                expected: Kind::ALL.map(Kind::name).join(" or "),
            })?;
        if let Some(key) = spec.params().keys().next() {
            return Err(SpecError::UnknownKey {
                spec: spec.to_string(),
                name: spec.name().to_owned(),
                key: key.clone(),
                keys: "(none)".to_owned(),
            });
        }
        Ok(Blended::new(kind))
    }

    fn pipelines(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        format: wgpu::TextureFormat,
    ) -> Result<(), GpuError> {
        // Scenes with coloured transmission blend per channel with dual-source blending where
        // the adapter has it; every other scene keeps the one-source pipelines.
        let transmit = scene.scene.has_transmission() && ctx.caps.dual_source_blending;
        let key = (format, scene.scene.camera.reverse_z, transmit);
        if self.pipelines.as_ref().is_some_and(|p| p.key == key) {
            return Ok(());
        }
        let module = ctx.shader_with("blend.wgsl", oit_gpu::shaders::BLEND, &[crate::SHADERS])?;
        let transmit_module = if transmit {
            Some(ctx.shader_with("blend_transmit.wgsl", BLEND_TRANSMIT, &[crate::SHADERS])?)
        } else {
            None
        };
        let color = [Some(wgpu::ColorTargetState {
            format,
            blend: Some(if transmit {
                PER_CHANNEL_OVER
            } else {
                PREMULTIPLIED_OVER
            }),
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let nearer = scene.depth_nearer();
        let far = [("FAR_DEPTH", f64::from(scene.scene.camera.far_depth()))];
        let make = |label: &str,
                    entry: &str,
                    targets: &[Option<wgpu::ColorTargetState>],
                    write: bool,
                    cmp,
                    cull| {
            // Colour entries come from blend_transmit.wgsl on transmission scenes.
            let (module, entry) = match (&transmit_module, entry) {
                (Some(m), "fs_blend") => (m, "fs_blend_transmit"),
                (Some(m), "fs_blend_equal") => (m, "fs_blend_transmit_equal"),
                _ => (&module, entry),
            };
            let equal = entry.ends_with("_equal");
            ScenePipelines::new(
                ctx,
                &ScenePipelineDesc {
                    targets,
                    depth: Some(depth_test(cmp, write)),
                    cull,
                    constants: if equal { &far } else { &[] },
                    // The unculled pipeline draws sorted-triangle's stream, one draw call
                    // that mixes materials.
                    material: if cull == CullRule::Fixed(None) {
                        MaterialSource::PerVertex
                    } else {
                        MaterialSource::PerDraw
                    },
                    ..ScenePipelineDesc::new(label, module, entry)
                },
            )
        };
        let k = self.kind;
        self.pipelines = Some(Pipelines {
            key,
            blend: make(
                "blend",
                "fs_blend",
                &color,
                false,
                nearer,
                CullRule::ByMaterial,
            ),
            blend_unculled: (k == Kind::SortedTriangle).then(|| {
                make(
                    "blend unculled",
                    "fs_blend",
                    &color,
                    false,
                    nearer,
                    CullRule::Fixed(None),
                )
            }),
            depth_only: (k == Kind::DepthPrepass).then(|| {
                make(
                    "transparent depth",
                    "fs_depth_only",
                    &[],
                    true,
                    nearer,
                    CullRule::ByMaterial,
                )
            }),
            blend_equal: (k == Kind::DepthPrepass).then(|| {
                make(
                    "blend equal",
                    "fs_blend_equal",
                    &color,
                    false,
                    wgpu::CompareFunction::Equal,
                    CullRule::ByMaterial,
                )
            }),
            back_faces: (k == Kind::CullSplit).then(|| {
                make(
                    "blend back faces",
                    "fs_blend",
                    &color,
                    false,
                    nearer,
                    CullRule::Fixed(Some(wgpu::Face::Front)),
                )
            }),
            front_faces: (k == Kind::CullSplit).then(|| {
                make(
                    "blend front faces",
                    "fs_blend",
                    &color,
                    false,
                    nearer,
                    CullRule::Fixed(Some(wgpu::Face::Back)),
                )
            }),
        });
        Ok(())
    }

    /// Builds (once per scene) the transparent triangle list of `sorted-triangle`.
    fn stream(&mut self, ctx: &Context, scene: &GpuScene) -> Result<&mut TriangleStream, GpuError> {
        if self.stream.as_ref().is_none_or(|s| s.scene_id != scene.id) {
            let s = &scene.scene;
            // Per (render group, queue) level, as the reference composites them.
            let mut groups: BTreeMap<oit_scene::QueueLevel, (Vec<u32>, Vec<glam::Vec3>)> =
                BTreeMap::new();
            for i in scene.transparent_draws() {
                let d = &s.draws[i];
                let g = groups.entry(s.queue_level(d)).or_default();
                for t in 0..d.triangle_count() {
                    let v = d.first_vertex + 3 * t;
                    let p = |k: u32| s.vertices[(v + k) as usize].position;
                    g.0.push(v);
                    g.1.push(centroid(p(0), p(1), p(2)));
                }
            }
            let triangles: usize = groups.values().map(|g| g.0.len()).sum();
            let bytes = (triangles as u64 * 12).max(12);
            if bytes > ctx.caps.max_buffer_size {
                return Err(GpuError::TooLarge {
                    what: format!("the sorted index buffer of {triangles} transparent triangles"),
                    needed: bytes,
                    limit: ctx.caps.max_buffer_size,
                });
            }
            self.ledger.clear();
            let index_buffer = self.ledger.create_buffer(
                &ctx.device,
                &wgpu::BufferDescriptor {
                    label: Some("sorted triangle indices"),
                    size: bytes,
                    usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                },
            );
            self.stream = Some(TriangleStream {
                scene_id: scene.id,
                groups: groups.into_values().collect(),
                triangles,
                indices: Vec::with_capacity(triangles * 3),
                index_buffer,
                sorter: DepthSorter::new(),
            });
        }
        Ok(self.stream.as_mut().expect("stream just built"))
    }
}

/// The opaque pass's depth, tested against (and, in the prepass, written).
fn load_depth(targets: &Targets) -> Option<wgpu::RenderPassDepthStencilAttachment<'_>> {
    pass::depth(
        &targets.depth_view,
        wgpu::LoadOp::Load,
        wgpu::StoreOp::Store,
    )
}

impl Technique for Blended {
    fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of(self.kind.name())
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        caps.require_scene_materials()?;
        Ok(())
    }

    fn predict(
        &self,
        scene: &oit_scene::Scene,
        lists: &oit_gpu::predict::PixelLists,
        caps: &Caps,
    ) -> oit_gpu::Prediction {
        crate::predict::predict(self.kind, scene, lists, caps)
    }

    fn render(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
        timer: &mut GpuTimer,
    ) -> Result<RenderStats, GpuError> {
        self.pipelines(ctx, scene, targets.color_format)?;
        let cpu = Instant::now();
        let mut stats = RenderStats {
            geometry_passes: 1,
            ..Default::default()
        };
        // CPU ordering first (timed), then recording.
        let order = match self.kind {
            Kind::SortedObject | Kind::CullSplit => object_order(&scene.scene),
            _ => scene.transparent_draws(),
        };
        let mut index_count = 0;
        if self.kind == Kind::SortedTriangle {
            let view = scene.scene.camera.view;
            let stream = self.stream(ctx, scene)?;
            let sort_start = Instant::now();
            stream.indices.clear();
            for (first, centroids) in &stream.groups {
                for &t in stream.sorter.sort_back_to_front(&view, centroids) {
                    let v = first[t as usize];
                    stream.indices.extend([v, v + 1, v + 2]);
                }
            }
            index_count = stream.indices.len() as u32;
            debug_assert_eq!(index_count as usize, stream.triangles * 3);
            if index_count > 0 {
                ctx.queue.write_buffer(
                    &stream.index_buffer,
                    0,
                    bytemuck::cast_slice(&stream.indices),
                );
            }
            stats.cpu_ms = sort_start.elapsed().as_secs_f64() * 1e3;
        } else {
            stats.cpu_ms = cpu.elapsed().as_secs_f64() * 1e3;
        }
        let p = self.pipelines.as_ref().expect("pipelines built above");
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        if self.kind == Kind::DepthPrepass {
            stats.geometry_passes = 2;
            let ts = timer.pass("transparent depth prepass");
            {
                let mut pass = pass::begin(
                    &mut encoder,
                    "transparent depth prepass",
                    &[],
                    load_depth(targets),
                    &ts,
                );
                scene.bind(&mut pass);
                let depth_only = p.depth_only.as_ref().expect("prepass pipelines");
                for &i in &order {
                    scene.draw(&mut pass, depth_only, i);
                }
            }
            timer.submit(ctx, encoder)?;
            encoder = ctx.device.create_command_encoder(&Default::default());
        }
        let ts = timer.pass(match self.kind {
            Kind::DepthPrepass => "blend nearest layer",
            _ => "blend",
        });
        {
            let mut pass = pass::begin(
                &mut encoder,
                self.kind.name(),
                &[pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                load_depth(targets),
                &ts,
            );
            scene.bind(&mut pass);
            match self.kind {
                Kind::Unsorted | Kind::SortedObject => {
                    for &i in &order {
                        scene.draw(&mut pass, &p.blend, i);
                    }
                }
                Kind::DepthPrepass => {
                    let equal = p.blend_equal.as_ref().expect("prepass pipelines");
                    for &i in &order {
                        scene.draw(&mut pass, equal, i);
                    }
                }
                Kind::CullSplit => {
                    let back = p.back_faces.as_ref().expect("cull-split pipelines");
                    let front = p.front_faces.as_ref().expect("cull-split pipelines");
                    for &i in &order {
                        let d = &scene.scene.draws[i];
                        if scene.scene.material_of(d).double_sided {
                            scene.draw(&mut pass, back, i);
                        }
                        scene.draw(&mut pass, front, i);
                    }
                }
                Kind::SortedTriangle => {
                    if index_count > 0 {
                        let stream = self.stream.as_ref().expect("stream built above");
                        let unculled = p
                            .blend_unculled
                            .as_ref()
                            .expect("sorted-triangle pipelines");
                        pass.set_pipeline(unculled.double_sided_for(scene));
                        pass.set_index_buffer(
                            stream.index_buffer.slice(..),
                            wgpu::IndexFormat::Uint32,
                        );
                        pass.draw_indexed(0..index_count, 0, 0..1);
                    }
                }
            }
        }
        timer.submit(ctx, encoder)?;
        Ok(stats)
    }

    fn work(&self, _caps: &oit_gpu::Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, blend};
        let (dst_read, dst_written) = blend(target);
        // Every blend pass: a depth test against the opaque depth (read, no write), and the
        // premultiplied over into the final target (its texel read and written).
        let blended = |name: &str, draws| {
            PassWork::new(name, draws).bytes(DEPTH_BYTES + dst_read, dst_written)
        };
        Work::new(match self.kind {
            Kind::Unsorted | Kind::SortedObject | Kind::SortedTriangle => {
                vec![blended("blend", PassDraws::Transparent)]
            }
            // Back faces of double-sided draws first, then front faces: those draws twice.
            Kind::CullSplit => vec![blended("blend", PassDraws::TransparentDoubleSidedTwice)],
            Kind::DepthPrepass => vec![
                // The nearest transparent depth: read and written per passing fragment.
                PassWork::new("transparent depth prepass", PassDraws::Transparent)
                    .bytes(DEPTH_BYTES, DEPTH_BYTES),
                // Only the fragment equal to that depth passes, and blends.
                blended("blend nearest layer", PassDraws::Transparent),
            ],
        })
    }

    fn memory_bytes(&self) -> u64 {
        self.ledger.total()
    }

    fn transmission(&self, caps: &Caps) -> Support {
        if caps.dual_source_blending {
            // blend_transmit.wgsl: dst = src0 + src1 ⊙ dst, per channel.
            Support::Exact
        } else {
            Support::Approximate(
                "composites 1 − mean(t) as scalar α, exact for grey filters only (the adapter has no dual-source blending for dst = C + t ⊙ dst)",
            )
        }
    }

    fn queues(&self) -> oit_gpu::Queues {
        // Object orders follow the engine's (group, queue) order, the triangle stream is
        // grouped by level; no transparent draw writes depth.
        match self.kind {
            Kind::SortedObject | Kind::SortedTriangle | Kind::CullSplit => oit_gpu::Queues::Ordered,
            Kind::Unsorted | Kind::DepthPrepass => oit_gpu::Queues::Ignored,
        }
    }

    fn operator(&self, operator: BlendOperator, caps: &Caps) -> Support {
        match operator {
            // (P, t) with t = 1: what is behind is not dimmed.
            BlendOperator::Over | BlendOperator::Add | BlendOperator::Subtract => Support::Exact,
            // A filter without colour: coloured transmittance with P = 0.
            BlendOperator::Multiply => self.transmission(caps),
        }
    }
}
