//! `oit cost-model RESULTS.json`: fits GPU time per frame to each run's counts on the adapter
//! that timed them (`oit_results::cost_model`; docs/results-schema.md, "counts"), and prints
//! the coefficients, R² and the worst residuals.

use std::path::Path;

use anyhow::{Context as _, Result};
use oit_results::Results;
use oit_results::cost_model::{CostModel, Weighting, fit};

/// Reads `results`, fits the model, prints it; with `json`, also writes it there.
pub fn run(results: &Path, json: Option<&Path>, absolute: bool) -> Result<()> {
    let file = Results::read(results)?;
    let weighting = if absolute {
        Weighting::Absolute
    } else {
        Weighting::Relative
    };
    let model =
        fit(&file, weighting).with_context(|| format!("{}: no cost model", results.display()))?;
    print!("{}", table(&model));
    if let Some(out) = json {
        let text = serde_json::to_string_pretty(&model)?;
        oit_metrics::write_atomic_bytes(out, format!("{text}\n").as_bytes())
            .with_context(|| format!("writing {}", out.display()))?;
    }
    Ok(())
}

/// The model as text: coefficients, fit quality, worst runs, runs left out, the note.
pub fn table(model: &CostModel) -> String {
    let mut s = format!(
        "Cost model on {} over {} runs: time ≈ Σ coefficient × count (non-negative least squares, {} residuals)\n\n",
        model.adapter,
        model.runs,
        match model.weighting {
            Weighting::Relative => "relative",
            Weighting::Absolute => "absolute",
        }
    );
    s += &format!(
        "{:<18} {:>13} {:>14} {:>7}  unit\n",
        "term", "coefficient", "unconstrained", "share"
    );
    for c in &model.coefficients {
        s += &format!(
            "{:<18} {:>13.4e} {:>14.4e} {:>6.1}%  {}\n",
            c.term,
            c.value,
            c.unconstrained,
            100.0 * c.share,
            c.unit
        );
    }
    if !model.absent_terms.is_empty() {
        s += &format!(
            "not fitted (no run has any): {}\n",
            model.absent_terms.join(", ")
        );
    }
    s += &format!(
        "\nR² = {:.4} (unweighted); median |measured − predicted| / measured = {:.2}\n\nWorst residuals:\n",
        model.r_squared, model.median_relative_error
    );
    s += &format!(
        "{:<28} {:<44} {:>11} {:>11} {:>9}\n",
        "scene", "technique", "measured", "predicted", "ratio"
    );
    for r in &model.worst {
        s += &format!(
            "{:<28} {:<44} {:>8.3} ms {:>8.3} ms {:>9}\n",
            r.scene,
            r.technique,
            r.measured_ms,
            r.predicted_ms,
            if r.predicted_ms > 0.0 {
                format!("{:.2}×", r.measured_ms / r.predicted_ms)
            } else {
                "–".to_owned()
            }
        );
    }
    s += "\nPer technique, measured ÷ predicted (median, range):\n";
    for t in &model.by_technique {
        s += &format!(
            "  {:<18} {:>4} runs {:>7.2}  ({:.2}–{:.2})\n",
            t.technique, t.runs, t.median_ratio, t.min_ratio, t.max_ratio
        );
    }
    if !model.left_out.is_empty() {
        s += &format!("\n{} runs left out:\n", model.left_out.len());
        for l in &model.left_out {
            s += &format!("  {} × {}: {}\n", l.scene, l.technique, l.reason);
        }
    }
    s += &format!("\n{}\n", model.note);
    s
}
