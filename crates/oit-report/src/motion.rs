//! Plots of animated scenes: the scenes whose runs carry a `temporal` block
//! (docs/results-schema.md). [`motion_plot_data`] decides what is drawn; [`render_motion_svg`]
//! and [`render_motion_png`] only draw a [`MotionPlot`], so a test of the data is a test of the
//! picture.
//!
//! - **Error over time** ([`MotionKind::FlipOverFrames`], `plots/SCENE-flip-frames.svg|png`):
//!   x the frame, y the headline ꟻLIP of that frame against that frame's exact reference, one
//!   line per technique (colour by family, marker shape by configuration, as in the
//!   speed-versus-error plots), and every pop event marked by a black × on its line.
//! - **Convergence** ([`MotionKind::Convergence`], `plots/SCENE-convergence.svg|png`), when
//!   some run has `static_camera`: the RMSE of the exponential history (`history_rmse`)
//!   against the number of frames accumulated, log-log, one line per technique.
//!
//! The error-over-time y axis ([`YScale`]): on one scene ꟻLIP runs from an exact technique's 0
//! (or rounding near 1e-6) to 0.9, and a log axis has no 0. When the nonzero values span less
//! than a factor of 10 the axis is linear from 0. Otherwise it is a symmetric log,
//! `y ↦ log10(1 + y / t)`, with the threshold `t` the larger of the smallest nonzero value and
//! 1e-4 × the largest: linear below `t`, logarithmic above it, and 0 at the bottom — so an exact
//! technique's line lies visibly along the bottom edge instead of off the axis. The y label
//! says which, and the threshold.
//!
//! Stems end in `-flip-frames` and `-convergence`, never in the `-cost` / `-bytes` of the
//! speed-versus-error plots, so no pair of scene names gives two plots one file.

use std::path::{Path, PathBuf};

use oit_results::{Results, Run, RunStatus, Temporal};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::prelude::*;

use crate::ReportError;
use crate::plot::{
    FONT_FAMILY, LEGEND_WIDTH, LegendEntry, Marker, PALETTE, PLOT_SIZE, configuration_styles,
    log_range, log_ticks, runs_by_scene, short_number,
};

/// The stem suffix of the error-over-time plot.
pub const FRAMES_SUFFIX: &str = "flip-frames";
/// The stem suffix of the static-camera convergence plot.
pub const CONVERGENCE_SUFFIX: &str = "convergence";

/// Which plot of an animated scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionKind {
    /// Headline ꟻLIP per frame against the frame.
    FlipOverFrames,
    /// RMSE of the exponential history against the frames accumulated (log-log).
    Convergence,
}

impl MotionKind {
    fn suffix(self) -> &'static str {
        match self {
            MotionKind::FlipOverFrames => FRAMES_SUFFIX,
            MotionKind::Convergence => CONVERGENCE_SUFFIX,
        }
    }
}

/// The file stem (no extension) of a scene's motion plot, under `plots/`.
pub fn motion_stem(scene: &str, kind: MotionKind) -> String {
    format!("{}-{}", oit_results::file_stem(scene), kind.suffix())
}

/// How values map onto the drawn y axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum YScale {
    /// Linear from 0 to `hi`.
    Linear { hi: f64 },
    /// `y ↦ log10(1 + y / threshold)`: linear below `threshold`, log above, 0 at the bottom;
    /// the axis reaches `hi`. Drawn as `1 + y / threshold` on a log axis, which is the same
    /// picture.
    SymLog { threshold: f64, hi: f64 },
    /// Log from `lo` to `hi`; a value of 0 is drawn at `zero`.
    Log { lo: f64, hi: f64, zero: f64 },
}

impl YScale {
    /// Where the value `y` is drawn on the axis.
    pub fn drawn(self, y: f64) -> f64 {
        match self {
            YScale::Linear { .. } => y,
            YScale::SymLog { threshold, .. } => 1.0 + y.max(0.0) / threshold,
            YScale::Log { zero, .. } => {
                if y > 0.0 {
                    y
                } else {
                    zero
                }
            }
        }
    }

    /// The value drawn at axis position `drawn` (the inverse of [`YScale::drawn`]).
    pub fn value(self, drawn: f64) -> f64 {
        match self {
            YScale::SymLog { threshold, .. } => threshold * (drawn - 1.0),
            YScale::Linear { .. } | YScale::Log { .. } => drawn,
        }
    }

    /// The scale of the error-over-time plot for these values (see the module documentation).
    pub fn for_flip(values: impl Iterator<Item = f64>) -> YScale {
        let (min_pos, hi) = values
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
                (if v > 0.0 { lo.min(v) } else { lo }, hi.max(v))
            });
        if hi <= 0.0 {
            YScale::Linear { hi: 1e-3 }
        } else if min_pos >= hi / 10.0 {
            YScale::Linear { hi: hi * 1.1 }
        } else {
            YScale::SymLog {
                threshold: min_pos.max(hi * 1e-4),
                hi,
            }
        }
    }

    fn axis_note(self) -> String {
        match self {
            YScale::Linear { .. } => "linear".to_owned(),
            YScale::SymLog { threshold, .. } => format!(
                "symmetric log: linear below {}, log above",
                short_number(round_significant(threshold, 2))
            ),
            YScale::Log { .. } => "log scale".to_owned(),
        }
    }
}

/// `v` to `digits` significant digits (tick labels of inverted positions).
fn round_significant(v: f64, digits: i32) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let e = v.abs().log10().floor() as i32 - digits + 1;
    // Divided for negative powers, so 3e-5 is the double nearest 0.00003.
    if e >= 0 {
        let scale = 10f64.powi(e);
        (v / scale).round() * scale
    } else {
        let scale = 10f64.powi(-e);
        (v * scale).round() / scale
    }
}

/// One technique's line.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionSeries {
    pub technique: String,
    /// Colour (family), shape (configuration) and legend label, as in the other plots.
    pub legend: LegendEntry,
    /// `(frame, ꟻLIP)` or `(frames accumulated, RMSE)`, in order.
    pub points: Vec<(f64, f64)>,
    /// The pop events as `(frame, ꟻLIP of that frame)`: marked on the line (error over time).
    pub pops: Vec<(f64, f64)>,
}

/// Everything one motion plot shows.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionPlot {
    pub scene: String,
    pub kind: MotionKind,
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    /// One per ok run with the data this plot needs, in run order.
    pub series: Vec<MotionSeries>,
    pub x_range: (f64, f64),
    pub y_scale: YScale,
    /// Runs with a `temporal` block that could not be drawn, with the reason.
    pub omitted: Vec<(String, String)>,
    /// File name without extension ([`motion_stem`]).
    pub stem: String,
}

/// Every motion plot: per scene with a `temporal` run, the error over time, then the
/// convergence plot when some run has `static_camera`. Scenes without `temporal` runs get none.
pub fn motion_plot_data(results: &Results) -> Vec<MotionPlot> {
    let configs = configuration_styles(results);
    let legend_of = |technique: &str| {
        configs.iter().find(|(c, _)| c == technique).map_or_else(
            || LegendEntry {
                label: technique.to_owned(),
                style: 0,
                shape: 0,
            },
            |(_, e)| e.clone(),
        )
    };
    let mut out = Vec::new();
    for (scene, runs) in runs_by_scene(results) {
        let temporal: Vec<(&Run, &Temporal)> = runs
            .iter()
            .filter(|r| r.status == RunStatus::Ok)
            .filter_map(|r| Some((*r, r.temporal.as_ref()?)))
            .collect();
        if temporal.is_empty() {
            continue;
        }
        let res = temporal[0].0.resolution;
        out.push(frames_plot(&scene, res, &temporal, &legend_of));
        if temporal.iter().any(|(_, t)| t.static_camera.is_some()) {
            out.push(convergence_plot(&scene, res, &temporal, &legend_of));
        }
    }
    out
}

fn frames_plot(
    scene: &str,
    res: [u32; 2],
    runs: &[(&Run, &Temporal)],
    legend_of: &dyn Fn(&str) -> LegendEntry,
) -> MotionPlot {
    let mut series = Vec::new();
    let mut omitted = Vec::new();
    for (run, t) in runs {
        let n = t.frames.len();
        if t.flip.len() != n || n == 0 {
            omitted.push((
                run.technique_label(),
                format!("{} FLIP values for {n} frames", t.flip.len()),
            ));
            continue;
        }
        if let Some(bad) = t.flip.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            omitted.push((run.technique_label(), format!("FLIP {bad} cannot be drawn")));
            continue;
        }
        let points: Vec<(f64, f64)> = t
            .frames
            .iter()
            .zip(&t.flip)
            .map(|(&f, &v)| (f64::from(f), v))
            .collect();
        let pops = t
            .pop_events
            .iter()
            .filter_map(|p| {
                let i = t.frames.iter().position(|f| f == p)?;
                Some((f64::from(*p), t.flip[i]))
            })
            .collect();
        series.push(MotionSeries {
            technique: run.technique_label(),
            legend: legend_of(&crate::plot::config_of(run)),
            points,
            pops,
        });
    }
    let xs = series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let (x_lo, x_hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    let x_range = if x_lo.is_finite() && x_hi > x_lo {
        (x_lo, x_hi)
    } else if x_lo.is_finite() {
        (x_lo - 1.0, x_lo + 1.0)
    } else {
        (0.0, 1.0)
    };
    let y_scale = YScale::for_flip(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
    let names: Vec<&str> = runs.iter().map(|(_, t)| t.flip_name.as_str()).collect();
    let name = if names.iter().all(|n| *n == "HDR-FLIP") {
        "HDR-FLIP"
    } else if names.iter().all(|n| *n != "HDR-FLIP") {
        "FLIP"
    } else {
        "headline FLIP"
    };
    MotionPlot {
        scene: scene.to_owned(),
        kind: MotionKind::FlipOverFrames,
        title: format!(
            "{scene} ({}x{}): {name} of each frame against its reference",
            res[0], res[1]
        ),
        x_label: "frame".to_owned(),
        y_label: format!("mean {name} of the frame (0-1; {})", y_scale.axis_note()),
        series,
        x_range,
        y_scale,
        omitted,
        stem: motion_stem(scene, MotionKind::FlipOverFrames),
    }
}

fn convergence_plot(
    scene: &str,
    res: [u32; 2],
    runs: &[(&Run, &Temporal)],
    legend_of: &dyn Fn(&str) -> LegendEntry,
) -> MotionPlot {
    let mut series = Vec::new();
    let mut omitted = Vec::new();
    let mut blends: Vec<f64> = Vec::new();
    for (run, t) in runs {
        let Some(s) = &t.static_camera else {
            continue;
        };
        if s.history_rmse.is_empty() {
            omitted.push((run.technique_label(), "no history_rmse".to_owned()));
            continue;
        }
        if let Some(bad) = s
            .history_rmse
            .iter()
            .find(|v| !(v.is_finite() && **v >= 0.0))
        {
            omitted.push((run.technique_label(), format!("RMSE {bad} cannot be drawn")));
            continue;
        }
        if !blends.contains(&s.history_blend) {
            blends.push(s.history_blend);
        }
        series.push(MotionSeries {
            technique: run.technique_label(),
            legend: legend_of(&crate::plot::config_of(run)),
            points: (1..)
                .zip(&s.history_rmse)
                .map(|(n, &v)| (f64::from(n), v))
                .collect(),
            pops: Vec::new(),
        });
    }
    let n_max = series.iter().map(|s| s.points.len()).max().unwrap_or(1) as f64;
    let x_range = if n_max > 1.0 {
        (0.8, n_max * 1.25)
    } else {
        (0.5, 2.0)
    };
    let values = || series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
    let min_pos = values().filter(|v| *v > 0.0).fold(f64::INFINITY, f64::min);
    let zero = if min_pos.is_finite() {
        min_pos / 4.0
    } else {
        1e-6
    };
    let (lo, hi) = log_range(values().map(|v| if v > 0.0 { v } else { zero }), 1e-4, 1.0);
    let blend = match blends.as_slice() {
        [b] => format!("blend {}", short_number(*b)),
        _ => "blends differ".to_owned(),
    };
    MotionPlot {
        scene: scene.to_owned(),
        kind: MotionKind::Convergence,
        title: format!(
            "{scene} ({}x{}): static camera, error of the exponential history ({blend})",
            res[0], res[1]
        ),
        x_label: "frames accumulated (log scale)".to_owned(),
        y_label: "RMSE of the history (display space, as FLIP sees it; log scale)".to_owned(),
        series,
        x_range,
        y_scale: YScale::Log { lo, hi, zero },
        omitted,
        stem: motion_stem(scene, MotionKind::Convergence),
    }
}

/// Writes every motion plot ([`motion_plot_data`]) as `STEM.svg` and `STEM.png` into `out_dir`
/// (created if missing), atomically. Returns the files in that order, SVG before PNG; none for
/// results without animated scenes.
pub fn write_motion_plots(results: &Results, out_dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    let plots = motion_plot_data(results);
    if plots.is_empty() {
        return Ok(Vec::new());
    }
    crate::plot::write_charts(&plots, out_dir)
}

/// The plot as an SVG document.
pub fn render_motion_svg(plot: &MotionPlot) -> Result<String, ReportError> {
    crate::plot::chart_svg(plot)
}

/// The plot as PNG bytes (RGB8).
pub fn render_motion_png(plot: &MotionPlot) -> Result<Vec<u8>, ReportError> {
    crate::plot::chart_png(plot)
}

impl crate::plot::Chart for MotionPlot {
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

fn draw<'a, DB: DrawingBackend + 'a>(
    root: &'a DrawingArea<DB, Shift>,
    plot: &MotionPlot,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let (chart_area, legend) = root.split_horizontally(PLOT_SIZE.0 - LEGEND_WIDTH);
    let (x_lo, x_hi) = plot.x_range;
    let scale = plot.y_scale;
    let label = move |v: &f64| {
        if scale.value(*v) < 0.0 {
            String::new()
        } else {
            short_number(round_significant(scale.value(*v), 2))
        }
    };
    let frame_label = |v: &f64| format!("{v:.0}");
    match scale {
        YScale::Linear { hi } => draw_chart(
            &chart_area,
            &legend,
            plot,
            x_lo..x_hi,
            -0.02 * hi..hi,
            (&frame_label, &label),
        ),
        YScale::SymLog { threshold, hi } => {
            // 2 % of the height below 0, so the line of an exact technique clears the axis.
            let top = scale.drawn(hi).powf(1.05);
            let bottom = top.powf(-0.02);
            let mut ticks = vec![1.0];
            ticks.extend(
                log_ticks(threshold, scale.value(top))
                    .into_iter()
                    .map(|v| scale.drawn(v)),
            );
            draw_chart(
                &chart_area,
                &legend,
                plot,
                x_lo..x_hi,
                (bottom..top).log_scale().with_key_points(ticks),
                (&frame_label, &label),
            )
        }
        YScale::Log { lo, hi, .. } => draw_chart(
            &chart_area,
            &legend,
            plot,
            (x_lo..x_hi)
                .log_scale()
                .with_key_points(log_ticks(x_lo, x_hi)),
            (lo..hi).log_scale().with_key_points(log_ticks(lo, hi)),
            (&|v: &f64| short_number(*v), &label),
        ),
    }
}

/// Tick label formatters of the x and y axes.
type Labels<'f> = (&'f dyn Fn(&f64) -> String, &'f dyn Fn(&f64) -> String);

/// Every how many points a line carries its configuration's marker: about 12 per line.
fn marker_step(points: usize) -> usize {
    points.div_ceil(12).max(1)
}

fn draw_chart<'a, DB, X, Y>(
    root: &'a DrawingArea<DB, Shift>,
    legend: &DrawingArea<DB, Shift>,
    plot: &MotionPlot,
    x: X,
    y: Y,
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
    let axes = crate::plot::Axes {
        title: &plot.title,
        x_label: &plot.x_label,
        y_label: &plot.y_label,
        x_format,
        y_format,
        x_ticks: Some(10),
    };
    let mut chart = axes.build(root, x, y)?;
    let scale = plot.y_scale;
    for s in &plot.series {
        let colour = PALETTE[s.legend.style % PALETTE.len()];
        let line = s.points.iter().map(|&(x, y)| (x, scale.drawn(y)));
        chart
            .draw_series(LineSeries::new(line, colour.stroke_width(2)))
            .map_err(err)?;
        let step = marker_step(s.points.len());
        chart
            .draw_series(s.points.iter().step_by(step).map(|&(x, y)| Marker {
                at: (x, scale.drawn(y)),
                style: s.legend.style,
                shape: s.legend.shape,
            }))
            .map_err(err)?;
    }
    // Pop events last, over every line.
    for s in &plot.series {
        chart
            .draw_series(
                s.pops
                    .iter()
                    .map(|&(x, y)| Cross::new((x, scale.drawn(y)), 7, BLACK.stroke_width(2))),
            )
            .map_err(err)?;
    }
    draw_legend(legend, plot).map_err(err)?;
    if let YScale::Log { zero, .. } = scale
        && plot
            .series
            .iter()
            .any(|s| s.points.iter().any(|p| p.1 == 0.0))
    {
        root.draw(&Text::new(
            format!("error 0 (exact) is drawn at {}", short_number(zero)),
            (100, 40),
            (FONT_FAMILY, 12).into_font(),
        ))
        .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// One row per line (its colour, its marker, its label), then the pop-event mark when the plot
/// has pop events; rows shrink when there are many.
fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    plot: &MotionPlot,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    const TOP: i32 = 50;
    let pops = plot.series.iter().any(|s| !s.pops.is_empty());
    let rows = plot.series.len() as i32 + i32::from(pops);
    let room = PLOT_SIZE.1 as i32 - TOP - 20;
    let row = (room / rows.max(1)).clamp(9, 18);
    let font = (FONT_FAMILY, (row - 5).clamp(8, 13)).into_font();
    let text =
        |i: i32, label: &str| Text::new(label.to_owned(), (34, TOP + i * row - 7), font.clone());
    for (i, s) in (0..).zip(&plot.series) {
        let y = TOP + i * row;
        let colour = PALETTE[s.legend.style % PALETTE.len()];
        area.draw(&PathElement::new(
            vec![(4, y), (28, y)],
            colour.stroke_width(2),
        ))?;
        area.draw(&Marker {
            at: (16, y),
            style: s.legend.style,
            shape: s.legend.shape,
        })?;
        area.draw(&text(i, &s.legend.label))?;
    }
    if pops {
        let i = plot.series.len() as i32;
        area.draw(&Cross::new((16, TOP + i * row), 7, BLACK.stroke_width(2)))?;
        area.draw(&text(i, "pop event"))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn close_values_get_a_linear_axis_and_spread_ones_a_symlog_that_keeps_zero() {
        assert_eq!(
            YScale::for_flip([0.0, 0.2, 0.5].into_iter()),
            YScale::Linear { hi: 0.5 * 1.1 }
        );
        let s = YScale::for_flip([0.0, 1e-7, 0.01, 0.5].into_iter());
        assert_eq!(
            s,
            YScale::SymLog {
                threshold: 0.5 * 1e-4,
                hi: 0.5
            }
        );
        // On the log axis: 0 at 1, the threshold at 2 (log10(1 + 1)), exact-but-rounded
        // values just above 0.
        assert_eq!(s.drawn(0.0), 1.0);
        assert!(s.drawn(1e-7) > 1.0 && s.drawn(1e-7) < 1.01);
        assert!((s.drawn(5e-5) - 2.0).abs() < 1e-12);
        for v in [0.0, 1e-6, 0.01, 0.5] {
            assert!((s.value(s.drawn(v)) - v).abs() <= 1e-12 * v.max(1.0));
        }
        // The smallest nonzero value sets the threshold when it is above 1e-4 × the largest.
        assert_eq!(
            YScale::for_flip([0.0, 0.01, 0.5].into_iter()),
            YScale::SymLog {
                threshold: 0.01,
                hi: 0.5
            }
        );
        assert_eq!(
            YScale::for_flip([0.0, 0.0].into_iter()),
            YScale::Linear { hi: 1e-3 }
        );
    }

    #[test]
    fn stems_cannot_collide_with_the_speed_plots() {
        assert_eq!(
            motion_stem("motion-sort-swap", MotionKind::FlipOverFrames),
            "motion-sort-swap-flip-frames"
        );
        assert_eq!(
            motion_stem("a b", MotionKind::Convergence),
            "a_b-convergence"
        );
        for kind in [MotionKind::FlipOverFrames, MotionKind::Convergence] {
            let stem = motion_stem("x", kind);
            assert!(!stem.ends_with("-cost") && !stem.ends_with("-bytes"));
        }
    }

    #[test]
    fn about_twelve_markers_per_line() {
        assert_eq!(marker_step(1), 1);
        assert_eq!(marker_step(12), 1);
        assert_eq!(marker_step(13), 2);
        assert_eq!(marker_step(240), 20);
    }

    #[test]
    fn significant_digits() {
        assert_eq!(round_significant(2.9999e-5, 2), 3e-5);
        assert_eq!(round_significant(0.0, 2), 0.0);
        assert_eq!(round_significant(0.123456, 2), 0.12);
    }
}
