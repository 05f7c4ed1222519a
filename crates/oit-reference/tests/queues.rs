//! Render queues in the reference (docs/scene-format.md, "Render queues"): transparent
//! fragments composite by (render group, queue) descending, then depth; a depth-writing
//! transparent fragment hides fragments of later queues behind it. Pixels worked out by hand,
//! the bundled scenes' descriptions, and seeded random scenes: one level is bit-identical to no
//! queues, and any level assignment gives lists in (level, depth) order whose composite is the
//! image and which do not depend on draw order.

mod common;

use common::*;
use oit_reference::lists::render_lists;
use oit_reference::{ReferenceOptions, render};
use oit_scene::{BlendOperator, Material, RenderQueue, Scene};

const SIZE: u32 = 16;
const BACKGROUND: [f32; 3] = [0.2, 0.3, 0.4];

/// Full-screen panes, one draw each, in the given order: (material, z, queue).
fn panes(layers: &[(Material, f32, Option<u16>)]) -> Scene {
    let mut b = SceneBuilder::new(SIZE, SIZE).background(BACKGROUND);
    for &(m, z, _) in layers {
        b.quad(m, fullscreen(z), white());
    }
    let mut scene = b.build();
    for (d, &(_, _, queue)) in scene.draws.iter_mut().zip(layers) {
        d.ordering.queue = queue.and_then(RenderQueue::new);
    }
    scene
}

fn centre(scene: &Scene) -> [f32; 4] {
    let r = render(scene, &ReferenceOptions::default());
    r.image.pixels[(SIZE / 2 * SIZE + SIZE / 2) as usize]
}

fn assert_rgb(got: [f32; 4], want: [f64; 3], what: &str) {
    for k in 0..3 {
        let err = (f64::from(got[k]) - want[k]).abs();
        assert!(
            err <= 1e-6,
            "{what}: channel {k} is {} but by hand {} (error {err:e})",
            got[k],
            want[k]
        );
    }
}

/// `α·c + (1 − α)·behind` per channel, in f64.
fn over(rgb: [f32; 3], alpha: f32, behind: [f64; 3]) -> [f64; 3] {
    let a = f64::from(alpha);
    std::array::from_fn(|k| a * f64::from(rgb[k]) + (1.0 - a) * behind[k])
}

fn additive(rgb: [f32; 3], alpha: f32, depth_write: bool) -> Material {
    let mut m = blend(rgb, alpha);
    m.operator = BlendOperator::Add;
    m.depth_write = depth_write;
    m
}

#[test]
fn an_overlay_behind_a_pane_is_composited_over_it() {
    let (pane, label) = (([0.7, 0.85, 1.0], 0.55), ([1.0, 1.0, 0.3], 0.85));
    let scene = panes(&[
        (blend(pane.0, pane.1), -1.0, None),
        (blend(label.0, label.1), -2.0, Some(4000)),
    ]);
    assert!(scene.has_queue_effects());
    let bg = BACKGROUND.map(f64::from);
    // Queue 4000 is drawn after queue 3000: the label lands on top although it lies behind.
    let want = over(label.0, label.1, over(pane.0, pane.1, bg));
    assert_rgb(centre(&scene), want, "overlay over pane");
    // In one queue the pane is in front, as depth says.
    let mut flat = scene.clone();
    flat.draws[1].ordering.queue = None;
    assert!(!flat.has_queue_effects());
    let depth_only = over(pane.0, pane.1, over(label.0, label.1, bg));
    assert_rgb(centre(&flat), depth_only, "one queue");
    assert!(
        (want[0] - depth_only[0]).abs() > 0.05,
        "the queue changes the pixel"
    );
}

#[test]
fn a_depth_writer_hides_later_queues_behind_it_but_not_earlier_ones() {
    let front = ([0.3f32, 0.4, 1.0], 0.45f32);
    let glow = ([1.0f32, 0.5, 0.15], 0.7f32);
    let later = ([0.2f32, 0.9, 0.3], 0.6f32);
    let earlier = ([0.9f32, 0.1, 0.6], 0.5f32);
    // Nearest first: a queue-3000 pane in front, the additive depth writer (derived queue
    // 2600), a queue-3000 pane behind it (hidden) and a queue-2500 pane behind that (drawn
    // before the writer, so not hidden).
    let scene = panes(&[
        (blend(later.0, later.1), -3.0, None),
        (blend(front.0, front.1), -1.0, None),
        (blend(earlier.0, earlier.1), -3.5, Some(2500)),
        (additive(glow.0, glow.1, true), -2.0, None),
    ]);
    assert_eq!(scene.queue_of(&scene.draws[3]).get(), 2600);
    let bg = BACKGROUND.map(f64::from);
    let behind_writer = over(earlier.0, earlier.1, bg);
    let a = f64::from(glow.1);
    let with_glow: [f64; 3] = std::array::from_fn(|k| a * f64::from(glow.0[k]) + behind_writer[k]);
    let want = over(front.0, front.1, with_glow);
    assert_rgb(centre(&scene), want, "writer hides the later queue only");
    let r = render(&scene, &ReferenceOptions::default());
    let p = (SIZE / 2 * SIZE + SIZE / 2) as usize;
    assert_eq!(r.layers[p], 3, "the hidden pane is not a layer");
    assert_eq!(r.fragments[p], 4, "but it is a fragment");
    // Without depth_write the writer moves to queue 3000 with the two panes; the queue-2500
    // pane still composites under all of them, and nothing is hidden.
    let mut plain = scene.clone();
    plain.materials[3].depth_write = false;
    let three = over(
        front.0,
        front.1,
        std::array::from_fn(|k| {
            a * f64::from(glow.0[k]) + over(later.0, later.1, behind_writer)[k]
        }),
    );
    assert_rgb(centre(&plain), three, "no depth write");
}

#[test]
fn a_depth_writer_hides_nothing_in_its_own_queue() {
    let glow = ([1.0f32, 0.5, 0.15], 0.7f32);
    let back = ([0.2f32, 0.9, 0.3], 0.6f32);
    let scene = panes(&[
        (additive(glow.0, glow.1, true), -1.0, Some(3000)),
        (blend(back.0, back.1), -2.0, None),
    ]);
    assert!(!scene.has_queue_effects());
    let behind = over(back.0, back.1, BACKGROUND.map(f64::from));
    let want = std::array::from_fn(|k| f64::from(glow.1) * f64::from(glow.0[k]) + behind[k]);
    assert_rgb(centre(&scene), want, "same queue");
}

#[test]
fn render_groups_come_before_queues() {
    let (near, far) = (([1.0f32, 0.2, 0.2], 0.5f32), ([0.2f32, 0.2, 1.0], 0.6f32));
    let mut scene = panes(&[
        (blend(near.0, near.1), -1.0, Some(4000)),
        (blend(far.0, far.1), -2.0, None),
    ]);
    scene.draws[1].ordering.group = 1;
    // Group 1 is drawn after group 0's overlay: the far pane is on top.
    let want = over(
        far.0,
        far.1,
        over(near.0, near.1, BACKGROUND.map(f64::from)),
    );
    assert_rgb(centre(&scene), want, "group before queue");
}

/// Transparent draws of seeded random scenes, spread over a few queues (and sometimes depth
/// writers, sometimes render groups).
fn queued(seed: u64) -> Scene {
    let (json, _) = oit_scene::random::random_scene_json(seed);
    let mut scene = oit_scene::parse(&json, "random.json").expect("random scenes load");
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let mut next = move |n: u64| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state % n
    };
    for i in 0..scene.draws.len() {
        let m = scene.draws[i].material as usize;
        if !scene.materials[m].mode.is_transparent() {
            continue;
        }
        scene.draws[i].ordering.queue =
            RenderQueue::new([2600, 3000, 3500, 4000][next(4) as usize]);
        if next(3) == 0 {
            scene.materials[m].depth_write = true;
        }
        if next(8) == 0 {
            scene.draws[i].ordering.group = 1;
        }
    }
    scene
}

#[test]
fn random_scenes_in_one_queue_are_bit_identical_to_no_queues() {
    for seed in 0..24 {
        let (json, _) = oit_scene::random::random_scene_json(seed);
        let scene = oit_scene::parse(&json, "random.json").unwrap();
        let mut one = scene.clone();
        for d in &mut one.draws {
            d.ordering.queue = RenderQueue::new(3000);
        }
        for m in &mut one.materials {
            m.depth_write = m.mode.is_transparent();
        }
        assert!(!one.has_queue_effects());
        let (a, b) = (
            render(&scene, &Default::default()),
            render(&one, &Default::default()),
        );
        assert_eq!(image_bits(&a.image), image_bits(&b.image), "seed {seed}");
        assert_eq!(a.layers, b.layers, "seed {seed}");
    }
}

#[test]
fn random_queue_scenes_composite_their_lists_in_level_then_depth_order() {
    let mut with_effects = 0;
    for seed in 0..40 {
        let scene = queued(seed);
        if !scene.has_queue_effects() {
            continue;
        }
        with_effects += 1;
        let (reference, lists) = render_lists(&scene, &Default::default()).unwrap();
        // Stored and sliced paths, any tile size: the same bits.
        let small = ReferenceOptions {
            tile_size: 8,
            memory_budget: 1 << 20,
            ..Default::default()
        };
        let again = render(&scene, &small);
        assert_eq!(
            image_bits(&reference.image),
            image_bits(&again.image),
            "seed {seed}"
        );
        // Draw order does not matter.
        let reversed = render(&scene.with_reversed_draw_order(), &Default::default());
        assert_eq!(
            image_bits(&reference.image),
            image_bits(&reversed.image),
            "seed {seed}"
        );
        for p in 0..scene.resolution.pixel_count() {
            let pixel = lists.pixel(p);
            let level =
                |l: &oit_reference::lists::Layer| scene.queue_level(&scene.draws[l.draw as usize]);
            let nearer = |a: f32, b: f32| scene.camera.nearer(a, b) || a == b;
            for w in pixel.layers.windows(2) {
                let (a, b) = (level(&w[0]), level(&w[1]));
                assert!(
                    a > b || (a == b && nearer(w[0].depth, w[1].depth)),
                    "seed {seed} pixel {p}: {a:?} at {} before {b:?} at {}",
                    w[0].depth,
                    w[1].depth
                );
            }
            // No kept layer has a depth writer of a lower level in front of it.
            for l in pixel.layers {
                let hidden_by = pixel.layers.iter().find(|w| {
                    scene.material_of(&scene.draws[w.draw as usize]).depth_write
                        && level(w) < level(l)
                        && scene.camera.nearer(w.depth, l.depth)
                });
                assert!(
                    hidden_by.is_none(),
                    "seed {seed} pixel {p}: {l:?} behind {hidden_by:?}"
                );
            }
            assert_eq!(
                reference.layers[p] as usize,
                pixel.layers.len(),
                "seed {seed} pixel {p}"
            );
            let fragments: Vec<([f64; 3], [f64; 3])> = pixel
                .layers
                .iter()
                .map(|l| {
                    (
                        l.premultiplied.map(f64::from),
                        l.transmittance.map(f64::from),
                    )
                })
                .collect();
            let want =
                oit_reference::composite_transmittance_front_to_back(&fragments, pixel.behind);
            let got = reference.image.pixels[p];
            for k in 0..3 {
                let err = (f64::from(got[k]) - want[k]).abs();
                assert!(
                    err <= 1e-5 * want[k].abs().max(1.0),
                    "seed {seed} pixel {p}: {got:?} but the list composites to {want:?}"
                );
            }
        }
    }
    assert!(
        with_effects >= 20,
        "only {with_effects} scenes had queue effects"
    );
}

#[test]
fn bundled_queue_scenes_do_what_their_descriptions_say() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let overlay = oit_scene::load(&root.join("ops-background-overlay.json")).unwrap();
    let glow = oit_scene::load(&root.join("ops-additive-depth-write.json")).unwrap();
    for scene in [&overlay, &glow] {
        assert!(scene.has_queue_effects(), "{}", scene.name);
        let mut flat = scene.clone();
        for d in &mut flat.draws {
            d.ordering.queue = None;
        }
        for m in &mut flat.materials {
            m.depth_write = false;
        }
        let (q, f) = (
            render(scene, &Default::default()),
            render(&flat, &Default::default()),
        );
        let changed = q
            .image
            .pixels
            .iter()
            .zip(&f.image.pixels)
            .filter(|(a, b)| (0..3).any(|k| (a[k] - b[k]).abs() > 1e-3))
            .count();
        let largest = q
            .image
            .pixels
            .iter()
            .zip(&f.image.pixels)
            .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
            .fold(0.0f32, f32::max);
        let hidden: u64 = f.layers.iter().map(|&l| u64::from(l)).sum::<u64>()
            - q.layers.iter().map(|&l| u64::from(l)).sum::<u64>();
        eprintln!(
            "{}: {changed} of {} pixels change by more than 1e-3 with queues (largest {largest}); {hidden} layers hidden",
            scene.name,
            q.image.pixels.len()
        );
        assert!(
            changed > 100,
            "{}: queues change only {changed} pixels",
            scene.name
        );
        if std::ptr::eq(scene, &glow) {
            assert!(hidden > 100, "the sphere hides the green pane behind it");
        } else {
            assert_eq!(hidden, 0, "no depth writer in the overlay scene");
        }
    }
}
