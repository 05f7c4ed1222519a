//! How cost grows with the work: the runs of a scene-parameter sweep (`oit compare --vary`,
//! runs with `varied`), per technique against the swept value x.
//!
//! - [`fit_power_law`]: `y ≈ a·x^b` by least squares on `(ln x, ln y)`, with R² of that fit
//!   (in log space: the share of the variance of ln y the line explains).
//! - [`growth_data`]: per sweep (base scene × parameter) and technique, the points, the fitted
//!   exponent of GPU ms and of cost × floor, and where the technique **breaks**: the first
//!   value (in increasing x) whose error on the report's metric exceeds a bound
//!   ([`DEFAULT_BREAK_AT`] unless given). The scene's floor gets its own row.
//! - [`write_growth_plots`]: per sweep, GPU ms, cost × floor and error against x, one line per
//!   technique (`plots/BASE-LABEL-growth-ms|floor|error.svg|png`).
//! - [`growth_markdown`]: the tables, for results.md and the terminal; the HTML report has the
//!   same tables with the plots.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use oit_results::{Results, Run, RunStatus};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::prelude::*;

use crate::ReportError;
use crate::motion::YScale;
use crate::plot::{
    Axes, FONT_FAMILY, LEGEND_WIDTH, LegendEntry, Marker, Metric, PALETTE, PLOT_SIZE,
    configuration_styles, log_range, log_ticks, short_number,
};

/// The error above which a technique counts as broken, on the report's error axis, unless
/// `--break-at` says otherwise: a mean ꟻLIP of 0.05 is a difference a viewer sees at a glance
/// on most of the image.
pub const DEFAULT_BREAK_AT: f64 = 0.05;

/// `y ≈ a·x^b`, fitted over `points` pairs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerLaw {
    pub a: f64,
    pub b: f64,
    /// Coefficient of determination of the log–log line (1 when the line passes through every
    /// point, a constant ln y included).
    pub r2: f64,
    pub points: usize,
}

/// Why no power law was fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("a power law needs at least 2 points, got {0}")]
    TooFewPoints(usize),
    #[error("{axis} = {value} is not positive (a log–log fit needs x > 0 and y > 0)")]
    NotPositive { axis: &'static str, value: f64 },
    #[error("every x is {0}: nothing grows")]
    NoSpread(f64),
}

/// Least squares on `(ln x, ln y)`: `ln y = ln a + b·ln x`.
pub fn fit_power_law(points: &[(f64, f64)]) -> Result<PowerLaw, FitError> {
    if points.len() < 2 {
        return Err(FitError::TooFewPoints(points.len()));
    }
    for &(x, y) in points {
        if !(x > 0.0 && x.is_finite()) {
            return Err(FitError::NotPositive {
                axis: "x",
                value: x,
            });
        }
        if !(y > 0.0 && y.is_finite()) {
            return Err(FitError::NotPositive {
                axis: "y",
                value: y,
            });
        }
    }
    let n = points.len() as f64;
    let logs: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x.ln(), y.ln())).collect();
    let mx = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let my = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= f64::EPSILON * mx.abs().max(1.0) {
        return Err(FitError::NoSpread(points[0].0));
    }
    let b = sxy / sxx;
    let ln_a = my - b * mx;
    let ss_tot: f64 = logs.iter().map(|p| (p.1 - my).powi(2)).sum();
    let ss_res: f64 = logs.iter().map(|p| (p.1 - ln_a - b * p.0).powi(2)).sum();
    // A line through every point (to rounding) explains everything, also a flat one whose
    // ln y varies only by rounding.
    let r2 = if ss_res <= 1e-24 * n * (1.0 + my * my) || ss_tot <= 0.0 {
        1.0
    } else {
        1.0 - ss_res / ss_tot
    };
    Ok(PowerLaw {
        a: ln_a.exp(),
        b,
        r2,
        points: points.len(),
    })
}

/// One run of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct GrowthPoint {
    pub x: f64,
    /// The value as set (`16`, `256x256`).
    pub value: String,
    pub gpu_ms: Option<f64>,
    pub cost_vs_floor: Option<f64>,
    /// On the report's metric.
    pub error: Option<f64>,
    /// Why the run has no numbers (skipped or failed), else `None`.
    pub not_run: Option<String>,
}

/// One technique (or the floor) across a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct GrowthRow {
    /// The technique, or `floor` for the scene's floor.
    pub technique: String,
    pub legend: LegendEntry,
    /// In increasing x.
    pub points: Vec<GrowthPoint>,
    /// GPU ms ∝ x^b.
    pub ms_fit: Result<PowerLaw, FitError>,
    /// The same over the upper half of the values (x ≥ the median value): the growth once a
    /// fixed per-frame cost no longer dominates.
    pub upper_fit: Result<PowerLaw, FitError>,
    /// Cost × floor ∝ x^b (none for the floor row).
    pub floor_fit: Option<Result<PowerLaw, FitError>>,
    /// The first point whose error exceeds the bound (none for the floor row).
    pub breaks_at: Option<GrowthPoint>,
}

/// One sweep: a base scene and the parameter its derived scenes vary.
#[derive(Debug, Clone, PartialEq)]
pub struct GrowthSweep {
    pub base_scene: String,
    pub parameter: String,
    pub label: String,
    /// What x is, for axes and tables.
    pub x_label: String,
    pub metric: Metric,
    pub bound: f64,
    /// The scene's floor first, then each technique in run order.
    pub rows: Vec<GrowthRow>,
    /// File name stem of the plots (before `-growth-…`).
    pub stem: String,
}

impl GrowthSweep {
    /// The distinct swept values in increasing x.
    pub fn values(&self) -> Vec<(f64, String)> {
        let mut out: Vec<(f64, String)> = Vec::new();
        for p in self.rows.iter().flat_map(|r| &r.points) {
            if !out.iter().any(|(_, v)| *v == p.value) {
                out.push((p.x, p.value.clone()));
            }
        }
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out
    }
}

/// Every sweep of `results`, in order of first appearance; none when no run has `varied`.
pub fn growth_data(results: &Results, metric: Metric, bound: f64) -> Vec<GrowthSweep> {
    let configs = configuration_styles(results);
    let mut keys: Vec<(String, String)> = Vec::new();
    for v in results.runs.iter().filter_map(|r| r.varied.as_ref()) {
        let key = (v.base_scene.clone(), v.parameter.clone());
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    keys.into_iter()
        .map(|(base, parameter)| {
            let runs: Vec<&Run> = results
                .runs
                .iter()
                .filter(|r| {
                    r.varied
                        .as_ref()
                        .is_some_and(|v| v.base_scene == base && v.parameter == parameter)
                })
                .collect();
            let label = runs
                .iter()
                .find_map(|r| r.varied.as_ref().map(|v| v.label.clone()))
                .unwrap_or_else(|| parameter.clone());
            sweep(
                results, &configs, &base, &parameter, &label, &runs, metric, bound,
            )
        })
        .collect()
}

#[allow(clippy::too_many_arguments)] // one sweep's identity and its runs
fn sweep(
    results: &Results,
    configs: &[(String, LegendEntry)],
    base: &str,
    parameter: &str,
    label: &str,
    runs: &[&Run],
    metric: Metric,
    bound: f64,
) -> GrowthSweep {
    let point = |r: &Run| {
        let v = r.varied.as_ref();
        GrowthPoint {
            x: v.map_or(f64::NAN, |v| v.x),
            value: v.map_or_else(String::new, |v| v.value.clone()),
            gpu_ms: r.gpu_ms.as_ref().map(|g| g.median),
            cost_vs_floor: r.cost_vs_floor,
            error: r.error.as_ref().map(|e| metric.of(e)),
            not_run: (r.status != RunStatus::Ok).then(|| {
                format!(
                    "{}: {}",
                    match r.status {
                        RunStatus::Skipped => "skipped",
                        _ => "failed",
                    },
                    r.reason.as_deref().unwrap_or("no reason given")
                )
            }),
        }
    };
    let mut rows: Vec<GrowthRow> = Vec::new();
    // The floor of each derived scene, when timed.
    let mut floor_points: Vec<GrowthPoint> = Vec::new();
    let mut scenes: Vec<&str> = Vec::new();
    for r in runs {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
            if let (Some(f), Some(v)) = (
                results.floors.iter().find(|f| f.scene == r.scene),
                r.varied.as_ref(),
            ) {
                floor_points.push(GrowthPoint {
                    x: v.x,
                    value: v.value.clone(),
                    gpu_ms: Some(f.gpu_ms.median),
                    cost_vs_floor: Some(1.0),
                    error: None,
                    not_run: None,
                });
            }
        }
    }
    if !floor_points.is_empty() {
        floor_points.sort_by(|a, b| a.x.total_cmp(&b.x));
        rows.push(GrowthRow {
            technique: "floor".to_owned(),
            legend: LegendEntry {
                label: "floor".to_owned(),
                style: usize::MAX,
                shape: 0,
            },
            ms_fit: fit_power_law(&ms_points(&floor_points)),
            upper_fit: fit_power_law(&upper_half(&ms_points(&floor_points))),
            floor_fit: None,
            breaks_at: None,
            points: floor_points,
        });
    }
    // One row per technique at each target format (`sorted @ rgba8unorm`).
    let mut techniques: Vec<String> = Vec::new();
    for r in runs {
        let label = r.technique_label();
        if !techniques.contains(&label) {
            techniques.push(label);
        }
    }
    for technique in &techniques {
        let mut points: Vec<GrowthPoint> = runs
            .iter()
            .filter(|r| r.technique_label() == *technique)
            .map(|r| point(r))
            .collect();
        points.sort_by(|a, b| a.x.total_cmp(&b.x));
        let floor: Vec<(f64, f64)> = points
            .iter()
            .filter_map(|p| Some((p.x, p.cost_vs_floor?)))
            .collect();
        let breaks_at = points
            .iter()
            .find(|p| p.error.is_some_and(|e| e > bound))
            .cloned();
        rows.push(GrowthRow {
            technique: technique.to_owned(),
            legend: configs.iter().find(|(c, _)| c == technique).map_or_else(
                || LegendEntry {
                    label: technique.to_owned(),
                    style: 0,
                    shape: 0,
                },
                |(_, e)| e.clone(),
            ),
            ms_fit: fit_power_law(&ms_points(&points)),
            upper_fit: fit_power_law(&upper_half(&ms_points(&points))),
            floor_fit: Some(fit_power_law(&floor)),
            breaks_at,
            points,
        });
    }
    let x_label = if parameter == "resolution" {
        "pixels (width × height)".to_owned()
    } else {
        format!("{label} ({parameter})")
    };
    GrowthSweep {
        base_scene: base.to_owned(),
        parameter: parameter.to_owned(),
        label: label.to_owned(),
        x_label,
        metric,
        bound,
        rows,
        stem: format!(
            "{}-{}",
            oit_results::file_stem(base),
            oit_results::file_stem(label)
        ),
    }
}

/// The points whose x is at least the median of the distinct x values.
fn upper_half(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut xs: Vec<f64> = points.iter().map(|p| p.0).collect();
    xs.sort_by(f64::total_cmp);
    xs.dedup();
    let Some(&median) = xs.get(xs.len() / 2) else {
        return Vec::new();
    };
    points.iter().copied().filter(|p| p.0 >= median).collect()
}

fn ms_points(points: &[GrowthPoint]) -> Vec<(f64, f64)> {
    points
        .iter()
        .filter_map(|p| Some((p.x, p.gpu_ms?)))
        .collect()
}

/// `b (R² r)` or why there is no fit.
fn fit_cell(fit: &Result<PowerLaw, FitError>) -> (String, String) {
    match fit {
        Ok(f) => (format!("{:.2}", f.b), format!("{:.3}", f.r2)),
        Err(e) => (format!("no fit: {e}"), "–".to_owned()),
    }
}

fn range_cell(points: &[GrowthPoint], get: impl Fn(&GrowthPoint) -> Option<f64>) -> String {
    let values: Vec<f64> = points.iter().filter_map(&get).collect();
    match (values.first(), values.last()) {
        (Some(a), Some(b)) => format!("{} → {}", short_number(*a), short_number(*b)),
        _ => "–".to_owned(),
    }
}

/// What each row of a growth table shows, as text cells in column order.
fn row_cells(sweep: &GrowthSweep, row: &GrowthRow) -> Vec<String> {
    let (b_ms, r2_ms) = fit_cell(&row.ms_fit);
    let (b_upper, r2_upper) = fit_cell(&row.upper_fit);
    let (b_floor, r2_floor) = row
        .floor_fit
        .as_ref()
        .map_or(("–".to_owned(), "–".to_owned()), fit_cell);
    let breaks = if row.technique == "floor" {
        "–".to_owned()
    } else {
        match &row.breaks_at {
            Some(p) => format!(
                "{} = {} ({} {})",
                sweep.label,
                p.value,
                sweep.metric.name(),
                short_number(p.error.unwrap_or(f64::NAN))
            ),
            None if row.points.iter().any(|p| p.error.is_some()) => "holds".to_owned(),
            None => "no error measured".to_owned(),
        }
    };
    let not_run: Vec<String> = row
        .points
        .iter()
        .filter(|p| p.not_run.is_some())
        .map(|p| p.value.clone())
        .collect();
    vec![
        row.technique.clone(),
        b_ms,
        r2_ms,
        b_upper,
        r2_upper,
        b_floor,
        r2_floor,
        range_cell(&row.points, |p| p.gpu_ms),
        range_cell(&row.points, |p| p.error),
        breaks,
        if not_run.is_empty() {
            String::new()
        } else {
            format!("not run at {}", not_run.join(", "))
        },
    ]
}

const HEADERS: [&str; 11] = [
    "technique",
    "b (GPU ms)",
    "R²",
    "b, upper half",
    "R²",
    "b (cost × floor)",
    "R²",
    "GPU ms, first → last",
    "error, first → last",
    "breaks at",
    "notes",
];

/// The sentence under a sweep's heading: the values, the fit and the bound.
fn sweep_note(sweep: &GrowthSweep) -> String {
    let values = sweep.values();
    let first = values.first().map_or("?", |v| v.1.as_str());
    let last = values.last().map_or("?", |v| v.1.as_str());
    format!(
        "{} from {first} to {last} ({} values; x = {}). b: the exponent of a power law \
         (cost ∝ x^b) fitted by least squares to ln cost against ln x over the runs that \
         rendered, R² that fit's; b = 1 is linear growth. Upper half: the same fit over the \
         values from the median up, where a fixed per-frame cost weighs less. Breaks at: the \
         first value whose {} exceeds {} (`--break-at`); holds: it never does over the sweep.",
        sweep.label,
        values.len(),
        sweep.x_label,
        sweep.metric.name(),
        short_number(sweep.bound)
    )
}

/// The growth tables, one per sweep, as Markdown (empty when no run has `varied`).
pub fn growth_markdown(results: &Results, metric: Metric, bound: f64) -> String {
    let sweeps = growth_data(results, metric, bound);
    let mut out = String::new();
    for sweep in &sweeps {
        let _ = writeln!(
            out,
            "\n## How cost grows: {} over `{}` ({})\n\n{}\n",
            sweep.base_scene,
            sweep.label,
            sweep.parameter,
            sweep_note(sweep)
        );
        let _ = writeln!(out, "| {} |", HEADERS.join(" | "));
        let _ = writeln!(
            out,
            "|---|{}",
            HEADERS[1..].iter().map(|_| "---:|").collect::<String>()
        );
        for row in &sweep.rows {
            let cells = row_cells(sweep, row);
            let cells: Vec<String> = cells.iter().map(|c| c.replace('|', "\\|")).collect();
            let _ = writeln!(out, "| {} |", cells.join(" | "));
        }
    }
    out
}

/// The report's section: per sweep its note, table and three plots.
pub(crate) fn html_section(out: &mut String, results: &Results, metric: Metric, bound: f64) {
    let sweeps = growth_data(results, metric, bound);
    if sweeps.is_empty() {
        return;
    }
    let esc = crate::html::esc;
    out.push_str("<section id=\"growth\">\n<h2>How cost grows</h2>\n");
    for sweep in &sweeps {
        let _ = writeln!(
            out,
            "<h3>{} over <code>{}</code> ({})</h3>\n<p>{}</p>\n<table class=\"sortable\"><thead><tr>{}</tr></thead><tbody>",
            esc(&sweep.base_scene),
            esc(&sweep.label),
            esc(&sweep.parameter),
            esc(&sweep_note(sweep)).replace("`--break-at`", "<code>--break-at</code>"),
            HEADERS
                .iter()
                .map(|h| format!("<th>{}</th>", esc(h)))
                .collect::<String>()
        );
        for row in &sweep.rows {
            let cells = row_cells(sweep, row);
            let _ = writeln!(
                out,
                "<tr>{}</tr>",
                cells
                    .iter()
                    .enumerate()
                    .map(|(i, c)| if i >= 9 {
                        format!("<td class=\"text\">{}</td>", esc(c))
                    } else {
                        format!("<td>{}</td>", esc(c))
                    })
                    .collect::<String>()
            );
        }
        out.push_str("</tbody></table>\n<div class=\"plots\">");
        for kind in GrowthKind::ALL {
            let rel = format!("plots/{}-{}.png", sweep.stem, kind.suffix());
            let _ = write!(
                out,
                "<img src=\"{}\" alt=\"{} against {}\" loading=\"eager\">",
                esc(&crate::html::url(&rel)),
                esc(kind.what(sweep.metric)),
                esc(&sweep.label)
            );
        }
        out.push_str("</div>\n");
    }
    out.push_str("</section>\n");
}

/// Which growth plot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GrowthKind {
    GpuMs,
    CostVsFloor,
    Error,
}

impl GrowthKind {
    pub const ALL: [GrowthKind; 3] = [
        GrowthKind::GpuMs,
        GrowthKind::CostVsFloor,
        GrowthKind::Error,
    ];

    /// The stem suffix: never `-cost`, `-bytes` or a motion suffix.
    pub fn suffix(self) -> &'static str {
        match self {
            GrowthKind::GpuMs => "growth-ms",
            GrowthKind::CostVsFloor => "growth-floor",
            GrowthKind::Error => "growth-error",
        }
    }

    fn what(self, metric: Metric) -> &'static str {
        match (self, metric) {
            (GrowthKind::GpuMs, _) => "median GPU ms per frame",
            (GrowthKind::CostVsFloor, _) => "cost × floor",
            (GrowthKind::Error, Metric::Flip) => "mean FLIP",
            (GrowthKind::Error, Metric::Rmse) => "RMSE",
        }
    }
}

/// One growth plot, ready to draw.
#[derive(Debug, Clone)]
pub struct GrowthChart {
    pub kind: GrowthKind,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// `(legend, points)` per line; the floor's legend style is `usize::MAX` (drawn black).
    pub lines: Vec<(LegendEntry, Vec<(f64, f64)>)>,
    /// The break bound, drawn as a dashed line (error plot only).
    pub bound: Option<f64>,
    pub stem: String,
}

/// The three charts of each sweep.
pub fn growth_charts(results: &Results, metric: Metric, bound: f64) -> Vec<GrowthChart> {
    let mut out = Vec::new();
    for sweep in growth_data(results, metric, bound) {
        for kind in GrowthKind::ALL {
            let lines = sweep
                .rows
                .iter()
                .filter(|r| kind != GrowthKind::Error || r.technique != "floor")
                .filter(|r| kind != GrowthKind::CostVsFloor || r.technique != "floor")
                .map(|r| {
                    let pts = r
                        .points
                        .iter()
                        .filter_map(|p| {
                            let y = match kind {
                                GrowthKind::GpuMs => p.gpu_ms,
                                GrowthKind::CostVsFloor => p.cost_vs_floor,
                                GrowthKind::Error => p.error,
                            }?;
                            (p.x.is_finite() && y.is_finite() && y >= 0.0).then_some((p.x, y))
                        })
                        .collect();
                    let label = match (&r.ms_fit, kind) {
                        (Ok(f), GrowthKind::GpuMs) => {
                            format!("{} (b {:.2})", r.legend.label, f.b)
                        }
                        _ => r.legend.label.clone(),
                    };
                    (
                        LegendEntry {
                            label,
                            ..r.legend.clone()
                        },
                        pts,
                    )
                })
                .collect();
            let what = kind.what(metric);
            out.push(GrowthChart {
                kind,
                title: format!("{}: {what} against {}", sweep.base_scene, sweep.label),
                x_label: format!("{} (log scale)", sweep.x_label),
                y_label: match kind {
                    GrowthKind::Error => format!("{what} (symmetric log where spread)"),
                    _ => format!("{what} (log scale)"),
                },
                lines,
                bound: (kind == GrowthKind::Error).then_some(bound),
                stem: format!("{}-{}", sweep.stem, kind.suffix()),
            });
        }
    }
    out
}

/// Writes every growth plot as `STEM.svg` and `STEM.png` into `out_dir`; none without sweeps.
pub fn write_growth_plots(
    results: &Results,
    out_dir: &Path,
    metric: Metric,
    bound: f64,
) -> Result<Vec<PathBuf>, ReportError> {
    let charts = growth_charts(results, metric, bound);
    if charts.is_empty() {
        return Ok(Vec::new());
    }
    crate::plot::write_charts(&charts, out_dir)
}

impl crate::plot::Chart for GrowthChart {
    fn stem(&self) -> &str {
        &self.stem
    }

    fn draw_on<'a, DB: DrawingBackend + 'a>(
        &self,
        root: &'a DrawingArea<DB, Shift>,
    ) -> Result<(), String> {
        draw(root, self)
    }
}

fn colour(legend: &LegendEntry) -> RGBColor {
    if legend.style == usize::MAX {
        BLACK
    } else {
        PALETTE[legend.style % PALETTE.len()]
    }
}

fn draw<'a, DB: DrawingBackend + 'a>(
    root: &'a DrawingArea<DB, Shift>,
    chart: &GrowthChart,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let (area, legend) = root.split_horizontally(PLOT_SIZE.0 - LEGEND_WIDTH);
    let xs = || chart.lines.iter().flat_map(|(_, p)| p.iter().map(|q| q.0));
    let ys = || chart.lines.iter().flat_map(|(_, p)| p.iter().map(|q| q.1));
    let (x_lo, x_hi) = log_range(xs(), 0.5, 2.0);
    let x = (x_lo..x_hi)
        .log_scale()
        .with_key_points(log_ticks(x_lo, x_hi));
    let x_format = |v: &f64| short_number(*v);
    if chart.kind == GrowthKind::Error {
        let scale = YScale::for_flip(ys().chain(chart.bound));
        let label = move |v: &f64| {
            let value = scale.value(*v);
            if value < 0.0 {
                String::new()
            } else {
                short_number(value)
            }
        };
        match scale {
            YScale::Linear { hi } | YScale::Log { hi, .. } => {
                draw_lines(&area, chart, x, -0.02 * hi..hi, scale, (&x_format, &label))?
            }
            YScale::SymLog { threshold, hi } => {
                let top = scale.drawn(hi).powf(1.05);
                let bottom = top.powf(-0.02);
                let mut ticks = vec![1.0];
                ticks.extend(
                    log_ticks(threshold, scale.value(top))
                        .into_iter()
                        .map(|v| scale.drawn(v)),
                );
                draw_lines(
                    &area,
                    chart,
                    x,
                    (bottom..top).log_scale().with_key_points(ticks),
                    scale,
                    (&x_format, &label),
                )?
            }
        }
    } else {
        let (y_lo, y_hi) = log_range(ys(), 0.5, 2.0);
        let scale = YScale::Log {
            lo: y_lo,
            hi: y_hi,
            zero: y_lo,
        };
        draw_lines(
            &area,
            chart,
            x,
            (y_lo..y_hi)
                .log_scale()
                .with_key_points(log_ticks(y_lo, y_hi)),
            scale,
            (&x_format, &|v: &f64| short_number(*v)),
        )?;
    }
    draw_legend(&legend, chart).map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// Tick label formatters of the x and y axes.
type Labels<'f> = (&'f dyn Fn(&f64) -> String, &'f dyn Fn(&f64) -> String);

fn draw_lines<'a, DB, X, Y>(
    root: &'a DrawingArea<DB, Shift>,
    chart: &GrowthChart,
    x: X,
    y: Y,
    scale: YScale,
    (x_format, y_format): Labels<'_>,
) -> Result<(), String>
where
    DB: DrawingBackend + 'a,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let axes = Axes {
        title: &chart.title,
        x_label: &chart.x_label,
        y_label: &chart.y_label,
        x_format,
        y_format,
        x_ticks: None,
    };
    let mut plot = axes.build(root, x, y)?;
    if let Some(bound) = chart.bound {
        let (lo, hi) = chart
            .lines
            .iter()
            .flat_map(|(_, p)| p.iter().map(|q| q.0))
            .filter(|v| *v > 0.0)
            .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
        if lo.is_finite() {
            let grey = RGBColor(120, 120, 120);
            plot.draw_series(DashedLineSeries::new(
                [(lo, scale.drawn(bound)), (hi, scale.drawn(bound))],
                8,
                5,
                grey.stroke_width(2),
            ))
            .map_err(err)?;
        }
    }
    for (legend, points) in &chart.lines {
        let c = colour(legend);
        let drawn: Vec<(f64, f64)> = points.iter().map(|&(x, y)| (x, scale.drawn(y))).collect();
        plot.draw_series(LineSeries::new(drawn.iter().copied(), c.stroke_width(2)))
            .map_err(err)?;
        if legend.style == usize::MAX {
            continue;
        }
        plot.draw_series(drawn.iter().map(|&at| Marker {
            at,
            style: legend.style,
            shape: legend.shape,
        }))
        .map_err(err)?;
    }
    Ok(())
}

fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    chart: &GrowthChart,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    const TOP: i32 = 50;
    let rows = chart.lines.len() as i32 + i32::from(chart.bound.is_some());
    let room = PLOT_SIZE.1 as i32 - TOP - 20;
    let row = (room / rows.max(1)).clamp(9, 18);
    let font = (FONT_FAMILY, (row - 5).clamp(8, 13)).into_font();
    let text =
        |i: i32, label: &str| Text::new(label.to_owned(), (34, TOP + i * row - 7), font.clone());
    for (i, (legend, _)) in (0..).zip(&chart.lines) {
        let y = TOP + i * row;
        area.draw(&PathElement::new(
            vec![(4, y), (28, y)],
            colour(legend).stroke_width(2),
        ))?;
        if legend.style != usize::MAX {
            area.draw(&Marker {
                at: (16, y),
                style: legend.style,
                shape: legend.shape,
            })?;
        }
        area.draw(&text(i, &legend.label))?;
    }
    if let Some(bound) = chart.bound {
        let i = chart.lines.len() as i32;
        let y = TOP + i * row;
        area.draw(&PathElement::new(
            vec![(4, y), (28, y)],
            RGBColor(120, 120, 120).stroke_width(2),
        ))?;
        area.draw(&text(i, &format!("break bound {}", short_number(bound))))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_recovers_exponents_of_power_laws() {
        for (a, b) in [
            (3.0, 1.0),
            (0.5, 2.0),
            (10.0, 0.0),
            (2.0, -0.5),
            (1e-3, 1.37),
        ] {
            let points: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 16.0, 100.0, 256.0]
                .iter()
                .map(|&x: &f64| (x, a * x.powf(b)))
                .collect();
            let fit = fit_power_law(&points).unwrap();
            assert!((fit.b - b).abs() < 1e-9, "{b}: {fit:?}");
            assert!((fit.a - a).abs() < 1e-9 * a.max(1.0), "{a}: {fit:?}");
            assert!((fit.r2 - 1.0).abs() < 1e-9, "{fit:?}");
            assert_eq!(fit.points, 6);
        }
    }

    /// Noise lowers R² and leaves b near the truth; a constant offset (a fixed cost) bends the
    /// curve, which a smaller b and a lower R² show.
    #[test]
    fn noise_and_fixed_costs_show_in_r2() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut noise = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            0.8 + 0.4 * (state % 10_000) as f64 / 10_000.0
        };
        let noisy: Vec<(f64, f64)> = (0..9)
            .map(|i| {
                let x = 2f64.powi(i);
                (x, 5.0 * x.powf(1.5) * noise())
            })
            .collect();
        let fit = fit_power_law(&noisy).unwrap();
        assert!(
            (fit.b - 1.5).abs() < 0.1 && fit.r2 > 0.95 && fit.r2 < 1.0,
            "{fit:?}"
        );
        let offset: Vec<(f64, f64)> = (0..9)
            .map(|i| {
                let x = 2f64.powi(i);
                (x, 100.0 + x)
            })
            .collect();
        let fit = fit_power_law(&offset).unwrap();
        assert!(fit.b < 0.6 && fit.r2 < 0.95, "{fit:?}");
    }

    #[test]
    fn the_fit_refuses_what_it_cannot_fit() {
        assert_eq!(fit_power_law(&[]), Err(FitError::TooFewPoints(0)));
        assert_eq!(fit_power_law(&[(1.0, 2.0)]), Err(FitError::TooFewPoints(1)));
        assert_eq!(
            fit_power_law(&[(0.0, 1.0), (2.0, 3.0)]),
            Err(FitError::NotPositive {
                axis: "x",
                value: 0.0
            })
        );
        assert_eq!(
            fit_power_law(&[(1.0, 1.0), (2.0, -3.0)]),
            Err(FitError::NotPositive {
                axis: "y",
                value: -3.0
            })
        );
        assert!(matches!(
            fit_power_law(&[(1.0, f64::NAN), (2.0, 3.0)]),
            Err(FitError::NotPositive { axis: "y", .. })
        ));
        assert_eq!(
            fit_power_law(&[(4.0, 1.0), (4.0, 3.0)]),
            Err(FitError::NoSpread(4.0))
        );
        let e = fit_power_law(&[(1.0, 0.0), (2.0, 3.0)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("not positive") && e.contains("y = 0"), "{e}");
        assert!(FitError::TooFewPoints(1).to_string().contains("at least 2"));
    }

    #[test]
    fn the_upper_half_starts_at_the_median_value() {
        let points: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0, 16.0]
            .iter()
            .map(|&x| (x, 1.0 + x))
            .collect();
        assert_eq!(upper_half(&points), [(4.0, 5.0), (8.0, 9.0), (16.0, 17.0)]);
        // A fixed cost bends the whole-range fit more than the upper half's.
        let whole = fit_power_law(&points).unwrap();
        let upper = fit_power_law(&upper_half(&points)).unwrap();
        assert!(whole.b < upper.b && upper.b < 1.0, "{whole:?} {upper:?}");
        assert!(upper_half(&[]).is_empty());
    }
}
