//! oit-report: the speed-versus-error picture of a `results.json`.
//!
//! - [`pareto_front`]: which (cost, error) points no other point beats on both axes.
//! - [`pareto_members`] / [`pareto_markdown`]: the front per scene, for `results.md`.
//! - [`write_plots`]: per scene, error against GPU cost relative to `unsorted` and error against
//!   bytes per pixel, as SVG and PNG. Text is rendered by plotters' pure-Rust `ab_glyph` path
//!   with a bundled DejaVu Sans, so no system font library (fontconfig, freetype) is needed.
//! - [`write_motion_plots`]: per animated scene (runs with a `temporal` block), the headline ꟻLIP
//!   of every frame per technique with its pop events marked, and the static-camera convergence
//!   of the exponential history, as SVG and PNG (what is drawn: [`motion_plot_data`]).
//! - [`write_growth_plots`] / [`growth_markdown`]: for scene-parameter sweeps (runs with
//!   `varied`), cost and error against the swept value per technique, the fitted growth
//!   exponent and where each technique breaks ([`growth_data`]).
//! - [`recommend`]: the cheapest configuration within an error budget, per scene and over
//!   several scenes (`oit recommend`, docs/recommend.md).
//! - [`write_html_report`]: a static `report.html` (no server, no network, no external files
//!   other than the run's own images) with tables, images side by side, and the plots.

mod growth;
mod html;
mod motion;
mod pareto;
mod plot;
pub mod recommend;

use std::path::{Path, PathBuf};

pub use growth::{
    DEFAULT_BREAK_AT, FitError, GrowthChart, GrowthKind, GrowthPoint, GrowthRow, GrowthSweep,
    PowerLaw, fit_power_law, growth_charts, growth_data, growth_markdown, write_growth_plots,
};
pub use html::{REPORT_FILE, write_html_report, write_html_report_with};
pub use motion::{
    CONVERGENCE_SUFFIX, FRAMES_SUFFIX, MotionKind, MotionPlot, MotionSeries, YScale,
    motion_plot_data, motion_stem, render_motion_png, render_motion_svg, write_motion_plots,
};
pub use pareto::{pareto_front, pareto_markdown, pareto_members, scene_front};
pub use plot::{
    LEGEND_WIDTH, LegendEntry, Metric, PLOT_SIZE, PlotData, PlotKind, PlotPoint, family, log_ticks,
    plot_data, render_png, render_svg, style_colour, write_plots,
};

/// Errors of report generation. Each names the file or plot it concerns.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// `results.json` could not be read or is not schema `oit-lab/results/v1`.
    #[error(transparent)]
    Results(#[from] oit_results::ResultsError),
    /// plotters failed while drawing a plot (the message is plotters' own).
    #[error("plot {plot}: {message}")]
    Plot { plot: String, message: String },
    #[error(transparent)]
    Metrics(#[from] oit_metrics::MetricsError),
}

impl ReportError {
    fn io(path: &Path, source: std::io::Error) -> Self {
        ReportError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}
