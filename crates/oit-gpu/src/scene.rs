//! The scene on the GPU and the one pipeline builder every scene pass uses.

use crate::bind;
use crate::context::Context;
use crate::error::GpuError;
use oit_scene::{AlphaMode, Material, Scene};
use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use wgpu::util::DeviceExt;

/// Bytes per GPU vertex: position f32×3, material index u32, colour f32×4, uv f32×2.
pub const VERTEX_STRIDE: u64 = 40;
/// Bytes per entry of the material table (matches `struct Material` in shaders/common.wgsl).
pub const MATERIAL_STRIDE: usize = 80;
/// Bytes per texel of the texture store (RGBA f32).
pub const TEXEL_BYTES: u64 = 16;

const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 4] = wgpu::vertex_attr_array![
    0 => Float32x3,
    1 => Uint32,
    2 => Float32x4,
    3 => Float32x2,
];

/// The vertex buffer layout of [`GpuScene::vertices`].
pub fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: VERTEX_STRIDE,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &VERTEX_ATTRIBUTES,
    }
}

pub(crate) fn create_scene_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("scene"),
        entries: &[
            // The camera's view-projection matrix, one material at least. The vertex stage reads
            // the material table and passes the draw's material on as flat varyings.
            bind::min_size(bind::uniform(0, wgpu::ShaderStages::VERTEX_FRAGMENT), 64),
            bind::min_size(
                bind::storage(1, wgpu::ShaderStages::VERTEX, true),
                MATERIAL_STRIDE as u64,
            ),
            // Every texture's texels, read by `shade()` (shaders/common.wgsl).
            bind::min_size(
                bind::storage(2, wgpu::ShaderStages::FRAGMENT, true),
                TEXEL_BYTES,
            ),
        ],
    })
}

fn mode_code(mode: AlphaMode) -> u32 {
    match mode {
        AlphaMode::Opaque => 0,
        AlphaMode::Mask => 1,
        AlphaMode::Blend => 2,
        AlphaMode::MaskBlend => 3,
    }
}

/// Where each texture starts in the texel store (in texels), in `Scene::textures` order.
fn texel_offsets(scene: &Scene) -> Vec<u32> {
    let mut offsets = Vec::with_capacity(scene.textures.len());
    let mut next = 0u64;
    for t in &scene.textures {
        offsets.push(next as u32);
        next += t.texels.len() as u64;
    }
    offsets
}

/// One material as the shader reads it (80 bytes, little-endian f32/u32 words).
fn material_words(m: &Material, scene: &Scene, offsets: &[u32]) -> [u32; 20] {
    // (first texel, width | height << 16, wrap bits) of a texture slot; zeros for none.
    let slot = |t: Option<u32>| match t {
        Some(t) => {
            let tex = &scene.textures[t as usize];
            (
                offsets[t as usize],
                tex.width | tex.height << 16,
                tex.wrap_u.code() | tex.wrap_v.code() << 2,
            )
        }
        None => (0, 0, 0),
    };
    let (base_first, base_size, base_wrap) = slot(m.base_texture);
    let (emissive_first, emissive_size, emissive_wrap) = slot(m.emissive_texture);
    [
        m.base_color[0].to_bits(),
        m.base_color[1].to_bits(),
        m.base_color[2].to_bits(),
        m.alpha.to_bits(),
        m.emissive[0].to_bits(),
        m.emissive[1].to_bits(),
        m.emissive[2].to_bits(),
        mode_code(m.mode),
        m.cutoff.to_bits(),
        u32::from(m.premultiplied),
        m.intensity.to_bits(),
        u32::from(m.double_sided),
        base_first,
        base_size,
        emissive_first,
        emissive_size,
        base_wrap | emissive_wrap << 4,
        m.transmission.to_bits(),
        0,
        0,
    ]
}

/// Checks what the loader guarantees but a hand-built scene may break: texture indices in
/// range, texel arrays matching their sizes, the texel store addressable with u32 offsets.
fn check_textures(scene: &Scene) -> Result<u64, GpuError> {
    let mut total = 0u64;
    for (i, t) in scene.textures.iter().enumerate() {
        if !t.is_consistent() {
            return Err(GpuError::InvalidScene(format!(
                "texture {i} ({}): {}x{} with {} texels; allowed: 1..={} per side, width·height texels",
                t.name,
                t.width,
                t.height,
                t.texels.len(),
                oit_scene::MAX_TEXTURE_DIMENSION
            )));
        }
        total += t.texels.len() as u64;
    }
    for (i, m) in scene.materials.iter().enumerate() {
        for t in [m.base_texture, m.emissive_texture].into_iter().flatten() {
            if t as usize >= scene.textures.len() {
                return Err(GpuError::InvalidScene(format!(
                    "material {i}: texture {t} does not exist (the scene has {})",
                    scene.textures.len()
                )));
            }
        }
    }
    if total > u64::from(u32::MAX) {
        return Err(GpuError::InvalidScene(format!(
            "{total} texels in all; allowed: at most {} (u32 texel offsets)",
            u32::MAX
        )));
    }
    Ok(total)
}

/// GPU bytes of a scene once uploaded, shared by every technique that draws it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SceneBytes {
    pub vertices: u64,
    pub materials: u64,
    /// The texel store (RGBA f32 per texel).
    pub textures: u64,
}

impl SceneBytes {
    /// What [`GpuScene::upload`] allocates for `scene` (dummy entries of empty tables included).
    pub fn of(scene: &Scene) -> SceneBytes {
        let texels: u64 = scene.textures.iter().map(|t| t.texels.len() as u64).sum();
        SceneBytes {
            vertices: scene.vertices.len().max(1) as u64 * VERTEX_STRIDE,
            materials: scene.materials.len().max(1) as u64 * MATERIAL_STRIDE as u64,
            textures: texels.max(1) * TEXEL_BYTES,
        }
    }

    pub fn total(&self) -> u64 {
        self.vertices + self.materials + self.textures
    }
}

static NEXT_SCENE_ID: AtomicU64 = AtomicU64::new(1);

/// A [`Scene`] uploaded once: all vertices in draw-list storage order, the material table and
/// the camera. Techniques draw ranges of it; nothing here changes after upload.
#[derive(Debug)]
pub struct GpuScene {
    /// The scene as uploaded (draw order, ids, materials, camera).
    pub scene: Scene,
    /// Unique per upload, so techniques can cache per-scene data (sort keys, index buffers).
    pub id: u64,
    pub vertices: wgpu::Buffer,
    pub camera: wgpu::Buffer,
    pub materials: wgpu::Buffer,
    /// Every texture's texels (see shaders/common.wgsl `texels`).
    pub texels: wgpu::Buffer,
    /// Group 0 of every scene pipeline.
    pub bind_group: wgpu::BindGroup,
    opaque: Mutex<HashMap<(wgpu::TextureFormat, bool), ScenePipelines>>,
}

impl GpuScene {
    pub fn upload(ctx: &Context, scene: &Scene) -> Result<GpuScene, GpuError> {
        let mut words: Vec<u32> = Vec::with_capacity(scene.vertices.len() * 8 + 8);
        // Vertices are stored in `Scene::vertices` order; a draw's range is its own.
        let mut material_of_vertex = vec![0u32; scene.vertices.len()];
        for d in &scene.draws {
            for m in &mut material_of_vertex[d.vertex_range()] {
                *m = d.material;
            }
        }
        for (v, m) in scene.vertices.iter().zip(&material_of_vertex) {
            words.extend(v.position.map(f32::to_bits));
            words.push(*m);
            words.extend(v.color.map(f32::to_bits));
            words.extend(v.uv.map(f32::to_bits));
        }
        // wgpu rejects zero-sized vertex bindings; an empty scene still gets one dummy vertex.
        if words.is_empty() {
            words.resize(VERTEX_STRIDE as usize / 4, 0);
        }
        let vertex_bytes = words.len() as u64 * 4;
        let limit = ctx.caps.max_buffer_size;
        if vertex_bytes > limit {
            return Err(GpuError::TooLarge {
                what: format!("the vertex buffer of scene {:?}", scene.name),
                needed: vertex_bytes,
                limit,
            });
        }
        let device = &ctx.device;
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scene vertices"),
            contents: bytemuck::cast_slice(&words),
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
        });
        let camera = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: bytemuck::cast_slice(&scene.camera.view_proj.to_cols_array()),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let texel_count = check_textures(scene)?;
        let texel_bytes = texel_count.max(1) * TEXEL_BYTES;
        let binding_limit = ctx.caps.max_storage_buffer_binding_size.min(limit);
        if texel_bytes > binding_limit {
            return Err(GpuError::TooLarge {
                what: format!("the textures of scene {:?}", scene.name),
                needed: texel_bytes,
                limit: binding_limit,
            });
        }
        let offsets = texel_offsets(scene);
        let mut mat_words: Vec<u32> = scene
            .materials
            .iter()
            .flat_map(|m| material_words(m, scene, &offsets))
            .collect();
        if mat_words.is_empty() {
            mat_words.resize(MATERIAL_STRIDE / 4, 0);
        }
        let materials = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("materials"),
            contents: bytemuck::cast_slice(&mat_words),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let mut texel_words: Vec<u32> = Vec::with_capacity(texel_count as usize * 4);
        for t in &scene.textures {
            texel_words.extend(t.texels.iter().flatten().map(|c| c.to_bits()));
        }
        if texel_words.is_empty() {
            texel_words.resize(4, 0);
        }
        let texels = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("texels"),
            contents: bytemuck::cast_slice(&texel_words),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene"),
            layout: ctx.scene_layout(),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: camera.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: materials.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: texels.as_entire_binding(),
                },
            ],
        });
        Ok(GpuScene {
            scene: scene.clone(),
            id: NEXT_SCENE_ID.fetch_add(1, Ordering::Relaxed),
            vertices,
            camera,
            materials,
            texels,
            bind_group,
            opaque: Mutex::new(HashMap::new()),
        })
    }

    /// Depth test for "strictly nearer": LESS, or GREATER with reverse-Z.
    pub fn depth_nearer(&self) -> wgpu::CompareFunction {
        if self.scene.camera.reverse_z {
            wgpu::CompareFunction::Greater
        } else {
            wgpu::CompareFunction::Less
        }
    }

    /// Sets group 0 and vertex buffer 0 on `pass`.
    pub fn bind(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
    }

    /// Draws `self.scene.draws[index]` with the pipeline its material needs.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, pipelines: &ScenePipelines, index: usize) {
        let d = &self.scene.draws[index];
        if d.vertex_count == 0 {
            return;
        }
        pass.set_pipeline(pipelines.for_material(self.scene.material_of(d)));
        pass.draw(d.first_vertex..d.first_vertex + d.vertex_count, 0..1);
    }

    /// Indices into `scene.draws` of transparent draws, in draw order.
    pub fn transparent_draws(&self) -> Vec<usize> {
        self.draws_where(|m| m.mode.is_transparent())
    }

    /// Indices into `scene.draws` of opaque and mask draws, in draw order.
    pub fn opaque_draws(&self) -> Vec<usize> {
        self.draws_where(|m| !m.mode.is_transparent())
    }

    fn draws_where(&self, keep: impl Fn(&Material) -> bool) -> Vec<usize> {
        let s = &self.scene;
        (0..s.draws.len())
            .filter(|&i| keep(s.material_of(&s.draws[i])))
            .collect()
    }

    /// The shared opaque pass's pipelines for a colour format (built once, cached).
    pub(crate) fn opaque_pipelines(
        &self,
        ctx: &Context,
        format: wgpu::TextureFormat,
    ) -> Result<ScenePipelines, GpuError> {
        let key = (format, self.scene.camera.reverse_z);
        let mut cache = self.opaque.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = cache.get(&key) {
            return Ok(p.clone());
        }
        let module = ctx.shader("opaque.wgsl", crate::shaders::OPAQUE)?;
        let p = ScenePipelines::new(
            ctx,
            &ScenePipelineDesc {
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
                depth: Some(depth_test(self.depth_nearer(), true)),
                ..ScenePipelineDesc::new("opaque", &module, "fs_opaque")
            },
        );
        cache.insert(key, p.clone());
        Ok(p)
    }
}

/// Which faces fixed function culls. The shader additionally discards back faces of
/// single-sided materials, so `Fixed(None)` still obeys the material's culling rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CullRule {
    /// Back faces culled unless the material is double-sided.
    ByMaterial,
    /// The same for every draw, e.g. `Fixed(Some(Face::Front))` draws only back faces.
    Fixed(Option<wgpu::Face>),
}

/// Everything that differs between scene pipelines (passes that draw [`GpuScene::vertices`]
/// with [`vertex_layout`]). Start from [`ScenePipelineDesc::new`] and set what the pass needs.
#[derive(Debug, Clone)]
pub struct ScenePipelineDesc<'a> {
    pub label: &'a str,
    /// A module built from a pass file that includes common.wgsl.
    pub module: &'a wgpu::ShaderModule,
    /// `vs_main` of common.wgsl, or a pass's own vertex stage over the same vertex layout.
    pub vertex_entry: &'a str,
    pub fragment_entry: &'a str,
    /// Colour targets by location; empty for depth-only passes.
    pub targets: &'a [Option<wgpu::ColorTargetState>],
    /// `None` for passes without a depth attachment; [`depth_test`] for the usual one.
    pub depth: Option<wgpu::DepthStencilState>,
    /// Pipeline override constants of the fragment stage (the vertex stage keeps the
    /// overrides' defaults).
    pub constants: &'a [(&'a str, f64)],
    /// Must match the attachments' sample count (and may enable alpha-to-coverage).
    pub multisample: wgpu::MultisampleState,
    pub cull: CullRule,
}

impl<'a> ScenePipelineDesc<'a> {
    /// `vs_main`, no colour targets, no depth attachment, no constants, single sampled, culled
    /// by material.
    pub fn new(label: &'a str, module: &'a wgpu::ShaderModule, fragment_entry: &'a str) -> Self {
        ScenePipelineDesc {
            label,
            module,
            vertex_entry: "vs_main",
            fragment_entry,
            targets: &[],
            depth: None,
            constants: &[],
            multisample: wgpu::MultisampleState::default(),
            cull: CullRule::ByMaterial,
        }
    }
}

/// A test against the `Depth32Float` depth attachment every scene pass uses: `compare`, with
/// or without writing depth.
pub fn depth_test(compare: wgpu::CompareFunction, write: bool) -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: wgpu::TextureFormat::Depth32Float,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// A pipeline pair: one for single-sided and one for double-sided materials, each in two
/// variants specialised by the `TEXTURED` override of shaders/common.wgsl. CPU rasterizers run
/// a branch's code masked per lane whatever the condition, so untextured materials get
/// pipelines whose `shade()` has no texture code at all (eight texel fetches per fragment made
/// `unsorted` 11× slower on lavapipe, even behind a uniform branch).
#[derive(Debug, Clone)]
pub struct ScenePipelines {
    pub single_sided: wgpu::RenderPipeline,
    pub double_sided: wgpu::RenderPipeline,
    /// The same two for materials that read a texture.
    pub textured_single_sided: wgpu::RenderPipeline,
    pub textured_double_sided: wgpu::RenderPipeline,
}

impl ScenePipelines {
    /// The pair with a layout of group 0 ([`Context::scene_layout`]) alone.
    pub fn new(ctx: &Context, desc: &ScenePipelineDesc<'_>) -> Self {
        let layout = ctx
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(desc.label),
                bind_group_layouts: &[Some(ctx.scene_layout())],
                immediate_size: 0,
            });
        Self::with_layout(ctx, desc, &layout)
    }

    /// The pair with the caller's layout (techniques with extra bind groups), whose group 0
    /// is [`Context::scene_layout`].
    pub fn with_layout(
        ctx: &Context,
        desc: &ScenePipelineDesc<'_>,
        layout: &wgpu::PipelineLayout,
    ) -> Self {
        let make = |cull: Option<wgpu::Face>, textured: bool| {
            let mut constants = desc.constants.to_vec();
            constants.push(("TEXTURED", if textured { 1.0 } else { 0.0 }));
            let desc = ScenePipelineDesc {
                constants: &constants,
                ..desc.clone()
            };
            scene_pipeline(ctx, &desc, layout, cull)
        };
        let pair = |textured: bool| match desc.cull {
            CullRule::ByMaterial => (make(Some(wgpu::Face::Back), textured), make(None, textured)),
            CullRule::Fixed(c) => {
                let p = make(c, textured);
                (p.clone(), p)
            }
        };
        let (single_sided, double_sided) = pair(false);
        let (textured_single_sided, textured_double_sided) = pair(true);
        ScenePipelines {
            single_sided,
            double_sided,
            textured_single_sided,
            textured_double_sided,
        }
    }

    pub fn for_material(&self, m: &Material) -> &wgpu::RenderPipeline {
        match (m.double_sided, m.is_textured()) {
            (true, false) => &self.double_sided,
            (false, false) => &self.single_sided,
            (true, true) => &self.textured_double_sided,
            (false, true) => &self.textured_single_sided,
        }
    }

    /// The double-sided pipeline for one draw call that mixes materials: textured when any
    /// material of `scene` reads a texture.
    pub fn double_sided_for(&self, scene: &oit_scene::Scene) -> &wgpu::RenderPipeline {
        if scene.materials.iter().any(Material::is_textured) {
            &self.textured_double_sided
        } else {
            &self.double_sided
        }
    }
}

/// Builds one scene pipeline with an explicit layout and face culling (`desc.cull` is not
/// consulted; [`ScenePipelines`] applies it).
pub fn scene_pipeline(
    ctx: &Context,
    desc: &ScenePipelineDesc<'_>,
    layout: &wgpu::PipelineLayout,
    cull: Option<wgpu::Face>,
) -> wgpu::RenderPipeline {
    ctx.device
        .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(desc.label),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module: desc.module,
                entry_point: Some(desc.vertex_entry),
                compilation_options: Default::default(),
                buffers: &[Some(vertex_layout())],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: cull,
                ..Default::default()
            },
            depth_stencil: desc.depth.clone(),
            multisample: desc.multisample,
            fragment: Some(wgpu::FragmentState {
                module: desc.module,
                entry_point: Some(desc.fragment_entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: desc.constants,
                    ..Default::default()
                },
                targets: desc.targets,
            }),
            multiview_mask: None,
            cache: None,
        })
}
