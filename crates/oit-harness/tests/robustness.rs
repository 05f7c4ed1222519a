//! `compare` on hostile input and interrupted work: scene names that look like paths stay
//! inside `--out`, names that would share files are refused, two comparisons never share a
//! folder, results are on disk after every run, and `resume` reruns only what changed.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use oit_harness::results::Results;
use oit_harness::{
    CompareOptions, Event, LOCK_FILE, ReferenceCache, SceneEntry, compare, resolve_specs,
};
use oit_scene::Resolution;

/// A fresh scratch folder under the system's temp dir, removed when the test passes and kept
/// (its path printed) when it fails, to look at.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("kept {} for inspection", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

impl std::ops::Deref for TempDir {
    type Target = Path;

    fn deref(&self) -> &Path {
        &self.0
    }
}

fn temp_dir(name: &str) -> TempDir {
    let dir = std::env::temp_dir().join(format!("oit-robust-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    TempDir(dir)
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
    SceneEntry {
        path: PathBuf::from(file),
        scene: oit_scene::parse(&json, file).unwrap(),
    }
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
        reference_memory_budget: oit_reference::ReferenceOptions::DEFAULT_MEMORY_BUDGET,
        resume: false,
        retime: 0,
        context: Default::default(),
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
