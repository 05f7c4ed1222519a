//! The comparison loop: for each scene, the reference (cached), then for each technique
//! warm-up frames, timed frames, readback, metrics, the reversed-order render, and reports.

use std::path::{Path, PathBuf};

use oit_gpu::{
    ColorFormat, Context, ContextOptions, GpuScene, GpuTimer, Targets, Technique, TechniqueSpec,
    TimingSource, read_color, render_frame,
};
use oit_scene::{LinearImage, Resolution, Scene};

use crate::results::{
    AdapterJson, FloorJson, GpuMs, Outputs, PassMs, Results, Run, RunInputs, RunStatus, SCHEMA,
    SceneJson, Stats,
};
use crate::{HarnessError, SceneEntry, at_resolution, file_stem, interference, registry};

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
    /// Untimed frames first: pipelines compile and caches fill on the first frame.
    pub warmup: u32,
    pub out_dir: PathBuf,
    pub cache: ReferenceCache,
    /// Bytes the reference may hold for fragments (`oit_reference::ReferenceOptions`).
    pub reference_memory_budget: u64,
    /// Reuse the runs of `out_dir/results.json` made from identical inputs (see
    /// [`crate::results::RunInputs`]) instead of running them again.
    pub resume: bool,
    /// Times a run's frames again, up to this many times, while they were taken with more than
    /// [`NOTABLE`](crate::interference::NOTABLE) of the machine's CPU time going elsewhere
    /// (a judgeable window only); the quietest attempt is kept and says how many were made.
    pub retime: u32,
    pub context: ContextOptions,
}

impl Default for CompareOptions {
    fn default() -> Self {
        CompareOptions {
            resolution: None,
            frames: 20,
            warmup: 3,
            out_dir: PathBuf::from("out"),
            cache: ReferenceCache::Default,
            reference_memory_budget: oit_reference::ReferenceOptions::DEFAULT_MEMORY_BUDGET,
            resume: false,
            retime: 0,
            context: ContextOptions::default(),
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
    /// One line people must see (e.g. a cached reference that was not trusted).
    Warning(&'a str),
}

/// One rendered image and what it cost.
#[derive(Debug, Clone)]
pub struct RenderedFrame {
    pub image: LinearImage,
    pub stats: oit_gpu::RenderStats,
    pub timings: oit_gpu::FrameTimings,
    pub memory_bytes: u64,
}

fn build(spec: &TechniqueSpec) -> Result<Box<dyn Technique>, HarnessError> {
    Ok(TechniqueSpec::build(&spec.canonical(), &registry())?)
}

/// Renders one frame of `scene` with `spec` (after one warm-up frame) and reads it back.
pub fn render_once(
    ctx: &Context,
    scene: &Scene,
    spec: &TechniqueSpec,
) -> Result<RenderedFrame, HarnessError> {
    let mut technique = build(spec)?;
    let gpu_scene = GpuScene::upload(ctx, scene)?;
    let targets = Targets::new(ctx, scene.resolution, ColorFormat::Rgba16Float)?;
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
/// and PNG files under `options.out_dir`, and nothing outside it. `results.json` and
/// `results.md` are rewritten (atomically) after every run, so an interrupted comparison keeps
/// what it finished and `--resume` can continue it. Two comparisons never share an output
/// folder (a lock file), and no two scenes or techniques share an output file.
pub fn compare(
    ctx: &Context,
    scenes: &[SceneEntry],
    specs: &[TechniqueSpec],
    options: &CompareOptions,
    on_event: &dyn Fn(Event<'_>),
) -> Result<Results, HarnessError> {
    if options.frames == 0 {
        return Err(HarnessError::Options(
            "frames must be at least 1 (the timed frames of every run)".into(),
        ));
    }
    check_unique_outputs(scenes, specs)?;
    let out = &options.out_dir;
    std::fs::create_dir_all(out).map_err(|e| HarnessError::io(out, e))?;
    let _lock = OutputLock::acquire(out)?;
    oit_metrics::remove_stale_temporaries(out);
    // Read before anything is written: results.json is rewritten after every run.
    let earlier = if options.resume {
        earlier_results(out, ctx)?
    } else {
        None
    };
    let (earlier_runs, earlier_floors) =
        earlier.map_or((Vec::new(), Vec::new()), |e| (e.runs, e.floors));
    let cache_dir = match &options.cache {
        ReferenceCache::Default => Some(crate::cache::default_dir()),
        ReferenceCache::Dir(d) => Some(d.clone()),
        ReferenceCache::Off => None,
    };
    let mut results = Results {
        schema: SCHEMA.to_owned(),
        adapter: AdapterJson::of(ctx),
        runs: Vec::new(),
        floors: Vec::new(),
        scenes: Vec::new(),
    };
    for entry in scenes {
        let scene = at_resolution(&entry.scene, options.resolution);
        let scene_file = entry.path.display().to_string();
        results.scenes.push(SceneJson::of(&scene, &scene_file));
        let compute = || {
            Ok(oit_reference::try_render(
                &scene,
                &oit_reference::ReferenceOptions {
                    memory_budget: options.reference_memory_budget,
                    ..Default::default()
                },
            )?)
        };
        let reference = match &cache_dir {
            Some(dir) => {
                let (reference, outcome) = crate::cache::reference(dir, &scene, compute)?;
                if let Some(warning) = outcome.warning(&scene.name) {
                    on_event(Event::Warning(&warning));
                }
                reference
            }
            None => compute()?,
        };
        let scene_dir = out.join(file_stem(&scene.name));
        std::fs::create_dir_all(&scene_dir).map_err(|e| HarnessError::io(&scene_dir, e))?;
        oit_metrics::remove_stale_temporaries(&scene_dir);
        // The reference once per scene, for reports that show it beside every render.
        crate::write_reference_exr(&scene_dir.join("reference.exr"), &reference)?;
        oit_metrics::write_png_preview(&scene_dir.join("reference.png"), &reference.image)?;
        let forward = GpuScene::upload(ctx, &scene)?;
        let reversed = GpuScene::upload(ctx, &scene.with_reversed_draw_order())?;
        let targets = Targets::new(ctx, scene.resolution, ColorFormat::Rgba16Float)?;
        let inputs = RunInputs {
            scene_hash: format!("{:016x}", scene.content_hash()),
            frames: options.frames,
            warmup: options.warmup,
            retime: options.retime,
        };
        let first_run = results.runs.len();
        let mut all_resumed = true;
        for spec in specs {
            let canonical = spec.canonical();
            let resumed = earlier_runs
                .iter()
                .find(|r| reusable(r, &scene, &canonical, &inputs, out))
                .cloned();
            let run = match resumed {
                Some(mut run) => {
                    run.resumed = true;
                    run.scene_file.clone_from(&scene_file);
                    run
                }
                None => {
                    all_resumed = false;
                    let mut run = run_one(
                        ctx,
                        &scene,
                        &scene_file,
                        &forward,
                        &reversed,
                        &targets,
                        spec,
                        &reference,
                        options,
                        out,
                    )
                    .unwrap_or_else(|e| {
                        Run::not_rendered(
                            &scene.name,
                            &scene_file,
                            &canonical,
                            res(&scene),
                            RunStatus::Failed,
                            e.to_string(),
                        )
                    });
                    run.inputs = Some(inputs.clone());
                    run
                }
            };
            let was_resumed = run.resumed;
            results.runs.push(run);
            write_outputs(out, &results)?;
            on_event(Event::RunDone {
                scene: &scene.name,
                technique: &canonical,
                resumed: was_resumed,
            });
        }
        let earlier_floor = earlier_floors
            .iter()
            .find(|f| f.scene == scene.name && f.resolution == res(&scene));
        match earlier_floor.filter(|_| all_resumed) {
            // Every run came from the earlier comparison: its ratios and floor stand together.
            Some(floor) => results.floors.push(floor.clone()),
            None => {
                fill_costs(&mut results.runs[first_run..], || {
                    // `unsorted` was not requested: time it anyway, so every cost has its baseline.
                    let spec = TechniqueSpec::parse("unsorted", &registry()).ok()?;
                    let mut t = build(&spec).ok()?;
                    time_frames(ctx, &forward, t.as_mut(), &targets, options)
                        .ok()
                        .map(|(ms, _, _)| ms.median)
                });
                let floor = time_floor(ctx, &scene, &forward, &targets, options)?;
                fill_floor_costs(&mut results.runs[first_run..], floor.gpu_ms.median);
                results.floors.push(floor);
            }
        }
        write_outputs(out, &results)?;
    }
    Ok(results)
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
struct OutputLock {
    path: PathBuf,
}

/// The lock's file name inside the output folder (hidden: no stem starts with `.`).
pub const LOCK_FILE: &str = ".oit-compare.lock";

impl OutputLock {
    fn acquire(out: &Path) -> Result<OutputLock, HarnessError> {
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
                                    "another `oit compare` (pid {pid}) is writing to this folder; wait for it or choose another --out"
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

/// The earlier comparison in `out` whose runs `--resume` may reuse: none when there is no
/// results.json; an error when it exists but cannot be read or comes from another adapter.
fn earlier_results(out: &Path, ctx: &Context) -> Result<Option<Results>, HarnessError> {
    let path = out.join("results.json");
    if !path.exists() {
        return Ok(None);
    }
    let earlier = Results::read(&path)?;
    let adapter = AdapterJson::of(ctx);
    if earlier.adapter != adapter {
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

/// An earlier run stands for this one: same scene content, technique, resolution, frames and
/// warm-up, it finished (a failed run is tried again) and its files are all there.
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
    let (gpu_ms, passes, _) = time_frames(ctx, forward, &mut floor, targets, options)?;
    Ok(FloorJson {
        scene: scene.name.clone(),
        resolution: res(scene),
        gpu_ms,
        passes,
    })
}

/// Divides every ok run's median GPU time by the scene's floor.
fn fill_floor_costs(runs: &mut [Run], floor_ms: f64) {
    if floor_ms <= 0.0 {
        return;
    }
    for run in runs.iter_mut().filter(|r| r.status == RunStatus::Ok) {
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
    forward: &GpuScene,
    reversed: &GpuScene,
    targets: &Targets,
    spec: &TechniqueSpec,
    reference: &oit_reference::Reference,
    options: &CompareOptions,
    out: &Path,
) -> Result<Run, HarnessError> {
    let canonical = spec.canonical();
    let mut technique = build(spec)?;
    if let Err(unsupported) = oit_gpu::check_scene(technique.as_ref(), &ctx.caps, scene) {
        return Ok(Run::not_rendered(
            &scene.name,
            scene_file,
            &canonical,
            res(scene),
            RunStatus::Skipped,
            unsupported.reason,
        ));
    }
    let (gpu_ms, passes, frame) = time_frames(ctx, forward, technique.as_mut(), targets, options)?;
    let image = read_color(ctx, targets)?;

    // The same technique with the draw order reversed: any difference is order dependence.
    let mut timer = GpuTimer::wall_clock();
    render_frame(ctx, reversed, technique.as_mut(), targets, &mut timer)?;
    let reversed_image = read_color(ctx, targets)?;
    let order_dependence = max_rgb_difference(&image, &reversed_image);

    let error = oit_metrics::compare(&image, &reference.image)?;
    let diff = oit_metrics::diff_image(&image, &reference.image)?;
    let stem = file_stem(&canonical);
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
        outputs: Some(outputs),
        inputs: None,
        resumed: false,
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
    if scene.has_coloured_transmission()
        && technique.transmission(caps) != oit_gpu::TransmissionSupport::Exact
    {
        phrases.push(APPROXIMATE_TRANSMISSION.to_owned());
    }
    phrases
}

/// The `inexact` phrase of a run that composites coloured transmittance approximately
/// (`Technique::transmission`).
pub const APPROXIMATE_TRANSMISSION: &str = "approximate transmission";

/// Warm-up then timed frames. Returns total GPU ms (median/min/max), per-pass medians, and the
/// last frame's stats with `cpu_ms` replaced by its median over the timed frames. With
/// `options.retime`, frames timed in a noisy window are timed again ([`quietest`]).
fn time_frames(
    ctx: &Context,
    scene: &GpuScene,
    technique: &mut dyn Technique,
    targets: &Targets,
    options: &CompareOptions,
) -> Result<(GpuMs, Vec<PassMs>, oit_gpu::RenderStats), HarnessError> {
    let mut timer = GpuTimer::new(ctx);
    for _ in 0..options.warmup {
        render_frame(ctx, scene, technique, targets, &mut timer)?;
    }
    let ((mut gpu, passes, stats), made) = until_quiet(
        options.retime,
        || time_window(ctx, scene, technique, targets, options.frames, &mut timer),
        |attempt| attempt.0.interference,
    )?;
    gpu.attempts = made;
    Ok((gpu, passes, stats))
}

/// Makes `attempt`s until one's window is not noisy or `retime` more were made after the
/// first; returns the [`quietest`] and how many were made.
fn until_quiet<T, E>(
    retime: u32,
    mut attempt: impl FnMut() -> Result<T, E>,
    window: impl Fn(&T) -> Option<crate::interference::Interference>,
) -> Result<(T, u32), E> {
    let mut attempts = Vec::new();
    loop {
        let made = attempt()?;
        let quiet = !window(&made).is_some_and(|i| i.notable());
        attempts.push(made);
        if quiet || attempts.len() > retime as usize {
            break;
        }
    }
    let made = attempts.len() as u32;
    let best = quietest(attempts.iter().map(&window));
    Ok((attempts.swap_remove(best), made))
}

/// Which attempt to keep: the first whose window was not noisy (or could not be judged),
/// else the one that lost the least CPU time to others.
fn quietest(windows: impl Iterator<Item = Option<crate::interference::Interference>>) -> usize {
    let mut best: Option<(usize, f64)> = None;
    for (i, window) in windows.enumerate() {
        let lost = match window {
            Some(w) if w.notable() => w.lost(),
            _ => return i,
        };
        if best.is_none_or(|(_, least)| lost < least) {
            best = Some((i, lost));
        }
    }
    best.map_or(0, |(i, _)| i)
}

/// One window of `frames` timed frames: the [`time_frames`] results of one attempt.
fn time_window(
    ctx: &Context,
    scene: &GpuScene,
    technique: &mut dyn Technique,
    targets: &Targets,
    frames: u32,
    timer: &mut GpuTimer,
) -> Result<(GpuMs, Vec<PassMs>, oit_gpu::RenderStats), HarnessError> {
    let mut totals = Vec::with_capacity(frames as usize);
    let mut cpu = Vec::with_capacity(frames as usize);
    let mut per_pass: Vec<(String, Vec<f64>)> = Vec::new();
    let mut last = None;
    let mut source = TimingSource::WallClock;
    let before = interference::sample();
    for _ in 0..frames {
        let frame = render_frame(ctx, scene, technique, targets, timer)?;
        source = frame.timings.source;
        // Wall-clock mode: total GPU busy time is unknowable, so the whole frame counts.
        totals.push(match source {
            TimingSource::Timestamp => frame.timings.total_ms,
            TimingSource::WallClock => frame.timings.wall_ms,
        });
        cpu.push(frame.stats.cpu_ms);
        for p in &frame.timings.passes {
            match per_pass.iter_mut().find(|(n, _)| *n == p.name) {
                Some((_, v)) => v.push(p.ms),
                None => per_pass.push((p.name.clone(), vec![p.ms])),
            }
        }
        last = Some(frame.stats);
    }
    let after = interference::sample();
    let mut stats = last.expect("at least one frame");
    stats.cpu_ms = median(&mut cpu);
    let gpu = GpuMs {
        median: median(&mut totals.clone()),
        min: totals.iter().copied().fold(f64::INFINITY, f64::min),
        max: totals.iter().copied().fold(0.0, f64::max),
        frames,
        source: source.name().to_owned(),
        interference: before.zip(after).and_then(|(a, b)| {
            interference::Interference::between(a, b, interference::TICKS_PER_SECOND)
        }),
        attempts: 1,
    };
    let passes = per_pass
        .into_iter()
        .map(|(name, mut v)| PassMs {
            name,
            median_ms: median(&mut v),
        })
        .collect();
    Ok((gpu, passes, stats))
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// Largest per-channel |a − b| over RGB; NaN anywhere counts as infinitely different.
pub fn max_rgb_difference(a: &LinearImage, b: &LinearImage) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from(p[c]) - f64::from(q[c])))
        .map(|d| if d.is_nan() { f64::INFINITY } else { d.abs() })
        .fold(0.0, f64::max)
}

/// Divides every ok run's median GPU time by `unsorted`'s in the same scene.
fn fill_costs(runs: &mut [Run], measure_baseline: impl FnOnce() -> Option<f64>) {
    let baseline = runs
        .iter()
        .find(|r| r.technique == "unsorted" && r.status == RunStatus::Ok)
        .and_then(|r| r.gpu_ms.as_ref().map(|g| g.median));
    let baseline = baseline.or_else(measure_baseline);
    let Some(base) = baseline.filter(|b| *b > 0.0) else {
        return;
    };
    for run in runs.iter_mut().filter(|r| r.status == RunStatus::Ok) {
        run.cost_vs_unsorted = run.gpu_ms.as_ref().map(|g| g.median / base);
    }
}

fn write_outputs(out: &Path, results: &Results) -> Result<(), HarnessError> {
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

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
    }

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

    /// `--retime` keeps the first attempt whose window was quiet or too short to judge, and
    /// otherwise the one that lost the least CPU time.
    #[test]
    fn the_quietest_attempt_is_kept() {
        use crate::interference::Interference;
        let window = |lost: f64, cpu_seconds: f64| {
            Some(Interference {
                steal: lost,
                other_processes: 0.0,
                cpu_seconds,
            })
        };
        let noisy = |lost: f64| window(lost, 4.0);
        assert_eq!(quietest([noisy(0.3), window(0.05, 4.0)].into_iter()), 1);
        assert_eq!(
            quietest([noisy(0.3), noisy(0.12), noisy(0.2)].into_iter()),
            1
        );
        assert_eq!(quietest([noisy(0.2), noisy(0.4)].into_iter()), 0);
        // Too short to judge, or not measured at all (no /proc/stat): as good as quiet.
        assert_eq!(quietest([noisy(0.3), window(0.9, 0.1)].into_iter()), 1);
        assert_eq!(quietest([noisy(0.3), None, noisy(0.01)].into_iter()), 1);
        assert_eq!(quietest([None].into_iter()), 0);
    }

    /// A noisy window is timed again at most `retime` times, and timing stops at the first
    /// quiet one.
    #[test]
    fn retiming_stops_at_a_quiet_window_or_the_limit() {
        use crate::interference::Interference;
        let lost = [0.3, 0.2, 0.01, 0.5];
        let run = |retime: u32| {
            let mut next = 0;
            until_quiet::<usize, ()>(
                retime,
                || {
                    next += 1;
                    Ok(next - 1)
                },
                |&i| {
                    Some(Interference {
                        steal: lost[i],
                        other_processes: 0.0,
                        cpu_seconds: 4.0,
                    })
                },
            )
            .unwrap()
        };
        assert_eq!(
            run(0),
            (0, 1),
            "no retiming: the first window, noisy or not"
        );
        assert_eq!(run(1), (1, 2), "the quieter of two noisy windows");
        assert_eq!(run(2), (2, 3), "stops at the quiet third window");
        assert_eq!(run(10), (2, 3), "and makes no more after it");
        let failing = until_quiet::<u32, &str>(3, || Err("lost the device"), |_| None);
        assert_eq!(failing, Err("lost the device"));
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
        fill_costs(&mut runs, || panic!("unsorted ran: not measured again"));
        assert_eq!(runs[0].cost_vs_unsorted, Some(1.0));
        assert_eq!(runs[1].cost_vs_unsorted, Some(5.0));
        assert_eq!(runs[2].cost_vs_unsorted, None);
        fill_floor_costs(&mut runs, 0.5);
        assert_eq!(runs[1].cost_vs_floor, Some(20.0));
        assert_eq!(runs[2].cost_vs_floor, None);
        // Without `unsorted` among the runs, the baseline is measured.
        let mut alone = vec![ok_run("wboit", 3.0)];
        fill_costs(&mut alone, || Some(1.5));
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
