//! `report.html`: one static page per results directory. Everything it shows lives in that
//! directory (images by relative path, plots under `plots/`, CSS and a small script inline), so
//! it opens from disk with no server and no network.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use oit_results::{Results, Run, RunStatus, SceneJson};

use crate::motion::{MotionKind, motion_stem};
use crate::plot::{Metric, PlotKind, runs_by_scene};
use crate::{ReportError, pareto_members, write_motion_plots, write_plots};

/// The page's file name inside the results directory.
pub const REPORT_FILE: &str = "report.html";

/// Reads `dir/results.json`, writes the plots (on `metric` and on the other error axis) and
/// the legends under `dir/plots/` and the page `dir/report.html`; returns the page's path.
/// The page's Pareto fronts, bold rows, summary and first plots are on `metric`; `label` names
/// a technique in the summary's fronts (the harness drops parameters at their defaults).
///
/// Images the page would show but that are missing on disk (a scene's `reference.png`, a
/// run's PNGs) are replaced by a note rather than a broken image.
///
/// The page carries a small inline script that, on load, writes into `<body>` whether every
/// image decoded (`data-images-ok="loaded/total"`) and any script or resource errors
/// (`data-errors`), so a headless browser's DOM dump is enough to check that the page renders.
/// A second script sorts tables by a clicked column, flips a render with its reference and
/// zooms the images of one run together.
pub fn write_html_report(
    dir: &Path,
    metric: Metric,
    label: &dyn Fn(&str) -> String,
) -> Result<PathBuf, ReportError> {
    write_html_report_with(dir, metric, label, crate::DEFAULT_BREAK_AT)
}

/// [`write_html_report`] with the error bound at which the growth section (scene-parameter
/// sweeps, crate::growth) says a technique breaks, on `metric`.
pub fn write_html_report_with(
    dir: &Path,
    metric: Metric,
    label: &dyn Fn(&str) -> String,
    break_at: f64,
) -> Result<PathBuf, ReportError> {
    let results = Results::read(&dir.join("results.json"))?;
    let plots_dir = dir.join("plots");
    write_plots(&results, &plots_dir, Metric::Flip)?;
    write_plots(&results, &plots_dir, Metric::Rmse)?;
    write_motion_plots(&results, &plots_dir)?;
    crate::write_growth_plots(&results, &plots_dir, metric, break_at)?;
    oit_metrics::write_png_srgb8(
        &plots_dir.join(ERROR_LEGEND),
        &oit_metrics::heatmap_legend(LEGEND_PX, 14),
    )?;
    oit_metrics::write_png_srgb8(
        &plots_dir.join(LAYERS_LEGEND),
        &oit_metrics::count_legend(LEGEND_PX, 14),
    )?;
    let page = html(&results, dir, metric, label, break_at);
    let path = dir.join(REPORT_FILE);
    oit_metrics::write_atomic_bytes(&path, page.as_bytes())?;
    Ok(path)
}

/// The heat maps' legend bar, under `plots/`.
pub const ERROR_LEGEND: &str = "legend-error.png";
/// The layer maps' legend bar, under `plots/`.
pub const LAYERS_LEGEND: &str = "legend-layers.png";
/// Width of both legend bars in pixels.
const LEGEND_PX: u32 = 256;

const STYLE: &str = "body{font-family:sans-serif;margin:1.5em;color:#222;max-width:1400px}\
table{border-collapse:collapse;margin:1em 0;font-size:90%}\
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right}\
th{background:#f4f4f4;cursor:pointer;user-select:none}\
th[aria-sort=ascending]::after{content:' \\25B2'}th[aria-sort=descending]::after{content:' \\25BC'}\
th:first-child,td:first-child{text-align:left;font-family:monospace}\
tr.front td:first-child{font-weight:bold}\
td.note,td.text{text-align:left;color:#a33}td.text{color:#222;font-family:sans-serif}\
.banner{background:#fee;border:1px solid #c66;padding:.5em}\
.description{font-size:105%;max-width:60em}\
dl.columns dt{font-weight:bold;float:left;clear:left;width:9em}dl.columns dd{margin-left:10em;margin-bottom:.3em;max-width:60em}\
.legend{display:inline-block;margin:.5em 2em .5em 0;vertical-align:top}\
.legend img{display:block;width:256px;height:14px;border:1px solid #999}\
.ticks{display:flex;justify-content:space-between;width:258px;font-size:75%;color:#555}\
.plots img{max-width:48%;border:1px solid #ddd;margin-right:1%}\
.triple{display:flex;gap:.5em;align-items:flex-start;margin:.5em 0 1.5em;flex-wrap:wrap}\
.triple figure{margin:0}\
.pane{max-width:520px;max-height:520px;overflow:auto;border:1px solid #ddd}\
.pane img{width:256px;image-rendering:pixelated;display:block}\
.stack img.b{display:none}.stack.flipped img.a{display:none}.stack.flipped img.b{display:block}\
.controls{font-size:85%;margin:.2em 0}\
.missing{width:256px;height:64px;border:1px dashed #aaa;color:#777;font-size:85%;padding:.5em;box-sizing:border-box}\
figcaption{font-size:85%;color:#555}";

/// Sorting, flipping and zooming (no libraries, nothing fetched).
const UI_SCRIPT: &str = r#"(function () {
  function key(cell) {
    var t = cell.textContent.trim();
    var n = parseFloat(t.replace(/[^0-9eE.+\-]/g, ' ').trim().split(' ')[0]);
    return isNaN(n) || /^(–|-)$/.test(t) ? null : n;
  }
  function sortBy(table, col, th) {
    var body = table.tBodies[0];
    var rows = Array.prototype.slice.call(body.rows);
    var dir = th.getAttribute('aria-sort') === 'ascending' ? -1 : 1;
    Array.prototype.forEach.call(table.tHead.rows[0].cells, function (c) { c.removeAttribute('aria-sort'); });
    th.setAttribute('aria-sort', dir === 1 ? 'ascending' : 'descending');
    rows.sort(function (a, b) {
      var x = a.cells[col], y = b.cells[col];
      if (!x || !y) { return 0; }
      var kx = key(x), ky = key(y);
      if (kx === null && ky === null) { return dir * x.textContent.localeCompare(y.textContent); }
      if (kx === null) { return 1; }
      if (ky === null) { return -1; }
      return dir * (kx - ky);
    });
    rows.forEach(function (r) { body.appendChild(r); });
  }
  document.addEventListener('DOMContentLoaded', function () {
    Array.prototype.forEach.call(document.querySelectorAll('table.sortable'), function (table) {
      Array.prototype.forEach.call(table.tHead.rows[0].cells, function (th, col) {
        th.title = 'sort by ' + th.textContent;
        th.addEventListener('click', function () { sortBy(table, col, th); });
      });
    });
    Array.prototype.forEach.call(document.querySelectorAll('.viewer'), function (v) {
      var stack = v.querySelector('.stack');
      var flip = v.querySelector('button.flip');
      var label = v.querySelector('.showing');
      function toggle() {
        if (!stack) { return; }
        stack.classList.toggle('flipped');
        if (label) { label.textContent = stack.classList.contains('flipped') ? 'reference' : 'render'; }
      }
      if (flip) { flip.addEventListener('click', toggle); }
      if (stack) { stack.addEventListener('click', toggle); }
      var zoom = v.querySelector('select.zoom');
      if (zoom) {
        zoom.addEventListener('change', function () {
          var z = parseFloat(zoom.value);
          Array.prototype.forEach.call(v.querySelectorAll('.pane img'), function (img) {
            img.style.width = (z * 256) + 'px';
          });
        });
      }
    });
  });
})();"#;

/// Records, in `<body>` attributes, whether every image decoded and which errors happened.
const CHECK_SCRIPT: &str = r#"(function () {
  var errors = [];
  window.addEventListener('error', function (e) {
    var t = e.target;
    if (t && t !== window && t.tagName) {
      errors.push('failed to load ' + t.tagName.toLowerCase() + ' ' + (t.getAttribute('src') || ''));
    } else {
      errors.push('script error: ' + e.message);
    }
  }, true);
  window.addEventListener('unhandledrejection', function (e) { errors.push('unhandled rejection: ' + e.reason); });
  var consoleError = console.error;
  console.error = function () {
    errors.push('console.error: ' + Array.prototype.join.call(arguments, ' '));
    return consoleError.apply(console, arguments);
  };
  window.addEventListener('load', function () {
    var images = document.images, loaded = 0;
    for (var i = 0; i < images.length; i++) {
      if (images[i].complete && images[i].naturalWidth > 0) { loaded++; }
      else { errors.push('image not decoded: ' + images[i].getAttribute('src')); }
    }
    document.body.setAttribute('data-images-ok', loaded + '/' + images.length);
    document.body.setAttribute('data-errors', errors.join(' | '));
  });
})();"#;

pub(crate) fn esc(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A relative path as a URL: `/`-separated, anything but unreserved characters percent-encoded
/// (a `:` would otherwise read as a URL scheme).
pub(crate) fn url(rel: &str) -> String {
    let mut out = String::new();
    for b in rel.replace('\\', "/").bytes() {
        if b.is_ascii_alphanumeric() || b"-_./~".contains(&b) {
            out.push(b as char);
        } else {
            let _ = write!(out, "%{b:02X}");
        }
    }
    out
}

/// `<img>` when the file exists, a visible note otherwise.
fn image(dir: &Path, rel: &str, alt: &str) -> String {
    if dir.join(rel).is_file() {
        format!(
            r#"<img src="{}" alt="{}" loading="eager">"#,
            esc(&url(rel)),
            esc(alt)
        )
    } else {
        format!(
            r#"<div class="missing">{} not found ({})</div>"#,
            esc(alt),
            esc(rel)
        )
    }
}

/// What a column of the per-scene table means (its `title`), from the harness's glossary.
fn column_title(name: &str) -> String {
    oit_results::report::COLUMNS
        .iter()
        .find(|(n, _)| *n == name)
        .map_or_else(String::new, |(_, meaning)| esc(&meaning.replace('`', "")))
}

fn html(
    results: &Results,
    dir: &Path,
    metric: Metric,
    label: &dyn Fn(&str) -> String,
    break_at: f64,
) -> String {
    let members = pareto_members(results, metric);
    let a = &results.adapter;
    let mut out = String::new();
    let _ = write!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>oit-lab report</title>\n<style>{STYLE}</style>\n<script>{CHECK_SCRIPT}</script>\n\
         <script>{UI_SCRIPT}</script>\n</head>\n<body>\n<h1>oit-lab report</h1>\n"
    );
    if !results.complete {
        out.push_str(
            "<p class=\"banner\">Incomplete: the comparison was interrupted. Run the same \
             <code>oit compare</code> with <code>--resume</code> and this output folder to \
             finish it.</p>\n",
        );
    }
    if let Some(note) = oit_results::report::shard_note(results) {
        let _ = writeln!(out, "<p class=\"banner\">Shards: {}.</p>", esc(&note));
    }
    let _ = writeln!(
        out,
        "<p>Adapter: <b>{}</b> ({}, {}, {}){}. Errors are against the exact CPU reference on \
         linear RGB. The error axis of the fronts, the bold rows and the first plots is \
         <b>{}</b>.</p>",
        esc(&a.name),
        esc(&a.backend),
        esc(&a.device_type),
        esc(&a.driver),
        results.tool.as_ref().map_or_else(String::new, |t| format!(
            "; {} {} (build {})",
            esc(&t.name),
            esc(&t.version),
            esc(&t.build)
        )),
        metric.name()
    );
    if let Some(caveat) = oit_results::report::overall_timing_caveat(results) {
        let _ = writeln!(out, "<p class=\"caveat\">Timing: {}.</p>", esc(&caveat));
    }
    if let Some(line) = oit_results::report::predictions_summary(results) {
        let _ = writeln!(out, "<p>Predictions: {}.</p>", esc(&line));
    }
    let scenes = runs_by_scene(results);
    how_to_read(&mut out, metric);
    summary(&mut out, results, &scenes, &members, metric, label);
    crate::growth::html_section(&mut out, results, metric, break_at);
    out.push_str("<nav><h2>Scenes</h2><ul>\n");
    for (scene, _) in &scenes {
        let about = results.scenes.iter().find(|s| s.scene == *scene);
        let _ = writeln!(
            out,
            "<li><a href=\"#{}\">{}</a>{}</li>",
            esc(&oit_results::file_stem(scene)),
            esc(scene),
            about
                .map(|s| first_sentence(&s.description))
                .filter(|d| !d.is_empty())
                .map_or_else(String::new, |d| format!(": {}", esc(&d)))
        );
    }
    out.push_str("</ul></nav>\n");
    for (scene, runs) in &scenes {
        let about = results.scenes.iter().find(|s| s.scene == *scene);
        let timing = oit_results::report::timing_caveat(results, scene, runs);
        let floor_note = oit_results::report::below_floor_note(results, scene, runs);
        scene_section(
            &mut out,
            dir,
            scene,
            about,
            [timing, floor_note],
            runs,
            &members,
            metric,
        );
    }
    out.push_str("</body>\n</html>\n");
    out
}

/// The first sentence of a description: up to the first `. ` or `: ` outside parentheses, for
/// the scene list.
fn first_sentence(text: &str) -> String {
    let mut depth = 0i32;
    let mut end = text.len();
    let bytes = text.as_bytes();
    for (i, &b) in bytes.iter().enumerate() {
        match b {
            b'(' => depth += 1,
            b')' => depth -= 1,
            b'.' | b':' if depth <= 0 && bytes.get(i + 1) == Some(&b' ') => {
                end = i;
                break;
            }
            _ => {}
        }
    }
    text[..end].trim_end_matches('.').to_owned()
}

/// Escaped `text` with its markdown code spans (`` `x` ``) as `<code>`.
fn esc_code(text: &str) -> String {
    let mut out = String::new();
    for (i, part) in esc(text).split('`').enumerate() {
        if i % 2 == 1 {
            let _ = write!(out, "<code>{part}</code>");
        } else {
            out.push_str(part);
        }
    }
    out
}

/// The page's key: what fronts, columns, heat maps and layer maps mean.
fn how_to_read(out: &mut String, metric: Metric) {
    let _ = writeln!(
        out,
        "<section id=\"how-to-read\">\n<h2>How to read this report</h2>\n\
         <p>A technique is on a scene's <b>Pareto front</b> (bold, and listed under the scene) \
         when no other run of that scene is both cheaper (GPU time relative to \
         <code>unsorted</code>) and more accurate ({}): the configurations worth choosing \
         between. Every table sorts by the column you click.</p>\n<dl class=\"columns\">",
        metric.name()
    );
    let extra: [(&str, &str); 4] = [
        (
            "min–max",
            "the fastest and slowest timed frame, how many were timed, and the timing source",
        ),
        (
            "PSNR dB",
            "peak signal-to-noise ratio against the reference (peak 1), from the RMSE",
        ),
        (
            "relMSE",
            "mean of squared error over the squared reference value (plus 0.01), the render-noise measure of path-tracing papers",
        ),
        (
            "SSIM",
            "structural similarity of the tone-mapped luminance, 1 is identical",
        ),
    ];
    for (name, meaning) in oit_results::report::COLUMNS.iter().chain(&extra) {
        let _ = writeln!(out, "<dt>{}</dt><dd>{}.</dd>", esc(name), esc_code(meaning));
    }
    out.push_str("</dl>\n");
    let ticks = |labels: &[&str]| {
        labels
            .iter()
            .map(|l| format!("<span>{l}</span>"))
            .collect::<String>()
    };
    let _ = writeln!(
        out,
        "<div class=\"legend\"><b>Difference (heat map)</b>: per pixel, the largest absolute \
         error of R, G or B against the reference, log scale; darker is closer, cyan is NaN or \
         infinite.<img src=\"plots/{ERROR_LEGEND}\" alt=\"heat-map colours from error 1e-4 to 1\">\
         <div class=\"ticks\">{}</div></div>",
        ticks(&["≤1e-4", "1e-3", "1e-2", "0.1", "≥1"])
    );
    let _ = writeln!(
        out,
        "<div class=\"legend\"><b>Layers (the reference)</b>: per pixel, how many transparent \
         fragments the exact reference composited, log scale.<img src=\"plots/{LAYERS_LEGEND}\" \
         alt=\"layer-map colours from 0 to 255 layers\"><div class=\"ticks\">{}</div></div>",
        ticks(&["0", "3", "15", "63", "≥255"])
    );
    out.push_str(
        "<p>Each run shows its render (click it, or <i>flip</i>, to see the reference in the \
         same place), its difference and the zoom for both.</p>\n</section>\n",
    );
}

/// The answer before the detail: one row per technique over every scene it ran on, and the
/// front of every scene.
fn summary(
    out: &mut String,
    results: &Results,
    scenes: &[(String, Vec<&Run>)],
    members: &std::collections::BTreeSet<(String, String)>,
    metric: Metric,
    label: &dyn Fn(&str) -> String,
) {
    let mut techniques: Vec<(String, Vec<&Run>)> = Vec::new();
    for run in results.runs.iter().filter(|r| r.status == RunStatus::Ok) {
        let label = run.technique_label();
        match techniques.iter_mut().find(|(t, _)| *t == label) {
            Some((_, runs)) => runs.push(run),
            None => techniques.push((label, vec![run])),
        }
    }
    let median = |mut v: Vec<f64>| -> String {
        v.sort_by(f64::total_cmp);
        match v.len() {
            0 => "–".to_owned(),
            n if n % 2 == 1 => format!("{:.2}", v[n / 2]),
            n => format!("{:.2}", 0.5 * (v[n / 2 - 1] + v[n / 2])),
        }
    };
    let _ = writeln!(
        out,
        "<section id=\"summary\">\n<h2>Summary over the suite</h2>\n<p>Per technique over the \
         scenes it ran on: how often it is on a scene's front, the median of its per-scene cost \
         ratios, its mean {}, the scenes it renders within max error 4e-3 of the reference \
         (exact), its largest order dependence and the scenes where it reported itself \
         inexact.</p>\n<table class=\"sortable\">\n<thead><tr><th>technique</th><th>scenes</th>\
         <th>on the front of</th><th>median cost × unsorted</th><th>median cost × floor</th>\
         <th>mean {}</th><th>exact scenes</th><th>max order dep.</th><th>inexact scenes</th>\
         </tr></thead>\n<tbody>",
        metric.name(),
        metric.name()
    );
    for (technique, runs) in &techniques {
        let errors: Vec<&oit_metrics::Errors> =
            runs.iter().filter_map(|r| r.error.as_ref()).collect();
        let mean = errors.iter().map(|e| metric.of(e)).sum::<f64>() / errors.len().max(1) as f64;
        let exact = errors
            .iter()
            .filter(|e| e.max_abs <= 4e-3 && e.nonfinite == 0)
            .count();
        let fronts = runs
            .iter()
            .filter(|r| members.contains(&(r.scene.clone(), r.technique_label())))
            .count();
        let order = runs
            .iter()
            .filter_map(|r| r.order_dependence)
            .fold(0.0, f64::max);
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td>{}</td><td>{fronts}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{exact}</td><td>{}</td><td>{}</td></tr>",
            esc(technique),
            runs.len(),
            median(runs.iter().filter_map(|r| r.cost_vs_unsorted).collect()),
            median(runs.iter().filter_map(|r| r.cost_vs_floor).collect()),
            oit_results::report::sci(mean),
            oit_results::report::sci(order),
            runs.iter().filter(|r| !r.inexact.is_empty()).count()
        );
    }
    let _ = writeln!(
        out,
        "</tbody></table>\n<h3>Pareto front of each scene (cost against {})</h3>\n\
         <table class=\"sortable\">\n<thead><tr><th>scene</th><th>on the front</th></tr></thead>\n<tbody>",
        metric.name()
    );
    for (scene, runs) in scenes {
        let front: Vec<String> = runs
            .iter()
            .filter(|r| members.contains(&(r.scene.clone(), r.technique_label())))
            .map(|r| {
                format!(
                    "<code>{}</code>",
                    esc(&oit_results::technique_label(
                        &label(&r.technique),
                        r.target_format
                    ))
                )
            })
            .collect();
        let _ = writeln!(
            out,
            "<tr><td><a href=\"#{}\">{}</a></td><td class=\"text\">{}</td></tr>",
            esc(&oit_results::file_stem(scene)),
            esc(scene),
            if front.is_empty() {
                "– (no run with a cost and an error)".to_owned()
            } else {
                front.join(", ")
            }
        );
    }
    out.push_str("</tbody></table>\n</section>\n");
}

#[allow(clippy::too_many_arguments)] // one section needs all of these
fn scene_section(
    out: &mut String,
    dir: &Path,
    scene: &str,
    about: Option<&SceneJson>,
    caveats: [Option<String>; 2],
    runs: &[&Run],
    members: &std::collections::BTreeSet<(String, String)>,
    metric: Metric,
) {
    let stem = oit_results::file_stem(scene);
    let res = runs[0].resolution;
    let _ = writeln!(
        out,
        "<section id=\"{}\">\n<h2>{} ({}x{})</h2>",
        esc(&stem),
        esc(scene),
        res[0],
        res[1]
    );
    if let Some(d) = about
        .map(|a| a.description.as_str())
        .filter(|d| !d.is_empty())
    {
        let _ = writeln!(out, "<p class=\"description\">{}</p>", esc(d));
    }
    for line in about.map(SceneJson::report_lines).unwrap_or_default() {
        let _ = writeln!(out, "<p class=\"about\">{}.</p>", esc(&line));
    }
    for caveat in oit_results::report::scene_caveats(runs) {
        let _ = writeln!(out, "<p class=\"caveat\">Reference: {}.</p>", esc(&caveat));
    }
    let [timing, floor_note] = caveats;
    if let Some(timing) = timing {
        let _ = writeln!(out, "<p class=\"caveat\">Timing: {}.</p>", esc(&timing));
    }
    if let Some(note) = floor_note {
        let _ = writeln!(out, "<p class=\"caveat\">‡ {}.</p>", esc(&note));
    }
    let front: Vec<String> = runs
        .iter()
        .filter(|r| members.contains(&(r.scene.clone(), r.technique_label())))
        .map(|r| format!("<b><code>{}</code></b>", esc(&r.technique_label())))
        .collect();
    let _ = writeln!(
        out,
        "<p class=\"front\">On the Pareto front of cost against {}: {}.</p>",
        metric.name(),
        if front.is_empty() {
            "none (no run has both a cost and an error)".to_owned()
        } else {
            front.join(", ")
        }
    );

    let other = match metric {
        Metric::Flip => Metric::Rmse,
        Metric::Rmse => Metric::Flip,
    };
    out.push_str("<div class=\"plots\">\n");
    for kind in [PlotKind::CostError, PlotKind::BytesError] {
        let suffix = if kind == PlotKind::CostError {
            "cost"
        } else {
            "bytes"
        };
        let main = format!("plots/{stem}-{}-{suffix}", metric.key());
        let alt = format!("plots/{stem}-{}-{suffix}", other.key());
        out.push_str(&image(
            dir,
            &format!("{main}.svg"),
            &format!("{scene}: {} against {suffix}", metric.name()),
        ));
        let _ = writeln!(
            out,
            " <a href=\"{}\">PNG</a> · <a href=\"{}\">{} version</a>",
            esc(&url(&format!("{main}.png"))),
            esc(&url(&format!("{alt}.svg"))),
            other.name()
        );
    }
    out.push_str("</div>\n");

    let columns: [(&str, &str); 15] = [
        ("technique", ""),
        ("GPU ms", "GPU ms"),
        ("min–max (frames, source)", ""),
        ("cost × unsorted", "cost × unsorted"),
        ("cost × floor", "cost × floor"),
        ("bytes/px", "bytes/px"),
        ("RMSE", "RMSE"),
        ("PSNR dB", ""),
        ("mean FLIP", "FLIP"),
        ("relMSE", ""),
        ("SSIM", ""),
        ("max error", "max error"),
        ("order dep.", "order dep."),
        ("predicted exact", "predicted exact"),
        ("inexact", "inexact"),
    ];
    out.push_str("<table class=\"sortable\">\n<thead><tr>");
    for (name, glossary) in columns {
        let title = column_title(glossary);
        if title.is_empty() {
            let _ = write!(out, "<th>{name}</th>");
        } else {
            let _ = write!(out, "<th title=\"{title}\">{name}</th>");
        }
    }
    out.push_str("</tr></thead>\n<tbody>\n");
    for run in runs {
        let on_front = members.contains(&(run.scene.clone(), run.technique_label()));
        let _ = write!(
            out,
            "<tr{}><td>{}</td>",
            if on_front { " class=\"front\"" } else { "" },
            esc(&run.technique_label())
        );
        if run.status != RunStatus::Ok {
            let status = if run.status == RunStatus::Skipped {
                "skipped"
            } else {
                "failed"
            };
            let _ = writeln!(
                out,
                "<td class=\"note\" colspan=\"14\">{status}: {}</td></tr>",
                esc(run.reason.as_deref().unwrap_or("no reason recorded"))
            );
            continue;
        }
        let opt = |v: Option<f64>, f: fn(f64) -> String| v.map_or_else(|| "–".to_owned(), f);
        let (median, spread) = match &run.gpu_ms {
            Some(g) => (
                format!(
                    "{:.3}{}",
                    g.median,
                    if g.interference.is_some_and(|i| i.notable()) {
                        "†"
                    } else {
                        ""
                    }
                ),
                format!(
                    "{:.3}–{:.3} ({}, {})",
                    g.min,
                    g.max,
                    g.frames,
                    esc(&g.source)
                ),
            ),
            None => ("–".into(), "–".into()),
        };
        let e = run.error.as_ref();
        let _ = writeln!(
            out,
            "<td>{median}</td><td>{spread}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
             <td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"note\">{}</td>\
             <td class=\"note\">{}</td></tr>",
            opt(run.cost_vs_unsorted, |v| format!("{v:.2}")),
            opt(run.cost_vs_floor, |v| if v < 1.0 {
                format!("{v:.2}‡")
            } else {
                format!("{v:.2}")
            }),
            opt(run.bytes_per_pixel, |v| format!("{v:.1}")),
            opt(e.map(|e| e.rmse), oit_results::report::sci),
            opt(e.map(|e| e.psnr), |v| format!("{v:.1}")),
            e.map_or_else(|| "–".to_owned(), oit_results::report::flip_cell),
            opt(e.map(|e| e.relmse), oit_results::report::sci),
            opt(e.map(|e| e.ssim), |v| format!("{v:.4}")),
            opt(e.map(|e| e.max_abs), oit_results::report::sci),
            opt(run.order_dependence, oit_results::report::sci),
            esc(&prediction_html(run)),
            esc(&run.inexact.join("; ")),
        );
    }
    out.push_str("</tbody></table>\n");
    motion_section(out, dir, scene, runs);

    // The scene's reference and its layer count, once.
    let reference = format!("{stem}/reference.png");
    let layers = format!("{stem}/{}", oit_results::LAYERS_PNG);
    out.push_str("<div class=\"triple\">\n");
    for (rel, what) in [(&reference, "reference"), (&layers, "layers per pixel")] {
        let _ = writeln!(
            out,
            "<figure><div class=\"pane\">{}</div><figcaption>{what}</figcaption></figure>",
            image(dir, rel, &format!("{scene} {what}"))
        );
    }
    out.push_str("</div>\n");

    for run in runs.iter().filter(|r| r.status == RunStatus::Ok) {
        let _ = writeln!(
            out,
            "<h3><code>{}</code></h3>\n<div class=\"viewer\">\n<div class=\"controls\">\
             <button type=\"button\" class=\"flip\">flip render / reference</button> showing \
             <span class=\"showing\">render</span> · zoom <select class=\"zoom\">\
             <option value=\"1\">1×</option><option value=\"2\">2×</option>\
             <option value=\"4\">4×</option><option value=\"8\">8×</option></select></div>\n\
             <div class=\"triple\">",
            esc(&run.technique_label())
        );
        let (render, diff) = match &run.outputs {
            Some(o) => (o.render_png.clone(), o.diff_png.clone()),
            None => (String::new(), String::new()),
        };
        let flip_b = if dir.join(&reference).is_file() {
            image(
                dir,
                &reference,
                &format!("{} reference", run.technique_label()),
            )
            .replacen("<img ", "<img class=\"b\" ", 1)
        } else {
            String::new()
        };
        let _ = writeln!(
            out,
            "<figure><div class=\"pane stack\">{}{flip_b}</div><figcaption>render \
             (click: reference)</figcaption></figure>",
            image(dir, &render, &format!("{} render", run.technique_label())).replacen(
                "<img ",
                "<img class=\"a\" ",
                1,
            )
        );
        if flip_b.is_empty() {
            let _ = writeln!(
                out,
                "<figure>{}<figcaption>reference</figcaption></figure>",
                image(
                    dir,
                    &reference,
                    &format!("{} reference", run.technique_label())
                )
            );
        }
        let _ = writeln!(
            out,
            "<figure><div class=\"pane\">{}</div><figcaption>difference</figcaption></figure>",
            image(dir, &diff, &format!("{} difference", run.technique_label()))
        );
        out.push_str("</div>\n</div>\n");
    }
    out.push_str("</section>\n");
}

/// Where `oit compare` writes a technique's clip of an animated scene (an animated PNG of the
/// path, each frame render | reference | error heat map), relative to the results folder.
fn motion_clip(scene_stem: &str, technique: &str, format: oit_results::TargetFormat) -> String {
    format!(
        "{scene_stem}/{}{}-motion.png",
        oit_results::file_stem(technique),
        format.file_suffix()
    )
}

/// An animated scene's motion: the error-over-time plot, the convergence plot when some run
/// measured a static camera, and the motion table (oit_results::report::motion_cells). Nothing
/// for a still scene.
fn motion_section(out: &mut String, dir: &Path, scene: &str, runs: &[&Run]) {
    let rows = oit_results::report::motion_runs(runs);
    let Some((_, first)) = rows.first() else {
        return;
    };
    let stem = oit_results::file_stem(scene);
    let _ = writeln!(
        out,
        "<div class=\"motion\" id=\"{}-motion\">\n<h3>Motion over {} frames</h3>\n\
         <p>Each frame against the exact reference of that frame: {} per frame, one line per \
         technique, pop events marked ×.</p>\n<div class=\"plots\">",
        esc(&stem),
        first.frames.len(),
        esc(&first.flip_name)
    );
    let mut plots = vec![(MotionKind::FlipOverFrames, "FLIP of each frame")];
    if rows.iter().any(|(_, t)| t.static_camera.is_some()) {
        plots.push((MotionKind::Convergence, "static-camera history convergence"));
    }
    for (kind, what) in plots {
        let rel = format!("plots/{}", motion_stem(scene, kind));
        out.push_str(&image(
            dir,
            &format!("{rel}.svg"),
            &format!("{scene}: {what}"),
        ));
        let _ = writeln!(
            out,
            " <a href=\"{}\">PNG</a>",
            esc(&url(&format!("{rel}.png")))
        );
    }
    out.push_str("</div>\n<table class=\"sortable\">\n<thead><tr><th>technique</th>");
    for (name, meaning) in oit_results::report::MOTION_COLUMNS {
        let _ = write!(
            out,
            "<th title=\"{}\">{}</th>",
            esc(&meaning.replace('`', "")),
            esc(name)
        );
    }
    out.push_str(
        "<th title=\"the path as an animation: render, reference, error heat map side by side\">\
         clip</th></tr></thead>\n<tbody>\n",
    );
    for (run, t) in &rows {
        out.push_str("<tr>");
        for cell in oit_results::report::motion_cells(run, t, 8) {
            let _ = write!(out, "<td>{}</td>", esc(&cell));
        }
        // The harness's clip, linked only when it is on disk.
        let clip = motion_clip(&stem, &run.technique, run.target_format);
        if dir.join(&clip).is_file() {
            let _ = write!(
                out,
                "<td class=\"text\"><a href=\"{}\">play</a></td>",
                esc(&url(&clip))
            );
        } else {
            out.push_str("<td>–</td>");
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</tbody></table>\n</div>\n");
}

/// A run's prediction cell: the verdict, and why (the full reason is in results.md too).
fn prediction_html(run: &Run) -> String {
    match &run.prediction {
        Some(p) => format!(
            "{}: {}",
            oit_results::report::prediction_cell(run),
            p.because
        ),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_escape_reserved_characters() {
        assert_eq!(url("a b/c:d.png"), "a%20b/c%3Ad.png");
        assert_eq!(
            url("scene/dual-peel_passes-5.png"),
            "scene/dual-peel_passes-5.png"
        );
    }

    #[test]
    fn first_sentences_stop_outside_parentheses() {
        assert_eq!(
            first_sentence(
                "Quads at alpha 1 (red), a quad (kept: discard is α < c) and more. Then"
            ),
            "Quads at alpha 1 (red), a quad (kept: discard is α < c) and more"
        );
        assert_eq!(first_sentence("Red over green: exact."), "Red over green");
        assert_eq!(first_sentence("No stop"), "No stop");
        assert_eq!(esc_code("a `b` <c>"), "a <code>b</code> &lt;c&gt;");
    }

    #[test]
    fn html_escaping() {
        assert_eq!(
            esc("<a href=\"x\">&'"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
    }
}
