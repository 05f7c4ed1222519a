//! GPU time of every technique family at its defaults, in the criterion `Measurement` of
//! `oit_benches::gpu_time`: values are GPU milliseconds per frame (timestamp queries), or
//! wall-clock milliseconds where the adapter has none; the group name and the units say which.
//!
//! One frame is what `oit compare` times: the shared opaque pass plus the technique. The
//! `floor` group times the same frame with one vertex-colour blended pass instead of a technique
//! (`oit_gpu::Floor`): divide by it to see how far a technique is from the adapter's limit. Scenes are
//! small (128x128) so that `cargo bench -p oit-benches --bench techniques -- --quick` finishes in
//! minutes on lavapipe; pass `OIT_BENCH_SIZE=512` for a larger frame.

use std::path::Path;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion};
use oit_benches::gpu_time::{GpuClock, GpuTime};
use oit_gpu::{
    ColorFormat, Context, GpuScene, GpuTimer, Targets, Technique, TechniqueSpec, render_frame,
};
use oit_scene::{Resolution, Scene};

/// Scenes with opposite loads: 64 full-screen layers (fill and depth complexity) and
/// thousands of small billboards (triangle count, CPU sorting).
const SCENES: [&str; 2] = ["many-layers-64", "particles"];

fn scene(name: &str, size: u32) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(format!("{name}.json"));
    oit_scene::load(&path)
        .unwrap_or_else(|e| panic!("{e}"))
        .with_resolution(Resolution {
            width: size,
            height: size,
        })
}

/// Builds a fresh technique per scene.
type Builder = Box<dyn Fn() -> Box<dyn Technique>>;

fn techniques(c: &mut Criterion<GpuTime>, ctx: &Context, clock: &GpuClock, size: u32) {
    let registry = oit_harness::registry();
    let specs = oit_harness::resolve_specs(&[]).unwrap_or_else(|e| panic!("{e}"));
    let scenes: Vec<Scene> = SCENES.iter().map(|name| scene(name, size)).collect();
    // The floor first: one vertex-colour blended pass, the least any technique can spend.
    let mut families: Vec<(String, Builder)> = vec![(
        oit_gpu::FLOOR_NAME.to_owned(),
        Box::new(|| Box::new(oit_gpu::Floor::new())),
    )];
    for spec in specs {
        let registry = registry.clone();
        let canonical = spec.canonical();
        families.push((
            spec.name().to_owned(),
            Box::new(move || {
                TechniqueSpec::build(&canonical, &registry).unwrap_or_else(|e| panic!("{e}"))
            }),
        ));
    }
    for (family, build) in &families {
        let group_name = format!("{family} [{}]", clock.source().name());
        let mut group = c.benchmark_group(group_name);
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(300))
            .measurement_time(Duration::from_secs(2));
        for scene in &scenes {
            let mut technique = build();
            let canonical = technique.spec().canonical();
            if let Err(unsupported) = technique.check(&ctx.caps) {
                eprintln!(
                    "skipped {canonical} on {}: {}",
                    scene.name, unsupported.reason
                );
                continue;
            }
            let gpu_scene = GpuScene::upload(ctx, scene).unwrap_or_else(|e| panic!("{e}"));
            let targets = Targets::new(ctx, scene.resolution, ColorFormat::Rgba16Float)
                .unwrap_or_else(|e| panic!("{e}"));
            let mut timer = GpuTimer::new(ctx);
            let id = BenchmarkId::new(format!("{}/{size}x{size}", scene.name), &canonical);
            group.bench_function(id, |b| {
                b.iter(|| {
                    let frame =
                        render_frame(ctx, &gpu_scene, technique.as_mut(), &targets, &mut timer)
                            .unwrap_or_else(|e| panic!("{canonical} on {}: {e}", scene.name));
                    clock
                        .record(&frame.timings)
                        .unwrap_or_else(|e| panic!("{e}"))
                })
            });
        }
        group.finish();
    }
}

fn main() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("benches/techniques") else {
        return;
    };
    let size = std::env::var("OIT_BENCH_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(128);
    let info = ctx.adapter_info();
    let source = GpuTimer::new(&ctx).source();
    println!(
        "adapter: {} ({}, {}); frame times from {}",
        info.name,
        info.backend,
        info.driver,
        source.name()
    );
    let (measurement, clock) = GpuTime::new(source);
    let mut c = Criterion::default()
        .with_measurement(measurement)
        .configure_from_args();
    techniques(&mut c, &ctx, &clock, size);
    c.final_summary();
}
