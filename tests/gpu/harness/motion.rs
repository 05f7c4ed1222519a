//! Motion: `compare` on animated scenes sees what happens between frames. Per-object sorting
//! pops where (and only where) its sort keys swap, computed here from the geometry; exact
//! techniques are exact on every frame, on the bundled motion scenes and on seeded random
//! animated scenes; weighted blending is biased but noiseless at a static camera, stochastic
//! transparency noisy and flickering.

use std::path::PathBuf;

use oit_harness::results::{Run, RunStatus, Temporal};
use oit_harness::{CompareOptions, compare, load_scenes, render_once, resolve_specs};

const EXACT: [&str; 2] = [
    "front-peel:layers=auto",
    "dual-peel:passes=auto,depth=rg32f",
];

fn motion_scene(name: &str) -> PathBuf {
    crate::kit::scenes_dir()
        .join("motion")
        .join(format!("{name}.json"))
}

/// A fresh folder per call: tests running side by side measure the same motion scenes, and one
/// removing the other's folder took its reference cache and clips away mid-run.
fn temp_dir(name: &str) -> oit_gpu::testing::ScratchDir {
    oit_gpu::testing::ScratchDir::new(&format!("motion-{name}"))
}

/// Runs `techniques` over every frame of the motion scene `name` (one timed frame, no
/// warm-up), with `static_frames` renders at its static camera.
fn motion_runs(
    ctx: &oit_gpu::Context,
    name: &str,
    techniques: &[&str],
    static_frames: u32,
) -> Vec<Run> {
    motion_runs_of(ctx, &motion_scene(name), techniques, static_frames)
}

/// [`motion_runs`] of the scene file at `path`.
fn motion_runs_of(
    ctx: &oit_gpu::Context,
    path: &std::path::Path,
    techniques: &[&str],
    static_frames: u32,
) -> Vec<Run> {
    let name = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let out = temp_dir(&name);
    let scenes = load_scenes(&[path.to_path_buf()]).expect("motion scene");
    assert!(scenes[0].frames.is_some(), "{name} is animated");
    let specs = resolve_specs(&techniques.iter().map(|t| t.to_string()).collect::<Vec<_>>())
        .expect("specs");
    let options = CompareOptions {
        frames: 1,
        warmup: 0,
        out_dir: out.to_path_buf(),
        cache: oit_harness::ReferenceCache::Dir(out.join("cache")),
        static_frames,
        ..CompareOptions::default()
    };
    let results = compare(ctx, &scenes, &specs, &options, &|_| {}).expect("compare");
    let _ = std::fs::remove_dir_all(&out);
    results.runs
}

/// The temporal block of `technique`'s run (any spec form: it is made canonical first).
fn temporal<'a>(runs: &'a [Run], technique: &str) -> &'a Temporal {
    let canonical = resolve_specs(&[technique.to_string()]).expect("spec")[0].canonical();
    let run = runs
        .iter()
        .find(|r| r.technique == canonical)
        .unwrap_or_else(|| panic!("no run of {technique}"));
    assert_eq!(run.status, RunStatus::Ok, "{technique}: {:?}", run.reason);
    run.temporal
        .as_ref()
        .unwrap_or_else(|| panic!("{technique} has no temporal block"))
}

#[test]
fn sort_swap_pops_only_where_the_sort_keys_swap() {
    let Some(ctx) =
        oit_gpu::testing::context_or_skip("sort_swap_pops_only_where_the_sort_keys_swap")
    else {
        return;
    };
    // The frames where per-object sorting's order changes, from the geometry: the draws'
    // bounding-sphere centres and each frame's eye, as `Scene::babylon_object_order` sorts.
    let (frames, _) =
        oit_scene::load_frames(&motion_scene("motion-sort-swap"), &Default::default())
            .expect("loads");
    let orders: Vec<Vec<usize>> = (0..frames.count())
        .map(|t| frames.frame(t).expect("frame").babylon_object_order())
        .collect();
    let swaps: Vec<u32> = (1..frames.count())
        .filter(|&t| orders[t as usize] != orders[t as usize - 1])
        .collect();
    assert_eq!(
        swaps.len(),
        1,
        "the scene swaps its sort keys once: {swaps:?}"
    );
    let swap = swaps[0];

    let runs = motion_runs(
        &ctx,
        "motion-sort-swap",
        &["sorted-object", "sorted-triangle", EXACT[0], EXACT[1]],
        0,
    );
    let object = temporal(&runs, "sorted-object");
    assert_eq!(object.frames.len() as u32, frames.count());
    assert!(
        !object.pop_events.is_empty() && object.pop_events.iter().all(|&f| f.abs_diff(swap) <= 1),
        "sorted-object pops at {:?}, its keys swap at frame {swap}",
        object.pop_events
    );
    assert!(object.flicker > 0.0);
    for technique in ["sorted-triangle", EXACT[0], EXACT[1]] {
        let t = temporal(&runs, technique);
        assert!(
            t.pop_events.is_empty(),
            "{technique} pops at {:?}",
            t.pop_events
        );
    }
    for technique in EXACT {
        let t = temporal(&runs, technique);
        let worst = t.max_abs.iter().copied().fold(0.0, f64::max);
        assert!(
            worst <= 4e-3,
            "{technique}: max error {worst} on some frame"
        );
    }
}

/// Every frame of ≥ 20 seeded random animated scenes (moving cameras, keyed transforms and
/// alphas; `oit_scene::random`), without undecided or precision-tie pixels: the exact
/// techniques match each frame's reference to 4e-3 (relative above 1) and drop nothing.
#[test]
fn exact_techniques_are_exact_on_every_frame_of_random_animated_scenes() {
    let Some(ctx) = oit_gpu::testing::context_or_skip(
        "exact_techniques_are_exact_on_every_frame_of_random_animated_scenes",
    ) else {
        return;
    };
    let specs = resolve_specs(&EXACT.map(String::from)).expect("specs");
    let (mut scenes_compared, mut frames_compared, mut failures) = (0, 0, Vec::new());
    for seed in 0..32 {
        let (text, about) = oit_scene::random::random_animated_scene_json(seed);
        let frames = oit_scene::parse_frames(&text, "random").expect("random animated scene");
        let mut compared_here = 0;
        for t in 0..frames.count() {
            let scene = frames.frame(t).expect("frame");
            let reference = oit_reference::render(&scene, &Default::default());
            if reference.stats.undecided_pixels + reference.stats.precision_tie_pixels > 0 {
                continue;
            }
            compared_here += 1;
            for spec in &specs {
                let frame = match render_once(&ctx, &scene, spec) {
                    Ok(f) => f,
                    Err(e) => {
                        println!("seed {seed} frame {t}: {} skipped: {e}", spec.canonical());
                        continue;
                    }
                };
                let worst = crate::kit::max_relative_rgb(&frame.image, &reference.image);
                if worst > 4e-3 || frame.stats.pixels_with_dropped_layers > 0 {
                    failures.push(format!(
                        "seed {seed} frame {t} {}: max error {worst:e}, dropped layers on {} px; {about:?}",
                        spec.canonical(),
                        frame.stats.pixels_with_dropped_layers
                    ));
                }
            }
        }
        frames_compared += compared_here;
        scenes_compared += usize::from(compared_here > 0);
    }
    println!("{frames_compared} frames of {scenes_compared} random animated scenes compared");
    assert!(
        scenes_compared >= 20,
        "only {scenes_compared} scenes had tie-free frames"
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn bundled_motion_scenes_are_exact_on_every_frame_for_exact_techniques() {
    let Some(ctx) = oit_gpu::testing::context_or_skip(
        "bundled_motion_scenes_are_exact_on_every_frame_for_exact_techniques",
    ) else {
        return;
    };
    let scenes = load_scenes(&[crate::kit::scenes_dir().join("motion")]).expect("motion scenes");
    assert!(scenes.len() >= 6, "{} motion scenes", scenes.len());
    for entry in &scenes {
        let name = &entry.scene.name;
        let runs = motion_runs_of(&ctx, &entry.path, &EXACT, 0);
        for technique in EXACT {
            let t = temporal(&runs, technique);
            let worst = t.max_abs.iter().copied().fold(0.0, f64::max);
            assert!(worst <= 4e-3, "{name} {technique}: max error {worst}");
            assert!(
                t.pop_events.is_empty(),
                "{name} {technique}: pops {:?}",
                t.pop_events
            );
        }
    }
}

/// At a static camera weighted blending is deterministic: no noise, all of its error is bias.
/// Stochastic transparency draws fresh thresholds each frame: it flickers along the path and
/// is noisy at the static camera, and averaging its frames removes most of the error.
#[test]
fn weighted_blending_is_biased_and_stochastic_transparency_noisy() {
    let Some(ctx) = oit_gpu::testing::context_or_skip(
        "weighted_blending_is_biased_and_stochastic_transparency_noisy",
    ) else {
        return;
    };
    let runs = motion_runs(
        &ctx,
        "motion-stack-crossing",
        &["wboit", "mboit", "stochastic:pattern=white"],
        16,
    );
    for technique in ["wboit", "mboit"] {
        let s = temporal(&runs, technique)
            .static_camera
            .as_ref()
            .expect("static camera");
        assert_eq!(s.frames, 16);
        assert_eq!(s.noise_rms, 0.0, "{technique} is deterministic");
        assert!(s.bias_rmse > 1e-3, "{technique}: bias {}", s.bias_rmse);
    }
    let stochastic = temporal(&runs, "stochastic:pattern=white");
    assert!(
        stochastic.flicker > 0.0,
        "stochastic thresholds change per frame"
    );
    let s = stochastic.static_camera.as_ref().expect("static camera");
    assert!(s.noise_rms > 2.0 * s.bias_rmse, "{s:?}");
    let sum = s.bias_rmse.powi(2) + s.noise_rms.powi(2);
    assert!(
        (sum - s.mse).abs() <= 1e-9 + 1e-6 * s.mse,
        "MSE = bias² + variance: {s:?}"
    );
    assert!(s.mean_rmse[15] < 0.5 * s.mean_rmse[0], "{:?}", s.mean_rmse);
}
