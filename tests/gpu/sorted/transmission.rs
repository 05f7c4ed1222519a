//! Coloured transmission with dual-source blending: sorted blending composites `C + t ⊙ dst`
//! per channel, so where the object order is right it equals the reference; a scalar α could
//! not (the complementary panes multiply to nearly black).

use oit_gpu::testing::context_or_skip;
use oit_gpu::{ColorFormat, GpuScene, GpuTimer, Support, Targets, TechniqueSpec};

fn bundled(name: &str) -> oit_scene::Scene {
    let path = crate::kit::scenes_dir().join(format!("{name}.json"));
    oit_scene::load(&path).unwrap()
}

#[test]
fn sorted_object_equals_the_reference_on_tinted_panes() {
    let Some(ctx) = context_or_skip("sorted_object_transmission") else {
        return;
    };
    let techniques = oit_sorted::techniques();
    let mut technique = TechniqueSpec::build("sorted-object", &techniques).unwrap();
    if !ctx.caps.dual_source_blending {
        // The fallback is stated, not silent.
        assert!(matches!(
            technique.transmission(&ctx.caps),
            Support::Approximate(_)
        ));
        println!("sorted_object_transmission: no dual-source blending on this adapter, skipped");
        return;
    }
    assert_eq!(technique.transmission(&ctx.caps), Support::Exact);
    // Measured on lavapipe with f32 targets: 6.0e-8 (complementary), 4.8e-7 (32 panes),
    // 1.2e-7 (glTF); bounds about 10× above.
    for (name, bound) in [
        ("transmission-complementary", 1e-6),
        ("transmission-stack-32", 5e-6),
        ("transmission-gltf", 1e-6),
    ] {
        let scene = bundled(name);
        assert!(scene.has_coloured_transmission(), "{name}");
        let gpu = GpuScene::upload(&ctx, &scene).unwrap();
        let targets = Targets::new(&ctx, scene.resolution, ColorFormat::Rgba32Float).unwrap();
        let mut timer = GpuTimer::new(&ctx);
        oit_gpu::render_frame(&ctx, &gpu, technique.as_mut(), &targets, &mut timer).unwrap();
        let image = oit_gpu::read_color(&ctx, &targets).unwrap();
        let reference = oit_reference::render(&scene, &Default::default());
        let err = image
            .pixels
            .iter()
            .zip(&reference.image.pixels)
            .flat_map(|(p, q)| (0..3).map(move |k| (p[k] - q[k]).abs()))
            .fold(0.0f32, f32::max);
        println!("{name}: sorted-object max error {err:e}");
        assert!(err <= bound, "{name}: max error {err:e} > {bound:e}");
    }
}
