//! `oit`: compare order-independent transparency techniques against an exact CPU reference.
//!
//! Exit codes: 0 on success; 1 with one line on stderr otherwise; 2 for usage errors (clap);
//! 3 when `recommend` finds no configuration within the budget; 4 when `compare` wrote its
//! results and report but some runs failed ([`RunsFailed`]); 130 when `compare` was
//! interrupted (Ctrl-C) after writing what it finished.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use oit_scene::{Resolution, Scene};

mod analyze;
mod cost_model;
mod growth;
mod notes;
mod recommend;
mod scenes;

#[derive(Debug, Parser)]
#[command(
    name = "oit",
    version,
    about = "Order-independent transparency testbed: every technique against an exact CPU reference"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// List scenes with what they test, triangle counts and depth complexity (from the reference).
    Scenes {
        /// A scene file (.json, .gltf, .glb) or a directory of them.
        #[arg(default_value = "scenes")]
        path: PathBuf,
        /// Print JSON (one object per scene) instead of the table.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Measure what scenes ask of a technique from the reference's fragment lists (no GPU):
    /// layers, order conflicts, self-overlap, α, radiance, depth (docs/analyze.md).
    Analyze {
        /// Scene files (.json, .gltf, .glb) or directories of them.
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
        /// Print JSON (schema `oit-lab/analyze/v1`) instead of the tables.
        #[arg(long)]
        json: bool,
        /// Override every scene's resolution, e.g. 512x512.
        #[arg(long, value_parser = parse_resolution)]
        resolution: Option<Resolution>,
        /// Memory the reference may hold for fragments, in MiB (default 2048).
        #[arg(long, value_name = "MIB", default_value_t = 2048, value_parser = clap::value_parser!(u64).range(1..))]
        memory_budget: u64,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Fit GPU time to each run's counts (fragments, bytes, atomics, triangles × passes,
    /// pixels × full-screen passes) on the adapter of a results.json: coefficients, R², the
    /// worst residuals. The counts carry to other GPUs; the coefficients do not.
    CostModel {
        /// A results.json written by `oit compare`.
        results: PathBuf,
        /// Also write the model as JSON (schema `oit-lab/cost-model/v1`) to this file.
        #[arg(long, value_name = "OUT")]
        json: Option<PathBuf>,
        /// Minimise absolute residuals (the slowest runs decide) instead of relative ones.
        #[arg(long)]
        absolute: bool,
    },
    /// List every technique with its parameters and defaults.
    Techniques {
        /// Print JSON (one object per technique) instead of text.
        #[arg(long, conflicts_with = "markdown")]
        json: bool,
        /// Print a Markdown table instead: `techniques` (the README's) or `transmission`
        /// (docs/coloured-transmission.md's).
        #[arg(long, value_name = "TABLE")]
        markdown: Option<MarkdownArg>,
    },
    /// Render the exact CPU reference of a scene to a linear EXR (RGBA + `layers`) and a PNG preview.
    Reference {
        /// The scene file (.json, .gltf, .glb).
        scene: PathBuf,
        /// Output EXR (must end in .exr); a PNG preview is written beside it (same name, .png).
        /// Default: NAME-reference.exr in the working directory, NAME the scene's name made
        /// file-safe.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Override the scene's resolution, e.g. 512x512.
        #[arg(long, value_parser = parse_resolution)]
        resolution: Option<Resolution>,
        /// Memory the reference may hold for fragments, in MiB (default 2048); a scene that
        /// needs more for one pixel fails naming that pixel.
        #[arg(long, value_name = "MIB", default_value_t = 2048, value_parser = clap::value_parser!(u64).range(1..))]
        memory_budget: u64,
        /// Frames of an animated scene: `N`, `A..B` (B exclusive), `A..B:STEP` or `all`
        /// (default: frame 0). With more than one, each output gets `-fNNNN` before `.exr`.
        #[arg(long, value_name = "FRAMES", value_parser = parse_frames)]
        animation_frames: Option<oit_harness::motion::FrameSelection>,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// Render one technique on the GPU to a linear EXR and a PNG preview.
    Render {
        /// The scene file (.json, .gltf, .glb).
        scene: PathBuf,
        /// Technique spec, `name[:key=value,...]` (see `oit techniques`).
        #[arg(short, long)]
        technique: String,
        /// Output EXR (must end in .exr); a PNG preview is written beside it (same name, .png).
        /// Default: NAME-TECHNIQUE.exr in the working directory, both made file-safe.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Override the scene's resolution, e.g. 512x512.
        #[arg(long, value_parser = parse_resolution)]
        resolution: Option<Resolution>,
        /// Frames of an animated scene: `N`, `A..B` (B exclusive), `A..B:STEP` or `all`
        /// (default: frame 0). With more than one, each output gets `-fNNNN` before `.exr`.
        #[arg(long, value_name = "FRAMES", value_parser = parse_frames)]
        animation_frames: Option<oit_harness::motion::FrameSelection>,
        /// Format of the final colour target: rgba16float (half float, the default),
        /// rgba32float, or rgba8unorm (linear 8-bit UNORM, as VTK's framebuffer: every blend
        /// clamps to [0, 1] and rounds to 1/255). A format other than the default adds
        /// `@FORMAT` to the default output name.
        #[arg(long, value_name = "FORMAT", default_value = "rgba16float", value_parser = parse_target_format)]
        target_format: oit_results::TargetFormat,
        #[command(flatten)]
        load: LoadArgs,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Run techniques on scenes, diff against the reference, write results.json, results.md, EXR and PNG.
    Compare {
        /// Scene files (.json, .gltf, .glb) or directories of them.
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
        /// Technique spec `name[:key=value,...]`, repeatable; every technique at its defaults
        /// when none is given. A sweep runs several: a value list `stochastic:spp=1,4,16`, an
        /// integer range `dual-peel:passes=1..8`, several swept keys give every combination
        /// (at most 4096 specs per sweep).
        #[arg(short, long = "technique")]
        techniques: Vec<String>,
        /// Output directory: results.json, results.md, report.html, plots/ and one folder per
        /// scene; nothing is written outside it.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Override every scene's resolution, e.g. 512x512.
        #[arg(long, value_parser = parse_resolution)]
        resolution: Option<Resolution>,
        /// Timed frames per run (at least 1).
        #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..))]
        frames: u32,
        /// Untimed warm-up frames per run, after a first frame that is never timed (it builds
        /// the technique's pipelines), 0 to 1000.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=i64::from(oit_harness::MAX_WARMUP)))]
        warmup: u32,
        /// Where computed references are cached (keyed by scene content and resolution; each
        /// file checksummed). Default: $OIT_CACHE_DIR, else $XDG_CACHE_HOME/oit-lab/references,
        /// else ~/.cache/oit-lab/references.
        #[arg(long, conflicts_with = "no_cache")]
        cache: Option<PathBuf>,
        /// Compute every reference, read and write no cache.
        #[arg(long)]
        no_cache: bool,
        /// Most MiB of references the cache folder keeps; the least recently used are removed
        /// first, and a larger reference is not cached.
        #[arg(long, value_name = "MIB", default_value_t = oit_harness::cache::DEFAULT_CAP >> 20)]
        cache_cap: u64,
        /// Keep the runs of OUT/results.json made from identical inputs (scene content,
        /// technique, resolution, frames, warm-up, adapter, build of oit) and run only the
        /// rest; its runs of techniques and scenes not named now are kept beside the new ones,
        /// so one technique can be added to an existing comparison.
        #[arg(long)]
        resume: bool,
        /// Time a run's frames again, up to this many times, when over 10 % of the machine's
        /// CPU time went elsewhere while they ran (steal, other processes; Linux); the
        /// quietest attempt is kept and results.json says how many were made.
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=10))]
        retime: u32,
        /// Refuse comparisons of more runs (scenes × techniques) than this.
        #[arg(long, default_value_t = 2000)]
        max_runs: u64,
        /// Memory one scene may take, in MiB: the reference's fragments, one run's images,
        /// the predictions' lists, the scene's GPU upload (textures included), the targets
        /// and the technique's buffers. What cannot fit fails with its need in MiB; the
        /// others run.
        #[arg(long, value_name = "MIB", default_value_t = oit_harness::DEFAULT_MEMORY_BUDGET >> 20, value_parser = clap::value_parser!(u64).range(1..))]
        memory_budget: u64,
        /// Seconds one run (all its frames) may take: a peeling technique whose pass count for
        /// the scene's depth complexity would not fit is skipped before it starts, and any run
        /// still going past it is stopped and reported as failed.
        #[arg(long, value_name = "SECONDS", default_value_t = oit_harness::DEFAULT_RUN_BUDGET.as_secs(), value_parser = clap::value_parser!(u64).range(1..))]
        run_budget: u64,
        /// Error axis of the plots and Pareto fronts.
        #[arg(long, default_value = "flip", value_parser = ["flip", "rmse"])]
        metric: String,
        /// Frames of each animated scene's path measured for motion (flicker, pop events,
        /// per-frame errors): `all`, `N`, `A..B` (B exclusive) or `A..B:STEP`. Not to be
        /// confused with --frames, the timed repetitions of frame 0.
        #[arg(long, value_name = "FRAMES", default_value = "all", value_parser = parse_frames)]
        animation_frames: oit_harness::motion::FrameSelection,
        /// Renders of frame 0 of each animated scene at its static camera, for bias and noise
        /// over frames (0: not measured).
        #[arg(long, value_name = "N", default_value_t = oit_harness::motion::DEFAULT_STATIC_FRAMES, value_parser = clap::value_parser!(u32).range(0..=1024))]
        static_frames: u32,
        /// Make only shard K of N of the runs (1 ≤ K ≤ N; a contiguous, balanced block of the
        /// scene × technique runs, the same on every machine); `oit merge` joins the shards'
        /// output folders (docs/sharding.md).
        #[arg(long, value_name = "K/N", value_parser = parse_shard)]
        shard: Option<oit_harness::Shard>,
        /// Skip the exactness predictions (each still scene's reference is otherwise rendered
        /// once more to keep its per-pixel lists; docs/predictions.md).
        #[arg(long)]
        no_predict: bool,
        /// Final colour targets every technique runs into, comma-separated, each a run of its
        /// own compared with the same exact reference: rgba16float (half float, the default),
        /// rgba32float, rgba8unorm (linear 8-bit UNORM, as VTK's framebuffer and most
        /// engines' LDR paths: every blend clamps to [0, 1] and rounds to 1/255). Runs at a
        /// format other than the default are labelled `TECHNIQUE @ FORMAT` and their files
        /// named `TECHNIQUE@FORMAT.*`; a technique that cannot composite into a format is
        /// skipped with the reason.
        #[arg(long, value_name = "FORMATS", default_value = "rgba16float", value_parser = parse_target_formats)]
        target_format: TargetFormats,
        #[command(flatten)]
        growth: growth::GrowthArgs,
        #[command(flatten)]
        load: LoadArgs,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// The cheapest configuration within an error budget, per scene and over all scenes given,
    /// with the Pareto front and why each cheaper one fails (docs/recommend.md).
    Recommend(Box<recommend::RecommendArgs>),
    /// Join the output folders of `oit compare --shard K/N` into one results.json, results.md,
    /// plots and report.html, with every run's images.
    Merge {
        /// The shards' output folders (each holds results.json), in any order.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output directory for the merged results; never one of the shard folders.
        #[arg(long)]
        out: PathBuf,
        /// Merge even when shards are missing or were interrupted; the merged results then say
        /// they are incomplete and which shards are missing.
        #[arg(long)]
        allow_missing: bool,
        /// Error axis of the plots and Pareto fronts.
        #[arg(long, default_value = "flip", value_parser = ["flip", "rmse"])]
        metric: String,
        #[command(flatten)]
        bound: growth::BreakArgs,
    },
    /// Rebuild results.md, the plots and the static HTML report of DIR from its results.json.
    Report {
        /// A directory written by `oit compare`.
        dir: PathBuf,
        /// Error axis of the plots and Pareto fronts.
        #[arg(long, default_value = "flip", value_parser = ["flip", "rmse"])]
        metric: String,
        #[command(flatten)]
        bound: growth::BreakArgs,
    },
}

#[derive(Debug, Args)]
struct LoadArgs {
    /// glTF files loaded directly: view from camera N of the asset (`/cameras/N`) instead of
    /// its first camera in node order (or a framed one when it has none). JSON scenes have
    /// their own camera.
    #[arg(long)]
    camera: Option<usize>,
}

impl LoadArgs {
    fn options(&self) -> oit_scene::LoadOptions {
        oit_scene::LoadOptions {
            camera: self.camera,
            ..Default::default()
        }
    }

    /// `--camera` only means something for glTF files: refuse it for a lone JSON scene rather
    /// than ignore it.
    fn check(&self, paths: &[PathBuf]) -> Result<()> {
        if self.camera.is_some()
            && paths
                .iter()
                .all(|p| p.is_file() && !oit_scene::is_gltf_path(p))
        {
            anyhow::bail!(
                "--camera applies to .gltf/.glb files; {} has its own camera (set it in the JSON)",
                paths
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        Ok(())
    }
}

#[derive(Debug, Args)]
struct GpuArgs {
    /// Graphics backend.
    #[arg(long, default_value = "auto", value_parser = ["auto", "vulkan", "gl"])]
    backend: String,
    /// Use the first adapter whose name contains this substring.
    #[arg(long)]
    adapter: Option<String>,
}

impl GpuArgs {
    fn options(&self) -> oit_gpu::ContextOptions {
        let backend = match self.backend.as_str() {
            "vulkan" => oit_gpu::Backend::Vulkan,
            "gl" => oit_gpu::Backend::Gl,
            _ => oit_gpu::Backend::Auto,
        };
        oit_gpu::ContextOptions {
            backend,
            adapter: self.adapter.clone(),
        }
    }
}

/// The formats of `--target-format`, in the order given, each once.
#[derive(Debug, Clone, PartialEq, Eq)]
struct TargetFormats(Vec<oit_results::TargetFormat>);

/// Reads `--target-format` of `oit render`: one format.
fn parse_target_format(text: &str) -> Result<oit_results::TargetFormat, String> {
    oit_results::TargetFormat::parse(text)
}

/// Reads `--target-format` of `oit compare`: a comma-separated list of formats.
fn parse_target_formats(text: &str) -> Result<TargetFormats, String> {
    let mut formats = Vec::new();
    for name in text.split(',') {
        let format = oit_results::TargetFormat::parse(name)?;
        if !formats.contains(&format) {
            formats.push(format);
        }
    }
    Ok(TargetFormats(formats))
}

/// Reads `--shard K/N`.
fn parse_shard(text: &str) -> Result<oit_harness::Shard, String> {
    oit_harness::Shard::parse(text)
}

fn parse_resolution(s: &str) -> Result<Resolution, String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT (e.g. 256x256)"))?;
    let parse = |v: &str, what: &str| -> Result<u32, String> {
        let n: u32 = v
            .trim()
            .parse()
            .map_err(|_| format!("{what} `{v}` is not a whole number"))?;
        if n == 0 || n > Resolution::MAX_DIMENSION {
            return Err(format!(
                "{what} {n} is outside 1..={}",
                Resolution::MAX_DIMENSION
            ));
        }
        Ok(n)
    };
    Ok(Resolution {
        width: parse(w, "width")?,
        height: parse(h, "height")?,
    })
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if cli.command.opens_gpu()
        && let Some(code) = runtime_dir::reexec_with_private_runtime_dir()
    {
        return code;
    }
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<Interrupted>() => {
            eprintln!("oit: {e}");
            ExitCode::from(130)
        }
        Err(e) if e.is::<RunsFailed>() => {
            eprintln!("oit: {e}");
            ExitCode::from(RUNS_FAILED_EXIT)
        }
        Err(e) if e.is::<recommend::NotMet>() => {
            eprintln!("oit: {e}");
            ExitCode::from(recommend::NOT_MET_EXIT)
        }
        Err(e) => {
            eprintln!("oit: error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, each cause once: most messages already end with their
/// cause's text (`file: cannot read: No such file…`), which `{:#}` would repeat.
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

impl Command {
    /// Whether the command opens a GPU adapter (and with it Mesa's drivers).
    fn opens_gpu(&self) -> bool {
        matches!(self, Command::Render { .. } | Command::Compare { .. })
            || matches!(self, Command::Recommend(args) if args.opens_gpu())
    }
}

/// `compare` stopped by Ctrl-C after writing what it finished.
#[derive(Debug)]
struct Interrupted(String);

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// `compare` wrote every output, but some runs failed (a scene that did not load or fit, a
/// technique the GPU refused): exit [`RUNS_FAILED_EXIT`], so scripts notice.
#[derive(Debug)]
struct RunsFailed(String);

/// The exit code of [`RunsFailed`] (docs/outputs.md).
const RUNS_FAILED_EXIT: u8 = 4;

impl std::fmt::Display for RunsFailed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RunsFailed {}

/// The tables `oit techniques --markdown` generates.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum MarkdownArg {
    Techniques,
    Transmission,
    Operators,
}

impl From<MarkdownArg> for oit_harness::MarkdownTable {
    fn from(arg: MarkdownArg) -> Self {
        match arg {
            MarkdownArg::Techniques => oit_harness::MarkdownTable::Techniques,
            MarkdownArg::Transmission => oit_harness::MarkdownTable::Transmission,
            MarkdownArg::Operators => oit_harness::MarkdownTable::Operators,
        }
    }
}

impl std::error::Error for Interrupted {}

fn run(command: Command) -> Result<()> {
    match command {
        Command::Scenes { path, json, load } => {
            load.check(std::slice::from_ref(&path))?;
            scenes::scenes(&path, json, &load.options())
        }
        Command::Analyze {
            scenes,
            json,
            resolution,
            memory_budget,
            load,
        } => {
            load.check(&scenes)?;
            analyze::run(
                &scenes,
                json,
                resolution,
                mib(memory_budget),
                &load.options(),
            )
        }
        Command::CostModel {
            results,
            json,
            absolute,
        } => cost_model::run(&results, json.as_deref(), absolute),
        Command::Techniques { json, markdown } => {
            if json {
                println!("{}", oit_harness::techniques_json());
            } else if let Some(table) = markdown {
                print!("{}", oit_harness::techniques_markdown(table.into()));
            } else {
                print!("{}", oit_harness::techniques_help());
            }
            Ok(())
        }
        Command::Reference {
            scene,
            output,
            resolution,
            memory_budget,
            animation_frames,
            load,
        } => {
            load.check(std::slice::from_ref(&scene))?;
            let frames = frame_outputs(
                &scene,
                resolution,
                animation_frames,
                output,
                &load.options(),
            )?;
            // Every frame is the same asset: its notes once.
            if let Some(first) = frames.first() {
                notes::print_scene(&first.scene);
            }
            for frame in frames {
                reference(frame, mib(memory_budget))?;
            }
            Ok(())
        }
        Command::Render {
            scene,
            technique,
            output,
            resolution,
            animation_frames,
            target_format,
            load,
            gpu,
        } => {
            load.check(std::slice::from_ref(&scene))?;
            let frames = frame_outputs(
                &scene,
                resolution,
                animation_frames,
                output,
                &load.options(),
            )?;
            render(frames, &technique, target_format, &gpu)
        }
        Command::Compare {
            scenes,
            techniques,
            out,
            resolution,
            frames,
            warmup,
            cache,
            no_cache,
            cache_cap,
            resume,
            retime,
            max_runs,
            memory_budget,
            run_budget,
            metric,
            animation_frames,
            static_frames,
            shard,
            no_predict,
            target_format,
            growth,
            load,
            gpu,
        } => {
            load.check(&scenes)?;
            let cache = match (no_cache, cache) {
                (true, _) => oit_harness::ReferenceCache::Off,
                (false, Some(dir)) => oit_harness::ReferenceCache::Dir(dir),
                (false, None) => oit_harness::ReferenceCache::Default,
            };
            let options = oit_harness::CompareOptions {
                resolution,
                frames,
                warmup,
                out_dir: out,
                cache,
                cache_cap: mib(cache_cap),
                memory_budget: mib(memory_budget),
                run_budget: Duration::from_secs(run_budget),
                resume,
                retime,
                cancel: None,
                context: gpu.options(),
                animation_frames,
                static_frames,
                shard,
                predict: !no_predict,
                target_formats: target_format.0,
            };
            compare(
                &scenes,
                &techniques,
                &options,
                &load.options(),
                (parse_metric(&metric), &growth),
                max_runs,
            )
        }
        Command::Recommend(args) => recommend::run(*args),
        Command::Report { dir, metric, bound } => {
            let results = oit_harness::results::Results::read(&dir.join("results.json"))?;
            if !results.complete {
                eprintln!(
                    "note: {} is incomplete (an interrupted comparison): `oit compare … --out {} --resume` finishes it",
                    dir.join("results.json").display(),
                    dir.display()
                );
            }
            let html = write_report(&dir, &results, parse_metric(&metric), bound.break_at)?;
            println!("wrote {}", html.display());
            Ok(())
        }
        Command::Merge {
            dirs,
            out,
            allow_missing,
            metric,
            bound,
        } => {
            let results = oit_harness::merge(&dirs, &out, allow_missing)?;
            print!("{}", oit_harness::report::terminal_table(&results));
            let html = write_report(&out, &results, parse_metric(&metric), bound.break_at)?;
            println!(
                "\nwrote {} ({} runs from {} shards), {} and {}",
                out.join("results.json").display(),
                results.runs.len(),
                results.merged.len(),
                out.join("results.md").display(),
                html.display()
            );
            Ok(())
        }
    }
}

/// Every GPU command names the adapter first: timings mean nothing without it.
fn print_adapter(ctx: &oit_gpu::Context) {
    let info = ctx.adapter_info();
    eprintln!(
        "adapter: {} ({}, {}, {} {})",
        info.name, info.backend, info.device_type, info.driver, info.driver_info
    );
}

/// The error of a command given no scene file: an empty folder is a mistake.
fn no_scene_files(paths: &[PathBuf]) -> anyhow::Error {
    anyhow::anyhow!(
        "no scene files (*.json, *.gltf, *.glb) found in {}",
        paths
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// The scenes of `paths`, or an error when there are none (an empty folder is a mistake).
fn load_some_scenes(
    paths: &[PathBuf],
    load: &oit_scene::LoadOptions,
) -> Result<Vec<oit_harness::SceneEntry>> {
    let (scenes, skipped) = oit_harness::load_scenes_noting(paths, load)?;
    note_skipped(&skipped);
    if scenes.is_empty() {
        return Err(no_scene_files(paths));
    }
    Ok(scenes)
}

/// One line per JSON file of a scene folder that is not a scene (`metadata.json` beside a
/// downloaded model).
fn note_skipped(skipped: &[oit_harness::SkippedFile]) {
    for s in skipped {
        eprintln!("note: {}", oit_harness::report::printable(&s.note()));
    }
}

/// Where `reference` and `render` write: `output` or the default name, refused when it is not
/// an `.exr` path or when it or its PNG preview would replace any file the scene was read
/// from (the scene file, a glTF asset, its buffers and textures). Temporaries an interrupted
/// earlier run left in that folder are removed.
fn output_paths(
    output: Option<PathBuf>,
    default_stem: &str,
    inputs: &[PathBuf],
) -> Result<(PathBuf, PathBuf)> {
    let exr = output.unwrap_or_else(|| PathBuf::from(format!("{default_stem}.exr")));
    if !exr
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
    {
        bail!(
            "{}: the output must be an .exr path (the PNG preview is written beside it)",
            exr.display()
        );
    }
    let png = exr.with_extension("png");
    oit_harness::inputs::refuse_outputs_on_inputs(&[&exr, &png], inputs)?;
    let dir = match exr.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    oit_metrics::remove_stale_temporaries(dir);
    Ok((exr, png))
}

fn progress_bar(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template(
            "{msg:>24} [{bar:32}] {pos}/{len} {elapsed_precise} (about {eta} left)",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    bar.set_message(what.to_owned());
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

/// MiB to bytes (the flag's unit), saturating.
fn mib(value: u64) -> u64 {
    value.saturating_mul(1 << 20)
}

/// One frame of a scene to write, and where: the EXR and its PNG preview.
struct FrameOutput {
    scene: Scene,
    scene_path: PathBuf,
    inputs: Vec<PathBuf>,
    output: Option<PathBuf>,
    /// `-fNNNN`, inserted before the extension, when several frames are written.
    suffix: String,
}

/// The frames `selection` asks for (frame 0 when `None`), each with its output name. Every
/// frame is validated before anything is written.
fn frame_outputs(
    scene_path: &Path,
    resolution: Option<Resolution>,
    selection: Option<oit_harness::motion::FrameSelection>,
    output: Option<PathBuf>,
    load: &oit_scene::LoadOptions,
) -> Result<Vec<FrameOutput>> {
    let (frames, inputs) = oit_scene::load_frames(scene_path, load)?;
    let selected = match selection {
        None => vec![0],
        Some(s) => s
            .frames(frames.count())
            .map_err(|e| anyhow::anyhow!("{}: {e}", scene_path.display()))?,
    };
    let several = selected.len() > 1;
    selected
        .into_iter()
        .map(|t| {
            let scene = frames.frame(t)?;
            let scene = match resolution {
                Some(r) => scene.with_resolution(r),
                None => scene,
            };
            let suffix = if several {
                format!("-f{t:04}")
            } else {
                String::new()
            };
            let output_of_frame = output.as_ref().map(|o| {
                let stem = o
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                let ext = o
                    .extension()
                    .map(|e| e.to_string_lossy().into_owned())
                    .unwrap_or_default();
                o.with_file_name(format!("{stem}{suffix}.{ext}"))
            });
            Ok(FrameOutput {
                scene,
                scene_path: scene_path.to_path_buf(),
                inputs: inputs.clone(),
                output: output_of_frame,
                suffix,
            })
        })
        .collect()
}

fn reference(frame: FrameOutput, memory_budget: u64) -> Result<()> {
    let FrameOutput {
        scene,
        scene_path,
        inputs,
        output,
        suffix,
    } = frame;
    let scene_path = scene_path.as_path();
    let default = format!("{}-reference{suffix}", oit_harness::file_stem(&scene.name));
    let (output, png) = output_paths(output, &default, &inputs)?;
    let bar = progress_bar(0, &format!("reference {}", scene.name));
    let tick = bar.clone();
    let progress: oit_reference::Progress =
        std::sync::Arc::new(move |done: usize, total: usize| {
            tick.set_length(total as u64);
            tick.set_position(done as u64);
        });
    let options = oit_reference::ReferenceOptions {
        progress: Some(progress),
        memory_budget,
        ..Default::default()
    };
    let before = oit_harness::interference::sample();
    let reference = oit_reference::try_render(&scene, &options)
        .with_context(|| format!("reference of {}", scene_path.display()))?;
    let interference = before
        .zip(oit_harness::interference::sample())
        .and_then(|(a, b)| {
            oit_harness::interference::Interference::between(
                a,
                b,
                oit_harness::interference::TICKS_PER_SECOND,
            )
        });
    bar.finish_and_clear();
    oit_harness::write_reference_exr(&output, &reference)?;
    oit_metrics::write_png_preview(&png, &reference.image)?;
    let st = &reference.stats;
    let name = match scene.animation {
        Some(_) => format!("{} frame {}", scene.name, scene.frame),
        None => scene.name.clone(),
    };
    println!(
        "{}: {} at {}: {} fragments, depth complexity max {} mean {:.2}, {:.3} s ({:.1} M fragments/s)",
        name,
        output.display(),
        scene.resolution,
        st.fragments,
        st.max_depth_complexity,
        st.mean_depth_complexity,
        st.seconds,
        st.fragments_per_second / 1e6
    );
    for caveat in oit_harness::results::reference_caveats(st) {
        println!("note: {caveat}");
    }
    if let Some(i) = interference.filter(|i| i.notable()) {
        println!(
            "note: timed while {:.0} % of the machine's CPU time went elsewhere ({}): on a quiet machine it takes less",
            100.0 * i.lost(),
            i.describe()
        );
    }
    println!("preview: {}", png.display());
    Ok(())
}

fn render(
    frames: Vec<FrameOutput>,
    spec: &str,
    format: oit_results::TargetFormat,
    gpu: &GpuArgs,
) -> Result<()> {
    let spec = oit_harness::parse_spec(spec)?;
    // Refused before the GPU is opened: a bad output costs nothing.
    let mut planned = Vec::with_capacity(frames.len());
    for frame in frames {
        let default = format!(
            "{}-{}{}{}",
            oit_harness::file_stem(&frame.scene.name),
            oit_harness::file_stem(&spec.canonical()),
            format.file_suffix(),
            frame.suffix
        );
        let (output, png) = output_paths(frame.output.clone(), &default, &frame.inputs)?;
        planned.push((frame.scene, output, png));
    }
    let ctx = oit_harness::open_context(&gpu.options())?;
    print_adapter(&ctx);
    if let Some((scene, _, _)) = planned.first() {
        notes::print_scene(scene);
    }
    for (scene, output, png) in planned {
        // One call with no steps to count: a spinner with the time so far (a deep peel can
        // take minutes on a CPU adapter).
        let spinner = ProgressBar::new_spinner();
        spinner.set_style(
            ProgressStyle::with_template("{spinner} {msg} {elapsed_precise}")
                .expect("static template"),
        );
        let label = oit_results::technique_label(&spec.canonical(), format);
        spinner.set_message(format!(
            "rendering {} frame {} with {label}",
            scene.name, scene.frame,
        ));
        spinner.enable_steady_tick(Duration::from_millis(200));
        let frame = oit_harness::render_once_at(&ctx, &scene, &spec, format);
        spinner.finish_and_clear();
        let frame = frame?;
        oit_metrics::write_exr(
            &output,
            &[oit_metrics::ExrLayer::new("render", &frame.image)],
        )?;
        oit_metrics::write_png_preview(&png, &frame.image)?;
        println!(
            "{} frame {} with {label}: {} ({})",
            scene.name,
            scene.frame,
            output.display(),
            png.display()
        );
    }
    Ok(())
}

/// Reads `--animation-frames`.
fn parse_frames(text: &str) -> std::result::Result<oit_harness::motion::FrameSelection, String> {
    oit_harness::motion::FrameSelection::parse(text)
}

fn parse_metric(name: &str) -> oit_report::Metric {
    if name == "rmse" {
        oit_report::Metric::Rmse
    } else {
        oit_report::Metric::Flip
    }
}

/// Everything a person reads after a comparison: results.md with the Pareto fronts, the plots
/// (SVG and PNG) and the static HTML report, all on `metric`'s error axis. Returns the HTML
/// file.
fn write_report(
    dir: &Path,
    results: &oit_harness::results::Results,
    metric: oit_report::Metric,
    break_at: f64,
) -> Result<PathBuf> {
    let mut markdown = oit_harness::report::markdown(results);
    markdown.push_str(&oit_report::pareto_markdown(results, metric));
    markdown.push_str(&oit_report::growth_markdown(results, metric, break_at));
    oit_metrics::write_atomic_bytes(&dir.join("results.md"), markdown.as_bytes())?;
    Ok(oit_report::write_html_report_with(
        dir,
        metric,
        &oit_harness::report::short_spec,
        break_at,
    )?)
}

fn compare(
    paths: &[PathBuf],
    specs: &[String],
    options: &oit_harness::CompareOptions,
    load: &oit_scene::LoadOptions,
    (metric, growth): (oit_report::Metric, &growth::GrowthArgs),
    max_runs: u64,
) -> Result<()> {
    let (scenes, unloadable) = load_for_comparison(paths, load)?;
    let scenes = growth::vary(scenes, growth, options.resolution)?;
    // Specs are validated (and sweeps bounded) before the GPU is opened.
    let specs = oit_harness::resolve_specs(specs)?;
    let results = run_comparison(paths, &scenes, &unloadable, &specs, options, max_runs)?;
    print!("{}", oit_harness::report::terminal_table(&results));
    growth::print_tables(&results, metric, &growth.bound);
    finish_comparison(&results, &options.out_dir, metric, growth.bound.break_at)?;
    fail_on_failed_runs(&results, &options.out_dir)
}

/// The scenes of a comparison: one scene that does not load is reported as failed; the others
/// run.
fn load_for_comparison(
    paths: &[PathBuf],
    load: &oit_scene::LoadOptions,
) -> Result<(Vec<oit_harness::SceneEntry>, Vec<oit_harness::Unloadable>)> {
    let (scenes, unloadable, skipped) = oit_harness::load_scenes_lenient(paths, load)?;
    note_skipped(&skipped);
    if scenes.is_empty() && unloadable.is_empty() {
        return Err(no_scene_files(paths));
    }
    for u in &unloadable {
        eprintln!(
            "warning: {}: not loaded, its runs are reported as failed: {}",
            u.path.display(),
            u.error
        );
    }
    Ok((scenes, unloadable))
}

/// Runs `specs` on the scenes with a progress bar (Ctrl-C stops after the run in progress)
/// and returns what results.json holds; `compare` and `recommend` share it.
fn run_comparison(
    paths: &[PathBuf],
    scenes: &[oit_harness::SceneEntry],
    unloadable: &[oit_harness::Unloadable],
    specs: &[oit_gpu::TechniqueSpec],
    options: &oit_harness::CompareOptions,
    max_runs: u64,
) -> Result<oit_harness::results::Results> {
    // The output folder is never a scene folder, nor holds a file a scene reads.
    let scene_dirs: Vec<PathBuf> = paths.iter().filter(|p| p.is_dir()).cloned().collect();
    let inputs: Vec<PathBuf> = (scenes.iter().flat_map(|e| e.inputs.iter().cloned()))
        .chain(unloadable.iter().map(|u| u.path.clone()))
        .collect();
    oit_harness::inputs::refuse_out_dir_over_inputs(&options.out_dir, &scene_dirs, &inputs)?;
    let scene_count = scenes.len() + unloadable.len();
    // Every scene × technique pair is a run per target format.
    let formats = options.target_formats.len().max(1) as u64;
    let total = (scene_count as u64) * (specs.len() as u64);
    // A shard is bounded by the runs it makes.
    let runs = formats
        * options.shard.map_or(total, |s| {
            let r = s.range(total);
            r.end - r.start
        });
    let total = total * formats;
    let shape = if formats > 1 {
        format!(
            "{scene_count} scenes × {} techniques × {formats} target formats",
            specs.len()
        )
    } else {
        format!("{scene_count} scenes × {} techniques", specs.len())
    };
    if let Some(shard) = options.shard {
        eprintln!("shard {shard}: {runs} of the comparison's {total} runs");
    }
    if runs > max_runs {
        bail!("{runs} runs ({shape}) is more than --max-runs {max_runs}; raise it to run them all");
    }
    let ctx = oit_harness::open_context(&options.context)?;
    print_adapter(&ctx);
    eprintln!(
        "{runs} runs ({shape}), one untimed first frame, {} warm-up and {} timed frames each; at most {} s a run",
        options.warmup,
        options.frames,
        options.run_budget.as_secs()
    );
    if options.retime > 0 {
        eprintln!(
            "frames timed while over {:.0} % of the CPU went elsewhere are timed again, up to {} times",
            100.0 * oit_harness::interference::NOTABLE,
            options.retime
        );
    }
    // Ctrl-C stops after the run in progress (a second one ends the process at once).
    let cancel = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let flag = cancel.clone();
    let _ = ctrlc::set_handler(move || {
        if flag.swap(true, std::sync::atomic::Ordering::SeqCst) {
            std::process::exit(130);
        }
        eprintln!("\ninterrupted: stopping after the run in progress (Ctrl-C again to stop now)");
    });
    let options = oit_harness::CompareOptions {
        cancel: Some(cancel),
        ..options.clone()
    };
    let bar = progress_bar(runs, "compare");
    // Warnings and notices reach stderr whether or not it is a terminal (logs, CI, cron): the
    // bar only draws on a terminal, so they are printed around it, not through it.
    let say = |line: String| bar.suspend(|| eprintln!("{line}"));
    let results =
        oit_harness::compare_all(
            &ctx,
            scenes,
            unloadable,
            specs,
            &options,
            &|event| match event {
                oit_harness::Event::RunDone {
                    scene,
                    technique,
                    resumed,
                } => {
                    let kept = if resumed { " (kept)" } else { "" };
                    bar.set_message(format!(
                        "{} {technique}{kept}",
                        oit_harness::report::printable(scene)
                    ));
                    bar.inc(1);
                }
                oit_harness::Event::Warning(line) => {
                    say(format!("warning: {}", oit_harness::report::printable(line)))
                }
                oit_harness::Event::Notice(line) => {
                    say(format!("note: {}", oit_harness::report::printable(line)))
                }
                oit_harness::Event::FrameDone { scene, done, of } => {
                    bar.set_message(format!(
                        "{} motion {done}/{of}",
                        oit_harness::report::printable(scene)
                    ));
                }
            },
        )?;
    bar.finish_and_clear();
    Ok(results)
}

/// After a comparison: results.md, the plots and report.html; an interrupted one is an error.
fn finish_comparison(
    results: &oit_harness::results::Results,
    out_dir: &Path,
    metric: oit_report::Metric,
    break_at: f64,
) -> Result<()> {
    let html = write_report(out_dir, results, metric, break_at)?;
    println!(
        "\nwrote {}, {} and {}",
        out_dir.join("results.json").display(),
        out_dir.join("results.md").display(),
        html.display()
    );
    if !results.complete {
        return Err(Interrupted(format!(
            "interrupted: {} runs are in {}; run the same command with --resume to finish the rest",
            results.runs.len(),
            out_dir.join("results.json").display()
        ))
        .into());
    }
    Ok(())
}

/// After `compare` wrote everything: [`RunsFailed`] when any run failed.
fn fail_on_failed_runs(results: &oit_harness::results::Results, out_dir: &Path) -> Result<()> {
    let failed = (results.runs.iter())
        .filter(|r| r.status == oit_harness::results::RunStatus::Failed)
        .count();
    if failed > 0 {
        return Err(RunsFailed(format!(
            "{failed} of {} runs failed (each with its reason in results.md and report.html); the rest are in {}",
            results.runs.len(),
            out_dir.display()
        ))
        .into());
    }
    Ok(())
}

/// Mesa's drivers print `error: XDG_RUNTIME_DIR is invalid or not set in the environment.`
/// twice at every start when the variable is unset or names no private folder (a root shell,
/// cron, CI). The workspace forbids `unsafe`, so `std::env::set_var` is out; instead `oit`
/// runs itself once more with the variable naming a private folder of its own.
mod runtime_dir {
    use std::path::{Path, PathBuf};
    use std::process::ExitCode;

    /// Set in the re-executed process so it never re-executes again.
    const MARK: &str = "OIT_RUNTIME_DIR_SET";

    /// `Some(exit code)` when the command ran in a re-executed child; `None` to go on here
    /// (the variable is fine, or no private folder could be made: Mesa's lines are harmless).
    pub fn reexec_with_private_runtime_dir() -> Option<ExitCode> {
        if std::env::var_os(MARK).is_some() {
            return None;
        }
        if std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|d| usable(Path::new(&d))) {
            return None;
        }
        let dir = private_dir()?;
        let exe = std::env::current_exe().ok()?;
        // Ctrl-C goes to both processes: the child decides (compare stops after its run), this
        // one waits for it instead of dying and leaving it behind.
        let _ = ctrlc::set_handler(|| {});
        let status = std::process::Command::new(exe)
            .args(std::env::args_os().skip(1))
            .env("XDG_RUNTIME_DIR", &dir)
            .env(MARK, "1")
            .status()
            .ok()?;
        Some(match status.code() {
            Some(code) => ExitCode::from(code.clamp(0, 255) as u8),
            // Killed by a signal (Ctrl-C reaches both processes): 128 + signal, as shells say.
            None => ExitCode::from(130),
        })
    }

    /// What Mesa accepts: a folder owned by this user, mode 0700.
    fn usable(dir: &Path) -> bool {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            std::fs::metadata(dir).is_ok_and(|m| {
                m.is_dir()
                    && m.mode() & 0o777 == 0o700
                    && m.uid() == current_uid().unwrap_or(u32::MAX)
            })
        }
        #[cfg(not(unix))]
        {
            dir.is_dir()
        }
    }

    /// The owner of `/proc/self` (Linux) is this process's user.
    fn current_uid() -> Option<u32> {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            std::fs::metadata("/proc/self").ok().map(|m| m.uid())
        }
        #[cfg(not(unix))]
        {
            None
        }
    }

    /// `$TMPDIR/oit-runtime-UID`, created with mode 0700 (or reused when it already is).
    fn private_dir() -> Option<PathBuf> {
        let dir = std::env::temp_dir().join(format!("oit-runtime-{}", current_uid()?));
        #[cfg(unix)]
        {
            use std::os::unix::fs::{DirBuilderExt, PermissionsExt};
            let _ = std::fs::DirBuilder::new().mode(0o700).create(&dir);
            let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
        }
        usable(&dir).then_some(dir)
    }
}
