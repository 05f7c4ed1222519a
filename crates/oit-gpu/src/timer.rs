//! GPU time per pass: timestamp queries where the adapter has them, wall-clock otherwise.
//!
//! Usage inside a technique, for every pass:
//!
//! ```text
//! let ts = timer.pass("blend");
//! let mut enc = ctx.device.create_command_encoder(&Default::default());
//! { let pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor { timestamp_writes: &ts, .. }); … }
//! timer.submit(ctx, enc);
//! ```
//!
//! With timestamps, `submit` only submits and the frame's queries are resolved in
//! [`GpuTimer::end_frame`]. Without, `submit` waits for the GPU and the elapsed wall-clock time
//! (submit to completion) is attributed to the passes begun since the previous submit, so a
//! technique that submits once per pass gets per-pass wall-clock times.
//!
//! A timer made with [`GpuTimer::counting_fragments`] also hands every render pass an occlusion
//! query slot ([`crate::pass::begin`] begins and ends it), and [`GpuTimer::pass_fragments`]
//! then says, per pass, how many samples passed the depth test (and were not discarded). The
//! harness counts in a frame of its own, never in a timed one (see `oit-harness`'s `counts`).

use crate::context::Context;
use crate::error::GpuError;
use std::time::Instant;

/// Where the numbers come from; serialized as results.json's `gpu_ms.source`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum TimingSource {
    #[serde(rename = "timestamp")]
    Timestamp,
    #[serde(rename = "wall-clock")]
    WallClock,
}

impl TimingSource {
    pub fn name(self) -> &'static str {
        match self {
            TimingSource::Timestamp => "timestamp",
            TimingSource::WallClock => "wall-clock",
        }
    }
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PassTiming {
    pub name: String,
    pub ms: f64,
}

/// Timings of one frame.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FrameTimings {
    pub source: TimingSource,
    /// Sum of the passes (GPU busy time; idle gaps such as CPU sorting are excluded).
    pub total_ms: f64,
    pub passes: Vec<PassTiming>,
    /// Wall-clock from `begin_frame` to the end of `end_frame` (includes CPU work and waits).
    pub wall_ms: f64,
}

/// Timestamp writes for one pass (`writes()` is `None` in wall-clock mode), and, on a counting
/// timer, the pass's occlusion query slot.
#[derive(Debug, Clone)]
pub struct PassTimestamps {
    query_set: Option<wgpu::QuerySet>,
    begin: u32,
    occlusion: Option<OcclusionSlot>,
}

/// One pass's occlusion query; `begun` is set when a render pass begins it, so a pass that
/// never did (a compute pass, or a render pass begun without [`crate::pass::begin`]) reads as
/// "not counted" rather than as the zero wgpu resolves an unwritten query to.
#[derive(Debug, Clone)]
pub(crate) struct OcclusionSlot {
    pub(crate) set: wgpu::QuerySet,
    pub(crate) index: u32,
    pub(crate) begun: std::sync::Arc<std::sync::atomic::AtomicBool>,
}

impl PassTimestamps {
    /// No timestamps and no occlusion query: for passes that are not the timed work (a clear).
    pub fn untimed() -> Self {
        PassTimestamps {
            query_set: None,
            begin: 0,
            occlusion: None,
        }
    }

    /// The occlusion slot of a counting timer's pass, marked as begun.
    pub(crate) fn begin_occlusion(&self) -> Option<(&wgpu::QuerySet, u32)> {
        self.occlusion.as_ref().map(|slot| {
            slot.begun.store(true, std::sync::atomic::Ordering::Relaxed);
            (&slot.set, slot.index)
        })
    }

    pub fn writes(&self) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        self.query_set
            .as_ref()
            .map(|q| wgpu::RenderPassTimestampWrites {
                query_set: q,
                beginning_of_pass_write_index: Some(self.begin),
                end_of_pass_write_index: Some(self.begin + 1),
            })
    }

    pub fn compute_writes(&self) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.query_set
            .as_ref()
            .map(|q| wgpu::ComputePassTimestampWrites {
                query_set: q,
                beginning_of_pass_write_index: Some(self.begin),
                end_of_pass_write_index: Some(self.begin + 1),
            })
    }
}

/// Passes timed by one query set (two queries each). A frame that times more gets further sets:
/// a frame has no pass limit (depth peeling records one pass per layer, thousands on deep
/// scenes); wgpu caps one set at `wgpu::QUERY_SET_MAX_QUERIES` (4096) queries.
pub const PASSES_PER_QUERY_SET: u32 = 512;

/// One query set with its resolve and readback buffers.
#[derive(Debug)]
struct QueryChunk {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
}

impl QueryChunk {
    fn new(device: &wgpu::Device) -> Self {
        let count = PASSES_PER_QUERY_SET * 2;
        let bytes = u64::from(count) * 8;
        QueryChunk {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp readback"),
                size: bytes,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
        }
    }
}

/// Occlusion queries per query set: wgpu's most.
const OCCLUSION_PER_QUERY_SET: u32 = wgpu::QUERY_SET_MAX_QUERIES;

/// One occlusion query set with its resolve and readback buffers (8 bytes a query).
#[derive(Debug)]
struct OcclusionChunk {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
}

impl OcclusionChunk {
    fn new(device: &wgpu::Device) -> Self {
        let bytes = u64::from(OCCLUSION_PER_QUERY_SET) * 8;
        OcclusionChunk {
            set: device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass occlusion"),
                ty: wgpu::QueryType::Occlusion,
                count: OCCLUSION_PER_QUERY_SET,
            }),
            resolve: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("occlusion resolve"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("occlusion readback"),
                size: bytes,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
        }
    }
}

/// Occlusion queries of a counting timer: one slot per registered pass of the frame.
#[derive(Debug)]
struct Occlusion {
    chunks: Vec<OcclusionChunk>,
    device: wgpu::Device,
    /// The frame's passes in order, with whether each began its query.
    passes: Vec<(String, std::sync::Arc<std::sync::atomic::AtomicBool>)>,
    /// The last frame's counts, filled by `end_frame`.
    last: Vec<PassFragments>,
}

/// Whether occlusion queries count samples on this backend. wgpu 30 makes them boolean
/// (any sample passed: 0 or 1) on GL (`ANY_SAMPLES_PASSED_CONSERVATIVE`), DX12
/// (`BINARY_OCCLUSION`) and Metal (`MTLVisibilityResultModeBoolean`); on Vulkan they count,
/// begun without `VK_QUERY_CONTROL_PRECISE_BIT`, which a driver may count coarsely (lavapipe
/// counts exactly: tests/gpu/gpu/occlusion.rs checks it on whatever adapter runs the tests).
pub fn occlusion_counts_samples(caps: &crate::Caps) -> bool {
    caps.backend == wgpu::Backend::Vulkan
}

/// Samples of one pass that passed the depth test and were not discarded (an occlusion
/// query's count: fragments on a single-sampled target, samples on a multisampled one);
/// `None` for a pass that began no query (a compute pass).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct PassFragments {
    pub name: String,
    pub samples: Option<u64>,
}

#[derive(Debug)]
struct Queries {
    /// Grown on demand, kept across frames.
    chunks: Vec<QueryChunk>,
    /// For creating further chunks inside `pass` (which has no context argument).
    device: wgpu::Device,
    period_ns: f64,
}

#[derive(Debug)]
pub struct GpuTimer {
    queries: Option<Queries>,
    names: Vec<String>,
    /// Wall-clock mode: passes begun since the last submit.
    pending: Vec<String>,
    wall: Vec<PassTiming>,
    frame_start: Option<Instant>,
    /// Past this moment every submission fails with [`GpuError::OverBudget`]: a run's time
    /// budget, enforced between submissions (a runaway technique, such as thousands of peel
    /// passes, stops at its next submission instead of running until killed).
    deadline: Option<(Instant, f64)>,
    occlusion: Option<Occlusion>,
}

impl GpuTimer {
    /// Timestamps when the device has `TIMESTAMP_QUERY`, wall-clock otherwise.
    pub fn new(ctx: &Context) -> Self {
        if ctx.caps.timestamps {
            Self::with_timestamps(ctx)
        } else {
            Self::wall_clock()
        }
    }

    /// Forces wall-clock timing (submit + wait per submission).
    pub fn wall_clock() -> Self {
        GpuTimer {
            queries: None,
            names: Vec::new(),
            pending: Vec::new(),
            wall: Vec::new(),
            frame_start: None,
            deadline: None,
            occlusion: None,
        }
    }

    /// This timer also counts, per pass, the samples that pass the depth test (occlusion
    /// queries); read them with [`GpuTimer::pass_fragments`] after `end_frame`. They are counts
    /// only where [`occlusion_counts_samples`]; elsewhere 0 or 1.
    pub fn counting_fragments(mut self, ctx: &Context) -> Self {
        self.occlusion = Some(Occlusion {
            chunks: vec![OcclusionChunk::new(&ctx.device)],
            device: ctx.device.clone(),
            passes: Vec::new(),
            last: Vec::new(),
        });
        self
    }

    /// Per pass of the last frame, the occlusion count; `None` unless the timer counts.
    pub fn pass_fragments(&self) -> Option<&[PassFragments]> {
        self.occlusion.as_ref().map(|o| o.last.as_slice())
    }

    fn occlusion_slot(&mut self, name: &str) -> Option<OcclusionSlot> {
        let o = self.occlusion.as_mut()?;
        let index = o.passes.len() as u32;
        let chunk = (index / OCCLUSION_PER_QUERY_SET) as usize;
        while o.chunks.len() <= chunk {
            o.chunks.push(OcclusionChunk::new(&o.device));
        }
        let begun = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        o.passes.push((name.to_owned(), begun.clone()));
        Some(OcclusionSlot {
            set: o.chunks[chunk].set.clone(),
            index: index % OCCLUSION_PER_QUERY_SET,
            begun,
        })
    }

    /// Resolves and reads the frame's occlusion queries into `last` (waits for the GPU).
    fn resolve_occlusion(&mut self, ctx: &Context) -> Result<(), GpuError> {
        let Some(o) = self.occlusion.as_mut() else {
            return Ok(());
        };
        let n = o.passes.len() as u32;
        let used = n.div_ceil(OCCLUSION_PER_QUERY_SET) as usize;
        let in_chunk =
            |i: usize| (n - i as u32 * OCCLUSION_PER_QUERY_SET).min(OCCLUSION_PER_QUERY_SET);
        let mut counts: Vec<u64> = Vec::with_capacity(n as usize);
        if n > 0 {
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            for (i, chunk) in o.chunks[..used].iter().enumerate() {
                let queries = in_chunk(i);
                enc.resolve_query_set(&chunk.set, 0..queries, &chunk.resolve, 0);
                enc.copy_buffer_to_buffer(
                    &chunk.resolve,
                    0,
                    &chunk.readback,
                    0,
                    u64::from(queries) * 8,
                );
            }
            ctx.queue.submit([enc.finish()]);
            for (i, chunk) in o.chunks[..used].iter().enumerate() {
                let queries = in_chunk(i) as usize;
                let bytes = crate::readback::read_buffer(ctx, &chunk.readback, "occlusion counts")?;
                for b in bytes.chunks_exact(8).take(queries) {
                    let word: [u8; 8] = b.try_into().map_err(|_| {
                        GpuError::Mismatch("an occlusion count is not 8 bytes".into())
                    })?;
                    counts.push(u64::from_le_bytes(word));
                }
            }
        }
        o.last = std::mem::take(&mut o.passes)
            .into_iter()
            .zip(counts)
            .map(|((name, begun), samples)| PassFragments {
                name,
                samples: begun
                    .load(std::sync::atomic::Ordering::Relaxed)
                    .then_some(samples),
            })
            .collect();
        Ok(())
    }

    /// Makes submissions fail with [`GpuError::OverBudget`] once `budget` has passed from now
    /// (`None` lifts the limit).
    pub fn set_budget(&mut self, budget: Option<std::time::Duration>) {
        self.deadline = budget.map(|b| (Instant::now() + b, b.as_secs_f64()));
    }

    fn check_budget(&self) -> Result<(), GpuError> {
        match self.deadline {
            Some((at, seconds)) if Instant::now() >= at => Err(GpuError::OverBudget { seconds }),
            _ => Ok(()),
        }
    }

    fn with_timestamps(ctx: &Context) -> Self {
        GpuTimer {
            queries: Some(Queries {
                chunks: vec![QueryChunk::new(&ctx.device)],
                device: ctx.device.clone(),
                period_ns: f64::from(ctx.queue.get_timestamp_period()),
            }),
            ..Self::wall_clock()
        }
    }

    pub fn source(&self) -> TimingSource {
        if self.queries.is_some() {
            TimingSource::Timestamp
        } else {
            TimingSource::WallClock
        }
    }

    /// Starts a frame (forgets the previous frame's passes).
    pub fn begin_frame(&mut self) {
        self.names.clear();
        self.pending.clear();
        self.wall.clear();
        if let Some(o) = self.occlusion.as_mut() {
            o.passes.clear();
            o.last.clear();
        }
        self.frame_start = Some(Instant::now());
    }

    /// Registers a pass; put `writes()` into its descriptor.
    pub fn pass(&mut self, name: &str) -> PassTimestamps {
        let occlusion = self.occlusion_slot(name);
        match &mut self.queries {
            Some(q) => {
                let index = self.names.len() as u32;
                let chunk = (index / PASSES_PER_QUERY_SET) as usize;
                while q.chunks.len() <= chunk {
                    q.chunks.push(QueryChunk::new(&q.device));
                }
                self.names.push(name.to_owned());
                PassTimestamps {
                    query_set: Some(q.chunks[chunk].set.clone()),
                    begin: index % PASSES_PER_QUERY_SET * 2,
                    occlusion,
                }
            }
            None => {
                self.pending.push(name.to_owned());
                PassTimestamps {
                    query_set: None,
                    begin: 0,
                    occlusion,
                }
            }
        }
    }

    /// Submits a technique's work. In wall-clock mode this waits for completion.
    pub fn submit(&mut self, ctx: &Context, encoder: wgpu::CommandEncoder) -> Result<(), GpuError> {
        self.check_budget()?;
        if self.queries.is_some() {
            ctx.queue.submit([encoder.finish()]);
            return Ok(());
        }
        let commands = encoder.finish();
        let t0 = Instant::now();
        ctx.queue.submit([commands]);
        ctx.wait()?;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let name = if self.pending.is_empty() {
            "(untimed work)".to_owned()
        } else {
            self.pending.join(" + ")
        };
        self.pending.clear();
        self.wall.push(PassTiming { name, ms });
        Ok(())
    }

    /// Submits work that is not part of the timed frame (a statistic a technique gathers about
    /// its own frame, such as a count). It runs after the passes submitted before it; in
    /// wall-clock mode this waits for it, so its time goes to no pass.
    pub fn submit_untimed(
        &mut self,
        ctx: &Context,
        encoder: wgpu::CommandEncoder,
    ) -> Result<(), GpuError> {
        self.check_budget()?;
        ctx.queue.submit([encoder.finish()]);
        if self.queries.is_none() {
            ctx.wait()?;
        }
        Ok(())
    }

    /// Resolves the frame's timings (waits for the GPU).
    pub fn end_frame(&mut self, ctx: &Context) -> Result<FrameTimings, GpuError> {
        let start = self.frame_start.take().unwrap_or_else(Instant::now);
        let passes = match &self.queries {
            None => {
                ctx.wait()?;
                std::mem::take(&mut self.wall)
            }
            Some(q) => {
                let n = self.names.len() as u32;
                if n == 0 {
                    ctx.wait()?;
                    Vec::new()
                } else {
                    let used = n.div_ceil(PASSES_PER_QUERY_SET) as usize;
                    // Passes timed by chunk i (all but the last are full).
                    let in_chunk =
                        |i: usize| (n - i as u32 * PASSES_PER_QUERY_SET).min(PASSES_PER_QUERY_SET);
                    let mut enc = ctx.device.create_command_encoder(&Default::default());
                    for (i, chunk) in q.chunks[..used].iter().enumerate() {
                        let passes = in_chunk(i);
                        enc.resolve_query_set(&chunk.set, 0..passes * 2, &chunk.resolve, 0);
                        enc.copy_buffer_to_buffer(
                            &chunk.resolve,
                            0,
                            &chunk.readback,
                            0,
                            u64::from(passes) * 16,
                        );
                    }
                    ctx.queue.submit([enc.finish()]);
                    let mut ticks: Vec<u64> = Vec::with_capacity(n as usize * 2);
                    for (i, chunk) in q.chunks[..used].iter().enumerate() {
                        let passes = in_chunk(i);
                        let bytes =
                            crate::readback::read_buffer(ctx, &chunk.readback, "timestamps")?;
                        ticks.extend(
                            bytes
                                .chunks_exact(8)
                                .take(passes as usize * 2)
                                .map(|b| u64::from_le_bytes(b.try_into().unwrap_or([0; 8]))),
                        );
                    }
                    self.names
                        .iter()
                        .zip(ticks.chunks_exact(2))
                        .map(|(name, t)| PassTiming {
                            name: name.clone(),
                            ms: t[1].saturating_sub(t[0]) as f64 * q.period_ns / 1e6,
                        })
                        .collect()
                }
            }
        };
        self.resolve_occlusion(ctx)?;
        let total_ms = passes.iter().map(|p| p.ms).sum();
        Ok(FrameTimings {
            source: self.source(),
            total_ms,
            passes,
            wall_ms: start.elapsed().as_secs_f64() * 1e3,
        })
    }
}
