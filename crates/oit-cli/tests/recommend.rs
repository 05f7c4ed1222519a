//! `oit recommend` as a user runs it: bad flags, `--from` a results file, a budget nothing
//! meets (exit 3 with the closest), and on a GPU the recommended configuration, rerun with a
//! fresh `oit compare -t`, within the budget.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn oit() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_oit"));
    c.current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."));
    c
}

fn temp_dir(name: &str) -> oit_gpu::testing::ScratchDir {
    oit_gpu::testing::ScratchDir::new(&format!("recommend-{name}"))
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn bad_flags_are_usage_errors_naming_the_flag() {
    for (args, expect) in [
        (vec!["scenes/enderton.json"], "--max-flip"),
        (
            vec!["scenes/enderton.json", "--max-flip", "1.5"],
            "in 0..=1",
        ),
        (
            vec!["scenes/enderton.json", "--max-flip", "abc"],
            "is not a number",
        ),
        (vec!["scenes/enderton.json", "--max-error=-1"], "≥ 0"),
        (
            vec![
                "scenes/enderton.json",
                "--max-flip",
                "0.1",
                "--max-cost",
                "0",
            ],
            "> 0",
        ),
        (
            vec!["scenes/enderton.json", "--max-flip", "0.1", "--tie", "3"],
            "--tie",
        ),
        (
            vec![
                "--from",
                "x.json",
                "--max-flip",
                "0.1",
                "--resolution",
                "8x8",
            ],
            "--resolution",
        ),
        (vec!["--max-flip", "0.1"], "SCENES"),
    ] {
        let out = oit().arg("recommend").args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(stderr(&out).contains(expect), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn help_defines_the_budget_cost_candidates_and_exit_status() {
    let out = oit().args(["recommend", "--help"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "HDR-FLIP",
        "error.max_abs",
        "cost × floor",
        "k-buffer:k=1,2,4,16,32",
        "geometric mean",
        "1 + --tie",
        "3 when no configuration meets it",
    ] {
        assert!(text.contains(needle), "{needle} missing:\n{text}");
    }
}

/// A results file written as `oit compare` writes it, with two scenes: the answer, its JSON
/// and the exit status for a budget met and one nothing meets.
#[test]
fn from_a_results_file_answers_without_a_gpu() {
    let dir = temp_dir("from");
    let results = dir.join("results.json");
    let run = |scene: &str, technique: &str, status: &str, cost: f64, flip: f64| {
        let mut r = serde_json::json!({
            "scene": scene, "scene_file": format!("scenes/{scene}.json"),
            "technique": technique, "resolution": [16, 16], "status": status,
        });
        if status == "ok" {
            r["cost_vs_floor"] = serde_json::json!(cost);
            r["error"] = serde_json::json!({
                "rmse": flip, "psnr": 40.0, "mean_abs": flip, "max_abs": flip,
                "over_1_255": 0.0, "over_1_64": 0.0, "flip_mean": flip, "nonfinite": 0,
            });
        } else {
            r["reason"] = serde_json::json!("the adapter lacks a feature");
        }
        r
    };
    let file = serde_json::json!({
        "schema": "oit-lab/results/v1",
        "adapter": {"name": "test", "backend": "vulkan", "device_type": "cpu", "driver": "t"},
        "runs": [
            run("one", "unsorted", "ok", 1.0, 0.3),
            run("one", "sorted-object", "ok", 1.1, 0.001),
            run("one", "k-buffer:k=8,tail=average", "skipped", 0.0, 0.0),
            run("two", "unsorted", "ok", 1.0, 0.002),
            run("two", "sorted-object", "ok", 1.2, 0.02),
            run("two", "k-buffer:k=8,tail=average", "skipped", 0.0, 0.0),
        ],
    });
    std::fs::write(&results, serde_json::to_string(&file).unwrap()).unwrap();
    let json = dir.join("answer.json");
    let out = oit()
        .args(["recommend", "--max-flip", "0.01", "--from"])
        .arg(&results)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    // Each scene has an answer, but no single configuration meets both.
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("no single configuration meets FLIP ≤ 0.01 on all 2 scenes"),
        "{}",
        stderr(&out)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("recommended: sorted-object"), "{text}");
    assert!(text.contains("recommended: unsorted"), "{text}");
    assert!(
        text.contains("not ranked: k-buffer: skipped: the adapter lacks"),
        "{text}"
    );
    assert!(
        text.contains("none meets the budget on every scene"),
        "{text}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["schema"], "oit-lab/recommend/v1");
    assert_eq!(v["met"], false);
    assert_eq!(v["scenes"][0]["recommended"], "sorted-object");
    assert_eq!(
        v["suite"]["aggregate"],
        "geometric mean of cost × floor over the scenes"
    );
    // A looser budget: sorted-object meets both scenes (geomean √1.32).
    let out = oit()
        .args(["recommend", "--max-flip", "0.05", "--from"])
        .arg(&results)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("over all 2 scenes (geometric mean of cost × floor over the scenes):\n  recommended: sorted-object (geomean 1.15, worst 1.20× floor"),
        "{text}"
    );
    // A scene the file does not hold is an error naming it.
    let out = oit()
        .args([
            "recommend",
            "scenes/enderton.json",
            "--max-flip",
            "0.05",
            "--from",
        ])
        .arg(&results)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("no runs of scene enderton"),
        "{}",
        stderr(&out)
    );
    // A file that is not results names itself.
    let out = oit()
        .args(["recommend", "--max-flip", "0.05", "--from"])
        .arg(&json)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("answer.json"), "{}", stderr(&out));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Reads `dir/results.json`'s run of `technique` on `scene`: (headline ꟻLIP, max error).
fn measured(dir: &Path, scene: &str, technique: &str) -> (f64, f64) {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).unwrap()).unwrap();
    let run = v["runs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["scene"] == scene && r["technique"] == technique)
        .unwrap_or_else(|| panic!("no run of {technique} on {scene}"));
    let e = &run["error"];
    let flip = if e["hdr"] == true {
        e["hdr_flip_mean"].as_f64().unwrap()
    } else {
        e["flip_mean"].as_f64().unwrap()
    };
    (flip, e["max_abs"].as_f64().unwrap())
}

/// On bundled and seeded random scenes at low resolution: every recommended configuration,
/// rerun by a fresh `oit compare -t`, meets the budget; a second `recommend` reuses every run;
/// a budget nothing meets exits 3 naming the closest.
#[test]
fn the_recommended_configuration_rerun_meets_the_budget() {
    if oit_gpu::testing::context_or_skip("cli recommend").is_none() {
        return;
    }
    let dir = temp_dir("gpu");
    let random = dir.join("scenes");
    std::fs::create_dir_all(&random).unwrap();
    for seed in [3u64, 11] {
        let (text, _) = oit_scene::random::random_scene_json(seed);
        std::fs::write(random.join(format!("random-{seed}.json")), text).unwrap();
    }
    let out_dir = dir.join("out");
    let json = dir.join("answer.json");
    let recommend = |max_flip: &str| {
        oit()
            .args([
                "recommend",
                "scenes/intersecting-quads.json",
                "scenes/sorted-quads.json",
            ])
            .arg(&random)
            .args(["--max-flip", max_flip, "--resolution", "40x40"])
            .args(["--frames", "2", "--warmup", "0", "--no-cache"])
            .args([
                "-t",
                "unsorted",
                "-t",
                "sorted-object",
                "-t",
                "sorted-triangle",
            ])
            .args(["-t", "front-peel:layers=auto", "-t", "weighted-average"])
            .arg("--out")
            .arg(&out_dir)
            .arg("--json")
            .arg(&json)
            .output()
            .unwrap()
    };
    let out = recommend("0.01");
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["scenes"].as_array().unwrap().len(), 4);
    assert!(v["suite"]["recommended"].is_string(), "{v}");
    let mut checked = 0;
    for scene in v["scenes"].as_array().unwrap() {
        let name = scene["scene"].as_str().unwrap();
        let technique = scene["recommended"].as_str().unwrap();
        let file = if name.starts_with("random") {
            random.join(format!("{name}.json"))
        } else {
            PathBuf::from(format!("scenes/{name}.json"))
        };
        let again = dir.join(format!("again-{name}"));
        let out = oit()
            .arg("compare")
            .arg(&file)
            .args(["-t", technique, "--resolution", "40x40", "--frames", "1"])
            .args(["--warmup", "0", "--no-cache", "--out"])
            .arg(&again)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        let (flip, _) = measured(&again, name, technique);
        assert!(flip <= 0.01, "{name}: {technique} reran at FLIP {flip}");
        checked += 1;
    }
    assert_eq!(checked, 4);
    // intersecting-quads: no order of objects is right, so sorted-object cannot be it.
    assert_ne!(v["scenes"][0]["recommended"], "sorted-object");
    // A budget nothing meets: `unsorted` alone on the intersecting quads at ꟻLIP 0. Its run
    // is reused from the comparison above (same inputs, same build).
    let out = oit()
        .args([
            "recommend",
            "scenes/intersecting-quads.json",
            "--max-flip",
            "0",
        ])
        .args([
            "--resolution",
            "40x40",
            "--frames",
            "2",
            "--warmup",
            "0",
            "--no-cache",
        ])
        .args(["-t", "unsorted", "--out"])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("none meets the budget; closest: unsorted"),
        "{text}"
    );
    assert!(
        stderr(&out)
            .contains("no configuration meets FLIP ≤ 0 on 1 of 1 scenes (intersecting-quads)"),
        "{}",
        stderr(&out)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("results.json")).unwrap())
            .unwrap();
    let reused = v["runs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["scene"] == "intersecting-quads" && r["technique"] == "unsorted")
        .unwrap();
    assert_eq!(reused["resumed"], true);
    let _ = std::fs::remove_dir_all(&dir);
}
