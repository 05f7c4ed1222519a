//! Human-readable summaries of a [`Results`]: the terminal table and `results.md`.

use std::fmt::Write as _;

use crate::results::{Results, Run, RunStatus};

/// One row per run, grouped by scene, in run order.
pub fn markdown(results: &Results) -> String {
    let mut out = String::new();
    let a = &results.adapter;
    let _ = writeln!(out, "# oit-lab results\n");
    let _ = writeln!(
        out,
        "Adapter: **{}** ({}, {}, {}). GPU ms are medians over the timed frames; \
         cost is relative to `unsorted` on the same scene in this run; errors are against the \
         exact CPU reference on linear RGB; order dep. is the largest difference between \
         draw order and reversed draw order.\n",
        a.name, a.backend, a.device_type, a.driver
    );
    for (scene, runs) in by_scene(results) {
        let res = runs[0].resolution;
        let _ = writeln!(out, "## {scene} ({}x{})\n", res[0], res[1]);
        let _ = writeln!(
            out,
            "| technique | GPU ms | cost × unsorted | bytes/px | RMSE | max error | FLIP | order dep. |"
        );
        let _ = writeln!(out, "|---|---:|---:|---:|---:|---:|---:|---:|");
        for r in runs {
            let cells = row_cells(r);
            let _ = writeln!(out, "| {} |", cells.join(" | "));
        }
        let _ = writeln!(out);
    }
    out
}

/// Fixed-width table for the terminal.
pub fn terminal_table(results: &Results) -> String {
    const HEAD: [&str; 8] = [
        "technique",
        "GPU ms",
        "× unsorted",
        "B/px",
        "RMSE",
        "max err",
        "FLIP",
        "order dep.",
    ];
    let mut out = String::new();
    for (scene, runs) in by_scene(results) {
        let rows: Vec<Vec<String>> = runs.iter().map(|r| row_cells(r)).collect();
        let mut widths: Vec<usize> = HEAD.iter().map(|h| h.chars().count()).collect();
        for row in &rows {
            for (w, cell) in widths.iter_mut().zip(row) {
                *w = (*w).max(cell.chars().count());
            }
        }
        let _ = writeln!(out, "\n{scene}");
        let line = |cells: &[String]| {
            cells
                .iter()
                .zip(&widths)
                .enumerate()
                .map(|(i, (c, w))| {
                    let pad = w - c.chars().count();
                    if i == 0 {
                        format!("{c}{}", " ".repeat(pad))
                    } else {
                        format!("{}{c}", " ".repeat(pad))
                    }
                })
                .collect::<Vec<_>>()
                .join("  ")
        };
        let head: Vec<String> = HEAD.iter().map(|s| s.to_string()).collect();
        let _ = writeln!(out, "  {}", line(&head));
        for row in &rows {
            let _ = writeln!(out, "  {}", line(row));
        }
    }
    out
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
            r.technique.clone(),
            format!("{status}: {}", r.reason.as_deref().unwrap_or("")),
        ];
        cells.resize(8, String::new());
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
            format!("{:.3}{flag}", g.median)
        })
        .unwrap_or_default();
    let cost = r
        .cost_vs_unsorted
        .map(|c| format!("{c:.2}"))
        .unwrap_or_else(|| "–".into());
    let bpp = r
        .bytes_per_pixel
        .map(|b| format!("{b:.1}"))
        .unwrap_or_default();
    let (rmse, max, flip) = match &r.error {
        Some(e) => (sci(e.rmse), sci(e.max_abs), format!("{:.4}", e.flip_mean)),
        None => Default::default(),
    };
    let od = r.order_dependence.map(sci).unwrap_or_default();
    vec![r.technique.clone(), gpu, cost, bpp, rmse, max, flip, od]
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

    #[test]
    fn sci_formats_small_large_and_zero() {
        assert_eq!(sci(0.0), "0");
        assert_eq!(sci(3.14159e-4), "3.1e-4");
        assert_eq!(sci(0.25), "0.2500");
        assert_eq!(sci(12345.0), "1.2e4");
    }
}
