//! `oit`: compare order-independent transparency techniques against an exact CPU reference.
//!
//! Exit codes: 0 on success; 1 with one line on stderr otherwise; 2 for usage errors (clap).

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use oit_scene::{Resolution, Scene};

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
    /// List scenes with triangle counts and depth complexity (from the reference).
    Scenes {
        /// A scene file (.json, .gltf, .glb) or a directory of them.
        #[arg(default_value = "scenes")]
        path: PathBuf,
        #[command(flatten)]
        load: LoadArgs,
    },
    /// List every technique with its parameters and defaults.
    Techniques,
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
        /// Untimed warm-up frames per run.
        #[arg(long, default_value_t = 3)]
        warmup: u32,
        /// Where computed references are cached (keyed by scene content and resolution; each
        /// file checksummed). Default: $OIT_CACHE_DIR, else $XDG_CACHE_HOME/oit-lab/references,
        /// else ~/.cache/oit-lab/references.
        #[arg(long, conflicts_with = "no_cache")]
        cache: Option<PathBuf>,
        /// Compute every reference, read and write no cache.
        #[arg(long)]
        no_cache: bool,
        /// Keep the runs of OUT/results.json made from identical inputs (scene content,
        /// technique, resolution, frames, warm-up, adapter) and run only the rest.
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
        /// Memory the reference may hold for fragments, in MiB (default 2048); a scene that
        /// needs more for one pixel fails naming that pixel.
        #[arg(long, value_name = "MIB", default_value_t = 2048, value_parser = clap::value_parser!(u64).range(1..))]
        memory_budget: u64,
        /// Error axis of the plots and Pareto fronts.
        #[arg(long, default_value = "flip", value_parser = ["flip", "rmse"])]
        metric: String,
        #[command(flatten)]
        load: LoadArgs,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Rebuild results.md, the plots and the static HTML report of DIR from its results.json.
    Report {
        /// A directory written by `oit compare`.
        dir: PathBuf,
        /// Error axis of the plots and Pareto fronts.
        #[arg(long, default_value = "flip", value_parser = ["flip", "rmse"])]
        metric: String,
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
    match run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
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

fn run(command: Command) -> Result<()> {
    match command {
        Command::Scenes { path, load } => {
            load.check(std::slice::from_ref(&path))?;
            scenes(&path, &load.options())
        }
        Command::Techniques => {
            print!("{}", oit_harness::techniques_help());
            Ok(())
        }
        Command::Reference {
            scene,
            output,
            resolution,
            memory_budget,
            load,
        } => {
            load.check(std::slice::from_ref(&scene))?;
            reference(
                &scene,
                output,
                resolution,
                mib(memory_budget),
                &load.options(),
            )
        }
        Command::Render {
            scene,
            technique,
            output,
            resolution,
            load,
            gpu,
        } => {
            load.check(std::slice::from_ref(&scene))?;
            render(
                &scene,
                &technique,
                output,
                resolution,
                &load.options(),
                &gpu,
            )
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
            resume,
            retime,
            max_runs,
            memory_budget,
            metric,
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
                reference_memory_budget: mib(memory_budget),
                resume,
                retime,
                context: gpu.options(),
            };
            compare(
                &scenes,
                &techniques,
                &options,
                &load.options(),
                parse_metric(&metric),
                max_runs,
            )
        }
        Command::Report { dir, metric } => {
            let results = oit_harness::results::Results::read(&dir.join("results.json"))?;
            let html = write_report(&dir, &results, parse_metric(&metric))?;
            println!("wrote {}", html.display());
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

fn load_scene(
    path: &Path,
    resolution: Option<Resolution>,
    load: &oit_scene::LoadOptions,
) -> Result<Scene> {
    let scene = oit_scene::load_with(path, load)?;
    Ok(match resolution {
        Some(r) => scene.with_resolution(r),
        None => scene,
    })
}

/// The scenes of `paths`, or an error when there are none (an empty folder is a mistake).
fn load_some_scenes(
    paths: &[PathBuf],
    load: &oit_scene::LoadOptions,
) -> Result<Vec<oit_harness::SceneEntry>> {
    let scenes = oit_harness::load_scenes_with(paths, load)?;
    if scenes.is_empty() {
        bail!(
            "no scene files (*.json, *.gltf, *.glb) found in {}",
            paths
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(scenes)
}

/// Where `reference` and `render` write: `output` or the default name, refused when it is not
/// an `.exr` path or when it or its PNG preview would replace the scene file being read.
fn output_paths(
    output: Option<PathBuf>,
    default_stem: &str,
    scene: &Path,
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
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    for target in [&exr, &png] {
        if same(target, scene) {
            bail!(
                "{}: would replace the scene being read; choose another output",
                target.display()
            );
        }
    }
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

fn scenes(path: &Path, load: &oit_scene::LoadOptions) -> Result<()> {
    let entries = load_some_scenes(&[path.to_path_buf()], load)?;
    println!(
        "{:<22} {:>9} {:>9} {:>9} {:>7} {:>9} {:>10}",
        "scene", "size", "triangles", "transp.", "draws", "max depth", "mean depth"
    );
    for entry in &entries {
        let s = &entry.scene;
        let reference = oit_reference::try_render(s, &oit_reference::ReferenceOptions::default())
            .with_context(|| format!("reference of {}", entry.path.display()))?;
        println!(
            "{:<22} {:>9} {:>9} {:>9} {:>7} {:>9} {:>10.2}",
            s.name,
            s.resolution.to_string(),
            s.triangle_count(),
            s.transparent_triangle_count(),
            s.draws.len(),
            reference.stats.max_depth_complexity,
            reference.stats.mean_depth_complexity,
        );
        // Real content says where it came from and what of it is not modelled.
        if !(s.textures.is_empty() && s.credits.is_empty() && s.ignored.is_empty()) {
            for line in oit_harness::results::SceneJson::of(s, "").report_lines() {
                println!("  {line}");
            }
        }
    }
    Ok(())
}

/// MiB to bytes (the flag's unit), saturating.
fn mib(value: u64) -> u64 {
    value.saturating_mul(1 << 20)
}

fn reference(
    scene_path: &Path,
    output: Option<PathBuf>,
    resolution: Option<Resolution>,
    memory_budget: u64,
    load: &oit_scene::LoadOptions,
) -> Result<()> {
    let scene = load_scene(scene_path, resolution, load)?;
    let default = format!("{}-reference", oit_harness::file_stem(&scene.name));
    let (output, png) = output_paths(output, &default, scene_path)?;
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
    println!(
        "{}: {} at {}: {} fragments, depth complexity max {} mean {:.2}, {:.3} s ({:.1} M fragments/s)",
        scene.name,
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
    scene_path: &Path,
    spec: &str,
    output: Option<PathBuf>,
    resolution: Option<Resolution>,
    load: &oit_scene::LoadOptions,
    gpu: &GpuArgs,
) -> Result<()> {
    let scene = load_scene(scene_path, resolution, load)?;
    let ctx = oit_harness::open_context(&gpu.options())?;
    print_adapter(&ctx);
    let spec = oit_harness::parse_spec(spec)?;
    let default = format!(
        "{}-{}",
        oit_harness::file_stem(&scene.name),
        oit_harness::file_stem(&spec.canonical())
    );
    let (output, png) = output_paths(output, &default, scene_path)?;
    // One call with no steps to count: a spinner with the time so far (a deep peel can take
    // minutes on a CPU adapter).
    let spinner = ProgressBar::new_spinner();
    spinner.set_style(
        ProgressStyle::with_template("{spinner} {msg} {elapsed_precise}").expect("static template"),
    );
    spinner.set_message(format!(
        "rendering {} with {}",
        scene.name,
        spec.canonical()
    ));
    spinner.enable_steady_tick(Duration::from_millis(200));
    let frame = oit_harness::render_once(&ctx, &scene, &spec);
    spinner.finish_and_clear();
    let frame = frame?;
    oit_metrics::write_exr(
        &output,
        &[oit_metrics::ExrLayer::new("render", &frame.image)],
    )?;
    oit_metrics::write_png_preview(&png, &frame.image)?;
    println!(
        "{} with {}: {} ({})",
        scene.name,
        spec.canonical(),
        output.display(),
        png.display()
    );
    Ok(())
}

fn parse_metric(name: &str) -> oit_report::Metric {
    if name == "rmse" {
        oit_report::Metric::Rmse
    } else {
        oit_report::Metric::Flip
    }
}

/// Everything a person reads after a comparison: results.md with the Pareto fronts, the plots
/// (SVG and PNG) and the static HTML report. Returns the HTML file.
fn write_report(
    dir: &Path,
    results: &oit_harness::results::Results,
    metric: oit_report::Metric,
) -> Result<PathBuf> {
    let mut markdown = oit_harness::report::markdown(results);
    markdown.push_str(&oit_report::pareto_markdown(results, metric));
    oit_metrics::write_atomic_bytes(&dir.join("results.md"), markdown.as_bytes())?;
    oit_report::write_plots(results, &dir.join("plots"), metric)?;
    Ok(oit_report::write_html_report(dir)?)
}

fn compare(
    paths: &[PathBuf],
    specs: &[String],
    options: &oit_harness::CompareOptions,
    load: &oit_scene::LoadOptions,
    metric: oit_report::Metric,
    max_runs: u64,
) -> Result<()> {
    let scenes = load_some_scenes(paths, load)?;
    // Specs are validated (and sweeps bounded) before the GPU is opened.
    let specs = oit_harness::resolve_specs(specs)?;
    let runs = (scenes.len() as u64) * (specs.len() as u64);
    if runs > max_runs {
        bail!(
            "{runs} runs ({} scenes × {} techniques) is more than --max-runs {max_runs}; raise it to run them all",
            scenes.len(),
            specs.len()
        );
    }
    let ctx = oit_harness::open_context(&options.context)?;
    print_adapter(&ctx);
    eprintln!(
        "{runs} runs ({} scenes × {} techniques), {} timed + {} warm-up frames each{}",
        scenes.len(),
        specs.len(),
        options.frames,
        options.warmup,
        if options.resume {
            "; finished runs of the earlier results are kept"
        } else {
            ""
        }
    );
    if options.retime > 0 {
        eprintln!(
            "frames timed while over {:.0} % of the CPU went elsewhere are timed again, up to {} times",
            100.0 * oit_harness::interference::NOTABLE,
            options.retime
        );
    }
    let bar = progress_bar(runs, "compare");
    let results = oit_harness::compare(&ctx, &scenes, &specs, options, &|event| match event {
        oit_harness::Event::RunDone {
            scene,
            technique,
            resumed,
        } => {
            let kept = if resumed { " (kept)" } else { "" };
            bar.set_message(format!("{scene} {technique}{kept}"));
            bar.inc(1);
        }
        oit_harness::Event::Warning(line) => bar.println(format!("warning: {line}")),
    })?;
    bar.finish_and_clear();
    print!("{}", oit_harness::report::terminal_table(&results));
    let html = write_report(&options.out_dir, &results, metric)?;
    println!(
        "\nwrote {}, {} and {}",
        options.out_dir.join("results.json").display(),
        options.out_dir.join("results.md").display(),
        html.display()
    );
    Ok(())
}
