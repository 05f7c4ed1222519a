//! Measures what the README reports: cost per peeled layer of dual vs front peeling against
//! `unsorted`, bytes per pixel, the peel-test-before-shading and depth-only-init ablations, and
//! what a CPU round trip per pass costs against GPU-gated termination.
//!
//! `cargo run -p oit-tools --bin peel_bench -- [SCENE] [SIZE] [FRAMES]`
//! (defaults: many-layers-64 128 7). After one warm-up frame each, the configurations render
//! in interleaved rounds (one frame of each per round), so load from other processes on a
//! shared machine hits them alike. Times are minima over the rounds (the least disturbed run of
//! CPU-bound lavapipe work), medians in brackets.

use oit_gpu::{ColorFormat, Context, ContextOptions, GpuScene, GpuTimer, Targets, Technique};
use oit_peel::{
    DepthEncoding, DepthFormat, DualPeel, DualPeelConfig, FrontPeel, FrontPeelConfig, Options,
    PassCount, Tail, Termination,
};
use oit_scene::Resolution;
use std::collections::BTreeMap;
use std::path::Path;

struct Run {
    label: &'static str,
    technique: Box<dyn Technique>,
    targets: Targets,
    timer: GpuTimer,
    gpu_ms: Vec<f64>,
    wall_ms: Vec<f64>,
    /// Per pass kind ("init", "peel", "layer", …): the frame's sum, one entry per frame.
    kinds: BTreeMap<String, Vec<f64>>,
    geometry_passes: u32,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

fn min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

impl Run {
    fn frame(&mut self, ctx: &Context, scene: &GpuScene, record: bool) -> anyhow::Result<()> {
        let start = std::time::Instant::now();
        let f = oit_gpu::render_frame(
            ctx,
            scene,
            self.technique.as_mut(),
            &self.targets,
            &mut self.timer,
        )?;
        let wall = start.elapsed().as_secs_f64() * 1e3;
        if !record {
            return Ok(());
        }
        self.wall_ms.push(wall);
        // The shared opaque pass is not the technique's.
        let mine = f.timings.passes.iter().filter(|p| p.name != "opaque");
        self.gpu_ms.push(mine.clone().map(|p| p.ms).sum());
        let mut sums: BTreeMap<String, f64> = BTreeMap::new();
        for p in mine {
            let kind = match p.name.split(' ').next() {
                Some(k @ ("peel" | "layer" | "under")) => k.to_owned(),
                _ => p.name.clone(),
            };
            *sums.entry(kind).or_default() += p.ms;
        }
        for (k, v) in sums {
            self.kinds.entry(k).or_default().push(v);
        }
        self.geometry_passes = f.stats.geometry_passes;
        Ok(())
    }
}

/// What a CPU loop pays per pass at least: one copy-submit-map-wait cycle with nothing else
/// queued (the same cycle as the peel counters' readback).
fn round_trip(ctx: &Context) -> f64 {
    use oit_gpu::wgpu;
    let size = 1284;
    let src = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("round trip source"),
        size,
        usage: wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let dst = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("round trip readback"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut times = Vec::new();
    for _ in 0..51 {
        let start = std::time::Instant::now();
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&src, 0, &dst, 0, size);
        ctx.queue.submit([encoder.finish()]);
        // The same map, wait and copy-out the peel counters' readback does.
        if oit_gpu::read_buffer(ctx, &dst, "round trip readback").is_err() {
            return f64::NAN;
        }
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    median(times)
}

fn dual(passes: PassCount, depth: DepthFormat) -> DualPeelConfig {
    DualPeelConfig {
        passes,
        depth,
        accum: oit_peel::AccumFormat::Auto,
        reverse_z: true,
        tail: Tail::Drop,
        encoding: DepthEncoding::Window,
    }
}

fn with(f: impl FnOnce(&mut Options)) -> Options {
    let mut o = Options::default();
    f(&mut o);
    o
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("many-layers-64", String::as_str);
    let size: u32 = args.get(1).map_or(Ok(128), |s| s.parse())?;
    let frames: usize = args.get(2).map_or(Ok(7), |s| s.parse())?;
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.json"));
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
        "scene {name} {size}x{size}, max depth complexity L = {l}, {frames} interleaved rounds (median)\n"
    );

    let cpu_loop = with(|o| o.termination = Termination::CpuReadbackPerPass);
    let late = with(|o| o.test_before_shading = false);
    let full_init = with(|o| o.depth_only_init = false);
    let babylon = with(|o| {
        o.test_before_shading = false;
        o.depth_only_init = false;
    });
    let auto32 = dual(PassCount::Auto, DepthFormat::Rg32f);
    let front = FrontPeelConfig::default();
    let techniques: Vec<(&'static str, Box<dyn Technique>)> = vec![
        (
            "unsorted",
            oit_gpu::TechniqueSpec::build("unsorted", &oit_sorted::techniques())?,
        ),
        ("front-peel:layers=auto", Box::new(FrontPeel::new(front))),
        (
            "front-peel:layers=auto (shade before test)",
            Box::new(FrontPeel::with_options(front, late)),
        ),
        (
            "front-peel:layers=auto (CPU readback per pass)",
            Box::new(FrontPeel::with_options(front, cpu_loop)),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f",
            Box::new(DualPeel::new(auto32)),
        ),
        (
            "dual-peel:passes=auto,depth=rg16f",
            Box::new(DualPeel::new(dual(PassCount::Auto, DepthFormat::Rg16f))),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f (shade before test)",
            Box::new(DualPeel::with_options(auto32, late)),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f (full-shader init)",
            Box::new(DualPeel::with_options(auto32, full_init)),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f (both, as Babylon)",
            Box::new(DualPeel::with_options(auto32, babylon)),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f (CPU readback per pass)",
            Box::new(DualPeel::with_options(auto32, cpu_loop)),
        ),
        (
            "dual-peel:passes=5 (Babylon default)",
            Box::new(DualPeel::new(dual(
                PassCount::Fixed(oit_peel::Passes::of(5)),
                DepthFormat::Rg32f,
            ))),
        ),
        (
            "dual-peel:passes=5,tail=wboit",
            Box::new(DualPeel::new(DualPeelConfig {
                tail: Tail::Wboit,
                ..dual(
                    PassCount::Fixed(oit_peel::Passes::of(5)),
                    DepthFormat::Rg32f,
                )
            })),
        ),
    ];
    let mut runs = Vec::new();
    for (label, technique) in techniques {
        let mut run = Run {
            label,
            technique,
            targets: Targets::new(&ctx, scene.resolution, ColorFormat::Rgba16Float)?,
            timer: GpuTimer::new(&ctx),
            gpu_ms: Vec::new(),
            wall_ms: Vec::new(),
            kinds: BTreeMap::new(),
            geometry_passes: 0,
        };
        run.frame(&ctx, &gpu, false)?;
        runs.push(run);
    }
    for _ in 0..frames {
        for run in &mut runs {
            run.frame(&ctx, &gpu, true)?;
        }
    }
    println!(
        "{:58} {:>21} {:>21} {:>5} {:>6}",
        "technique", "gpu ms min [median]", "wall ms min [median]", "geom", "B/px"
    );
    for r in &runs {
        println!(
            "{:58} {:9.3} [{:9.3}] {:9.3} [{:9.3}] {:5} {:6.1}",
            r.label,
            min(&r.gpu_ms),
            median(r.gpu_ms.clone()),
            min(&r.wall_ms),
            median(r.wall_ms.clone()),
            r.geometry_passes,
            r.technique.memory_bytes() as f64 / pixels
        );
    }
    let get = |label: &str| runs.iter().find(|r| r.label == label).expect("measured");
    // Ratios are taken within a round (same load), then the median over rounds.
    let ratio = |a: &str, b: &str, wall: bool| {
        let (x, y) = (get(a), get(b));
        let (xs, ys) = if wall {
            (&x.wall_ms, &y.wall_ms)
        } else {
            (&x.gpu_ms, &y.gpu_ms)
        };
        median(xs.iter().zip(ys).map(|(p, q)| p / q).collect())
    };
    let lf = f64::from(l);
    let (front, dual32) = (
        "front-peel:layers=auto",
        "dual-peel:passes=auto,depth=rg32f",
    );
    println!("\nmedian over rounds of same-round ratios (gpu time unless noted):");
    println!(
        "  per peeled layer: front {:.3}x unsorted, dual {:.3}x unsorted; dual / front = {:.3}",
        ratio(front, "unsorted", false) / lf,
        ratio(dual32, "unsorted", false) / lf,
        ratio(dual32, front, false)
    );
    for r in &runs[1..] {
        let base = if r.label.starts_with("front") {
            front
        } else {
            dual32
        };
        if r.label != base {
            println!(
                "  {:58} {:.3}x {base} (wall {:.3}x)",
                r.label,
                ratio(r.label, base, false),
                ratio(r.label, base, true)
            );
        }
    }
    for r in &runs {
        let kinds: Vec<String> = r
            .kinds
            .iter()
            .map(|(k, v)| format!("{k} {:.3}", median(v.clone())))
            .collect();
        println!("  {} (median ms): {}", r.label, kinds.join(", "));
    }
    println!(
        "\nround trip (copy, submit, map, wait) on an idle queue: {:.3} ms median",
        round_trip(&ctx)
    );
    for (gated, looped) in [
        (front, "front-peel:layers=auto (CPU readback per pass)"),
        (
            dual32,
            "dual-peel:passes=auto,depth=rg32f (CPU readback per pass)",
        ),
    ] {
        let (x, y) = (get(gated), get(looped));
        let diff = median(
            y.wall_ms
                .iter()
                .zip(&x.wall_ms)
                .map(|(b, a)| b - a)
                .collect(),
        );
        println!(
            "stall: {looped}: wall minus gated wall, same round, median {diff:+.3} ms ({:+.3} ms per pass)",
            diff / f64::from(y.geometry_passes)
        );
    }
    Ok(())
}
