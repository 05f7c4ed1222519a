//! `oit_report::recommend` on results built by hand: the cheapest within budget, ties inside
//! the noise band, why cheaper ones fail, what did not render, the suite's one answer, and
//! budgets nothing meets.

use oit_metrics::Errors;
use oit_report::recommend::{Budget, ErrorAxis, Question, Recommendation, recommend};
use oit_results::{AdapterJson, Results, Run, RunStatus, SCHEMA};

fn run(scene: &str, technique: &str, cost: f64, flip: f64, max_abs: f64) -> Run {
    let mut r = Run::not_rendered(
        scene,
        &format!("scenes/{scene}.json"),
        technique,
        [32, 32],
        RunStatus::Ok,
        String::new(),
    );
    r.reason = None;
    r.cost_vs_floor = Some(cost);
    r.error = Some(Errors {
        flip_mean: flip,
        max_abs,
        ..Errors::default()
    });
    r
}

fn skipped(scene: &str, technique: &str, reason: &str) -> Run {
    Run::not_rendered(
        scene,
        &format!("scenes/{scene}.json"),
        technique,
        [32, 32],
        RunStatus::Skipped,
        reason.to_owned(),
    )
}

fn results(runs: Vec<Run>) -> Results {
    Results {
        schema: SCHEMA.to_owned(),
        tool: None,
        complete: true,
        adapter: AdapterJson {
            name: "test adapter".into(),
            backend: "vulkan".into(),
            device_type: "cpu".into(),
            driver: "test".into(),
        },
        runs,
        floors: Vec::new(),
        scenes: Vec::new(),
        shard: None,
        merged: Vec::new(),
    }
}

fn flip_budget(max_flip: f64) -> Budget {
    Budget {
        max_flip: Some(max_flip),
        max_error: None,
        max_cost: None,
        tie: 0.1,
    }
}

fn ask(results: &Results, budget: Budget) -> Recommendation {
    recommend(
        results,
        &Question {
            scenes: &[],
            candidates: &[],
            budget,
            source: "results.json",
            date: "2026-12-06",
        },
    )
}

#[test]
fn the_cheapest_within_budget_is_recommended_and_cheaper_ones_say_why() {
    let r = results(vec![
        run("a", "unsorted", 1.0, 0.20, 0.5),
        run("a", "sorted-object", 1.5, 0.02, 0.1),
        run("a", "k-buffer:k=8", 3.0, 0.004, 0.01),
        run("a", "front-peel", 9.0, 0.0, 0.0),
        skipped(
            "a",
            "k-buffer:k=32",
            "the adapter lacks SHADER_INT64_ATOMIC_ALL_OPS",
        ),
    ]);
    let answer = ask(&r, flip_budget(0.01));
    let a = &answer.scenes[0];
    assert_eq!(a.recommended.as_deref(), Some("k-buffer:k=8"));
    assert!(answer.met);
    let cheaper: Vec<&str> = a
        .cheaper_failing()
        .iter()
        .map(|m| m.technique.as_str())
        .collect();
    assert_eq!(cheaper, ["unsorted", "sorted-object"]);
    assert_eq!(a.candidates[0].fails, ["LDR-FLIP 0.2000 > 0.01"]);
    let unranked = a.unranked();
    assert_eq!(unranked.len(), 1);
    assert!(unranked[0].fails[0].contains("skipped: the adapter lacks"));
    // Every point beats the next on error; all four are on the front, cheapest first.
    assert_eq!(
        a.front,
        ["unsorted", "sorted-object", "k-buffer:k=8", "front-peel"]
    );
    let text = oit_report::recommend::recommendation_text(&answer, &|s| s.to_owned());
    assert!(
        text.contains("recommended: k-buffer:k=8 (3.00× floor, LDR-FLIP 0.0040)"),
        "{text}"
    );
    assert!(
        text.contains("not ranked: k-buffer:k=32: skipped"),
        "{text}"
    );
    // The budget is inclusive: a run exactly on it meets it.
    let answer = ask(&r, flip_budget(0.02));
    assert_eq!(
        answer.scenes[0].recommended.as_deref(),
        Some("sorted-object")
    );
}

#[test]
fn costs_inside_the_tie_band_go_to_the_more_accurate() {
    let r = results(vec![
        run("a", "x", 2.00, 0.009, 0.1),
        run("a", "y", 2.15, 0.001, 0.1),
        run("a", "z", 2.30, 0.000, 0.1),
    ]);
    let answer = ask(&r, flip_budget(0.01));
    // y is within 10 % of x, z (15 % over) is not.
    assert_eq!(answer.scenes[0].recommended.as_deref(), Some("y"));
    assert_eq!(answer.scenes[0].tied, ["x"]);
    let strict = ask(
        &r,
        Budget {
            tie: 0.0,
            ..flip_budget(0.01)
        },
    );
    assert_eq!(strict.scenes[0].recommended.as_deref(), Some("x"));
    assert!(strict.scenes[0].tied.is_empty());
}

#[test]
fn max_error_cost_cap_non_finite_and_hdr_flip_are_judged() {
    let mut hdr = run("a", "hdr-run", 1.0, 0.0001, 0.01);
    if let Some(e) = hdr.error.as_mut() {
        e.hdr = true;
        e.hdr_flip_mean = Some(0.3);
    }
    let mut nan = run("a", "nan-run", 1.1, 0.0, 0.0);
    if let Some(e) = nan.error.as_mut() {
        e.nonfinite = 4;
    }
    let r = results(vec![
        hdr,
        nan,
        run("a", "coarse", 1.2, 0.001, 0.2),
        run("a", "fine", 4.0, 0.0, 0.001),
        run("a", "dear", 8.0, 0.0, 0.0),
    ]);
    // HDR-FLIP, not the Reinhard LDR-FLIP, is what --max-flip bounds on an HDR scene.
    let answer = ask(&r, flip_budget(0.01));
    let a = &answer.scenes[0];
    assert_eq!(a.recommended.as_deref(), Some("coarse"));
    assert_eq!(a.candidates[0].fails, ["HDR-FLIP 0.3000 > 0.01"]);
    assert_eq!(a.candidates[1].fails, ["4 non-finite pixels"]);
    // --max-error bounds max_abs; the front is on max error then.
    let budget = Budget {
        max_flip: None,
        max_error: Some(0.01),
        max_cost: Some(5.0),
        tie: 0.1,
    };
    let answer = ask(&r, budget);
    assert_eq!(answer.error_axis, ErrorAxis::MaxError);
    let a = &answer.scenes[0];
    assert_eq!(a.recommended.as_deref(), Some("hdr-run"));
    let answer = ask(
        &r,
        Budget {
            max_error: Some(0.005),
            ..budget
        },
    );
    let a = &answer.scenes[0];
    assert_eq!(a.recommended.as_deref(), Some("fine"));
    let dear = a.candidates.iter().find(|m| m.technique == "dear").unwrap();
    assert_eq!(dear.fails, ["cost × floor 8.00 > 5 (--max-cost)"]);
}

#[test]
fn a_budget_nothing_meets_names_the_closest() {
    let r = results(vec![
        run("a", "unsorted", 1.0, 0.30, 0.5),
        run("a", "sorted", 1.2, 0.05, 0.1),
        run("a", "peel", 5.0, 0.02, 0.05),
    ]);
    let answer = ask(&r, flip_budget(0.001));
    let a = &answer.scenes[0];
    assert!(!answer.met);
    assert_eq!(a.recommended, None);
    assert_eq!(a.closest.as_deref(), Some("peel"));
    // Nothing is "cheaper than the recommendation": every failing ranked run is listed.
    assert_eq!(a.cheaper_failing().len(), 3);
    let text = oit_report::recommend::recommendation_text(&answer, &|s| s.to_owned());
    assert!(
        text.contains("none meets the budget; closest: peel"),
        "{text}"
    );
}

#[test]
fn the_suite_answer_meets_every_scene_at_the_lowest_geometric_mean() {
    let r = results(vec![
        // cheap: fails on b.
        run("a", "cheap", 1.0, 0.001, 0.0),
        run("b", "cheap", 1.0, 0.5, 0.0),
        // mid: passes both, geomean sqrt(2 * 8) = 4.
        run("a", "mid", 2.0, 0.001, 0.0),
        run("b", "mid", 8.0, 0.001, 0.0),
        // even: passes both, geomean 5 but worst 5 (an arithmetic mean would pick it).
        run("a", "even", 5.0, 0.0, 0.0),
        run("b", "even", 5.0, 0.002, 0.0),
        // gone: skipped on b.
        run("a", "gone", 0.5, 0.0, 0.0),
        skipped("b", "gone", "too many passes for the run budget"),
    ]);
    let answer = ask(&r, flip_budget(0.01));
    assert_eq!(answer.scenes[0].recommended.as_deref(), Some("gone"));
    assert_eq!(answer.scenes[1].recommended.as_deref(), Some("even"));
    let suite = answer.suite.as_ref().unwrap();
    assert_eq!(suite.recommended.as_deref(), Some("mid"));
    let mid = suite
        .candidates
        .iter()
        .find(|c| c.technique == "mid")
        .unwrap();
    assert!((mid.geomean_cost.unwrap() - 4.0).abs() < 1e-12);
    assert_eq!(mid.worst_cost, Some(8.0));
    let cheaper: Vec<&str> = suite
        .cheaper_failing()
        .iter()
        .map(|c| c.technique.as_str())
        .collect();
    assert_eq!(cheaper, ["cheap"]);
    let gone = suite
        .candidates
        .iter()
        .find(|c| c.technique == "gone")
        .unwrap();
    assert_eq!(gone.geomean_cost, None);
    assert_eq!(gone.failing[0].scene, "b");
    assert!(gone.failing[0].why[0].starts_with("skipped: too many passes"));
    assert!(answer.met);
    // Nothing meets b at 0: a still has an answer, the suite names the closest (even and gone
    // meet a only; even has a cost everywhere, so the lower geometric mean).
    let answer = ask(&r, flip_budget(0.0));
    let suite = answer.suite.as_ref().unwrap();
    assert!(!answer.met);
    assert_eq!(suite.recommended, None);
    assert_eq!(suite.closest.as_deref(), Some("even"));
}

#[test]
fn named_candidates_missing_from_the_results_are_said_so() {
    let r = results(vec![run("a", "unsorted", 1.0, 0.0, 0.0)]);
    let answer = recommend(
        &r,
        &Question {
            scenes: &["a".to_owned()],
            candidates: &["unsorted".to_owned(), "k-buffer:k=4".to_owned()],
            budget: flip_budget(0.01),
            source: "results.json",
            date: "2026-12-06",
        },
    );
    let kb = answer.scenes[0]
        .candidates
        .iter()
        .find(|m| m.technique == "k-buffer:k=4")
        .unwrap();
    assert_eq!(kb.status, "missing");
    assert!(kb.fails[0].contains("not measured"));
    let json = serde_json::to_value(&answer).unwrap();
    assert_eq!(json["schema"], "oit-lab/recommend/v1");
    assert_eq!(json["scenes"][0]["recommended"], "unsorted");
    assert_eq!(json["budget"]["max_flip"], 0.01);
    assert!(json["budget"]["max_error"].is_null());
}

#[test]
fn budgets_out_of_range_are_refused_naming_the_flag() {
    for (budget, flag) in [
        (
            Budget {
                max_flip: None,
                ..flip_budget(0.0)
            },
            "--max-flip",
        ),
        (flip_budget(1.5), "--max-flip"),
        (flip_budget(f64::NAN), "--max-flip"),
        (
            Budget {
                max_error: Some(-1.0),
                ..flip_budget(0.1)
            },
            "--max-error",
        ),
        (
            Budget {
                max_cost: Some(0.0),
                ..flip_budget(0.1)
            },
            "--max-cost",
        ),
        (
            Budget {
                tie: 2.0,
                ..flip_budget(0.1)
            },
            "--tie",
        ),
    ] {
        let err = budget.validate().unwrap_err();
        assert!(err.contains(flag), "{err}");
    }
    assert!(flip_budget(0.01).validate().is_ok());
}
