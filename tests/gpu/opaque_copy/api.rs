//! What `opaque-copy` reports besides its image: the specs it accepts, the adapters it refuses,
//! its pass count, CPU time and memory, and a resize of a reused instance.

use oit_gpu::testing::context_or_skip;
use oit_gpu::{ColorFormat, Context, RenderStats, SpecError, Technique, TechniqueSpec};
use oit_opaque_copy::OpaqueCopy;
use oit_scene::{LinearImage, Scene};
use std::time::Instant;

/// A parameter opaque-copy does not have, declared here to set it by hand.
const SPP: oit_gpu::Param<oit_gpu::Bounded<1, 128>> = oit_gpu::Param::new(
    "spp",
    oit_gpu::Bounded::of(1),
    "not a parameter of opaque-copy",
);

#[test]
fn from_spec_refuses_another_name_and_any_parameter() {
    assert!(OpaqueCopy::from_spec(&TechniqueSpec::of("opaque-copy")).is_ok());
    assert!(matches!(
        OpaqueCopy::from_spec(&TechniqueSpec::of("wboit")),
        Err(SpecError::WrongTechnique { .. })
    ));
    let with_spp = TechniqueSpec::of("opaque-copy").with(&SPP, oit_gpu::Bounded::of(4));
    let e = OpaqueCopy::from_spec(&with_spp).unwrap_err();
    assert!(
        matches!(e, SpecError::UnknownKey { ref key, .. } if key == "spp"),
        "{e}"
    );
    assert_eq!(OpaqueCopy::default().spec().to_string(), "opaque-copy");
}

/// A wall, one tinted pane and `quads` small blended quads in front of it at `size`².
fn scene(quads: usize, size: u32) -> Scene {
    let mut objects = vec![
        r#"{"mesh": {"kind": "quad", "size": [4, 4]}, "transform": {"translate": [0, 0, -2]},
            "material": {"base_color": [0.9, 0.7, 0.5], "mode": "opaque"}}"#
            .to_owned(),
        r#"{"mesh": {"kind": "quad", "size": [4, 4]}, "transform": {"translate": [0, 0, 0]},
            "material": {"base_color": [1, 0.2, 0.1], "alpha": 0.9, "mode": "blend", "transmission": 0.8}}"#
            .to_owned(),
    ];
    for i in 0..quads {
        let (x, y) = ((i % 8) as f32 * 0.25 - 0.9, (i / 8) as f32 * 0.25 - 0.9);
        objects.push(format!(
            r#"{{"mesh": {{"kind": "quad", "size": [0.3, 0.3]}}, "transform": {{"translate": [{x}, {y}, {}]}},
                "material": {{"base_color": [0.1, 0.9, 0.2], "alpha": 0.5, "mode": "blend"}}}}"#,
            0.5 + i as f32 * 0.01
        ));
    }
    let json = format!(
        r#"{{"name": "opaque-copy-api", "resolution": [{size}, {size}],
            "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "orthographic": {{"height": 2}}, "near": 0.1, "far": 100}},
            "background": [0.1, 0.2, 0.3], "objects": [{}]}}"#,
        objects.join(",")
    );
    oit_scene::parse(&json, "opaque-copy-api.json").unwrap_or_else(|e| panic!("{e}"))
}

fn render(ctx: &Context, technique: &mut OpaqueCopy, scene: &Scene) -> (LinearImage, RenderStats) {
    let (image, frame) = crate::kit::render(ctx, scene, technique, ColorFormat::Rgba32Float);
    (image, frame.stats)
}

#[test]
fn an_adapter_without_vertex_storage_buffers_is_refused() {
    let Some(ctx) = context_or_skip("opaque_copy_check") else {
        return;
    };
    let technique = OpaqueCopy::default();
    technique.check(&ctx.caps).expect("this adapter runs it");
    let mut caps = ctx.caps.clone();
    caps.max_storage_buffers_per_shader_stage = 0;
    let e = technique.check(&caps).unwrap_err();
    assert!(e.reason.contains("storage buffers"), "{e}");
}

/// Two geometry passes; the CPU time is the draw lists' (64 blended quads to order): more than
/// 100 ns and no more than the frame's wall time, in milliseconds.
#[test]
fn stats_count_two_passes_and_the_cpu_time_of_the_draw_lists() {
    let Some(ctx) = context_or_skip("opaque_copy_stats") else {
        return;
    };
    let s = scene(64, 32);
    let mut technique = OpaqueCopy::default();
    render(&ctx, &mut technique, &s);
    let start = Instant::now();
    let (_, stats) = render(&ctx, &mut technique, &s);
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    println!("{stats:?}, frame wall time {wall_ms:.2} ms");
    assert_eq!(stats.geometry_passes, 2);
    assert!(
        stats.cpu_ms > 1e-4 && stats.cpu_ms <= wall_ms,
        "cpu {} ms, frame {wall_ms} ms",
        stats.cpu_ms
    );
}

/// Memory is the colour copy, one texel per pixel in the target's format; an instance reused
/// at another size rebuilds it and renders what a fresh instance does.
#[test]
fn memory_is_the_colour_copy_and_a_resize_rebuilds_it() {
    let Some(ctx) = context_or_skip("opaque_copy_memory") else {
        return;
    };
    let mut technique = OpaqueCopy::default();
    assert_eq!(technique.memory_bytes(), 0);
    render(&ctx, &mut technique, &scene(4, 32));
    // Rgba32Float: 16 bytes per pixel.
    assert_eq!(technique.memory_bytes(), 32 * 32 * 16);
    let larger = scene(4, 48);
    let (reused, _) = render(&ctx, &mut technique, &larger);
    assert_eq!(technique.memory_bytes(), 48 * 48 * 16);
    let (fresh, _) = render(&ctx, &mut OpaqueCopy::default(), &larger);
    assert_eq!(reused.pixels, fresh.pixels);
}
