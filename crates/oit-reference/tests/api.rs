//! The crate's smaller public surface: comparing a GPU's fragment counts with the reference's
//! (undecided cutoff fragments are the only tolerated difference), the triangle limit, and the
//! options' `Debug` form.

mod common;

use std::sync::Arc;
use std::time::Duration;

use common::*;
use glam::Vec3;
use oit_reference::{
    CountComparison, MAX_TRIANGLES, Reference, ReferenceError, ReferenceOptions, render, try_render,
};
use oit_scene::{AlphaMode, Draw, Material, Scene};

/// 4×4: over the left half a mask quad whose vertex α varies from its cutoff to 2^-20 above
/// it (interpolated, so within the undecided band on every fragment, and kept), a blended
/// full-screen quad (decided everywhere) in front.
fn knife_edge() -> Reference {
    let mut b = SceneBuilder::new(4, 4);
    let mask = Material::plain([1.0, 0.0, 0.0], 1.0, AlphaMode::Mask);
    let [p, q, r, s] = rect(-1.5, -1.5, 0.0, 1.5, 0.0);
    let on = [1.0, 0.0, 0.0, mask.cutoff];
    let above = [1.0, 0.0, 0.0, mask.cutoff + 1.0 / (1 << 20) as f32];
    b.colored_triangles(
        mask,
        &[
            [(p, on), (q, above), (r, above)],
            [(p, on), (r, above), (s, above)],
        ],
    );
    b.quad(blend([0.0, 1.0, 0.0], 0.5), fullscreen(1.0), white());
    render(&b.build(), &ReferenceOptions::default())
}

/// Pixel index of (x, y) in the 4×4 image.
fn px(x: usize, y: usize) -> usize {
    y * 4 + x
}

#[test]
fn the_knife_edge_scene_has_undecided_pixels_on_the_left_only() {
    // The premise of the comparisons below.
    let r = knife_edge();
    for y in 0..4 {
        for x in 0..4 {
            let p = px(x, y);
            assert_eq!(
                r.undecided[p] > 0,
                x < 2,
                "pixel ({x}, {y}): {:?}",
                r.undecided
            );
            // The blended quad everywhere, the kept mask fragment on the left.
            assert_eq!(r.fragments[p], 1 + u32::from(x < 2), "{:?}", r.fragments);
        }
    }
}

#[test]
fn equal_counts_compare_clean() {
    let r = knife_edge();
    assert_eq!(
        r.compare_fragment_counts(&r.fragments),
        CountComparison {
            unexplained: Vec::new(),
            undecided: 0,
        }
    );
}

#[test]
fn differences_within_a_pixels_undecided_fragments_are_tolerated_and_counted() {
    let r = knife_edge();
    let mut gpu = r.fragments.clone();
    // The GPU kept fewer on two undecided pixels (rounding discarded them), more on one.
    let (a, b, c) = (px(0, 0), px(1, 2), px(0, 3));
    gpu[a] -= r.undecided[a];
    gpu[b] -= 1;
    gpu[c] += r.undecided[c];
    let cmp = r.compare_fragment_counts(&gpu);
    assert_eq!(cmp.undecided, 3, "{cmp:?}");
    assert!(cmp.unexplained.is_empty(), "{cmp:?}");
}

#[test]
fn differences_beyond_the_undecided_fragments_are_unexplained_by_pixel() {
    let r = knife_edge();
    let mut gpu = r.fragments.clone();
    // One more than the undecided fragments on the left, one extra on a pixel that has none,
    // one undecided difference beside them.
    let (left, right, tolerated) = (px(1, 1), px(3, 0), px(0, 2));
    gpu[left] += r.undecided[left] + 1;
    gpu[right] -= 1;
    gpu[tolerated] += 1;
    let cmp = r.compare_fragment_counts(&gpu);
    let mut expected = vec![left, right];
    expected.sort_unstable();
    assert_eq!(cmp.unexplained, expected, "{cmp:?}");
    assert_eq!(cmp.undecided, 1, "{cmp:?}");
}

#[test]
#[should_panic(expected = "counts for another resolution")]
fn counts_for_another_resolution_are_refused() {
    let r = knife_edge();
    r.compare_fragment_counts(&r.fragments[1..]);
}

/// A scene of more than `MAX_TRIANGLES` (2^28) triangles (4 097 draws of 65 537 triangles
/// sharing one vertex range) is refused at once, before anything is set up, and the error
/// states the limit. The render runs on its own thread so that a build that let the scene
/// through (and set up 268 M triangles for minutes) fails here after 20 s instead of hanging;
/// the triangles are degenerate, so such a build keeps none of them.
#[test]
fn a_scene_over_max_triangles_is_refused_at_once() {
    let per_draw: u32 = 65_537;
    let draws: u32 = 4_097;
    let count = u64::from(per_draw) * u64::from(draws);
    assert!(count > u64::from(MAX_TRIANGLES) && count < u64::from(MAX_TRIANGLES) + 1_000_000);
    let mut b = SceneBuilder::new(4, 4);
    b.triangles(
        blend([1.0; 3], 0.5),
        &vec![[Vec3::ZERO; 3]; per_draw as usize],
        white(),
    );
    let mut scene: Scene = b.build();
    let template: Draw = scene.draws[0].clone();
    scene.draws = (0..draws)
        .map(|id| Draw {
            id,
            name: format!("objects[{id}]"),
            ..template.clone()
        })
        .collect();
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = send.send(try_render(&scene, &ReferenceOptions::default()).map(|_| ()));
    });
    let err = receive
        .recv_timeout(Duration::from_secs(20))
        .expect("the render of 268 M triangles was not refused within 20 s")
        .unwrap_err();
    assert!(
        matches!(err, ReferenceError::TooManyTriangles(n) if n == count),
        "{err}"
    );
    assert!(err.to_string().contains("at most 268435456"), "{err}");
}

#[test]
fn options_debug_shows_every_field_and_whether_a_callback_is_set() {
    let plain = format!("{:?}", ReferenceOptions::default());
    assert_eq!(
        plain,
        "ReferenceOptions { tile_size: 32, progress: None, memory_budget: 2147483648, in_order: true }"
    );
    let with = ReferenceOptions {
        tile_size: 8,
        progress: Some(Arc::new(|_, _| {})),
        memory_budget: 1 << 20,
        in_order: false,
    };
    assert_eq!(
        format!("{with:?}"),
        "ReferenceOptions { tile_size: 8, progress: Some(\"callback\"), memory_budget: 1048576, in_order: false }"
    );
}
