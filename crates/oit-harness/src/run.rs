//! The comparison loop: for each scene, the reference (cached) and the floor, then for each
//! technique a first untimed frame, warm-up frames, timed frames, readback, metrics, the
//! reversed-order render, and reports.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use oit_gpu::{
    ColorFormat, Context, ContextOptions, GpuScene, GpuTimer, Targets, Technique, TechniqueSpec,
    read_color, render_frame,
};
use oit_scene::{LinearImage, Resolution, Scene};

use crate::results::{
    FloorJson, Outputs, Results, Run, RunInputs, RunStatus, SCHEMA, Stats, TargetFormat, ToolJson,
};
use crate::resume::ResumeCount;
use crate::timing::{PassEstimate, time_frames, time_unbudgeted};
use crate::{HarnessError, SceneEntry, Unloadable, at_resolution, file_stem, registry};

/// Where `compare` keeps computed references.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ReferenceCache {
    /// [`crate::cache::default_dir`].
    Default,
    /// This folder.
    Dir(PathBuf),
    /// No cache: every reference is computed (`--no-cache`).
    Off,
}

/// How `compare` runs.
#[derive(Debug, Clone)]
pub struct CompareOptions {
    /// Overrides every scene's own resolution.
    pub resolution: Option<Resolution>,
    /// Timed frames per run (median, min and max are reported); at least 1.
    pub frames: u32,
    /// Untimed frames after the first (which is never timed: pipelines are built in it); at
    /// most [`MAX_WARMUP`].
    pub warmup: u32,
    pub out_dir: PathBuf,
    pub cache: ReferenceCache,
    /// Bytes of reference files the cache folder may hold; the least recently used go first,
    /// and a reference larger than this is not cached ([`crate::cache`]).
    pub cache_cap: u64,
    /// Host memory one scene may take, in bytes: the images of one run
    /// ([`crate::RUN_BYTES_PER_PIXEL`] a pixel) and the reference's fragments (the rest). A scene
    /// that cannot fit fails before anything is computed, and the comparison goes on.
    pub memory_budget: u64,
    /// Wall-clock time one run may take (all its frames): a technique's own pass estimate
    /// over it is skipped before it starts, a first frame that shows the run would go past
    /// it stops the run, and any submission past it fails.
    pub run_budget: Duration,
    /// Reuse the runs of `out_dir/results.json` made from identical inputs (see
    /// [`crate::results::RunInputs`]) instead of running them again, and keep its runs of
    /// other techniques and scenes.
    pub resume: bool,
    /// Times a run's frames again, up to this many times, while they were taken with more than
    /// [`NOTABLE`](crate::interference::NOTABLE) of the machine's CPU time going elsewhere
    /// (a judgeable window only); the quietest attempt is kept and says how many were made.
    pub retime: u32,
    /// Set it (from a Ctrl-C handler, say) to stop after the run in progress: what finished
    /// is written, and the results say they are incomplete.
    pub cancel: Option<Arc<AtomicBool>>,
    pub context: ContextOptions,
    /// Frames of an animated scene rendered for the motion measurements (all by default).
    pub animation_frames: crate::motion::FrameSelection,
    /// Times frame 0 of an animated scene is rendered at its static camera for bias and noise
    /// (0: not measured).
    pub static_frames: u32,
    /// Make only this shard's runs ([`crate::shard`]); `None` makes them all.
    pub shard: Option<crate::shard::Shard>,
    /// Predict every rendered run's exactness from the reference's per-pixel lists
    /// ([`crate::predict`]; renders each still scene's reference once more).
    pub predict: bool,
    /// The final colour targets every technique runs into, each a run of its own
    /// (`--target-format`); `[rgba16float]` by default. Every run is compared with the same
    /// exact reference, so the error a format costs shows beside a technique's own.
    pub target_formats: Vec<TargetFormat>,
}

/// Default of [`CompareOptions::run_budget`].
pub const DEFAULT_RUN_BUDGET: Duration = Duration::from_secs(300);

/// Default of [`CompareOptions::memory_budget`]: 4 GiB.
pub const DEFAULT_MEMORY_BUDGET: u64 = 4 << 30;

impl Default for CompareOptions {
    fn default() -> Self {
        CompareOptions {
            resolution: None,
            frames: 20,
            warmup: 3,
            out_dir: PathBuf::from("out"),
            cache: ReferenceCache::Default,
            cache_cap: crate::cache::DEFAULT_CAP,
            memory_budget: DEFAULT_MEMORY_BUDGET,
            run_budget: DEFAULT_RUN_BUDGET,
            resume: false,
            retime: 0,
            cancel: None,
            context: ContextOptions::default(),
            animation_frames: crate::motion::FrameSelection::ALL,
            static_frames: crate::motion::DEFAULT_STATIC_FRAMES,
            shard: None,
            predict: true,
            target_formats: vec![TargetFormat::default()],
        }
    }
}

/// What `compare` reports while it works.
#[derive(Debug, Clone, Copy)]
pub enum Event<'a> {
    /// A run is done (rendered, skipped, failed, or taken from the earlier results).
    RunDone {
        scene: &'a str,
        technique: &'a str,
        resumed: bool,
    },
    /// One line people must see because something went wrong or was not trusted (e.g. a
    /// cached reference recomputed, a scene that failed).
    Warning(&'a str),
    /// One line that says what the comparison did with earlier results.
    Notice(&'a str),
    /// A frame of an animated scene's path was measured for every technique.
    FrameDone {
        scene: &'a str,
        done: usize,
        of: usize,
    },
}

/// One rendered image and what it cost.
#[derive(Debug, Clone)]
pub struct RenderedFrame {
    pub image: LinearImage,
    pub stats: oit_gpu::RenderStats,
    pub timings: oit_gpu::FrameTimings,
    pub memory_bytes: u64,
}

pub(crate) fn build(spec: &TechniqueSpec) -> Result<Box<dyn Technique>, HarnessError> {
    Ok(TechniqueSpec::build(&spec.canonical(), &registry())?)
}

/// The GPU format of a target format as results.json names it.
pub fn color_format(format: TargetFormat) -> ColorFormat {
    match format {
        TargetFormat::Rgba8Unorm => ColorFormat::Rgba8Unorm,
        TargetFormat::Rgba16Float => ColorFormat::Rgba16Float,
        TargetFormat::Rgba32Float => ColorFormat::Rgba32Float,
    }
}

/// Renders one frame of `scene` with `spec` (after one warm-up frame) into the default final
/// target (`rgba16float`) and reads it back.
pub fn render_once(
    ctx: &Context,
    scene: &Scene,
    spec: &TechniqueSpec,
) -> Result<RenderedFrame, HarnessError> {
    render_once_at(ctx, scene, spec, TargetFormat::default())
}

/// [`render_once`] into a final target of `format`. A technique that cannot composite into
/// it is refused with [`oit_gpu::GpuError::Unsupported`] before anything is built.
pub fn render_once_at(
    ctx: &Context,
    scene: &Scene,
    spec: &TechniqueSpec,
    format: TargetFormat,
) -> Result<RenderedFrame, HarnessError> {
    let mut technique = build(spec)?;
    let gpu_scene = GpuScene::upload(ctx, scene)?;
    let targets = Targets::new(ctx, scene.resolution, color_format(format))?;
    technique
        .check_target(targets.color_format, &ctx.caps)
        .map_err(oit_gpu::GpuError::from)?;
    let mut timer = GpuTimer::new(ctx);
    render_frame(ctx, &gpu_scene, technique.as_mut(), &targets, &mut timer)?;
    let frame = render_frame(ctx, &gpu_scene, technique.as_mut(), &targets, &mut timer)?;
    let image = read_color(ctx, &targets)?;
    Ok(RenderedFrame {
        image,
        stats: frame.stats,
        timings: frame.timings,
        memory_bytes: technique.memory_bytes(),
    })
}

/// Runs every technique on every scene; writes `results.json`, `results.md` and per-run EXR
/// and PNG files under `options.out_dir`, and nothing outside it but the reference cache.
/// `results.json` and `results.md` are rewritten (atomically) after every run, so an
/// interrupted comparison keeps what it finished and `--resume` can continue it. Two
/// comparisons never share an output folder (a lock file), and no two scenes or techniques
/// share an output file.
pub fn compare(
    ctx: &Context,
    scenes: &[SceneEntry],
    specs: &[TechniqueSpec],
    options: &CompareOptions,
    on_event: &dyn Fn(Event<'_>),
) -> Result<Results, HarnessError> {
    compare_all(ctx, scenes, &[], specs, options, on_event)
}

/// [`compare`], with the scene files that failed to load: each gets a failed run per
/// technique with the loader's message, and the other scenes run as usual. A scene whose
/// reference or upload fails is reported the same way: one bad scene never ends a comparison.
pub fn compare_all(
    ctx: &Context,
    scenes: &[SceneEntry],
    unloadable: &[Unloadable],
    specs: &[TechniqueSpec],
    options: &CompareOptions,
    on_event: &dyn Fn(Event<'_>),
) -> Result<Results, HarnessError> {
    if options.frames == 0 {
        return Err(HarnessError::Options(
            "frames must be at least 1 (the timed frames of every run)".into(),
        ));
    }
    if options.warmup > MAX_WARMUP {
        return Err(HarnessError::Options(format!(
            "warmup {} is more than {MAX_WARMUP} frames per run",
            options.warmup
        )));
    }
    check_unique_outputs(scenes, specs)?;
    let out = &options.out_dir;
    std::fs::create_dir_all(out).map_err(|e| HarnessError::io(out, e))?;
    let _lock = OutputLock::acquire(out)?;
    oit_metrics::remove_stale_temporaries(out);
    // Read before anything is written: results.json is rewritten after every run.
    let earlier = earlier_results(out, ctx, options.resume)?;
    if let (Some(e), false) = (&earlier, options.resume) {
        on_event(Event::Notice(&format!(
            "{} holds the results of an earlier comparison ({} runs): replaced (--resume keeps them)",
            out.display(),
            e.runs.len()
        )));
    }
    let earlier = earlier.filter(|_| options.resume);
    let (mut earlier_runs, earlier_floors, earlier_scenes) = earlier.map_or_else(
        || (Vec::new(), Vec::new(), Vec::new()),
        |e| (e.runs, e.floors, e.scenes),
    );
    let mut resume = ResumeCount::default();
    let cache_dir = match &options.cache {
        ReferenceCache::Default => Some(crate::cache::default_dir()),
        ReferenceCache::Dir(d) => Some(d.clone()),
        ReferenceCache::Off => None,
    };
    let mut results = Results {
        schema: SCHEMA.to_owned(),
        tool: Some(ToolJson::current()),
        complete: false,
        adapter: crate::results::adapter_json(ctx),
        runs: Vec::new(),
        floors: Vec::new(),
        scenes: Vec::new(),
        shard: (options.shard)
            .map(|s| crate::shard::shard_json(s, scenes, unloadable, specs, options)),
        merged: Vec::new(),
    };
    if options.target_formats.is_empty() {
        return Err(HarnessError::Options(
            "no target format: every run needs one (--target-format)".into(),
        ));
    }
    let formats = &options.target_formats;
    let total = ((scenes.len() + unloadable.len()) * specs.len()) as u64;
    // The specs of scene `i` this comparison runs: all, or this shard's.
    let specs_of = |i: usize| -> Vec<TechniqueSpec> {
        match options.shard {
            Some(shard) => (shard.specs_of(i, specs, total).into_iter().cloned()).collect(),
            None => specs.to_vec(),
        }
    };
    let build = ToolJson::build_id();
    let cancelled = || {
        options
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed))
    };
    for (index, entry) in scenes.iter().enumerate() {
        let specs = &specs_of(index);
        if cancelled() {
            break;
        } else if specs.is_empty() {
            continue; // another shard's scene
        }
        let scene = at_resolution(&entry.scene, options.resolution);
        let scene_file = entry.path.display().to_string();
        let inputs = RunInputs {
            scene_hash: format!("{:016x}", scene.content_hash()),
            frames: options.frames,
            warmup: options.warmup,
            retime: options.retime,
            build: build.clone(),
            motion: entry
                .frames
                .as_ref()
                .map(|f| crate::motion::inputs(f, options)),
        };
        // Earlier runs of this scene: reused for requested techniques when made from the same
        // inputs, kept beside them for techniques not requested now.
        let (mine, others): (Vec<Run>, Vec<Run>) = std::mem::take(&mut earlier_runs)
            .into_iter()
            .partition(|r| r.scene == scene.name && r.resolution == res(&scene));
        earlier_runs = others;
        let (reusable_runs, stale): (Vec<Run>, Vec<Run>) = mine
            .into_iter()
            .partition(|r| reusable(r, &scene, &r.technique, &inputs, out));
        resume.dropped += stale.len();
        let first_run = results.runs.len();
        results
            .scenes
            .push(crate::results::scene_json(&scene, &scene_file));
        let earlier_floors_here: Vec<FloorJson> = earlier_floors
            .iter()
            .filter(|f| f.scene == scene.name && f.resolution == res(&scene))
            .cloned()
            .collect();
        let peak = crate::peak::ScenePeak::start();
        let scene_done = crate::isolate::contained(ctx, "the scene", || {
            run_scene(
                ctx,
                &scene,
                &scene_file,
                specs,
                &reusable_runs,
                &earlier_floors_here,
                &inputs,
                cache_dir.as_deref(),
                options,
                &mut results,
                &mut resume,
                &cancelled,
                on_event,
            )
        });
        if let Err(e) = scene_done {
            if matches!(e, HarnessError::Io { .. }) && is_under(&e, out) {
                // The output folder itself failed: nothing more can be written.
                return Err(e);
            }
            // Every requested run of the scene that did not finish fails with the scene's
            // error; the comparison goes on with the next scene.
            let message = format!("scene {} ({scene_file}): {e}", scene.name);
            on_event(Event::Warning(&message));
            for &format in formats {
                for spec in specs {
                    let canonical = spec.canonical();
                    if results.runs[first_run..]
                        .iter()
                        .any(|r| r.is(&canonical, format))
                    {
                        continue;
                    }
                    let mut run = Run::not_rendered(
                        &scene.name,
                        &scene_file,
                        &canonical,
                        res(&scene),
                        RunStatus::Failed,
                        message.clone(),
                    );
                    run.inputs = Some(inputs.clone());
                    run.target_format = format;
                    results.runs.push(run);
                    on_event(Event::RunDone {
                        scene: &scene.name,
                        technique: &canonical,
                        resumed: false,
                    });
                }
            }
            crate::vary::tag(&mut results.runs[first_run..], entry);
            crate::isolate::finish_scene(ctx, &mut results, peak);
            write_outputs(out, &mut results)?;
            continue;
        }
        if let Some(frames) = &entry.frames {
            for &format in formats.iter().filter(|_| !cancelled()) {
                motion_runs(
                    ctx,
                    frames,
                    &scene,
                    specs,
                    options,
                    format,
                    cache_dir.as_deref(),
                    &mut results.runs[first_run..],
                    on_event,
                )?;
            }
        }
        // Techniques (or target formats) of the earlier comparison that were not requested now
        // stay beside these runs: a comparison grows one technique at a time (a shard keeps
        // only its own runs).
        let requested: Vec<String> = specs.iter().map(TechniqueSpec::canonical).collect();
        let was_requested =
            |r: &Run| requested.contains(&r.technique) && formats.contains(&r.target_format);
        for mut run in reusable_runs
            .into_iter()
            .filter(|r| !was_requested(r) && options.shard.is_none())
        {
            run.resumed = true;
            run.scene_file.clone_from(&scene_file);
            resume.kept_unrequested += 1;
            results.runs.push(run);
        }
        let mut formats_here: Vec<TargetFormat> = Vec::new();
        for run in &results.runs[first_run..] {
            if !formats_here.contains(&run.target_format) {
                formats_here.push(run.target_format);
            }
        }
        for format in formats_here {
            if let Some(floor) =
                (results.floors.iter()).find(|f| f.scene == scene.name && f.target_format == format)
            {
                let floor_ms = floor.gpu_ms.median;
                fill_floor_costs(&mut results.runs[first_run..], format, floor_ms);
            }
            fill_costs(&mut results.runs[first_run..], format, || None);
        }
        crate::vary::tag(&mut results.runs[first_run..], entry);
        crate::isolate::finish_scene(ctx, &mut results, peak);
        write_outputs(out, &mut results)?;
    }
    let done = !cancelled();
    for (index, u) in unloadable.iter().enumerate().filter(|_| done) {
        let name = crate::shard::unloadable_name(u);
        let file = u.path.display().to_string();
        let message = format!("could not load {file}: {}", u.error);
        for &format in formats {
            for spec in &specs_of(scenes.len() + index) {
                let canonical = spec.canonical();
                let mut run = Run::not_rendered(
                    &name,
                    &file,
                    &canonical,
                    [0, 0],
                    RunStatus::Failed,
                    message.clone(),
                );
                run.target_format = format;
                results.runs.push(run);
                on_event(Event::RunDone {
                    scene: &name,
                    technique: &canonical,
                    resumed: false,
                });
            }
        }
    }
    if done && options.resume && options.shard.is_none() {
        // Scenes of the earlier comparison that were not part of this one stay, when the same
        // build made them (a shard keeps only its own).
        for run in std::mem::take(&mut earlier_runs) {
            if run.inputs.as_ref().is_some_and(|i| i.build == build) {
                if !results.scenes.iter().any(|s| s.scene == run.scene)
                    && let Some(s) = earlier_scenes.iter().find(|s| s.scene == run.scene)
                {
                    results.scenes.push(s.clone());
                }
                if !(results.floors.iter())
                    .any(|f| f.scene == run.scene && f.target_format == run.target_format)
                    && let Some(f) = (earlier_floors.iter())
                        .find(|f| f.scene == run.scene && f.target_format == run.target_format)
                {
                    results.floors.push(f.clone());
                }
                resume.kept_other_scenes += 1;
                results.runs.push(Run {
                    resumed: true,
                    ..run
                });
            } else {
                resume.dropped += 1;
            }
        }
    }
    if options.resume
        && let Some(line) = resume.describe()
    {
        on_event(Event::Notice(&line));
    }
    results.complete = done;
    write_outputs(out, &mut results)?;
    Ok(results)
}

/// The motion measurements of an animated scene, added to its rendered runs that have none
/// yet (runs taken from an earlier comparison keep theirs). A scene-level failure is a
/// warning: the still runs stand.
#[allow(clippy::too_many_arguments)] // the comparison's state, passed down once per scene
fn motion_runs(
    ctx: &Context,
    frames: &oit_scene::Frames,
    scene: &Scene,
    specs: &[TechniqueSpec],
    options: &CompareOptions,
    format: TargetFormat,
    cache_dir: Option<&Path>,
    runs: &mut [Run],
    on_event: &dyn Fn(Event<'_>),
) -> Result<(), HarnessError> {
    let wanted: Vec<TechniqueSpec> = specs
        .iter()
        .filter(|spec| {
            let canonical = spec.canonical();
            runs.iter().any(|r| {
                r.is(&canonical, format) && r.status == RunStatus::Ok && r.temporal.is_none()
            })
        })
        .cloned()
        .collect();
    if wanted.is_empty() {
        return Ok(());
    }
    let scene_dir = options.out_dir.join(file_stem(&scene.name));
    let measured = crate::isolate::contained(ctx, "the motion measurements", || {
        crate::motion::measure(
            ctx, frames, &wanted, options, format, cache_dir, &scene_dir, on_event,
        )
    });
    match measured {
        Ok(measured) => {
            for (canonical, temporal) in measured {
                if let (Some(run), Ok(temporal)) =
                    (runs.iter_mut().find(|r| r.is(&canonical, format)), temporal)
                {
                    run.temporal = Some(temporal);
                }
            }
            Ok(())
        }
        Err(e @ HarnessError::Io { .. }) if is_under(&e, &options.out_dir) => Err(e),
        Err(e) => {
            on_event(Event::Warning(&format!(
                "scene {}: no motion measurements: {e}",
                scene.name
            )));
            Ok(())
        }
    }
}

/// Most untimed warm-up frames a run may ask for: beyond this a run never ends in practice.
pub const MAX_WARMUP: u32 = 1000;

/// Whether `e` concerns a path inside `out`.
fn is_under(e: &HarnessError, out: &Path) -> bool {
    match e {
        HarnessError::Io { path, .. } => path.starts_with(out),
        _ => false,
    }
}

/// One scene of a comparison: its reference (cached), then per target format its floor (timed
/// first, so every run finished has its cost ratios even if the comparison is interrupted) and
/// each technique, with `results.json` written after every run.
#[allow(clippy::too_many_arguments)] // the comparison's state, passed down once per scene
fn run_scene(
    ctx: &Context,
    scene: &Scene,
    scene_file: &str,
    specs: &[TechniqueSpec],
    earlier: &[Run],
    earlier_floors: &[FloorJson],
    inputs: &RunInputs,
    cache_dir: Option<&Path>,
    options: &CompareOptions,
    results: &mut Results,
    resume: &mut ResumeCount,
    cancelled: &dyn Fn() -> bool,
    on_event: &dyn Fn(Event<'_>),
) -> Result<(), HarnessError> {
    let out = &options.out_dir;
    let reference = reference_of(scene, options, cache_dir, on_event)?;
    let lists = crate::predict::lists_for(scene, options, on_event);
    let mut held = crate::budget::scene_memory(scene, options, lists.as_ref())?;
    let scene_dir = out.join(file_stem(&scene.name));
    std::fs::create_dir_all(&scene_dir).map_err(|e| HarnessError::io(&scene_dir, e))?;
    oit_metrics::remove_stale_temporaries(&scene_dir);
    // The reference once per scene, for reports that show it beside every render, and its
    // per-pixel layer count as a picture.
    crate::write_reference_exr(&scene_dir.join("reference.exr"), &reference)?;
    oit_metrics::write_png_preview(&scene_dir.join("reference.png"), &reference.image)?;
    oit_metrics::write_png_srgb8(
        &scene_dir.join(crate::LAYERS_PNG),
        &oit_metrics::count_map(&reference.layers, scene.resolution.width),
    )?;
    let forward = GpuScene::upload(ctx, scene)?;
    let reversed = GpuScene::upload(ctx, &scene.with_reversed_order())?;
    let scene_gpu = SceneGpu {
        forward: &forward,
        reversed: &reversed,
        reference: &reference,
        lists: lists.as_ref(),
    };
    for &format in &options.target_formats {
        if cancelled() {
            break;
        }
        let targets = match Targets::new(ctx, scene.resolution, color_format(format)) {
            Ok(targets) => targets,
            // The default format fails the scene as it always did; another one the adapter
            // cannot render or blend into skips its runs, with the reason.
            Err(e) if !format.is_default() => {
                for spec in specs {
                    let canonical = spec.canonical();
                    let mut run = Run::not_rendered(
                        &scene.name,
                        scene_file,
                        &canonical,
                        res(scene),
                        RunStatus::Skipped,
                        format!("final colour target {format}: {e}"),
                    );
                    run.inputs = Some(inputs.clone());
                    run.target_format = format;
                    results.runs.push(run);
                    write_outputs(out, results)?;
                    on_event(Event::RunDone {
                        scene: &scene.name,
                        technique: &canonical,
                        resumed: false,
                    });
                }
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        held.targets = targets.memory_bytes();
        let floor = earlier_floors.iter().find(|f| f.target_format == format);
        run_format(
            ctx,
            scene,
            scene_file,
            specs,
            earlier,
            floor,
            inputs,
            options,
            (&scene_gpu, &targets, held, format),
            results,
            resume,
            cancelled,
            on_event,
        )?;
    }
    Ok(())
}

/// What every run of a scene shares: its uploads in submission order and reversed, its
/// reference and the reference's per-pixel lists (for the predictions).
struct SceneGpu<'a> {
    forward: &'a GpuScene,
    reversed: &'a GpuScene,
    reference: &'a oit_reference::Reference,
    lists: Option<&'a oit_gpu::predict::PixelLists>,
}

/// The runs of one scene into final targets of one format: the floor, `unsorted`'s time when
/// it is not among them, then each technique.
#[allow(clippy::too_many_arguments)] // the comparison's state, passed down once per format
fn run_format(
    ctx: &Context,
    scene: &Scene,
    scene_file: &str,
    specs: &[TechniqueSpec],
    earlier: &[Run],
    earlier_floor: Option<&FloorJson>,
    inputs: &RunInputs,
    options: &CompareOptions,
    (gpu, targets, held, format): (
        &SceneGpu<'_>,
        &Targets,
        crate::budget::RunMemory,
        TargetFormat,
    ),
    results: &mut Results,
    resume: &mut ResumeCount,
    cancelled: &dyn Fn() -> bool,
    on_event: &dyn Fn(Event<'_>),
) -> Result<(), HarnessError> {
    let out = &options.out_dir;
    let first_run = results.runs.len();
    let reused: Vec<&Run> = specs
        .iter()
        .filter_map(|spec| {
            let canonical = spec.canonical();
            earlier.iter().find(|r| r.is(&canonical, format))
        })
        .collect();
    let all_reused = reused.len() == specs.len();
    // The floor first: timed before any run, it gives each finished run its ratio at once.
    match earlier_floor.filter(|_| all_reused) {
        // Every run comes from the earlier comparison: its ratios and floor stand together.
        Some(floor) => results.floors.push(floor.clone()),
        None => {
            let mut floor = time_floor(ctx, scene, gpu.forward, targets, options)?;
            floor.target_format = format;
            results.floors.push(floor);
        }
    }
    let floor_ms = results
        .floors
        .last()
        .map(|f| f.gpu_ms.median)
        .unwrap_or(0.0);
    // `unsorted` is every cost's baseline: timed now when it is not among the runs.
    let unsorted_requested = specs.iter().any(|s| s.canonical() == "unsorted");
    let mut baseline_ms = None;
    if !unsorted_requested && !all_reused {
        let spec = TechniqueSpec::parse("unsorted", &registry())?;
        let mut t = build(&spec)?;
        baseline_ms = Some(
            time_unbudgeted(ctx, gpu.forward, t.as_mut(), targets, options)?
                .0
                .median,
        );
    }
    for spec in specs {
        if cancelled() {
            break;
        }
        let canonical = spec.canonical();
        let run = match earlier.iter().find(|r| r.is(&canonical, format)) {
            Some(run) => {
                resume.reused += 1;
                let mut run = run.clone();
                run.resumed = true;
                run.scene_file = scene_file.to_owned();
                run
            }
            None => {
                resume.made += 1;
                let mut run = crate::isolate::contained(ctx, "the run", || {
                    run_one(
                        ctx,
                        scene,
                        scene_file,
                        gpu,
                        targets,
                        spec,
                        options,
                        out,
                        (floor_ms, held, format),
                    )
                })
                .unwrap_or_else(|e| {
                    Run::not_rendered(
                        &scene.name,
                        scene_file,
                        &canonical,
                        res(scene),
                        RunStatus::Failed,
                        e.to_string(),
                    )
                });
                run.inputs = Some(inputs.clone());
                run.target_format = format;
                // The models predict a technique's arithmetic into a float target; an 8-bit
                // target's own rounding (up to ½ of 1/255 per blend) is not modelled.
                if !color_format(format).clamps() {
                    crate::predict::fill(&mut run, scene, gpu.lists, &ctx.caps);
                }
                run
            }
        };
        let was_resumed = run.resumed;
        results.runs.push(run);
        let runs = &mut results.runs[first_run..];
        fill_floor_costs(runs, format, floor_ms);
        fill_costs(runs, format, || baseline_ms);
        write_outputs(out, results)?;
        on_event(Event::RunDone {
            scene: &scene.name,
            technique: &canonical,
            resumed: was_resumed,
        });
    }
    Ok(())
}

/// The exact reference of `scene` within the memory budget, from the cache when it holds a
/// trustworthy one (a warning says when it did not).
pub(crate) fn reference_of(
    scene: &Scene,
    options: &CompareOptions,
    cache_dir: Option<&Path>,
    on_event: &dyn Fn(Event<'_>),
) -> Result<oit_reference::Reference, HarnessError> {
    let memory = crate::MemoryPlan::of(scene, options.memory_budget)?;
    let compute = || {
        Ok(oit_reference::try_render(
            scene,
            &oit_reference::ReferenceOptions {
                memory_budget: memory.reference_bytes,
                ..Default::default()
            },
        )?)
    };
    match cache_dir {
        Some(dir) => {
            let (reference, outcome) =
                crate::cache::reference(dir, scene, options.cache_cap, compute)?;
            if let Some(warning) = outcome.warning(&scene.name) {
                on_event(Event::Warning(&warning));
            }
            Ok(reference)
        }
        None => compute(),
    }
}

/// Refuses scenes or techniques whose outputs would land on the same files: one scene's
/// renders would silently replace another's.
fn check_unique_outputs(
    scenes: &[SceneEntry],
    specs: &[TechniqueSpec],
) -> Result<(), HarnessError> {
    let mut seen: Vec<(String, &SceneEntry)> = Vec::new();
    for entry in scenes {
        // Case-insensitive: some file systems fold case.
        let stem = file_stem(&entry.scene.name).to_lowercase();
        if let Some((_, first)) = seen
            .iter()
            .find(|(s, e)| *s == stem || e.scene.name == entry.scene.name)
        {
            return Err(HarnessError::Invalid {
                path: entry.path.clone(),
                message: format!(
                    "scene name `{}` would write to the same output folder as `{}` from {}; give every scene of a comparison its own `name`",
                    entry.scene.name,
                    first.scene.name,
                    first.path.display()
                ),
            });
        }
        seen.push((stem, entry));
    }
    let mut stems: Vec<(String, String)> = Vec::new();
    for spec in specs {
        let canonical = spec.canonical();
        let stem = file_stem(&canonical).to_lowercase();
        if let Some((_, first)) = stems.iter().find(|(s, _)| *s == stem) {
            return Err(HarnessError::Options(format!(
                "techniques `{first}` and `{canonical}` would write to the same files"
            )));
        }
        stems.push((stem, canonical));
    }
    Ok(())
}

/// The lock file that keeps two comparisons out of one output folder. Removed on drop; one left
/// by a process that no longer runs is taken over.
pub(crate) struct OutputLock {
    path: PathBuf,
}

/// The lock's file name inside the output folder (hidden: no stem starts with `.`).
pub const LOCK_FILE: &str = ".oit-compare.lock";

impl OutputLock {
    pub(crate) fn acquire(out: &Path) -> Result<OutputLock, HarnessError> {
        let path = out.join(LOCK_FILE);
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut file) => {
                    use std::io::Write;
                    let _ = write!(file, "{}", std::process::id());
                    return Ok(OutputLock { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let holder = std::fs::read_to_string(&path)
                        .ok()
                        .and_then(|t| t.trim().parse::<u32>().ok());
                    match holder {
                        Some(pid) if process_runs(pid) => {
                            return Err(HarnessError::Invalid {
                                path: out.to_path_buf(),
                                message: format!(
                                    "another `oit compare` or `oit merge` (pid {pid}) is writing to this folder; wait for it or choose another --out"
                                ),
                            });
                        }
                        // Left by a process that was killed: take it over.
                        _ => {
                            let _ = std::fs::remove_file(&path);
                        }
                    }
                }
                Err(e) => return Err(HarnessError::io(&path, e)),
            }
        }
        Err(HarnessError::Invalid {
            path: path.clone(),
            message: "could not take the output folder's lock".into(),
        })
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Whether a process with this id runs (Linux `/proc`; elsewhere every holder counts as alive,
/// so a stale lock there is removed by hand).
fn process_runs(pid: u32) -> bool {
    let proc_dir = Path::new("/proc");
    if !proc_dir.join("self").exists() {
        return true;
    }
    pid != std::process::id() && proc_dir.join(pid.to_string()).exists()
}

/// The earlier comparison in `out`: none when there is no results.json; an error when there
/// is one that is not an oit-lab results file (it is not ours to replace), or, with
/// `resume`, one made on another adapter (timings of two adapters do not mix).
fn earlier_results(
    out: &Path,
    ctx: &Context,
    resume: bool,
) -> Result<Option<Results>, HarnessError> {
    let path = out.join("results.json");
    if !path.exists() {
        return Ok(None);
    }
    let earlier = Results::read(&path).map_err(|e| HarnessError::Invalid {
        path: path.clone(),
        message: format!(
            "{}: not results this build of oit can read, so not replaced; move it away or choose another --out",
            match e {
                oit_results::ResultsError::Invalid { message, .. } => message,
                oit_results::ResultsError::Io { source, .. } => source.to_string(),
            }
        ),
    })?;
    let adapter = crate::results::adapter_json(ctx);
    if resume && earlier.adapter != adapter {
        return Err(HarnessError::Invalid {
            path,
            message: format!(
                "--resume: made on {} ({}), this comparison runs on {} ({}); timings of two adapters do not mix — choose another --out",
                earlier.adapter.name, earlier.adapter.backend, adapter.name, adapter.backend
            ),
        });
    }
    Ok(Some(earlier))
}

/// An earlier run stands for this one: same scene content, technique, resolution, frames,
/// warm-up and build of oit, it finished (a failed run is tried again) and its files are all
/// there.
fn reusable(run: &Run, scene: &Scene, canonical: &str, inputs: &RunInputs, out: &Path) -> bool {
    run.scene == scene.name
        && run.technique == canonical
        && run.resolution == res(scene)
        && run.inputs.as_ref() == Some(inputs)
        && match run.status {
            RunStatus::Ok => run.outputs.as_ref().is_some_and(|o| {
                [&o.exr, &o.render_png, &o.diff_png]
                    .iter()
                    .all(|f| out.join(f).is_file())
            }),
            RunStatus::Skipped => true,
            RunStatus::Failed => false,
        }
}

/// Times the scene's floor ([`oit_gpu::Floor`]) with the same frames and warm-up as a run.
fn time_floor(
    ctx: &Context,
    scene: &Scene,
    forward: &GpuScene,
    targets: &Targets,
    options: &CompareOptions,
) -> Result<FloorJson, HarnessError> {
    let mut floor = oit_gpu::Floor::new();
    let (gpu_ms, passes, _) = time_unbudgeted(ctx, forward, &mut floor, targets, options)?;
    Ok(FloorJson {
        scene: scene.name.clone(),
        resolution: res(scene),
        gpu_ms,
        passes,
        shard: options.shard.map(|s| s.index),
        target_format: TargetFormat::default(),
    })
}

/// Divides every ok run's median GPU time by the scene's floor.
fn fill_floor_costs(runs: &mut [Run], format: TargetFormat, floor_ms: f64) {
    if floor_ms <= 0.0 {
        return;
    }
    for run in (runs.iter_mut()).filter(|r| r.status == RunStatus::Ok && r.target_format == format)
    {
        run.cost_vs_floor = run.gpu_ms.as_ref().map(|g| g.median / floor_ms);
    }
}

fn res(scene: &Scene) -> [u32; 2] {
    [scene.resolution.width, scene.resolution.height]
}

#[allow(clippy::too_many_arguments)] // one run needs all of these; a struct would only rename them
fn run_one(
    ctx: &Context,
    scene: &Scene,
    scene_file: &str,
    gpu: &SceneGpu<'_>,
    targets: &Targets,
    spec: &TechniqueSpec,
    options: &CompareOptions,
    out: &Path,
    (floor_ms, held, format): (f64, crate::budget::RunMemory, TargetFormat),
) -> Result<Run, HarnessError> {
    let (forward, reversed, reference) = (gpu.forward, gpu.reversed, gpu.reference);
    let canonical = spec.canonical();
    let mut technique = build(spec)?;
    let checked = oit_gpu::check_scene(technique.as_ref(), &ctx.caps, scene)
        .and_then(|()| technique.check_target(targets.color_format, &ctx.caps));
    if let Err(unsupported) = checked {
        return Ok(Run::not_rendered(
            &scene.name,
            scene_file,
            &canonical,
            res(scene),
            RunStatus::Skipped,
            unsupported.reason,
        ));
    }
    // Known before anything is built: a technique whose passes grow with the depth
    // complexity says how many it will make, and the floor says what one pass costs here.
    if let Some(estimate) = PassEstimate::of(
        technique.as_ref(),
        reference.stats.max_depth_complexity,
        floor_ms,
        options,
    ) && estimate.over_budget(options.run_budget)
    {
        return Ok(Run::not_rendered(
            &scene.name,
            scene_file,
            &canonical,
            res(scene),
            RunStatus::Skipped,
            estimate.describe(options.run_budget),
        ));
    }
    let deadline = std::time::Instant::now() + options.run_budget;
    let timed = time_frames(
        ctx,
        forward,
        technique.as_mut(),
        targets,
        options,
        Some(held),
    );
    let (gpu_ms, passes, frame) = timed?;
    let image = read_color(ctx, targets)?;
    let counts = crate::counts::frame(ctx, forward, technique.as_mut(), targets, deadline)?;

    // The same technique with the draws, and the triangles within each draw, submitted in
    // reverse: any difference is order dependence.
    let mut timer = GpuTimer::wall_clock();
    timer.set_budget(Some(
        deadline.saturating_duration_since(std::time::Instant::now()),
    ));
    render_frame(ctx, reversed, technique.as_mut(), targets, &mut timer)?;
    let reversed_image = read_color(ctx, targets)?;
    let order_dependence = max_rgb_difference(&image, &reversed_image);

    let error = oit_metrics::compare(&image, &reference.image)?;
    let diff = oit_metrics::diff_image(&image, &reference.image)?;
    // Outputs at the default format keep their names; another format's get `@FORMAT`.
    let stem = format!("{}{}", file_stem(&canonical), format.file_suffix());
    let dir = file_stem(&scene.name);
    let outputs = Outputs {
        exr: format!("{dir}/{stem}.exr"),
        render_png: format!("{dir}/{stem}.png"),
        diff_png: format!("{dir}/{stem}-diff.png"),
    };
    oit_metrics::write_exr(
        &out.join(&outputs.exr),
        &[
            oit_metrics::ExrLayer::new("render", &image),
            oit_metrics::ExrLayer::new("reference", &reference.image),
            oit_metrics::ExrLayer::new("diff", &diff),
        ],
    )?;
    oit_metrics::write_png_preview(&out.join(&outputs.render_png), &image)?;
    let heat = oit_metrics::heatmap(&image, &reference.image)?;
    oit_metrics::write_png_srgb8(&out.join(&outputs.diff_png), &heat)?;

    let memory_bytes = technique.memory_bytes();
    let stats = Stats {
        geometry_passes: frame.geometry_passes,
        layers_peeled: frame.layers_peeled,
        pixels_with_dropped_layers: frame.pixels_with_dropped_layers,
        pixels_with_approximated_layers: frame.pixels_with_approximated_layers,
        auto_sizes: frame.auto_sizes.map(crate::results::auto_sizes_json),
        setup_ms: frame.setup_ms,
    };
    Ok(Run {
        scene: scene.name.clone(),
        scene_file: scene_file.to_owned(),
        technique: canonical,
        resolution: res(scene),
        status: RunStatus::Ok,
        reason: None,
        gpu_ms: Some(gpu_ms),
        passes,
        cpu_ms: Some(frame.cpu_ms),
        memory_bytes: Some(memory_bytes),
        bytes_per_pixel: Some(memory_bytes as f64 / scene.resolution.pixel_count() as f64),
        cost_vs_unsorted: None,
        cost_vs_floor: None,
        error: Some(error),
        order_dependence: Some(order_dependence),
        inexact: inexact(&stats, scene, technique.as_ref(), &ctx.caps),
        undecided_pixels: Some(reference.stats.undecided_pixels),
        precision_tie_pixels: Some(reference.stats.precision_tie_pixels),
        stats: Some(stats),
        counts,
        outputs: Some(outputs),
        inputs: None,
        resumed: false,
        temporal: None,
        shard: None,
        varied: None,
        prediction: None,
        target_format: format,
    })
}

/// The run's `inexact` phrases: what its statistics imply, and on a scene with coloured
/// transmission a technique that composites it only approximately.
fn inexact(
    stats: &Stats,
    scene: &Scene,
    technique: &dyn Technique,
    caps: &oit_gpu::Caps,
) -> Vec<String> {
    let mut phrases = stats.inexact();
    if scene.has_coloured_transmission() && technique.transmission(caps) != oit_gpu::Support::Exact
    {
        phrases.push(APPROXIMATE_TRANSMISSION.to_owned());
    }
    for operator in scene.operators_used() {
        if let oit_gpu::Support::Approximate(_) = technique.operator(operator, caps) {
            phrases.push(format!("approximate {}", operator.name()));
        }
    }
    phrases.extend(technique.queues().inexact(scene));
    phrases
}

/// The `inexact` phrase of a run that composites coloured transmittance approximately
/// (`Technique::transmission`).
pub const APPROXIMATE_TRANSMISSION: &str = "approximate transmission";

/// Largest per-channel |a − b| over RGB; NaN anywhere counts as infinitely different.
pub fn max_rgb_difference(a: &LinearImage, b: &LinearImage) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from(p[c]) - f64::from(q[c])))
        .map(|d| if d.is_nan() { f64::INFINITY } else { d.abs() })
        .fold(0.0, f64::max)
}

/// Divides every ok run's median GPU time at `format` by `unsorted`'s in the same scene at the
/// same format.
fn fill_costs(
    runs: &mut [Run],
    format: TargetFormat,
    measure_baseline: impl FnOnce() -> Option<f64>,
) {
    let baseline = runs
        .iter()
        .find(|r| r.is("unsorted", format) && r.status == RunStatus::Ok)
        .and_then(|r| r.gpu_ms.as_ref().map(|g| g.median));
    let baseline = baseline.or_else(measure_baseline);
    let Some(base) = baseline.filter(|b| *b > 0.0) else {
        return;
    };
    for run in (runs.iter_mut()).filter(|r| r.status == RunStatus::Ok && r.target_format == format)
    {
        run.cost_vs_unsorted = run.gpu_ms.as_ref().map(|g| g.median / base);
    }
}

/// Writes results.json and results.md; in a shard, every run says which shard made it.
pub(crate) fn write_outputs(out: &Path, results: &mut Results) -> Result<(), HarnessError> {
    if let Some(index) = results.shard.as_ref().map(|s| s.index) {
        results.runs.iter_mut().for_each(|r| r.shard = Some(index));
    }
    let json = serde_json::to_vec_pretty(results).expect("results serialize");
    oit_metrics::write_atomic_bytes(&out.join("results.json"), &json)?;
    oit_metrics::write_atomic_bytes(
        &out.join("results.md"),
        crate::report::markdown(results).as_bytes(),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results::GpuMs;

    fn ok_run(technique: &str, median: f64) -> Run {
        let mut run = Run::not_rendered(
            "s",
            "s.json",
            technique,
            [1, 1],
            RunStatus::Ok,
            String::new(),
        );
        run.reason = None;
        run.gpu_ms = Some(GpuMs {
            median,
            min: median,
            max: median,
            frames: 1,
            source: "timestamp".into(),
            interference: None,
            attempts: 1,
        });
        run
    }

    /// Files written before `--retime` read as one attempt and no retiming, and a run timed
    /// once writes neither field, so such results.json files stay as they were.
    #[test]
    fn attempts_and_retime_default_for_older_files() {
        let gpu: GpuMs = serde_json::from_str(
            r#"{"median": 1.0, "min": 1.0, "max": 1.0, "frames": 3, "source": "timestamp"}"#,
        )
        .unwrap();
        assert_eq!(gpu.attempts, 1);
        let text = serde_json::to_string(&gpu).unwrap();
        assert!(!text.contains("attempts"), "{text}");
        let again = GpuMs { attempts: 3, ..gpu };
        assert!(
            serde_json::to_string(&again)
                .unwrap()
                .contains(r#""attempts":3"#)
        );
        let inputs: RunInputs =
            serde_json::from_str(r#"{"scene_hash": "ab", "frames": 3, "warmup": 1}"#).unwrap();
        assert_eq!(inputs.retime, 0);
        assert!(!serde_json::to_string(&inputs).unwrap().contains("retime"));
        let retimed = RunInputs {
            retime: 2,
            ..inputs.clone()
        };
        assert_ne!(
            retimed, inputs,
            "runs timed with retiming are not resumed for plain ones"
        );
    }

    /// cost × unsorted and cost × floor are the run's time over the baseline's, never the
    /// inverse; runs that did not render get none.
    #[test]
    fn costs_divide_the_run_by_its_baseline() {
        let mut runs = vec![
            ok_run("unsorted", 2.0),
            ok_run("front-peel", 10.0),
            Run::not_rendered(
                "s",
                "s.json",
                "k-buffer",
                [1, 1],
                RunStatus::Skipped,
                "x".into(),
            ),
        ];
        fill_costs(&mut runs, TargetFormat::default(), || {
            panic!("unsorted ran: not measured again")
        });
        assert_eq!(runs[0].cost_vs_unsorted, Some(1.0));
        assert_eq!(runs[1].cost_vs_unsorted, Some(5.0));
        assert_eq!(runs[2].cost_vs_unsorted, None);
        fill_floor_costs(&mut runs, TargetFormat::default(), 0.5);
        assert_eq!(runs[1].cost_vs_floor, Some(20.0));
        assert_eq!(runs[2].cost_vs_floor, None);
        // Without `unsorted` among the runs, the baseline is measured.
        let mut alone = vec![ok_run("wboit", 3.0)];
        fill_costs(&mut alone, TargetFormat::default(), || Some(1.5));
        assert_eq!(alone[0].cost_vs_unsorted, Some(2.0));
    }

    #[test]
    fn order_difference_is_max_abs_and_nan_is_infinite() {
        let a = LinearImage::new(2, 1, [0.5, 0.5, 0.5, 1.0]);
        let mut b = a.clone();
        b.pixels[1][2] = 0.25;
        assert_eq!(max_rgb_difference(&a, &b), 0.25);
        b.pixels[0][0] = f32::NAN;
        assert_eq!(max_rgb_difference(&a, &b), f64::INFINITY);
    }
}
