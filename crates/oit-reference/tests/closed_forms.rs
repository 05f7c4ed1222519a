//! Closed-form checks: images whose every pixel can be computed on paper.

mod common;

use common::*;
use oit_reference::{ReferenceOptions, composite_front_to_back, render};
use oit_scene::AlphaMode;

fn assert_rgb_close(got: [f32; 4], want: [f64; 3], tol: f64, what: &str) {
    for k in 0..3 {
        assert!(
            (f64::from(got[k]) - want[k]).abs() <= tol,
            "{what}: channel {k} is {} but the closed form gives {} (tolerance {tol})",
            got[k],
            want[k]
        );
    }
    assert_eq!(got[3], 1.0, "{what}: alpha must be 1");
}

#[test]
fn n_identical_layers_match_the_geometric_series() {
    for &n in &[1usize, 2, 7, 64] {
        for &a in &[0.1f32, 0.5, 0.9] {
            let c = [0.8f32, 0.3, 0.6];
            let b = [0.1f32, 0.2, 0.9];
            let mut builder = SceneBuilder::new(32, 32).background(b);
            for i in 0..n {
                builder.quad(blend(c, a), fullscreen(-(i as f32) * 0.05), white());
            }
            let r = render(&builder.build(), &ReferenceOptions::default());
            let (a, t) = (f64::from(a), (1.0 - f64::from(a)).powi(n as i32));
            let want: [f64; 3] =
                std::array::from_fn(|k| f64::from(b[k]) * t + f64::from(c[k]) * (1.0 - t));
            for (i, px) in r.image.pixels.iter().enumerate() {
                assert_rgb_close(*px, want, 1e-6, &format!("n={n} a={a} pixel {i}"));
            }
            assert!(
                r.layers.iter().all(|&l| l as usize == n),
                "n={n}: every pixel has n layers"
            );
            assert!(r.fragments.iter().all(|&f| f as usize == n));
            assert_eq!(r.stats.max_depth_complexity as usize, n);
            assert_eq!(r.stats.mean_depth_complexity, n as f64);
            assert_eq!(r.stats.fragments, (n * 32 * 32) as u64);
        }
    }
}

#[test]
fn enderton_red_over_green_over_blue() {
    // Red α .45 in front, then green α .45, then an opaque blue quad. Drawn back to front,
    // front to back and shuffled: the reference sorts, so all give the same vector.
    let red = ([1.0, 0.0, 0.0], -1.0);
    let green = ([0.0, 1.0, 0.0], -2.0);
    for order in [[0usize, 1, 2], [2, 1, 0], [1, 2, 0]] {
        let mut b = SceneBuilder::new(16, 16).background([1.0, 1.0, 1.0]);
        for &o in &order {
            match o {
                0 => b.quad(blend(red.0, 0.45), fullscreen(red.1), white()),
                1 => b.quad(blend(green.0, 0.45), fullscreen(green.1), white()),
                _ => b.quad(opaque([0.0, 0.0, 1.0]), fullscreen(-3.0), white()),
            };
        }
        let r = render(&b.build(), &ReferenceOptions::default());
        for px in &r.image.pixels {
            assert_rgb_close(
                *px,
                [0.45, 0.2475, 0.3025],
                1e-6,
                &format!("order {order:?}"),
            );
        }
        assert!(r.layers.iter().all(|&l| l == 2));
        assert!(
            r.fragments.iter().all(|&f| f == 3),
            "two transparent + one opaque fragment"
        );
    }
}

#[test]
fn four_quarter_layers_over_grey() {
    // White layers of α .25 over grey .25: .25·.75⁴ + (1 − .75⁴) = 0.7626953125 (by hand).
    let mut b = SceneBuilder::new(16, 16).background([0.25; 3]);
    for i in 0..4 {
        b.quad(blend([1.0; 3], 0.25), fullscreen(-(i as f32)), white());
    }
    let r = render(&b.build(), &ReferenceOptions::default());
    for px in &r.image.pixels {
        assert_rgb_close(*px, [0.762_695_312_5; 3], 1e-7, "4 × α .25 over grey");
    }
}

#[test]
fn composite_function_closed_forms() {
    let enderton = composite_front_to_back(
        &[([0.45, 0.0, 0.0], 0.45), ([0.0, 0.45, 0.0], 0.45)],
        [0.0, 0.0, 1.0],
    );
    for (got, want) in enderton.iter().zip([0.45, 0.2475, 0.3025]) {
        assert!((got - want).abs() < 1e-12, "{got} vs {want}");
    }
    assert_eq!(
        composite_front_to_back(&[], [0.1, 0.2, 0.3]),
        [0.1, 0.2, 0.3]
    );
    // An opaque-alpha fragment in front hides everything behind it.
    let hidden = composite_front_to_back(&[([0.5, 0.25, 0.0], 1.0), ([9.0; 3], 0.5)], [7.0; 3]);
    assert_eq!(hidden, [0.5, 0.25, 0.0]);
    // Order matters: the same two fragments swapped give another colour.
    let swapped = composite_front_to_back(
        &[([0.0, 0.45, 0.0], 0.45), ([0.45, 0.0, 0.0], 0.45)],
        [0.0, 0.0, 1.0],
    );
    assert!((swapped[0] - 0.2475).abs() < 1e-12 && (swapped[1] - 0.45).abs() < 1e-12);
}

#[test]
fn opaque_occludes_and_layers_only_count_what_is_in_front() {
    // Layers at z = -1, -2, -4, -5; opaque at z = -3 over the left half only.
    let size = 32;
    let mut b = SceneBuilder::new(size, size).background([0.0; 3]);
    for z in [-1.0, -2.0, -4.0, -5.0] {
        b.quad(blend([1.0, 0.5, 0.25], 0.5), fullscreen(z), white());
    }
    b.quad(
        opaque([0.0, 1.0, 0.0]),
        rect(-1.5, -1.5, 0.0, 1.5, -3.0),
        white(),
    );
    for reverse_z in [true, false] {
        let scene = b.build();
        let scene = oit_scene::Scene {
            camera: ortho_camera(size, size, reverse_z),
            ..scene
        };
        let r = render(&scene, &ReferenceOptions::default());
        for y in 0..size {
            for x in 0..size {
                let i = (y * size + x) as usize;
                let left = x < size / 2;
                assert_eq!(r.layers[i], if left { 2 } else { 4 }, "layers at ({x},{y})");
                assert_eq!(
                    r.fragments[i],
                    if left { 5 } else { 4 },
                    "fragments at ({x},{y})"
                );
                let (n, base) = if left {
                    (2, [0.0, 1.0, 0.0])
                } else {
                    (4, [0.0; 3])
                };
                let t = 0.5f64.powi(n);
                let want = std::array::from_fn(|k| [1.0, 0.5, 0.25][k] * (1.0 - t) + base[k] * t);
                assert_rgb_close(
                    r.image.get(x, y),
                    want,
                    1e-6,
                    &format!("reverse_z={reverse_z}"),
                );
            }
        }
        assert_eq!(r.stats.transparent_fragments, 4 * u64::from(size * size));
        assert_eq!(r.stats.composited_fragments, 3 * u64::from(size * size));
    }
}

#[test]
fn nearest_opaque_wins_and_transparent_behind_is_dropped() {
    // Two opaque quads: the nearer (drawn first) must win regardless of draw order.
    let mut b = SceneBuilder::new(8, 8);
    b.quad(opaque([1.0, 0.0, 0.0]), fullscreen(-1.0), white());
    b.quad(opaque([0.0, 0.0, 1.0]), fullscreen(-2.0), white());
    b.quad(blend([0.0, 1.0, 0.0], 0.5), fullscreen(-1.5), white());
    for scene in [b.build(), b.build().with_reversed_draw_order()] {
        let r = render(&scene, &ReferenceOptions::default());
        assert!(r.image.pixels.iter().all(|p| *p == [1.0, 0.0, 0.0, 1.0]));
        assert!(r.layers.iter().all(|&l| l == 0));
        assert!(r.fragments.iter().all(|&f| f == 3));
    }
}

#[test]
fn mask_cutoff_discards_below_and_keeps_above() {
    // Vertex alpha ramps 0 → 1 from the left screen edge to the right one (orthographic, so
    // linear in x): α at pixel x is (x + .5)/64, below the .5 cutoff exactly for x < 32.
    let size = 64;
    let l = |x: f32, y: f32, a: f32| (glam::Vec3::new(x, y, -1.0), [1.0, 1.0, 1.0, a]);
    let tris = [
        [l(-1.0, -1.0, 0.0), l(1.0, -1.0, 1.0), l(1.0, 1.0, 1.0)],
        [l(-1.0, -1.0, 0.0), l(1.0, 1.0, 1.0), l(-1.0, 1.0, 0.0)],
    ];
    for mode in [AlphaMode::Mask, AlphaMode::MaskBlend] {
        let mut b = SceneBuilder::new(size, size).background([0.0, 0.0, 1.0]);
        b.colored_triangles(material([1.0, 0.0, 0.0], 1.0, mode), &tris);
        let r = render(&b.build(), &ReferenceOptions::default());
        for y in 0..size {
            for x in 0..size {
                let i = (y * size + x) as usize;
                let kept = x >= 32;
                assert_eq!(
                    r.fragments[i],
                    u32::from(kept),
                    "{mode:?} fragments at ({x},{y})"
                );
                let px = r.image.get(x, y);
                match (mode, kept) {
                    (_, false) => assert_eq!(px, [0.0, 0.0, 1.0, 1.0]),
                    (AlphaMode::Mask, true) => assert_eq!(px, [1.0, 0.0, 0.0, 1.0]),
                    _ => {
                        let a = (f64::from(x) + 0.5) / 64.0;
                        assert_rgb_close(px, [a, 0.0, 1.0 - a], 1e-5, "mask-blend");
                        assert_eq!(r.layers[i], 1);
                    }
                }
            }
        }
    }
}

#[test]
fn premultiplied_and_intensity_follow_material_shade() {
    let mut m = blend([0.5, 0.25, 1.0], 0.5);
    m.premultiplied = true;
    m.intensity = 4.0;
    let mut b = SceneBuilder::new(8, 8).background([1.0, 1.0, 1.0]);
    b.quad(m, fullscreen(-1.0), [1.0, 1.0, 1.0, 1.0]);
    let r = render(&b.build(), &ReferenceOptions::default());
    // Premultiplied: C = rgb · intensity = (2, 1, 4), T = .5 → C + .5 · white.
    for px in &r.image.pixels {
        assert_rgb_close(*px, [2.5, 1.5, 4.5], 1e-6, "premultiplied HDR");
    }
}

#[test]
fn invalid_hand_built_scenes_are_errors_not_panics() {
    let mut b = SceneBuilder::new(8, 8);
    b.quad(blend([1.0; 3], 0.5), fullscreen(-1.0), white());
    let good = b.build();
    let mut bad = good.clone();
    bad.draws[0].material = 7;
    let e = oit_reference::try_render(&bad, &ReferenceOptions::default()).unwrap_err();
    assert!(matches!(
        e,
        oit_reference::ReferenceError::Material {
            material: 7,
            count: 1,
            ..
        }
    ));
    assert!(e.to_string().contains("objects[0]"), "{e}");
    let mut bad = good.clone();
    bad.draws[0].vertex_count = 9;
    let e = oit_reference::try_render(&bad, &ReferenceOptions::default()).unwrap_err();
    assert!(matches!(
        e,
        oit_reference::ReferenceError::VertexRange {
            count: 9,
            total: 6,
            ..
        }
    ));
    let opts = ReferenceOptions {
        tile_size: 0,
        ..ReferenceOptions::default()
    };
    let e = oit_reference::try_render(&good, &opts).unwrap_err();
    assert_eq!(e, oit_reference::ReferenceError::TileSize(0));
}

#[test]
fn progress_reports_every_tile_and_tile_size_does_not_change_the_image() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let mut b = SceneBuilder::new(100, 70).background([0.2, 0.3, 0.4]);
    b.quad(
        blend([1.0, 0.0, 0.0], 0.3),
        rect(-0.7, -0.9, 0.8, 0.6, -1.0),
        white(),
    );
    b.triangles(
        double_sided(blend([0.0, 1.0, 0.5], 0.6)),
        &[[
            glam::Vec3::new(-1.2, 0.9, -2.0),
            glam::Vec3::new(0.3, -1.0, -0.5),
            glam::Vec3::new(1.1, 0.8, -1.5),
        ]],
        white(),
    );
    let scene = b.build();
    let calls = Arc::new(AtomicUsize::new(0));
    let max_done = Arc::new(AtomicUsize::new(0));
    let (c, m) = (calls.clone(), max_done.clone());
    let opts = ReferenceOptions {
        tile_size: 16,
        progress: Some(Arc::new(move |done, total| {
            assert_eq!(total, 7 * 5);
            c.fetch_add(1, Ordering::SeqCst);
            m.fetch_max(done, Ordering::SeqCst);
        })),
        ..Default::default()
    };
    let a = render(&scene, &opts);
    assert_eq!(calls.load(Ordering::SeqCst), 35);
    assert_eq!(max_done.load(Ordering::SeqCst), 35);
    assert_eq!(a.stats.tiles, 35);
    for tile_size in [1, 7, 32, 128] {
        let b = render(
            &scene,
            &ReferenceOptions {
                tile_size,
                progress: None,
                ..Default::default()
            },
        );
        assert_eq!(a.image, b.image, "tile size {tile_size}");
        assert_eq!(a.layers, b.layers);
        assert_eq!(a.fragments, b.fragments);
    }
    assert!(a.layers.contains(&2), "the two shapes overlap somewhere");
}
