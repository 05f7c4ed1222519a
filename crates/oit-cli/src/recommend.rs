//! `oit recommend`: the cheapest configuration within an error budget, per scene and over the
//! scenes given, from a comparison it runs (resumable) or from an existing results.json. The
//! choice itself is `oit_report::recommend`; definitions in docs/recommend.md.

use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context as _, Result};
use clap::Args;
use oit_report::recommend::{Budget, DEFAULT_TIE, Question, Recommendation};
use oit_scene::Resolution;

/// Exit status when the budget is not met (no configuration within it on a scene, or, with
/// several scenes, none within it on every one).
pub const NOT_MET_EXIT: u8 = 3;

const DEFINITIONS: &str = "\
Definitions (docs/recommend.md):
  --max-flip X   bounds the run's headline FLIP: HDR-FLIP (error.hdr_flip_mean) on a scene
                 whose reference exceeds 1, LDR-FLIP (error.flip_mean, Reinhard tone map)
                 otherwise; on an animated scene also every measured frame's.
  --max-error X  bounds the largest absolute linear RGB channel error (error.max_abs).
  A run with non-finite pixels meets no budget. Both bounds may be given; both must hold.
  cost           cost × floor: the run's median GPU frame time over the floor's (one blended
                 vertex-colour pass over the same draws), both timed in the same comparison.
  candidates     every technique at its defaults plus front-peel:layers=1,2,4,8,16,
                 dual-peel:passes=1,2,3,8,auto, stochastic:spp=4,16, a2c:samples=8,
                 mboit:moments=power4,power8, linked-list:nodes-per-pixel=128,sort-max=128,
                 k-buffer:k=1,2,4,16,32 (36 configurations); -t replaces them; with --from,
                 every configuration the file holds.
  ties           passing configurations whose cost is within a factor 1 + --tie of the cheapest
                 passing one are equally cheap (timing noise); the most accurate of them is
                 recommended, the others are listed as tied.
  several scenes the configuration within budget on every scene with the lowest geometric mean
                 of cost × floor over the scenes (ties as above, broken by the worst error).
Exit status: 0 within budget; 3 when no configuration meets it (on a scene, or on every scene
together), after printing the closest; 1 on errors; 2 on bad flags; 130 when interrupted.";

/// `oit recommend`'s flags.
#[derive(Debug, Args)]
#[command(
    after_long_help = DEFINITIONS,
    group(clap::ArgGroup::new("budget").required(true).multiple(true).args(["max_flip", "max_error"]))
)]
pub struct RecommendArgs {
    /// Scene files (.json, .gltf, .glb) or directories of them. With --from they pick scenes
    /// of that file by name (all of them when none are given).
    #[arg(required_unless_present = "from")]
    scenes: Vec<PathBuf>,
    /// Error budget: the largest headline FLIP (HDR-FLIP on HDR scenes, LDR-FLIP otherwise), 0–1.
    #[arg(long, value_name = "X", value_parser = flip_bound)]
    max_flip: Option<f64>,
    /// Error budget: the largest absolute linear RGB channel error (error.max_abs), ≥ 0.
    #[arg(long, value_name = "X", value_parser = error_bound)]
    max_error: Option<f64>,
    /// Cost cap: configurations above this cost × floor do not qualify.
    #[arg(long, value_name = "Y", value_parser = cost_cap)]
    max_cost: Option<f64>,
    /// Relative cost band of a tie (0–1): costs within a factor 1 + TIE are equally cheap.
    #[arg(long, default_value_t = DEFAULT_TIE, value_parser = tie_band)]
    tie: f64,
    /// Read runs from this results.json instead of running any (no GPU needed).
    #[arg(long, value_name = "RESULTS_JSON")]
    from: Option<PathBuf>,
    /// Candidate spec (sweeps allowed, as in `oit compare -t`), repeatable; replaces the default
    /// candidates (see below). With --from, only these of the file are considered.
    #[arg(short, long = "technique")]
    techniques: Vec<String>,
    /// Output directory of the comparison it runs: results.json, results.md, report.html and
    /// images. Runs already there from the same inputs and build are reused (--resume).
    #[arg(long, default_value = "out-recommend", conflicts_with = "from")]
    out: PathBuf,
    /// Also write the answer as JSON (schema `oit-lab/recommend/v1`) to this file.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Override every scene's resolution, e.g. 128x128.
    #[arg(long, value_parser = crate::parse_resolution, conflicts_with = "from")]
    resolution: Option<Resolution>,
    /// Timed frames per run (at least 1).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..), conflicts_with = "from")]
    frames: u32,
    /// Untimed warm-up frames per run, 0 to 1000.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=i64::from(oit_harness::MAX_WARMUP)), conflicts_with = "from")]
    warmup: u32,
    /// Time a noisy run's frames again, up to this many times (as `oit compare --retime`).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=10), conflicts_with = "from")]
    retime: u32,
    /// Seconds one run may take; a run past it is reported as failed (as `oit compare`).
    #[arg(long, value_name = "SECONDS", default_value_t = oit_harness::DEFAULT_RUN_BUDGET.as_secs(), value_parser = clap::value_parser!(u64).range(1..), conflicts_with = "from")]
    run_budget: u64,
    /// Refuse comparisons of more runs (scenes × candidates) than this.
    #[arg(long, default_value_t = 2000, conflicts_with = "from")]
    max_runs: u64,
    /// Compute every reference, read and write no cache.
    #[arg(long, conflicts_with = "from")]
    no_cache: bool,
    #[command(flatten)]
    load: crate::LoadArgs,
    #[command(flatten)]
    gpu: crate::GpuArgs,
}

/// A number of a flag, or what it must be.
fn number(text: &str, ok: impl Fn(f64) -> bool, allowed: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if ok(v) => Ok(v),
        Ok(v) => Err(format!("{v} is not {allowed}")),
        Err(_) => Err(format!("`{text}` is not a number ({allowed})")),
    }
}

fn flip_bound(text: &str) -> Result<f64, String> {
    number(
        text,
        |v| (0.0..=1.0).contains(&v),
        "in 0..=1 (FLIP is a mean in [0, 1])",
    )
}

fn error_bound(text: &str) -> Result<f64, String> {
    number(
        text,
        |v| v.is_finite() && v >= 0.0,
        "a finite number ≥ 0 (linear RGB)",
    )
}

fn cost_cap(text: &str) -> Result<f64, String> {
    number(
        text,
        |v| v.is_finite() && v > 0.0,
        "a finite number > 0 (cost × floor)",
    )
}

fn tie_band(text: &str) -> Result<f64, String> {
    number(
        text,
        |v| (0.0..=1.0).contains(&v),
        "in 0..=1 (0.1 is a 10 % band)",
    )
}

impl RecommendArgs {
    /// Whether it opens a GPU adapter (not with --from).
    pub fn opens_gpu(&self) -> bool {
        self.from.is_none()
    }
}

/// The budget was not met: the answer was printed, the exit status is [`NOT_MET_EXIT`].
#[derive(Debug)]
pub struct NotMet(pub String);

impl std::fmt::Display for NotMet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for NotMet {}

pub fn run(args: RecommendArgs) -> Result<()> {
    let budget = Budget {
        max_flip: args.max_flip,
        max_error: args.max_error,
        max_cost: args.max_cost,
        tie: args.tie,
    };
    budget.validate().map_err(anyhow::Error::msg)?;
    args.load.check(&args.scenes)?;
    let load = args.load.options();
    let (results, source, scenes, candidates) = match &args.from {
        Some(file) => {
            let results = oit_harness::results::Results::read(file)?;
            let scenes = if args.scenes.is_empty() {
                Vec::new()
            } else {
                let entries = crate::load_some_scenes(&args.scenes, &load)?;
                entries.into_iter().map(|e| e.scene.name).collect()
            };
            let candidates = oit_harness::resolve_specs(&args.techniques)?;
            let candidates = if args.techniques.is_empty() {
                Vec::new()
            } else {
                candidates.iter().map(|s| s.canonical()).collect()
            };
            check_present(&results, file, &scenes)?;
            (results, file.display().to_string(), scenes, candidates)
        }
        None => {
            let (entries, unloadable) = crate::load_for_comparison(&args.scenes, &load)?;
            let specs = if args.techniques.is_empty() {
                oit_harness::candidates::candidate_specs()?
            } else {
                oit_harness::resolve_specs(&args.techniques)?
            };
            let options = oit_harness::CompareOptions {
                resolution: args.resolution,
                frames: args.frames,
                warmup: args.warmup,
                out_dir: args.out.clone(),
                cache: if args.no_cache {
                    oit_harness::ReferenceCache::Off
                } else {
                    oit_harness::ReferenceCache::Default
                },
                run_budget: Duration::from_secs(args.run_budget),
                resume: true,
                retime: args.retime,
                context: args.gpu.options(),
                ..Default::default()
            };
            let results = crate::run_comparison(
                &args.scenes,
                &entries,
                &unloadable,
                &specs,
                &options,
                args.max_runs,
            )?;
            crate::finish_comparison(
                &results,
                &args.out,
                oit_report::Metric::Flip,
                oit_report::DEFAULT_BREAK_AT,
            )?;
            let scenes = (entries.iter().map(|e| e.scene.name.clone()))
                .chain(unloadable.iter().map(oit_harness::shard::unloadable_name))
                .collect();
            let candidates = specs.iter().map(|s| s.canonical()).collect();
            let source = args.out.join("results.json").display().to_string();
            (results, source, scenes, candidates)
        }
    };
    let date = today();
    let answer = oit_report::recommend::recommend(
        &results,
        &Question {
            scenes: &scenes,
            candidates: &candidates,
            budget,
            source: &source,
            date: &date,
        },
    );
    print!(
        "{}",
        oit_report::recommend::recommendation_text(&answer, &oit_harness::report::short_spec)
    );
    crate::notes::print_results(&results);
    if let Some(path) = &args.json {
        write_json(path, &answer)?;
        println!("wrote {}", path.display());
    }
    if !answer.met {
        return Err(NotMet(not_met_line(&answer)).into());
    }
    Ok(())
}

/// A named scene the results file does not hold is a mistake, not an empty answer.
fn check_present(
    results: &oit_harness::results::Results,
    file: &Path,
    scenes: &[String],
) -> Result<()> {
    if results.runs.is_empty() {
        anyhow::bail!("{}: holds no runs", file.display());
    }
    let missing: Vec<&str> = scenes
        .iter()
        .filter(|s| !results.runs.iter().any(|r| &&r.scene == s))
        .map(String::as_str)
        .collect();
    if !missing.is_empty() {
        anyhow::bail!(
            "{}: no runs of scene {} (run `oit recommend` without --from to measure them)",
            file.display(),
            missing.join(", ")
        );
    }
    Ok(())
}

fn not_met_line(answer: &Recommendation) -> String {
    let missed: Vec<&str> = (answer.scenes.iter())
        .filter(|a| a.recommended.is_none())
        .map(|a| a.scene.as_str())
        .collect();
    if !missed.is_empty() {
        format!(
            "no configuration meets {} on {} of {} scenes ({})",
            answer.budget.describe(),
            missed.len(),
            answer.scenes.len(),
            missed.join(", ")
        )
    } else {
        format!(
            "no single configuration meets {} on all {} scenes",
            answer.budget.describe(),
            answer.scenes.len()
        )
    }
}

fn write_json(path: &Path, answer: &Recommendation) -> Result<()> {
    let mut text = serde_json::to_string_pretty(answer)?;
    text.push('\n');
    oit_metrics::write_atomic_bytes(path, text.as_bytes())
        .with_context(|| format!("{}: writing the recommendation", path.display()))
}

/// Today's UTC date, `YYYY-MM-DD` (days to civil date: Howard Hinnant's algorithm).
fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

#[cfg(test)]
mod tests {
    #[test]
    fn today_is_a_date() {
        let d = super::today();
        assert_eq!(d.len(), 10, "{d}");
        assert!(d.starts_with("20"), "{d}");
    }
}
