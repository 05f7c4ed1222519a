//! Coloured transmission in the reference: closed forms per channel, order independence,
//! scalar alpha as the grey special case, and the memory budget with the extra per-slot
//! transmittance.

mod common;

use common::*;
use oit_reference::{
    ReferenceOptions, composite_front_to_back, composite_transmittance_front_to_back, render,
    try_render,
};
use oit_scene::{AlphaMode, Material, Scene};

/// A transmissive pane: filter (and base colour) `rgb`, coverage `alpha`, factor `tau`.
fn pane(rgb: [f32; 3], alpha: f32, tau: f32) -> Material {
    let mut m = Material::plain(rgb, alpha, AlphaMode::Blend);
    m.transmission = tau;
    m
}

/// The fragment of [`pane`] in f64: premultiplied radiance and transmittance.
fn pane_fragment(rgb: [f32; 3], alpha: f32, tau: f32) -> ([f64; 3], [f64; 3]) {
    let (a, t) = (f64::from(alpha), f64::from(tau));
    (
        rgb.map(|c| a * (1.0 - t) * f64::from(c)),
        rgb.map(|c| (1.0 - a) + a * t * f64::from(c)),
    )
}

/// Front to back, by hand: `C1 + t1 ⊙ (C2 + t2 ⊙ background)`.
fn two_panes(front: ([f64; 3], [f64; 3]), back: ([f64; 3], [f64; 3]), bg: [f32; 3]) -> [f64; 3] {
    std::array::from_fn(|k| front.0[k] + front.1[k] * (back.0[k] + back.1[k] * f64::from(bg[k])))
}

fn assert_close(got: [f32; 4], want: [f64; 3], tol: f64, what: &str) {
    for k in 0..3 {
        let err = (f64::from(got[k]) - want[k]).abs();
        assert!(
            err <= tol,
            "{what}: channel {k} is {} but the closed form gives {} (error {err:e}, tolerance {tol:e})",
            got[k],
            want[k]
        );
    }
}

/// Two overlapping tinted panes of complementary colours over a grey background, in `order`;
/// the front pane covers the left half of the frame more than the back one.
fn complementary(front_first: bool) -> Scene {
    let mut b = SceneBuilder::new(32, 32).background([0.5, 0.6, 0.7]);
    let red = (
        pane([0.9, 0.2, 0.1], 0.8, 0.75),
        rect(-1.5, -1.5, 0.5, 1.5, -1.0),
    );
    let cyan = (
        pane([0.1, 0.7, 0.95], 0.9, 0.6),
        rect(-0.5, -1.5, 1.5, 1.5, -2.0),
    );
    let draws = if front_first {
        [red, cyan]
    } else {
        [cyan, red]
    };
    for (m, r) in draws {
        b.quad(m, r, white());
    }
    b.build()
}

#[test]
fn two_tinted_panes_match_the_closed_form_per_channel() {
    let bg = [0.5, 0.6, 0.7];
    let red = pane_fragment([0.9, 0.2, 0.1], 0.8, 0.75);
    let cyan = pane_fragment([0.1, 0.7, 0.95], 0.9, 0.6);
    let none = ([0.0; 3], [1.0; 3]);
    for front_first in [true, false] {
        let r = render(&complementary(front_first), &ReferenceOptions::default());
        // Columns 0..8: red only; 8..24: red over cyan; 24..32: cyan only.
        for y in [0, 13, 31] {
            for (x, want) in [
                (3, two_panes(red, none, bg)),
                (16, two_panes(red, cyan, bg)),
                (28, two_panes(none, cyan, bg)),
            ] {
                let what = format!("front_first={front_first} pixel ({x}, {y})");
                assert_close(r.image.get(x, y), want, 1e-6, &what);
            }
        }
        assert_eq!(r.stats.max_depth_complexity, 2);
    }
    // Where they overlap the filters multiply per channel: no scalar alpha gives this colour.
    let overlap = two_panes(red, cyan, bg);
    let spread = overlap.iter().cloned().fold(f64::MIN, f64::max)
        - overlap.iter().cloned().fold(f64::MAX, f64::min);
    assert!(spread > 0.05, "the case must be coloured: {overlap:?}");
}

#[test]
fn draw_order_does_not_change_a_bit() {
    let a = render(&complementary(true), &ReferenceOptions::default());
    let b = render(&complementary(false), &ReferenceOptions::default());
    assert!(image_bits(&a.image) == image_bits(&b.image));
    // A 32-pane stack of alternating tints, in both orders.
    let stack = |reverse: bool| {
        let mut b = SceneBuilder::new(16, 16).background([1.0; 3]);
        let mut panes: Vec<usize> = (0..32).collect();
        if reverse {
            panes.reverse();
        }
        for i in panes {
            let c = [[1.0, 0.8, 0.6], [0.6, 1.0, 0.8], [0.8, 0.6, 1.0]][i % 3];
            b.quad(pane(c, 0.9, 0.9), fullscreen(-0.1 * i as f32), white());
        }
        render(&b.build(), &ReferenceOptions::default())
    };
    let (front, back) = (stack(false), stack(true));
    assert!(image_bits(&front.image) == image_bits(&back.image));
    // And the stack is what the f64 formula gives for its 32 fragments.
    let fragments: Vec<_> = (0..32)
        .map(|i| {
            let c = [[1.0, 0.8, 0.6], [0.6, 1.0, 0.8], [0.8, 0.6, 1.0]][i % 3];
            pane_fragment(c, 0.9, 0.9)
        })
        .collect();
    let want = composite_transmittance_front_to_back(&fragments, [1.0; 3]);
    assert_close(front.image.get(7, 7), want, 1e-6, "32-pane stack");
}

#[test]
fn scalar_alpha_is_the_grey_case_bit_for_bit() {
    // The coloured formula with t = 1 − α in every channel is the scalar one, bit for bit.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for n in [1, 2, 5, 33] {
        let scalar: Vec<([f64; 3], f64)> =
            (0..n).map(|_| ([next(), next(), next()], next())).collect();
        let coloured: Vec<([f64; 3], [f64; 3])> =
            scalar.iter().map(|&(c, a)| (c, [1.0 - a; 3])).collect();
        let bg = [next(), next(), next()];
        let a = composite_front_to_back(&scalar, bg);
        let b = composite_transmittance_front_to_back(&coloured, bg);
        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "{n} layers");
    }
    // In a rendered scene: ordinary layers composited beside a transmissive one keep their
    // exact 1 − α (a pane with τ = 1 and a white filter is invisible).
    let layered = |with_pane: bool| {
        let mut b = SceneBuilder::new(8, 8).background([0.2, 0.3, 0.4]);
        b.quad(blend([1.0, 0.5, 0.25], 0.3), fullscreen(-1.0), white());
        if with_pane {
            b.quad(pane([1.0; 3], 1.0, 1.0), fullscreen(-2.0), white());
        }
        b.quad(blend([0.1, 0.9, 0.3], 0.7), fullscreen(-3.0), white());
        render(&b.build(), &ReferenceOptions::default())
    };
    let (plain, clear) = (layered(false), layered(true));
    assert!(image_bits(&plain.image) == image_bits(&clear.image));
    assert_eq!(clear.stats.max_depth_complexity, 3);
}

#[test]
fn a_tinted_pane_over_opaque_filters_it_and_opaque_in_front_hides_it() {
    let mut b = SceneBuilder::new(16, 16).background([0.0; 3]);
    b.quad(
        opaque([0.8, 0.8, 0.8]),
        rect(-1.5, -1.5, 1.5, 1.5, -3.0),
        white(),
    );
    b.quad(pane([0.2, 0.9, 0.4], 1.0, 1.0), fullscreen(-2.0), white());
    // The left half has an opaque quad in front of the pane.
    b.quad(
        opaque([0.1, 0.1, 0.1]),
        rect(-1.5, -1.5, 0.0, 1.5, -1.0),
        white(),
    );
    let r = render(&b.build(), &ReferenceOptions::default());
    let filtered = [0.8 * 0.2, 0.8 * 0.9, 0.8 * 0.4].map(|c: f64| c as f32 as f64);
    assert_close(r.image.get(12, 8), filtered, 1e-6, "pane over opaque");
    assert_close(
        r.image.get(3, 8),
        [0.1f32 as f64; 3],
        0.0,
        "opaque in front",
    );
    assert_eq!(r.layers[8 * 16 + 3], 0);
    assert_eq!(r.layers[8 * 16 + 12], 1);
}

#[test]
fn a_small_budget_slices_coloured_tiles_and_changes_no_bit() {
    let mut b = SceneBuilder::new(64, 64).background([0.3; 3]);
    for i in 0..24 {
        let c = [[1.0, 0.3, 0.3], [0.3, 1.0, 0.3], [0.3, 0.3, 1.0]][i % 3];
        b.quad(pane(c, 0.7, 0.5), fullscreen(-0.1 * i as f32), white());
    }
    let scene = b.build();
    let whole = render(&scene, &ReferenceOptions::default());
    // The panes arrive nearest first: composited in order they need no slot storage at all.
    assert_eq!(whole.stats.in_order_tiles, whole.stats.tiles);
    for in_order in [false, true] {
        let tight = try_render(
            &scene,
            &ReferenceOptions {
                memory_budget: 256 * 1024,
                in_order,
                ..ReferenceOptions::default()
            },
        )
        .expect("fits when sliced");
        assert!(image_bits(&whole.image) == image_bits(&tight.image));
        assert_eq!(
            tight.stats.sliced_tiles > 0,
            !in_order,
            "stored, the budget must force slicing; in order, it need not"
        );
        assert!(tight.stats.peak_tile_bytes <= 256 * 1024);
    }
}
