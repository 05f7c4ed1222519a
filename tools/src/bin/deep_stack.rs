//! What `auto` costs on a deep stack: L screen-filling layers (one draw each, tie-free, α =
//! 2 / L), front and dual peeling, first (cold) frame and warm frames, GPU time by pass kind,
//! memory, and the error against the reference.
//!
//! `cargo run --release -p oit-tools --bin deep_stack -- [LAYERS] [SIZE] [FRAMES]`
//! (defaults: 1000 8 3).

use oit_gpu::{ColorFormat, Context, ContextOptions, GpuScene, GpuTimer, Targets, Technique};
use oit_peel::{
    DepthEncoding, DepthFormat, DualPeel, DualPeelConfig, FrontPeel, FrontPeelConfig, PassCount,
    Tail,
};
use std::collections::BTreeMap;

fn stack_json(layers: u32, size: u32) -> String {
    let alpha = 2.0 / f64::from(layers);
    format!(
        r#"{{"name": "stack-{layers}", "resolution": [{size}, {size}],
            "camera": {{"eye": [0, 0, 10], "target": [0, 0, 0], "orthographic": {{"height": 2}},
                        "near": 0.5, "far": 30}},
            "background": [0.02, 0.02, 0.03],
            "objects": [{{"mesh": {{"kind": "layers", "count": {layers}, "spacing": 0.008,
                "size": [4, 4], "color_from": [1, 0.55, 0.1], "color_to": [0.1, 0.3, 1],
                "alpha_from": {alpha}, "alpha_to": {alpha}}},
              "transform": {{"translate": [0, 0, 4]}}, "material": {{"mode": "blend"}}}}]}}"#
    )
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let layers: u32 = args.first().map_or(Ok(1000), |s| s.parse())?;
    let size: u32 = args.get(1).map_or(Ok(8), |s| s.parse())?;
    let frames: usize = args.get(2).map_or(Ok(3), |s| s.parse())?;
    let scene = oit_scene::parse(&stack_json(layers, size), "deep stack")?;
    let reference = oit_reference::render(&scene, &oit_reference::ReferenceOptions::default());
    let ctx = Context::new(&ContextOptions::default())?;
    let gpu = GpuScene::upload(&ctx, &scene)?;
    let (slots, limit) = oit_peel::max_pass_slots(&ctx.caps);
    println!(
        "adapter {:?} ({}), timing {:?}; pass slots at most {slots} ({limit}): front-peel {} layers, dual-peel {} passes",
        ctx.adapter_info().name,
        ctx.adapter_info().backend,
        GpuTimer::new(&ctx).source(),
        oit_peel::max_front_layers(&ctx.caps),
        oit_peel::max_dual_passes(&ctx.caps),
    );
    println!("stack of {layers} layers at {size}x{size}, Rgba16Float target, {frames} warm frames");
    let techniques: Vec<(&str, Box<dyn Technique>)> = vec![
        (
            "front-peel:layers=auto",
            Box::new(FrontPeel::new(FrontPeelConfig {
                layers: PassCount::Auto,
            })),
        ),
        (
            "dual-peel:passes=auto,depth=rg32f",
            Box::new(DualPeel::new(DualPeelConfig {
                passes: PassCount::Auto,
                depth: DepthFormat::Rg32f,
                accum: oit_peel::AccumFormat::Auto,
                reverse_z: true,
                tail: Tail::Drop,
                encoding: DepthEncoding::Window,
            })),
        ),
    ];
    for (label, mut technique) in techniques {
        let targets = Targets::new(&ctx, scene.resolution, ColorFormat::Rgba16Float)?;
        let mut timer = GpuTimer::new(&ctx);
        let mut walls = Vec::new();
        let mut last = None;
        for _ in 0..=frames {
            let start = std::time::Instant::now();
            let f = oit_gpu::render_frame(&ctx, &gpu, technique.as_mut(), &targets, &mut timer)?;
            walls.push(start.elapsed().as_secs_f64() * 1e3);
            last = Some(f);
        }
        let f = last.expect("at least one frame");
        let image = oit_gpu::read_color(&ctx, &targets)?;
        let e = oit_metrics::compare(&image, &reference.image)?;
        let mut kinds: BTreeMap<String, (usize, f64)> = BTreeMap::new();
        for p in f.timings.passes.iter().filter(|p| p.name != "opaque") {
            let kind = p.name.split(' ').next().unwrap_or("").to_owned();
            let k = kinds.entry(kind).or_default();
            k.0 += 1;
            k.1 += p.ms;
        }
        let warm = walls[1..].iter().copied().fold(f64::INFINITY, f64::min);
        println!(
            "\n{label}: cold frame {:.0} ms wall, warm frame {warm:.0} ms wall (min of {frames}), GPU {:.0} ms ({:?}); {} geometry passes, {} layers peeled, {} px dropped; {} bytes ({:.0} B/px); max error {:.2e}",
            walls[0],
            f.timings.total_ms,
            f.timings.source,
            f.stats.geometry_passes,
            f.stats.layers_peeled,
            f.stats.pixels_with_dropped_layers,
            technique.memory_bytes(),
            technique.memory_bytes() as f64 / f64::from(size * size),
            e.max_abs
        );
        for (kind, (n, ms)) in kinds {
            println!(
                "  {kind:10} {n:5} passes {ms:9.1} ms ({:.3} ms each)",
                ms / n as f64
            );
        }
    }
    Ok(())
}
