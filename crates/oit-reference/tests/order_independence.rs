//! The reference does not depend on draw order: its tie-breaks use the stable draw ids.

mod common;

use common::*;
use glam::Vec3;
use oit_reference::{Reference, ReferenceOptions, render};
use oit_scene::{AlphaMode, Camera, Projection, Scene};
use proptest::prelude::*;

const SIZE: u32 = 48;

fn assert_identical(a: &Reference, b: &Reference, what: &str) {
    assert!(
        image_bits(&a.image) == image_bits(&b.image),
        "{what}: images differ"
    );
    assert_eq!(a.layers, b.layers, "{what}: layer counts differ");
    assert_eq!(a.fragments, b.fragments, "{what}: fragment counts differ");
}

/// (material kind, rgb, alpha, triangles) of one draw.
type SoupDraw = (u8, [f32; 3], f32, Vec<[Vec3; 3]>);

#[derive(Debug, Clone)]
struct Soup {
    perspective: bool,
    reverse_z: bool,
    draws: Vec<SoupDraw>,
}

fn soup() -> impl Strategy<Value = Soup> {
    let coord = -1.2f32..1.2;
    // A few depth levels shared by many triangles: exact coplanar ties under ortho.
    let z = prop_oneof![Just(-1.0f32), Just(-2.0f32), Just(-3.0f32), -4.0f32..-0.5];
    let tri = (
        coord.clone(),
        coord.clone(),
        coord.clone(),
        coord.clone(),
        coord.clone(),
        coord,
        z.clone(),
        z,
    )
        .prop_map(|(a, b, c, d, e, f, z0, z1)| {
            [
                Vec3::new(a, b, z0),
                Vec3::new(c, d, z0),
                Vec3::new(e, f, z1),
            ]
        });
    let draw = (
        0u8..4,
        prop::array::uniform3(0.0f32..1.0),
        0.0f32..=1.0,
        prop::collection::vec(tri, 1..4),
    );
    (
        any::<bool>(),
        any::<bool>(),
        prop::collection::vec(draw, 2..7),
    )
        .prop_map(|(perspective, reverse_z, draws)| Soup {
            perspective,
            reverse_z,
            draws,
        })
}

fn build(s: &Soup) -> Scene {
    let camera = if s.perspective {
        Camera::new(
            Vec3::new(0.2, 0.1, 2.5),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::Y,
            Projection::Perspective {
                fov_y_degrees: 70.0,
            },
            0.5,
            20.0,
            s.reverse_z,
            1.0,
        )
    } else {
        ortho_camera(SIZE, SIZE, s.reverse_z)
    };
    let mut b = SceneBuilder::new(SIZE, SIZE)
        .camera(camera)
        .background([0.1, 0.2, 0.3]);
    for (i, (kind, rgb, alpha, tris)) in s.draws.iter().enumerate() {
        let mode = [
            AlphaMode::Blend,
            AlphaMode::Opaque,
            AlphaMode::MaskBlend,
            AlphaMode::Mask,
        ][*kind as usize];
        let mut m = double_sided(material(*rgb, *alpha, mode));
        m.cutoff = 0.3;
        b.triangles(m, tris, white());
        // Every other draw gets an exact coplanar duplicate in another colour: a pure tie.
        if i % 2 == 0 {
            b.triangles(
                double_sided(blend([rgb[2], rgb[0], rgb[1]], 0.5)),
                tris,
                white(),
            );
        }
    }
    b.build()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn permuted_draw_orders_give_bit_identical_references(s in soup(), seed in any::<u64>()) {
        let scene = build(&s);
        let reference = render(&scene, &ReferenceOptions::default());
        assert_all_finite(&reference.image);
        let reversed = render(&scene.with_reversed_draw_order(), &ReferenceOptions::default());
        assert_identical(&reference, &reversed, "reversed");
        // A seeded Fisher–Yates shuffle.
        let mut order: Vec<usize> = (0..scene.draws.len()).collect();
        let mut state = seed | 1;
        for i in (1..order.len()).rev() {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            order.swap(i, (state % (i as u64 + 1)) as usize);
        }
        let shuffled = render(&scene.with_draw_order(&order), &ReferenceOptions::default());
        assert_identical(&reference, &shuffled, "shuffled");
    }
}

#[test]
fn coplanar_ties_follow_the_documented_rule() {
    // Four quads at one depth. Transparent: the highest draw id is in front. Whatever the
    // draw order, the result is red (id 3) over blue (2) over green (1) over white (0).
    let colours = [
        [1.0, 1.0, 1.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
    ];
    let mut b = SceneBuilder::new(8, 8).background([0.0; 3]);
    for c in colours {
        b.quad(blend(c, 0.5), fullscreen(-1.0), white());
    }
    let scene = b.build();
    let front_to_back: Vec<([f64; 3], f64)> = colours
        .iter()
        .rev()
        .map(|c| (c.map(|v| 0.5 * f64::from(v)), 0.5))
        .collect();
    let want = oit_reference::composite_front_to_back(&front_to_back, [0.0; 3]);
    // By hand: R .5, B .25, G .125, W .0625 → (0.5625, 0.1875, 0.3125).
    assert!((want[0] - 0.5625).abs() < 1e-12 && (want[1] - 0.1875).abs() < 1e-12);
    for order in [vec![0, 1, 2, 3], vec![3, 2, 1, 0], vec![2, 0, 3, 1]] {
        let r = render(&scene.with_draw_order(&order), &ReferenceOptions::default());
        for p in &r.image.pixels {
            for k in 0..3 {
                assert!(
                    (f64::from(p[k]) - want[k]).abs() < 1e-6,
                    "order {order:?}: {p:?}"
                );
            }
        }
    }
    // Opaque: the lowest draw id wins a tie (a LESS depth test in natural order).
    let mut b = SceneBuilder::new(8, 8);
    for c in colours {
        b.quad(opaque(c), fullscreen(-1.0), white());
    }
    for order in [vec![0, 1, 2, 3], vec![3, 2, 1, 0]] {
        let r = render(
            &b.build().with_draw_order(&order),
            &ReferenceOptions::default(),
        );
        assert!(
            r.image.pixels.iter().all(|p| *p == [1.0, 1.0, 1.0, 1.0]),
            "order {order:?}"
        );
    }
}
