//! Measures what the README reports: cost per peeled layer of dual vs front peeling against
//! `unsorted`, bytes per pixel, the peel-test-before-shading and depth-only-init ablations, and
//! what a CPU round trip per pass costs against GPU-gated termination.
//!
//! `cargo run --release -p oit-peel --example peel_bench -- [SCENE] [SIZE] [FRAMES]`
//! (defaults: many-layers-64 128 7). Times are medians over FRAMES frames after one warm-up.

use oit_gpu::{ColorFormat, Context, ContextOptions, GpuScene, GpuTimer, Targets, Technique};
use oit_peel::{
    DepthEncoding, DepthFormat, DualPeel, DualPeelConfig, FrontPeel, FrontPeelConfig, Options,
    PassCount, Tail, Termination,
};
use oit_scene::Resolution;
use std::path::Path;

struct Sample {
    gpu_ms: f64,
    wall_ms: f64,
    passes: Vec<(String, f64)>,
    geometry_passes: u32,
    bytes: u64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn measure(
    ctx: &Context,
    scene: &GpuScene,
    t: &mut dyn Technique,
    frames: usize,
) -> anyhow::Result<Sample> {
    let targets = Targets::new(ctx, scene.scene.resolution, ColorFormat::Rgba16Float)?;
    let mut timer = GpuTimer::new(ctx);
    oit_gpu::render_frame(ctx, scene, t, &targets, &mut timer)?;
    let (mut gpu, mut wall) = (Vec::new(), Vec::new());
    let mut per_pass: Vec<(String, Vec<f64>)> = Vec::new();
    let mut geometry_passes = 0;
    for _ in 0..frames {
        let start = std::time::Instant::now();
        let f = oit_gpu::render_frame(ctx, scene, t, &targets, &mut timer)?;
        wall.push(start.elapsed().as_secs_f64() * 1e3);
        // The shared opaque pass is not the technique's.
        gpu.push(
            f.timings
                .passes
                .iter()
                .filter(|p| p.name != "opaque")
                .map(|p| p.ms)
                .sum(),
        );
        geometry_passes = f.stats.geometry_passes;
        for p in &f.timings.passes {
            let key = if p.name.starts_with("peel ")
                || p.name.starts_with("layer ")
                || p.name.starts_with("under ")
            {
                p.name.split(' ').next().unwrap_or("").to_owned() + " (sum)"
            } else {
                p.name.clone()
            };
            match per_pass.iter_mut().find(|(n, _)| *n == key) {
                Some((_, v)) => v.push(p.ms),
                None => per_pass.push((key, vec![p.ms])),
            }
        }
    }
    // Sums over a frame's passes of one kind, median over frames.
    let passes = per_pass
        .into_iter()
        .map(|(n, v)| {
            let per_frame = v.len() / frames;
            let sums: Vec<f64> = v.chunks(per_frame.max(1)).map(|c| c.iter().sum()).collect();
            (n, median(sums))
        })
        .collect();
    Ok(Sample {
        gpu_ms: median(gpu),
        wall_ms: median(wall),
        passes,
        geometry_passes,
        bytes: t.memory_bytes(),
    })
}

fn dual(passes: PassCount, depth: DepthFormat) -> DualPeelConfig {
    DualPeelConfig {
        passes,
        depth,
        reverse_z: true,
        tail: Tail::Drop,
        encoding: DepthEncoding::Window,
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("many-layers-64", String::as_str);
    let size: u32 = args.get(1).map_or(Ok(128), |s| s.parse())?;
    let frames: usize = args.get(2).map_or(Ok(7), |s| s.parse())?;
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../scenes/{name}.json"));
    let scene = oit_scene::load(&path)?.with_resolution(Resolution {
        width: size,
        height: size,
    });
    let reference = oit_reference::render(&scene, &oit_reference::ReferenceOptions::default());
    let l = reference.stats.max_depth_complexity;
    let ctx = Context::new(&ContextOptions::default())?;
    let gpu = GpuScene::upload(&ctx, &scene)?;
    let pixels = f64::from(size * size);
    println!(
        "adapter {:?} ({}), timing {:?}",
        ctx.adapter_info().name,
        ctx.adapter_info().backend,
        GpuTimer::new(&ctx).source()
    );
    println!(
        "scene {name} {size}x{size}, max depth complexity L = {l}, {frames} frames (median)\n"
    );

    let mut unsorted = oit_gpu::TechniqueSpec::build("unsorted", &oit_sorted::techniques())?;
    let u = measure(&ctx, &gpu, unsorted.as_mut(), frames)?;
    println!(
        "{:58} {:>9} {:>9} {:>6} {:>8}",
        "technique", "gpu ms", "wall ms", "geom", "B/px"
    );
    let row = |label: &str, s: &Sample| {
        println!(
            "{label:58} {:9.3} {:9.3} {:6} {:8.1}",
            s.gpu_ms,
            s.wall_ms,
            s.geometry_passes,
            s.bytes as f64 / pixels
        );
    };
    row("unsorted", &u);
    let mut results = Vec::new();
    let runs: Vec<(&str, Box<dyn Technique>)> = vec![
        (
            "front-peel:layers=auto",
            Box::new(FrontPeel::new(FrontPeelConfig::default())),
        ),
        (
            "front-peel:layers=auto (shade before test)",
            Box::new(FrontPeel::with_options(
                FrontPeelConfig::default(),
                Options {
                    test_before_shading: false,
                    ..Options::default()
                },
            )),
        ),
        (
            "front-peel:layers=auto (CPU readback per pass)",
            Box::new(FrontPeel::with_options(
                FrontPeelConfig::default(),
                Options {
                    termination: Termination::CpuReadbackPerPass,
                    ..Options::default()
                },
            )),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f",
            Box::new(DualPeel::new(dual(PassCount::Auto, DepthFormat::Rg32f))),
        ),
        (
            "dual-peel:passes=auto,depth=rg16f",
            Box::new(DualPeel::new(dual(PassCount::Auto, DepthFormat::Rg16f))),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f (shade before test)",
            Box::new(DualPeel::with_options(
                dual(PassCount::Auto, DepthFormat::Rg32f),
                Options {
                    test_before_shading: false,
                    ..Options::default()
                },
            )),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f (full-shader init)",
            Box::new(DualPeel::with_options(
                dual(PassCount::Auto, DepthFormat::Rg32f),
                Options {
                    depth_only_init: false,
                    ..Options::default()
                },
            )),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f (Babylon: both)",
            Box::new(DualPeel::with_options(
                dual(PassCount::Auto, DepthFormat::Rg32f),
                Options {
                    depth_only_init: false,
                    test_before_shading: false,
                    ..Options::default()
                },
            )),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f (CPU readback per pass)",
            Box::new(DualPeel::with_options(
                dual(PassCount::Auto, DepthFormat::Rg32f),
                Options {
                    termination: Termination::CpuReadbackPerPass,
                    ..Options::default()
                },
            )),
        ),
        (
            "dual-peel:passes=5 (Babylon default)",
            Box::new(DualPeel::new(dual(PassCount::Fixed(5), DepthFormat::Rg32f))),
        ),
        (
            "dual-peel:passes=5,tail=wboit",
            Box::new(DualPeel::new(DualPeelConfig {
                tail: Tail::Wboit,
                ..dual(PassCount::Fixed(5), DepthFormat::Rg32f)
            })),
        ),
    ];
    for (label, mut t) in runs {
        let s = measure(&ctx, &gpu, t.as_mut(), frames)?;
        row(label, &s);
        results.push((label, s));
    }
    let get = |label: &str| {
        &results
            .iter()
            .find(|(l, _)| *l == label)
            .expect("measured")
            .1
    };
    let front = get("front-peel:layers=auto");
    let dualr = get("dual-peel:passes=auto,depth=rg32f");
    let lf = f64::from(l);
    println!(
        "\nper peeled layer (gpu ms / L): front {:.4} ms = {:.3}x unsorted, dual {:.4} ms = {:.3}x unsorted; dual/front = {:.3}",
        front.gpu_ms / lf,
        front.gpu_ms / lf / u.gpu_ms,
        dualr.gpu_ms / lf,
        dualr.gpu_ms / lf / u.gpu_ms,
        dualr.gpu_ms / front.gpu_ms
    );
    for (label, s) in &results {
        let interesting: Vec<String> = s
            .passes
            .iter()
            .filter(|(n, _)| n != "opaque")
            .map(|(n, ms)| format!("{n} {ms:.3}"))
            .collect();
        println!("  {label}: {}", interesting.join(", "));
    }
    let stall = |a: &str, b: &str| {
        let (x, y) = (get(a), get(b));
        println!(
            "stall: {b}: wall {:.3} ms vs gated {:.3} ms (+{:.3} ms, {:.3} ms per pass)",
            y.wall_ms,
            x.wall_ms,
            y.wall_ms - x.wall_ms,
            (y.wall_ms - x.wall_ms) / f64::from(y.geometry_passes)
        );
    };
    stall(
        "front-peel:layers=auto",
        "front-peel:layers=auto (CPU readback per pass)",
    );
    stall(
        "dual-peel:passes=auto,depth=rg32f",
        "dual-peel:passes=auto,depth=rg32f (CPU readback per pass)",
    );
    Ok(())
}
