//! `compare` on hostile input and interrupted work: scene names that look like paths stay
//! inside `--out`, names that would share files are refused, two comparisons never share a
//! folder, results are on disk after every run, and `resume` reruns only what changed (and
//! keeps what it was not asked to rerun). Also the classes found by trying the tool as a
//! hostile user would: warm-up extremes, names with control characters, foreign files in
//! `--out`, scenes that fail, and work that would never end.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use oit_harness::results::{Results, RunStatus};
use oit_harness::{
    CompareOptions, Event, LOCK_FILE, ReferenceCache, SceneEntry, compare, resolve_specs,
};
use oit_scene::Resolution;

fn temp_dir(name: &str) -> oit_gpu::testing::ScratchDir {
    oit_gpu::testing::ScratchDir::new(&format!("robust-{name}"))
}

/// A two-layer scene named `name`, as if loaded from `file`.
fn scene(name: &str, file: &str) -> SceneEntry {
    let json = format!(
        r#"{{
        "name": {name:?}, "description": "two layers", "resolution": [16, 16],
        "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100}},
        "background": [0.2, 0.3, 0.4],
        "objects": [
            {{"mesh": {{"kind": "quad", "size": [3, 3]}}, "material": {{"base_color": [1, 0, 0], "alpha": 0.5, "mode": "blend"}}}},
            {{"mesh": {{"kind": "quad", "size": [2, 2]}}, "transform": {{"translate": [0, 0, 0.5]}},
             "material": {{"base_color": [0, 1, 0], "alpha": 0.25, "mode": "blend"}}}}
        ]
    }}"#
    );
    SceneEntry::new(file, oit_scene::parse(&json, file).unwrap())
}

fn options(out: &Path, frames: u32) -> CompareOptions {
    CompareOptions {
        resolution: Some(Resolution {
            width: 16,
            height: 16,
        }),
        frames,
        warmup: 0,
        out_dir: out.to_path_buf(),
        cache: ReferenceCache::Off,
        ..CompareOptions::default()
    }
}

/// Every file under `dir`, relative, sorted.
fn files(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                out.push(p.strip_prefix(base).unwrap().display().to_string());
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// A scene named `..` or `/tmp/x` writes only inside `--out` (it once wrote into the parent of
/// `--out`, and outside the working directory).
#[test]
fn scene_names_that_look_like_paths_stay_inside_out() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("names_stay_inside_out") else {
        return;
    };
    let root = temp_dir("paths");
    let out = root.join("out");
    let escape = root.join("x");
    let scenes = [
        scene("..", "dots.json"),
        scene(&escape.display().to_string(), "abs.json"),
    ];
    let specs = resolve_specs(&["unsorted".into()]).unwrap();
    compare(&ctx, &scenes, &specs, &options(&out, 1), &|_| {}).unwrap();
    assert!(
        !escape.exists(),
        "wrote outside --out: {}",
        escape.display()
    );
    let outside: Vec<String> = files(&root)
        .into_iter()
        .filter(|f| !f.starts_with("out/"))
        .collect();
    assert!(outside.is_empty(), "outside --out: {outside:?}");
    let inside = files(&out);
    assert!(inside.contains(&"_./unsorted.exr".to_owned()), "{inside:?}");
    assert!(
        inside.iter().any(|f| f.ends_with("_x/unsorted.exr")),
        "{inside:?}"
    );
    assert!(
        !out.join(LOCK_FILE).exists(),
        "the lock outlived the comparison"
    );
}

/// Two scenes with one name, or names that sanitise alike, would share files: refused before
/// anything is written (it once exited 0 with one render lost).
#[test]
fn scenes_that_would_share_files_are_refused() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("colliding_names") else {
        return;
    };
    let root = temp_dir("collide");
    let out = root.join("out");
    let specs = resolve_specs(&["unsorted".into()]).unwrap();
    for (a, b) in [("same", "same"), ("a/b", "a:b"), ("Case", "case")] {
        let scenes = [scene(a, "first.json"), scene(b, "second.json")];
        let err = compare(&ctx, &scenes, &specs, &options(&out, 1), &|_| {})
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("second.json") && err.contains("first.json"),
            "{a} / {b}: {err}"
        );
        assert!(!out.exists() || files(&out).is_empty(), "{:?}", files(&out));
    }
}

/// A folder held by a running comparison is refused; a lock left by a killed one is taken
/// over.
#[test]
fn two_comparisons_never_share_an_output_folder() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("output_lock") else {
        return;
    };
    let out = temp_dir("lock");
    let scenes = [scene("locked", "locked.json")];
    let specs = resolve_specs(&["unsorted".into()]).unwrap();
    // pid 1 always runs.
    std::fs::write(out.join(LOCK_FILE), "1").unwrap();
    let err = compare(&ctx, &scenes, &specs, &options(&out, 1), &|_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("pid 1") && err.contains("--out"), "{err}");
    assert!(!out.join("results.json").exists());
    // PIDs stop at 2^22 on Linux: this holder was killed.
    std::fs::write(out.join(LOCK_FILE), "999999999").unwrap();
    compare(&ctx, &scenes, &specs, &options(&out, 1), &|_| {}).unwrap();
    assert!(out.join("results.json").exists());
    assert!(!out.join(LOCK_FILE).exists());
}

/// results.json is on disk, complete so far, after every run; `resume` keeps the finished runs
/// made from identical inputs and runs only the new technique, and different frames rerun all.
#[test]
fn results_are_written_after_every_run_and_resume_reruns_only_what_changed() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("incremental_and_resume") else {
        return;
    };
    let out = temp_dir("resume");
    let scenes = [scene("resumable", "resumable.json")];
    let two = resolve_specs(&["unsorted".into(), "sorted-object".into()]).unwrap();
    let on_disk = RefCell::new(Vec::new());
    let first = compare(&ctx, &scenes, &two, &options(&out, 1), &|event| {
        if let Event::RunDone { .. } = event {
            let r = Results::read(&out.join("results.json")).expect("results.json after a run");
            on_disk.borrow_mut().push(r.runs.len());
        }
    })
    .unwrap();
    assert_eq!(on_disk.into_inner(), [1, 2]);
    assert!(first.runs.iter().all(|r| !r.resumed && r.inputs.is_some()));

    let three = resolve_specs(&[
        "unsorted".into(),
        "sorted-object".into(),
        "sorted-triangle".into(),
    ])
    .unwrap();
    let kept = RefCell::new(Vec::new());
    let resume = CompareOptions {
        resume: true,
        ..options(&out, 1)
    };
    let second = compare(&ctx, &scenes, &three, &resume, &|event| {
        if let Event::RunDone {
            technique, resumed, ..
        } = event
        {
            kept.borrow_mut().push((technique.to_owned(), resumed));
        }
    })
    .unwrap();
    assert_eq!(
        kept.into_inner(),
        [
            ("unsorted".to_owned(), true),
            ("sorted-object".to_owned(), true),
            ("sorted-triangle".to_owned(), false),
        ]
    );
    for (a, b) in first.runs.iter().zip(&second.runs) {
        assert_eq!(a.gpu_ms, b.gpu_ms, "{} was rerun", a.technique);
    }
    // New frames are new inputs: nothing is kept.
    let other_frames = CompareOptions {
        resume: true,
        ..options(&out, 2)
    };
    let third = compare(&ctx, &scenes, &three, &other_frames, &|_| {}).unwrap();
    assert!(third.runs.iter().all(|r| !r.resumed));
    assert!(
        third.complete && third.tool.is_some(),
        "the build that made it is recorded"
    );
}

/// `--resume` with another technique list keeps the earlier runs it was not asked for (a
/// comparison grows one technique at a time) and says what it did; runs made by another
/// build of oit are made again, never mixed in.
#[test]
fn resume_keeps_unrequested_runs_and_reruns_another_builds() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("resume_changed_inputs") else {
        return;
    };
    let out = temp_dir("resume-merge");
    let scenes = [scene("merged", "merged.json")];
    let first_specs = resolve_specs(&["unsorted".into(), "sorted-object".into()]).unwrap();
    compare(&ctx, &scenes, &first_specs, &options(&out, 1), &|_| {}).unwrap();
    let resume = CompareOptions {
        resume: true,
        ..options(&out, 1)
    };
    let added = resolve_specs(&["wboit".into()]).unwrap();
    let notices = RefCell::new(Vec::new());
    let second = compare(&ctx, &scenes, &added, &resume, &|event| {
        if let Event::Notice(line) = event {
            notices.borrow_mut().push(line.to_owned());
        }
    })
    .unwrap();
    let techniques: Vec<&str> = second.runs.iter().map(|r| r.technique.as_str()).collect();
    assert_eq!(
        techniques,
        [
            "wboit:accum=rgba16f,reveal=r16f,weight=range",
            "unsorted",
            "sorted-object"
        ]
    );
    assert!(second.runs[1].resumed && second.runs[2].resumed);
    assert!(
        second.runs.iter().all(|r| r.cost_vs_floor.is_some()),
        "kept runs are priced against this comparison's floor"
    );
    let said = notices.into_inner().join("\n");
    assert!(
        said.contains("1 runs made now") && said.contains("2 of techniques not requested now kept"),
        "{said}"
    );
    let on_disk = Results::read(&out.join("results.json")).unwrap();
    assert_eq!(on_disk.runs.len(), 3);

    // Another build made the file: nothing of it is reused.
    let text = std::fs::read_to_string(out.join("results.json")).unwrap();
    let build = &on_disk.tool.as_ref().unwrap().build;
    std::fs::write(
        out.join("results.json"),
        text.replace(build.as_str(), "0123456789abcdef"),
    )
    .unwrap();
    let notices = RefCell::new(Vec::new());
    let third = compare(&ctx, &scenes, &first_specs, &resume, &|event| {
        if let Event::Notice(line) = event {
            notices.borrow_mut().push(line.to_owned());
        }
    })
    .unwrap();
    assert!(third.runs.iter().all(|r| !r.resumed), "{:?}", third.runs);
    assert_eq!(third.runs.len(), 2);
    let said = notices.into_inner().join("\n");
    assert!(said.contains("3 earlier runs dropped"), "{said}");
}

/// A results.json in `--out` that is not ours is refused, not replaced; ours is replaced with
/// a notice that says `--resume` would have kept it.
#[test]
fn a_foreign_results_file_is_never_replaced() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("foreign_results") else {
        return;
    };
    let out = temp_dir("foreign");
    let specs = resolve_specs(&["unsorted".into()]).unwrap();
    let scenes = [scene("foreign", "foreign.json")];
    for foreign in [r#"{"schema": "x"}"#, "[1, 2, 3]", "not json"] {
        std::fs::write(out.join("results.json"), foreign).unwrap();
        let err = compare(&ctx, &scenes, &specs, &options(&out, 1), &|_| {})
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("results.json") && err.contains("not replaced"),
            "{foreign}: {err}"
        );
        assert_eq!(
            std::fs::read_to_string(out.join("results.json")).unwrap(),
            foreign
        );
    }
    std::fs::remove_file(out.join("results.json")).unwrap();
    compare(&ctx, &scenes, &specs, &options(&out, 1), &|_| {}).unwrap();
    let notices = RefCell::new(Vec::new());
    compare(&ctx, &scenes, &specs, &options(&out, 1), &|event| {
        if let Event::Notice(line) = event {
            notices.borrow_mut().push(line.to_owned());
        }
    })
    .unwrap();
    let said = notices.into_inner().join("\n");
    assert!(
        said.contains("replaced") && said.contains("--resume"),
        "{said}"
    );
}

/// Control characters in a scene's name never reach the terminal or break a results.md
/// table: they are shown escaped, and every table row keeps its cells.
#[test]
fn names_with_control_characters_are_shown_escaped() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("control_names") else {
        return;
    };
    let out = temp_dir("control");
    let name = "evil\u{1b}[2J|\nname\u{7}";
    let specs = resolve_specs(&["unsorted".into(), "sorted-object".into()]).unwrap();
    let mut evil = scene("evil", "evil.json");
    evil.scene.name = name.into();
    let results = compare(&ctx, &[evil], &specs, &options(&out, 1), &|_| {}).unwrap();
    let table = oit_harness::report::terminal_table(&results);
    assert!(
        !table.chars().any(|c| c.is_control() && c != '\n'),
        "{table:?}"
    );
    assert!(table.contains("\\u{1b}"), "{table}");
    let md = std::fs::read_to_string(out.join("results.md")).unwrap();
    assert!(!md.chars().any(|c| c.is_control() && c != '\n'), "{md:?}");
    // Every row of the per-run table has the header's twelve cell borders.
    let header = "| technique | GPU ms |";
    let rows: Vec<&str> = md
        .lines()
        .skip_while(|l| !l.starts_with(header))
        .take_while(|l| l.starts_with('|'))
        .collect();
    assert_eq!(rows.len(), 4, "{md}");
    for row in rows {
        assert_eq!(row.replace("\\|", "").matches('|').count(), 12, "{row}");
    }
}

/// Warm-up extremes: far past any use is refused before anything is built, and with none the
/// first frame (pipelines and shaders built, caches cold) is still never timed.
#[test]
fn warm_up_extremes_are_refused_or_never_time_the_first_frame() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("warmup_extremes") else {
        return;
    };
    let out = temp_dir("warmup");
    let specs = resolve_specs(&["unsorted".into()]).unwrap();
    let huge = CompareOptions {
        warmup: u32::MAX,
        ..options(&out, 1)
    };
    let start = std::time::Instant::now();
    let err = compare(&ctx, &[scene("w", "w.json")], &specs, &huge, &|_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("warmup") && err.contains("1000"), "{err}");
    assert!(start.elapsed().as_secs() < 5);

    // A technique whose first frame is forty times the work of the others.
    let scene = oit_scene::load(&scenes_dir().join("many-layers-64.json"))
        .unwrap()
        .with_resolution(Resolution {
            width: 64,
            height: 64,
        });
    let gpu_scene = oit_gpu::GpuScene::upload(&ctx, &scene).unwrap();
    let targets =
        oit_gpu::Targets::new(&ctx, scene.resolution, oit_gpu::ColorFormat::Rgba16Float).unwrap();
    let mut heavy = HeavyFirstFrame {
        inner: oit_gpu::DrawOrderBlend::with(oit_gpu::BlendShading::Material),
        frames: 0,
    };
    let options = CompareOptions {
        frames: 5,
        warmup: 0,
        ..options(&out, 5)
    };
    let (gpu, _, _) =
        oit_harness::time_technique(&ctx, &gpu_scene, &mut heavy, &targets, &options).unwrap();
    assert_eq!(
        heavy.frames,
        1 + 5,
        "one untimed first frame, then the timed ones"
    );
    assert!(
        gpu.max < 10.0 * gpu.median,
        "the heavy first frame was timed: {gpu:?}"
    );
}

/// Renders its inner technique forty times in its first frame, once in every later one.
#[derive(Debug)]
struct HeavyFirstFrame {
    inner: oit_gpu::DrawOrderBlend,
    frames: u32,
}

impl oit_gpu::Technique for HeavyFirstFrame {
    fn spec(&self) -> oit_gpu::TechniqueSpec {
        self.inner.spec()
    }
    fn check(&self, caps: &oit_gpu::Caps) -> Result<(), oit_gpu::Unsupported> {
        self.inner.check(caps)
    }
    fn predict(
        &self,
        _: &oit_scene::Scene,
        _: &oit_gpu::predict::PixelLists,
        _: &oit_gpu::Caps,
    ) -> oit_gpu::Prediction {
        oit_gpu::Prediction::unmodelled("a test technique")
    }
    fn render(
        &mut self,
        ctx: &oit_gpu::Context,
        scene: &oit_gpu::GpuScene,
        targets: &oit_gpu::Targets,
        timer: &mut oit_gpu::GpuTimer,
    ) -> Result<oit_gpu::RenderStats, oit_gpu::GpuError> {
        let repeats = if self.frames == 0 { 40 } else { 1 };
        self.frames += 1;
        let mut stats = Default::default();
        for _ in 0..repeats {
            stats = self.inner.render(ctx, scene, targets, timer)?;
        }
        Ok(stats)
    }
    fn memory_bytes(&self) -> u64 {
        self.inner.memory_bytes()
    }
    fn transmission(&self, caps: &oit_gpu::Caps) -> oit_gpu::Support {
        self.inner.transmission(caps)
    }
    fn operator(&self, op: oit_scene::BlendOperator, caps: &oit_gpu::Caps) -> oit_gpu::Support {
        self.inner.operator(op, caps)
    }
}

fn scenes_dir() -> PathBuf {
    crate::kit::scenes_dir()
}

/// Runaway work is bounded: a peeling technique whose passes for the scene's depth
/// complexity cannot fit the run budget is skipped before it starts, with the estimate; any
/// run still going when its budget runs out stops; a scene whose images cannot fit the memory
/// budget fails with what it needs while the next scene runs.
#[test]
fn runaway_work_stops_within_its_budgets_and_the_comparison_goes_on() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("runaway") else {
        return;
    };
    let out = temp_dir("runaway");
    // 300 screen-filling layers.
    let deep = SceneEntry::new(
        "deep.json",
        oit_scene::parse(
            r#"{"name": "deep", "description": "", "resolution": [16, 16],
            "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100},
            "background": [0, 0, 0],
            "objects": [{"mesh": {"kind": "quad", "size": [20, 20]},
                "material": {"base_color": [1, 1, 1], "alpha": 0.01, "mode": "blend"},
                "instances": {"counts": [1, 1, 300], "spacing": [0, 0, -0.001]}}]}"#,
            "deep.json",
        )
        .unwrap(),
    );
    let specs = resolve_specs(&["front-peel".into()]).unwrap();
    // With room, it runs: the estimate is what decides, not the technique.
    let roomy = CompareOptions {
        run_budget: std::time::Duration::from_secs(600),
        ..options(&out, 1)
    };
    let results = compare(&ctx, std::slice::from_ref(&deep), &specs, &roomy, &|_| {}).unwrap();
    assert_eq!(
        results.runs[0].status,
        RunStatus::Ok,
        "{:?}",
        results.runs[0]
    );
    // A tenth of what 301 floor passes take in each of its three frames (first, timed,
    // reversed) on this adapter: skipped before it starts.
    let floor_ms = results.floors[0].gpu_ms.median;
    let tight = CompareOptions {
        run_budget: std::time::Duration::from_secs_f64(301.0 * floor_ms * 1e-3 * 3.0 / 10.0),
        ..options(&out, 1)
    };
    let results = compare(&ctx, std::slice::from_ref(&deep), &specs, &tight, &|_| {}).unwrap();
    let peel = &results.runs[0];
    assert_eq!(peel.status, RunStatus::Skipped, "{peel:?}");
    let reason = peel.reason.as_deref().unwrap();
    assert!(
        reason.contains("301 geometry passes") && reason.contains("depth complexity 300"),
        "{reason}"
    );

    // Past its budget, a run stops at its next submission.
    let mut technique = oit_gpu::DrawOrderBlend::with(oit_gpu::BlendShading::Material);
    let gpu_scene = oit_gpu::GpuScene::upload(&ctx, &deep.scene).unwrap();
    let targets = oit_gpu::Targets::new(
        &ctx,
        deep.scene.resolution,
        oit_gpu::ColorFormat::Rgba16Float,
    )
    .unwrap();
    let over = CompareOptions {
        run_budget: std::time::Duration::ZERO,
        ..options(&out, 1)
    };
    let err = oit_harness::time_technique(&ctx, &gpu_scene, &mut technique, &targets, &over)
        .unwrap_err()
        .to_string();
    assert!(err.contains("--run-budget"), "{err}");

    // A scene too large for the memory budget fails alone, naming what it needs.
    let big = SceneEntry::new(
        "big.json",
        deep.scene.with_resolution(Resolution {
            width: 2048,
            height: 2048,
        }),
    );
    let mut renamed = big.clone();
    renamed.scene.name = "big".into();
    let small = scene("small", "small.json");
    let budget = CompareOptions {
        resolution: None,
        memory_budget: 256 << 20,
        ..options(&out, 1)
    };
    let unsorted = resolve_specs(&["unsorted".into()]).unwrap();
    let mut small16 = small.clone();
    small16.scene = small.scene.with_resolution(Resolution {
        width: 16,
        height: 16,
    });
    let results = compare(&ctx, &[renamed, small16], &unsorted, &budget, &|_| {}).unwrap();
    assert_eq!(results.runs[0].status, RunStatus::Failed);
    let reason = results.runs[0].reason.as_deref().unwrap();
    assert!(
        reason.contains("big") && reason.contains("--memory-budget") && reason.contains("MiB"),
        "{reason}"
    );
    assert_eq!(results.runs[1].status, RunStatus::Ok, "the next scene runs");
}

/// A comparison stopped from outside (Ctrl-C) writes what it finished, says it is incomplete,
/// and every finished run has its cost ratios: the floor is timed before the runs.
#[test]
fn an_interrupted_comparison_keeps_finished_runs_with_their_ratios() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("interrupted") else {
        return;
    };
    let out = temp_dir("interrupt");
    let cancel = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let options = CompareOptions {
        cancel: Some(cancel.clone()),
        ..options(&out, 1)
    };
    let specs =
        resolve_specs(&["unsorted".into(), "sorted-object".into(), "wboit".into()]).unwrap();
    let scenes = [scene("first", "first.json"), scene("second", "second.json")];
    let results = compare(&ctx, &scenes, &specs, &options, &|event| {
        if let Event::RunDone { .. } = event {
            let on_disk = Results::read(&out.join("results.json")).unwrap();
            assert!(!on_disk.complete, "complete while running");
            for run in &on_disk.runs {
                assert!(
                    run.cost_vs_floor.is_some(),
                    "{} has no ratio",
                    run.technique
                );
            }
            if on_disk.runs.len() == 2 {
                cancel.store(true, std::sync::atomic::Ordering::SeqCst);
            }
        }
    })
    .unwrap();
    assert!(!results.complete);
    assert_eq!(results.runs.len(), 2);
    let on_disk = Results::read(&out.join("results.json")).unwrap();
    assert!(!on_disk.complete && on_disk.runs.len() == 2);
    // --resume finishes it.
    let resume = CompareOptions {
        resume: true,
        ..options_without_cancel(&out)
    };
    let finished = compare(&ctx, &scenes, &specs, &resume, &|_| {}).unwrap();
    assert!(finished.complete);
    assert_eq!(finished.runs.len(), 6);
    assert_eq!(finished.runs.iter().filter(|r| r.resumed).count(), 2);
}

fn options_without_cancel(out: &Path) -> CompareOptions {
    options(out, 1)
}

/// One scene whose reference fails and one file that does not load end nothing: their runs
/// fail with a reason naming them, and the other scenes run.
#[test]
fn a_failing_scene_never_ends_the_comparison() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("failing_scene") else {
        return;
    };
    let out = temp_dir("failing");
    // 60 000 layers within the tie distance on every pixel: the reference must hold them all,
    // more than 1 MiB for one pixel.
    let tied = SceneEntry::new(
        "tied.json",
        oit_scene::parse(
            r#"{"name": "tied", "description": "", "resolution": [16, 16],
            "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100},
            "background": [0, 0, 0],
            "objects": [{"mesh": {"kind": "quad", "size": [20, 20]},
                "material": {"base_color": [1, 1, 1], "alpha": 0.01, "mode": "blend"},
                "instances": {"counts": [1, 1, 60000], "spacing": [0, 0, -0.000001]}}]}"#,
            "tied.json",
        )
        .unwrap(),
    );
    let unloadable = [oit_harness::Unloadable {
        path: PathBuf::from("broken.json"),
        error: "broken.json: objects[0].material.alpha: 1.5 is not in 0..=1".into(),
    }];
    let specs = resolve_specs(&["unsorted".into()]).unwrap();
    let tight = CompareOptions {
        memory_budget: 16 * 16 * oit_harness::RUN_BYTES_PER_PIXEL + (1 << 20),
        ..options(&out, 1)
    };
    let warnings = RefCell::new(Vec::new());
    let results = oit_harness::compare_all(
        &ctx,
        &[tied, scene("fine", "fine.json")],
        &unloadable,
        &specs,
        &tight,
        &|event| {
            if let Event::Warning(line) = event {
                warnings.borrow_mut().push(line.to_owned());
            }
        },
    )
    .unwrap();
    let status: Vec<(&str, RunStatus)> = results
        .runs
        .iter()
        .map(|r| (r.scene.as_str(), r.status))
        .collect();
    assert_eq!(
        status,
        [
            ("tied", RunStatus::Failed),
            ("fine", RunStatus::Ok),
            ("broken", RunStatus::Failed)
        ]
    );
    assert!(
        results.runs[0]
            .reason
            .as_deref()
            .unwrap()
            .contains("scene tied (tied.json)")
    );
    assert!(
        results.runs[2]
            .reason
            .as_deref()
            .unwrap()
            .contains("objects[0].material.alpha")
    );
    assert!(warnings.into_inner().iter().any(|w| w.contains("tied")));
    assert!(results.complete);
}

#[test]
fn zero_frames_is_an_error() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("zero_frames") else {
        return;
    };
    let out = temp_dir("frames0");
    let specs = resolve_specs(&["unsorted".into()]).unwrap();
    let err = compare(
        &ctx,
        &[scene("frames", "frames.json")],
        &specs,
        &options(&out, 0),
        &|_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("frames"), "{err}");
}
