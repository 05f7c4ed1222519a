//! Rasterization conformance on seeded random scenes (`oit_scene::random`): the reference's
//! per-pixel fragment counts against the GPU's (`count_fragments`), scene by scene.
//!
//! `cargo xtask conformance --scenes N` (or `cargo run --release -p oit-gpu --example
//! conformance -- --scenes N [--first SEED]`). Prints every scene with a differing pixel and a
//! summary; exits 1 when a scene without near/far clipping differs (clipped triangles may differ
//! by the rounding of their new vertices, DESIGN.md). This is the measuring tool of the
//! calibration work: the bundled suite's own test (tests/gpu.rs) is exact; on random content no
//! differing pixel has been seen in 20 000 scenes since the reference mirrors lavapipe's vertex
//! arithmetic and viewport clipping (see the crate README of oit-reference).

use std::process::ExitCode;

use oit_gpu::{Context, ContextOptions, GpuScene};
use oit_scene::Scene;

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
    println!("adapter: {} ({}, {})", info.name, info.backend, info.driver);
    let (mut pixels, mut differing, mut unexplained) = (0usize, 0usize, 0usize);
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
        let mismatched: Vec<usize> = (0..counts.len())
            .filter(|&i| counts[i] != reference.fragments[i])
            .collect();
        pixels += counts.len();
        differing += mismatched.len();
        if mismatched.is_empty() {
            continue;
        }
        let clipped = needs_depth_clipping(&scene);
        if !clipped {
            unexplained += 1;
        }
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
            "seed {seed}: {} of {} px differ [{}]; clipping: {clipped}; {about:?}",
            mismatched.len(),
            counts.len(),
            at.join(", ")
        );
    }
    println!(
        "{scenes} random scenes: {differing} of {pixels} px differ; {unexplained} scenes differ without near/far clipping"
    );
    if unexplained > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// True when some triangle straddles the near or far plane (0 ≤ z ≤ w in clip space).
fn needs_depth_clipping(scene: &Scene) -> bool {
    scene.draws.iter().any(|d| {
        scene.vertices[d.vertex_range()].chunks_exact(3).any(|t| {
            let inside: Vec<bool> = t
                .iter()
                .map(|v| {
                    let c = scene.camera.clip(glam::Vec3::from(v.position));
                    c.z >= 0.0 && c.z <= c.w
                })
                .collect();
            inside.iter().any(|&i| i) && inside.iter().any(|&i| !i)
        })
    })
}
