//! `oit_reference::analyze` on scenes whose answer is known: bundled ones and hand-built ones.

use std::path::Path;

use oit_reference::ReferenceOptions;
use oit_reference::analyze::{Analysis, SCHEMA, analyze};
use oit_scene::Scene;

fn bundled(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(format!("{name}.json"));
    oit_scene::load(&path).unwrap()
}

fn run(scene: &Scene) -> Analysis {
    analyze(scene, &ReferenceOptions::default()).unwrap()
}

#[test]
fn sorted_quads_have_no_conflicts_and_babylon_order_is_right() {
    let a = run(&bundled("sorted-quads"));
    assert_eq!(a.schema, SCHEMA);
    assert_eq!(a.objects.conflict_pixels, 0);
    assert_eq!(a.objects.cycles, 0);
    assert_eq!(a.triangles.conflict_pixels, 0);
    assert_eq!(a.objects.technique_order_wrong_pixels, 0);
    assert_eq!(a.triangles.technique_order_wrong_pixels, 0);
    assert_eq!(a.self_overlap.pixels, 0);
    assert!(a.depth.depth16_separates);
    assert!(a.layers.max >= 2);
}

#[test]
fn intersecting_quads_conflict_per_object_and_per_triangle() {
    let a = run(&bundled("intersecting-quads"));
    assert!(a.objects.conflict_pixels > 0);
    assert_eq!(a.objects.cycles, 1);
    assert_eq!(a.objects.largest_cycle, 3);
    assert_eq!(a.objects.conflict_pairs, 3);
    for p in &a.objects.pairs {
        assert!(p.a_in_front > 0 && p.b_in_front > 0, "{p:?}");
    }
    assert!(a.objects.technique_order_wrong_pixels > 0);
    assert!(a.triangles.conflict_pixels > 0);
    assert!(a.triangles.technique_order_wrong_pixels > 0);
    // Every pixel on a cycle of triangles holds objects of the cycle too.
    assert!(a.triangles.conflict_pixels <= a.objects.conflict_pixels);
}

#[test]
fn many_layers_64_has_64_layers_everywhere() {
    let a = run(&bundled("many-layers-64"));
    assert_eq!(a.layers.max, 64);
    assert_eq!(a.layers.p50, 64);
    assert_eq!(a.layers.histogram, vec![[64, a.pixels]]);
    assert_eq!(a.fragments.composited, 64 * a.pixels);
    let [lo, hi] = a.depth.window.unwrap();
    assert!(lo < hi);
}

#[test]
fn coplanar_layers_tie_in_depth_and_in_16_bits() {
    let a = run(&bundled("coplanar"));
    assert!(a.depth.equal_depth_pixels > 0);
    assert!(a.depth.depth16_shared_pixels >= a.depth.equal_depth_pixels);
    assert!(!a.depth.depth16_separates);
}

#[test]
fn concave_self_overlaps_itself() {
    let a = run(&bundled("concave-self"));
    assert!(a.self_overlap.pixels > 0);
    assert!(!a.self_overlap.draws.is_empty());
    assert_eq!(a.objects.conflict_pixels, 0);
    // Whole draws are in order, their own triangles are not (index order is not depth order).
    assert_eq!(a.objects.technique_order_wrong_pixels, 0);
    assert!(a.objects.technique_draw_order_wrong_pixels > 0);
}

/// Two quads crossing at x = 0, turned ±30° about y: each is in front on one half.
fn crossing_quads() -> Scene {
    let json = r#"{
      "name": "crossing",
      "resolution": [64, 64],
      "camera": { "eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45,
                  "near": 0.1, "far": 100 },
      "objects": [
        { "mesh": { "kind": "quad", "size": [2, 2] },
          "transform": { "rotate": [0, 30, 0] },
          "material": { "base_color": [1, 0, 0], "alpha": 0.5, "mode": "blend",
                        "double_sided": true } },
        { "mesh": { "kind": "quad", "size": [2, 2] },
          "transform": { "rotate": [0, -30, 0] },
          "material": { "base_color": [0, 0, 1], "alpha": 0.5, "mode": "blend",
                        "double_sided": true } }
      ]
    }"#;
    oit_scene::parse(json, "crossing.json").unwrap()
}

#[test]
fn crossing_quads_give_the_pair_with_pixels_on_both_sides() {
    let a = run(&crossing_quads());
    assert_eq!(a.objects.cycles, 1);
    assert_eq!(a.objects.conflict_pairs, 1);
    let p = &a.objects.pairs[0];
    let names = [p.a.name.as_str(), p.b.name.as_str()];
    assert_eq!(names, ["objects[0]", "objects[1]"]);
    assert!(p.a_in_front > 0 && p.b_in_front > 0, "{p:?}");
    assert_eq!(p.interleaved, 0);
    // Symmetric about x = 0: the two sides differ by at most a column.
    assert!(p.a_in_front.abs_diff(p.b_in_front) <= 64, "{p:?}");
    // Every pixel where both quads meet is a conflict pixel.
    assert_eq!(a.objects.conflict_pixels, p.a_in_front + p.b_in_front);
    assert!(a.triangles.conflict_pixels > 0);
    assert!(a.objects.technique_order_wrong_pixels > 0);
}

#[test]
fn visiting_leaves_the_reference_bit_identical() {
    for name in ["intersecting-quads", "concave-self", "coplanar"] {
        let scene = bundled(name);
        let plain = oit_reference::render(&scene, &ReferenceOptions::default());
        let visited = oit_reference::render_visiting(
            &scene,
            &ReferenceOptions::default(),
            &|_: &oit_reference::RectFragments<'_>| {},
        )
        .unwrap();
        assert_eq!(plain.image, visited.image, "{name}");
        assert_eq!(plain.layers, visited.layers, "{name}");
        assert_eq!(plain.precision_ties, visited.precision_ties, "{name}");
    }
}

#[test]
fn a_pixel_over_the_memory_budget_is_an_error() {
    let scene = bundled("many-layers-64");
    let options = ReferenceOptions {
        memory_budget: 1000,
        ..Default::default()
    };
    assert!(analyze(&scene, &options).is_err());
}
