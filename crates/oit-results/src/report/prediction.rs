//! Each run's predicted exactness where people look: a table column, the reason under each
//! scene's table, and one line over the comparison that counts agreements.

use std::fmt::Write as _;

use crate::schema::{PredictionRecord, Results, Run};

/// The column's heading and meaning (results.md, report.html).
pub const PREDICTION_COLUMN: (&str, &str) = (
    "predicted exact",
    "whether the technique's model of a pixel, run on the reference's per-pixel lists, predicted an exact run (yes), an inexact one (no), one within rounding of the 4e-3 bound (borderline), or none (unmodelled: stochastic noise); ✗ marks a prediction the measured error contradicts (docs/predictions.md)",
);

fn word(p: &PredictionRecord) -> &'static str {
    match p.verdict.as_str() {
        "exact" => "yes",
        "inexact" => "no",
        "borderline" => "borderline",
        _ => "unmodelled",
    }
}

/// The table cell of `run`'s prediction; empty without one.
pub fn prediction_cell(run: &Run) -> String {
    match &run.prediction {
        Some(p) if p.agrees == Some(false) => format!("{} ✗", word(p)),
        Some(p) => word(p).to_string(),
        None => String::new(),
    }
}

/// The terminal table's narrow cell: yes, no, ~ (borderline) or – (unmodelled); a
/// contradiction is a numbered note instead.
pub fn terminal_prediction(run: &Run) -> String {
    match run.prediction.as_ref().map(|p| p.verdict.as_str()) {
        Some("exact") => "yes",
        Some("inexact") => "no",
        Some("borderline") => "~",
        Some(_) => "–",
        None => "",
    }
    .to_string()
}

/// The reasons under a scene's table, one line per run with a prediction.
pub fn scene_predictions_markdown(runs: &[&Run]) -> String {
    let mut out = String::new();
    let with: Vec<(&Run, &PredictionRecord)> = runs
        .iter()
        .filter_map(|r| r.prediction.as_ref().map(|p| (*r, p)))
        .collect();
    if with.is_empty() {
        return out;
    }
    let _ = writeln!(out, "Predicted exact:\n");
    for (run, p) in with {
        let measured = run
            .error
            .map(|e| format!("; measured {}", crate::report::sci(e.max_relative)))
            .unwrap_or_default();
        let model = p
            .modelled_error
            .map(|m| format!(" (model {}{measured})", crate::report::sci(m)))
            .unwrap_or_default();
        let mark = if p.agrees == Some(false) {
            " **✗ contradicted by the measurement**"
        } else {
            ""
        };
        let _ = writeln!(
            out,
            "- `{}`: {}, because {}{model}{mark}",
            crate::report::md_cell(&run.technique_label()),
            word(p),
            crate::report::md_cell(&p.because)
        );
    }
    let _ = writeln!(out);
    out
}

/// Counts of the comparison's predictions, or `None` when it made none.
pub fn predictions_summary(results: &Results) -> Option<String> {
    let all: Vec<(&Run, &PredictionRecord)> = results
        .runs
        .iter()
        .filter_map(|r| r.prediction.as_ref().map(|p| (r, p)))
        .collect();
    if all.is_empty() {
        return None;
    }
    let count = |f: &dyn Fn(&PredictionRecord) -> bool| all.iter().filter(|(_, p)| f(p)).count();
    let agree = count(&|p| p.agrees == Some(true));
    let wrong: Vec<String> = all
        .iter()
        .filter(|(_, p)| p.agrees == Some(false))
        .map(|(r, _)| format!("{} on {}", r.technique_label(), r.scene))
        .collect();
    let borderline = count(&|p| p.verdict == "borderline");
    let unmodelled = count(&|p| p.verdict == "unmodelled");
    let mut line = format!(
        "{} runs predicted: {agree} agree with the measurement, {} contradicted, {borderline} borderline, {unmodelled} unmodelled",
        all.len(),
        wrong.len()
    );
    if !wrong.is_empty() {
        let _ = write!(line, " (contradicted: {})", wrong.join(", "));
    }
    Some(line)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schema::RunStatus;

    fn run(technique: &str, verdict: &str, agrees: Option<bool>, measured: f64) -> Run {
        let mut r = Run::not_rendered(
            "s",
            "s.json",
            technique,
            [4, 4],
            RunStatus::Ok,
            String::new(),
        );
        r.reason = None;
        r.error = Some(oit_metrics::Errors {
            max_relative: measured,
            ..Default::default()
        });
        r.prediction = Some(PredictionRecord {
            verdict: verdict.into(),
            because: format!("{technique} because"),
            modelled_error: Some(measured),
            agrees,
        });
        r
    }

    /// A contradicted prediction is marked in the cell, under the table, in the terminal
    /// notes and in the comparison's count; agreeing ones are counted as such.
    #[test]
    fn contradicted_predictions_are_marked_everywhere() {
        let runs = vec![
            run("good", "exact", Some(true), 1e-4),
            run("bad", "exact", Some(false), 0.2),
            run("edge", "borderline", None, 5e-3),
            run("noise", "unmodelled", None, 0.3),
        ];
        assert_eq!(prediction_cell(&runs[0]), "yes");
        assert_eq!(prediction_cell(&runs[1]), "yes ✗");
        assert_eq!(prediction_cell(&runs[2]), "borderline");
        let refs: Vec<&Run> = runs.iter().collect();
        let md = scene_predictions_markdown(&refs);
        assert!(md.contains("- `bad`: yes, because bad because"), "{md}");
        assert!(md.contains("contradicted by the measurement"), "{md}");
        assert_eq!(md.matches("contradicted").count(), 1, "{md}");
        let results = crate::report::tests::results_of(runs, Vec::new());
        let summary = predictions_summary(&results).expect("predictions");
        assert!(
            summary.starts_with("4 runs predicted: 1 agree with the measurement, 1 contradicted, 1 borderline, 1 unmodelled"),
            "{summary}"
        );
        assert!(summary.contains("bad on s"), "{summary}");
        let table = crate::report::terminal_table_labelled(&results, &|t| t.to_string());
        assert!(
            table.contains("prediction contradicted by the measurement"),
            "{table}"
        );
        let markdown = crate::report::markdown(&results);
        assert!(
            markdown.contains("**Predictions:** 4 runs predicted"),
            "{markdown}"
        );
    }

    #[test]
    fn no_predictions_no_summary() {
        let mut r = run("x", "exact", Some(true), 0.0);
        r.prediction = None;
        let results = crate::report::tests::results_of(vec![r], Vec::new());
        assert_eq!(predictions_summary(&results), None);
        assert!(!crate::report::markdown(&results).contains("Predicted exact"));
    }
}
