//! Deep stacks: `auto` peels until nothing is left, far beyond the old fixed caps (128 layers
//! for front peeling, 64 passes for dual peeling), and a too-small explicit budget reports the
//! pixels it cut. Screen-filling stacks of 200 and 1000 layers at 16×16 / 8×8 so lavapipe
//! finishes in seconds; the exact answer is `oit_reference`'s.

use super::common::*;
use oit_gpu::{ColorFormat, Context, GpuScene, RenderStats, Technique};
use oit_peel::{
    DepthEncoding, DepthFormat, DualPeel, DualPeelConfig, FrontPeel, FrontPeelConfig, Options,
    PassCount, PeelReport, Tail, Termination,
};
use oit_scene::{LinearImage, Scene};

/// Largest error allowed against the reference (the Rgba16Float target's rounding).
const MAX: f64 = 4e-3;

/// A screen-filling stack of `front + back` layers, one draw each, tie-free (0.008 apart over
/// an orthographic depth range of 29.5, i.e. window depths ≥ 2.7e-4 apart), drawn front to
/// back: `front` warm layers, then `back` blue ones behind them, each of coverage
/// `alpha`, over a dark background. `back = 0` is the same stack with its last layers cut.
fn stack(front: u32, back: u32, alpha: f64, size: u32) -> Scene {
    let spacing = 0.008;
    let layers = |count: u32, z: f64, from: [f64; 3], to: [f64; 3]| {
        format!(
            r#"{{"mesh": {{"kind": "layers", "count": {count}, "spacing": {spacing}, "size": [4, 4],
                "color_from": {from:?}, "color_to": {to:?}, "alpha_from": {alpha}, "alpha_to": {alpha}}},
              "transform": {{"translate": [0, 0, {z}]}}, "material": {{"mode": "blend"}}}}"#
        )
    };
    let mut objects = vec![layers(front, 4.0, [1.0, 0.55, 0.1], [0.9, 0.2, 0.5])];
    if back > 0 {
        let z = 4.0 - f64::from(front) * spacing;
        objects.push(layers(back, z, [0.1, 0.3, 1.0], [0.1, 0.3, 1.0]));
    }
    let json = format!(
        r#"{{"name": "stack-{front}+{back}", "resolution": [{size}, {size}],
            "camera": {{"eye": [0, 0, 10], "target": [0, 0, 0], "orthographic": {{"height": 2}},
                        "near": 0.5, "far": 30}},
            "background": [0.02, 0.02, 0.03],
            "objects": [{}]}}"#,
        objects.join(",\n")
    );
    oit_scene::parse(&json, "deep-stack").unwrap_or_else(|e| panic!("{e}"))
}

/// `layers` layers at α = 2 / layers: the whole stack lets e⁻² ≈ 13.5 % of the background
/// through and its last 10 % still hold e⁻¹·⁸ ≈ 16.5 % of the light, so cutting them is
/// visible (asserted in [`the_last_tenth_of_the_stack_is_visible`]).
fn deep(layers: u32, size: u32) -> (Scene, Scene) {
    let back = layers / 10;
    let alpha = 2.0 / f64::from(layers);
    (
        stack(layers - back, back, alpha, size),
        stack(layers - back, 0, alpha, size),
    )
}

/// One frame into Rgba16Float targets (the harness's default).
fn render16(
    ctx: &Context,
    gpu: &GpuScene,
    technique: &mut dyn Technique,
) -> (LinearImage, RenderStats) {
    let (image, frame) = crate::kit::render_uploaded(ctx, gpu, technique, ColorFormat::Rgba16Float);
    (image, frame.stats)
}

fn dual_auto() -> DualPeel {
    DualPeel::new(DualPeelConfig {
        passes: PassCount::Auto,
        depth: DepthFormat::Rg32f,
        accum: oit_peel::AccumFormat::Auto,
        reverse_z: true,
        tail: Tail::Drop,
        encoding: DepthEncoding::Window,
    })
}

/// The stack's property the exactness tests rely on: without its last tenth the reference
/// differs by far more than the tolerance, so a peeler that stopped early would fail them.
#[test]
fn the_last_tenth_of_the_stack_is_visible() {
    for (layers, size) in [(200, 16), (1000, 8)] {
        let (full, cut) = deep(layers, size);
        let full_ref = reference(&full);
        let cut_ref = reference(&cut);
        assert_eq!(full_ref.stats.max_depth_complexity, layers);
        assert!(
            full_ref.layers.iter().all(|&l| l == layers),
            "screen-filling"
        );
        let d = max_diff(&full_ref.image, &cut_ref.image);
        println!("{layers} layers: the last tenth changes the image by up to {d:.3e}");
        assert!(
            d > 5.0 * MAX,
            "{layers} layers: cutting the last tenth changes only {d:.2e}"
        );
    }
}

/// Checks one exact render of a stack of `layers` layers everywhere.
fn assert_exact(
    label: &str,
    image: &LinearImage,
    stats: &RenderStats,
    report: &PeelReport,
    reference: &oit_reference::Reference,
    expected_passes: u32,
) {
    let layers = reference.stats.max_depth_complexity;
    let e = errors(image, &reference.image);
    println!(
        "{label}: rmse {:.2e} max {:.2e}, {} geometry passes, peeled {} (reference {}), dropped px {}, {} pass slots, {} readbacks",
        e.rmse,
        e.max_abs,
        stats.geometry_passes,
        stats.layers_peeled,
        reference.stats.composited_fragments,
        stats.pixels_with_dropped_layers,
        report.pass_slots,
        report.readbacks
    );
    assert!(e.max_abs <= MAX, "{label}: max error {:.3e}", e.max_abs);
    assert_eq!(stats.pixels_with_dropped_layers, 0, "{label}");
    assert_eq!(
        stats.layers_peeled, reference.stats.composited_fragments,
        "{label}: every layer of every pixel once"
    );
    assert_eq!(
        stats.layers_peeled,
        u64::from(layers) * reference.layers.len() as u64,
        "{label}"
    );
    assert_eq!(stats.geometry_passes, expected_passes, "{label}");
    assert!(
        report.pass_slots >= expected_passes - 1,
        "{label}: {} pass slots",
        report.pass_slots
    );
}

fn front_and_dual_are_exact(layers: u32, size: u32) {
    let name = format!("front_and_dual_are_exact_on_{layers}_layers");
    let Some(ctx) = oit_gpu::testing::context_or_skip(&name) else {
        return;
    };
    let (scene, _) = deep(layers, size);
    let reference = reference(&scene);
    assert_eq!(reference.stats.max_depth_complexity, layers);
    let gpu = GpuScene::upload(&ctx, &scene).expect("upload");

    let mut front = FrontPeel::new(FrontPeelConfig {
        layers: PassCount::Auto,
    });
    let t = std::time::Instant::now();
    let (image, stats) = render16(&ctx, &gpu, &mut front);
    println!(
        "front-peel, {layers} layers, {size}²: {:.2} s (first frame, wall clock)",
        t.elapsed().as_secs_f64()
    );
    // Opaque-depth pass, one pass per layer, and the pass that finds nothing.
    assert_exact(
        &format!("front-peel:layers=auto, {layers} layers"),
        &image,
        &stats,
        front.last_report(),
        &reference,
        layers + 2,
    );

    let mut dual = dual_auto();
    let t = std::time::Instant::now();
    let (image, stats) = render16(&ctx, &gpu, &mut dual);
    println!(
        "dual-peel, {layers} layers, {size}²: {:.2} s (first frame, wall clock)",
        t.elapsed().as_secs_f64()
    );
    // The init pass and ⌈L/2⌉ peel passes.
    assert_exact(
        &format!("dual-peel:passes=auto,depth=rg32f, {layers} layers"),
        &image,
        &stats,
        dual.last_report(),
        &reference,
        1 + layers.div_ceil(2),
    );
    // The second frame records exactly the passes it needs and reads back once.
    let (again, stats2) = render16(&ctx, &gpu, &mut dual);
    assert_eq!(max_diff(&image, &again), 0.0);
    assert_eq!(stats2, stats);
    assert_eq!(dual.last_report().readbacks, 1);
    assert_eq!(dual.last_report().passes_recorded, 1 + layers.div_ceil(2));
}

#[test]
fn auto_is_exact_on_200_layers() {
    front_and_dual_are_exact(200, 16);
}

#[test]
fn auto_is_exact_on_1000_layers() {
    front_and_dual_are_exact(1000, 8);
}

/// The classic loop (a CPU wait per pass) grows the per-pass counters and indices the same
/// way, mid-frame, and renders the same image with the same counts.
#[test]
fn the_cpu_loop_grows_its_pass_slots_too() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("the_cpu_loop_grows") else {
        return;
    };
    let (scene, _) = deep(200, 16);
    let gpu = GpuScene::upload(&ctx, &scene).expect("upload");
    let cpu = Options {
        termination: Termination::CpuReadbackPerPass,
        ..Options::default()
    };
    let front = FrontPeelConfig {
        layers: PassCount::Auto,
    };
    let (gated, gated_stats) = render16(&ctx, &gpu, &mut FrontPeel::new(front));
    let mut looped = FrontPeel::with_options(front, cpu);
    let (image, stats) = render16(&ctx, &gpu, &mut looped);
    assert_eq!(max_diff(&gated, &image), 0.0, "front");
    assert_eq!(stats, gated_stats, "front");
    assert_eq!(looped.last_report().readbacks, 201, "one per layer pass");
    assert!(looped.last_report().pass_slots >= 201);

    let (gated, gated_stats) = render16(&ctx, &gpu, &mut dual_auto());
    let config = DualPeelConfig {
        passes: PassCount::Auto,
        depth: DepthFormat::Rg32f,
        accum: oit_peel::AccumFormat::Auto,
        ..DualPeelConfig::default()
    };
    let mut looped = DualPeel::with_options(config, cpu);
    let (image, stats) = render16(&ctx, &gpu, &mut looped);
    assert_eq!(max_diff(&gated, &image), 0.0, "dual");
    assert_eq!(stats, gated_stats, "dual");
    assert_eq!(
        looped.last_report().readbacks,
        101,
        "init and one per peel pass"
    );
    assert!(looped.last_report().pass_slots >= 101);
}

/// An explicit budget below the depth complexity cuts every pixel and says so: exactly the
/// budget's layers are peeled, every pixel is counted as having lost layers.
#[test]
fn a_small_explicit_budget_reports_its_dropped_pixels() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("a_small_explicit_budget") else {
        return;
    };
    let (scene, _) = deep(200, 16);
    let reference = reference(&scene);
    let gpu = GpuScene::upload(&ctx, &scene).expect("upload");
    let pixels = reference.layers.len() as u64;
    let cases: [(&str, Box<dyn Technique>, u64); 2] = [
        ("front-peel:layers=10", build("front-peel:layers=10"), 10),
        (
            "dual-peel:passes=10,depth=rg32f",
            build("dual-peel:passes=10,depth=rg32f"),
            20,
        ),
    ];
    for (label, mut technique, peeled_per_pixel) in cases {
        let (image, stats) = render16(&ctx, &gpu, technique.as_mut());
        let e = errors(&image, &reference.image);
        println!("{label}: {stats:?}, max error {:.3e}", e.max_abs);
        assert_eq!(stats.pixels_with_dropped_layers, pixels, "{label}");
        assert_eq!(stats.layers_peeled, peeled_per_pixel * pixels, "{label}");
        assert!(e.max_abs > 10.0 * MAX, "{label}: the cut is visible");
    }
}

/// Explicit budgets have no fixed cap: the only bound is the adapter's, and a budget beyond it
/// is reported by `check` with the limit that sets it (here on a copy of the adapter's
/// capabilities with small limits).
#[test]
fn explicit_budgets_are_bounded_only_by_the_adapter() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("explicit_budgets_are_bounded") else {
        return;
    };
    let (slots, limit) = oit_peel::max_pass_slots(&ctx.caps);
    println!(
        "adapter {:?}: {slots} pass slots ({limit})",
        ctx.adapter_info().name
    );
    // Far beyond the old caps of 128 layers / 64 passes.
    assert!(slots > 100_000, "{slots}");
    for spec in ["front-peel:layers=100000", "dual-peel:passes=50000"] {
        build(spec)
            .check(&ctx.caps)
            .unwrap_or_else(|e| panic!("{spec}: {e}"));
    }

    // 1024 storage bytes: 1 header word and 255 / 2 = 127 pass records.
    let mut small = ctx.caps.clone();
    small.max_storage_buffer_binding_size = 1024;
    small.max_buffer_size = 1 << 30;
    small.min_uniform_buffer_offset_alignment = 256;
    assert_eq!(oit_peel::max_pass_slots(&small).0, 127);
    assert_eq!(oit_peel::max_front_layers(&small), 127);
    assert_eq!(oit_peel::max_dual_passes(&small), 126);
    for (ok, too_many, n) in [
        (
            "front-peel:layers=127",
            "front-peel:layers=128",
            "layers=128",
        ),
        (
            "dual-peel:passes=126,depth=rg32f",
            "dual-peel:passes=127,depth=rg32f",
            "passes=127",
        ),
    ] {
        build(ok)
            .check(&small)
            .unwrap_or_else(|e| panic!("{ok}: {e}"));
        let e = build(too_many).check(&small).expect_err(too_many);
        assert!(
            e.reason.contains(n)
                && e.reason.contains("at most")
                && e.reason.contains("max_storage_buffer_binding_size"),
            "{e}"
        );
        // `auto` is always allowed: it stops where the adapter does.
        let auto = if ok.starts_with("front") {
            "front-peel:layers=auto"
        } else {
            "dual-peel:passes=auto,depth=rg32f"
        };
        build(auto).check(&small).expect("auto");
    }

    // 64 KiB buffers with 256-byte dynamic offsets: 256 pass-index slots.
    let mut few_offsets = ctx.caps.clone();
    few_offsets.max_storage_buffer_binding_size = 1 << 30;
    few_offsets.max_buffer_size = 64 << 10;
    few_offsets.min_uniform_buffer_offset_alignment = 256;
    let (slots, limit) = oit_peel::max_pass_slots(&few_offsets);
    assert_eq!(slots, 256);
    assert!(limit.contains("max_buffer_size"), "{limit}");
    let e = build("front-peel:layers=257")
        .check(&few_offsets)
        .expect_err("257 layers");
    assert!(e.reason.contains("max_buffer_size"), "{e}");
}
