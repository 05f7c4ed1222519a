//! One scene's failure is that scene's failed runs, never the end of a comparison: a folder
//! with a malformed scene, a JSON file that is not a scene, a scene whose upload is over the
//! memory budget and a technique whose buffers are, each followed by good scenes in file-name
//! order. Every failure is a failed run with its reason in results.json, results.md, the
//! terminal table and report.html; the other runs are made; a GPU error inside one piece of
//! work does not poison the next.

use std::path::Path;

use oit_harness::results::{Results, RunStatus};
use oit_harness::{CompareOptions, compare_all, load_scenes_lenient, resolve_specs};

fn temp_dir(name: &str) -> oit_gpu::testing::ScratchDir {
    oit_gpu::testing::ScratchDir::new(&format!("failures-{name}"))
}

/// A still scene of `mesh` at 32², seen from the front.
fn scene_json(name: &str, mesh: &str) -> String {
    format!(
        r#"{{"name": "{name}", "resolution": [32, 32],
            "camera": {{"eye": [0, 0, 4], "target": [0, 0, 0], "fov_y": 45, "near": 0.1, "far": 100}},
            "objects": [{{"mesh": {mesh},
                "material": {{"base_color": [0.2, 0.8, 0.3], "alpha": 0.5, "mode": "blend"}}}}]}}"#
    )
}

const LAYERS: &str = r#"{"kind": "layers", "count": 4, "spacing": 0.1, "size": [2, 2],
    "color_from": [1, 0, 0], "color_to": [0, 0, 1], "alpha_from": 0.5, "alpha_to": 0.5}"#;

/// 40 000 triangles: 4.6 MiB of vertices a copy, far over a 2 MiB budget.
const DENSE_SPHERE: &str = r#"{"kind": "uv-sphere", "radius": 1, "segments": 200, "rings": 100}"#;

/// The folder, in file-name order: good, malformed, good, not a scene, dense (over budget),
/// good.
fn failing_folder(dir: &Path) {
    let files = [
        ("a-good.json", scene_json("a-good", LAYERS)),
        (
            "b-malformed.json",
            r#"{"name": "b-malformed", "camera": {"eye": [0, 0, 4], "target": [0, 0, 0]}, "objects": 3}"#.to_owned(),
        ),
        ("c-good.json", scene_json("c-good", LAYERS)),
        (
            "d-metadata.json",
            r#"{"version": 2, "legal": [{"license": "CC0"}]}"#.to_owned(),
        ),
        ("e-dense.json", scene_json("e-dense", DENSE_SPHERE)),
        ("f-good.json", scene_json("f-good", LAYERS)),
    ];
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
}

/// 256 nodes a pixel at 32²: megabytes of node pool, over the budget the good scenes fit.
const GREEDY: &str = "linked-list:nodes-per-pixel=256";

#[test]
fn failed_scenes_and_runs_are_reported_and_the_rest_run() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("failed_scenes_and_runs_are_reported") else {
        return;
    };
    let scenes_dir = temp_dir("scenes");
    failing_folder(&scenes_dir);
    let out = temp_dir("out");
    let (scenes, unloadable, skipped) =
        load_scenes_lenient(&[scenes_dir.to_path_buf()], &Default::default()).unwrap();
    let names: Vec<&str> = scenes.iter().map(|e| e.scene.name.as_str()).collect();
    assert_eq!(names, ["a-good", "c-good", "e-dense", "f-good"]);
    assert_eq!(unloadable.len(), 1);
    assert!(unloadable[0].path.ends_with("b-malformed.json"));
    assert_eq!(skipped.len(), 1, "{skipped:?}");
    assert!(skipped[0].path.ends_with("d-metadata.json"));
    assert!(skipped[0].note().starts_with("skipped: not a scene: "));

    let specs = resolve_specs(&["unsorted".to_owned(), GREEDY.to_owned()]).unwrap();
    let budget = 2u64 << 20;
    let options = CompareOptions {
        frames: 1,
        warmup: 0,
        out_dir: out.to_path_buf(),
        cache: oit_harness::ReferenceCache::Off,
        memory_budget: budget,
        predict: false,
        ..CompareOptions::default()
    };
    let warnings = std::sync::Mutex::new(Vec::new());
    let results = compare_all(&ctx, &scenes, &unloadable, &specs, &options, &|event| {
        if let oit_harness::Event::Warning(line) = event {
            warnings.lock().unwrap().push(line.to_owned());
        }
    })
    .expect("failures are runs, not the comparison's end");
    assert!(results.complete);
    // The context keeps one module per source and one pipeline per description: the same
    // comparison again makes nothing new (oit_gpu::made).
    let (forms, made) = (ctx.shader_forms(), ctx.made_objects());
    assert!(forms > 0 && made > 0);
    let again_dir = temp_dir("again");
    let again = CompareOptions {
        out_dir: again_dir.to_path_buf(),
        ..options.clone()
    };
    compare_all(&ctx, &scenes, &unloadable, &specs, &again, &|_| {}).unwrap();
    assert_eq!((ctx.shader_forms(), ctx.made_objects()), (forms, made));
    let run = |scene: &str, technique: &str| {
        (results.runs.iter())
            .find(|r| r.scene == scene && r.technique.starts_with(technique))
            .unwrap_or_else(|| panic!("no run of {technique} on {scene}"))
    };
    // Every good scene ran unsorted, and each refused the greedy list with its need in MiB.
    for scene in ["a-good", "c-good", "f-good"] {
        let ok = run(scene, "unsorted");
        assert_eq!(ok.status, RunStatus::Ok, "{ok:?}");
        assert!(ok.error.is_some());
        let refused = run(scene, "linked-list");
        assert_eq!(refused.status, RunStatus::Failed, "{refused:?}");
        let reason = refused.reason.as_deref().unwrap();
        assert!(reason.contains("of the technique's buffers"), "{reason}");
        assert!(
            reason.contains("more than --memory-budget 2.0 MiB; raise --memory-budget to at least"),
            "{reason}"
        );
        assert!(reason.contains(" MiB"), "{reason}");
    }
    // The dense scene fails both runs before anything is uploaded, saying why.
    for technique in ["unsorted", "linked-list"] {
        let failed = run("e-dense", technique);
        assert_eq!(failed.status, RunStatus::Failed, "{failed:?}");
        let reason = failed.reason.as_deref().unwrap();
        assert!(reason.contains("scene e-dense needs"), "{reason}");
        assert!(
            reason.contains("of the scene's GPU upload (2 copies"),
            "{reason}"
        );
        assert!(reason.contains("--memory-budget 2.0 MiB"), "{reason}");
    }
    // The malformed file's runs fail with the loader's message; the metadata has none.
    let malformed: Vec<_> = (results.runs.iter())
        .filter(|r| r.scene_file.ends_with("b-malformed.json"))
        .collect();
    assert_eq!(malformed.len(), 2);
    for r in &malformed {
        assert_eq!(r.status, RunStatus::Failed);
        assert!(r.reason.as_deref().unwrap().contains("objects"), "{r:?}");
    }
    assert!(
        !results
            .runs
            .iter()
            .any(|r| r.scene_file.contains("metadata"))
    );
    assert_eq!(results.runs.len(), 5 * specs.len());
    assert!(
        (warnings.lock().unwrap().iter()).any(|w| w.contains("e-dense")),
        "the scene's failure is also a warning"
    );
    // Each scene that ran has its peak memory (Linux), at least what its upload took.
    for s in &results.scenes {
        if cfg!(target_os = "linux") {
            let peak = s.peak_memory_bytes.unwrap_or_else(|| panic!("{}", s.scene));
            assert!(peak > s.scene_bytes, "{}: {peak}", s.scene);
        }
    }

    // Every output says it: results.json, results.md, the terminal table, report.html.
    let on_disk = Results::read(&out.join("results.json")).unwrap();
    assert_eq!(on_disk, results);
    let markdown = std::fs::read_to_string(out.join("results.md")).unwrap();
    let table = oit_harness::report::terminal_table(&results);
    let html_path =
        oit_report::write_html_report(&out, oit_report::Metric::Flip, &|t| t.to_owned()).unwrap();
    let html = std::fs::read_to_string(html_path).unwrap();
    for (name, text) in [
        ("results.md", &markdown),
        ("table", &table),
        ("html", &html),
    ] {
        assert!(text.contains("scene e-dense needs"), "{name}:\n{text}");
        assert!(
            text.contains("of the technique&#39;s buffers")
                || text.contains("of the technique's buffers"),
            "{name}"
        );
        assert!(text.contains("b-malformed"), "{name}");
        assert!(text.contains("f-good"), "{name}");
    }
    assert!(markdown.contains("Peak memory: ") == cfg!(target_os = "linux"));
    let _ = std::fs::remove_dir_all(&scenes_dir);
    let _ = std::fs::remove_dir_all(&out);
}

/// A validation error inside contained work fails that work with wgpu's message, and the same
/// device then renders the next scene as if nothing happened.
#[test]
fn a_gpu_error_fails_its_work_and_not_the_next() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("a_gpu_error_fails_its_work") else {
        return;
    };
    let bad = ctx.contain("the run", || {
        // Mapped at creation with a size that is not a multiple of 4: invalid.
        let _buffer = ctx.device.create_buffer(&oit_gpu::wgpu::BufferDescriptor {
            label: Some("invalid on purpose"),
            size: 3,
            usage: oit_gpu::wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: true,
        });
        Ok::<_, oit_gpu::GpuError>(())
    });
    match bad {
        Err(oit_gpu::ContainedError::Device(e)) => {
            let text = e.to_string();
            assert!(
                text.starts_with("the run stopped: the GPU reported "),
                "{text}"
            );
            assert!(!text.contains('\n'), "{text}");
        }
        other => panic!("expected a device error, got {other:?}"),
    }
    let panicked = ctx.contain("the run", || -> Result<(), oit_gpu::GpuError> {
        panic!("a technique's bug")
    });
    match panicked {
        Err(oit_gpu::ContainedError::Device(e)) => {
            assert_eq!(
                e.to_string(),
                "the run stopped: it panicked: a technique's bug"
            );
        }
        other => panic!("expected the panic as an error, got {other:?}"),
    }
    let scene = oit_scene::parse(&scene_json("after", LAYERS), "after.json").unwrap();
    let spec = oit_harness::parse_spec("unsorted").unwrap();
    let frame = ctx
        .contain("the next run", || {
            oit_harness::render_once(&ctx, &scene, &spec)
        })
        .expect("the device still works");
    let reference = oit_reference::render(&scene, &Default::default());
    let error = crate::kit::max_relative_rgb(&frame.image, &reference.image);
    assert!(error < 0.6, "unsorted renders the scene: {error}");
    // Not just the black background: the layers are there.
    let lit = |p: &[f32; 4]| p[0] + p[1] + p[2] > 0.05;
    assert!(frame.image.pixels.iter().any(lit));
    assert!(reference.image.pixels.iter().any(lit));
}
