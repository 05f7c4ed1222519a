//! Occlusion counts per pass (`GpuTimer::counting_fragments`) are exact: a screen-filling
//! quad passes W·H samples in a scene pass and in a full-screen pass, and `unsorted`'s blend
//! pass lets through exactly the reference's composited fragments, on a bundled scene and on
//! seeded random ones. lavapipe's pipeline-statistics fragment counter counts whole 4×4 blocks,
//! so only occlusion queries are used for counts.

use oit_gpu::{ColorFormat, GpuScene, GpuTimer, Targets, TechniqueSpec};
use oit_scene::Scene;

use crate::kit;

/// A context whose occlusion queries count samples (Vulkan), or `None` with the reason printed.
fn counting_context(test: &str) -> Option<oit_gpu::Context> {
    let ctx = oit_gpu::testing::context_or_skip(test)?;
    if !oit_gpu::occlusion_counts_samples(&ctx.caps) {
        println!(
            "{test}: skipped, occlusion queries on {:?} are boolean in wgpu",
            ctx.caps.backend
        );
        return None;
    }
    Some(ctx)
}

/// An opaque backdrop and a transparent quad in front, both filling a 37×23 view.
fn two_screen_filling_quads() -> Scene {
    oit_scene::parse(
        r#"{"name": "screen-filling quads", "description": "", "resolution": [37, 23],
        "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100},
        "background": [0, 0, 0],
        "objects": [
            {"mesh": {"kind": "quad", "size": [40, 40]}, "transform": {"translate": [0, 0, -2]},
             "material": {"base_color": [1, 0, 0], "mode": "opaque"}},
            {"mesh": {"kind": "quad", "size": [40, 40]},
             "material": {"base_color": [0, 1, 0], "alpha": 0.5, "mode": "blend"}}]}"#,
        "screen-filling.json",
    )
    .expect("scene")
}

/// Per pass of one counted frame of `spec` on `scene`: (name, samples).
fn counted_frame(ctx: &oit_gpu::Context, scene: &Scene, spec: &str) -> Vec<(String, Option<u64>)> {
    let gpu = GpuScene::upload(ctx, scene).expect("upload");
    let targets = Targets::new(ctx, scene.resolution, ColorFormat::Rgba16Float).expect("targets");
    let mut technique = TechniqueSpec::build(spec, &oit_harness::registry()).expect("valid spec");
    let mut timer = GpuTimer::new(ctx).counting_fragments(ctx);
    // Twice: the second frame's counts must not include the first's.
    for _ in 0..2 {
        oit_gpu::render_frame(ctx, &gpu, technique.as_mut(), &targets, &mut timer)
            .unwrap_or_else(|e| panic!("{spec}: {e}"));
    }
    timer
        .pass_fragments()
        .expect("a counting timer")
        .iter()
        .map(|p| (p.name.clone(), p.samples))
        .collect()
}

fn samples(passes: &[(String, Option<u64>)], name: &str) -> Option<u64> {
    passes
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no pass {name:?} in {passes:?}"))
        .1
}

#[test]
fn a_screen_filling_quad_passes_exactly_w_times_h() {
    let Some(ctx) = counting_context("a_screen_filling_quad_passes_exactly_w_times_h") else {
        return;
    };
    let scene = two_screen_filling_quads();
    let pixels = 37 * 23;
    let unsorted = counted_frame(&ctx, &scene, "unsorted");
    assert_eq!(samples(&unsorted, "opaque"), Some(pixels), "{unsorted:?}");
    assert_eq!(samples(&unsorted, "blend"), Some(pixels), "{unsorted:?}");
    // A full-screen triangle (no depth attachment, nothing discarded).
    let wboit = counted_frame(&ctx, &scene, "wboit");
    assert_eq!(
        samples(&wboit, "wboit accumulate"),
        Some(pixels),
        "{wboit:?}"
    );
    assert_eq!(
        samples(&wboit, "wboit composite"),
        Some(pixels),
        "{wboit:?}"
    );
    // A timer that does not count says so.
    let gpu = GpuScene::upload(&ctx, &scene).expect("upload");
    let targets = Targets::new(&ctx, scene.resolution, ColorFormat::Rgba16Float).expect("targets");
    let mut plain = GpuTimer::new(&ctx);
    let mut technique = TechniqueSpec::build("unsorted", &oit_harness::registry()).expect("spec");
    oit_gpu::render_frame(&ctx, &gpu, technique.as_mut(), &targets, &mut plain).expect("frame");
    assert!(plain.pass_fragments().is_none());
}

/// `unsorted` blends every transparent fragment in front of the opaque depth once: its pass
/// count is the reference's composited fragments, where the reference decides every pixel
/// (no fragment within the cutoff band, no precision tie).
#[test]
fn unsorted_passes_the_reference_composited_fragments() {
    let Some(ctx) = counting_context("unsorted_passes_the_reference_composited_fragments") else {
        return;
    };
    let mut scenes = vec![
        kit::bundled(
            "many-layers-64",
            oit_scene::Resolution {
                width: 61,
                height: 47,
            },
        ),
        kit::bundled(
            "sorted-quads",
            oit_scene::Resolution {
                width: 64,
                height: 64,
            },
        ),
    ];
    for seed in 0..40 {
        let (text, _) = oit_scene::random::random_scene_json(seed);
        scenes.push(oit_scene::parse(&text, &format!("random-{seed}")).expect("random scene"));
    }
    let (mut compared, mut undecided) = (0, 0);
    let mut failures = Vec::new();
    for scene in &scenes {
        let reference = oit_reference::render(scene, &Default::default());
        if reference.stats.undecided_fragments > 0 || reference.stats.precision_tie_pixels > 0 {
            undecided += 1;
            continue;
        }
        let passes = counted_frame(&ctx, scene, "unsorted");
        let blend = samples(&passes, "blend");
        if blend != Some(reference.stats.composited_fragments) {
            failures.push(format!(
                "{}: blend pass {blend:?}, reference {}",
                scene.name, reference.stats.composited_fragments
            ));
        }
        compared += 1;
    }
    println!(
        "occlusion vs reference: {compared} scenes compared, {undecided} with undecided pixels left out"
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(
        compared >= 20,
        "only {compared} scenes were decided everywhere"
    );
}

/// More passes than one occlusion query set holds (4096): every pass keeps its own count, and
/// a pass that began no query (a compute pass) reads as not counted, not as 0.
#[test]
fn counts_go_beyond_one_query_set_and_compute_passes_are_not_counted() {
    let Some(ctx) =
        counting_context("counts_go_beyond_one_query_set_and_compute_passes_are_not_counted")
    else {
        return;
    };
    let res = oit_scene::Resolution {
        width: 4,
        height: 4,
    };
    let targets = Targets::new(&ctx, res, ColorFormat::Rgba16Float).expect("targets");
    let n = oit_gpu::wgpu::QUERY_SET_MAX_QUERIES + 9;
    let mut timer = GpuTimer::wall_clock().counting_fragments(&ctx);
    timer.begin_frame();
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    for i in 0..n {
        let ts = timer.pass(&format!("clear {i}"));
        let _ = oit_gpu::pass::begin(
            &mut encoder,
            "clear",
            &[oit_gpu::pass::color(
                &targets.color_view,
                oit_gpu::wgpu::LoadOp::Clear(oit_gpu::wgpu::Color::BLACK),
            )],
            None,
            &ts,
        );
    }
    let ts = timer.pass("a compute pass");
    drop(
        encoder.begin_compute_pass(&oit_gpu::wgpu::ComputePassDescriptor {
            label: None,
            timestamp_writes: ts.compute_writes(),
        }),
    );
    timer.submit(&ctx, encoder).expect("submit");
    timer.end_frame(&ctx).expect("end frame");
    let counted = timer.pass_fragments().expect("counting");
    assert_eq!(counted.len(), n as usize + 1);
    for (i, p) in counted[..n as usize].iter().enumerate() {
        assert_eq!(p.name, format!("clear {i}"));
        // A clear rasterizes nothing.
        assert_eq!(p.samples, Some(0), "{p:?}");
    }
    assert_eq!(counted[n as usize].samples, None);
}
