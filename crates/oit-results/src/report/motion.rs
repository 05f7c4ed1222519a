//! The motion tables: per animated scene (a scene whose runs carry a `temporal` block), one row
//! per technique over its frames; and one row per technique over the suite's animated scenes.

use std::fmt::Write as _;

use super::{md_cell, printable, sci};
use crate::schema::{Results, Run, RunStatus, Temporal};

/// What the columns of the motion tables mean, for results.md and report.html.
pub const MOTION_COLUMNS: &[(&str, &str)] = &[
    (
        "flicker",
        "RMS over pixels, channels and consecutive frames of the change of the error image (display space, as ꟻLIP sees it): 0 for an error that stays put, however large",
    ),
    (
        "pop events",
        "frames whose mean change of the error image exceeds 4 × the run's median change and 1/1020 (a quarter of an 8-bit step over the whole image); the count, then the first frames",
    ),
    (
        "worst frame",
        "the frame with the largest headline ꟻLIP, and that ꟻLIP",
    ),
    (
        "mean FLIP",
        "the headline ꟻLIP averaged over the frames (HDR marks HDR-FLIP)",
    ),
    (
        "max order dep.",
        "the largest order dependence over the frames (max |forward − reversed submission|)",
    ),
    (
        "static bias / noise",
        "frame 0 rendered repeatedly at its camera with fresh per-frame noise: RMSE of the mean image, and RMS of the per-pixel standard deviation (display space); – when not measured",
    ),
    (
        "inexact frames",
        "frames whose image holds dropped or approximated layers by the technique's own count (k-buffer tails, peeling's last passes), of the frames rendered; – when none",
    ),
];

/// How many pop frames a cell names before `…`.
const POPS_SHOWN: usize = 5;

/// The ok runs of `runs` that carry a `temporal` block, in run order.
pub fn motion_runs<'a>(runs: &[&'a Run]) -> Vec<(&'a Run, &'a Temporal)> {
    runs.iter()
        .filter(|r| r.status == RunStatus::Ok)
        .filter_map(|r| Some((*r, r.temporal.as_ref()?)))
        .collect()
}

/// A headline ꟻLIP with `HDR` when it is HDR-FLIP, as [`super::flip_cell`] writes it.
fn flip_value(v: f64, flip_name: &str) -> String {
    if flip_name == "HDR-FLIP" {
        format!("{v:.4} HDR")
    } else {
        format!("{v:.4}")
    }
}

/// `N`, or `N (f1, f2, …)` naming the first `shown` pop frames.
pub fn pops_cell(pops: &[u32], shown: usize) -> String {
    if pops.is_empty() {
        return "0".to_owned();
    }
    let first: Vec<String> = pops.iter().take(shown).map(u32::to_string).collect();
    let more = if pops.len() > shown { ", …" } else { "" };
    format!("{} ({}{more})", pops.len(), first.join(", "))
}

/// The cells of one motion row: technique, flicker, pop events, worst frame, mean ꟻLIP, max
/// order dependence, static bias / noise. Pop frames are named up to `shown`.
pub fn motion_cells(run: &Run, t: &Temporal, shown: usize) -> [String; 8] {
    [
        run.technique_label(),
        sci(t.flicker),
        pops_cell(&t.pop_events, shown),
        format!(
            "{} ({})",
            t.worst_frame,
            flip_value(t.worst_flip, &t.flip_name)
        ),
        flip_value(t.mean_flip, &t.flip_name),
        sci(t.max_order_dependence),
        t.static_camera.as_ref().map_or_else(
            || "–".to_owned(),
            |s| format!("{} / {}", sci(s.bias_rmse), sci(s.noise_rms)),
        ),
        inexact_cell(t),
    ]
}

/// `N/M`: frames with dropped or approximated layers of the frames rendered; `–` when none.
fn inexact_cell(t: &Temporal) -> String {
    if t.inexact_frames.is_empty() {
        "–".to_owned()
    } else {
        format!("{}/{}", t.inexact_frames.len(), t.frames.len())
    }
}

/// The frame count of a scene's motion runs: `N`, or `N–M` when runs differ.
fn frame_span(rows: &[(&Run, &Temporal)]) -> String {
    let counts = rows.iter().map(|(_, t)| t.frames.len());
    let (lo, hi) = counts.fold((usize::MAX, 0), |(a, b), n| (a.min(n), b.max(n)));
    if lo == hi {
        lo.to_string()
    } else {
        format!("{lo}–{hi}")
    }
}

/// The `### Motion` section of one scene for results.md, or an empty string when none of its
/// runs has a `temporal` block (a still scene).
pub fn scene_motion_markdown(runs: &[&Run]) -> String {
    let rows = motion_runs(runs);
    if rows.is_empty() {
        return String::new();
    }
    let mut out = String::new();
    let _ = writeln!(out, "### Motion ({} frames)\n", frame_span(&rows));
    let _ = writeln!(
        out,
        "Each frame against the exact reference of that frame (columns: see Motion over the suite).\n"
    );
    let _ = writeln!(
        out,
        "| technique | flicker | pop events | worst frame (FLIP) | mean FLIP | max order dep. | static bias / noise | inexact frames |"
    );
    let _ = writeln!(out, "|---|---:|---|---:|---:|---:|---:|---:|");
    for (run, t) in rows {
        let cells: Vec<String> = motion_cells(run, t, POPS_SHOWN)
            .iter()
            .map(|c| md_cell(c))
            .collect();
        let _ = writeln!(out, "| {} |", cells.join(" | "));
    }
    let _ = writeln!(out);
    out
}

/// The motion table of one scene for the terminal, under its still table: numbers
/// right-aligned, techniques by `label` (cut at the still table's width), pop frames and
/// static bias / noise in numbered notes; an empty string for a still scene. Lines fit
/// [`TERMINAL_WIDTH`](super::TERMINAL_WIDTH).
pub fn scene_motion_terminal(runs: &[&Run], label: &dyn Fn(&str) -> String) -> String {
    const HEAD: [&str; 6] = [
        "technique",
        "flicker",
        "pops",
        "worst frame",
        "mean",
        "order",
    ];
    let rows = motion_runs(runs);
    if rows.is_empty() {
        return String::new();
    }
    let flip_name = rows[0].1.flip_name.as_str();
    let mut notes: Vec<String> = Vec::new();
    let mut table: Vec<Vec<String>> = vec![HEAD.iter().map(|h| (*h).to_owned()).collect()];
    for (run, t) in &rows {
        let name = printable(&crate::technique_label(
            &label(&run.technique),
            run.target_format,
        ));
        let mut parts = Vec::new();
        let shown = if name.chars().count() > super::LABEL_MAX {
            parts.push(name.clone());
            let cut: String = name.chars().take(super::LABEL_MAX - 1).collect();
            format!("{cut}…")
        } else {
            name
        };
        if !t.pop_events.is_empty() {
            parts.push(format!("pops at {}", pops_cell(&t.pop_events, 8)));
        }
        if !t.inexact_frames.is_empty() {
            parts.push(format!(
                "dropped or approximated layers on {} of {} frames",
                t.inexact_frames.len(),
                t.frames.len()
            ));
        }
        if let Some(s) = &t.static_camera {
            parts.push(format!(
                "static camera, {} frames: bias {}, noise {}",
                s.frames,
                sci(s.bias_rmse),
                sci(s.noise_rms)
            ));
        }
        let note = if parts.is_empty() {
            String::new()
        } else {
            notes.push(parts.join("; "));
            format!("[{}]", notes.len())
        };
        table.push(vec![
            shown,
            sci(t.flicker),
            t.pop_events.len().to_string(),
            format!("{} ({:.4})", t.worst_frame, t.worst_flip),
            format!("{:.4}", t.mean_flip),
            sci(t.max_order_dependence),
            note,
        ]);
    }
    table[0].push("note".to_owned());
    let mut widths = vec![0usize; table[0].len()];
    for row in &table {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let last = widths.len() - 1;
    let mut out = format!(
        "  motion over {} frames ({flip_name} per frame against each frame's reference):\n",
        frame_span(&rows)
    );
    for row in &table {
        let line: Vec<String> = row
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(i, (c, w))| {
                let pad = " ".repeat(w - c.chars().count());
                if i == 0 || i == last {
                    format!("{c}{pad}")
                } else {
                    format!("{pad}{c}")
                }
            })
            .collect();
        let _ = writeln!(out, "  {}", line.join(" ").trim_end());
    }
    for (i, note) in notes.iter().enumerate() {
        for (j, line) in super::wrap(&format!("[{}] {note}", i + 1), super::TERMINAL_WIDTH - 4)
            .iter()
            .enumerate()
        {
            let indent = if j == 0 { "  " } else { "    " };
            let _ = writeln!(out, "{indent}{line}");
        }
    }
    out
}

/// The heading of [`motion_summary_markdown`], which README markers name.
pub const MOTION_SUMMARY_HEADING: &str = "Motion over the suite";

/// One row per technique over the animated scenes it ran on: how many, the median flicker, the
/// pop events in all, and the largest worst-frame ꟻLIP. Always written (a README table quotes
/// it); without animated scenes its one row says so.
pub fn motion_summary_markdown(results: &Results) -> String {
    let mut techniques: Vec<(String, Vec<&Temporal>)> = Vec::new();
    for run in results.runs.iter().filter(|r| r.status == RunStatus::Ok) {
        let Some(t) = &run.temporal else { continue };
        let label = run.technique_label();
        match techniques.iter_mut().find(|(n, _)| *n == label) {
            Some((_, ts)) => ts.push(t),
            None => techniques.push((label, vec![t])),
        }
    }
    let mut out = String::new();
    let _ = writeln!(out, "## {MOTION_SUMMARY_HEADING}\n");
    if techniques.is_empty() {
        let _ = writeln!(
            out,
            "No animated scene in this comparison: no run has a `temporal` block.\n"
        );
    } else {
        let _ = writeln!(
            out,
            "Per technique over the animated scenes it ran on (runs with a `temporal` block): \
             the median flicker, the pop events in all, and the largest worst-frame FLIP (HDR \
             marks HDR-FLIP). Columns of the motion tables:\n"
        );
        for (name, meaning) in MOTION_COLUMNS {
            let _ = writeln!(out, "- **{name}**: {meaning}.");
        }
        let _ = writeln!(out);
    }
    let _ = writeln!(
        out,
        "| technique | motion scenes | median flicker | pop events | worst frame FLIP |"
    );
    let _ = writeln!(out, "|---|---:|---:|---:|---:|");
    if techniques.is_empty() {
        let _ = writeln!(out, "| – (no animated scene) | 0 | – | – | – |");
    }
    for (technique, ts) in techniques {
        let mut flicker: Vec<f64> = ts.iter().map(|t| t.flicker).collect();
        flicker.sort_by(f64::total_cmp);
        let n = flicker.len();
        let median = if n % 2 == 1 {
            flicker[n / 2]
        } else {
            0.5 * (flicker[n / 2 - 1] + flicker[n / 2])
        };
        let pops: usize = ts.iter().map(|t| t.pop_events.len()).sum();
        let worst = ts
            .iter()
            .max_by(|a, b| a.worst_flip.total_cmp(&b.worst_flip))
            .map_or_else(
                || "–".to_owned(),
                |t| flip_value(t.worst_flip, &t.flip_name),
            );
        let _ = writeln!(
            out,
            "| {} | {} | {} | {pops} | {} |",
            md_cell(&technique),
            ts.len(),
            sci(median),
            md_cell(&worst)
        );
    }
    let _ = writeln!(out);
    out
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::schema::StaticCamera;

    /// A temporal block over `frames` frames with the given per-frame ꟻLIP.
    pub(crate) fn temporal(flip: &[f64], flicker: f64, pops: &[u32]) -> Temporal {
        let n = flip.len();
        let worst_flip = flip.iter().copied().fold(0.0, f64::max);
        let worst = flip.iter().position(|&f| f == worst_flip).unwrap_or(0);
        Temporal {
            frames: (0..n as u32).collect(),
            rmse: flip.iter().map(|f| f / 2.0).collect(),
            flip: flip.to_vec(),
            flip_name: "LDR-FLIP".into(),
            max_abs: flip.to_vec(),
            change: vec![0.0; n.saturating_sub(1)],
            flicker,
            pop_events: pops.to_vec(),
            pop_multiple: 4.0,
            pop_floor: 1.0 / 1020.0,
            worst_frame: worst as u32,
            worst_flip,
            mean_flip: flip.iter().sum::<f64>() / n.max(1) as f64,
            mean_rmse: 0.0,
            max_order_dependence: 0.125,
            inexact_frames: Vec::new(),
            static_camera: None,
        }
    }

    fn ok(scene: &str, technique: &str, t: Option<Temporal>) -> Run {
        let mut r = Run::not_rendered(
            scene,
            "f.json",
            technique,
            [4, 4],
            RunStatus::Ok,
            String::new(),
        );
        r.reason = None;
        r.temporal = t;
        r
    }

    #[test]
    fn pop_cells_name_the_first_frames() {
        assert_eq!(pops_cell(&[], 5), "0");
        assert_eq!(pops_cell(&[3, 9], 5), "2 (3, 9)");
        assert_eq!(pops_cell(&[1, 2, 3, 4, 5, 6, 7], 3), "7 (1, 2, 3, …)");
    }

    #[test]
    fn a_still_scene_has_no_motion_section() {
        let still = ok("s", "t", None);
        assert_eq!(scene_motion_markdown(&[&still]), "");
    }

    #[test]
    fn a_motion_row_has_every_column_escaped() {
        let mut t = temporal(&[0.0, 0.25, 0.5, 0.125], 0.03, &[2]);
        t.static_camera = Some(StaticCamera {
            frames: 8,
            bias_rmse: 1.5e-3,
            noise_rms: 0.25,
            mse: 0.0625,
            history_rmse: vec![0.25; 8],
            history_blend: 0.1,
            mean_rmse: vec![0.25; 8],
        });
        t.inexact_frames = vec![1, 3];
        let with = ok("m", "a|b", Some(t));
        let without = ok("m", "plain", Some(temporal(&[0.0; 3], 0.0, &[])));
        let text = scene_motion_markdown(&[&with, &without]);
        assert!(text.starts_with("### Motion (3–4 frames)\n"), "{text}");
        assert!(
            text.contains(
                "| a\\|b | 0.0300 | 1 (2) | 2 (0.5000) | 0.2188 | 0.1250 | 1.5e-3 / 0.2500 | 2/4 |"
            ),
            "{text}"
        );
        assert!(
            text.contains("| plain | 0 | 0 | 0 (0.0000) | 0.0000 | 0.1250 | – | – |"),
            "{text}"
        );
        // The terminal says it under the table.
        let terminal = scene_motion_terminal(&[&with, &without], &|t| t.to_owned());
        assert!(
            terminal.contains("dropped or approximated layers on 2 of 4 frames"),
            "{terminal}"
        );
    }

    #[test]
    fn the_suite_summary_takes_median_flicker_total_pops_and_worst_frame() {
        let mut hdr = temporal(&[0.1, 0.9], 0.5, &[1]);
        hdr.flip_name = "HDR-FLIP".into();
        let results = super::super::tests::results_of(
            vec![
                ok("m1", "t", Some(temporal(&[0.1, 0.2], 0.01, &[1]))),
                ok("m2", "t", Some(temporal(&[0.3, 0.1, 0.1], 0.03, &[1, 2]))),
                ok("m3", "t", Some(hdr)),
                ok("still", "t", None),
                ok("m1", "u", Some(temporal(&[0.0, 0.0], 0.0, &[]))),
            ],
            Vec::new(),
        );
        let text = motion_summary_markdown(&results);
        assert!(
            text.contains("| t | 3 | 0.0300 | 4 | 0.9000 HDR |"),
            "{text}"
        );
        assert!(text.contains("| u | 1 | 0 | 0 | 0.0000 |"), "{text}");
        assert!(!text.contains("no animated scene"), "{text}");
        assert!(
            text.contains("- **flicker**: RMS"),
            "the columns explained: {text}"
        );
        let none = super::super::tests::results_of(vec![ok("still", "t", None)], Vec::new());
        let none = motion_summary_markdown(&none);
        assert!(
            none.contains("| – (no animated scene) | 0 | – | – | – |"),
            "{none}"
        );
        assert!(!none.contains("- **flicker**"), "{none}");
    }

    #[test]
    fn the_terminal_motion_table_fits_and_notes_pops_and_long_names() {
        let long = format!("stochastic:{}", "spp=64,".repeat(12));
        let pops: Vec<u32> = (101..120).collect();
        let mut t = temporal(&[0.0, 0.5, 0.25], 0.02, &pops);
        t.static_camera = Some(StaticCamera {
            frames: 16,
            bias_rmse: 0.0,
            noise_rms: 0.125,
            mse: 0.015625,
            history_rmse: Vec::new(),
            history_blend: 0.1,
            mean_rmse: Vec::new(),
        });
        let run = ok("m", &long, Some(t));
        let exact = ok("m", "front-peel", Some(temporal(&[0.0; 3], 0.0, &[])));
        let text = scene_motion_terminal(&[&run, &exact], &|t| t.to_owned());
        for line in text.lines() {
            assert!(
                line.chars().count() <= crate::report::TERMINAL_WIDTH,
                "{line}"
            );
        }
        assert!(
            text.starts_with("  motion over 3 frames (LDR-FLIP per frame"),
            "{text}"
        );
        assert!(
            text.contains("0.0200   19  1 (0.5000) 0.2500 0.1250 [1]"),
            "{text}"
        );
        let words = text.split_whitespace().collect::<Vec<_>>().join(" ");
        assert!(words.contains("[1] stochastic:spp=64,"), "{text}");
        assert!(
            words.contains("pops at 19 (101, 102, 103, 104, 105, 106, 107, 108, …); static camera, 16 frames: bias 0, noise 0.1250"),
            "{text}"
        );
        assert!(text.contains("  front-peel "), "{text}");
        assert!(!text.contains("[2]"), "an exact run needs no note: {text}");
    }

    #[test]
    fn reports_show_motion_only_for_animated_scenes() {
        let results = super::super::tests::results_of(
            vec![
                ok("still", "t", None),
                ok("moving", "t", Some(temporal(&[0.1, 0.2], 0.01, &[]))),
            ],
            Vec::new(),
        );
        let md = crate::report::markdown(&results);
        assert_eq!(md.matches("### Motion").count(), 1, "{md}");
        let moving = md.find("## moving").unwrap();
        assert!(md.find("### Motion (2 frames)").unwrap() > moving, "{md}");
        assert_eq!(md.matches("## Motion over the suite").count(), 1);
        let table = crate::report::terminal_table_labelled(&results, &|t| t.to_owned());
        assert_eq!(table.matches("motion over 2 frames").count(), 1, "{table}");
        assert!(
            table.find("motion over").unwrap() > table.find("\nmoving").unwrap(),
            "{table}"
        );
    }
}
