//! The scene on the GPU and the one pipeline builder every scene pass uses.

use crate::bind;
use crate::context::Context;
use crate::error::GpuError;
use oit_scene::{AlphaMode, Material, Scene};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use wgpu::util::DeviceExt;

/// Bytes per GPU vertex: position f32×3, material index u32, colour f32×4, uv f32×2, normal
/// f32×3.
pub const VERTEX_STRIDE: u64 = 52;
/// Bytes per entry of [`GpuScene::indices`] (u32).
pub const INDEX_STRIDE: u64 = 4;
/// Bytes per entry of the material table (matches `struct Material` in shaders/common.wgsl).
pub const MATERIAL_STRIDE: usize = 96;
/// Bytes of the lights (`struct Lights` in shaders/lighting.wgsl): eye, count, ambient and
/// [`oit_scene::MAX_LIGHTS`] lights of 64 bytes, after the matrix in the camera uniform.
pub const LIGHTS_BYTES: u64 = 32 + 64 * oit_scene::MAX_LIGHTS as u64;
/// Bytes of the camera uniform (`struct Camera` in shaders/common.wgsl): the view-projection
/// matrix and the lights.
pub const CAMERA_BYTES: u64 = 64 + LIGHTS_BYTES;
/// Distance between two materials in the per-draw uniform buffer
/// ([`GpuScene::draw_materials`]): 256, the largest dynamic-offset alignment WebGPU allows, so
/// it is valid on every adapter.
pub const MATERIAL_UNIFORM_STRIDE: u64 = 256;

/// Largest mean projected triangle area, in pixels at the scene's resolution, for which a draw
/// reads its material per draw ([`GpuScene::reads_material_per_draw`]). Measured on lavapipe
/// (`unsorted`, 256²): the per-vertex form's five flat varyings cost about 0.75 µs of setup per
/// triangle, the uniform about 1.8 ns per fragment, so they break even near 400 fragments per
/// triangle. Both give the same image; only the time differs.
pub const PER_DRAW_MATERIAL_MAX_AREA: f64 = 256.0;

const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 5] = wgpu::vertex_attr_array![
    0 => Float32x3,
    1 => Uint32,
    2 => Float32x4,
    3 => Float32x2,
    4 => Float32x3,
];

/// The vertex buffer layout of [`GpuScene::vertices`].
pub fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: VERTEX_STRIDE,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &VERTEX_ATTRIBUTES,
    }
}

pub(crate) fn create_scene_layout(made: &crate::made::Made) -> wgpu::BindGroupLayout {
    made.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("scene"),
        entries: &[
            // The camera's view-projection matrix, one material at least. Pipelines for draw
            // calls that mix materials read the table per vertex and pass it on flat.
            bind::min_size(
                bind::uniform(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
                CAMERA_BYTES,
            ),
            bind::min_size(
                bind::storage(1, wgpu::ShaderStages::VERTEX, true),
                MATERIAL_STRIDE as u64,
            ),
            // The texel decode table, read by `shade()` (shaders/common.wgsl).
            bind::min_size(
                bind::storage(2, wgpu::ShaderStages::FRAGMENT, true),
                crate::texels::DECODE_TABLE_BYTES,
            ),
            // The draw's material, a uniform at its dynamic offset ([`GpuScene::use_draw`]).
            bind::dynamic_uniform(3, wgpu::ShaderStages::FRAGMENT, MATERIAL_STRIDE as u64),
            // Every texture's codes in pages (crate::texels).
            wgpu::BindGroupLayoutEntry {
                binding: 4,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Uint,
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            },
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
        next += t.codes().len() as u64;
    }
    offsets
}

/// The specular code of shaders/lighting.wgsl: 0 unlit, 1 faded, 2 kept.
fn specular_code(m: &Material) -> u32 {
    match m.reflectance.map(|r| r.specular) {
        None => 0,
        Some(oit_scene::Specular::Faded) => 1,
        Some(oit_scene::Specular::Kept) => 2,
    }
}

/// The lights uniform (`struct Lights` of shaders/lighting.wgsl): eye, count, ambient, then
/// every light, unused slots zero.
fn light_words(scene: &Scene) -> Result<Vec<u32>, GpuError> {
    let rig = &scene.lights;
    if rig.lights.len() > oit_scene::MAX_LIGHTS {
        return Err(GpuError::InvalidScene(format!(
            "scene {:?}: {} lights; allowed: at most {} (oit_scene::MAX_LIGHTS)",
            scene.name,
            rig.lights.len(),
            oit_scene::MAX_LIGHTS
        )));
    }
    let mut words = Vec::with_capacity(LIGHTS_BYTES as usize / 4);
    words.extend(scene.camera.eye.to_array().map(f32::to_bits));
    words.push(rig.lights.len() as u32);
    words.extend(rig.ambient.map(f32::to_bits));
    words.push(0);
    for l in &rig.lights {
        words.extend(l.position.map(f32::to_bits));
        words.push(l.kind.code());
        words.extend(l.direction.map(f32::to_bits));
        words.push(l.range.to_bits());
        words.extend(l.radiance.map(f32::to_bits));
        words.push(l.cone_scale.to_bits());
        words.extend([l.cone_offset.to_bits(), 0, 0, 0]);
    }
    words.resize(LIGHTS_BYTES as usize / 4, 0);
    Ok(words)
}

/// One material as the shader reads it (96 bytes, little-endian f32/u32 words).
fn material_words(m: &Material, scene: &Scene, offsets: &[u32]) -> [u32; 24] {
    // (first texel, width | height << 16, sampler bits) of a texture slot; zeros for none.
    let slot = |t: Option<u32>| match t {
        Some(t) => {
            let tex = &scene.textures[t as usize];
            let unorm = u32::from(tex.encoding() == oit_scene::Encoding::Unorm);
            (
                offsets[t as usize],
                tex.width() | tex.height() << 16,
                tex.sampler().code() | unorm << 9,
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
        base_wrap | emissive_wrap << 12,
        m.transmission.to_bits(),
        m.operator.code(),
        0,
        m.reflectance.map_or(0, |r| r.metallic.to_bits()),
        m.reflectance.map_or(0, |r| r.roughness.to_bits()),
        specular_code(m),
        0,
    ]
}

const _: () = assert!(
    MATERIAL_STRIDE == 24 * 4,
    "material_words fills one table entry"
);

/// Checks what the loader guarantees but a hand-built scene may break: texture indices in
/// range, the texel store addressable with u32 offsets (sizes and codes agree by
/// construction, see `oit_scene::Texture::new`).
fn check_textures(scene: &Scene) -> Result<u64, GpuError> {
    let mut total = 0u64;
    for t in &scene.textures {
        total += t.codes().len() as u64;
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
    /// The index buffer every scene draw goes through ([`GpuScene::indices`]).
    pub indices: u64,
    /// The material table and its per-draw uniform copy.
    pub materials: u64,
    /// The texel store (8-bit RGBA codes of every mip level, in pages: crate::texels) and its
    /// decode table.
    pub textures: u64,
}

impl SceneBytes {
    /// What [`GpuScene::upload`] allocates for `scene` (dummy entries of empty tables included).
    pub fn of(scene: &Scene) -> SceneBytes {
        let texels = crate::texels::texel_count(scene);
        SceneBytes {
            vertices: scene.vertices.len().max(1) as u64 * VERTEX_STRIDE,
            indices: scene.vertices.len().max(1) as u64 * INDEX_STRIDE,
            materials: scene.materials.len().max(1) as u64
                * (MATERIAL_STRIDE as u64 + MATERIAL_UNIFORM_STRIDE),
            textures: crate::texels::store_bytes(texels) + crate::texels::DECODE_TABLE_BYTES,
        }
    }

    pub fn total(&self) -> u64 {
        self.vertices + self.indices + self.materials + self.textures
    }
}

/// The vertex buffer's words ([`VERTEX_STRIDE`] bytes per vertex, [`vertex_layout`]), in
/// `Scene::vertices` order, so that a draw's range is its own.
pub fn vertex_words(scene: &Scene) -> Vec<u32> {
    let mut words: Vec<u32> =
        Vec::with_capacity(scene.vertices.len() * (VERTEX_STRIDE / 4) as usize);
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
        words.extend(v.normal.map(f32::to_bits));
    }
    words
}

/// The index buffer of a scene ([`GpuScene::indices`]) from its uploaded vertex words
/// ([`VERTEX_STRIDE`] bytes each): slot `i` names the first vertex of the same draw whose bits
/// equal vertex `i`'s. The triangles, their order and their vertices' bits stay those of
/// `Scene::vertices`; only a corner two triangles share is named once, so an indexed draw
/// shades it once.
pub fn shared_corner_indices(scene: &Scene, words: &[u32]) -> Vec<u32> {
    let per_vertex = (VERTEX_STRIDE / 4) as usize;
    let mut indices: Vec<u32> = (0..scene.vertices.len() as u32).collect();
    let mut first_of: HashMap<&[u32], u32> = HashMap::new();
    for d in &scene.draws {
        first_of.clear();
        for i in d.vertex_range() {
            let bits = &words[i * per_vertex..(i + 1) * per_vertex];
            indices[i] = *first_of.entry(bits).or_insert(i as u32);
        }
    }
    indices
}

static NEXT_SCENE_ID: AtomicU64 = AtomicU64::new(1);

/// Mean area of a draw's triangles projected to the scene's viewport, in pixels (whole
/// triangles, on screen or not); infinite when a triangle reaches behind the eye plane.
fn mean_triangle_pixels(scene: &Scene, d: &oit_scene::Draw) -> f64 {
    let triangles = d.vertex_count / 3;
    if triangles == 0 {
        return f64::INFINITY;
    }
    let view_proj = scene.camera.view_proj.as_dmat4();
    let (w, h) = (
        f64::from(scene.resolution.width),
        f64::from(scene.resolution.height),
    );
    let mut sum = 0.0;
    for t in 0..triangles {
        let first = (d.first_vertex + 3 * t) as usize;
        let mut ndc = [glam::DVec2::ZERO; 3];
        for (k, v) in scene.vertices[first..first + 3].iter().enumerate() {
            let p = view_proj * glam::Vec3::from(v.position).as_dvec3().extend(1.0);
            if p.w <= 1e-9 {
                return f64::INFINITY;
            }
            ndc[k] = p.truncate().truncate() / p.w;
        }
        let area = (ndc[1] - ndc[0]).perp_dot(ndc[2] - ndc[0]).abs() / 2.0;
        sum += area * w * h / 4.0;
    }
    sum / f64::from(triangles)
}

/// A [`Scene`] uploaded once: all vertices in draw-list storage order, the material table and
/// the camera. Techniques draw ranges of it; nothing here changes after upload.
#[derive(Debug)]
pub struct GpuScene {
    /// The scene as uploaded (draw order, ids, materials, camera).
    pub scene: Scene,
    /// Unique per upload, so techniques can cache per-scene data (sort keys, index buffers).
    pub id: u64,
    pub vertices: wgpu::Buffer,
    /// One u32 per vertex of `Scene::vertices` ([`shared_corner_indices`]): every scene draw is
    /// indexed ([`GpuScene::draw_range`]), index slot `i` standing for vertex `i`, so that a
    /// draw's range is the same in both. Measured on lavapipe (Mesa 22.3.6, 2026-12-07):
    /// unindexed, a draw whose chunk of vertices holds one clipped vertex goes through
    /// llvmpipe's clipping pipeline, which walks every vertex of the chunk at each of its
    /// flushes; on `particles` (24 000 triangles, billboards across the screen's edges) that
    /// walk was 21 % of the frame. Indexed draws come in smaller chunks (6 % with every index
    /// distinct, 3 % with shared corners) and shade a shared corner once.
    pub indices: wgpu::Buffer,
    pub camera: wgpu::Buffer,
    pub materials: wgpu::Buffer,
    /// The same materials [`MATERIAL_UNIFORM_STRIDE`] apart, bound per draw as a uniform at
    /// the draw's dynamic offset (shaders/common.wgsl `draw_material`).
    pub draw_materials: wgpu::Buffer,
    /// Every texture's codes in pages (see shaders/common.wgsl `texel_pages`, crate::texels).
    pub texel_pages: wgpu::Texture,
    /// The 512-entry decode table (shaders/common.wgsl `texel_decode`).
    pub texel_decode: wgpu::Buffer,
    /// Group 0 of every scene pipeline.
    pub bind_group: wgpu::BindGroup,
    /// Per draw: whether it reads its material per draw (small triangles), see
    /// [`GpuScene::reads_material_per_draw`].
    per_draw_material: Vec<bool>,
    /// Whether materials get the specialised pipelines, `OVER_ONLY` and `UNIT_FACTORS`
    /// ([`GpuScene::set_specialised`]).
    specialised: bool,
    /// The dynamic offset group 0 was last set with in the pass being recorded ([`GpuScene::bind`]
    /// sets it), so that [`GpuScene::use_draw`] sets it again only for a per-draw material that
    /// differs: lavapipe keeps a copy of the descriptor state per bind (about 23 KB), and 1000
    /// draws rebound in each of 1000 peeling passes took 23 GB.
    bound_offset: AtomicU32,
    opaque: Mutex<HashMap<(wgpu::TextureFormat, bool), ScenePipelines>>,
}

impl GpuScene {
    pub fn upload(ctx: &Context, scene: &Scene) -> Result<GpuScene, GpuError> {
        let mut words = vertex_words(scene);
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
        let mut index_words = shared_corner_indices(scene, &words);
        if index_words.is_empty() {
            index_words.push(0);
        }
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scene indices"),
            contents: bytemuck::cast_slice(&index_words),
            usage: wgpu::BufferUsages::INDEX,
        });
        // The matrix, then the lights (`struct Camera` of shaders/common.wgsl).
        let mut camera_words: Vec<u32> = (scene.camera.view_proj.to_cols_array())
            .map(f32::to_bits)
            .to_vec();
        camera_words.extend(light_words(scene)?);
        let camera = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: bytemuck::cast_slice(&camera_words),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        check_textures(scene)?;
        let store = crate::texels::upload(ctx, scene)?;
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
        // Dynamic offsets are u32: at most 2^24 materials at 256 bytes each.
        let uniform_size =
            (mat_words.len() / (MATERIAL_STRIDE / 4)) as u64 * MATERIAL_UNIFORM_STRIDE;
        let uniform_limit = limit.min(u64::from(u32::MAX) + 1);
        if uniform_size > uniform_limit {
            return Err(GpuError::TooLarge {
                what: format!(
                    "the per-draw materials of scene {:?} ({} materials, {MATERIAL_UNIFORM_STRIDE} bytes each)",
                    scene.name,
                    scene.materials.len()
                ),
                needed: uniform_size,
                limit: uniform_limit,
            });
        }
        let stride = MATERIAL_UNIFORM_STRIDE as usize;
        let mut uniform_bytes = vec![0u8; mat_words.len() / (MATERIAL_STRIDE / 4) * stride];
        for (entry, words) in uniform_bytes
            .chunks_exact_mut(stride)
            .zip(mat_words.chunks_exact(MATERIAL_STRIDE / 4))
        {
            entry[..MATERIAL_STRIDE].copy_from_slice(bytemuck::cast_slice(words));
        }
        let draw_materials = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("draw materials"),
            contents: &uniform_bytes,
            usage: wgpu::BufferUsages::UNIFORM,
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
                    resource: store.decode.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&store.view),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &draw_materials,
                        offset: 0,
                        size: wgpu::BufferSize::new(MATERIAL_STRIDE as u64),
                    }),
                },
            ],
        });
        Ok(GpuScene {
            scene: scene.clone(),
            id: NEXT_SCENE_ID.fetch_add(1, Ordering::Relaxed),
            vertices,
            indices,
            camera,
            materials,
            draw_materials,
            texel_pages: store.pages,
            texel_decode: store.decode,
            bind_group,
            per_draw_material: scene
                .draws
                .iter()
                .map(|d| mean_triangle_pixels(scene, d) <= PER_DRAW_MATERIAL_MAX_AREA)
                .collect(),
            specialised: true,
            bound_offset: AtomicU32::new(0),
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

    /// Sets group 0 (with the first material as the draw material), vertex buffer 0 and the
    /// index buffer on `pass`. Draw through [`GpuScene::draw`], or [`GpuScene::use_draw`] (which
    /// selects each draw's material) then [`GpuScene::draw_range`].
    pub fn bind(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_bind_group(0, &self.bind_group, &[0]);
        self.bound_offset.store(0, Ordering::Relaxed);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
    }

    /// Draws the triangles of `vertices` (a range of `Scene::vertices`, a draw's or part of
    /// one) through [`GpuScene::indices`], after [`GpuScene::bind`] on the same pass.
    pub fn draw_range(
        pass: &mut wgpu::RenderPass<'_>,
        vertices: std::ops::Range<u32>,
        instances: std::ops::Range<u32>,
    ) {
        pass.draw_indexed(vertices, 0, instances);
    }

    /// The indirect arguments of [`wgpu::RenderPass::draw_indexed_indirect`] (index count,
    /// instance count, first index, base vertex, first instance) that draw `draw` once, as
    /// [`GpuScene::draw_range`] would.
    pub fn indirect_args(draw: &oit_scene::Draw) -> [u32; 5] {
        [draw.vertex_count, 1, draw.first_vertex, 0, 0]
    }

    /// The dynamic offset of group 0 that selects material `material` as the draw material.
    pub fn material_offset(material: u32) -> u32 {
        material * MATERIAL_UNIFORM_STRIDE as u32
    }

    /// Whether draw `index` reads its material per draw, from a uniform (shaders/scene_io/
    /// draw.wgsl), rather than per vertex as flat varyings: where its triangles are small
    /// ([`PER_DRAW_MATERIAL_MAX_AREA`]), so that per-triangle setup would cost more than a read
    /// per fragment. Pipelines without the per-draw form read it per vertex regardless.
    pub fn reads_material_per_draw(&self, index: usize) -> bool {
        self.per_draw_material[index]
    }

    /// Makes every draw read its material per draw (`true`) or per vertex (`false`), whatever
    /// the size of its triangles: for tests that both forms give the same bits, and for A/B
    /// timings.
    pub fn set_reads_material_per_draw(&mut self, per_draw: bool) {
        self.per_draw_material.fill(per_draw);
    }

    /// Lets materials draw with the pipelines specialised for what they fix (`true`, the
    /// default) or not: `OVER_ONLY` and `STRAIGHT_OVER` leave the operator, transmission and
    /// alpha-form code out, `UNIT_FACTORS` the reads of factors that are units. Both give the
    /// same bits, which tests check with this, and A/B timings use it.
    pub fn set_specialised(&mut self, specialised: bool) {
        self.specialised = specialised;
    }

    /// Whether material `m` draws with the `OVER_ONLY` pipelines ([`GpuScene::set_specialised`]).
    pub fn draws_over_only(&self, m: &Material) -> bool {
        self.specialised && over_only(m)
    }

    /// Whether material `m` draws with the `UNIT_FACTORS` pipelines
    /// ([`GpuScene::set_specialised`]).
    pub fn draws_unit_factors(&self, m: &Material) -> bool {
        self.specialised && unit_factors(m)
    }

    /// Prepares `pass` for `self.scene.draws[index]` (after [`GpuScene::bind`] on the same
    /// pass, and no other group 0 since): the pipeline its material needs and, where it reads
    /// the material per draw, group 0 at its material's offset. For passes that issue the
    /// draw call themselves (instanced, indirect); [`GpuScene::draw`] does both.
    pub fn use_draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipelines: &ScenePipelines,
        index: usize,
    ) {
        let d = &self.scene.draws[index];
        let per_draw = self.reads_material_per_draw(index) && pipelines.has_per_draw_form();
        let m = self.scene.material_of(d);
        pass.set_pipeline(pipelines.for_draw(
            m,
            per_draw,
            self.draws_over_only(m),
            self.draws_unit_factors(m),
        ));
        let offset = Self::material_offset(d.material);
        if per_draw && self.bound_offset.swap(offset, Ordering::Relaxed) != offset {
            pass.set_bind_group(0, &self.bind_group, &[offset]);
        }
    }

    /// Draws `self.scene.draws[index]` with the pipeline its material needs.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, pipelines: &ScenePipelines, index: usize) {
        let d = &self.scene.draws[index];
        if d.vertex_count == 0 {
            return;
        }
        self.use_draw(pass, pipelines, index);
        Self::draw_range(pass, d.first_vertex..d.first_vertex + d.vertex_count, 0..1);
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
    /// The pass's own pipeline override constants (both stages get them).
    pub constants: &'a [(&'a str, f64)],
    /// Must match the attachments' sample count (and may enable alpha-to-coverage).
    pub multisample: wgpu::MultisampleState,
    pub cull: CullRule,
    /// Where the fragment stage reads the material.
    pub material: MaterialSource,
}

/// How a scene pipeline's draws get their material to the fragment stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaterialSource {
    /// Each draw in the form that costs it less ([`GpuScene::reads_material_per_draw`]): read
    /// per vertex and passed flat (shaders/scene_io/vertex.wgsl), or read per fragment from a
    /// uniform at the draw's dynamic offset (shaders/scene_io/draw.wgsl). The same bits either
    /// way. Needs a module from [`Context::shader_with`] whose pass uses `vs_main`'s interface.
    PerDraw,
    /// Always read per vertex and passed flat: for one draw call that mixes materials
    /// (sorted-triangle's stream), or a pass with its own vertex outputs.
    PerVertex,
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
            material: MaterialSource::PerDraw,
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

/// The pipelines of one scene pass, one per kind of draw, each built when first needed:
///
/// * single- or double-sided (back faces culled or not, by [`CullRule`]);
/// * override `TEXTURED` of shaders/common.wgsl: CPU rasterizers run a branch's code masked
///   per lane whatever the condition, so untextured materials get a `shade()` without texture
///   code (eight texel fetches per fragment made `unsorted` 11× slower on lavapipe, even
///   behind a uniform branch);
/// * override `MAY_DISCARD`: false where no fragment can be discarded (no cutoff, and back
///   faces culled or drawn), so the rasterizer may test depth before shading;
/// * override `OVER_ONLY` of shaders/common.wgsl: true for materials that blend OVER without
///   coloured transmission ([`over_only`]), whose `shade()` then has no operator or
///   transmission code (the same bits);
/// * override `STRAIGHT_OVER` of shaders/common.wgsl: true where, besides, the material is
///   transparent, straight-alpha and unlit ([`straight_over`]), whose `shade()` then has one
///   path (the same bits);
/// * override `UNIT_FACTORS` of shaders/common.wgsl: true for materials whose colour, alpha,
///   intensity, emission and transmission factors change nothing ([`unit_factors`]), whose
///   `shade()` then does not read them (the same bits; [`GpuScene::set_specialised`] turns
///   this and the two above off);
/// * override `LIT` of shaders/lighting.wgsl: true only for lit materials
///   ([`Material::is_lit`]), so unlit draws never run (or pay for) the lighting loop (the
///   per-vertex form still passes them the world position and normal: lavapipe does not drop
///   unread varyings, which is why the per-draw forms of unlit draws leave them out);
/// * the material read per vertex or per draw ([`MaterialSource`],
///   [`GpuScene::reads_material_per_draw`]), from the module or its per-draw form.
///
/// Clones share the pipelines.
#[derive(Debug, Clone)]
pub struct ScenePipelines {
    shared: Arc<PipelineSet>,
}

/// What [`ScenePipelines`] builds its variants from, and the variants built so far.
#[derive(Debug)]
struct PipelineSet {
    made: Arc<crate::made::Made>,
    layout: wgpu::PipelineLayout,
    label: String,
    module: wgpu::ShaderModule,
    vertex_entry: String,
    fragment_entry: String,
    targets: Vec<Option<wgpu::ColorTargetState>>,
    depth: Option<wgpu::DepthStencilState>,
    constants: Vec<(String, f64)>,
    multisample: wgpu::MultisampleState,
    cull: CullRule,
    /// The module's per-draw form ([`MaterialSource::PerDraw`]).
    per_draw_form: Option<Arc<crate::context::PerDrawForm>>,
    /// By [`Variant::index`].
    built: [OnceLock<wgpu::RenderPipeline>; Variant::COUNT],
}

/// One specialisation of a scene pass's pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Variant {
    double_sided: bool,
    textured: bool,
    may_discard: bool,
    /// Built from the module's per-draw form.
    per_draw: bool,
    /// Override `LIT` of shaders/lighting.wgsl: lit materials only.
    lit: bool,
    /// Override `OVER_ONLY` of shaders/common.wgsl ([`over_only`]).
    over_only: bool,
    /// Override `STRAIGHT_OVER` of shaders/common.wgsl ([`straight_over`]).
    straight_over: bool,
    /// Override `UNIT_FACTORS` of shaders/common.wgsl ([`unit_factors`]).
    unit_factors: bool,
}

/// Whether `m` blends OVER with no coloured transmission: the override `OVER_ONLY` of
/// shaders/common.wgsl may leave the operator and transmission code out of its `shade()`.
fn over_only(m: &Material) -> bool {
    m.operator == oit_scene::BlendOperator::Over && m.transmission == 0.0
}

/// Whether `m`, drawn with the `OVER_ONLY` form (`over_only`), may also take `STRAIGHT_OVER`
/// of shaders/common.wgsl: transparent, straight alpha, unlit, so `shade()` has one path.
fn straight_over(m: &Material, over_only: bool) -> bool {
    over_only && m.mode.is_transparent() && !m.premultiplied && !m.is_lit()
}

/// Whether `m`'s factors are units, so that `shade()` may use constants for them (override
/// `UNIT_FACTORS` of shaders/common.wgsl): base colour and alpha 1, intensity 1, no emission
/// (whatever its texture: it is scaled by 0), no transmission.
fn unit_factors(m: &Material) -> bool {
    m.base_color == [1.0; 3]
        && m.alpha == 1.0
        && m.intensity == 1.0
        && m.emissive == [0.0; 3]
        && m.transmission == 0.0
}

impl Variant {
    const COUNT: usize = 256;

    fn index(self) -> usize {
        usize::from(self.double_sided)
            | usize::from(self.textured) << 1
            | usize::from(self.may_discard) << 2
            | usize::from(self.per_draw) << 3
            | usize::from(self.lit) << 4
            | usize::from(self.over_only) << 5
            | usize::from(self.straight_over) << 6
            | usize::from(self.unit_factors) << 7
    }
}

impl ScenePipelines {
    /// The pipelines with a layout of group 0 ([`Context::scene_layout`]) alone.
    pub fn new(ctx: &Context, desc: &ScenePipelineDesc<'_>) -> Self {
        let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(desc.label),
            bind_group_layouts: &[Some(ctx.scene_layout())],
            immediate_size: 0,
        });
        Self::with_layout(ctx, desc, &layout)
    }

    /// The pipelines with the caller's layout (techniques with extra bind groups), whose
    /// group 0 is [`Context::scene_layout`].
    pub fn with_layout(
        ctx: &Context,
        desc: &ScenePipelineDesc<'_>,
        layout: &wgpu::PipelineLayout,
    ) -> Self {
        ScenePipelines {
            shared: Arc::new(PipelineSet {
                made: ctx.made().clone(),
                layout: layout.clone(),
                label: desc.label.to_owned(),
                module: desc.module.clone(),
                vertex_entry: desc.vertex_entry.to_owned(),
                fragment_entry: desc.fragment_entry.to_owned(),
                targets: desc.targets.to_vec(),
                depth: desc.depth.clone(),
                constants: desc
                    .constants
                    .iter()
                    .map(|&(k, v)| (k.to_owned(), v))
                    .collect(),
                multisample: desc.multisample,
                cull: desc.cull,
                per_draw_form: match desc.material {
                    MaterialSource::PerDraw => ctx.per_draw_form(desc.module),
                    MaterialSource::PerVertex => None,
                },
                built: std::array::from_fn(|_| OnceLock::new()),
            }),
        }
    }

    /// Whether these pipelines can read a draw's material per draw ([`MaterialSource::PerDraw`]
    /// and a module with the scene pass interface).
    pub fn has_per_draw_form(&self) -> bool {
        self.shared.per_draw_form.is_some()
    }

    /// The pipeline for a draw of material `m`, which reads it per draw where `per_draw` and
    /// the pass has that form ([`MaterialSource::PerDraw`]), else per vertex; `over_only`
    /// where `m` may take the `OVER_ONLY` form ([`GpuScene::draws_over_only`]), `unit_factors`
    /// where it may take the `UNIT_FACTORS` form ([`GpuScene::draws_unit_factors`]).
    pub fn for_draw(
        &self,
        m: &Material,
        per_draw: bool,
        over_only: bool,
        unit_factors: bool,
    ) -> &wgpu::RenderPipeline {
        let set = &self.shared;
        // Every fragment is kept when the material has no cutoff and the pipeline's face
        // culling leaves nothing `shade()` would discard (a single-sided material's back faces).
        let culls_back = match set.cull {
            CullRule::ByMaterial => !m.double_sided,
            CullRule::Fixed(face) => face == Some(wgpu::Face::Back),
        };
        self.variant(Variant {
            double_sided: m.double_sided,
            textured: m.is_textured(),
            may_discard: m.mode.uses_cutoff() || !(m.double_sided || culls_back),
            per_draw: per_draw && set.per_draw_form.is_some(),
            lit: m.is_lit(),
            over_only,
            straight_over: straight_over(m, over_only),
            unit_factors,
        })
    }

    /// The double-sided pipeline for one draw call that mixes materials (which needs
    /// [`MaterialSource::PerVertex`]): textured when any material of `scene` reads a
    /// texture, discarding where any could.
    pub fn double_sided_for(&self, gpu: &GpuScene) -> &wgpu::RenderPipeline {
        let scene = &gpu.scene;
        self.variant(Variant {
            double_sided: true,
            textured: scene.materials.iter().any(Material::is_textured),
            may_discard: true,
            per_draw: false,
            lit: scene.materials.iter().any(Material::is_lit),
            over_only: scene.materials.iter().all(|m| gpu.draws_over_only(m)),
            straight_over: (scene.materials.iter())
                .all(|m| straight_over(m, gpu.draws_over_only(m))),
            unit_factors: scene.materials.iter().all(|m| gpu.draws_unit_factors(m)),
        })
    }

    fn variant(&self, v: Variant) -> &wgpu::RenderPipeline {
        let set = &self.shared;
        set.built[v.index()].get_or_init(|| {
            let mut constants: Vec<(&str, f64)> = set
                .constants
                .iter()
                .map(|(k, v)| (k.as_str(), *v))
                .collect();
            let flag = |b: bool| if b { 1.0 } else { 0.0 };
            constants.push(("TEXTURED", flag(v.textured)));
            constants.push(("MAY_DISCARD", flag(v.may_discard)));
            constants.push(("LIT", flag(v.lit)));
            constants.push(("OVER_ONLY", flag(v.over_only)));
            constants.push(("STRAIGHT_OVER", flag(v.straight_over)));
            constants.push(("UNIT_FACTORS", flag(v.unit_factors)));
            let cull = match set.cull {
                CullRule::ByMaterial if !v.double_sided => Some(wgpu::Face::Back),
                CullRule::ByMaterial => None,
                CullRule::Fixed(face) => face,
            };
            let module = match (&set.per_draw_form, v.per_draw) {
                (Some(form), true) => form.module(&set.made, v.textured, v.lit),
                _ => &set.module,
            };
            let desc = ScenePipelineDesc {
                label: &set.label,
                module,
                vertex_entry: &set.vertex_entry,
                fragment_entry: &set.fragment_entry,
                targets: &set.targets,
                depth: set.depth.clone(),
                constants: &constants,
                multisample: set.multisample,
                cull: set.cull,
                material: if v.per_draw {
                    MaterialSource::PerDraw
                } else {
                    MaterialSource::PerVertex
                },
            };
            build_scene_pipeline(&set.made, &desc, &set.layout, cull)
        })
    }
}

/// Builds one scene pipeline with an explicit layout and face culling (`desc.cull` is not
/// consulted; [`ScenePipelines`] applies it).
fn build_scene_pipeline(
    made: &crate::made::Made,
    desc: &ScenePipelineDesc<'_>,
    layout: &wgpu::PipelineLayout,
    cull: Option<wgpu::Face>,
) -> wgpu::RenderPipeline {
    let constants = wgpu::PipelineCompilationOptions {
        constants: desc.constants,
        ..Default::default()
    };
    made.render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(desc.label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module: desc.module,
            entry_point: Some(desc.vertex_entry),
            compilation_options: constants.clone(),
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
            compilation_options: constants,
            targets: desc.targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every index slot names a vertex of its own draw, at or before it, with the same bits;
    /// a vertex named by a later slot is named by itself.
    fn check_indices(scene: &Scene) -> Vec<u32> {
        let words = vertex_words(scene);
        let per_vertex = (VERTEX_STRIDE / 4) as usize;
        assert_eq!(words.len(), scene.vertices.len() * per_vertex);
        let indices = shared_corner_indices(scene, &words);
        assert_eq!(indices.len(), scene.vertices.len());
        let bits = |i: usize| &words[i * per_vertex..(i + 1) * per_vertex];
        for d in &scene.draws {
            let range = d.vertex_range();
            for i in range.clone() {
                let j = indices[i] as usize;
                assert!(range.contains(&j) && j <= i, "slot {i} names {j}");
                assert_eq!(bits(i), bits(j), "slot {i} names {j}");
                assert_eq!(indices[j] as usize, j);
            }
        }
        indices
    }

    fn distinct(indices: &[u32]) -> usize {
        indices
            .iter()
            .collect::<std::collections::HashSet<_>>()
            .len()
    }

    #[test]
    fn billboards_shade_four_corners_per_quad() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../scenes/particles.json"
        ))
        .unwrap();
        let scene = oit_scene::parse(&text, "particles.json").unwrap();
        let indices = check_indices(&scene);
        assert_eq!(indices.len(), 72_000);
        assert_eq!(distinct(&indices), 48_000);
    }

    #[test]
    fn random_scenes_keep_every_triangle_and_its_bits() {
        for seed in 0..24 {
            let (text, _) = oit_scene::random::random_scene_json(seed);
            let scene = oit_scene::parse(&text, "random").unwrap();
            check_indices(&scene);
        }
    }

    #[test]
    fn corners_of_different_draws_or_bits_stay_apart() {
        let text = r#"{"name": "two", "resolution": [8, 8],
            "camera": {"eye": [0, 0, 3], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 10},
            "objects": [
              {"mesh": {"kind": "quad", "size": [1, 1]}, "material": {"base_color": [1, 0, 0], "alpha": 0.5, "mode": "blend"}},
              {"mesh": {"kind": "quad", "size": [1, 1]}, "material": {"base_color": [1, 0, 0], "alpha": 0.5, "mode": "blend"}}
            ]}"#;
        let scene = oit_scene::parse(text, "two.json").unwrap_or_else(|e| panic!("{e}"));
        let indices = check_indices(&scene);
        // Two identical quads in two draws: four corners each, none shared across draws.
        assert_eq!(distinct(&indices), 8);
    }
}
