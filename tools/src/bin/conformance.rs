//! Rasterization conformance on seeded random scenes (`oit_scene::random`): the reference's
//! per-pixel fragment counts against the GPU's (`count_fragments`), scene by scene.
//!
//! `cargo xtask conformance --scenes N` (or `cargo run --release -p oit-tools --bin
//! conformance -- --scenes N [--first SEED]`). Prints every scene with a differing pixel and a
//! summary; exits 1 when any pixel differs. CI runs the first 200 seeds as a test
//! (tests/gpu/gpu/context.rs); this runs as many as you like. A pixel may differ by up to its fragments in a
//! cutoff's undecided band (`Reference::compare_fragment_counts`); any other difference fails. Since the reference mirrors lavapipe's vertex
//! arithmetic and viewport clipping, no pixel of seeds 0–39 999 differs on lavapipe.

use std::process::ExitCode;

use oit_gpu::{Context, ContextOptions, GpuScene};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str, default: u64| -> Result<u64, String> {
        match args.iter().position(|a| a == flag) {
            None => Ok(default),
            Some(i) => args
                .get(i + 1)
                .and_then(|v| v.parse().ok())
                .ok_or_else(|| format!("{flag} needs a non-negative integer")),
        }
    };
    let (scenes, first) = match (value("--scenes", 200), value("--first", 0)) {
        (Ok(n), Ok(f)) => (n, f),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("conformance: error: {e}; usage: conformance [--scenes N] [--first SEED]");
            return ExitCode::from(2);
        }
    };
    let ctx = match Context::new(&ContextOptions::default()) {
        Ok(ctx) => ctx,
        Err(e) => {
            eprintln!("conformance: error: {e}");
            return ExitCode::from(2);
        }
    };
    let info = ctx.adapter_info();
    println!(
        "adapter: {} ({}, {}, {})",
        info.name, info.backend, info.driver, info.driver_info
    );
    let (mut pixels, mut differing, mut scenes_differing) = (0usize, 0usize, 0usize);
    // Pixels that differ only by fragments in a cutoff's undecided band (allowed).
    let mut tolerated = 0usize;
    for seed in first..first + scenes {
        let (text, about) = oit_scene::random::random_scene_json(seed);
        let scene = match oit_scene::parse(&text, &format!("random-{seed}")) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("conformance: error: {e}");
                return ExitCode::from(2);
            }
        };
        let reference = oit_reference::render(&scene, &Default::default());
        let counts = match GpuScene::upload(&ctx, &scene)
            .and_then(|gpu| oit_gpu::count_fragments(&ctx, &gpu))
        {
            Ok(c) => c,
            Err(e) => {
                eprintln!("conformance: error: seed {seed}: {e}");
                return ExitCode::from(2);
            }
        };
        let width = scene.resolution.width as usize;
        let comparison = reference.compare_fragment_counts(&counts);
        tolerated += comparison.undecided;
        let mismatched = comparison.unexplained;
        pixels += counts.len();
        differing += mismatched.len();
        if mismatched.is_empty() {
            continue;
        }
        scenes_differing += 1;
        let at: Vec<String> = mismatched
            .iter()
            .take(4)
            .map(|&i| {
                format!(
                    "({}, {}) GPU {} ref {}",
                    i % width,
                    i / width,
                    counts[i],
                    reference.fragments[i]
                )
            })
            .collect();
        println!(
            "seed {seed}: {} of {} px differ [{}]; {about:?}",
            mismatched.len(),
            counts.len(),
            at.join(", ")
        );
    }
    println!(
        "{scenes} random scenes: {differing} of {pixels} px differ, in {scenes_differing} scenes; {tolerated} px differ within the undecided cutoff band (allowed)"
    );
    if scenes_differing > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
