//! `report.html`: one static page per results directory. Everything it shows lives in that
//! directory (images by relative path, plots under `plots/`, CSS and a small script inline), so
//! it opens from disk with no server and no network.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use oit_harness::results::{Results, Run, RunStatus, SceneJson};

use crate::plot::{Metric, PlotKind, runs_by_scene};
use crate::{ReportError, pareto_members, write_plots};

/// The page's file name inside the results directory.
pub const REPORT_FILE: &str = "report.html";

/// Reads `dir/results.json`, writes the plots (FLIP and RMSE) under `dir/plots/` and the page
/// `dir/report.html`; returns the page's path.
///
/// Images the page would show but that are missing on disk (a scene's `reference.png`, a
/// run's PNGs) are replaced by a note rather than a broken image.
///
/// The page carries a small inline script that, on load, writes into `<body>` whether every
/// image decoded (`data-images-ok="loaded/total"`) and any script or resource errors
/// (`data-errors`), so a headless browser's DOM dump is enough to check that the page renders.
pub fn write_html_report(dir: &Path) -> Result<PathBuf, ReportError> {
    let results = Results::read(&dir.join("results.json"))?;
    let plots_dir = dir.join("plots");
    write_plots(&results, &plots_dir, Metric::Flip)?;
    write_plots(&results, &plots_dir, Metric::Rmse)?;
    let page = html(&results, dir);
    let path = dir.join(REPORT_FILE);
    oit_metrics::write_atomic_bytes(&path, page.as_bytes())?;
    Ok(path)
}

const STYLE: &str = "body{font-family:sans-serif;margin:1.5em;color:#222}\
table{border-collapse:collapse;margin:1em 0;font-size:90%}\
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right}\
th:first-child,td:first-child{text-align:left;font-family:monospace}\
tr.front td:first-child{font-weight:bold}\
td.note{text-align:left;color:#a33}\
.plots img{max-width:48%;border:1px solid #ddd;margin-right:1%}\
.triple{display:flex;gap:.5em;align-items:flex-start;margin:.5em 0 1.5em}\
.triple figure{margin:0}\
.triple img{width:256px;image-rendering:pixelated;border:1px solid #ddd}\
.missing{width:256px;height:64px;border:1px dashed #aaa;color:#777;font-size:85%;padding:.5em;box-sizing:border-box}\
figcaption{font-size:85%;color:#555}";

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

fn esc(text: &str) -> String {
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
fn url(rel: &str) -> String {
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

fn html(results: &Results, dir: &Path) -> String {
    let members = pareto_members(results, Metric::Flip);
    let a = &results.adapter;
    let mut out = String::new();
    let _ = write!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>oit-lab report</title>\n<style>{STYLE}</style>\n<script>{CHECK_SCRIPT}</script>\n\
         </head>\n<body>\n<h1>oit-lab report</h1>\n"
    );
    let _ = writeln!(
        out,
        "<p>Adapter: <b>{}</b> ({}, {}, {}). GPU ms are medians over the timed frames (min–max \
         beside them); cost is relative to <code>unsorted</code> on the same scene; errors are \
         against the exact CPU reference on linear RGB. <b>Bold</b> techniques are on the scene's \
         Pareto front of cost against mean FLIP (no other run is both cheaper and more accurate).</p>",
        esc(&a.name),
        esc(&a.backend),
        esc(&a.device_type),
        esc(&a.driver)
    );
    if let Some(caveat) = oit_harness::report::overall_timing_caveat(results) {
        let _ = writeln!(out, "<p class=\"caveat\">Timing: {}.</p>", esc(&caveat));
    }
    let scenes = runs_by_scene(results);
    out.push_str("<nav><ul>\n");
    for (scene, _) in &scenes {
        let _ = writeln!(
            out,
            "<li><a href=\"#{}\">{}</a></li>",
            esc(&oit_harness::file_stem(scene)),
            esc(scene)
        );
    }
    out.push_str("</ul></nav>\n");
    for (scene, runs) in &scenes {
        let about = results.scenes.iter().find(|s| s.scene == *scene);
        let timing = oit_harness::report::timing_caveat(results, scene, runs);
        scene_section(&mut out, dir, scene, about, timing, runs, &members);
    }
    out.push_str("</body>\n</html>\n");
    out
}

fn scene_section(
    out: &mut String,
    dir: &Path,
    scene: &str,
    about: Option<&SceneJson>,
    timing: Option<String>,
    runs: &[&Run],
    members: &std::collections::BTreeSet<(String, String)>,
) {
    let stem = oit_harness::file_stem(scene);
    let res = runs[0].resolution;
    let _ = writeln!(
        out,
        "<section id=\"{}\">\n<h2>{} ({}x{})</h2>",
        esc(&stem),
        esc(scene),
        res[0],
        res[1]
    );
    for line in about.map(SceneJson::report_lines).unwrap_or_default() {
        let _ = writeln!(out, "<p class=\"about\">{}.</p>", esc(&line));
    }
    for caveat in oit_harness::report::scene_caveats(runs) {
        let _ = writeln!(out, "<p class=\"caveat\">Reference: {}.</p>", esc(&caveat));
    }
    if let Some(timing) = timing {
        let _ = writeln!(out, "<p class=\"caveat\">Timing: {}.</p>", esc(&timing));
    }

    out.push_str("<div class=\"plots\">\n");
    for kind in [PlotKind::CostError, PlotKind::BytesError] {
        let suffix = if kind == PlotKind::CostError {
            "cost"
        } else {
            "bytes"
        };
        let flip = format!("plots/{stem}-{}-{suffix}", Metric::Flip.key());
        let rmse = format!("plots/{stem}-{}-{suffix}", Metric::Rmse.key());
        out.push_str(&image(
            dir,
            &format!("{flip}.svg"),
            &format!("{scene}: mean FLIP against {suffix}"),
        ));
        let _ = writeln!(
            out,
            " <a href=\"{}\">PNG</a> · <a href=\"{}\">RMSE version</a>",
            esc(&url(&format!("{flip}.png"))),
            esc(&url(&format!("{rmse}.svg")))
        );
    }
    out.push_str("</div>\n");

    out.push_str(
        "<table>\n<tr><th>technique</th><th>GPU ms median</th><th>min–max (frames, source)</th>\
         <th>cost × unsorted</th><th>cost × floor</th><th>bytes/px</th><th>RMSE</th><th>PSNR dB</th><th>mean FLIP</th>\
         <th>relMSE</th><th>SSIM</th><th>max error</th><th>order dep.</th><th>inexact</th></tr>\n",
    );
    for run in runs {
        let front = members.contains(&(run.scene.clone(), run.technique.clone()));
        let _ = write!(
            out,
            "<tr{}><td>{}</td>",
            if front { " class=\"front\"" } else { "" },
            esc(&run.technique)
        );
        if run.status != RunStatus::Ok {
            let status = if run.status == RunStatus::Skipped {
                "skipped"
            } else {
                "failed"
            };
            let _ = writeln!(
                out,
                "<td class=\"note\" colspan=\"13\">{status}: {}</td></tr>",
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
             <td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"note\">{}</td></tr>",
            opt(run.cost_vs_unsorted, |v| format!("{v:.2}")),
            opt(run.cost_vs_floor, |v| format!("{v:.2}")),
            opt(run.bytes_per_pixel, |v| format!("{v:.1}")),
            opt(e.map(|e| e.rmse), oit_harness::report::sci),
            opt(e.map(|e| e.psnr), |v| format!("{v:.1}")),
            e.map_or_else(|| "–".to_owned(), oit_harness::report::flip_cell),
            opt(e.map(|e| e.relmse), oit_harness::report::sci),
            opt(e.map(|e| e.ssim), |v| format!("{v:.4}")),
            opt(e.map(|e| e.max_abs), oit_harness::report::sci),
            opt(run.order_dependence, oit_harness::report::sci),
            esc(&run.inexact.join("; ")),
        );
    }
    out.push_str("</table>\n");

    let reference = format!("{stem}/reference.png");
    for run in runs.iter().filter(|r| r.status == RunStatus::Ok) {
        let _ = writeln!(
            out,
            "<h3><code>{}</code></h3>\n<div class=\"triple\">",
            esc(&run.technique)
        );
        let (render, diff) = match &run.outputs {
            Some(o) => (o.render_png.clone(), o.diff_png.clone()),
            None => (String::new(), String::new()),
        };
        for (rel, what) in [
            (&render, "render"),
            (&reference, "reference"),
            (&diff, "difference"),
        ] {
            let _ = writeln!(
                out,
                "<figure>{}<figcaption>{what}</figcaption></figure>",
                image(dir, rel, &format!("{} {what}", run.technique))
            );
        }
        out.push_str("</div>\n");
    }
    out.push_str("</section>\n");
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
    fn html_escaping() {
        assert_eq!(
            esc("<a href=\"x\">&'"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
    }
}
