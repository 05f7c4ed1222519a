//! Render queues at load time: an opaque or mask object an engine would draw after a
//! transparent one is refused with the object and field named; everything else loads, and the
//! queue levels the reference composites by are derived from the material, not the method.

mod common;

use common::*;
use oit_scene::Problem;
use serde_json::json;

fn pane(mode: &str) -> serde_json::Value {
    json!({"mesh": {"kind": "quad"}, "material": {"mode": mode, "alpha": 0.5}})
}

fn assert_refused(objects: serde_json::Value, path: &str, mentions: &[&str]) {
    let (at, problem) = fail(&scene_with(objects));
    assert_eq!(at, path);
    let Problem::BadValue { value, allowed, .. } = &problem else {
        panic!("{problem:?}");
    };
    for m in mentions {
        assert!(value.contains(m), "{value:?} does not mention {m:?}");
    }
    assert!(
        allowed.contains("at or below every transparent"),
        "{allowed}"
    );
}

#[test]
fn an_opaque_object_in_a_later_queue_than_a_transparent_one_is_refused() {
    let mut opaque = pane("opaque");
    opaque["render_queue"] = json!(3500);
    assert_refused(
        json!([pane("blend"), opaque]),
        "objects[1].render_queue",
        &["objects[1]", "queue 3500", "objects[0]", "queue 3000"],
    );
    // A mask object above a transparent overlay's queue is fine only when the overlay is not
    // below it.
    let mut mask = pane("mask");
    mask["render_queue"] = json!(2450);
    let mut low = pane("blend");
    low["render_queue"] = json!(2000);
    assert_refused(
        json!([low, mask.clone()]),
        "objects[1].render_queue",
        &["2450", "2000"],
    );
    load_ok(&scene_with(json!([pane("blend"), mask])));
}

#[test]
fn an_opaque_object_in_a_later_render_group_is_refused() {
    let mut opaque = pane("opaque");
    opaque["render_group"] = json!(1);
    assert_refused(
        json!([pane("blend"), opaque]),
        "objects[1].render_group",
        &["render group 1", "render group 0"],
    );
}

#[test]
fn opaque_objects_at_or_below_every_transparent_queue_load() {
    let mut background = pane("opaque");
    background["render_queue"] = json!(1000);
    let mut overlay = pane("blend");
    overlay["render_queue"] = json!(4000);
    let mut same = pane("opaque");
    same["render_queue"] = json!(3000);
    let s = load_ok(&scene_with(json!([
        background,
        pane("blend"),
        overlay,
        same
    ])));
    assert!(s.has_queue_effects());
    let queues: Vec<u16> = s.draws.iter().map(|d| s.exact_queue_of(d).get()).collect();
    assert_eq!(queues, [1000, 3000, 4000, 3000]);
}

#[test]
fn the_reference_queue_ignores_the_method_and_depth_write_derives_2600() {
    let mut dithered = pane("blend");
    dithered["method"] = json!("stochastic");
    let mut glow = pane("blend");
    glow["material"]["depth_write"] = json!(true);
    let s = load_ok(&scene_with(json!([dithered, glow, pane("blend")])));
    // pygfx puts a dithered object in 2400; the exact answer does not depend on the method.
    assert_eq!(s.queue_of(&s.draws[0]).get(), 2400);
    assert_eq!(s.exact_queue_of(&s.draws[0]).get(), 3000);
    assert_eq!(s.exact_queue_of(&s.draws[1]).get(), 2600);
    assert!(s.has_queue_effects());
    let flat = load_ok(&scene_with(json!([pane("blend"), pane("blend")])));
    assert!(!flat.has_queue_effects());
}
