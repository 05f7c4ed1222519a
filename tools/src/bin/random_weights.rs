//! The WBOIT weights on seeded random scenes (`oit_scene::random`), content none of the weights
//! was designed or tuned on:
//! `cargo run -p oit-tools --release --bin random_weights -- [SCENES] [SIZE] [FIRST_SEED]`
//! (default 50 scenes at 128×128 from seed 0; `WBOIT_ONLY=eq10,range` limits the weights).
//!
//! Every weight renders with rgba16f + r16f; scenes without a transparent fragment in front of
//! the opaque surface are skipped (every weight is exact there). Prints the mean FLIP and RMSE
//! per weight, and `range` against each other weight: the relative difference of the means, and
//! the mean per-scene difference with its standard error (the scenes are paired), so a
//! difference within noise reads as such.

use anyhow::{Result, bail};
use oit_gpu::{ColorFormat, GpuScene, GpuTimer, Targets, read_color, render_frame};
use oit_scene::Resolution;
use oit_wboit::tail::{AccumFormat, RevealFormat};
use oit_wboit::{Config, Wboit, Weight};

/// Mean and standard error of the mean.
fn mean_se(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, (var / n).sqrt())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let count: u64 = args.first().map_or(Ok(50), |s| s.parse())?;
    let size: u32 = args.get(1).map_or(Ok(128), |s| s.parse())?;
    let first: u64 = args.get(2).map_or(Ok(0), |s| s.parse())?;
    let Some(ctx) = oit_gpu::testing::context_or_skip("random_weights") else {
        bail!("no GPU adapter");
    };
    println!(
        "adapter: {} ({}); seeds {first}..{}, {size}x{size}, rgba16f + r16f",
        ctx.adapter_info().name,
        ctx.adapter_info().backend,
        first + count
    );
    let weights: Vec<Weight> = std::env::var("WBOIT_ONLY")
        .map(|v| v.split(',').filter_map(Weight::parse).collect())
        .unwrap_or_else(|_| Weight::ALL.to_vec());
    if !weights.contains(&Weight::Range) {
        bail!("WBOIT_ONLY must include range (the others are compared with it)");
    }
    let res = Resolution {
        width: size,
        height: size,
    };
    let targets = Targets::new(&ctx, res, ColorFormat::Rgba16Float)?;
    // Per weight, per used scene: (FLIP, RMSE).
    let mut errors: Vec<Vec<(f64, f64)>> = vec![Vec::new(); weights.len()];
    let mut skipped = 0;
    let mut overflowed = vec![0u32; weights.len()];
    for seed in first..first + count {
        let (text, _) = oit_scene::random::random_scene_json(seed);
        let scene = oit_scene::parse(&text, &format!("random-{seed}"))?.with_resolution(res);
        let reference = oit_reference::render(&scene, &Default::default());
        if reference.stats.composited_fragments == 0 {
            skipped += 1;
            continue;
        }
        let gpu = GpuScene::upload(&ctx, &scene)?;
        for (i, &weight) in weights.iter().enumerate() {
            let mut t = Wboit::new(Config::Weighted {
                weight,
                accum: AccumFormat::Rgba16f,
                reveal: RevealFormat::R16f,
            });
            render_frame(&ctx, &gpu, &mut t, &targets, &mut GpuTimer::wall_clock())?;
            let image = read_color(&ctx, &targets)?;
            let guards = t.last_guard_counts(&ctx)?.unwrap_or_default();
            if guards.accum_overflow > 0 {
                overflowed[i] += 1;
            }
            let e = oit_metrics::compare(&image, &reference.image)?;
            if e.nonfinite > 0 {
                bail!(
                    "random-{seed} {}: {} non-finite pixels",
                    weight.name(),
                    e.nonfinite
                );
            }
            errors[i].push((e.headline_flip().0, e.rmse));
        }
    }
    let used = errors[0].len();
    println!("{used} scenes with transparent layers ({skipped} without skipped)");
    println!("| weight | mean FLIP | mean RMSE | scenes with accum_overflow |");
    println!("|---|---:|---:|---:|");
    for (i, w) in weights.iter().enumerate() {
        let flip = errors[i].iter().map(|e| e.0).sum::<f64>() / used as f64;
        let rmse = errors[i].iter().map(|e| e.1).sum::<f64>() / used as f64;
        println!(
            "| {} | {flip:.4} | {rmse:.4} | {} |",
            w.name(),
            overflowed[i]
        );
    }
    let r = weights
        .iter()
        .position(|&w| w == Weight::Range)
        .expect("checked above");
    println!(
        "range against each weight (negative: range lower; ± one standard error of the paired mean):"
    );
    for (i, w) in weights.iter().enumerate() {
        if i == r {
            continue;
        }
        for (metric, pick) in [
            ("FLIP", (|e: &(f64, f64)| e.0) as fn(&(f64, f64)) -> f64),
            ("RMSE", |e| e.1),
        ] {
            let diffs: Vec<f64> = errors[r]
                .iter()
                .zip(&errors[i])
                .map(|(a, b)| pick(a) - pick(b))
                .collect();
            let (d, se) = mean_se(&diffs);
            let other = errors[i].iter().map(pick).sum::<f64>() / used as f64;
            let wins = diffs.iter().filter(|&&d| d < 0.0).count();
            println!(
                "  vs {:12} {metric}: {:+6.1} % of its mean ({d:+.4} ± {se:.4} per scene), range lower on {wins} of {used}",
                w.name(),
                100.0 * d / other
            );
        }
    }
    Ok(())
}
