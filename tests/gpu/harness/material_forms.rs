//! Scene draws read their material per vertex (flat varyings, crates/oit-gpu/shaders/scene_io/vertex.wgsl) or
//! per draw (a uniform, crates/oit-gpu/shaders/scene_io/draw.wgsl), whichever costs less for the size of their
//! triangles (`GpuScene::reads_material_per_draw`). Which one is used must never show: every
//! technique draws the same bits with either form, and with or without the pipelines
//! specialised for what a material fixes (`OVER_ONLY`, `STRAIGHT_OVER`, `UNIT_FACTORS`:
//! `GpuScene::set_specialised`).

use oit_gpu::testing::context_or_skip;
use oit_gpu::{ColorFormat, GpuScene, GpuTimer, Targets, read_color, render_frame};
use oit_harness::{registry, resolve_specs};
use oit_scene::{LinearImage, Resolution};

fn repo() -> std::path::PathBuf {
    crate::kit::root()
}

/// Every technique at its defaults, on scenes that reach every material property `shade()`
/// reads (cutoffs and mask-blend, double-sided, textures, intensity, transmission, opaque
/// occluders, small and large triangles), in Rgba32Float so no rounding of the target hides a
/// difference: the per-vertex and per-draw forms, and the general and specialised pipelines,
/// give bit-identical images.
#[test]
fn every_technique_draws_the_same_bits_with_either_material_form() {
    let Some(ctx) =
        context_or_skip("every_technique_draws_the_same_bits_with_either_material_form")
    else {
        return;
    };
    let specs = resolve_specs(&[]).expect("default specs");
    assert_eq!(specs.len(), registry().len());
    let size = Resolution {
        width: 40,
        height: 32,
    };
    let mut compared = 0;
    let mut failures = Vec::new();
    let mut unit_factors = [0; 2];
    for name in [
        "foliage-cards",
        "gltf-alpha-blend-modes",
        "hdr-emissive",
        "transmission-over-blended",
        "opaque-interleaved",
        "particles",
    ] {
        let path = repo().join("scenes").join(format!("{name}.json"));
        let scene = oit_scene::load(&path)
            .unwrap_or_else(|e| panic!("{e}"))
            .with_resolution(size);
        let mut gpu = GpuScene::upload(&ctx, &scene).expect("upload");
        // Both kinds of material are here: with unit factors and with factors read per fragment.
        for m in &scene.materials {
            unit_factors[usize::from(gpu.draws_unit_factors(m))] += 1;
        }
        let targets = Targets::new(&ctx, size, ColorFormat::Rgba32Float).expect("targets");
        for spec in &specs {
            let mut images: Vec<LinearImage> = Vec::new();
            // Per vertex, per draw, and per draw without the specialised pipelines.
            for (per_draw, specialised) in [(false, true), (true, true), (true, false)] {
                gpu.set_reads_material_per_draw(per_draw);
                gpu.set_specialised(specialised);
                let mut technique =
                    oit_gpu::TechniqueSpec::build(&spec.canonical(), &registry()).expect("build");
                let mut timer = GpuTimer::new(&ctx);
                match render_frame(&ctx, &gpu, technique.as_mut(), &targets, &mut timer) {
                    Ok(_) => images.push(read_color(&ctx, &targets).expect("read back")),
                    Err(e) => println!("{name} {}: skipped: {e}", spec.canonical()),
                }
            }
            if let [vertex, draw, general] = &images[..] {
                compared += 1;
                let differ = |a: &LinearImage, b: &LinearImage| {
                    (a.pixels.iter().zip(&b.pixels))
                        .filter(|(a, b)| a.map(f32::to_bits) != b.map(f32::to_bits))
                        .count()
                };
                for (what, n) in [
                    ("per vertex and per draw", differ(vertex, draw)),
                    (
                        "with and without the specialised pipelines",
                        differ(draw, general),
                    ),
                ] {
                    if n > 0 {
                        failures.push(format!(
                            "{name} {}: {what}: {n} px differ",
                            spec.canonical()
                        ));
                    }
                }
            }
        }
    }
    assert!(
        unit_factors.iter().all(|&n| n > 0),
        "materials with and without unit factors: {unit_factors:?}"
    );
    // Every technique runs on at least the scalar scenes here.
    assert!(compared >= 5 * specs.len(), "only {compared} runs compared");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The rule picks the per-draw form for draws of small triangles and the per-vertex form for
/// large ones, at the scene's resolution.
#[test]
fn small_triangles_read_their_material_per_draw() {
    let Some(ctx) = context_or_skip("small_triangles_read_their_material_per_draw") else {
        return;
    };
    let load = |name: &str| {
        oit_scene::load(&repo().join("scenes").join(format!("{name}.json")))
            .unwrap_or_else(|e| panic!("{e}"))
    };
    // 24 000 billboards of about 13 px each at 256².
    let particles = GpuScene::upload(&ctx, &load("particles")).expect("upload");
    assert!(particles.reads_material_per_draw(0));
    // 64 screen-filling layers of two triangles.
    let layers = GpuScene::upload(&ctx, &load("many-layers-64")).expect("upload");
    assert!((0..layers.scene.draws.len()).all(|i| !layers.reads_material_per_draw(i)));
    // The same billboards at 16² cover under a pixel each; at 4096² about 3 300.
    let tiny = load("particles").with_resolution(Resolution {
        width: 16,
        height: 16,
    });
    assert!(
        GpuScene::upload(&ctx, &tiny)
            .expect("upload")
            .reads_material_per_draw(0)
    );
    let huge = load("particles").with_resolution(Resolution {
        width: 4096,
        height: 4096,
    });
    assert!(
        !GpuScene::upload(&ctx, &huge)
            .expect("upload")
            .reads_material_per_draw(0)
    );
}
