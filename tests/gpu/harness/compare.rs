//! `compare` end to end on the bundled suite: results.json holds every schema field, the
//! metrics can fail (unsorted is wrong and order dependent), costs have their baseline, every
//! output file exists, and the reference cache is used the second time.

use std::path::{Path, PathBuf};

use oit_harness::results::{Results, RunStatus};
use oit_harness::{CompareOptions, compare, load_scenes, resolve_specs};
use oit_scene::Resolution;

fn scenes_dir() -> PathBuf {
    crate::kit::scenes_dir()
}

fn temp_dir(name: &str) -> oit_gpu::testing::ScratchDir {
    oit_gpu::testing::ScratchDir::new(&format!("harness-{name}"))
}

/// One frame, no warm-up, at 32×32 into `out`, references cached under `out/cache`: the
/// cheapest compare for tests that check what is reported, not how fast.
fn one_frame_at_32px(out: &Path, context: oit_gpu::ContextOptions) -> CompareOptions {
    CompareOptions {
        resolution: Some(Resolution {
            width: 32,
            height: 32,
        }),
        frames: 1,
        warmup: 0,
        out_dir: out.to_path_buf(),
        cache: oit_harness::ReferenceCache::Dir(out.join("cache")),
        context,
        ..CompareOptions::default()
    }
}

const SORTED: [&str; 5] = [
    "unsorted",
    "sorted-object",
    "sorted-triangle",
    "depth-prepass",
    "cull-split",
];

#[test]
fn compare_suite_writes_complete_results() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("compare_suite_writes_complete_results")
    else {
        return;
    };
    let out = temp_dir("out");
    let cache = temp_dir("cache");
    let scenes = load_scenes(&[scenes_dir()]).unwrap();
    assert!(
        scenes.len() >= 15,
        "bundled suite has {} scenes",
        scenes.len()
    );
    let specs = resolve_specs(&SORTED.map(String::from)).unwrap();
    let options = CompareOptions {
        resolution: Some(Resolution {
            width: 128,
            height: 128,
        }),
        frames: 2,
        warmup: 1,
        out_dir: out.to_path_buf(),
        cache: oit_harness::ReferenceCache::Dir(cache.to_path_buf()),
        ..CompareOptions::default()
    };
    let runs_done = std::sync::atomic::AtomicUsize::new(0);
    let results = compare(&ctx, &scenes, &specs, &options, &|event| {
        if let oit_harness::Event::RunDone { .. } = event {
            runs_done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    })
    .unwrap();
    assert_eq!(runs_done.into_inner(), scenes.len() * specs.len());

    // The file on disk is the same document, and parses with the published types.
    let on_disk = Results::read(&out.join("results.json")).unwrap();
    assert_eq!(on_disk, results);
    assert!(out.join("results.md").is_file());

    // Every field of the schema, checked on the raw JSON so a renamed field cannot hide.
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(json["schema"], "oit-lab/results/v1");
    for key in ["name", "backend", "device_type", "driver"] {
        assert!(json["adapter"][key].is_string(), "adapter.{key}");
    }
    let runs = json["runs"].as_array().unwrap();
    assert_eq!(runs.len(), scenes.len() * SORTED.len());
    for run in runs {
        assert_eq!(run["status"], "ok", "{run}");
        for key in ["scene", "scene_file", "technique"] {
            assert!(run[key].is_string(), "{key} in {run}");
        }
        assert_eq!(run["resolution"], serde_json::json!([128, 128]));
        for key in ["median", "min", "max"] {
            assert!(run["gpu_ms"][key].as_f64().unwrap() >= 0.0, "gpu_ms.{key}");
        }
        assert_eq!(run["gpu_ms"]["frames"], 2);
        assert!(matches!(
            run["gpu_ms"]["source"].as_str(),
            Some("timestamp" | "wall-clock")
        ));
        assert!(!run["passes"].as_array().unwrap().is_empty());
        for p in run["passes"].as_array().unwrap() {
            assert!(p["name"].is_string() && p["median_ms"].is_number());
        }
        for key in [
            "cpu_ms",
            "memory_bytes",
            "order_dependence",
            "cost_vs_unsorted",
            "cost_vs_floor",
            "bytes_per_pixel",
        ] {
            assert!(run[key].is_number(), "{key} in {run}");
        }
        for key in [
            "rmse",
            "psnr",
            "mean_abs",
            "max_abs",
            "over_1_255",
            "over_1_64",
            "flip_mean",
            "nonfinite",
        ] {
            assert!(run["error"][key].is_number(), "error.{key} in {run}");
        }
        assert_eq!(run["error"]["nonfinite"], 0, "non-finite pixels in {run}");
        for key in [
            "geometry_passes",
            "layers_peeled",
            "pixels_with_dropped_layers",
        ] {
            assert!(run["stats"][key].is_number(), "stats.{key}");
        }
        for key in ["exr", "render_png", "diff_png"] {
            let file = out.join(run["outputs"][key].as_str().unwrap());
            assert!(file.is_file(), "{} missing", file.display());
        }
    }
    for entry in &scenes {
        let dir = out.join(oit_harness::file_stem(&entry.scene.name));
        assert!(dir.join("reference.png").is_file() && dir.join("reference.exr").is_file());
    }
    // One floor per scene, timed like a run (opaque pass + the floor pass), and every ok run's
    // cost × floor is its median over that floor's.
    let floors = json["floors"].as_array().unwrap();
    assert_eq!(floors.len(), scenes.len());
    for (floor, entry) in results.floors.iter().zip(&scenes) {
        assert_eq!(floor.scene, entry.scene.name);
        assert_eq!(floor.gpu_ms.frames, 2);
        assert!(floor.gpu_ms.median > 0.0, "{floor:?}");
        let names: Vec<&str> = floor.passes.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["opaque", "floor"]);
        for r in results.runs.iter().filter(|r| r.scene == floor.scene) {
            let expected = r.gpu_ms.as_ref().unwrap().median / floor.gpu_ms.median;
            assert_eq!(r.cost_vs_floor, Some(expected), "{r:?}");
        }
    }
    let md = std::fs::read_to_string(out.join("results.md")).unwrap();
    assert!(md.contains("| median cost × floor |"), "{md}");
    assert!(
        md.contains("Floor (opaque pass + one vertex-colour blended pass)"),
        "{md}"
    );

    let run = |scene: &str, technique: &str| {
        results
            .runs
            .iter()
            .find(|r| r.scene == scene && r.technique == technique)
            .unwrap()
    };
    // The metrics can fail: `sorted-quads` is listed front to back, so draw order is wrong.
    let unsorted = run("sorted-quads", "unsorted");
    assert!(unsorted.error.unwrap().max_abs > 0.05, "{unsorted:?}");
    assert!(unsorted.order_dependence.unwrap() > 0.05, "{unsorted:?}");
    assert_eq!(unsorted.cost_vs_unsorted, Some(1.0));
    // ... and pass: sorting by object fixes it to the target's precision, order independently.
    let sorted = run("sorted-quads", "sorted-object");
    assert!(sorted.error.unwrap().max_abs <= 2e-3, "{sorted:?}");
    assert!(sorted.order_dependence.unwrap() <= 1e-3, "{sorted:?}");
    assert!(results.runs.iter().all(|r| r.status == RunStatus::Ok));

    // A second comparison finds every reference in the cache.
    let cached = std::fs::read_dir(&cache).unwrap().count();
    assert_eq!(cached, scenes.len(), "one cached reference per scene");
    // A rewrite is atomic (a new file renamed over the old): it changes the inode. A hit only
    // marks the file as used (its modification time, for the cache's eviction order).
    let inodes = || -> Vec<(std::ffi::OsString, u64)> {
        use std::os::unix::fs::MetadataExt;
        let mut v: Vec<_> = std::fs::read_dir(&cache)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                (e.file_name(), e.metadata().unwrap().ino())
            })
            .collect();
        v.sort();
        v
    };
    let before = inodes();
    let one = resolve_specs(&["sorted-object".to_string()]).unwrap();
    let again = compare(&ctx, &scenes[..2], &one, &options, &|_| {}).unwrap();
    assert_eq!(again.runs.len(), 2);
    // Only `unsorted` baseline timing is extra; no reference was recomputed.
    assert_eq!(before, inodes(), "cache files were rewritten");
    // The baseline was measured even though `unsorted` was not requested.
    assert!(again.runs.iter().all(|r| r.cost_vs_unsorted.is_some()));

    let _ = std::fs::remove_dir_all(&out);
    let _ = std::fs::remove_dir_all(&cache);
}

#[test]
fn unknown_option_is_rejected_before_any_gpu_work() {
    // Specs are validated before any GPU work: an unknown option is an error listing what is valid.
    let err = resolve_specs(&["sorted-object:bogus=1".to_string()])
        .unwrap_err()
        .to_string();
    assert!(err.contains("bogus"), "{err}");
}

#[test]
fn a_technique_the_adapter_cannot_run_is_skipped_with_its_reason_and_the_rest_run() {
    // llvmpipe's GL adapter cannot blend into Rg32Float: `dual-peel:depth=rg32f` must be
    // recorded as skipped, with the reason, while the other techniques still run.
    let Some(ctx) = oit_gpu::testing::gl_context_or_skip("GL compare") else {
        return;
    };
    if ctx
        .caps
        .format(oit_gpu::wgpu::TextureFormat::Rg32Float)
        .blendable
    {
        println!("skipped: this GL adapter can blend Rg32Float, nothing to skip");
        return;
    }
    let out = temp_dir("skip");
    let scenes = load_scenes(&[scenes_dir().join("enderton.json")]).unwrap();
    let specs = resolve_specs(&[
        "dual-peel:depth=rg32f".to_string(),
        "sorted-object".to_string(),
    ])
    .unwrap();
    let options = one_frame_at_32px(
        &out,
        oit_gpu::ContextOptions {
            backend: oit_gpu::Backend::Gl,
            adapter: None,
        },
    );
    let results = compare(&ctx, &scenes, &specs, &options, &|_| {}).unwrap();
    assert_eq!(results.runs.len(), 2);
    let skipped = &results.runs[0];
    assert_eq!(skipped.status, RunStatus::Skipped, "{skipped:?}");
    let reason = skipped.reason.as_deref().unwrap_or("");
    assert!(
        reason.contains("Rg32Float") || reason.contains("rg32f"),
        "{reason}"
    );
    assert!(skipped.error.is_none() && skipped.gpu_ms.is_none());
    assert_eq!(results.runs[1].status, RunStatus::Ok);
    assert!(results.runs[1].error.unwrap().max_abs < 2e-3);
    // The skip is in the written results too.
    let on_disk = Results::read(&out.join("results.json")).unwrap();
    assert_eq!(on_disk.runs[0].status, RunStatus::Skipped);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn approximate_transmission_is_flagged_and_exact_transmission_is_not() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("approximate_transmission_is_flagged") else {
        return;
    };
    let out = temp_dir("transmission");
    let scenes = load_scenes(&[scenes_dir().join("transmission-complementary.json")]).unwrap();
    let specs = resolve_specs(&[
        "sorted-object".to_string(),
        "mboit".to_string(),
        "opaque-copy".to_string(),
    ])
    .unwrap();
    let options = one_frame_at_32px(&out, Default::default());
    let results = compare(&ctx, &scenes, &specs, &options, &|_| {}).unwrap();
    let flagged = |r: &oit_harness::results::Run| {
        r.inexact
            .iter()
            .any(|p| p == oit_harness::APPROXIMATE_TRANSMISSION)
    };
    let (sorted, mboit, copy) = (&results.runs[0], &results.runs[1], &results.runs[2]);
    assert_eq!(
        flagged(sorted),
        !ctx.caps.dual_source_blending,
        "{sorted:?}"
    );
    assert!(flagged(mboit) && flagged(copy), "{mboit:?} {copy:?}");
    // The flag is earned: mboit's scalar α misses the complementary filters by far more than
    // sorted blending with dual-source blending does.
    let rmse = |r: &oit_harness::results::Run| r.error.as_ref().unwrap().rmse;
    if ctx.caps.dual_source_blending {
        assert!(
            rmse(sorted) < 1e-3 && rmse(mboit) > 0.05,
            "{} {}",
            rmse(sorted),
            rmse(mboit)
        );
    }
    let md = std::fs::read_to_string(out.join("results.md")).unwrap();
    assert!(md.contains("approximate transmission"), "{md}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_run_that_drops_layers_says_so_in_every_report() {
    // Four peeled layers of 64: every pixel loses layers. That must be a flag of the run, in
    // results.json, results.md and the terminal table, not only a statistic.
    let Some(ctx) =
        oit_gpu::testing::context_or_skip("a_run_that_drops_layers_says_so_in_every_report")
    else {
        return;
    };
    let out = temp_dir("inexact");
    let scenes = load_scenes(&[scenes_dir().join("many-layers-64.json")]).unwrap();
    let specs = resolve_specs(&[
        "front-peel:layers=4".to_string(),
        "front-peel:layers=auto".to_string(),
    ])
    .unwrap();
    let options = one_frame_at_32px(&out, Default::default());
    let results = compare(&ctx, &scenes, &specs, &options, &|_| {}).unwrap();
    let (cut, full) = (&results.runs[0], &results.runs[1]);
    let dropped = cut.stats.as_ref().unwrap().pixels_with_dropped_layers;
    assert_eq!(dropped, 32 * 32, "{cut:?}");
    assert_eq!(cut.inexact, [format!("dropped layers on {dropped} px")]);
    assert!(full.inexact.is_empty(), "{full:?}");
    let json = std::fs::read_to_string(out.join("results.json")).unwrap();
    assert!(
        json.contains("\"inexact\": [\n        \"dropped layers on 1024 px\""),
        "{json}"
    );
    let md = std::fs::read_to_string(out.join("results.md")).unwrap();
    assert!(md.contains("| dropped layers on 1024 px |"), "{md}");
    let table = oit_harness::report::terminal_table(&results);
    assert!(table.contains("dropped layers on 1024 px"), "{table}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn deep_stacks_peel_exactly_with_auto_and_flag_a_small_budget() {
    // 200 screen-filling layers (past the old 128-layer / 64-pass caps of the peelers): `auto`
    // peels all of them and is exact; a budget of 10 layers (dual: 20) cuts every pixel,
    // which the run reports as inexact.
    let Some(ctx) = oit_gpu::testing::context_or_skip("deep_stacks_peel_exactly_with_auto") else {
        return;
    };
    let out = temp_dir("deep");
    let alpha = 2.0 / 200.0;
    let scene = format!(
        r#"{{"name": "stack-200", "resolution": [16, 16],
            "camera": {{"eye": [0, 0, 10], "target": [0, 0, 0], "orthographic": {{"height": 2}},
                        "near": 0.5, "far": 30}},
            "background": [0.02, 0.02, 0.03],
            "objects": [{{"mesh": {{"kind": "layers", "count": 200, "spacing": 0.008,
                "size": [4, 4], "color_from": [1, 0.55, 0.1], "color_to": [0.1, 0.3, 1],
                "alpha_from": {alpha}, "alpha_to": {alpha}}},
              "transform": {{"translate": [0, 0, 4]}}, "material": {{"mode": "blend"}}}}]}}"#
    );
    let path = out.join("stack-200.json");
    std::fs::write(&path, scene).unwrap();
    let scenes = load_scenes(&[path]).unwrap();
    let specs = resolve_specs(&[
        "front-peel:layers=10".to_string(),
        "front-peel:layers=auto".to_string(),
        "dual-peel:passes=10,depth=rg32f".to_string(),
        "dual-peel:passes=auto,depth=rg32f".to_string(),
    ])
    .unwrap();
    let options = CompareOptions {
        resolution: None,
        ..one_frame_at_32px(&out, Default::default())
    };
    let results = compare(&ctx, &scenes, &specs, &options, &|_| {}).unwrap();
    let pixels = 16 * 16;
    for (run, peeled_per_pixel) in results.runs.iter().zip([10, 200, 20, 200]) {
        let stats = run.stats.as_ref().unwrap();
        let error = run.error.as_ref().unwrap();
        println!(
            "{}: {stats:?}, max error {:.2e}, {:?}",
            run.technique, error.max_abs, run.inexact
        );
        assert_eq!(run.resolution, [16, 16]);
        assert_eq!(stats.layers_peeled, peeled_per_pixel * pixels, "{run:?}");
        if peeled_per_pixel < 200 {
            assert_eq!(stats.pixels_with_dropped_layers, pixels, "{run:?}");
            assert_eq!(run.inexact, [format!("dropped layers on {pixels} px")]);
            assert!(error.max_abs > 0.1, "{run:?}");
        } else {
            assert_eq!(stats.pixels_with_dropped_layers, 0, "{run:?}");
            assert!(run.inexact.is_empty(), "{run:?}");
            assert!(error.max_abs <= 4e-3, "{run:?}");
        }
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// Order dependence reverses the triangles inside a draw too: `particles` is one draw of
/// 24 000 billboards, where reversing only the draw list changed nothing and `unsorted` (max
/// error 0.28) read as order independent. An exact technique still reads 0.
#[test]
fn order_dependence_sees_triangle_order_inside_one_draw() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("order_inside_a_draw") else {
        return;
    };
    let out = temp_dir("order-inside");
    let scenes = load_scenes(&[scenes_dir().join("particles.json")]).unwrap();
    assert_eq!(scenes[0].scene.draws.len(), 1, "one draw");
    let specs = resolve_specs(&["unsorted".into(), "front-peel".into()]).unwrap();
    let options = CompareOptions {
        resolution: Some(Resolution {
            width: 64,
            height: 64,
        }),
        ..one_frame_at_32px(&out, Default::default())
    };
    let results = compare(&ctx, &scenes, &specs, &options, &|_| {}).unwrap();
    let unsorted = &results.runs[0];
    assert!(unsorted.order_dependence.unwrap() > 0.05, "{unsorted:?}");
    let peel = &results.runs[1];
    assert!(peel.order_dependence.unwrap() <= 1e-3, "{peel:?}");
    let _ = std::fs::remove_dir_all(&out);
}
