//! `per-object` (pygfx's per-object methods) against the exact reference and closed forms: all
//! blended equals sorted-object, `opaque` writes straight colours with α = 1, dither keeps
//! about α of a flat surface, weighted equals OVER on one layer, and a mixed scene draws each
//! method in its pass.

use oit_gpu::testing::context_or_skip;
use oit_gpu::{ColorFormat, Context};
use oit_scene::{LinearImage, Scene};

/// Orthographic view of x, y in [−1, 1] at `size`² with an opaque grey wall behind `objects`.
fn scene(size: u32, objects: &str) -> Scene {
    let json = format!(
        r#"{{
        "name": "per-object-test", "description": "quads with per-object methods over a wall",
        "resolution": [{size}, {size}],
        "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "orthographic": {{"height": 2}}, "near": 0.1, "far": 100}},
        "background": [0, 0, 0],
        "objects": [
            {{"mesh": {{"kind": "quad", "size": [4, 4]}}, "transform": {{"translate": [0, 0, -3]}},
              "material": {{"base_color": [0.2, 0.2, 0.2], "mode": "opaque"}}}}
            {objects}
        ]}}"#
    );
    oit_scene::parse(&json, "per-object-test.json").unwrap()
}

/// A `size` quad centred at `centre`, colour `rgb`, alpha `a`, with `method` ("" for none).
fn quad(centre: [f32; 3], size: [f32; 2], rgb: [f32; 3], a: f32, method: &str) -> String {
    let [x, y, z] = centre;
    let [w, h] = size;
    let method = if method.is_empty() {
        String::new()
    } else {
        format!(r#", "method": "{method}""#)
    };
    format!(
        r#", {{"mesh": {{"kind": "quad", "size": [{w}, {h}]}}, "transform": {{"translate": [{x}, {y}, {z}]}},
            "material": {{"base_color": [{}, {}, {}], "alpha": {a}, "mode": "blend"}}{method}}}"#,
        rgb[0], rgb[1], rgb[2]
    )
}

fn render(ctx: &Context, scene: &Scene, spec: &str) -> LinearImage {
    crate::kit::render_spec(ctx, scene, spec, ColorFormat::Rgba32Float).0
}

fn assert_close(p: [f32; 4], want: [f32; 3], tolerance: f32, at: &str) {
    for c in 0..3 {
        assert!(
            (p[c] - want[c]).abs() <= tolerance,
            "{at}: {p:?}, expected {want:?} ± {tolerance}"
        );
    }
}

#[test]
fn all_blended_sortable_objects_match_the_reference_like_sorted_object() {
    let Some(ctx) = context_or_skip("per_object_all_blended") else {
        return;
    };
    let objects = [
        quad(
            [-0.3, 0.0, -1.0],
            [1.2, 1.2],
            [1.0, 0.2, 0.1],
            0.5,
            "blended",
        ),
        quad([0.2, 0.2, 0.0], [1.2, 1.2], [0.1, 0.9, 0.2], 0.4, "blended"),
        quad([0.0, -0.3, 1.0], [1.2, 1.2], [0.2, 0.3, 1.0], 0.6, ""),
    ]
    .concat();
    let s = scene(32, &objects);
    let reference = oit_reference::render(&s, &Default::default());
    let image = render(&ctx, &s, "per-object");
    let sorted = render(&ctx, &s, "sorted-object");
    let err = crate::kit::max_abs_rgb(&image, &reference.image);
    assert!(err <= 1e-5, "per-object on sortable blended quads: {err:e}");
    assert!(crate::kit::max_abs_rgb(&image, &sorted) <= 1e-6);
}

#[test]
fn force_blended_draws_random_scenes_as_sorted_object_does() {
    let Some(ctx) = context_or_skip("per_object_random_blended") else {
        return;
    };
    for seed in 0..3 {
        let (json, _) = oit_scene::random::random_scene_json(seed);
        let s = oit_scene::parse(&json, "random").unwrap();
        let image = render(&ctx, &s, "per-object:force=blended");
        let sorted = render(&ctx, &s, "sorted-object");
        let err = crate::kit::max_abs_rgb(&image, &sorted);
        assert!(err <= 1e-6, "random scene {seed}: {err:e}");
    }
}

#[test]
fn force_opaque_writes_straight_colours_with_alpha_one() {
    let Some(ctx) = context_or_skip("per_object_force_opaque") else {
        return;
    };
    // Red in front of blue, overlapping in the middle; neither object names a method.
    let objects = [
        quad([-0.3, 0.0, 0.0], [1.0, 1.0], [1.0, 0.2, 0.1], 0.3, ""),
        quad([0.3, 0.0, -1.0], [1.0, 1.0], [0.1, 0.3, 1.0], 0.6, ""),
    ]
    .concat();
    let s = scene(32, &objects);
    let image = render(&ctx, &s, "per-object:force=opaque");
    // Pixel centres: x = -0.6 (red only), 0 (both: red in front), 0.6 (blue only), 0.95 (wall).
    let px = |x: f32| (((x + 1.0) * 16.0) as u32).min(31);
    assert_close(image.get(px(-0.6), 16), [1.0, 0.2, 0.1], 1e-6, "red alone");
    assert_close(
        image.get(px(0.0), 16),
        [1.0, 0.2, 0.1],
        1e-6,
        "red over blue",
    );
    assert_close(image.get(px(0.6), 16), [0.1, 0.3, 1.0], 1e-6, "blue alone");
    assert_close(image.get(px(0.95), 16), [0.2, 0.2, 0.2], 1e-6, "the wall");
    // The blended default differs: the opaque colours are not a composite.
    let blended = render(&ctx, &s, "per-object");
    assert!((blended.get(px(-0.6), 16)[0] - 1.0).abs() > 0.3);
}

#[test]
fn stochastic_keeps_about_alpha_of_a_flat_quad() {
    let Some(ctx) = context_or_skip("per_object_stochastic_fraction") else {
        return;
    };
    let s = scene(
        64,
        &quad(
            [0.0, 0.0, 0.0],
            [4.0, 4.0],
            [1.0, 1.0, 1.0],
            0.5,
            "stochastic",
        ),
    );
    let image = render(&ctx, &s, "per-object");
    let mut kept = 0usize;
    for p in &image.pixels {
        // Every pixel is the white survivor (α = 1) or the wall, nothing in between.
        let white = p[..3].iter().all(|&c| (c - 1.0).abs() <= 1e-6);
        let wall = p[..3].iter().all(|&c| (c - 0.2).abs() <= 1e-6);
        assert!(white || wall, "{p:?}");
        kept += usize::from(white);
    }
    let fraction = kept as f64 / image.pixels.len() as f64;
    assert!((fraction - 0.5).abs() <= 0.03, "kept fraction {fraction}");
    // α = 0.25 keeps about a quarter: the threshold is uniform.
    let quarter = scene(
        64,
        &quad(
            [0.0, 0.0, 0.0],
            [4.0, 4.0],
            [1.0, 1.0, 1.0],
            0.25,
            "stochastic",
        ),
    );
    let image = render(&ctx, &quarter, "per-object");
    let kept = image
        .pixels
        .iter()
        .filter(|p| (p[0] - 1.0).abs() <= 1e-6)
        .count();
    let fraction = kept as f64 / image.pixels.len() as f64;
    assert!(
        (fraction - 0.25).abs() <= 0.03,
        "kept fraction at α = 0.25: {fraction}"
    );
}

#[test]
fn weighted_on_one_layer_equals_over() {
    let Some(ctx) = context_or_skip("per_object_weighted_one_layer") else {
        return;
    };
    let s = scene(
        32,
        &quad(
            [0.0, 0.0, 0.0],
            [1.0, 1.0],
            [0.9, 0.5, 0.1],
            0.4,
            "weighted",
        ),
    );
    let reference = oit_reference::render(&s, &Default::default());
    let image = render(&ctx, &s, "per-object");
    // The r8unorm revealage rounds 1 − α to 1/255 (an error up to 0.5/255 times |c − wall|)
    // and the accumulation is f16.
    let err = crate::kit::max_abs_rgb(&image, &reference.image);
    assert!(err <= 3e-3, "one weighted layer against OVER: {err:e}");
    assert_close(
        image.get(16, 16),
        [0.48, 0.32, 0.16],
        3e-3,
        "the quad over the wall",
    );
    // Two overlapping weighted layers are a weighted average, not OVER.
    let two = scene(
        32,
        &[
            quad(
                [0.0, 0.0, 0.0],
                [1.0, 1.0],
                [0.9, 0.5, 0.1],
                0.4,
                "weighted",
            ),
            quad(
                [0.0, 0.0, -1.0],
                [1.0, 1.0],
                [0.1, 0.2, 1.0],
                0.8,
                "weighted",
            ),
        ]
        .concat(),
    );
    let reference = oit_reference::render(&two, &Default::default());
    let image = render(&ctx, &two, "per-object");
    assert!(crate::kit::max_abs_rgb(&image, &reference.image) > 0.05);
}

#[test]
fn a_mixed_scene_draws_each_method_in_its_pass() {
    let Some(ctx) = context_or_skip("per_object_mixed") else {
        return;
    };
    // Blue opaque-method quad at z = 0 hides the red blended quad behind it (z = −1) where they
    // overlap; a green blended quad in front (z = 1) composites over the blue one.
    let objects = [
        quad(
            [0.3, 0.0, -1.0],
            [1.2, 2.0],
            [1.0, 0.0, 0.0],
            0.5,
            "blended",
        ),
        quad([-0.3, 0.0, 0.0], [1.2, 2.0], [0.0, 0.0, 1.0], 0.5, "opaque"),
        quad(
            [-0.5, 0.5, 1.0],
            [1.0, 1.0],
            [0.0, 1.0, 0.0],
            0.5,
            "blended",
        ),
    ]
    .concat();
    let s = scene(32, &objects);
    let image = render(&ctx, &s, "per-object");
    let px = |x: f32| (((x + 1.0) * 16.0) as u32).min(31);
    let (low, high) = (24, 4); // y = -0.5 and y = +0.75 in image rows (top is +1)
    // Blue and red overlap at x = 0.1 (lower half): blue alone, solid.
    assert_close(
        image.get(px(0.1), low),
        [0.0, 0.0, 1.0],
        1e-6,
        "blue hides red",
    );
    // Red alone over the wall at x = 0.75.
    assert_close(
        image.get(px(0.75), low),
        [0.6, 0.1, 0.1],
        1e-6,
        "red over the wall",
    );
    // Green over blue at x = -0.5, upper half.
    assert_close(
        image.get(px(-0.5), high),
        [0.0, 0.5, 0.5],
        1e-6,
        "green over blue",
    );
    // The exact answer shows red through the blue quad: the opaque method is not exact there.
    let reference = oit_reference::render(&s, &Default::default());
    assert!(reference.image.get(px(0.1), low)[0] > 0.05);
}
