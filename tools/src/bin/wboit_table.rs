//! Error table of every weight on every bundled scene against the CPU reference:
//! `cargo run -p oit-tools --release --bin wboit_table -- [SIZE] [accum] [reveal]`
//! (default 128 rgba16f r16f; `WBOIT_ONLY=eq10,range` limits the weights). Prints mean FLIP
//! (HDR-FLIP on scenes whose reference exceeds 1, as `oit compare` reports) and RMSE per
//! scene × weight, the suite means, guard counts and the order dependence (max |forward −
//! reversed draw order| over RGB).

use anyhow::{Context as _, Result, bail};
use oit_gpu::{ColorFormat, GpuScene, GpuTimer, Targets, read_color, render_frame};
use oit_scene::{LinearImage, Resolution};
use oit_wboit::tail::{AccumFormat, RevealFormat};
use oit_wboit::{Config, Wboit, Weight};
use std::path::Path;

fn max_rgb_difference(a: &LinearImage, b: &LinearImage) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from((p[c] - q[c]).abs())))
        .fold(
            0.0,
            |m, d| if d.is_nan() { f64::INFINITY } else { m.max(d) },
        )
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let size: u32 = args.first().map_or(Ok(128), |s| s.parse())?;
    let accum = args
        .get(1)
        .map_or(Some(AccumFormat::Rgba16f), |s| AccumFormat::parse(s))
        .context("accum: rgba16f or rgba32f")?;
    let reveal = args
        .get(2)
        .map_or(Some(RevealFormat::R16f), |s| RevealFormat::parse(s))
        .context("reveal: r8, r16f or r32f")?;
    let Some(ctx) = oit_gpu::testing::context_or_skip("wboit_table") else {
        bail!("no GPU adapter");
    };
    println!(
        "adapter: {} ({})",
        ctx.adapter_info().name,
        ctx.adapter_info().backend
    );
    let res = Resolution {
        width: size,
        height: size,
    };
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let scenes = oit_scene::load_dir(&dir)?;
    let only: Vec<Weight> = std::env::var("WBOIT_ONLY")
        .map(|v| v.split(',').filter_map(Weight::parse).collect())
        .unwrap_or_else(|_| Weight::ALL.to_vec());
    let mut configs: Vec<(String, Config)> = only
        .iter()
        .map(|&weight| {
            (
                weight.name().to_owned(),
                Config::Weighted {
                    weight,
                    accum,
                    reveal,
                },
            )
        })
        .collect();
    if std::env::var("WBOIT_ONLY").is_err() {
        configs.push(("w-average".to_owned(), Config::Average));
    }
    let mut flip_sum = vec![0.0; configs.len()];
    let mut rmse_sum = vec![0.0; configs.len()];
    let mut header = "| scene |".to_owned();
    for (name, _) in &configs {
        header.push_str(&format!(" {name} |"));
    }
    println!(
        "accum={} reveal={} {size}x{size}; cells: mean FLIP / RMSE",
        accum.name(),
        reveal.name()
    );
    println!("{header}");
    println!("|---|{}", "---|".repeat(configs.len()));
    let mut notes = Vec::new();
    for (_, scene) in &scenes {
        let scene = scene.with_resolution(res);
        let reference = oit_reference::render(&scene, &Default::default());
        let gpu = GpuScene::upload(&ctx, &scene)?;
        let reversed = GpuScene::upload(&ctx, &scene.with_reversed_draw_order())?;
        let targets = Targets::new(&ctx, res, ColorFormat::Rgba16Float)?;
        let mut row = format!("| {} |", scene.name);
        for (i, (name, config)) in configs.iter().enumerate() {
            let mut t = Wboit::new(*config);
            let mut timer = GpuTimer::wall_clock();
            render_frame(&ctx, &gpu, &mut t, &targets, &mut timer)?;
            let image = read_color(&ctx, &targets)?;
            let guards = t.last_guard_counts(&ctx)?.unwrap_or_default();
            render_frame(&ctx, &reversed, &mut t, &targets, &mut timer)?;
            let rev = read_color(&ctx, &targets)?;
            let e = oit_metrics::compare(&image, &reference.image)?;
            let flip = e.headline_flip().0;
            flip_sum[i] += flip;
            rmse_sum[i] += e.rmse;
            row.push_str(&format!(" {flip:.4} / {:.4} |", e.rmse));
            notes.push(format!(
                "{} {name}: nonfinite {} order_dependence {:.3e} guards [{guards}]",
                scene.name,
                e.nonfinite,
                max_rgb_difference(&image, &rev)
            ));
        }
        println!("{row}");
    }
    let n = scenes.len() as f64;
    let mut row = "| **suite mean** |".to_owned();
    for i in 0..configs.len() {
        row.push_str(&format!(
            " **{:.4}** / {:.4} |",
            flip_sum[i] / n,
            rmse_sum[i] / n
        ));
    }
    println!("{row}");
    for line in notes {
        println!("{line}");
    }
    Ok(())
}
