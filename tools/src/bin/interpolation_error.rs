//! How far the adapter's attribute interpolation is from the exact value: the bound behind the
//! reference's *undecided* cutoff class (`oit_reference::CUTOFF_UNDECIDED_BOUND`).
//!
//! Every material of seeded random scenes is made opaque with colour 1, so the opaque pass
//! writes the interpolated vertex colour itself into an `Rgba32Float` target; the reference
//! interpolates the same colour in f64 and rounds once. On pixels with exactly one fragment
//! (no visibility decision involved) the difference is the GPU's interpolation error.
//! `cargo run --release -p oit-tools --bin interpolation_error -- [--scenes N]`.

use std::process::ExitCode;

use oit_gpu::{ColorFormat, Context, ContextOptions, GpuScene, GpuTimer, Targets};
use oit_scene::{AlphaMode, Material};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scenes: u64 = match args.iter().position(|a| a == "--scenes") {
        None => 200,
        Some(i) => match args.get(i + 1).and_then(|v| v.parse().ok()) {
            Some(n) => n,
            None => {
                eprintln!("interpolation_error: --scenes needs a non-negative integer");
                return ExitCode::from(2);
            }
        },
    };
    let ctx = match Context::new(&ContextOptions::default()) {
        Ok(ctx) => ctx,
        Err(e) => {
            eprintln!("interpolation_error: {e}");
            return ExitCode::from(2);
        }
    };
    let info = ctx.adapter_info();
    println!("adapter: {} ({}, {})", info.name, info.backend, info.driver);
    // Histogram of |GPU − exact| in units of 2^-24 (half an ulp of values in [0.5, 1)).
    let mut histogram = [0u64; 12];
    let (mut samples, mut worst) = (0u64, 0.0f64);
    for seed in 0..scenes {
        let (text, _) = oit_scene::random::random_scene_json(seed);
        let mut scene = oit_scene::parse(&text, "random").expect("random scenes parse");
        for m in &mut scene.materials {
            *m = Material {
                base_color: [1.0; 3],
                alpha: 1.0,
                mode: AlphaMode::Opaque,
                premultiplied: false,
                intensity: 1.0,
                ..*m
            };
        }
        let reference = oit_reference::render(&scene, &Default::default());
        let result = (|| {
            let gpu = GpuScene::upload(&ctx, &scene)?;
            let targets = Targets::new(&ctx, scene.resolution, ColorFormat::Rgba32Float)?;
            let mut timer = GpuTimer::new(&ctx);
            oit_gpu::render_frame(&ctx, &gpu, &mut oit_gpu::Floor::new(), &targets, &mut timer)?;
            oit_gpu::read_color(&ctx, &targets)
        })();
        let image = match result {
            Ok(i) => i,
            Err(e) => {
                eprintln!("interpolation_error: seed {seed}: {e}");
                return ExitCode::from(2);
            }
        };
        for (p, (gpu, exact)) in image.pixels.iter().zip(&reference.image.pixels).enumerate() {
            if reference.fragments[p] != 1 {
                continue;
            }
            for c in 0..3 {
                let e = f64::from((gpu[c] - exact[c]).abs()) * f64::from(1u32 << 24);
                worst = worst.max(e);
                let bucket = if e == 0.0 {
                    0
                } else {
                    (e.log2().floor() as i64 + 2).clamp(1, 11) as usize
                };
                histogram[bucket] += 1;
                samples += 1;
            }
        }
    }
    println!(
        "{samples} interpolated channels on {scenes} scenes; |GPU − exact| in units of 2^-24:"
    );
    println!("  exact: {}", histogram[0]);
    for (b, n) in histogram.iter().enumerate().skip(1) {
        if *n > 0 {
            println!(
                "  [{}, {}): {n}",
                2f64.powi(b as i32 - 2),
                2f64.powi(b as i32 - 1)
            );
        }
    }
    println!(
        "  worst: {worst:.2} (= {:.3e})",
        worst / f64::from(1u32 << 24)
    );
    ExitCode::SUCCESS
}
