//! The answer to "which configuration is the cheapest one good enough for my content?": from a
//! `results.json`, per scene the cheapest configuration within an error budget, the Pareto
//! front, and why each cheaper configuration fails; over several scenes, the one configuration
//! within budget on all of them. Definitions: docs/recommend.md. `oit recommend` prints it.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use oit_results::{AdapterJson, Results, Run, RunStatus};
use serde::Serialize;

use crate::pareto::pareto_front;

/// The schema string of `oit recommend --json`.
pub const SCHEMA: &str = "oit-lab/recommend/v1";

/// Default relative cost band inside which two configurations count as equally cheap: frame
/// times on a CPU adapter move by this much between comparisons.
pub const DEFAULT_TIE: f64 = 0.10;

/// What "good enough" and "affordable" mean for one recommendation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Budget {
    /// Bound on the run's headline ꟻLIP (`Errors::headline_flip`: HDR-ꟻLIP on a scene whose
    /// reference exceeds 1, LDR-ꟻLIP otherwise).
    pub max_flip: Option<f64>,
    /// Bound on the largest absolute linear RGB channel error (`error.max_abs`).
    pub max_error: Option<f64>,
    /// Bound on cost × floor (`cost_vs_floor`).
    pub max_cost: Option<f64>,
    /// Relative cost band of a tie: costs within a factor `1 + tie` of the cheapest passing
    /// one are equally cheap, and the most accurate of them is recommended.
    pub tie: f64,
}

impl Budget {
    /// Refuses budgets that select nothing meaningful, naming the flag and what is allowed.
    pub fn validate(&self) -> Result<(), String> {
        if self.max_flip.is_none() && self.max_error.is_none() {
            return Err("give an error budget: --max-flip X and/or --max-error X".into());
        }
        if let Some(f) = self.max_flip
            && !(f.is_finite() && (0.0..=1.0).contains(&f))
        {
            return Err(format!(
                "--max-flip {f} is outside 0..=1 (ꟻLIP is a mean in [0, 1])"
            ));
        }
        if let Some(e) = self.max_error
            && !(e.is_finite() && e >= 0.0)
        {
            return Err(format!(
                "--max-error {e} must be a finite number ≥ 0 (linear RGB)"
            ));
        }
        if let Some(c) = self.max_cost
            && !(c.is_finite() && c > 0.0)
        {
            return Err(format!(
                "--max-cost {c} must be a finite number > 0 (cost × floor)"
            ));
        }
        if !(self.tie.is_finite() && (0.0..=1.0).contains(&self.tie)) {
            return Err(format!(
                "--tie {} is outside 0..=1 (a relative cost band, 0.1 = 10 %)",
                self.tie
            ));
        }
        Ok(())
    }

    /// The error the Pareto front and tie-breaks use: ꟻLIP when bounded, else max error.
    pub fn primary(&self) -> ErrorAxis {
        if self.max_flip.is_some() {
            ErrorAxis::Flip
        } else {
            ErrorAxis::MaxError
        }
    }

    /// One line saying the budget, e.g. `ꟻLIP ≤ 0.01, cost × floor ≤ 5`.
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        if let Some(f) = self.max_flip {
            parts.push(format!("FLIP ≤ {f}"));
        }
        if let Some(e) = self.max_error {
            parts.push(format!("max error ≤ {e}"));
        }
        if let Some(c) = self.max_cost {
            parts.push(format!("cost × floor ≤ {c}"));
        }
        parts.join(", ")
    }
}

/// Which error orders the front and breaks ties.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ErrorAxis {
    Flip,
    MaxError,
}

/// One configuration on one scene, as measured, and whether it meets the budget.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measured {
    /// Canonical spec.
    pub technique: String,
    /// `ok`, `skipped`, `failed`, or `missing` (no run of it in the results).
    pub status: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cost_vs_floor: Option<f64>,
    /// Headline ꟻLIP; on an animated scene the largest over frame 0 and the measured frames.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flip: Option<f64>,
    /// `LDR-FLIP` or `HDR-FLIP`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flip_name: Option<String>,
    /// Largest absolute linear RGB channel error (the largest over frames when animated).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_error: Option<f64>,
    /// The technique's own account of what it cut (`dropped layers on N px`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub inexact: Vec<String>,
    pub meets: bool,
    /// Why it does not meet the budget (empty when it does).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub fails: Vec<String>,
}

impl Measured {
    fn of(technique: &str, run: Option<&Run>, budget: &Budget) -> Self {
        let mut m = Measured {
            technique: technique.to_owned(),
            status: "missing".into(),
            cost_vs_floor: None,
            flip: None,
            flip_name: None,
            max_error: None,
            inexact: Vec::new(),
            meets: false,
            fails: Vec::new(),
        };
        let Some(run) = run else {
            m.fails.push("not measured: no run in the results".into());
            return m;
        };
        m.inexact = run.inexact.clone();
        match run.status {
            RunStatus::Skipped => {
                m.status = "skipped".into();
                m.fails.push(format!(
                    "skipped: {}",
                    run.reason.as_deref().unwrap_or("no reason given")
                ));
                return m;
            }
            RunStatus::Failed => {
                m.status = "failed".into();
                m.fails.push(format!(
                    "failed: {}",
                    run.reason.as_deref().unwrap_or("no reason given")
                ));
                return m;
            }
            RunStatus::Ok => m.status = "ok".into(),
        }
        m.cost_vs_floor = run.cost_vs_floor.filter(|c| c.is_finite());
        let Some(e) = run.error else {
            m.fails.push("no error measured".into());
            return m;
        };
        let (mut flip, name) = e.headline_flip();
        let mut max_error = e.max_abs;
        if let Some(t) = &run.temporal {
            flip = flip.max(t.worst_flip);
            max_error = t.max_abs.iter().copied().fold(max_error, f64::max);
        }
        m.flip = Some(flip);
        m.flip_name = Some(name.to_owned());
        m.max_error = Some(max_error);
        if e.nonfinite > 0 {
            m.fails.push(format!("{} non-finite pixels", e.nonfinite));
        }
        if let Some(b) = budget.max_flip
            && !within(flip, b)
        {
            m.fails.push(format!("{name} {} > {b}", num(flip)));
        }
        if let Some(b) = budget.max_error
            && !within(max_error, b)
        {
            m.fails.push(format!("max error {} > {b}", num(max_error)));
        }
        match (m.cost_vs_floor, budget.max_cost) {
            (None, _) => m
                .fails
                .push("no cost × floor (the results hold no floor for this scene)".into()),
            (Some(c), Some(cap)) if c > cap => m
                .fails
                .push(format!("cost × floor {c:.2} > {cap} (--max-cost)")),
            _ => {}
        }
        // Why the scene defeats it, from its prediction (docs/predictions.md), after the numbers.
        if !m.fails.is_empty()
            && let Some(p) = &run.prediction
            && p.verdict == "inexact"
        {
            m.fails.push(format!("predicted inexact: {}", p.because));
        }
        m.meets = m.fails.is_empty();
        m
    }

    /// The value on `axis` (`None` without a measured error).
    pub fn error(&self, axis: ErrorAxis) -> Option<f64> {
        match axis {
            ErrorAxis::Flip => self.flip,
            ErrorAxis::MaxError => self.max_error,
        }
    }

    /// How far over the budget the run is: the largest of value / bound over the bounds given
    /// (≤ 1 within budget). Orders the closest miss when nothing meets.
    fn excess(&self, budget: &Budget) -> f64 {
        let ratio = |v: Option<f64>, b: Option<f64>| match (v, b) {
            (Some(v), Some(b)) if b > 0.0 => v / b,
            (Some(v), Some(_)) if v <= 0.0 => 0.0,
            (Some(_), Some(_)) | (None, Some(_)) => f64::INFINITY,
            (_, None) => 0.0,
        };
        [
            ratio(self.flip, budget.max_flip),
            ratio(self.max_error, budget.max_error),
            ratio(self.cost_vs_floor, budget.max_cost),
        ]
        .into_iter()
        .fold(0.0, f64::max)
    }
}

/// One scene's answer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneAnswer {
    pub scene: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resolution: Option<[u32; 2]>,
    /// The cheapest configuration within budget (the most accurate of those tied with it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recommended: Option<String>,
    /// Other configurations within budget whose cost ties with the cheapest one.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub tied: Vec<String>,
    /// When nothing meets the budget: the run nearest to it (smallest excess over a bound).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub closest: Option<String>,
    /// The Pareto front of cost × floor against the primary error, cheapest first.
    pub front: Vec<String>,
    /// Every candidate, ranked by cost × floor (unranked ones last, in candidate order).
    pub candidates: Vec<Measured>,
}

impl SceneAnswer {
    fn find(&self, technique: &str) -> Option<&Measured> {
        self.candidates.iter().find(|m| m.technique == technique)
    }

    /// Candidates cheaper than the recommendation that fail, with their reasons; every
    /// failing ranked candidate when nothing meets.
    pub fn cheaper_failing(&self) -> Vec<&Measured> {
        let limit = self
            .recommended
            .as_deref()
            .and_then(|r| self.find(r))
            .and_then(|m| m.cost_vs_floor)
            .unwrap_or(f64::INFINITY);
        self.candidates
            .iter()
            .filter(|m| !m.meets && m.cost_vs_floor.is_some_and(|c| c < limit))
            .collect()
    }

    /// Candidates that did not render, or have no cost: named with their reasons.
    pub fn unranked(&self) -> Vec<&Measured> {
        self.candidates
            .iter()
            .filter(|m| m.cost_vs_floor.is_none())
            .collect()
    }
}

/// One configuration over every scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuiteCandidate {
    pub technique: String,
    /// Scenes where it meets the budget, of `scenes`.
    pub scenes_met: usize,
    pub scenes: usize,
    /// Geometric mean of cost × floor over the scenes (only when it has a cost on each).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub geomean_cost: Option<f64>,
    /// Largest cost × floor over the scenes (only when it has a cost on each).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_cost: Option<f64>,
    /// Largest primary error over the scenes where it was measured.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub worst_error: Option<f64>,
    /// The scenes where it fails, each with why.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub failing: Vec<SceneFailure>,
}

/// Why one configuration fails on one scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneFailure {
    pub scene: String,
    pub why: Vec<String>,
}

/// The one configuration for every scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuiteAnswer {
    /// How the per-scene costs are combined: `geometric mean of cost × floor`.
    pub aggregate: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recommended: Option<String>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub tied: Vec<String>,
    /// When none meets the budget on every scene: the one meeting it on the most scenes
    /// (then the cheapest).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub closest: Option<String>,
    /// Every candidate, cheapest geometric mean first (those without a cost on every scene last).
    pub candidates: Vec<SuiteCandidate>,
}

impl SuiteAnswer {
    fn find(&self, technique: &str) -> Option<&SuiteCandidate> {
        self.candidates.iter().find(|c| c.technique == technique)
    }

    /// Candidates with a lower geometric mean than the recommendation that fail somewhere;
    /// every failing ranked candidate when nothing meets.
    pub fn cheaper_failing(&self) -> Vec<&SuiteCandidate> {
        let limit = self
            .recommended
            .as_deref()
            .and_then(|r| self.find(r))
            .and_then(|c| c.geomean_cost)
            .unwrap_or(f64::INFINITY);
        self.candidates
            .iter()
            .filter(|c| c.scenes_met < c.scenes && c.geomean_cost.is_some_and(|g| g < limit))
            .collect()
    }
}

/// `oit recommend`'s whole answer (`--json`, schema [`SCHEMA`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Recommendation {
    pub schema: String,
    pub date: String,
    pub adapter: AdapterJson,
    /// The results file the answer was read from.
    pub results: String,
    pub budget: Budget,
    pub error_axis: ErrorAxis,
    /// The configurations considered, canonical specs.
    pub candidates: Vec<String>,
    pub scenes: Vec<SceneAnswer>,
    /// Present with more than one scene.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub suite: Option<SuiteAnswer>,
    /// True when every scene has a configuration within budget and, with several scenes, one
    /// configuration meets it on all of them.
    pub met: bool,
}

/// Everything `recommend` reads besides the results: which scenes and configurations.
#[derive(Debug, Clone)]
pub struct Question<'a> {
    /// Scene names, in the order to report them; empty: every scene of the results.
    pub scenes: &'a [String],
    /// Canonical specs; empty: every technique the results hold for those scenes.
    pub candidates: &'a [String],
    pub budget: Budget,
    /// Where the results came from, recorded in the answer.
    pub source: &'a str,
    /// The date recorded in the answer (`YYYY-MM-DD`).
    pub date: &'a str,
}

/// Answers `question` from `results`. The budget must have passed [`Budget::validate`].
pub fn recommend(results: &Results, question: &Question<'_>) -> Recommendation {
    let budget = question.budget;
    let scenes: Vec<String> = if question.scenes.is_empty() {
        let mut seen = Vec::new();
        for r in &results.runs {
            if !seen.contains(&r.scene) {
                seen.push(r.scene.clone());
            }
        }
        seen
    } else {
        question.scenes.to_vec()
    };
    let candidates: Vec<String> = if question.candidates.is_empty() {
        let mut seen: Vec<String> = Vec::new();
        for r in results.runs.iter().filter(|r| scenes.contains(&r.scene)) {
            if !seen.contains(&r.technique) {
                seen.push(r.technique.clone());
            }
        }
        seen
    } else {
        question.candidates.to_vec()
    };
    let mut by_key: BTreeMap<(&str, &str), &Run> = BTreeMap::new();
    for r in &results.runs {
        by_key.insert((r.scene.as_str(), r.technique.as_str()), r);
    }
    let answers: Vec<SceneAnswer> = scenes
        .iter()
        .map(|scene| {
            let resolution = results
                .runs
                .iter()
                .find(|r| &r.scene == scene)
                .map(|r| r.resolution);
            let measured = candidates
                .iter()
                .map(|t| {
                    Measured::of(
                        t,
                        by_key.get(&(scene.as_str(), t.as_str())).copied(),
                        &budget,
                    )
                })
                .collect();
            scene_answer(scene, resolution, measured, &budget)
        })
        .collect();
    let suite = (answers.len() > 1).then(|| suite_answer(&answers, &candidates, &budget));
    let met = answers.iter().all(|a| a.recommended.is_some())
        && suite.as_ref().is_none_or(|s| s.recommended.is_some());
    Recommendation {
        schema: SCHEMA.to_owned(),
        date: question.date.to_owned(),
        adapter: results.adapter.clone(),
        results: question.source.to_owned(),
        budget,
        error_axis: budget.primary(),
        candidates,
        scenes: answers,
        suite,
        met,
    }
}

/// Ranks one scene's candidates and picks within the tie band.
fn scene_answer(
    scene: &str,
    resolution: Option<[u32; 2]>,
    mut measured: Vec<Measured>,
    budget: &Budget,
) -> SceneAnswer {
    let axis = budget.primary();
    // Stable: equal costs and unranked candidates keep the candidate order.
    measured.sort_by(|a, b| match (a.cost_vs_floor, b.cost_vs_floor) {
        (Some(x), Some(y)) => x.total_cmp(&y),
        (Some(_), None) => std::cmp::Ordering::Less,
        (None, Some(_)) => std::cmp::Ordering::Greater,
        (None, None) => std::cmp::Ordering::Equal,
    });
    let passing: Vec<&Measured> = measured.iter().filter(|m| m.meets).collect();
    let (recommended, tied) = pick_in_band(
        passing
            .iter()
            .map(|m| {
                (
                    m.technique.as_str(),
                    m.cost_vs_floor.unwrap_or(f64::INFINITY),
                    m.error(axis).unwrap_or(f64::INFINITY),
                )
            })
            .collect(),
        budget.tie,
    );
    let closest = if recommended.is_none() {
        measured
            .iter()
            .filter(|m| m.status == "ok" && m.error(axis).is_some())
            .min_by(|a, b| {
                a.excess(budget).total_cmp(&b.excess(budget)).then(
                    (a.cost_vs_floor.unwrap_or(f64::INFINITY))
                        .total_cmp(&b.cost_vs_floor.unwrap_or(f64::INFINITY)),
                )
            })
            .map(|m| m.technique.clone())
    } else {
        None
    };
    let ranked: Vec<&Measured> = measured
        .iter()
        .filter(|m| m.status == "ok" && m.cost_vs_floor.is_some() && m.error(axis).is_some())
        .collect();
    let points: Vec<(f64, f64)> = ranked
        .iter()
        .map(|m| {
            (
                m.cost_vs_floor.unwrap_or(f64::NAN),
                m.error(axis).unwrap_or(f64::NAN),
            )
        })
        .collect();
    // `ranked` is sorted by cost, and so are the ascending indices of the front.
    let front = pareto_front(&points)
        .into_iter()
        .map(|i| ranked[i].technique.clone())
        .collect();
    SceneAnswer {
        scene: scene.to_owned(),
        resolution,
        recommended,
        tied,
        closest,
        front,
        candidates: measured,
    }
}

/// From `(name, cost, error)` of passing configurations: the most accurate among those whose
/// cost is within `1 + tie` of the cheapest (then the cheaper, then the name), and the others
/// in that band, cheapest first.
fn pick_in_band(mut passing: Vec<(&str, f64, f64)>, tie: f64) -> (Option<String>, Vec<String>) {
    passing.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(b.0)));
    let Some(&(_, cheapest, _)) = passing.first() else {
        return (None, Vec::new());
    };
    let band: Vec<(&str, f64, f64)> = passing
        .into_iter()
        .filter(|p| p.1 <= cheapest * (1.0 + tie))
        .collect();
    let best = band
        .iter()
        .min_by(|a, b| {
            a.2.total_cmp(&b.2)
                .then(a.1.total_cmp(&b.1))
                .then(a.0.cmp(b.0))
        })
        .map(|p| p.0.to_owned());
    let tied = band
        .iter()
        .filter(|p| Some(p.0) != best.as_deref())
        .map(|p| p.0.to_owned())
        .collect();
    (best, tied)
}

/// The one configuration for every scene: meets the budget on each, cheapest by the
/// geometric mean of cost × floor (ties as per scene, broken by the worst error).
fn suite_answer(answers: &[SceneAnswer], candidates: &[String], budget: &Budget) -> SuiteAnswer {
    let axis = budget.primary();
    let mut rows: Vec<SuiteCandidate> = candidates
        .iter()
        .map(|t| {
            let per_scene: Vec<(&str, Option<&Measured>)> = answers
                .iter()
                .map(|a| (a.scene.as_str(), a.find(t)))
                .collect();
            let costs: Vec<f64> = per_scene
                .iter()
                .filter_map(|(_, m)| m.and_then(|m| m.cost_vs_floor))
                .filter(|c| *c > 0.0)
                .collect();
            let everywhere = costs.len() == answers.len();
            let geomean = everywhere
                .then(|| (costs.iter().map(|c| c.ln()).sum::<f64>() / costs.len() as f64).exp());
            let worst_cost = everywhere.then(|| costs.iter().copied().fold(0.0, f64::max));
            let worst_error = per_scene
                .iter()
                .filter_map(|(_, m)| m.and_then(|m| m.error(axis)))
                .reduce(f64::max);
            let failing: Vec<SceneFailure> = per_scene
                .iter()
                .filter(|(_, m)| !m.is_some_and(|m| m.meets))
                .map(|(scene, m)| SceneFailure {
                    scene: (*scene).to_owned(),
                    why: m.map_or_else(|| vec!["not measured".to_owned()], |m| m.fails.clone()),
                })
                .collect();
            SuiteCandidate {
                technique: t.clone(),
                scenes_met: answers.len() - failing.len(),
                scenes: answers.len(),
                geomean_cost: geomean,
                worst_cost,
                worst_error,
                failing,
            }
        })
        .collect();
    rows.sort_by(|a, b| match (a.geomean_cost, b.geomean_cost) {
        (Some(x), Some(y)) => x.total_cmp(&y),
        (Some(_), None) => std::cmp::Ordering::Less,
        (None, Some(_)) => std::cmp::Ordering::Greater,
        (None, None) => std::cmp::Ordering::Equal,
    });
    let (recommended, tied) = pick_in_band(
        rows.iter()
            .filter(|r| r.scenes_met == r.scenes)
            .map(|r| {
                (
                    r.technique.as_str(),
                    r.geomean_cost.unwrap_or(f64::INFINITY),
                    r.worst_error.unwrap_or(f64::INFINITY),
                )
            })
            .collect(),
        budget.tie,
    );
    let closest = if recommended.is_none() {
        rows.iter()
            .max_by(|a, b| {
                a.scenes_met.cmp(&b.scenes_met).then(
                    b.geomean_cost
                        .unwrap_or(f64::INFINITY)
                        .total_cmp(&a.geomean_cost.unwrap_or(f64::INFINITY)),
                )
            })
            .map(|r| r.technique.clone())
    } else {
        None
    };
    SuiteAnswer {
        aggregate: "geometric mean of cost × floor over the scenes".into(),
        recommended,
        tied,
        closest,
        candidates: rows,
    }
}

/// `value` meets `bound` (equal included); NaN meets nothing.
fn within(value: f64, bound: f64) -> bool {
    value.partial_cmp(&bound).is_some_and(|o| o.is_le())
}

/// A number in 4 significant digits, small ones in scientific notation.
fn num(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-3 {
        format!("{v:.1e}")
    } else {
        format!("{v:.4}")
    }
}

/// `technique cost/error` of one measured run, for the text answer.
fn point(m: &Measured, axis: ErrorAxis, label: &dyn Fn(&str) -> String) -> String {
    format!(
        "{} ({}, {})",
        label(&m.technique),
        m.cost_vs_floor
            .map_or_else(|| "no cost".into(), |c| format!("{c:.2}× floor")),
        measured_error(m, axis)
    )
}

fn measured_error(m: &Measured, axis: ErrorAxis) -> String {
    match axis {
        ErrorAxis::Flip => format!(
            "{} {}",
            m.flip_name.as_deref().unwrap_or("FLIP"),
            m.flip.map_or_else(|| "-".into(), num)
        ),
        ErrorAxis::MaxError => format!("max error {}", m.max_error.map_or_else(|| "-".into(), num)),
    }
}

/// The terminal answer: a block per scene, then the suite's answer and a summary table.
/// `label` shortens canonical specs (defaults left out).
pub fn recommendation_text(r: &Recommendation, label: &dyn Fn(&str) -> String) -> String {
    let axis = r.error_axis;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "budget: {}; cost = cost × floor; costs within {:.0} % tie (the most accurate of them is chosen)",
        r.budget.describe(),
        100.0 * r.budget.tie
    );
    let _ = writeln!(
        out,
        "adapter: {}; {} candidates; results: {}\n",
        r.adapter.name,
        r.candidates.len(),
        r.results
    );
    for a in &r.scenes {
        let res = a
            .resolution
            .map_or_else(String::new, |[w, h]| format!(" ({w}x{h})"));
        let _ = writeln!(out, "{}{res}", oit_results::report::printable(&a.scene));
        match (&a.recommended, &a.closest) {
            (Some(t), _) => {
                if let Some(m) = a.find(t) {
                    let _ = writeln!(out, "  recommended: {}", point(m, axis, label));
                    if !m.inexact.is_empty() {
                        let _ = writeln!(out, "    inexact: {}", m.inexact.join("; "));
                    }
                }
            }
            (None, Some(t)) => {
                if let Some(m) = a.find(t) {
                    let _ = writeln!(
                        out,
                        "  none meets the budget; closest: {}: {}",
                        point(m, axis, label),
                        m.fails.join("; ")
                    );
                }
            }
            (None, None) => {
                let _ = writeln!(out, "  none meets the budget, and no run was measured");
            }
        }
        if !a.tied.is_empty() {
            let tied: Vec<String> = (a.tied.iter().filter_map(|t| a.find(t)))
                .map(|m| point(m, axis, label))
                .collect();
            let _ = writeln!(out, "  tied on cost: {}", tied.join(", "));
        }
        let cheaper = a.cheaper_failing();
        if !cheaper.is_empty() {
            let _ = writeln!(
                out,
                "  {}:",
                if a.recommended.is_some() {
                    "cheaper, failing"
                } else {
                    "failing"
                }
            );
            for m in cheaper {
                let inexact = if m.inexact.is_empty() {
                    String::new()
                } else {
                    format!(" [inexact: {}]", m.inexact.join("; "))
                };
                let _ = writeln!(
                    out,
                    "    {:<40} {:>7} {}{inexact}",
                    label(&m.technique),
                    m.cost_vs_floor
                        .map_or_else(|| "-".into(), |c| format!("{c:.2}")),
                    m.fails.join("; ")
                );
            }
        }
        for m in a.unranked() {
            let _ = writeln!(
                out,
                "  not ranked: {}: {}",
                label(&m.technique),
                m.fails.join("; ")
            );
        }
        let front: Vec<String> = (a.front.iter().filter_map(|t| a.find(t)))
            .map(|m| point(m, axis, label))
            .collect();
        let _ = writeln!(out, "  Pareto front: {}\n", front.join(" · "));
    }
    if let Some(s) = &r.suite {
        let _ = writeln!(out, "over all {} scenes ({}):", r.scenes.len(), s.aggregate);
        let row = |c: &SuiteCandidate| {
            format!(
                "{} (geomean {}, worst {}× floor; worst error {})",
                label(&c.technique),
                c.geomean_cost
                    .map_or_else(|| "-".into(), |g| format!("{g:.2}")),
                c.worst_cost
                    .map_or_else(|| "-".into(), |g| format!("{g:.2}")),
                c.worst_error.map_or_else(|| "-".into(), num)
            )
        };
        match (&s.recommended, &s.closest) {
            (Some(t), _) => {
                if let Some(c) = s.find(t) {
                    let _ = writeln!(out, "  recommended: {}", row(c));
                }
            }
            (None, Some(t)) => {
                if let Some(c) = s.find(t) {
                    let _ = writeln!(
                        out,
                        "  none meets the budget on every scene; closest: {} meets it on {} of {}",
                        row(c),
                        c.scenes_met,
                        c.scenes
                    );
                }
            }
            (None, None) => {
                let _ = writeln!(out, "  none meets the budget on every scene");
            }
        }
        if !s.tied.is_empty() {
            let tied: Vec<String> = (s.tied.iter().filter_map(|t| s.find(t))).map(row).collect();
            let _ = writeln!(out, "  tied on cost: {}", tied.join(", "));
        }
        for c in s.cheaper_failing() {
            let scenes: Vec<String> = c
                .failing
                .iter()
                .take(3)
                .map(|f| format!("{} ({})", f.scene, f.why.join("; ")))
                .collect();
            let more = c.failing.len().saturating_sub(3);
            let more = if more > 0 {
                format!(", and {more} more")
            } else {
                String::new()
            };
            let _ = writeln!(
                out,
                "  cheaper, failing: {} on {} of {}: {}{more}",
                label(&c.technique),
                c.failing.len(),
                c.scenes,
                scenes.join(", ")
            );
        }
    }
    out
}
