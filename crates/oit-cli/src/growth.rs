//! `oit compare --vary` (scene-parameter sweeps) and `--break-at` (where the growth tables say
//! a technique breaks): the flags, the derived scenes and the growth table printed after a
//! comparison.

use anyhow::{Result, bail};
use clap::Args;

/// The bound of the growth tables, for every command that writes a report.
#[derive(Debug, Clone, Args)]
pub struct BreakArgs {
    /// Growth tables of `--vary` sweeps: a technique breaks at the first swept value whose
    /// error on the --metric axis exceeds this (mean ꟻLIP or RMSE).
    #[arg(long, value_name = "ERROR", default_value_t = oit_report::DEFAULT_BREAK_AT, value_parser = parse_bound)]
    pub break_at: f64,
}

/// `oit compare`'s sweep flags.
#[derive(Debug, Clone, Args)]
pub struct GrowthArgs {
    /// Sweep a scene parameter, repeatable: `PATH=VALUES`, PATH `resolution` or a JSON
    /// pointer to a number of a JSON scene file (`/objects/0/mesh/count`); VALUES a list of
    /// numbers and ranges `a..b`, `a..b:+STEP`, `a..b:xFACTOR` (resolution: `N` for N×N or
    /// `WxH`). Each scene runs once per value, named `NAME[LABEL=VALUE]`; at most 1024 values
    /// per sweep.
    #[arg(long, value_name = "PATH=VALUES")]
    pub vary: Vec<String>,
    #[command(flatten)]
    pub bound: BreakArgs,
}

fn parse_bound(text: &str) -> std::result::Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("`{text}` is not an error bound (a number ≥ 0)")),
    }
}

/// The scenes a comparison runs: each scene once per value of each `--vary` sweep, every
/// value validated by the scene loader (before any GPU work).
pub fn vary(
    scenes: Vec<oit_harness::SceneEntry>,
    args: &GrowthArgs,
    resolution: Option<oit_scene::Resolution>,
) -> Result<Vec<oit_harness::SceneEntry>> {
    if args.vary.is_empty() {
        return Ok(scenes);
    }
    let sweeps = oit_harness::vary::parse_scene_sweeps(&args.vary)?;
    if resolution.is_some()
        && sweeps
            .iter()
            .any(|s| s.parameter == oit_harness::vary::Parameter::Resolution)
    {
        bail!("--resolution and --vary resolution=… both set the resolution; give one");
    }
    let varied = oit_harness::vary::vary_scenes(scenes, &sweeps)?;
    eprintln!(
        "--vary: {} scenes from {} sweep{}",
        varied.len(),
        sweeps.len(),
        if sweeps.len() == 1 { "" } else { "s" }
    );
    Ok(varied)
}

/// The growth tables of `results` (nothing when no run was swept).
pub fn print_tables(
    results: &oit_harness::results::Results,
    metric: oit_report::Metric,
    bound: &BreakArgs,
) {
    let tables = oit_report::growth_markdown(results, metric, bound.break_at);
    if !tables.is_empty() {
        print!("{tables}");
    }
}
