//! GPU time of wboit configurations relative to plain draw-order OVER blending ("unsorted",
//! `oit_gpu::DrawOrderBlend` with materials, so this crate does not depend on oit-sorted), and bytes
//! per pixel: `cargo run -p oit-tools --release --bin wboit_cost -- [SIZE] [FRAMES]`.
//! Times are medians of the technique's passes (the shared opaque pass excluded), from
//! timestamp queries where the adapter has them, else wall-clock.

use anyhow::{Result, bail};
use oit_gpu::{
    BlendShading, ColorFormat, Context, DrawOrderBlend, GpuScene, GpuTimer, Targets, Technique,
    render_frame,
};
use oit_scene::Resolution;
use oit_wboit::tail::{AccumFormat, RevealFormat};
use oit_wboit::{Config, Wboit, Weight};
use std::path::Path;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median GPU ms of the technique's passes (everything but "opaque").
fn time(
    ctx: &Context,
    scene: &GpuScene,
    t: &mut dyn Technique,
    targets: &Targets,
    frames: usize,
) -> Result<f64> {
    let mut timer = GpuTimer::new(ctx);
    for _ in 0..3 {
        render_frame(ctx, scene, t, targets, &mut timer)?;
    }
    let mut ms = Vec::new();
    for _ in 0..frames {
        let f = render_frame(ctx, scene, t, targets, &mut timer)?;
        ms.push(
            f.timings
                .passes
                .iter()
                .filter(|p| p.name != "opaque")
                .map(|p| p.ms)
                .sum(),
        );
    }
    Ok(median(ms))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let size: u32 = args.first().map_or(Ok(256), |s| s.parse())?;
    let frames: usize = args.get(1).map_or(Ok(15), |s| s.parse())?;
    let Some(ctx) = oit_gpu::testing::context_or_skip("wboit_cost") else {
        bail!("no GPU adapter");
    };
    let timing = GpuTimer::new(&ctx).source();
    println!(
        "adapter: {} ({}), {size}x{size}, median of {frames} frames, timing: {}",
        ctx.adapter_info().name,
        ctx.adapter_info().backend,
        timing.name()
    );
    let res = Resolution {
        width: size,
        height: size,
    };
    let targets = Targets::new(&ctx, res, ColorFormat::Rgba16Float)?;
    let configs: Vec<Config> = vec![
        Config::DEFAULT,
        Config::Weighted {
            weight: Weight::Range,
            accum: AccumFormat::Rgba16f,
            reveal: RevealFormat::R8,
        },
        Config::Weighted {
            weight: Weight::Range,
            accum: AccumFormat::Rgba32f,
            reveal: RevealFormat::R32f,
        },
        Config::Weighted {
            weight: Weight::Eq10,
            accum: AccumFormat::Rgba16f,
            reveal: RevealFormat::R16f,
        },
        Config::Average,
    ];
    let mut header = "| scene | unsorted ms |".to_owned();
    for c in &configs {
        header.push_str(&format!(" {} |", c.spec()));
    }
    println!("{header}");
    println!("|---|---|{}", "---|".repeat(configs.len()));
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let mut ratios = vec![Vec::new(); configs.len()];
    for (_, scene) in oit_scene::load_dir(&dir)? {
        let scene = scene.with_resolution(res);
        let gpu = GpuScene::upload(&ctx, &scene)?;
        let base = time(
            &ctx,
            &gpu,
            &mut DrawOrderBlend::with(BlendShading::Material),
            &targets,
            frames,
        )?;
        let mut row = format!("| {} | {base:.3} |", scene.name);
        for (i, &c) in configs.iter().enumerate() {
            let mut t = Wboit::new(c);
            if t.check(&ctx.caps).is_err() {
                row.push_str(" unsupported |");
                continue;
            }
            let ms = time(&ctx, &gpu, &mut t, &targets, frames)?;
            ratios[i].push(ms / base);
            row.push_str(&format!(" {ms:.3} ({:.2}x) |", ms / base));
        }
        println!("{row}");
    }
    let mut row = "| **median ratio** | 1 |".to_owned();
    for r in ratios {
        row.push_str(&format!(" **{:.2}x** |", median(r)));
    }
    println!("{row}");
    let mut bpp = "| bytes/pixel (targets) | 0 |".to_owned();
    for &c in &configs {
        let t = oit_wboit::tail::AccumTargets::with_formats(
            &ctx,
            res,
            match c {
                Config::Average => oit_wboit::tail::CompositeMode::Average,
                _ => oit_wboit::tail::CompositeMode::Weighted,
            },
            match c {
                Config::Weighted { accum, .. } => accum,
                Config::Average => AccumFormat::Rgba16f,
            },
            match c {
                Config::Weighted { reveal, .. } => reveal,
                Config::Average => RevealFormat::R32f,
            },
        )?;
        bpp.push_str(&format!(" {} |", t.bytes_per_pixel()));
    }
    println!("{bpp}");
    Ok(())
}
