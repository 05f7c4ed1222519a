//! Blend operators (docs/scene-format.md "Blend operators"): stacks of full-screen layers with
//! mixed operators against an independent back-to-front evaluation of the documented table,
//! and the document's worked examples to the digit.

mod common;

use common::*;
use oit_reference::{ReferenceOptions, render};
use oit_scene::{AlphaMode, BlendOperator, Material, SplitMix64};

/// One layer as the documentation states it: straight colour `c`, coverage `a`, operator.
#[derive(Debug, Clone, Copy)]
struct Layer {
    c: [f64; 3],
    a: f64,
    op: BlendOperator,
}

/// The documented back-to-front rule, written from the table and nothing else: layers far to
/// near, each applied to the colour behind it.
fn back_to_front(background: [f64; 3], far_to_near: &[Layer]) -> [f64; 3] {
    let mut colour = background;
    for l in far_to_near {
        for (behind, c) in colour.iter_mut().zip(l.c) {
            *behind = match l.op {
                BlendOperator::Over => l.a * c + (1.0 - l.a) * *behind,
                BlendOperator::Add => *behind + l.a * c,
                BlendOperator::Subtract => *behind - l.a * c,
                BlendOperator::Multiply => *behind * (1.0 - l.a + l.a * c),
            };
        }
    }
    colour
}

fn material(l: &Layer) -> Material {
    let mut m = Material::plain(l.c.map(|x| x as f32), l.a as f32, AlphaMode::Blend);
    m.operator = l.op;
    m
}

/// Renders `near_to_far` as full-screen quads (drawn in the order `draw_order` gives) and
/// returns the centre pixel.
fn render_stack(background: [f32; 3], near_to_far: &[Layer], draw_order: &[usize]) -> [f32; 4] {
    let mut b = SceneBuilder::new(8, 8).background(background);
    for &i in draw_order {
        b.quad(
            material(&near_to_far[i]),
            fullscreen(-0.25 - 0.1 * i as f32),
            white(),
        );
    }
    let r = render(&b.build(), &ReferenceOptions::default());
    r.image.pixels[4 * 8 + 4]
}

fn assert_close(got: [f32; 4], want: [f64; 3], tol: f64, what: &str) {
    for k in 0..3 {
        let scale = want[k].abs().max(1.0);
        assert!(
            (f64::from(got[k]) - want[k]).abs() <= tol * scale,
            "{what}: channel {k} is {} but the documented rule gives {} (tolerance {tol})",
            got[k],
            want[k]
        );
    }
}

#[test]
fn the_documented_worked_examples() {
    let l = |c: f64, a: f64, op| Layer { c: [c; 3], a, op };
    use BlendOperator::*;
    // (near to far, expected), background 0.2: the examples of docs/scene-format.md.
    let cases: [(&[Layer], f64); 6] = [
        (&[l(0.8, 0.5, Over), l(0.6, 1.0, Add)], 0.8),
        (&[l(0.8, 0.5, Over)], 0.5),
        (&[l(2.0, 0.5, Add), l(0.4, 0.5, Over)], 1.3),
        (&[l(0.5, 1.0, Subtract), l(0.4, 1.0, Add)], 0.1),
        (&[l(0.5, 0.6, Multiply), l(0.9, 1.0, Over)], 0.63),
        (&[l(0.9, 1.0, Over), l(0.5, 0.6, Multiply)], 0.9),
    ];
    for (i, (layers, want)) in cases.iter().enumerate() {
        let order: Vec<usize> = (0..layers.len()).collect();
        let got = render_stack([0.2; 3], layers, &order);
        assert_close(got, [*want; 3], 1e-6, &format!("worked example {i}"));
    }
}

#[test]
fn mixed_operator_stacks_match_an_independent_back_to_front_evaluation() {
    let mut rng = SplitMix64::new(0x0b1e_5eed);
    let ops = BlendOperator::ALL;
    let mut negative = 0;
    for case in 0..200 {
        let n = 1 + (rng.next_u64() % 7) as usize;
        // f32 values, as the scene stores them; HDR colours for add and subtract, filters in
        // [0, 1] for multiply.
        let layers: Vec<Layer> = (0..n)
            .map(|_| {
                let op = ops[(rng.next_u64() % 4) as usize];
                let top = if op == BlendOperator::Multiply {
                    1.0
                } else {
                    2.0
                };
                Layer {
                    c: std::array::from_fn(|_| f64::from(rng.next_f32() * top)),
                    a: f64::from(rng.next_f32()),
                    op,
                }
            })
            .collect();
        let background = [0.3f32, 0.1, 0.6];
        let far_to_near: Vec<Layer> = layers.iter().rev().copied().collect();
        let want = back_to_front(background.map(f64::from), &far_to_near);
        negative += usize::from(want.iter().any(|&x| x < 0.0));
        // Natural and reversed draw order: the reference sorts by depth.
        let natural: Vec<usize> = (0..n).collect();
        let reversed: Vec<usize> = (0..n).rev().collect();
        for order in [natural, reversed] {
            let got = render_stack(background, &layers, &order);
            assert_close(
                got,
                want,
                1e-5,
                &format!("case {case}, layers near to far {layers:?}, draw order {order:?}"),
            );
        }
    }
    // The random stacks reach below 0 (subtract) somewhere: no clamp hides there.
    assert!(negative > 0, "no stack went below 0");
}

#[test]
fn operators_on_opaque_materials_are_refused_with_the_field_named() {
    let text = r#"{"name": "x", "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
        "objects": [{"mesh": {"kind": "quad"}, "material": {"mode": "opaque", "operator": "add"}}]}"#;
    let e = oit_scene::parse(text, "x.json").expect_err("add on an opaque material");
    let msg = e.to_string();
    assert!(
        msg.contains("objects[0].material.operator") && msg.contains("blend"),
        "{msg}"
    );
    let text = r#"{"name": "x", "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
        "objects": [{"mesh": {"kind": "quad"}, "material": {"mode": "blend", "operator": "multiply", "transmission": 0.5}}]}"#;
    let e = oit_scene::parse(text, "x.json").expect_err("multiply with transmission");
    assert!(e.to_string().contains("transmission 0"), "{e}");
    let text = r#"{"name": "x", "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
        "objects": [{"mesh": {"kind": "quad"}, "material": {"mode": "blend", "operator": "screen"}}]}"#;
    let e = oit_scene::parse(text, "x.json").expect_err("an unknown operator");
    assert!(
        e.to_string().contains("subtract") && e.to_string().contains("multiply"),
        "the error lists the operators: {e}"
    );
}
