//! `opaque-copy` against the exact reference: exact for one tinted pane over opaque content and
//! for blended layers in front of the glass; the missing layer behind the nearest pane, at the
//! size the closed form predicts.

use oit_gpu::testing::context_or_skip;
use oit_gpu::{ColorFormat, Context};
use oit_scene::{LinearImage, Scene};

/// Orthographic view of x, y in [−1, 1] at 32×32 with an opaque wall behind and `panes`
/// (JSON objects) in front.
fn scene(panes: &str) -> Scene {
    let json = format!(
        r#"{{
        "name": "opaque-copy-test", "description": "tinted panes over an opaque wall",
        "resolution": [32, 32],
        "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "orthographic": {{"height": 2}}, "near": 0.1, "far": 100}},
        "background": [0.1, 0.2, 0.3],
        "objects": [
            {{"mesh": {{"kind": "quad", "size": [4, 4]}}, "transform": {{"translate": [0, 0, -2]}},
              "material": {{"base_color": [0.9, 0.7, 0.5], "mode": "opaque"}}}},
            {panes}
        ]}}"#
    );
    oit_scene::parse(&json, "opaque-copy-test.json").unwrap()
}

fn render(ctx: &Context, scene: &Scene) -> LinearImage {
    crate::kit::render_spec(ctx, scene, "opaque-copy", ColorFormat::Rgba32Float).0
}

use crate::kit::max_abs_rgb as max_error;

const RED_PANE: &str = r#"{"mesh": {"kind": "quad", "size": [4, 4]}, "transform": {"translate": [0, 0, 0]},
    "material": {"base_color": [1, 0.2, 0.1], "alpha": 0.9, "mode": "blend", "transmission": 0.8}}"#;

#[test]
fn a_tinted_pane_over_opaque_content_equals_the_reference() {
    let Some(ctx) = context_or_skip("opaque_copy_pane_over_opaque") else {
        return;
    };
    let s = scene(RED_PANE);
    let image = render(&ctx, &s);
    let reference = oit_reference::render(&s, &Default::default());
    // f32 target: shading and one multiply-add in f32 against the f64 composite.
    let err = max_error(&image, &reference.image);
    assert!(err <= 1e-6, "max error {err:e} on one pane over the wall");
    // And the pane is coloured: the wall's green channel is filtered far more than its red.
    let p = image.get(16, 16);
    assert!(p[0] > 2.0 * p[1], "{p:?}");
}

#[test]
fn a_pane_behind_the_nearest_pane_is_missing_by_the_closed_form() {
    let Some(ctx) = context_or_skip("opaque_copy_pane_behind_pane") else {
        return;
    };
    // A cyan pane behind the red one, covering the right half only.
    let cyan = r#"{"mesh": {"kind": "quad", "size": [1, 4]}, "transform": {"translate": [0.5, 0, -1]},
        "material": {"base_color": [0.1, 0.8, 1], "alpha": 1, "mode": "blend", "transmission": 0.9}}"#;
    let both = scene(&format!("{RED_PANE}, {cyan}"));
    let image = render(&ctx, &both);
    let reference = oit_reference::render(&both, &Default::default());
    // The red pane alone over the wall: what opaque-copy shows wherever the cyan one is.
    let alone = oit_reference::render(&scene(RED_PANE), &Default::default());
    let (left, right) = ((8, 16), (24, 16));
    for (x, y) in [left, right] {
        let (p, q) = (image.get(x, y), alone.image.get(x, y));
        for k in 0..3 {
            assert!(
                (p[k] - q[k]).abs() <= 1e-6,
                "({x}, {y}): {p:?}, one pane over the wall {q:?}"
            );
        }
    }
    // Left the answer is exact; right the cyan filter is missing, and that is the error.
    let at = |img: &LinearImage, (x, y): (u32, u32)| img.get(x, y);
    let missing = (0..3)
        .map(|k| (at(&image, right)[k] - at(&reference.image, right)[k]).abs())
        .fold(0.0, f32::max);
    assert!(missing > 0.05, "the far pane changes the answer: {missing}");
    let exact = (0..3)
        .map(|k| (at(&image, left)[k] - at(&reference.image, left)[k]).abs())
        .fold(0.0, f32::max);
    assert!(exact <= 1e-6, "left of the far pane: {exact:e}");
}

#[test]
fn blended_layers_in_front_of_the_glass_are_exact_and_behind_it_are_hidden() {
    let Some(ctx) = context_or_skip("opaque_copy_blended_layers") else {
        return;
    };
    // A green blended quad in front of the pane (left half) and a blue one behind it (right).
    let layers = r#"{"mesh": {"kind": "quad", "size": [1, 4]}, "transform": {"translate": [-0.5, 0, 1]},
        "material": {"base_color": [0.1, 0.9, 0.2], "alpha": 0.5, "mode": "blend"}},
        {"mesh": {"kind": "quad", "size": [1, 4]}, "transform": {"translate": [0.5, 0, -1]},
        "material": {"base_color": [0.1, 0.2, 0.9], "alpha": 0.5, "mode": "blend"}}"#;
    let s = scene(&format!("{RED_PANE}, {layers}"));
    let image = render(&ctx, &s);
    let reference = oit_reference::render(&s, &Default::default());
    let alone = oit_reference::render(&scene(RED_PANE), &Default::default());
    let (front, behind) = (image.get(8, 16), image.get(24, 16));
    let r_front = reference.image.get(8, 16);
    for k in 0..3 {
        assert!(
            (front[k] - r_front[k]).abs() <= 1e-6,
            "{front:?} {r_front:?}"
        );
        // Behind the glass: only the pane over the wall, as if the blue quad were absent.
        assert!((behind[k] - alone.image.get(24, 16)[k]).abs() <= 1e-6);
    }
    let hidden = (0..3)
        .map(|k| (behind[k] - reference.image.get(24, 16)[k]).abs())
        .fold(0.0, f32::max);
    assert!(
        hidden > 0.02,
        "the hidden blue layer must show as error: {hidden}"
    );
}
