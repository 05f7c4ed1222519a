//! The blending and ordering fields of the JSON format: what they load to, and the errors of
//! values that cannot be (docs/scene-format.md "Blend operators").

use oit_scene::{BlendOperator, ObjectMethod, RenderQueue, Shaded, Texels, parse};

fn scene(objects: &str) -> String {
    format!(
        r#"{{"name": "t", "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0]}}, "objects": [{objects}]}}"#
    )
}

fn error(objects: &str) -> String {
    parse(&scene(objects), "t.json")
        .expect_err("the scene must be refused")
        .to_string()
}

#[test]
fn operators_shade_to_their_documented_pairs() {
    let s = parse(
        &scene(
            r#"{"mesh": {"kind": "quad"}, "material": {"mode": "blend", "alpha": 0.5, "base_color": [0.8, 0.4, 0.2], "operator": "add"}},
               {"mesh": {"kind": "quad"}, "material": {"mode": "blend", "alpha": 0.5, "base_color": [0.8, 0.4, 0.2], "operator": "subtract"}},
               {"mesh": {"kind": "quad"}, "material": {"mode": "blend", "alpha": 0.5, "base_color": [0.8, 0.4, 0.2], "operator": "multiply"}},
               {"mesh": {"kind": "quad"}, "material": {"mode": "blend", "alpha": 0.5, "base_color": [0.8, 0.4, 0.2]}}"#,
        ),
        "t.json",
    )
    .expect("valid");
    let shade = |i: usize| s.materials[i].shade([1.0; 4], Texels::UNTEXTURED);
    assert_eq!(
        shade(0),
        Shaded::Transparent {
            premultiplied: [0.4, 0.2, 0.1],
            alpha: 0.0
        }
    );
    assert_eq!(
        shade(1),
        Shaded::Transparent {
            premultiplied: [-0.4, -0.2, -0.1],
            alpha: 0.0
        }
    );
    let Shaded::Transmissive {
        premultiplied,
        transmittance,
        opacity,
    } = shade(2)
    else {
        panic!("multiply is a filter: {:?}", shade(2));
    };
    assert_eq!(premultiplied, [0.0; 3]);
    assert_eq!(transmittance, [0.9, 0.7, 0.6]);
    assert!((opacity - (1.0 - (0.9 + 0.7 + 0.6) / 3.0)).abs() < 1e-6);
    assert_eq!(
        shade(3),
        Shaded::Transparent {
            premultiplied: [0.4, 0.2, 0.1],
            alpha: 0.5
        }
    );
    assert_eq!(
        s.operators_used(),
        vec![
            BlendOperator::Add,
            BlendOperator::Subtract,
            BlendOperator::Multiply
        ]
    );
    assert!(s.materials[2].is_transmissive() && !s.materials[0].is_transmissive());
}

#[test]
fn queues_are_derived_as_pygfx_derives_them_unless_given() {
    let s = parse(
        &scene(
            r#"{"mesh": {"kind": "quad"}, "material": {"mode": "opaque"}},
               {"mesh": {"kind": "quad"}, "material": {"mode": "mask"}},
               {"mesh": {"kind": "quad"}, "material": {"mode": "blend", "alpha": 0.5, "depth_write": true, "operator": "add"}},
               {"mesh": {"kind": "quad"}, "material": {"mode": "blend", "alpha": 0.5}},
               {"mesh": {"kind": "quad"}, "material": {"mode": "blend", "alpha": 0.5}, "method": "stochastic"},
               {"mesh": {"kind": "quad"}, "material": {"mode": "blend", "alpha": 0.5}, "render_queue": 4000, "render_order": -3}"#,
        ),
        "t.json",
    )
    .expect("valid");
    let queues: Vec<u16> = s.draws.iter().map(|d| s.queue_of(d).get()).collect();
    assert_eq!(queues, [2000, 2400, 2600, 3000, 2400, 4000]);
    assert_eq!(s.draws[4].ordering.method, Some(ObjectMethod::Stochastic));
    assert_eq!(s.draws[5].ordering.order, -3);
    assert!(s.materials[2].depth_write);
    assert!(RenderQueue::ALPHA_TEST.front_to_back() && !RenderQueue::TRANSPARENT.front_to_back());
    // Engine order of the transparent draws: queue first, whatever the file order.
    let order = s.babylon_object_order();
    let order_queues: Vec<u16> = order
        .iter()
        .map(|&i| s.exact_queue_of(&s.draws[i]).get())
        .collect();
    assert!(
        order_queues.windows(2).all(|w| w[0] <= w[1]),
        "{order_queues:?}"
    );
}

#[test]
fn bad_blending_and_ordering_values_name_the_field() {
    let e = error(r#"{"mesh": {"kind": "quad"}, "render_queue": 5000}"#);
    assert!(
        e.contains("objects[0].render_queue") && e.contains("1..=4999"),
        "{e}"
    );
    let e = error(r#"{"mesh": {"kind": "quad"}, "render_queue": 0}"#);
    assert!(e.contains("objects[0].render_queue"), "{e}");
    let e = error(r#"{"mesh": {"kind": "quad"}, "render_order": 1, "alpha_index": 2}"#);
    assert!(
        e.contains("objects[0].alpha_index") && e.contains("render_order"),
        "{e}"
    );
    let e =
        error(r#"{"mesh": {"kind": "quad"}, "material": {"mode": "mask", "depth_write": true}}"#);
    assert!(e.contains("objects[0].material.depth_write"), "{e}");
    let e = error(r#"{"mesh": {"kind": "quad"}, "method": "dither"}"#);
    assert!(e.contains("stochastic") && e.contains("weighted"), "{e}");
    let e = error(
        r#"{"mesh": {"kind": "quad"}, "material": {"mode": "mask", "operator": "subtract"}}"#,
    );
    assert!(e.contains("objects[0].material.operator"), "{e}");
}
