//! Adapter choice, device creation and capabilities.

use crate::error::GpuError;
use crate::made::Made;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};
use wgpu::{Features, TextureFormat, TextureFormatFeatureFlags, TextureUsages};

/// Which graphics API to use (`--backend auto|vulkan|gl`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Backend {
    /// Every backend this build has; hardware adapters preferred over CPU ones, Vulkan over GL.
    #[default]
    Auto,
    Vulkan,
    Gl,
}

impl Backend {
    pub const ALL: [Backend; 3] = [Backend::Auto, Backend::Vulkan, Backend::Gl];

    pub fn name(self) -> &'static str {
        match self {
            Backend::Auto => "auto",
            Backend::Vulkan => "vulkan",
            Backend::Gl => "gl",
        }
    }

    fn backends(self) -> wgpu::Backends {
        match self {
            Backend::Auto => wgpu::Backends::all(),
            Backend::Vulkan => wgpu::Backends::VULKAN,
            Backend::Gl => wgpu::Backends::GL,
        }
    }
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Backend {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Backend::ALL
            .into_iter()
            .find(|b| b.name() == s)
            .ok_or_else(|| format!("unknown backend {s:?}; allowed: auto, vulkan, gl"))
    }
}

/// How to pick the adapter.
#[derive(Debug, Clone, Default)]
pub struct ContextOptions {
    pub backend: Backend,
    /// Case-insensitive substring of the adapter name or driver info (`--adapter`): two
    /// lavapipes share a name and differ in driver info (`Mesa 22.3.6`, `Mesa 25.0.7`).
    pub adapter: Option<String>,
}

/// The adapter as results.json's `"adapter"` object records it.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct AdapterSummary {
    pub name: String,
    /// `vulkan`, `gl`, `metal`, `dx12`, …
    pub backend: String,
    /// `cpu`, `discrete-gpu`, `integrated-gpu`, `virtual-gpu`, `other`.
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
}

impl AdapterSummary {
    fn new(info: &wgpu::AdapterInfo) -> Self {
        let device_type = match info.device_type {
            wgpu::DeviceType::Cpu => "cpu",
            wgpu::DeviceType::DiscreteGpu => "discrete-gpu",
            wgpu::DeviceType::IntegratedGpu => "integrated-gpu",
            wgpu::DeviceType::VirtualGpu => "virtual-gpu",
            wgpu::DeviceType::Other => "other",
        };
        Self {
            name: info.name.clone(),
            backend: info.backend.to_str().to_owned(),
            device_type: device_type.to_owned(),
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
        }
    }
}

/// What one texture format can do on this device (with the features the context enabled).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct FormatCaps {
    /// Usable as a render attachment.
    pub renderable: bool,
    /// Usable as a render attachment with blending enabled.
    pub blendable: bool,
    /// Sampled with linear filtering.
    pub filterable: bool,
    /// Usable as a read-write storage texture.
    pub storage_read_write: bool,
    /// 4× multisampling.
    pub multisample_x4: bool,
}

/// Formats whose capabilities are probed at start (the ones OIT techniques choose between).
pub const PROBED_FORMATS: [TextureFormat; 9] = [
    TextureFormat::R32Float,
    TextureFormat::Rg32Float,
    TextureFormat::Rgba32Float,
    TextureFormat::R16Float,
    TextureFormat::Rg16Float,
    TextureFormat::Rgba16Float,
    TextureFormat::R8Unorm,
    TextureFormat::Rgba8Unorm,
    TextureFormat::Depth32Float,
];

/// Capabilities of the device, as a technique's `check` reads them.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Caps {
    /// The graphics API the device runs on (`vulkan`, `gl`, …): some limits are the backend's,
    /// not the adapter's (see [`Caps::depth_copies`], [`Caps::depth_texture_loads`]).
    #[serde(serialize_with = "serialize_backend")]
    pub backend: wgpu::Backend,
    /// `FLOAT32_BLENDABLE`: blending into R32Float/Rg32Float/Rgba32Float targets.
    pub float32_blendable: bool,
    /// `TIMESTAMP_QUERY` at pass boundaries.
    pub timestamps: bool,
    pub timestamps_inside_encoders: bool,
    pub timestamps_inside_passes: bool,
    /// Per-format features beyond the WebGPU baseline are usable.
    pub adapter_specific_format_features: bool,
    pub dual_source_blending: bool,
    /// `SHADER_INT64` with `SHADER_INT64_ATOMIC_ALL_OPS`: 64-bit storage atomics whose result
    /// the shader may read (a k-buffer's `atomicMin` insertion needs the old value). Vulkan and
    /// DX12 only; never GL.
    pub int64_atomics: bool,
    /// `EXPERIMENTAL_RAY_QUERY`: acceleration structures and `ray_query` in shaders (Vulkan,
    /// native; lavapipe from Mesa 24.1, `.ci/lavapipe-ray-query`).
    pub ray_query: bool,
    pub max_texture_dimension_2d: u32,
    pub max_color_attachments: u32,
    pub max_color_attachment_bytes_per_sample: u32,
    pub max_storage_buffers_per_shader_stage: u32,
    pub max_buffer_size: u64,
    pub max_storage_buffer_binding_size: u64,
    /// Alignment of dynamic uniform-buffer offsets (one slot per offset costs this many bytes).
    pub min_uniform_buffer_offset_alignment: u32,
    /// `(format name, capabilities)` for every format in [`PROBED_FORMATS`].
    pub formats: Vec<(String, FormatCaps)>,
}

impl Caps {
    /// Every scene pass reads the material table, a storage buffer, in the vertex stage: the
    /// check each technique's [`crate::Technique::check`] starts with.
    pub fn require_scene_materials(&self) -> Result<(), crate::Unsupported> {
        if self.max_storage_buffers_per_shader_stage == 0 {
            return Err(crate::Unsupported::new(
                "the adapter has no storage buffers in vertex shaders (scene materials)",
            ));
        }
        Ok(())
    }

    fn probe(adapter: &wgpu::Adapter, features: Features, limits: &wgpu::Limits) -> Self {
        let formats = PROBED_FORMATS
            .iter()
            .map(|&f| (format!("{f:?}"), format_caps(adapter, features, f)))
            .collect();
        Caps {
            backend: adapter.get_info().backend,
            float32_blendable: features.contains(Features::FLOAT32_BLENDABLE),
            timestamps: features.contains(Features::TIMESTAMP_QUERY),
            timestamps_inside_encoders: features
                .contains(Features::TIMESTAMP_QUERY_INSIDE_ENCODERS),
            timestamps_inside_passes: features.contains(Features::TIMESTAMP_QUERY_INSIDE_PASSES),
            adapter_specific_format_features: features
                .contains(Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES),
            dual_source_blending: features.contains(Features::DUAL_SOURCE_BLENDING),
            int64_atomics: features
                .contains(Features::SHADER_INT64 | Features::SHADER_INT64_ATOMIC_ALL_OPS),
            ray_query: features.contains(Features::EXPERIMENTAL_RAY_QUERY),
            max_texture_dimension_2d: limits.max_texture_dimension_2d,
            max_color_attachments: limits.max_color_attachments,
            max_color_attachment_bytes_per_sample: limits.max_color_attachment_bytes_per_sample,
            max_storage_buffers_per_shader_stage: limits.max_storage_buffers_per_shader_stage,
            max_buffer_size: limits.max_buffer_size,
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            min_uniform_buffer_offset_alignment: limits.min_uniform_buffer_offset_alignment,
            formats,
        }
    }

    /// wgpu's GL backend (OpenGL / GLES through EGL).
    pub fn is_gl(&self) -> bool {
        self.backend == wgpu::Backend::Gl
    }

    /// Whether `Depth32Float` textures can be copied. On wgpu 30's GL backend a texture to
    /// texture copy is recorded and left undone without an error, and a texture to buffer copy
    /// is a validation error (no `DEPTH_TEXTURE_AND_BUFFER_COPIES` downlevel flag); a technique
    /// that needs the opaque depth elsewhere draws it (a full-screen pass reading the depth as
    /// a float texture) or reports itself unsupported here.
    pub fn depth_copies(&self) -> bool {
        !self.is_gl()
    }

    /// Whether shaders may `textureLoad` from depth textures (`texture_depth_2d`). naga cannot
    /// translate that to GLSL (no `texelFetch` of shadow samplers), so on GL a depth texture
    /// must be bound as an unfilterable float texture instead.
    pub fn depth_texture_loads(&self) -> bool {
        !self.is_gl()
    }

    /// Capabilities of `format`, or all-false for a format that was not probed.
    pub fn format(&self, format: TextureFormat) -> FormatCaps {
        let name = format!("{format:?}");
        self.formats
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, c)| *c)
            .unwrap_or_default()
    }

    /// `Ok` when per-pixel textures of `resolution` can be created (1 ..= the 2D texture
    /// limit on each side), otherwise the reason.
    pub fn require_resolution(
        &self,
        resolution: oit_scene::Resolution,
    ) -> Result<(), crate::Unsupported> {
        let max = self.max_texture_dimension_2d;
        if resolution.width > max || resolution.height > max || resolution.pixel_count() == 0 {
            return Err(crate::Unsupported::new(format!(
                "resolution {resolution} is outside 1..={max} pixels per side"
            )));
        }
        Ok(())
    }

    /// `Ok` when `format` can be rendered to (and blended into, if `blend`), otherwise the
    /// reason, ready for a technique's `check`.
    pub fn require_target(
        &self,
        format: TextureFormat,
        blend: bool,
    ) -> Result<(), crate::Unsupported> {
        let c = self.format(format);
        // Over GL the limit is wgpu's, not the driver's (docs/findings/2026-12-07-gl-rg32f.md).
        let gl_float32 = if self.backend == wgpu::Backend::Gl && is_float32_color(format) {
            "; wgpu's GL backend renders 32-bit float targets only when the context lists GL_EXT/ARB_color_buffer_float (desktop core profiles need not: it is core since GL 3.0) and never offers FLOAT32_BLENDABLE"
        } else {
            ""
        };
        if !c.renderable {
            return Err(crate::Unsupported::new(format!(
                "the adapter cannot render to {format:?} textures{gl_float32}"
            )));
        }
        if blend && !c.blendable {
            return Err(crate::Unsupported::new(format!(
                "the adapter cannot blend into {format:?} textures{}{gl_float32}",
                if is_float32_color(format) && !self.float32_blendable {
                    " (no FLOAT32_BLENDABLE feature)"
                } else {
                    ""
                }
            )));
        }
        Ok(())
    }
}

fn serialize_backend<S: serde::Serializer>(b: &wgpu::Backend, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(b.to_str())
}

/// R32Float, Rg32Float and Rgba32Float: blending into them needs `FLOAT32_BLENDABLE`.
fn is_float32_color(format: TextureFormat) -> bool {
    matches!(
        format,
        TextureFormat::R32Float | TextureFormat::Rg32Float | TextureFormat::Rgba32Float
    )
}

fn format_caps(adapter: &wgpu::Adapter, features: Features, format: TextureFormat) -> FormatCaps {
    // Without TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES the device only allows the WebGPU
    // guaranteed set, so that is what techniques may rely on.
    let f = if features.contains(Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES) {
        adapter.get_texture_format_features(format)
    } else {
        format.guaranteed_format_features(features)
    };
    let renderable = f.allowed_usages.contains(TextureUsages::RENDER_ATTACHMENT);
    let mut blendable = renderable && f.flags.contains(TextureFormatFeatureFlags::BLENDABLE);
    if is_float32_color(format) && !features.contains(Features::FLOAT32_BLENDABLE) {
        blendable = false;
    }
    FormatCaps {
        renderable,
        blendable,
        filterable: f.flags.contains(TextureFormatFeatureFlags::FILTERABLE),
        storage_read_write: f.allowed_usages.contains(TextureUsages::STORAGE_BINDING)
            && f.flags
                .contains(TextureFormatFeatureFlags::STORAGE_READ_WRITE),
        multisample_x4: f.flags.contains(TextureFormatFeatureFlags::MULTISAMPLE_X4),
    }
}

/// Optional features requested whenever the adapter has them.
const WANTED_FEATURES: Features = Features::FLOAT32_BLENDABLE
    .union(Features::TIMESTAMP_QUERY)
    .union(Features::TIMESTAMP_QUERY_INSIDE_ENCODERS)
    .union(Features::TIMESTAMP_QUERY_INSIDE_PASSES)
    .union(Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES)
    .union(Features::DUAL_SOURCE_BLENDING)
    .union(Features::DEPTH32FLOAT_STENCIL8)
    .union(Features::SHADER_INT64)
    .union(Features::SHADER_INT64_ATOMIC_ALL_OPS);

/// The GPU: adapter, device, queue and what they can do.
#[derive(Debug)]
pub struct Context {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub caps: Caps,
    info: wgpu::AdapterInfo,
    scene_layout: wgpu::BindGroupLayout,
    /// Per scene pass module from [`Context::shader_with`]: its per-draw form. Modules are
    /// made once per source ([`crate::made`]), so the table holds one entry per scene pass
    /// source this context has seen.
    per_draw: Mutex<HashMap<wgpu::ShaderModule, Arc<PerDrawForm>>>,
    /// Modules, layouts and pipelines made once and handed out again ([`crate::made`]).
    made: Arc<Made>,
}

/// The per-draw forms of a scene pass module, unlit untextured, unlit textured and lit: their
/// composed sources, and the modules once built (only pipelines that use one build it).
#[derive(Debug)]
pub(crate) struct PerDrawForm {
    name: String,
    code: [String; 3],
    modules: [OnceLock<wgpu::ShaderModule>; 3],
}

impl PerDrawForm {
    pub(crate) fn module(&self, made: &Made, textured: bool, lit: bool) -> &wgpu::ShaderModule {
        let i = if lit { 2 } else { usize::from(textured) };
        self.modules[i].get_or_init(|| made.module(&self.name, &self.code[i]))
    }
}

fn device_rank(t: wgpu::DeviceType) -> u32 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

fn backend_rank(b: wgpu::Backend) -> u32 {
    match b {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    }
}

impl Context {
    /// Picks an adapter (hardware before CPU, Vulkan/Metal/DX12 before GL, then enumeration
    /// order) and creates a device with every feature in the wanted set the adapter has and
    /// the adapter's own limits.
    pub fn new(options: &ContextOptions) -> Result<Context, GpuError> {
        // Auto tries Vulkan/Metal/DX12 first and only falls back to GL when they have no
        // adapter (initialising EGL is slow and noisy on headless machines).
        let tiers: &[wgpu::Backends] = match options.backend {
            Backend::Auto => &[wgpu::Backends::PRIMARY, wgpu::Backends::SECONDARY],
            b => &[b.backends()],
        };
        let mut instance = None;
        let mut adapters = Vec::new();
        for &backends in tiers {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
            desc.backends = backends;
            let inst = wgpu::Instance::new(desc);
            adapters = pollster::block_on(inst.enumerate_adapters(backends));
            instance = Some(inst);
            if !adapters.is_empty() {
                break;
            }
        }
        let Some(instance) = instance else {
            return Err(GpuError::NoAdapter {
                backend: options.backend.name().to_owned(),
            });
        };
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter {
                backend: options.backend.name().to_owned(),
            });
        }
        if let Some(filter) = &options.adapter {
            let needle = filter.to_lowercase();
            let available: Vec<String> = adapters
                .iter()
                .map(|a| {
                    let i = a.get_info();
                    format!("{:?} ({}, {})", i.name, i.backend.to_str(), i.driver_info)
                })
                .collect();
            adapters.retain(|a| {
                let i = a.get_info();
                format!("{} {}", i.name, i.driver_info)
                    .to_lowercase()
                    .contains(&needle)
            });
            if adapters.is_empty() {
                return Err(GpuError::AdapterNotMatched {
                    backend: options.backend.name().to_owned(),
                    filter: filter.clone(),
                    available: available.join(", "),
                });
            }
        }
        // Stable sort keeps the enumeration order among equals.
        adapters.sort_by_key(|a| {
            let i = a.get_info();
            (device_rank(i.device_type), backend_rank(i.backend))
        });
        let adapter = adapters.swap_remove(0);
        let info = adapter.get_info();
        let mut features = adapter.features() & WANTED_FEATURES;
        // Ray queries are experimental in wgpu 30: requested only where the adapter has them,
        // with the token from the one crate allowed `unsafe` (crates/oit-experimental).
        let experimental_features = if adapter
            .features()
            .contains(Features::EXPERIMENTAL_RAY_QUERY)
        {
            features |= Features::EXPERIMENTAL_RAY_QUERY;
            oit_experimental::experimental_features()
        } else {
            wgpu::ExperimentalFeatures::disabled()
        };
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("oit-lab"),
            required_features: features,
            required_limits: limits.clone(),
            experimental_features,
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::RequestDevice {
            adapter: info.name.clone(),
            message: e.to_string(),
        })?;
        let caps = Caps::probe(&adapter, device.features(), &device.limits());
        let made = Arc::new(Made::new(&device));
        let scene_layout = crate::scene::create_scene_layout(&made);
        Ok(Context {
            instance,
            adapter,
            device,
            queue,
            caps,
            info,
            scene_layout,
            per_draw: Mutex::new(HashMap::new()),
            made,
        })
    }

    /// A bind group layout with `desc`'s entries: the same object for equal entries (its
    /// label is the first caller's), so that pipelines made for one technique instance are
    /// found again by the next ([`crate::made`]).
    pub fn bind_group_layout(
        &self,
        desc: &wgpu::BindGroupLayoutDescriptor<'_>,
    ) -> wgpu::BindGroupLayout {
        self.made.bind_group_layout(desc)
    }

    /// A pipeline layout of `desc`'s groups, the same object for the same groups.
    pub fn pipeline_layout(
        &self,
        desc: &wgpu::PipelineLayoutDescriptor<'_>,
    ) -> wgpu::PipelineLayout {
        self.made.pipeline_layout(desc)
    }

    /// The module of WGSL `code` as it is (no `#include`s resolved: [`Context::shader`] does
    /// that), made once per source; `label` names it in the driver's messages.
    pub fn wgsl_module(&self, label: &str, code: &str) -> wgpu::ShaderModule {
        self.made.module(label, code)
    }

    /// A render pipeline as `desc` describes it, made once per description (labels aside).
    pub fn render_pipeline(
        &self,
        desc: &wgpu::RenderPipelineDescriptor<'_>,
    ) -> wgpu::RenderPipeline {
        self.made.render_pipeline(desc)
    }

    /// A compute pipeline as `desc` describes it, made once per description (labels aside).
    pub fn compute_pipeline(
        &self,
        desc: &wgpu::ComputePipelineDescriptor<'_>,
    ) -> wgpu::ComputePipeline {
        self.made.compute_pipeline(desc)
    }

    /// How many modules, layouts and pipelines this context keeps for reuse (at most
    /// [`crate::made::MADE_CAP`] of each kind).
    pub fn made_objects(&self) -> usize {
        self.made.len()
    }

    pub(crate) fn made(&self) -> &Arc<Made> {
        &self.made
    }

    /// The adapter for results.json.
    pub fn adapter_info(&self) -> AdapterSummary {
        AdapterSummary::new(&self.info)
    }

    /// The raw wgpu adapter info.
    pub fn wgpu_adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// Bind group layout 0 of every scene pipeline (camera uniform, material table, texels and
    /// the per-draw material uniform at a dynamic offset), shared
    /// so that pipelines do not depend on which scene is uploaded.
    pub fn scene_layout(&self) -> &wgpu::BindGroupLayout {
        &self.scene_layout
    }

    /// Blocks until all submitted work is done.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .map(|_| ())
            .map_err(|e| GpuError::Poll(e.to_string()))
    }

    /// Creates a shader module from a pass file, resolving `#include` lines against the
    /// shared modules (see [`crate::shaders`]).
    pub fn shader(&self, name: &str, source: &str) -> Result<wgpu::ShaderModule, GpuError> {
        self.shader_with(name, source, &[])
    }

    /// [`Context::shader`] with a technique's own WGSL: `#include "NAME"` resolves in
    /// `libraries` first (the technique crate's `SHADERS`), then in the shared modules
    /// ([`crate::shaders::resolve`]).
    pub fn shader_with(
        &self,
        name: &str,
        source: &str,
        libraries: &[&[(&str, &str)]],
    ) -> Result<wgpu::ShaderModule, GpuError> {
        let resolve = |n: &str| crate::shaders::resolve(n, libraries).map(str::to_owned);
        let include_error = |e: crate::shaders::IncludeError| GpuError::Shader {
            shader: name.to_owned(),
            message: e.to_string(),
        };
        let code = crate::shaders::compose(source, &resolve).map_err(include_error)?;
        let module = self.made.module(name, &code);
        let mut forms = self.per_draw.lock().unwrap_or_else(|e| e.into_inner());
        if forms.contains_key(&module) {
            // Made before from the same source: its per-draw forms are known.
            return Ok(module);
        }
        let per_draw = |textured, lit| {
            crate::shaders::compose_per_draw(source, &resolve, textured, lit)
                .transpose()
                .map_err(include_error)
        };
        if let (Some(a), Some(b), Some(c)) = (
            per_draw(false, false)?,
            per_draw(true, false)?,
            per_draw(true, true)?,
        ) {
            forms.insert(
                module.clone(),
                Arc::new(PerDrawForm {
                    name: format!("{name} (per-draw material)"),
                    code: [a, b, c],
                    modules: Default::default(),
                }),
            );
        }
        Ok(module)
    }

    /// How many scene pass modules the per-draw table holds: one per scene pass source made
    /// on this context, however many techniques were built from it.
    pub fn shader_forms(&self) -> usize {
        self.per_draw
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .len()
    }

    /// The per-draw form of a scene pass module made by [`Context::shader_with`]
    /// (shaders/scene_io/draw.wgsl in place of the per-vertex interface); `None` for a module
    /// without the scene pass interface.
    pub(crate) fn per_draw_form(&self, module: &wgpu::ShaderModule) -> Option<Arc<PerDrawForm>> {
        self.per_draw
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(module)
            .cloned()
    }
}
