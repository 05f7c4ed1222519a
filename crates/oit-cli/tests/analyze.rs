//! `oit analyze` as a user runs it: the table, the JSON schema, and a scene that fails while
//! the others go on.

use std::path::Path;
use std::process::Command;

fn oit() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_oit"));
    c.current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."));
    c
}

#[test]
fn analyze_prints_a_table_per_scene_within_100_columns() {
    let out = oit()
        .args([
            "analyze",
            "scenes/intersecting-quads.json",
            "scenes/sorted-quads.json",
            "--resolution",
            "64x64",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("intersecting-quads (scenes/intersecting-quads.json, 64x64"));
    assert!(text.contains("sorted-quads (scenes/sorted-quads.json, 64x64"));
    for row in [
        "layers",
        "object cycles",
        "sorted-object wrong",
        "triangle cycles",
    ] {
        assert!(text.contains(row), "{row} missing:\n{text}");
    }
    assert!(text.contains("objects[0] / objects[1]"), "{text}");
    for line in text.lines() {
        assert!(line.chars().count() <= 100, "too wide: {line}");
    }
}

#[test]
fn analyze_json_follows_the_v1_schema() {
    let out = oit()
        .args([
            "analyze",
            "scenes/concave-self.json",
            "--resolution",
            "64x64",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["schema"], "oit-lab/analyze/v1");
    let a = &v["scenes"][0]["analysis"];
    assert_eq!(a["schema"], "oit-lab/analyze/v1");
    assert_eq!(a["resolution"], serde_json::json!([64, 64]));
    let keys: Vec<&str> = a.as_object().unwrap().keys().map(String::as_str).collect();
    for key in [
        "schema",
        "scene",
        "resolution",
        "pixels",
        "layers",
        "fragments",
        "objects",
        "triangles",
        "self_overlap",
        "alpha",
        "radiance",
        "depth",
        "seconds",
    ] {
        assert!(keys.contains(&key), "{key} missing from {keys:?}");
    }
    for key in ["max", "p50", "p95", "p99", "covered_pixels", "histogram"] {
        assert!(a["layers"].get(key).is_some(), "layers.{key}");
    }
    for key in [
        "conflict_pixels",
        "cycles",
        "largest_cycle",
        "conflict_pairs",
        "pairs",
        "technique_order_wrong_pixels",
        "technique_draw_order_wrong_pixels",
    ] {
        assert!(a["objects"].get(key).is_some(), "objects.{key}");
        assert!(a["triangles"].get(key).is_some(), "triangles.{key}");
    }
    assert!(a["self_overlap"]["pixels"].as_u64().unwrap() > 0);
    assert!(a["depth"]["depth16_separates"].is_boolean());
}

#[test]
fn analyze_reports_a_missing_file_and_goes_on() {
    let out = oit()
        .args([
            "analyze",
            "scenes/no-such-scene.json",
            "scenes/sorted-quads.json",
            "--resolution",
            "32x32",
            "--json",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("scenes/no-such-scene.json"), "{stderr}");
    assert!(
        stderr.contains("1 of 2 scenes could not be analysed"),
        "{stderr}"
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["scenes"][0]["error"].is_string());
    assert_eq!(v["scenes"][1]["analysis"]["scene"], "sorted-quads");
}
