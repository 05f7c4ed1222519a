//! Speed-versus-error plots. [`plot_data`] decides what is drawn (every point, sweep line and
//! front member, with the reason for anything left out); [`render_svg`] and [`render_png`] only
//! draw a [`PlotData`], so a test of the data is a test of the picture.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use oit_results::{Results, Run, RunStatus};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::element::{Drawable, PointCollection};
use plotters::prelude::*;
use plotters_backend::{BackendCoord, DrawingErrorKind};

use crate::ReportError;
use crate::pareto::pareto_front;

/// Plot size in pixels (SVG user units and PNG pixels).
pub const PLOT_SIZE: (u32, u32) = (1080, 600);
/// Pixels at the right kept for the legend, beside the axes.
pub const LEGEND_WIDTH: u32 = 180;

/// DejaVu Sans 2.37 (Bitstream Vera licence, `fonts/LICENSE-DejaVu.txt`), registered with
/// plotters' pure-Rust `ab_glyph` text path so that no system font library is needed.
static FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");
pub(crate) const FONT_FAMILY: &str = "sans-serif";

pub(crate) fn register_font() -> Result<(), ReportError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(ReportError::Plot {
            plot: "font".into(),
            message: "bundled DejaVuSans.ttf did not parse".into(),
        })
    }
}

/// The error axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Metric {
    /// Mean ꟻLIP in [0, 1]: `error.flip_mean`, or `error.hdr_flip_mean` on HDR scenes
    /// ([`oit_metrics::Errors::headline_flip`]).
    Flip,
    /// Root mean squared error on linear RGB (`error.rmse`).
    Rmse,
}

impl Metric {
    pub fn of(self, e: &oit_metrics::Errors) -> f64 {
        match self {
            Metric::Flip => e.headline_flip().0,
            Metric::Rmse => e.rmse,
        }
    }

    /// Short name for file names.
    pub fn key(self) -> &'static str {
        match self {
            Metric::Flip => "flip",
            Metric::Rmse => "rmse",
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Metric::Flip => "mean FLIP",
            Metric::Rmse => "RMSE",
        }
    }

    /// Axis label with its unit.
    pub fn axis_label(self) -> &'static str {
        match self {
            Metric::Flip => "mean FLIP (HDR-FLIP on HDR scenes; 0-1, log scale)",
            Metric::Rmse => "RMSE (linear RGB, 1 = full scale; log scale)",
        }
    }
}

/// Which plot of a scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlotKind {
    /// Error against `cost_vs_unsorted` (median GPU time over `unsorted`'s), both log.
    CostError,
    /// Error (log) against `bytes_per_pixel` (linear: `unsorted` allocates nothing, 0 B/px).
    BytesError,
}

/// One drawn marker.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotPoint {
    pub technique: String,
    pub family: String,
    /// Index of the marker colour: the family's place in the results' family order.
    pub style: usize,
    /// Index of the marker shape: the configuration's place among its family's
    /// configurations in the results, so two configurations of one technique never look alike.
    pub shape: usize,
    pub x: f64,
    /// The true error.
    pub y: f64,
    /// Where the marker is drawn: `y`, or [`PlotData::zero_y`] when the error is exactly 0 (a
    /// log axis has no 0).
    pub y_drawn: f64,
}

/// Everything one plot shows.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotData {
    pub scene: String,
    pub kind: PlotKind,
    pub metric: Metric,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// One per drawn ok run, in run order.
    pub points: Vec<PlotPoint>,
    /// Sweeps: indices into `points` joined by a line, in parameter order.
    pub sweeps: Vec<Vec<usize>>,
    /// Indices into `points` on this plot's Pareto front (its own x against error).
    pub front: Vec<usize>,
    /// Where error 0 is drawn, when some run has it.
    pub zero_y: Option<f64>,
    /// Ok runs that could not be drawn, with the reason (e.g. no `cost_vs_unsorted`).
    pub omitted: Vec<(String, String)>,
    /// The legend: one entry per configuration drawn, in results order, labelled by the
    /// parameters that tell it from its family's other configurations.
    pub legend: Vec<LegendEntry>,
    /// File name without extension.
    pub stem: String,
}

/// One legend row: a marker of `style` (colour) and `shape`, and its label.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LegendEntry {
    pub label: String,
    pub style: usize,
    pub shape: usize,
}

/// Configurations in order of first appearance, each with its colour (family) and shape
/// (place among its family's configurations) and a legend label: the family name, with the
/// parameters that differ between the family's configurations when it has several.
pub(crate) fn configuration_styles(results: &Results) -> Vec<(String, LegendEntry)> {
    let families = family_order(results);
    let mut configs: Vec<String> = Vec::new();
    for run in &results.runs {
        let config = config_of(run);
        if !configs.contains(&config) {
            configs.push(config);
        }
    }
    let refs: Vec<&str> = configs.iter().map(String::as_str).collect();
    configs
        .iter()
        .map(|c| {
            let f = family(c);
            let siblings: Vec<&str> = refs.iter().copied().filter(|o| family(o) == f).collect();
            let label = if siblings.len() < 2 {
                f.to_owned()
            } else {
                let short = oit_results::report::short_labels(&siblings);
                let mine = &short[siblings.iter().position(|o| *o == c).unwrap_or(0)];
                if mine == f || mine.starts_with(&format!("{f}:")) {
                    mine.clone()
                } else {
                    format!("{f}:{mine}")
                }
            };
            (
                c.clone(),
                LegendEntry {
                    label,
                    style: families.iter().position(|g| g == f).unwrap_or(0),
                    shape: siblings.iter().position(|o| *o == c).unwrap_or(0),
                },
            )
        })
        .collect()
}

/// A run's configuration on the plots: its canonical spec, with its target format as one more
/// parameter when that is not the default (`sorted:target=rgba8unorm`), so runs of one
/// technique at several formats get their own markers and a sweep line like any parameter.
pub fn config_of(run: &Run) -> String {
    if run.target_format.is_default() {
        run.technique.clone()
    } else {
        let sep = if run.technique.contains(':') {
            ','
        } else {
            ':'
        };
        format!("{}{sep}target={}", run.technique, run.target_format.name())
    }
}

/// Technique family: the name before `:` (`dual-peel:passes=5` → `dual-peel`).
pub fn family(technique: &str) -> &str {
    technique
        .split_once(':')
        .map_or(technique, |(name, _)| name)
}

fn params(technique: &str) -> Vec<(&str, &str)> {
    technique
        .split_once(':')
        .map(|(_, rest)| {
            rest.split(',')
                .filter_map(|kv| kv.split_once('='))
                .collect()
        })
        .unwrap_or_default()
}

/// Parameter order: numbers numerically and before words, words alphabetically.
fn compare_values(a: &str, b: &str) -> std::cmp::Ordering {
    match (a.parse::<f64>(), b.parse::<f64>()) {
        (Ok(x), Ok(y)) => x.total_cmp(&y),
        (Ok(_), Err(_)) => std::cmp::Ordering::Less,
        (Err(_), Ok(_)) => std::cmp::Ordering::Greater,
        (Err(_), Err(_)) => a.cmp(b),
    }
}

/// Runs grouped by scene, scenes in order of first appearance.
pub(crate) fn runs_by_scene(results: &Results) -> Vec<(String, Vec<&Run>)> {
    let mut out: Vec<(String, Vec<&Run>)> = Vec::new();
    for run in &results.runs {
        match out.iter_mut().find(|(s, _)| *s == run.scene) {
            Some((_, v)) => v.push(run),
            None => out.push((run.scene.clone(), vec![run])),
        }
    }
    out
}

/// Families in order of first appearance across all scenes, so a family keeps its marker from
/// one scene's plot to the next.
fn family_order(results: &Results) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for run in &results.runs {
        let f = family(&run.technique);
        if !out.iter().any(|g| g == f) {
            out.push(f.to_owned());
        }
    }
    out
}

/// Sweep lines among `points`: for every parameter `k` whose value varies within a family,
/// the points that agree on every other parameter, joined in order of `k` (lines of two or
/// more points only). A one-parameter sweep is one line; a two-parameter grid is drawn as its
/// rows and columns.
fn sweeps(points: &[PlotPoint]) -> Vec<Vec<usize>> {
    let mut by_family: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    for (i, p) in points.iter().enumerate() {
        by_family.entry(&p.family).or_default().push(i);
    }
    let mut lines = Vec::new();
    for members in by_family.values() {
        let parsed: Vec<Vec<(&str, &str)>> = members
            .iter()
            .map(|&i| params(&points[i].technique))
            .collect();
        let mut keys: Vec<&str> = parsed.iter().flatten().map(|(k, _)| *k).collect();
        keys.sort_unstable();
        keys.dedup();
        let value = |p: &[(&str, &'static str)], k: &str| {
            p.iter().find(|(kk, _)| *kk == k).map(|(_, v)| *v)
        };
        let _ = value;
        for &k in &keys {
            let get =
                |m: usize, key: &str| parsed[m].iter().find(|(kk, _)| *kk == key).map(|(_, v)| *v);
            let distinct = {
                let mut v: Vec<Option<&str>> = (0..members.len()).map(|m| get(m, k)).collect();
                v.sort_unstable();
                v.dedup();
                v.len()
            };
            if distinct < 2 {
                continue;
            }
            // Group by the values of every other key.
            let mut groups: BTreeMap<Vec<Option<&str>>, Vec<usize>> = BTreeMap::new();
            for m in 0..members.len() {
                let rest: Vec<Option<&str>> = keys
                    .iter()
                    .filter(|&&o| o != k)
                    .map(|&o| get(m, o))
                    .collect();
                groups.entry(rest).or_default().push(m);
            }
            for mut group in groups.into_values() {
                if group.len() < 2 {
                    continue;
                }
                group.sort_by(|&a, &b| {
                    compare_values(get(a, k).unwrap_or(""), get(b, k).unwrap_or(""))
                });
                lines.push(group.into_iter().map(|m| members[m]).collect());
            }
        }
    }
    lines
}

/// What every plot of every scene shows. Per scene: [`PlotKind::CostError`] then
/// [`PlotKind::BytesError`].
pub fn plot_data(results: &Results, metric: Metric) -> Vec<PlotData> {
    let configs = configuration_styles(results);
    let mut out = Vec::new();
    for (scene, runs) in runs_by_scene(results) {
        let ok: Vec<&Run> = runs
            .iter()
            .copied()
            .filter(|r| r.status == RunStatus::Ok)
            .collect();
        let res = ok.first().or(runs.first()).map_or([0, 0], |r| r.resolution);
        let timing = ok
            .iter()
            .filter_map(|r| r.gpu_ms.as_ref().map(|g| g.source.as_str()))
            .next()
            .unwrap_or("no timing");
        for kind in [PlotKind::CostError, PlotKind::BytesError] {
            let mut points = Vec::new();
            let mut omitted = Vec::new();
            for run in &ok {
                let x = match kind {
                    PlotKind::CostError => run.cost_vs_unsorted,
                    PlotKind::BytesError => run.bytes_per_pixel,
                };
                let y = run.error.as_ref().map(|e| metric.of(e));
                let what = match kind {
                    PlotKind::CostError => "cost_vs_unsorted",
                    PlotKind::BytesError => "bytes_per_pixel",
                };
                match (x, y) {
                    (Some(x), Some(y))
                        if x.is_finite() && y.is_finite() && y >= 0.0 && valid_x(kind, x) =>
                    {
                        let f = family(&run.technique);
                        let config = config_of(run);
                        let entry = configs
                            .iter()
                            .find(|(c, _)| *c == config)
                            .map(|(_, e)| e.clone());
                        points.push(PlotPoint {
                            technique: config,
                            family: f.to_owned(),
                            style: entry.as_ref().map_or(0, |e| e.style),
                            shape: entry.as_ref().map_or(0, |e| e.shape),
                            x,
                            y,
                            y_drawn: y,
                        })
                    }
                    (None, _) => omitted.push((run.technique_label(), format!("no {what}"))),
                    (_, None) => omitted.push((run.technique_label(), "no error".to_owned())),
                    (Some(x), Some(y)) => omitted.push((
                        run.technique_label(),
                        format!("{what} {x} or {} {y} cannot be drawn", metric.name()),
                    )),
                }
            }
            // A log axis has no 0: exact runs sit at a quarter of the smallest nonzero error.
            let zero_y = points.iter().any(|p| p.y == 0.0).then(|| {
                let min_pos = points
                    .iter()
                    .map(|p| p.y)
                    .filter(|&y| y > 0.0)
                    .fold(f64::INFINITY, f64::min);
                if min_pos.is_finite() {
                    min_pos / 4.0
                } else {
                    1e-6
                }
            });
            if let Some(z) = zero_y {
                for p in points.iter_mut().filter(|p| p.y == 0.0) {
                    p.y_drawn = z;
                }
            }
            let front = pareto_front(&points.iter().map(|p| (p.x, p.y)).collect::<Vec<_>>());
            let (title, x_label, suffix) = match kind {
                PlotKind::CostError => (
                    format!(
                        "{scene} ({}x{}): {} vs GPU cost, {timing}",
                        res[0],
                        res[1],
                        metric.name()
                    ),
                    "GPU time relative to unsorted (median frame ms / unsorted's; log scale)"
                        .to_owned(),
                    "cost",
                ),
                PlotKind::BytesError => (
                    format!(
                        "{scene} ({}x{}): {} vs memory",
                        res[0],
                        res[1],
                        metric.name()
                    ),
                    "technique memory (bytes per pixel)".to_owned(),
                    "bytes",
                ),
            };
            let sweeps = sweeps(&points);
            let mut legend: Vec<LegendEntry> = Vec::new();
            for p in &points {
                if let Some((_, e)) = configs.iter().find(|(c, _)| *c == p.technique)
                    && !legend.contains(e)
                {
                    legend.push(e.clone());
                }
            }
            out.push(PlotData {
                scene: scene.clone(),
                kind,
                metric,
                title,
                x_label,
                y_label: metric.axis_label().to_owned(),
                sweeps,
                front,
                zero_y,
                omitted,
                legend,
                stem: format!(
                    "{}-{}-{suffix}",
                    oit_results::file_stem(&scene),
                    metric.key()
                ),
                points,
            });
        }
    }
    out
}

fn valid_x(kind: PlotKind, x: f64) -> bool {
    match kind {
        PlotKind::CostError => x > 0.0,
        PlotKind::BytesError => x >= 0.0,
    }
}

/// Writes every plot of every scene as `STEM.svg` and `STEM.png` into `out_dir` (created if
/// missing), atomically. Returns the files in [`plot_data`] order, SVG before PNG.
pub fn write_plots(
    results: &Results,
    out_dir: &Path,
    metric: Metric,
) -> Result<Vec<PathBuf>, ReportError> {
    write_charts(&plot_data(results, metric), out_dir)
}

/// The plot as an SVG document.
pub fn render_svg(plot: &PlotData) -> Result<String, ReportError> {
    chart_svg(plot)
}

/// The plot as PNG bytes (RGB8).
pub fn render_png(plot: &PlotData) -> Result<Vec<u8>, ReportError> {
    chart_png(plot)
}

/// A picture drawn with plotters on any backend at [`PLOT_SIZE`]: the cost–error plots and the
/// motion plots share how they become SVG and PNG files.
pub(crate) trait Chart {
    /// File stem, also the name in errors.
    fn stem(&self) -> &str;
    fn draw_on<'a, DB: DrawingBackend + 'a>(
        &self,
        root: &'a DrawingArea<DB, Shift>,
    ) -> Result<(), String>;
}

impl Chart for PlotData {
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

/// Writes each chart as `STEM.svg` and `STEM.png` into `out_dir` (created if missing),
/// atomically; returns the files, SVG before PNG.
pub(crate) fn write_charts(
    charts: &[impl Chart],
    out_dir: &Path,
) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(out_dir).map_err(|e| ReportError::io(out_dir, e))?;
    let mut files = Vec::new();
    for chart in charts {
        let svg = out_dir.join(format!("{}.svg", chart.stem()));
        oit_metrics::write_atomic_bytes(&svg, chart_svg(chart)?.as_bytes())?;
        files.push(svg);
        let png = out_dir.join(format!("{}.png", chart.stem()));
        oit_metrics::write_atomic_bytes(&png, &chart_png(chart)?)?;
        files.push(png);
    }
    Ok(files)
}

/// The chart as an SVG document.
pub(crate) fn chart_svg(chart: &impl Chart) -> Result<String, ReportError> {
    register_font()?;
    let failed = |message: String| ReportError::Plot {
        plot: chart.stem().to_string(),
        message,
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, PLOT_SIZE).into_drawing_area();
        chart.draw_on(&root).map_err(failed)?;
    }
    Ok(svg)
}

/// The chart as PNG bytes (RGB8).
pub(crate) fn chart_png(chart: &impl Chart) -> Result<Vec<u8>, ReportError> {
    register_font()?;
    let failed = |message: String| ReportError::Plot {
        plot: chart.stem().to_string(),
        message,
    };
    let (w, h) = PLOT_SIZE;
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, PLOT_SIZE).into_drawing_area();
        chart.draw_on(&root).map_err(failed)?;
    }
    let image = image::RgbImage::from_raw(w, h, rgb)
        .ok_or_else(|| failed("bitmap buffer has the wrong size".into()))?;
    let mut png = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| failed(format!("PNG encoding: {e}")))?;
    Ok(png)
}

/// Ten colours distinguishable on white (Tableau 10).
pub(crate) const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Colour of marker style `style`.
pub fn style_colour(style: usize) -> (u8, u8, u8) {
    let c = PALETTE[style % PALETTE.len()];
    (c.0, c.1, c.2)
}

/// A data marker: the family's colour (`style`) and the configuration's shape (`shape`):
/// circle, square, triangle or diamond. Its own element, because
/// plotters' boxed `DynElement` only works with `'static` backends.
pub(crate) struct Marker<C> {
    pub(crate) at: C,
    pub(crate) style: usize,
    pub(crate) shape: usize,
}

impl<'a, C> PointCollection<'a, C> for &'a Marker<C> {
    type Point = &'a C;
    type IntoIter = std::iter::Once<&'a C>;
    fn point_iter(self) -> Self::IntoIter {
        std::iter::once(&self.at)
    }
}

impl<C, DB: DrawingBackend> Drawable<DB> for Marker<C> {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut pos: I,
        backend: &mut DB,
        _: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        const R: i32 = 5;
        let Some((x, y)) = pos.next() else {
            return Ok(());
        };
        let colour = PALETTE[self.style % PALETTE.len()].filled();
        // Families past the tenth colour start from another shape, so they differ too.
        match (self.shape + self.style / PALETTE.len()) % 4 {
            0 => backend.draw_circle((x, y), R as u32, &colour, true),
            1 => backend.draw_rect(
                (x - R + 1, y - R + 1),
                (x + R - 1, y + R - 1),
                &colour,
                true,
            ),
            2 => backend.fill_polygon(
                [(x, y - R - 1), (x + R + 1, y + R), (x - R - 1, y + R)],
                &colour,
            ),
            _ => backend.fill_polygon(
                [
                    (x, y - R - 1),
                    (x + R + 1, y),
                    (x, y + R + 1),
                    (x - R - 1, y),
                ],
                &colour,
            ),
        }
    }
}

fn draw<'a, DB: DrawingBackend + 'a>(
    root: &'a DrawingArea<DB, Shift>,
    plot: &PlotData,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    // The legend beside the axes, not over the points (inside them it hid two techniques'
    // markers on the transmission scenes).
    let (chart_area, legend) = root.split_horizontally(PLOT_SIZE.0 - LEGEND_WIDTH);
    let root = &chart_area;
    let ys = plot.points.iter().map(|p| p.y_drawn);
    let (y_lo, y_hi) = log_range(ys, 1e-4, 1.0);
    match plot.kind {
        PlotKind::CostError => {
            let (x_lo, x_hi) = log_range(plot.points.iter().map(|p| p.x), 0.5, 2.0);
            draw_chart(
                root,
                &legend,
                plot,
                (x_lo..x_hi)
                    .log_scale()
                    .with_key_points(log_ticks(x_lo, x_hi)),
                (y_lo..y_hi)
                    .log_scale()
                    .with_key_points(log_ticks(y_lo, y_hi)),
            )
        }
        PlotKind::BytesError => {
            let x_max = plot.points.iter().map(|p| p.x).fold(0.0, f64::max);
            let x_hi = if x_max > 0.0 { x_max * 1.1 } else { 1.0 };
            draw_chart(
                root,
                &legend,
                plot,
                -0.02 * x_hi..x_hi,
                (y_lo..y_hi)
                    .log_scale()
                    .with_key_points(log_ticks(y_lo, y_hi)),
            )
        }
    }
}

/// Tick positions for a log axis over `[lo, hi]`: 1, 2 and 5 times each power of ten in it;
/// only the powers when that would be more than 12 ticks (and every other power beyond 12
/// decades); 1 to 9 times each power when fewer than 3 would show. A log axis left to plotters
/// labels only powers of ten and shows no label at all on a range inside one decade.
pub fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    let ticks = |mantissas: &[f64], decade_step: i32| -> Vec<f64> {
        let first = lo.log10().floor() as i32;
        let last = hi.log10().ceil() as i32;
        let mut out = Vec::new();
        let mut e = first;
        while e <= last {
            for m in mantissas {
                // Divided for negative powers, so 3e-1 is the double nearest 0.3.
                let v = if e >= 0 {
                    m * 10f64.powi(e)
                } else {
                    m / 10f64.powi(-e)
                };
                if v >= lo * (1.0 - 1e-12) && v <= hi * (1.0 + 1e-12) {
                    out.push(v);
                }
            }
            e += decade_step;
        }
        out
    };
    let fine = ticks(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], 1);
    let medium = ticks(&[1.0, 2.0, 5.0], 1);
    if fine.len() < 2 {
        // Narrower than one step of 1..9: three ticks, two significant digits each.
        return (0..3)
            .map(|i| {
                let v = lo * (hi / lo).powf(f64::from(i) / 2.0);
                let scale = 10f64.powi(v.log10().floor() as i32 - 1);
                (v / scale).round() * scale
            })
            .collect();
    }
    if medium.len() < 3 {
        return fine;
    }
    if medium.len() <= 12 {
        return medium;
    }
    let coarse = ticks(&[1.0], 1);
    if coarse.len() <= 12 {
        coarse
    } else {
        ticks(&[1.0], 2)
    }
}

/// A log range around the positive values with some margin, or `[lo, hi]` when there are none.
pub(crate) fn log_range(values: impl Iterator<Item = f64>, lo: f64, hi: f64) -> (f64, f64) {
    let (min, max) = values
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !min.is_finite() {
        return (lo, hi);
    }
    // At least a factor of 4 in view, so single points do not sit on a degenerate axis.
    let (min, max) = if max / min < 4.0 {
        let mid = (min * max).sqrt();
        (mid / 2.0, mid * 2.0)
    } else {
        (min, max)
    };
    (min / 1.5, max * 1.5)
}

/// A plotters chart over the coordinates `X` × `Y` describe.
pub(crate) type Chart2d<'a, DB, X, Y> = ChartContext<
    'a,
    DB,
    Cartesian2d<<X as AsRangedCoord>::CoordDescType, <Y as AsRangedCoord>::CoordDescType>,
>;

/// The frame every plot of the report shares: caption, margins, axis descriptions, fonts and
/// grid; the cost–error plots and the motion plots differ only in what they draw inside it.
pub(crate) struct Axes<'f> {
    pub title: &'f str,
    pub x_label: &'f str,
    pub y_label: &'f str,
    pub x_format: &'f dyn Fn(&f64) -> String,
    pub y_format: &'f dyn Fn(&f64) -> String,
    /// How many x labels to aim for (plotters' default when `None`).
    pub x_ticks: Option<usize>,
}

impl Axes<'_> {
    /// The chart on `root` over `x` × `y`, its mesh drawn.
    pub(crate) fn build<'a, DB, X, Y>(
        &self,
        root: &'a DrawingArea<DB, Shift>,
        x: X,
        y: Y,
    ) -> Result<Chart2d<'a, DB, X, Y>, String>
    where
        DB: DrawingBackend + 'a,
        X: AsRangedCoord<Value = f64>,
        Y: AsRangedCoord<Value = f64>,
        X::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let mut chart = ChartBuilder::on(root)
            .caption(self.title, (FONT_FAMILY, 20))
            .margin(12)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x, y)
            .map_err(err)?;
        let mut mesh = chart.configure_mesh();
        mesh.x_desc(self.x_label)
            .y_desc(self.y_label)
            .axis_desc_style((FONT_FAMILY, 15))
            .label_style((FONT_FAMILY, 12))
            .light_line_style(WHITE)
            .bold_line_style(BLACK.mix(0.12))
            .x_label_formatter(self.x_format)
            .y_label_formatter(self.y_format);
        if let Some(n) = self.x_ticks {
            mesh.x_labels(n);
        }
        mesh.draw().map_err(err)?;
        Ok(chart)
    }
}

fn draw_chart<'a, DB, X, Y>(
    root: &'a DrawingArea<DB, Shift>,
    legend: &DrawingArea<DB, Shift>,
    plot: &PlotData,
    x: X,
    y: Y,
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
        title: &plot.title,
        x_label: &plot.x_label,
        y_label: &plot.y_label,
        x_format: &|v| short_number(*v),
        y_format: &|v| short_number(*v),
        x_ticks: None,
    };
    let mut chart = axes.build(root, x, y)?;

    // Pareto front: the staircase of what is attainable, and a ring around each member.
    let mut front: Vec<&PlotPoint> = plot.front.iter().map(|&i| &plot.points[i]).collect();
    front.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    let mut stairs = Vec::new();
    for (i, p) in front.iter().enumerate() {
        if i > 0 {
            stairs.push((p.x, front[i - 1].y_drawn));
        }
        stairs.push((p.x, p.y_drawn));
    }
    let grey = RGBColor(90, 90, 90);
    chart
        .draw_series(LineSeries::new(stairs, grey.mix(0.5).stroke_width(3)))
        .map_err(err)?
        .label("Pareto front")
        .legend(move |(x, y)| {
            PathElement::new(vec![(x - 8, y), (x + 8, y)], grey.mix(0.5).stroke_width(3))
        });
    chart
        .draw_series(
            front
                .iter()
                .map(|p| Circle::new((p.x, p.y_drawn), 10, BLACK.stroke_width(1))),
        )
        .map_err(err)?;

    for sweep in &plot.sweeps {
        let colour = PALETTE[plot.points[sweep[0]].style % PALETTE.len()];
        let line = sweep
            .iter()
            .map(|&i| (plot.points[i].x, plot.points[i].y_drawn));
        chart
            .draw_series(LineSeries::new(line, colour.stroke_width(2)))
            .map_err(err)?;
    }

    // Markers, one series per configuration so each has its own legend entry.
    for entry in &plot.legend {
        let (style, shape) = (entry.style, entry.shape);
        chart
            .draw_series(
                plot.points
                    .iter()
                    .filter(|p| p.style == style && p.shape == shape)
                    .map(|p| Marker {
                        at: (p.x, p.y_drawn),
                        style,
                        shape,
                    }),
            )
            .map_err(err)?;
    }
    draw_legend(legend, plot, grey).map_err(err)?;
    if let Some(z) = plot.zero_y {
        root.draw(&Text::new(
            format!("error 0 (exact) is drawn at {}", short_number(z)),
            (100, 40),
            (FONT_FAMILY, 12).into_font(),
        ))
        .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// The legend in its own area: the Pareto front's line, then a marker and the label of each
/// configuration drawn, one row each from the top (rows shrink when there are many).
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    plot: &PlotData,
    front: RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    const TOP: i32 = 50;
    let rows = plot.legend.len() as i32 + 1;
    let room = PLOT_SIZE.1 as i32 - TOP - 20;
    let row_height = (room / rows.max(1)).clamp(9, 18);
    #[allow(non_snake_case)]
    let ROW = row_height;
    let font = (FONT_FAMILY, (row_height - 5).clamp(8, 13)).into_font();
    let text = |row: i32, label: &str| {
        Text::new(label.to_owned(), (30, TOP + row * ROW - 7), font.clone())
    };
    area.draw(&PathElement::new(
        vec![(6, TOP), (22, TOP)],
        front.mix(0.5).stroke_width(3),
    ))?;
    area.draw(&text(0, "Pareto front"))?;
    for (row, entry) in (1..).zip(&plot.legend) {
        area.draw(&Marker {
            at: (14, TOP + row * ROW),
            style: entry.style,
            shape: entry.shape,
        })?;
        area.draw(&text(row, &entry.label))?;
    }
    Ok(())
}

/// Tick labels: plain for ordinary magnitudes, scientific for tiny or huge ones.
pub(crate) fn short_number(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.0e}")
    } else if a >= 100.0 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.2}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_owned()
    } else {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(technique: &str) -> PlotPoint {
        PlotPoint {
            technique: technique.into(),
            family: family(technique).into(),
            style: 0,
            shape: 0,
            x: 1.0,
            y: 1.0,
            y_drawn: 1.0,
        }
    }

    #[test]
    fn family_is_the_name_before_the_colon() {
        assert_eq!(family("dual-peel:passes=5,tail=wboit"), "dual-peel");
        assert_eq!(family("unsorted"), "unsorted");
    }

    #[test]
    fn one_parameter_sweep_is_joined_in_numeric_order() {
        let pts: Vec<PlotPoint> = ["s:spp=16", "s:spp=4", "other", "s:spp=64", "s:spp=1"]
            .map(point)
            .into();
        // spp 1, 4, 16, 64 → indices 4, 1, 0, 3 (lexicographic order would put 16 before 4).
        assert_eq!(sweeps(&pts), vec![vec![4, 1, 0, 3]]);
    }

    #[test]
    fn two_parameter_grid_gives_rows_and_columns_and_words_after_numbers() {
        let pts: Vec<PlotPoint> = [
            "d:passes=2,tail=drop",
            "d:passes=1,tail=wboit",
            "d:passes=auto,tail=drop",
            "d:passes=1,tail=drop",
        ]
        .map(point)
        .into();
        let lines = sweeps(&pts);
        // Along `passes` with tail=drop: 1, 2, auto. With tail=wboit only one point: no line.
        // Along `tail` with passes=1: drop then wboit.
        assert_eq!(lines, vec![vec![3, 0, 2], vec![3, 1]]);
    }

    #[test]
    fn short_numbers() {
        assert_eq!(short_number(0.0), "0");
        assert_eq!(short_number(2.5), "2.5");
        assert_eq!(short_number(0.0125), "0.0125");
        assert_eq!(short_number(1e-5), "1e-5");
        assert_eq!(short_number(300.0), "300");
    }

    /// Every log axis gets labelled ticks, also inside one decade (where plotters alone
    /// labels nothing) and over many decades (thinned).
    #[test]
    fn log_axes_always_have_ticks() {
        assert_eq!(log_ticks(0.5, 2.0), vec![0.5, 1.0, 2.0]);
        assert_eq!(log_ticks(0.25, 0.45), vec![0.3, 0.4]);
        assert_eq!(log_ticks(0.9, 30.0), vec![1.0, 2.0, 5.0, 10.0, 20.0]);
        let wide = log_ticks(1e-7, 1e9);
        assert!(wide.len() <= 12 && wide.len() >= 6, "{wide:?}");
        assert_eq!(log_ticks(1.2, 1.3).len(), 3);
        assert!(log_ticks(0.0, 1.0).is_empty());
    }
}
