//! Human-readable summaries of a [`Results`]: the terminal table and `results.md`.

use std::fmt::Write as _;

use crate::interference::Interference;
use crate::schema::{Results, Run, RunStatus};

mod motion;
mod prediction;

pub use motion::{
    MOTION_COLUMNS, MOTION_SUMMARY_HEADING, motion_cells, motion_runs, motion_summary_markdown,
    pops_cell, scene_motion_markdown, scene_motion_terminal,
};
pub use prediction::{
    PREDICTION_COLUMN, prediction_cell, predictions_summary, scene_predictions_markdown,
    terminal_prediction,
};

/// What the columns of every table mean, once, for the top of results.md and report.html.
pub const COLUMNS: &[(&str, &str)] = &[
    (
        "GPU ms",
        "median GPU time of the timed frames (GPU timestamps; `wall` where the adapter has none); † timed while over 10 % of the machine's CPU time went elsewhere",
    ),
    (
        "cost × unsorted",
        "GPU ms over `unsorted`'s on the same scene in the same comparison",
    ),
    (
        "cost × floor",
        "GPU ms over the scene's floor: one pass blending every transparent fragment once with vertex colour only, after the same opaque pass. A reference pass, measured like a run, not a bound: below 1 (‡) a technique's frame took less than the floor's median frame, which happens within the floor's own frame-to-frame spread on small scenes and when a technique tests depth before shading (fewer fragments shaded)",
    ),
    (
        "bytes/px",
        "GPU memory the technique allocates beyond the shared targets and scene, per pixel",
    ),
    (
        "RMSE",
        "root mean square error against the exact CPU reference, linear RGB",
    ),
    (
        "max error",
        "largest absolute error of any channel of any pixel",
    ),
    (
        "FLIP",
        "mean ꟻLIP of the Reinhard-tone-mapped images; HDR marks HDR-FLIP (exposure-bracketed, ACES) on scenes whose reference exceeds 1. 0 is identical, 1 the largest difference",
    ),
    (
        "order dep.",
        "largest difference between the technique's image with the draws in order and with everything submitted in reverse (the draw list, and the triangles inside each draw). 0 only where reversing changed nothing",
    ),
    PREDICTION_COLUMN,
    (
        "inexact",
        "what the technique itself reports it cut or approximated (dropped layers, approximated tails, approximate transmission)",
    ),
];

/// `text` safe to print in a terminal or a table: control characters (which could move the
/// cursor, clear the screen or break a row) are shown as `\u{…}` escapes.
pub fn printable(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() {
            out.push_str(&c.escape_unicode().to_string());
        } else {
            out.push(c);
        }
    }
    out
}

/// [`printable`] for a markdown table cell: `|` escaped so it cannot end the cell.
pub fn md_cell(text: &str) -> String {
    printable(text).replace('|', "\\|")
}

/// Words of `text` in lines of at most `width` characters (a longer word gets a line alone).
pub fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

/// What a report says about where the timings came from when `results` is a shard
/// (`oit compare --shard K/N`) or a merge of shards (`oit merge`); `None` otherwise.
pub fn shard_note(results: &Results) -> Option<String> {
    if let Some(s) = &results.shard {
        return Some(format!(
            "shard {}/{} of a comparison of {} runs; `oit merge` joins the shards",
            s.index, s.count, s.runs
        ));
    }
    let first = results.merged.first()?;
    let mut adapters: Vec<String> = Vec::new();
    for s in &results.merged {
        if let Some(a) = &s.adapter
            && !adapters.contains(&a.name)
        {
            adapters.push(a.name.clone());
        }
    }
    let shards: Vec<String> = results.merged.iter().map(|s| s.index.to_string()).collect();
    let missing: Vec<String> = (1..=first.count)
        .filter(|k| !results.merged.iter().any(|s| s.index == *k))
        .map(|k| k.to_string())
        .collect();
    let mut note = format!(
        "merged from shards {} of {} (adapters: {}): each run was timed on its shard's machine against that shard's floor and `unsorted`, so GPU ms and cost ratios compare only within one shard (`shard` of each run in results.json), not across shards",
        shards.join(", "),
        first.count,
        printable(&adapters.join("; "))
    );
    if !missing.is_empty() {
        note.push_str(&format!(
            "; shards {} are missing, and their runs with them",
            missing.join(", ")
        ));
    }
    Some(note)
}

/// One row per run, grouped by scene, in run order.
pub fn markdown(results: &Results) -> String {
    let mut out = String::new();
    let a = &results.adapter;
    let _ = writeln!(out, "# oit-lab results\n");
    if !results.complete {
        let _ = writeln!(
            out,
            "**Incomplete:** the comparison was interrupted; `oit compare … --resume` with the same output folder finishes it.\n"
        );
    }
    if let Some(note) = shard_note(results) {
        let _ = writeln!(out, "**Shards:** {}.\n", md_cell(&note));
    }
    let _ = writeln!(
        out,
        "Adapter: **{}** ({}, {}, {}){}. Errors are against the exact CPU reference.\n",
        md_cell(&a.name),
        md_cell(&a.backend),
        md_cell(&a.device_type),
        md_cell(&a.driver),
        results
            .tool
            .as_ref()
            .map(|t| format!("; {} {} (build {})", t.name, t.version, t.build))
            .unwrap_or_default()
    );
    let _ = writeln!(out, "Columns:\n");
    for (name, meaning) in COLUMNS {
        let _ = writeln!(out, "- **{name}**: {meaning}.");
    }
    let _ = writeln!(out);
    if let Some(caveat) = overall_timing_caveat(results) {
        let _ = writeln!(out, "**Timing:** {caveat}.\n");
    }
    if let Some(line) = predictions_summary(results) {
        let _ = writeln!(out, "**Predictions:** {}.\n", md_cell(&line));
    }
    out.push_str(&summary_markdown(results));
    out.push_str(&matrix_markdown(
        results,
        "Mean FLIP per scene and technique (HDR-FLIP where the reference exceeds 1)",
        |r| r.error.map(|e| e.headline_flip().0),
    ));
    out.push_str(&matrix_markdown(
        results,
        "RMSE per scene and technique",
        |r| r.error.map(|e| e.rmse),
    ));
    out.push_str(&motion_summary_markdown(results));
    for (scene, runs) in by_scene(results) {
        let res = runs[0].resolution;
        let _ = writeln!(out, "## {} ({}x{})\n", md_cell(&scene), res[0], res[1]);
        if let Some(s) = results.scenes.iter().find(|s| s.scene == scene) {
            if !s.description.is_empty() {
                let _ = writeln!(out, "{}\n", md_cell(&s.description));
            }
            for line in s.report_lines() {
                let _ = writeln!(out, "{}.\n", md_cell(&line));
            }
        }
        for f in results.floors.iter().filter(|f| f.scene == scene) {
            let _ = writeln!(
                out,
                "Floor (opaque pass + one vertex-colour blended pass{}): {:.3} GPU ms (frames {:.3}–{:.3}).\n",
                format_note(f.target_format),
                f.gpu_ms.median,
                f.gpu_ms.min,
                f.gpu_ms.max
            );
        }
        for caveat in scene_caveats(&runs) {
            let _ = writeln!(out, "Reference: {caveat}.\n");
        }
        if let Some(caveat) = timing_caveat(results, &scene, &runs) {
            let _ = writeln!(out, "Timing: {caveat}.\n");
        }
        if let Some(note) = below_floor_note(results, &scene, &runs) {
            let _ = writeln!(out, "‡ {note}.\n");
        }
        let _ = writeln!(
            out,
            "| technique | GPU ms | cost × unsorted | cost × floor | bytes/px | RMSE | max error | FLIP | order dep. | predicted exact | inexact |"
        );
        let _ = writeln!(out, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|");
        for r in &runs {
            let cells: Vec<String> = row_cells(r).iter().map(|c| md_cell(c)).collect();
            let _ = writeln!(out, "| {} |", cells.join(" | "));
        }
        let _ = writeln!(out);
        out.push_str(&scene_predictions_markdown(&runs));
        out.push_str(&scene_motion_markdown(&runs));
    }
    out
}

/// The line under a scene whose runs cost less than its floor (marked ‡), with the floor's
/// own frame spread for scale; `None` when no run did.
pub fn below_floor_note(results: &Results, scene: &str, runs: &[&Run]) -> Option<String> {
    let below = runs
        .iter()
        .filter(|r| r.cost_vs_floor.is_some_and(|c| c < 1.0))
        .count();
    if below == 0 {
        return None;
    }
    let floor = results.floors.iter().find(|f| f.scene == scene)?;
    let g = &floor.gpu_ms;
    Some(format!(
        "{below} of {} runs cost less than the floor's median frame ({:.3} ms; its own frames took {:.3}–{:.3} ms, {:.2}–{:.2} × its median): the floor is a measured reference pass, not a bound",
        runs.len(),
        g.median,
        g.min,
        g.max,
        if g.median > 0.0 {
            g.min / g.median
        } else {
            0.0
        },
        if g.median > 0.0 {
            g.max / g.median
        } else {
            0.0
        },
    ))
}

/// Widest line [`terminal_table`] writes.
pub const TERMINAL_WIDTH: usize = 100;

/// Longest technique label in the terminal table; a longer one is cut (`…`) and given whole
/// in the row's note.
const LABEL_MAX: usize = 28;

/// Fixed-width table for the terminal: techniques by `label` (the harness drops parameters at
/// their defaults), numbers right-aligned, and everything long (skip reasons, what was
/// inexact) as numbered notes under the table, wrapped to [`TERMINAL_WIDTH`].
pub fn terminal_table_labelled(results: &Results, label: &dyn Fn(&str) -> String) -> String {
    const HEAD: [&str; 11] = [
        "technique",
        "GPU ms",
        "×unsort",
        "×floor",
        "B/px",
        "RMSE",
        "max err",
        "FLIP",
        "order",
        "pred",
        "note",
    ];
    let mut out = String::new();
    if !results.complete {
        let _ = writeln!(
            out,
            "\nincomplete: the comparison was interrupted; --resume finishes it"
        );
    }
    if let Some(note) = shard_note(results) {
        for line in wrap(&format!("shards: {note}"), TERMINAL_WIDTH) {
            let _ = writeln!(out, "{line}");
        }
    }
    if let Some(caveat) = overall_timing_caveat(results) {
        for line in wrap(&format!("timing: {caveat}"), TERMINAL_WIDTH) {
            let _ = writeln!(out, "{line}");
        }
    }
    if let Some(summary) = predictions_summary(results) {
        for line in wrap(&format!("predictions: {summary}"), TERMINAL_WIDTH) {
            let _ = writeln!(out, "{line}");
        }
    }
    let say = |out: &mut String, text: &str| {
        for (i, line) in wrap(&printable(text), TERMINAL_WIDTH - 4)
            .iter()
            .enumerate()
        {
            let indent = if i == 0 { "  " } else { "    " };
            let _ = writeln!(out, "{indent}{line}");
        }
    };
    for (scene, runs) in by_scene(results) {
        let mut notes: Vec<String> = Vec::new();
        let rows: Vec<Vec<String>> = runs
            .iter()
            .map(|r| {
                let mut cells = row_cells(r);
                cells[9] = terminal_prediction(r);
                let label = technique_cell(&label(&r.technique), r);
                let mut note_parts = Vec::new();
                cells[0] = if label.chars().count() > LABEL_MAX {
                    note_parts.push(label.clone());
                    let cut: String = label.chars().take(LABEL_MAX - 1).collect();
                    format!("{cut}…")
                } else {
                    label
                };
                let note = if r.status != RunStatus::Ok {
                    let text = std::mem::take(&mut cells[1]);
                    cells.iter_mut().skip(2).for_each(String::clear);
                    cells[1] = text.split(':').next().unwrap_or_default().to_owned();
                    Some(text)
                } else {
                    let text = std::mem::take(&mut cells[10]);
                    (!text.is_empty()).then_some(text)
                };
                note_parts.extend(note);
                if r.prediction
                    .as_ref()
                    .is_some_and(|p| p.agrees == Some(false))
                {
                    note_parts.push("prediction contradicted by the measurement".into());
                }
                if !note_parts.is_empty() {
                    notes.push(note_parts.join(": "));
                    cells[10] = format!("[{}]", notes.len());
                }
                cells
            })
            .collect();
        let mut widths: Vec<usize> = HEAD.iter().map(|h| h.chars().count()).collect();
        for row in &rows {
            for (w, cell) in widths.iter_mut().zip(row) {
                *w = (*w).max(cell.chars().count());
            }
        }
        let _ = writeln!(out, "\n{}", printable(&scene));
        if let Some(s) = results.scenes.iter().find(|s| s.scene == scene) {
            if !s.description.is_empty() {
                say(&mut out, &s.description);
            }
            for line in s.report_lines() {
                say(&mut out, &line);
            }
        }
        for caveat in scene_caveats(&runs) {
            say(&mut out, &format!("reference: {caveat}"));
        }
        if let Some(caveat) = timing_caveat(results, &scene, &runs) {
            say(&mut out, &format!("timing: {caveat}"));
        }
        if let Some(note) = below_floor_note(results, &scene, &runs) {
            say(&mut out, &format!("‡ {note}"));
        }
        let line = |cells: &[String]| {
            cells
                .iter()
                .zip(&widths)
                .enumerate()
                .map(|(i, (c, w))| {
                    let pad = w - c.chars().count();
                    // Names and notes read left to right; numbers align on the right.
                    if i == 0 || i == HEAD.len() - 1 {
                        format!("{c}{}", " ".repeat(pad))
                    } else {
                        format!("{}{c}", " ".repeat(pad))
                    }
                })
                .collect::<Vec<_>>()
                .join(" ")
                .trim_end()
                .to_owned()
        };
        let head: Vec<String> = HEAD.iter().map(|s| s.to_string()).collect();
        let _ = writeln!(out, "  {}", line(&head));
        for row in &rows {
            let _ = writeln!(out, "  {}", line(row));
        }
        for (i, note) in notes.iter().enumerate() {
            say(&mut out, &format!("[{}] {note}", i + 1));
        }
        out.push_str(&scene_motion_terminal(&runs, label));
    }
    out
}

/// Which of the scene's timings (runs marked †, and its floor) were taken while more than
/// [`NOTABLE`](crate::interference::NOTABLE) of the machine's CPU time went elsewhere, with
/// the worst share; or, when no window was long enough to judge alone, whether all of them
/// together were. None when neither.
pub fn timing_caveat(results: &Results, scene: &str, runs: &[&Run]) -> Option<String> {
    let noise = noise_caveat(results, scene, runs);
    let retimed = runs
        .iter()
        .filter(|r| r.gpu_ms.as_ref().is_some_and(|g| g.attempts > 1))
        .count();
    if retimed == 0 {
        return noise;
    }
    let again = format!(
        "{retimed} of {} runs timed again after a noisy window (`--retime`), the quietest attempt kept",
        runs.len()
    );
    Some(match noise {
        Some(noise) => format!("{noise}; {again}"),
        None => again,
    })
}

/// [`timing_caveat`] without the re-timed runs.
fn noise_caveat(results: &Results, scene: &str, runs: &[&Run]) -> Option<String> {
    let floor = results
        .floors
        .iter()
        .find(|f| f.scene == scene)
        .and_then(|f| f.gpu_ms.interference);
    let windows: Vec<Interference> = runs
        .iter()
        .filter_map(|r| r.gpu_ms.as_ref()?.interference)
        .collect();
    let marked: Vec<_> = windows.iter().filter(|i| i.notable()).collect();
    let marked_floor = floor.filter(|i| i.notable());
    let limit = 100.0 * crate::interference::NOTABLE;
    if let Some(worst) = marked
        .iter()
        .copied()
        .chain(&marked_floor)
        .max_by(|a, b| a.lost().total_cmp(&b.lost()))
    {
        return Some(format!(
            "{} of {} runs{} timed while over {limit:.0} % of the machine's CPU time went \
             elsewhere (†; worst {}): their times, and ratios to runs timed at quieter moments, \
             carry that noise",
            marked.len(),
            runs.len(),
            if marked_floor.is_some() {
                " and the floor"
            } else {
                ""
            },
            worst.describe()
        ));
    }
    let all = Interference::combine(windows.iter().copied().chain(floor))?;
    (all.notable() && !windows.iter().chain(&floor).any(|i| i.conclusive())).then(|| {
        format!(
            "the timed frames of this scene, each run too short to judge alone, together ran \
             while {:.0} % of the machine's CPU time went elsewhere ({}): its times carry that \
             noise",
            100.0 * all.lost(),
            all.describe()
        )
    })
}

/// The share of the machine's CPU time that went elsewhere over every timed frame of the
/// comparison, when it is over [`NOTABLE`](crate::interference::NOTABLE): a line for the
/// top of a report.
pub fn overall_timing_caveat(results: &Results) -> Option<String> {
    let windows = (results.runs.iter().filter_map(|r| r.gpu_ms.as_ref()))
        .chain(results.floors.iter().map(|f| &f.gpu_ms))
        .filter_map(|g| g.interference);
    let all = Interference::combine(windows).filter(Interference::notable)?;
    Some(format!(
        "over all timed frames ({:.1} CPU-seconds), {:.0} % of the machine's CPU time went \
         elsewhere ({}): absolute times are slower than this adapter can do, and ratios \
         between runs timed at different moments carry the difference",
        all.cpu_seconds,
        100.0 * all.lost(),
        all.describe()
    ))
}

/// The scene's reference caveats, from its first run that recorded them.
pub fn scene_caveats(runs: &[&Run]) -> Vec<String> {
    runs.iter()
        .find(|r| r.undecided_pixels.is_some())
        .map(|r| r.reference_caveats())
        .unwrap_or_default()
}

/// One row per technique over every scene it ran on: the answer to "which technique, for this
/// suite, at what cost?" before the per-scene detail.
pub fn summary_markdown(results: &Results) -> String {
    let mut techniques: Vec<(String, Vec<&Run>)> = Vec::new();
    for run in results.runs.iter().filter(|r| r.status == RunStatus::Ok) {
        let label = run.technique_label();
        match techniques.iter_mut().find(|(t, _)| *t == label) {
            Some((_, runs)) => runs.push(run),
            None => techniques.push((label, vec![run])),
        }
    }
    let mut out = String::new();
    let _ = writeln!(out, "## Summary over the suite\n");
    let _ = writeln!(
        out,
        "Per technique: scenes run, median of the per-scene cost × unsorted and cost × floor, \
         mean FLIP, mean RMSE, scenes within max error 4e-3 of the reference (\"exact\"), largest \
         order dependence, and scenes whose run was inexact by the technique's own account \
         (dropped layers: see the per-scene tables).\n"
    );
    let _ = writeln!(
        out,
        "| technique | scenes | median cost × unsorted | median cost × floor | mean FLIP | mean RMSE | exact scenes | max order dep. | inexact scenes |"
    );
    let _ = writeln!(out, "|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (technique, runs) in techniques {
        let median_cost = median_cell(runs.iter().filter_map(|r| r.cost_vs_unsorted).collect());
        let median_floor = median_cell(runs.iter().filter_map(|r| r.cost_vs_floor).collect());
        let errors: Vec<_> = runs.iter().filter_map(|r| r.error).collect();
        let n = errors.len().max(1) as f64;
        let flip = errors.iter().map(|e| e.headline_flip().0).sum::<f64>() / n;
        let rmse = errors.iter().map(|e| e.rmse).sum::<f64>() / n;
        let exact = errors
            .iter()
            .filter(|e| e.max_abs <= 4e-3 && e.nonfinite == 0)
            .count();
        let order = runs
            .iter()
            .filter_map(|r| r.order_dependence)
            .fold(0.0, f64::max);
        let _ = writeln!(
            out,
            "| {technique} | {} | {median_cost} | {median_floor} | {flip:.4} | {} | {exact} | {} | {} |",
            runs.len(),
            sci(rmse),
            sci(order),
            runs.iter().filter(|r| !r.inexact.is_empty()).count()
        );
    }
    let _ = writeln!(out);
    out
}

/// The median of `values` with two decimals, or `–` when there are none.
fn median_cell(mut values: Vec<f64>) -> String {
    values.sort_by(f64::total_cmp);
    match values.len() {
        0 => "–".to_owned(),
        n if n % 2 == 1 => format!("{:.2}", values[n / 2]),
        n => format!("{:.2}", 0.5 * (values[n / 2 - 1] + values[n / 2])),
    }
}

/// A scene × technique matrix of one number per ok run (e.g. mean FLIP), with a suite-mean
/// row: the shape in which a parameter sweep (say, WBOIT weights) is easiest to read.
pub fn matrix_markdown(
    results: &Results,
    title: &str,
    metric: impl Fn(&Run) -> Option<f64>,
) -> String {
    let mut techniques: Vec<String> = Vec::new();
    for run in &results.runs {
        let label = run.technique_label();
        if !techniques.contains(&label) {
            techniques.push(label);
        }
    }
    let mut out = String::new();
    let _ = writeln!(out, "## {title}\n");
    let labels = short_labels(&techniques.iter().map(String::as_str).collect::<Vec<_>>());
    if labels.iter().zip(&techniques).any(|(l, t)| l != t) {
        let _ = writeln!(
            out,
            "Columns name only the parameters that differ between columns.\n"
        );
    }
    let _ = writeln!(out, "| scene | {} |", labels.join(" | "));
    let _ = writeln!(out, "|---|{}", "---:|".repeat(techniques.len()));
    let mut sums = vec![(0.0, 0usize); techniques.len()];
    for (scene, runs) in by_scene(results) {
        let cells: Vec<String> = techniques
            .iter()
            .zip(&mut sums)
            .map(|(t, sum)| {
                let value = runs
                    .iter()
                    .find(|r| r.technique_label() == *t && r.status == RunStatus::Ok)
                    .and_then(|r| metric(r));
                match value {
                    Some(v) => {
                        sum.0 += v;
                        sum.1 += 1;
                        sci(v)
                    }
                    None => "–".to_owned(),
                }
            })
            .collect();
        let _ = writeln!(out, "| {} | {} |", md_cell(&scene), cells.join(" | "));
    }
    let means: Vec<String> = sums
        .iter()
        .map(|&(s, n)| {
            if n == 0 {
                "–".to_owned()
            } else {
                format!("**{}**", sci(s / n as f64))
            }
        })
        .collect();
    let _ = writeln!(out, "| **mean** | {} |\n", means.join(" | "));
    out
}

/// Column labels for canonical specs: `key=value` pairs shared by every column of the same
/// technique (when it has several columns) are dropped, so a weight sweep reads `weight=eq7`, not the whole spec. A column left
/// with nothing keeps its technique name. A target format (`sorted @ rgba8unorm`,
/// [`crate::technique_label`]) is kept whole after the shortened spec.
pub fn short_labels(labels: &[&str]) -> Vec<String> {
    let (specs, formats): (Vec<&str>, Vec<&str>) = labels
        .iter()
        .map(|l| match l.find(" @ ") {
            Some(i) => l.split_at(i),
            None => (*l, ""),
        })
        .unzip();
    short_spec_labels(&specs)
        .into_iter()
        .zip(formats)
        .map(|(spec, format)| format!("{spec}{format}"))
        .collect()
}

fn short_spec_labels(specs: &[&str]) -> Vec<String> {
    let split = |s: &str| -> (String, Vec<String>) {
        match s.split_once(':') {
            Some((n, p)) => (n.to_owned(), p.split(',').map(str::to_owned).collect()),
            None => (s.to_owned(), Vec::new()),
        }
    };
    let parsed: Vec<(String, Vec<String>)> = specs.iter().map(|s| split(s)).collect();
    let same_name = parsed.windows(2).all(|w| w[0].0 == w[1].0);
    parsed
        .iter()
        .map(|(name, params)| {
            let kept: Vec<&String> = params
                .iter()
                .filter(|p| {
                    let family = parsed.iter().filter(|(n, _)| n == name);
                    family.clone().count() < 2
                        || !family.clone().all(|(_, other)| other.contains(p))
                })
                .collect();
            let kept = kept
                .iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join(",");
            match (same_name && parsed.len() > 1, kept.is_empty()) {
                (_, true) => name.clone(),
                (true, false) => kept,
                (false, false) => format!("{name}:{kept}"),
            }
        })
        .collect()
}

fn by_scene(results: &Results) -> Vec<(String, Vec<&Run>)> {
    let mut groups: Vec<(String, Vec<&Run>)> = Vec::new();
    for run in &results.runs {
        match groups.iter_mut().find(|(s, _)| *s == run.scene) {
            Some((_, runs)) => runs.push(run),
            None => groups.push((run.scene.clone(), vec![run])),
        }
    }
    groups
}

fn row_cells(r: &Run) -> Vec<String> {
    if r.status != RunStatus::Ok {
        let status = if r.status == RunStatus::Skipped {
            "skipped"
        } else {
            "failed"
        };
        let mut cells = vec![
            r.technique_label(),
            format!("{status}: {}", r.reason.as_deref().unwrap_or("")),
        ];
        cells.resize(11, String::new());
        return cells;
    }
    let gpu = r
        .gpu_ms
        .as_ref()
        .map(|g| {
            let flag = if g.source == "timestamp" {
                ""
            } else {
                " (wall)"
            };
            let marked = if g.interference.is_some_and(|i| i.notable()) {
                "†"
            } else {
                ""
            };
            format!("{:.3}{flag}{marked}", g.median)
        })
        .unwrap_or_default();
    let ratio = |c: Option<f64>| c.map(|c| format!("{c:.2}")).unwrap_or_else(|| "–".into());
    let floor_ratio = |c: Option<f64>| match c {
        Some(c) if c < 1.0 => format!("{c:.2}‡"),
        other => ratio(other),
    };
    let bpp = r
        .bytes_per_pixel
        .map(|b| format!("{b:.1}"))
        .unwrap_or_default();
    let (rmse, max, flip) = match &r.error {
        Some(e) => (sci(e.rmse), sci(e.max_abs), flip_cell(e)),
        None => Default::default(),
    };
    let od = r.order_dependence.map(sci).unwrap_or_default();
    vec![
        technique_cell(&r.technique, r),
        gpu,
        ratio(r.cost_vs_unsorted),
        floor_ratio(r.cost_vs_floor),
        bpp,
        rmse,
        max,
        flip,
        od,
        prediction_cell(r),
        r.inexact.join("; "),
    ]
}

/// A run's technique as tables show it: with its target format when that is not the default
/// (`sorted @ rgba8unorm`), and with the sizes its `auto` parameters chose, when it has any
/// (`k-buffer:k=auto → k=5, slots 640.0 KiB`), and its one-time set-up when it has one, which
/// GPU ms leaves out (`ray-query:… (+ build 3.2 ms)`).
pub fn technique_cell(technique: &str, r: &Run) -> String {
    let technique = crate::technique_label(technique, r.target_format);
    let technique = match r.stats.as_ref().and_then(|s| s.auto_sizes) {
        Some(sizes) => format!("{technique} → {}", sizes.summary()),
        None => technique,
    };
    match r.stats.as_ref().and_then(|s| s.setup_ms) {
        Some(ms) => format!("{technique} (+ build {ms:.1} ms)"),
        None => technique,
    }
}

/// ` into a FORMAT target` for a floor timed at a format other than the default, else nothing.
fn format_note(format: crate::TargetFormat) -> String {
    if format.is_default() {
        String::new()
    } else {
        format!(", into a {} target", format.name())
    }
}

/// The FLIP a person should read for this run: LDR-FLIP of the tone-mapped images, or HDR-FLIP
/// (marked) when the reference is HDR.
pub fn flip_cell(e: &oit_metrics::Errors) -> String {
    match e.headline_flip() {
        (v, "HDR-FLIP") => format!("{v:.4} HDR"),
        (v, _) => format!("{v:.4}"),
    }
}

/// Compact scientific notation that keeps small errors readable (`3.1e-4`) and zero exact (`0`).
pub fn sci(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if !v.is_finite() {
        format!("{v}")
    } else if (1e-2..1e3).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.1e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::schema::{AdapterJson, Results, Run, RunStatus};

    fn run(scene: &str, technique: &str, cost: f64, max_abs: f64, flip: f64) -> Run {
        let mut r = Run::not_rendered(
            scene,
            "f.json",
            technique,
            [4, 4],
            RunStatus::Ok,
            String::new(),
        );
        r.reason = None;
        r.cost_vs_unsorted = Some(cost);
        r.cost_vs_floor = Some(cost * 2.0);
        r.order_dependence = Some(max_abs / 2.0);
        r.error = Some(oit_metrics::Errors {
            rmse: max_abs / 2.0,
            psnr: 0.0,
            mean_abs: 0.0,
            max_abs,
            over_1_255: 0.0,
            over_1_64: 0.0,
            flip_mean: flip,
            nonfinite: 0,
            ..Default::default()
        });
        r
    }

    /// Results of `runs` (and `floors`) on a made-up adapter.
    pub(crate) fn results_of(runs: Vec<Run>, floors: Vec<crate::schema::FloorJson>) -> Results {
        Results {
            schema: crate::schema::SCHEMA.into(),
            tool: None,
            complete: true,
            adapter: AdapterJson {
                name: "a".into(),
                backend: "b".into(),
                device_type: "c".into(),
                driver: "d".into(),
            },
            runs,
            floors,
            scenes: Vec::new(),
            shard: None,
            merged: Vec::new(),
        }
    }

    /// The sizes `auto` chose are beside the technique in results.md and the terminal table,
    /// and results.json keeps them (a file without them still reads).
    #[test]
    fn auto_sizes_are_shown_beside_the_technique_and_round_trip() {
        let mut sized = run("s1", "k-buffer:k=auto,tail=average", 1.0, 1e-3, 0.1);
        sized.stats = Some(crate::schema::Stats {
            auto_sizes: Some(crate::schema::AutoSizes {
                fragments: 70,
                max_per_pixel: 5,
                k: Some(5),
                sized_bytes: 640 << 10,
                count_bytes: 112,
                ..Default::default()
            }),
            ..Default::default()
        });
        let fixed = run("s1", "k-buffer:k=8,tail=average", 1.0, 1e-3, 0.1);
        let results = results_of(vec![sized.clone(), fixed], Vec::new());
        let md = markdown(&results);
        assert!(
            md.contains("| k-buffer:k=auto,tail=average → k=5, slots 640.0 KiB |"),
            "{md}"
        );
        assert!(md.contains("| k-buffer:k=8,tail=average |"), "{md}");
        let table = terminal_table_labelled(&results, &|t| t.to_owned());
        assert!(table.contains("k=5, slots 640.0 KiB"), "{table}");
        let json = serde_json::to_string(&sized).unwrap();
        assert!(json.contains("\"auto_sizes\":{\"fragments\":70,\"max_per_pixel\":5,\"k\":5,\"sized_bytes\":655360,\"count_bytes\":112}"), "{json}");
        let back: Run = serde_json::from_str(&json).unwrap();
        assert_eq!(back, sized);
        let older = json.replace(
            ",\"auto_sizes\":{\"fragments\":70,\"max_per_pixel\":5,\"k\":5,\"sized_bytes\":655360,\"count_bytes\":112}",
            "",
        );
        let back: Run = serde_json::from_str(&older).unwrap();
        assert_eq!(back.stats.and_then(|s| s.auto_sizes), None);
        let list = crate::schema::AutoSizes {
            pool_nodes: Some(1234),
            sort_max: Some(12),
            sized_bytes: 3 << 20,
            ..Default::default()
        };
        assert_eq!(list.summary(), "nodes=1234, sort-max=12, pool 3.0 MiB");
    }

    /// A one-time set-up (ray-query's acceleration-structure build) is shown beside the
    /// technique, since GPU ms leaves it out, and round-trips through results.json.
    #[test]
    fn setup_time_is_shown_beside_the_technique_and_round_trips() {
        let mut traced = run("s1", "ray-query:epsilon=0,k=8", 1.0, 1e-3, 0.1);
        traced.stats = Some(crate::schema::Stats {
            setup_ms: Some(3.25),
            ..Default::default()
        });
        let results = results_of(vec![traced.clone()], Vec::new());
        let md = markdown(&results);
        assert!(
            md.contains("| ray-query:epsilon=0,k=8 (+ build 3.2 ms) |"),
            "{md}"
        );
        let json = serde_json::to_string(&traced).unwrap();
        assert!(json.contains("\"setup_ms\":3.25"), "{json}");
        let back: Run = serde_json::from_str(&json).unwrap();
        assert_eq!(back, traced);
    }

    /// A run's target format round-trips through results.json; the default is never written
    /// (so files of default comparisons are as before the field existed) and a file without
    /// it reads as the default; an unknown format is refused naming the allowed ones. Tables
    /// show a run at another format as `TECHNIQUE @ FORMAT`, its own row, summary row and
    /// matrix column, and its floor says its format.
    #[test]
    fn target_format_round_trips_and_is_shown_beside_the_technique() {
        use crate::schema::TargetFormat;
        let half = run("s1", "stochastic:spp=4", 1.0, 1e-3, 0.1);
        let mut byte = run("s1", "stochastic:spp=4", 1.0, 4e-3, 0.2);
        byte.target_format = TargetFormat::Rgba8Unorm;
        let mut full = run("s1", "stochastic:spp=16", 1.0, 1e-3, 0.1);
        full.target_format = TargetFormat::Rgba32Float;
        let half_json = serde_json::to_string(&half).unwrap();
        assert!(!half_json.contains("target_format"), "{half_json}");
        for r in [&byte, &full] {
            let json = serde_json::to_string(r).unwrap();
            let name = r.target_format.name();
            assert!(
                json.contains(&format!("\"target_format\":\"{name}\"")),
                "{json}"
            );
            let back: Run = serde_json::from_str(&json).unwrap();
            assert_eq!(&back, r);
        }
        let explicit = half_json.replacen('{', "{\"target_format\":\"rgba16float\",", 1);
        let back: Run = serde_json::from_str(&explicit).unwrap();
        assert_eq!(back, half);
        let bad = half_json.replacen('{', "{\"target_format\":\"rgba8\",", 1);
        let err = serde_json::from_str::<Run>(&bad).unwrap_err().to_string();
        assert!(
            err.contains("rgba8unorm") && err.contains("rgba32float"),
            "{err}"
        );
        assert_eq!(
            TargetFormat::parse("RGBA8Unorm"),
            Ok(TargetFormat::Rgba8Unorm)
        );
        let err = TargetFormat::parse("rgb8").unwrap_err();
        assert!(
            err.contains("`rgb8`") && err.contains("allowed: rgba8unorm, rgba16float, rgba32float"),
            "{err}"
        );
        assert_eq!(TargetFormat::Rgba16Float.file_suffix(), "");
        assert_eq!(TargetFormat::Rgba8Unorm.file_suffix(), "@rgba8unorm");

        let floor = |format| crate::schema::FloorJson {
            scene: "s1".into(),
            resolution: [4, 4],
            gpu_ms: crate::schema::GpuMs {
                median: 1.0,
                min: 1.0,
                max: 1.0,
                frames: 1,
                source: "timestamp".into(),
                interference: None,
                attempts: 1,
            },
            passes: Vec::new(),
            shard: None,
            target_format: format,
        };
        let results = results_of(
            vec![half, byte, full],
            vec![
                floor(TargetFormat::Rgba16Float),
                floor(TargetFormat::Rgba8Unorm),
            ],
        );
        let md = markdown(&results);
        assert!(md.contains("| stochastic:spp=4 |"), "{md}");
        assert!(md.contains("| stochastic:spp=4 @ rgba8unorm |"), "{md}");
        assert!(md.contains("| stochastic:spp=16 @ rgba32float |"), "{md}");
        assert!(
            md.contains("blended pass, into a rgba8unorm target):"),
            "{md}"
        );
        let summary = summary_markdown(&results);
        assert_eq!(
            summary.matches("| stochastic:spp=4").count(),
            2,
            "{summary}"
        );
        let matrix = matrix_markdown(&results, "m", |r| r.error.map(|e| e.max_abs));
        assert!(
            matrix.contains("| scene | spp=4 | spp=4 @ rgba8unorm | spp=16 @ rgba32float |"),
            "{matrix}"
        );
        let table = terminal_table_labelled(&results, &|t| t.to_owned());
        assert!(table.contains("stochastic:spp=4 @ rgba8unorm"), "{table}");
    }

    #[test]
    fn summary_aggregates_per_technique_over_scenes() {
        let mut skipped = run("s3", "t", 9.0, 9.0, 9.0);
        skipped.status = RunStatus::Skipped;
        let results = results_of(
            vec![
                run("s1", "t", 1.0, 1e-3, 0.1),
                run("s2", "t", 3.0, 0.5, 0.3),
                run("s4", "t", 2.0, 4e-3, 0.2),
                skipped,
                run("s1", "u", 1.0, 0.2, 0.5),
            ],
            Vec::new(),
        );
        let text = summary_markdown(&results);
        // t: 3 ok scenes, median cost 2, mean FLIP 0.2, 2 exact (1e-3 and exactly 4e-3), max order 0.25.
        assert!(
            text.contains("| t | 3 | 2.00 | 4.00 | 0.2000 | 0.0842 | 2 | 0.2500 | 0 |"),
            "{text}"
        );
        assert!(
            text.contains("| u | 1 | 1.00 | 2.00 | 0.5000 | 0.1000 | 0 | 0.1000 | 0 |"),
            "{text}"
        );
    }

    #[test]
    fn matrix_has_one_cell_per_scene_and_technique_and_a_mean_row() {
        let results = results_of(
            vec![
                run("s1", "t", 1.0, 0.0, 0.25),
                run("s1", "u", 1.0, 0.0, 0.5),
                run("s2", "t", 1.0, 0.0, 0.75),
            ],
            Vec::new(),
        );
        let text = matrix_markdown(&results, "FLIP", |r| r.error.map(|e| e.flip_mean));
        assert!(text.contains("| scene | t | u |"), "{text}");
        assert!(text.contains("| s1 | 0.2500 | 0.5000 |"), "{text}");
        assert!(text.contains("| s2 | 0.7500 | – |"), "{text}");
        assert!(
            text.contains("| **mean** | **0.5000** | **0.5000** |"),
            "{text}"
        );
    }

    #[test]
    fn timings_taken_while_the_machine_was_busy_are_marked_where_people_look() {
        use crate::interference::Interference;
        use crate::schema::{FloorJson, GpuMs};
        let timed = |ms: f64, steal: f64| GpuMs {
            median: ms,
            min: ms,
            max: ms,
            frames: 3,
            source: "timestamp".into(),
            interference: Some(Interference {
                steal,
                other_processes: 0.02,
                cpu_seconds: 4.0,
            }),
            attempts: 1,
        };
        let mut quiet = run("s1", "t", 1.0, 0.0, 0.1);
        quiet.gpu_ms = Some(timed(2.0, 0.06));
        let mut busy = run("s1", "u", 1.0, 0.0, 0.1);
        busy.gpu_ms = Some(timed(3.0, 0.35));
        let mut elsewhere = run("s2", "t", 1.0, 0.0, 0.1);
        elsewhere.gpu_ms = Some(timed(2.0, 0.0));
        let results = results_of(
            vec![quiet, busy, elsewhere],
            vec![FloorJson {
                scene: "s1".into(),
                resolution: [4, 4],
                gpu_ms: timed(1.0, 0.5),
                passes: Vec::new(),
                shard: None,
                target_format: Default::default(),
            }],
        );
        let text = markdown(&results);
        assert!(text.contains("| u | 3.000† |"), "{text}");
        assert!(text.contains("| t | 2.000 |"), "{text}");
        assert!(
            text.contains(
                "Timing: 1 of 2 runs and the floor timed while over 10 % of the machine's CPU \
                 time went elsewhere (†; worst steal 50 %, other processes 2 %)"
            ),
            "{text}"
        );
        // The quiet scene says nothing; the top says what all of it amounted to.
        assert_eq!(text.matches("\nTiming:").count(), 1, "{text}");
        assert!(
            text.contains(
                "**Timing:** over all timed frames (16.0 CPU-seconds), 25 % of the machine's \
                 CPU time went elsewhere (steal 23 %, other processes 2 %)"
            ),
            "{text}"
        );
        let table = terminal_table_labelled(&results, &|t| t.to_owned());
        assert!(table.contains("3.000†"), "{table}");
        assert_eq!(table.matches("timing: 1 of 2 runs").count(), 1, "{table}");
        assert!(table.contains("timing: over all timed frames"), "{table}");
    }

    /// One timed window of 1 ms frames that lost `steal` of the CPU over `cpu_seconds`.
    fn timed_in_window(steal: f64, cpu_seconds: f64) -> crate::schema::GpuMs {
        crate::schema::GpuMs {
            median: 1.0,
            min: 1.0,
            max: 1.0,
            frames: 3,
            source: "timestamp".into(),
            interference: Some(crate::interference::Interference {
                steal,
                other_processes: 0.0,
                cpu_seconds,
            }),
            attempts: 1,
        }
    }

    /// Runs timed again (`--retime`) are counted in the scene's timing line, beside the noise
    /// caveat when the kept attempt was still noisy, on their own when it was quiet.
    #[test]
    fn retimed_runs_are_counted_where_people_look() {
        use crate::schema::GpuMs;
        let timed = |steal: f64, attempts: u32| GpuMs {
            attempts,
            ..timed_in_window(steal, 4.0)
        };
        let with = |steals: [(f64, u32); 2]| {
            let runs = ["t", "u"]
                .iter()
                .zip(steals)
                .map(|(t, (steal, attempts))| {
                    let mut r = run("s", t, 1.0, 0.0, 0.1);
                    r.gpu_ms = Some(timed(steal, attempts));
                    r
                })
                .collect();
            markdown(&results_of(runs, Vec::new()))
        };
        let quiet_after_retry = with([(0.02, 3), (0.01, 1)]);
        assert!(
            quiet_after_retry.contains(
                "Timing: 1 of 2 runs timed again after a noisy window (`--retime`), the quietest \
                 attempt kept"
            ),
            "{quiet_after_retry}"
        );
        let still_noisy = with([(0.3, 3), (0.01, 1)]);
        assert!(
            still_noisy.contains(
                "carry that noise; 1 of 2 runs timed again after a noisy window (`--retime`)"
            ),
            "{still_noisy}"
        );
        let never = with([(0.02, 1), (0.01, 1)]);
        assert!(!never.contains("Timing:"), "{never}");
    }

    #[test]
    fn short_runs_are_judged_together() {
        // Four runs of 0.1 CPU-seconds each: none can be judged alone.
        let timed = |steal: f64| timed_in_window(steal, 0.1);
        let runs = |steal: f64| -> Vec<Run> {
            ["t", "u", "v", "w"]
                .iter()
                .map(|t| {
                    let mut r = run("s", t, 1.0, 0.0, 0.1);
                    r.gpu_ms = Some(timed(steal));
                    r
                })
                .collect()
        };
        let busy = results_of(runs(0.3), Vec::new());
        let text = markdown(&busy);
        assert!(
            !text
                .lines()
                .filter(|l| l.starts_with("| "))
                .any(|l| l.contains('†')),
            "{text}"
        );
        assert!(
            text.contains(
                "Timing: the timed frames of this scene, each run too short to judge alone, \
                 together ran while 30 % of the machine's CPU time went elsewhere"
            ),
            "{text}"
        );
        let quiet = results_of(runs(0.05), Vec::new());
        assert!(!markdown(&quiet).contains("Timing"));
    }

    #[test]
    fn short_labels_keep_only_what_differs() {
        assert_eq!(
            short_labels(&[
                "wboit:accum=a,weight=eq7",
                "wboit:accum=a,weight=eq8",
                "weighted-average"
            ]),
            ["wboit:weight=eq7", "wboit:weight=eq8", "weighted-average"]
        );
        assert_eq!(
            short_labels(&["s:spp=1,x=y", "s:spp=4,x=y"]),
            ["spp=1", "spp=4"]
        );
        assert_eq!(
            short_labels(&["unsorted", "wboit:w=1"]),
            ["unsorted", "wboit:w=1"]
        );
        assert_eq!(short_labels(&["wboit:w=1"]), ["wboit:w=1"]);
    }

    #[test]
    fn sci_formats_small_large_and_zero() {
        assert_eq!(sci(0.0), "0");
        assert_eq!(sci(3.14159e-4), "3.1e-4");
        assert_eq!(sci(0.25), "0.2500");
        assert_eq!(sci(12345.0), "1.2e4");
    }

    /// A cost below the floor is marked and explained beside the floor's own spread, never
    /// left as an unexplained "impossible" number.
    #[test]
    fn costs_below_the_floor_are_marked_and_explained() {
        let mut cheap = run("s", "unsorted", 1.0, 1e-4, 0.0);
        cheap.cost_vs_floor = Some(0.8);
        let dear = run("s", "front-peel", 10.0, 1e-4, 0.0);
        let floor = crate::schema::FloorJson {
            scene: "s".into(),
            resolution: [4, 4],
            gpu_ms: crate::schema::GpuMs {
                median: 1.0,
                min: 0.6,
                max: 1.9,
                frames: 20,
                source: "timestamp".into(),
                interference: None,
                attempts: 1,
            },
            passes: Vec::new(),
            shard: None,
            target_format: Default::default(),
        };
        let results = results_of(vec![cheap, dear], vec![floor]);
        let md = markdown(&results);
        assert!(md.contains("| 0.80‡ |"), "{md}");
        assert!(
            md.contains("‡ 1 of 2 runs cost less than the floor's median frame (1.000 ms; its own frames took 0.600–1.900 ms, 0.60–1.90 × its median)"),
            "{md}"
        );
        assert!(terminal_table_labelled(&results, &|t| t.to_owned()).contains("0.80‡"));
        let none = results_of(vec![run("s", "front-peel", 10.0, 1e-4, 0.0)], Vec::new());
        assert!(!markdown(&none).contains("‡ "));
    }
}
