//! The `ray-query` technique: acceleration structures of the transparent triangles, the copy of
//! the opaque colour, and the one full-screen pass that traces.

use oit_gpu::wgpu;
use oit_gpu::{
    Caps, Context, FullscreenDesc, GpuError, GpuScene, GpuTimer, MemoryLedger, Param, ParamInfo,
    Prediction, RenderStats, SpecError, Support, Targets, Technique, TechniqueSpec, Unsupported,
    bind, fullscreen_pipeline, pass,
};
use oit_scene::{BlendOperator, Resolution, Scene};

/// Hits collected per trace.
pub type K = oit_gpu::Bounded<1, 32>;

oit_gpu::words! {
    /// When a pixel stops tracing: once every channel of its transmittance is at most this.
    pub enum Epsilon {
        /// Only when nothing behind can show (transmittance 0): exact.
        Zero = "0",
        E4 = "1e-4",
        E3 = "1e-3",
        E2 = "1e-2",
    }
}

impl Epsilon {
    pub fn value(self) -> f32 {
        match self {
            Epsilon::Zero => 0.0,
            Epsilon::E4 => 1e-4,
            Epsilon::E3 => 1e-3,
            Epsilon::E2 => 1e-2,
        }
    }
}

/// A valid `ray-query` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Config {
    pub k: K,
    pub epsilon: Epsilon,
}

impl Config {
    /// K = 8 hits per trace, traced until nothing is left.
    pub const DEFAULT: Config = Config {
        k: Self::K.default,
        epsilon: Self::EPSILON.default,
    };

    pub const K: Param<K> = Param::new(
        "k",
        K::of(8),
        "candidate hits kept per trace (a private array per pixel); a pixel with L layers traces ⌊L/K⌋ + 1 times",
    );
    pub const EPSILON: Param<Epsilon> = Param::new(
        "epsilon",
        Epsilon::Zero,
        "stop tracing once every channel of the transmittance is at most this; 0 traces until no hit is left (exact)",
    );

    pub fn params() -> Vec<ParamInfo> {
        vec![Self::K.info(), Self::EPSILON.info()]
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of(RayQuery::NAME)
            .with(&Self::K, self.k)
            .with(&Self::EPSILON, self.epsilon)
    }

    /// Refuses a spec that is not `ray-query` with every parameter valid.
    pub fn from_spec(spec: &TechniqueSpec) -> Result<Config, SpecError> {
        spec.expect_name(RayQuery::NAME)?;
        Ok(Config {
            k: Self::K.read(spec)?,
            epsilon: Self::EPSILON.read(spec)?,
        })
    }
}

/// Words of the pass's `RayParams` (shaders/ray_query.wgsl): the inverse view-projection, the
/// near and far window depths, the resolution, reverse-Z and the triangle count.
pub fn params_words(scene: &Scene, resolution: Resolution, triangles: u32) -> [u32; 24] {
    let camera = &scene.camera;
    let inverse = camera.view_proj.as_dmat4().inverse().as_mat4();
    let (near, far) = if camera.reverse_z {
        (1.0f32, 0.0f32)
    } else {
        (0.0, 1.0)
    };
    let mut w = [0u32; 24];
    for (o, v) in w.iter_mut().zip(inverse.to_cols_array()) {
        *o = v.to_bits();
    }
    w[16] = near.to_bits();
    w[17] = far.to_bits();
    w[18] = (resolution.width as f32).to_bits();
    w[19] = (resolution.height as f32).to_bits();
    w[20] = u32::from(camera.reverse_z);
    w[21] = triangles;
    w
}

/// The scene's transparent triangles as an acceleration structure, with what the pass reads of
/// each (first vertex, rank, draw).
#[derive(Debug)]
struct Accel {
    scene_id: u64,
    triangle_count: u32,
    /// `None` without transparent triangles (nothing to trace).
    structures: Option<(wgpu::Blas, wgpu::Tlas)>,
    triangles: wgpu::Buffer,
    ledger: MemoryLedger,
    /// Wall time of the build's submission, waited for (milliseconds).
    build_ms: f64,
}

#[derive(Debug)]
struct PixelResources {
    key: (wgpu::TextureFormat, Resolution, u64),
    copy: wgpu::Texture,
    pipeline: wgpu::RenderPipeline,
    scene_group: wgpu::BindGroup,
    group: wgpu::BindGroup,
    ledger: MemoryLedger,
}

/// Ray-traced transparency; see the crate documentation.
#[derive(Debug)]
pub struct RayQuery {
    config: Config,
    accel: Option<Accel>,
    pixel: Option<PixelResources>,
}

impl RayQuery {
    pub const NAME: &'static str = "ray-query";

    pub fn new(config: Config) -> Self {
        RayQuery {
            config,
            accel: None,
            pixel: None,
        }
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Self, SpecError> {
        Ok(Self::new(Config::from_spec(spec)?))
    }

    pub fn config(&self) -> Config {
        self.config
    }

    /// Milliseconds the last acceleration-structure build took (submitted alone and waited
    /// for; not part of the frame's pass timings), or `None` before the first frame.
    pub fn build_ms(&self) -> Option<f64> {
        self.accel.as_ref().map(|a| a.build_ms)
    }

    /// Builds the acceleration structures of `scene` (once per uploaded scene).
    fn accel(&mut self, ctx: &Context, scene: &GpuScene) -> Result<(), GpuError> {
        if self.accel.as_ref().is_some_and(|a| a.scene_id == scene.id) {
            return Ok(());
        }
        let s = &scene.scene;
        let device = &ctx.device;
        // Ranks as the reference counts them: triangles in (draw id, triangle index) order.
        let mut by_id: Vec<usize> = (0..s.draws.len()).collect();
        by_id.sort_by_key(|&i| s.draws[i].id);
        let mut first_rank = vec![0u32; s.draws.len()];
        let mut total = 0u32;
        for &i in &by_id {
            first_rank[i] = total;
            total += s.draws[i].triangle_count();
        }
        let mut positions: Vec<f32> = Vec::new();
        let mut triangles: Vec<u32> = Vec::new();
        for i in scene.transparent_draws() {
            let d = &s.draws[i];
            for t in 0..d.triangle_count() {
                let first = d.first_vertex + 3 * t;
                for k in 0..3 {
                    positions.extend(s.vertices[(first + k) as usize].position);
                }
                triangles.extend([first, first_rank[i] + t, i as u32, 0]);
            }
        }
        let triangle_count = (triangles.len() / 4) as u32;
        let mut ledger = MemoryLedger::new();
        if triangles.is_empty() {
            triangles.extend([0; 4]);
        }
        let triangles_buffer = ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("ray-query triangles"),
                size: triangles.len() as u64 * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        ctx.queue
            .write_buffer(&triangles_buffer, 0, bytemuck::cast_slice(&triangles));
        let mut build_ms = 0.0;
        let structures = if triangle_count == 0 {
            None
        } else {
            let vertex_buffer = ledger.create_buffer(
                device,
                &wgpu::BufferDescriptor {
                    label: Some("ray-query positions"),
                    size: positions.len() as u64 * 4,
                    usage: wgpu::BufferUsages::BLAS_INPUT | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                },
            );
            ctx.queue
                .write_buffer(&vertex_buffer, 0, bytemuck::cast_slice(&positions));
            let size = wgpu::BlasTriangleGeometrySizeDescriptor {
                vertex_format: wgpu::VertexFormat::Float32x3,
                vertex_count: 3 * triangle_count,
                index_format: None,
                index_count: None,
                flags: wgpu::AccelerationStructureGeometryFlags::NO_DUPLICATE_ANY_HIT_INVOCATION,
            };
            let blas = device.create_blas(
                &wgpu::CreateBlasDescriptor {
                    label: Some("ray-query transparent triangles"),
                    flags: wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE,
                    update_mode: wgpu::AccelerationStructureUpdateMode::Build,
                },
                wgpu::BlasGeometrySizeDescriptors::Triangles {
                    descriptors: vec![size.clone()],
                },
            );
            let mut tlas = device.create_tlas(&wgpu::CreateTlasDescriptor {
                label: Some("ray-query scene"),
                max_instances: 1,
                flags: wgpu::AccelerationStructureFlags::PREFER_FAST_TRACE,
                update_mode: wgpu::AccelerationStructureUpdateMode::Build,
            });
            // Positions are in world space already: the identity, row-major 3×4.
            let identity = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
            tlas[0] = Some(wgpu::TlasInstance::new(&blas, identity, 0, 0xff));
            let started = std::time::Instant::now();
            let mut encoder = device.create_command_encoder(&Default::default());
            encoder.build_acceleration_structures(
                std::iter::once(&wgpu::BlasBuildEntry {
                    blas: &blas,
                    geometry: wgpu::BlasGeometries::TriangleGeometries(vec![
                        wgpu::BlasTriangleGeometry {
                            size: &size,
                            vertex_buffer: &vertex_buffer,
                            first_vertex: 0,
                            vertex_stride: 12,
                            index_buffer: None,
                            first_index: None,
                            transform_buffer: None,
                            transform_buffer_offset: None,
                        },
                    ]),
                }),
                std::iter::once(&tlas),
            );
            ctx.queue.submit([encoder.finish()]);
            ctx.wait()?;
            build_ms = started.elapsed().as_secs_f64() * 1e3;
            Some((blas, tlas))
        };
        self.pixel = None;
        self.accel = Some(Accel {
            scene_id: scene.id,
            triangle_count,
            structures,
            triangles: triangles_buffer,
            ledger,
            build_ms,
        });
        Ok(())
    }

    fn pixel_resources(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        targets: &Targets,
    ) -> Result<(), GpuError> {
        let key = (targets.color_format, targets.resolution, scene.id);
        if self.pixel.as_ref().is_some_and(|p| p.key == key) {
            return Ok(());
        }
        let accel = self
            .accel
            .as_ref()
            .expect("acceleration structures built first");
        let Some((_, tlas)) = &accel.structures else {
            self.pixel = None;
            return Ok(());
        };
        let device = &ctx.device;
        let mut ledger = MemoryLedger::new();
        let copy = ledger.create_texture_2d(
            device,
            "ray-query opaque colour copy",
            targets.resolution,
            targets.color_format,
            wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::TEXTURE_BINDING,
            1,
        );
        let words = params_words(&scene.scene, targets.resolution, accel.triangle_count);
        let params = ledger.create_buffer(
            device,
            &wgpu::BufferDescriptor {
                label: Some("ray-query params"),
                size: std::mem::size_of_val(&words) as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            },
        );
        ctx.queue
            .write_buffer(&params, 0, bytemuck::cast_slice(&words));
        let fs = wgpu::ShaderStages::FRAGMENT;
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ray-query"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: fs,
                    ty: wgpu::BindingType::AccelerationStructure {
                        vertex_return: false,
                    },
                    count: None,
                },
                bind::uniform(1, fs),
                bind::storage(2, fs, true),
                bind::storage(3, fs, true),
                bind::float_texture(4, fs),
                bind::texture(5, fs, wgpu::TextureSampleType::Depth),
            ],
        });
        let copy_view = copy.create_view(&Default::default());
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("ray-query"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: tlas.as_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: accel.triangles.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: scene.vertices.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&copy_view),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(&targets.depth_view),
                },
            ],
        });
        // Group 0 holds the scene's own buffers, as common.wgsl declares them, visible to the
        // fragment stage (the shared scene layout gives the material table to vertices only):
        // the pass runs the vertex stage's `scene_vertex` per hit.
        let scene_layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ray-query scene"),
            entries: &[
                bind::uniform(0, fs),
                bind::storage(1, fs, true),
                bind::storage(2, fs, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 4,
                    visibility: fs,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Uint,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
            ],
        });
        let mut scene_entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: scene.camera.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: scene.materials.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: scene.texel_decode.as_entire_binding(),
            },
        ];
        let pages = scene.texel_pages.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        scene_entries.push(wgpu::BindGroupEntry {
            binding: 4,
            resource: wgpu::BindingResource::TextureView(&pages),
        });
        let scene_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("ray-query scene"),
            layout: &scene_layout,
            entries: &scene_entries,
        });
        let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ray-query"),
            bind_group_layouts: &[Some(&scene_layout), Some(&layout)],
            immediate_size: 0,
        });
        let module = ctx.shader_with("ray_query.wgsl", crate::SHADER, &[crate::SHADERS])?;
        let s = &scene.scene;
        let textured = s
            .draws
            .iter()
            .any(|d| s.material_of(d).mode.is_transparent() && s.material_of(d).is_textured());
        let lit = s
            .draws
            .iter()
            .any(|d| s.material_of(d).mode.is_transparent() && s.material_of(d).is_lit());
        let constants = [
            ("RAY_K", f64::from(self.config.k.get())),
            ("MIN_TRANSMITTANCE", f64::from(self.config.epsilon.value())),
            ("TEXTURED", f64::from(u8::from(textured))),
            ("LIT", f64::from(u8::from(lit))),
        ];
        let pipeline = fullscreen_pipeline(
            ctx,
            &FullscreenDesc {
                label: "ray-query trace",
                layout: &pipeline_layout,
                module: &module,
                fragment_entry: "fs_trace",
                targets: &[Some(wgpu::ColorTargetState {
                    format: targets.color_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: None,
                multisample: Default::default(),
                constants: &constants,
            },
        );
        self.pixel = Some(PixelResources {
            key,
            copy,
            pipeline,
            scene_group,
            group,
            ledger,
        });
        Ok(())
    }
}

impl Technique for RayQuery {
    fn spec(&self) -> TechniqueSpec {
        self.config.spec()
    }

    fn check(&self, caps: &Caps) -> Result<(), Unsupported> {
        caps.require_scene_materials()?;
        if !caps.ray_query {
            return Err(Unsupported::new(
                "the adapter has no ray queries (wgpu's EXPERIMENTAL_RAY_QUERY: Vulkan with VK_KHR_ray_query; lavapipe has them from Mesa 24.1, `.ci/lavapipe-ray-query` unpacks Mesa 25.0.7's)",
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
        self.accel(ctx, scene)?;
        self.pixel_resources(ctx, scene, targets)?;
        let Some(p) = self.pixel.as_ref() else {
            // No transparent triangle: the opaque pass is the image.
            return Ok(RenderStats::default());
        };
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_texture(
            targets.color.as_image_copy(),
            p.copy.as_image_copy(),
            p.copy.size(),
        );
        {
            let ts = timer.pass("trace");
            let mut pass = pass::begin(
                &mut encoder,
                "ray-query trace",
                &[pass::color(&targets.color_view, wgpu::LoadOp::Load)],
                None,
                &ts,
            );
            pass.set_pipeline(&p.pipeline);
            pass.set_bind_group(0, &p.scene_group, &[]);
            pass.set_bind_group(1, &p.group, &[]);
            pass.draw(0..3, 0..1);
        }
        timer.submit(ctx, encoder)?;
        Ok(RenderStats {
            setup_ms: self.build_ms(),
            ..Default::default()
        })
    }

    fn memory_bytes(&self) -> u64 {
        self.accel.as_ref().map_or(0, |a| a.ledger.total())
            + self.pixel.as_ref().map_or(0, |p| p.ledger.total())
    }

    fn transmission(&self, _caps: &Caps) -> Support {
        Support::Exact
    }

    fn operator(&self, _operator: BlendOperator, _caps: &Caps) -> Support {
        // Every hit's (P, t) composited in order, as the reference does.
        Support::Exact
    }

    fn predict(
        &self,
        scene: &Scene,
        lists: &oit_gpu::predict::PixelLists,
        _caps: &Caps,
    ) -> Prediction {
        if self.config.epsilon != Epsilon::Zero {
            let eps = f64::from(self.config.epsilon.value());
            let error = oit_gpu::predict::model_error(lists, |px| {
                let mut c = [0.0f64; 3];
                let mut t = [1.0f64; 3];
                for l in px.layers {
                    for i in 0..3 {
                        c[i] += t[i] * f64::from(l.premultiplied[i]);
                        t[i] *= f64::from(l.transmittance[i]);
                    }
                    if t.iter().all(|&x| x <= eps) {
                        break;
                    }
                }
                [0, 1, 2].map(|i| c[i] + t[i] * px.behind[i])
            });
            return Prediction::from_model(
                &error,
                "tracing stops only where the transmittance is already below ε",
                "tracing stops at transmittance ε and drops what is behind",
            );
        }
        let exact = format!(
            "every pixel's layers (at most {}) are composited in order, {} per trace",
            lists.max_layers(),
            self.config.k.get()
        );
        let band = crate::coverage::coverage_band(scene)
            .iter()
            .filter(|b| **b)
            .count();
        if band == 0 {
            return Prediction::exact(exact);
        }
        Prediction {
            verdict: oit_gpu::Verdict::Borderline,
            because: format!(
                "{exact}, but on {band} px a transparent edge passes within 1/128 px of the pixel centre, where a ray and the snapping rasterizer the reference mirrors may disagree on coverage"
            ),
            modelled_error: Some(0.0),
        }
    }

    fn work(&self, _caps: &Caps, target: wgpu::TextureFormat) -> oit_gpu::Work {
        use oit_gpu::work::{DEPTH_BYTES, PassDraws, PassWork, Work, texel_bytes};
        let texel = texel_bytes(target);
        // One full-screen pass: the opaque depth and the copy read, the colour written; the
        // traversal's reads are the driver's and not counted.
        Work::new(vec![
            PassWork::new("trace", PassDraws::FullScreen).bytes(DEPTH_BYTES + texel, texel),
        ])
    }
}
