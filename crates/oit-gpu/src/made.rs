//! Shader modules, layouts and pipelines made once per context and handed out again.
//!
//! Techniques are built afresh for every scene, and every test builds its own; each build asked
//! the driver for the same pipelines again. On lavapipe (Mesa 22.3.6) a pipeline costs its
//! SPIR-V translation and NIR optimisation on every creation, even when Mesa's disk cache
//! already holds the machine code: 2026-12-07, the random mixed-operator scenes' GPU test spent
//! 90 % of its time in `create_render_pipeline`. Here equal descriptions get the same object:
//! bind group layouts by their entries, pipeline layouts by their groups, modules by their
//! source, pipelines by everything they were made from (labels aside).
//!
//! An object the device reported an error for is never kept: it is made again outside the
//! capture, so the error reaches the caller's error scope ([`crate::Context::contain`]) or the
//! device's handler as it would have without the table. Each table holds at most
//! [`MADE_CAP`] objects (what is in use stays alive with its users).

use std::collections::HashMap;
use std::hash::Hash;
use std::num::NonZeroU32;
use std::sync::Mutex;

/// Most objects of one kind a context keeps for reuse; when full, the least recently used half
/// goes. A lavapipe pipeline holds about 1.7 MB (its NIR and compiled code), so this bounds
/// what the table adds to a context's memory (about 0.9 GB there). Measured 2026-12-07 on the
/// mixed-operator random scenes' GPU test (about 700 distinct pipelines: scene pass variants
/// × techniques): 132 s and 1.8 GB peak without the table, 56 s and 2.5 GB with 512, 45 s and
/// 3.0 GB with 1024.
pub const MADE_CAP: usize = 512;

/// A shader stage as a pipeline uses it.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct StageKey {
    module: wgpu::ShaderModule,
    entry_point: Option<String>,
    /// Name and bits of each override constant.
    constants: Vec<(String, u64)>,
    zero_initialize_workgroup_memory: bool,
}

impl StageKey {
    fn new(
        module: &wgpu::ShaderModule,
        entry_point: Option<&str>,
        options: &wgpu::PipelineCompilationOptions<'_>,
    ) -> Self {
        StageKey {
            module: module.clone(),
            entry_point: entry_point.map(str::to_owned),
            constants: (options.constants.iter())
                .map(|&(name, value)| (name.to_owned(), value.to_bits()))
                .collect(),
            zero_initialize_workgroup_memory: options.zero_initialize_workgroup_memory,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct RenderKey {
    layout: wgpu::PipelineLayout,
    vertex: StageKey,
    buffers: Vec<Option<(u64, wgpu::VertexStepMode, Vec<wgpu::VertexAttribute>)>>,
    primitive: wgpu::PrimitiveState,
    depth_stencil: Option<wgpu::DepthStencilState>,
    multisample: wgpu::MultisampleState,
    fragment: Option<(StageKey, Vec<Option<wgpu::ColorTargetState>>)>,
    multiview_mask: Option<NonZeroU32>,
}

impl RenderKey {
    /// `None` where the description cannot be keyed: an implicit layout (each pipeline gets its
    /// own) or a driver pipeline cache.
    fn of(desc: &wgpu::RenderPipelineDescriptor<'_>) -> Option<Self> {
        if desc.cache.is_some() {
            return None;
        }
        Some(RenderKey {
            layout: desc.layout?.clone(),
            vertex: StageKey::new(
                desc.vertex.module,
                desc.vertex.entry_point,
                &desc.vertex.compilation_options,
            ),
            buffers: (desc.vertex.buffers.iter())
                .map(|b| {
                    b.as_ref()
                        .map(|b| (b.array_stride, b.step_mode, b.attributes.to_vec()))
                })
                .collect(),
            primitive: desc.primitive,
            depth_stencil: desc.depth_stencil.clone(),
            multisample: desc.multisample,
            fragment: desc.fragment.as_ref().map(|f| {
                (
                    StageKey::new(f.module, f.entry_point, &f.compilation_options),
                    f.targets.to_vec(),
                )
            }),
            multiview_mask: desc.multiview_mask,
        })
    }
}

#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct ComputeKey {
    layout: wgpu::PipelineLayout,
    stage: StageKey,
}

/// One kind of object by key, each with the time it was last handed out.
#[derive(Debug)]
struct Table<K, V> {
    entries: HashMap<K, (V, u64)>,
}

impl<K, V> Default for Table<K, V> {
    fn default() -> Self {
        Table {
            entries: HashMap::new(),
        }
    }
}

#[derive(Debug, Default)]
struct Tables {
    /// Counts hand-outs, the clock of `Table`'s last uses.
    clock: u64,
    bind_group_layouts: Table<Vec<wgpu::BindGroupLayoutEntry>, wgpu::BindGroupLayout>,
    pipeline_layouts: Table<(Vec<Option<wgpu::BindGroupLayout>>, u32), wgpu::PipelineLayout>,
    modules: Table<String, wgpu::ShaderModule>,
    render_pipelines: Table<RenderKey, wgpu::RenderPipeline>,
    compute_pipelines: Table<ComputeKey, wgpu::ComputePipeline>,
}

/// The context's tables (see the module docs).
#[derive(Debug)]
pub(crate) struct Made {
    device: wgpu::Device,
    tables: Mutex<Tables>,
}

impl Made {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        Made {
            device: device.clone(),
            tables: Mutex::default(),
        }
    }

    /// `table[key]`, or `make()` kept there when the device reported no error for it.
    fn get_or_make<K: Hash + Eq, V: Clone>(
        &self,
        table: impl Fn(&mut Tables) -> &mut Table<K, V>,
        key: K,
        make: impl Fn() -> V,
    ) -> V {
        {
            let mut tables = self.lock();
            tables.clock += 1;
            let now = tables.clock;
            if let Some((v, used)) = table(&mut tables).entries.get_mut(&key) {
                *used = now;
                return v.clone();
            }
        }
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let value = make();
        let failed = [internal.pop(), memory.pop(), validation.pop()]
            .into_iter()
            .any(|e| pollster::block_on(e).is_some());
        if failed {
            // Again, where the caller's scope (or the device's handler) sees the error.
            return make();
        }
        let mut tables = self.lock();
        let now = tables.clock;
        let t = &mut table(&mut tables).entries;
        if t.len() >= MADE_CAP {
            // The least recently used half goes (what is in use stays alive with its users).
            let mut uses: Vec<u64> = t.values().map(|&(_, used)| used).collect();
            uses.sort_unstable();
            let median = uses[uses.len() / 2];
            t.retain(|_, &mut (_, used)| used > median);
        }
        t.entry(key).or_insert((value, now)).0.clone()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Tables> {
        self.tables.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub(crate) fn bind_group_layout(
        &self,
        desc: &wgpu::BindGroupLayoutDescriptor<'_>,
    ) -> wgpu::BindGroupLayout {
        self.get_or_make(
            |t| &mut t.bind_group_layouts,
            desc.entries.to_vec(),
            || self.device.create_bind_group_layout(desc),
        )
    }

    pub(crate) fn pipeline_layout(
        &self,
        desc: &wgpu::PipelineLayoutDescriptor<'_>,
    ) -> wgpu::PipelineLayout {
        let groups = (desc.bind_group_layouts.iter())
            .map(|g| g.cloned())
            .collect();
        self.get_or_make(
            |t| &mut t.pipeline_layouts,
            (groups, desc.immediate_size),
            || self.device.create_pipeline_layout(desc),
        )
    }

    /// The module of WGSL `code` (`label` names it in the driver's messages).
    pub(crate) fn module(&self, label: &str, code: &str) -> wgpu::ShaderModule {
        self.get_or_make(
            |t| &mut t.modules,
            code.to_owned(),
            || {
                self.device
                    .create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some(label),
                        source: wgpu::ShaderSource::Wgsl(code.into()),
                    })
            },
        )
    }

    pub(crate) fn render_pipeline(
        &self,
        desc: &wgpu::RenderPipelineDescriptor<'_>,
    ) -> wgpu::RenderPipeline {
        match RenderKey::of(desc) {
            Some(key) => self.get_or_make(
                |t| &mut t.render_pipelines,
                key,
                || self.device.create_render_pipeline(desc),
            ),
            None => self.device.create_render_pipeline(desc),
        }
    }

    pub(crate) fn compute_pipeline(
        &self,
        desc: &wgpu::ComputePipelineDescriptor<'_>,
    ) -> wgpu::ComputePipeline {
        let key = match (desc.layout, desc.cache) {
            (Some(layout), None) => ComputeKey {
                layout: layout.clone(),
                stage: StageKey::new(desc.module, desc.entry_point, &desc.compilation_options),
            },
            _ => return self.device.create_compute_pipeline(desc),
        };
        self.get_or_make(
            |t| &mut t.compute_pipelines,
            key,
            || self.device.create_compute_pipeline(desc),
        )
    }

    /// How many objects the tables hold, all kinds together.
    pub(crate) fn len(&self) -> usize {
        let t = self.lock();
        t.bind_group_layouts.entries.len()
            + t.pipeline_layouts.entries.len()
            + t.modules.entries.len()
            + t.render_pipelines.entries.len()
            + t.compute_pipelines.entries.len()
    }
}
