//! Coverage: the top-left rule, watertight shared edges, face culling.

mod common;

use common::*;
use glam::Vec3;
use oit_reference::{ReferenceOptions, render};
use oit_scene::{Camera, Projection, Scene};

const SIZE: u32 = 128;

/// Grid lines in window pixels: integers, pixel centres (x.5), arbitrary fractions, and lines
/// beyond the screen so the grid covers it fully.
const LINES: [f64; 12] = [
    -9.0, 0.0, 16.5, 32.0, 40.5, 53.25, 64.0, 64.3, 90.75, 100.5, 128.0, 140.0,
];

/// A grid of quads between `LINES` (in x and y), each split along an alternating diagonal,
/// one draw per quad.
fn screen_grid() -> Scene {
    let mut b = SceneBuilder::new(SIZE, SIZE);
    for (j, w) in LINES.windows(2).enumerate() {
        for (i, v) in LINES.windows(2).enumerate() {
            let (x0, x1) = (world_of_window_x(v[0], SIZE), world_of_window_x(v[1], SIZE));
            // Window rows grow downwards; world y upwards.
            let (y0, y1) = (world_of_window_y(w[1], SIZE), world_of_window_y(w[0], SIZE));
            let r = rect(x0, y0, x1, y1, -1.0);
            let tris = if (i + j) % 2 == 0 {
                [[r[0], r[1], r[2]], [r[0], r[2], r[3]]]
            } else {
                [[r[0], r[1], r[3]], [r[1], r[2], r[3]]]
            };
            b.triangles(blend([1.0; 3], 0.5), &tris, white());
        }
    }
    b.build()
}

fn assert_exactly_one(scene: &Scene, what: &str) {
    let r = render(scene, &ReferenceOptions::default());
    let w = scene.resolution.width as usize;
    for (i, (&f, &l)) in r.fragments.iter().zip(&r.layers).enumerate() {
        assert_eq!(
            f,
            1,
            "{what}: pixel ({}, {}) has {f} fragments",
            i % w,
            i / w
        );
        assert_eq!(l, 1, "{what}: pixel ({}, {}) has {l} layers", i % w, i / w);
    }
}

#[test]
fn screen_aligned_grid_covers_every_pixel_once() {
    let scene = screen_grid();
    assert_exactly_one(&scene, "axis-aligned grid");
    assert_exactly_one(
        &scene.with_reversed_draw_order(),
        "axis-aligned grid, reversed",
    );
}

#[test]
fn top_left_rule_on_pixel_centre_edges() {
    // Square with all four edges exactly through pixel centres: x from 10.5 to 20.5, y from
    // 10.5 to 20.5. Top and left edges are in, bottom and right out: pixels 10..=19 both ways.
    for ccw in [true, false] {
        let r = rect(
            world_of_window_x(10.5, 32),
            world_of_window_y(20.5, 32),
            world_of_window_x(20.5, 32),
            world_of_window_y(10.5, 32),
            -1.0,
        );
        let mut b = SceneBuilder::new(32, 32);
        let corners = if ccw { r } else { [r[0], r[3], r[2], r[1]] };
        b.quad(double_sided(blend([1.0; 3], 0.5)), corners, white());
        let out = render(&b.build(), &ReferenceOptions::default());
        for y in 0..32u32 {
            for x in 0..32u32 {
                let want = u32::from((10..20).contains(&x) && (10..20).contains(&y));
                assert_eq!(
                    out.fragments[(y * 32 + x) as usize],
                    want,
                    "ccw={ccw} ({x},{y})"
                );
            }
        }
    }
}

#[test]
fn top_left_rule_on_a_shared_diagonal_through_pixel_centres() {
    // A square with corners on pixel centres (4.5, 4.5)..(12.5, 12.5), split along its
    // diagonal, which therefore runs exactly through the pixel centres (k.5, k.5).
    let p = |x: f64, y: f64| Vec3::new(world_of_window_x(x, 16), world_of_window_y(y, 16), -1.0);
    let (a, b, c, d) = (p(4.5, 4.5), p(12.5, 4.5), p(12.5, 12.5), p(4.5, 12.5));
    // Double-sided: winding is tested separately (culling_follows_ccw_front_faces).
    let mut s = SceneBuilder::new(16, 16);
    s.triangles(double_sided(blend([1.0; 3], 0.5)), &[[a, b, c]], white());
    s.triangles(double_sided(blend([1.0; 3], 0.5)), &[[a, c, d]], white());
    let r = render(&s.build(), &ReferenceOptions::default());
    for y in 0..16u32 {
        for x in 0..16u32 {
            let want = u32::from((4..12).contains(&x) && (4..12).contains(&y));
            assert_eq!(r.fragments[(y * 16 + x) as usize], want, "({x},{y})");
        }
    }
    // The 8 diagonal centres belong to exactly one of the two triangles: the upper-right one,
    // whose spans start at the diagonal (a left edge: in); for the lower-left one the spans
    // end there (a right edge: out).
    assert_eq!(r.stats.fragments, 64);
    let upper_right_only = {
        let mut s = SceneBuilder::new(16, 16);
        s.triangles(double_sided(blend([1.0; 3], 0.5)), &[[a, b, c]], white());
        render(&s.build(), &ReferenceOptions::default())
    };
    // Row k (centre k + .5) spans x in [k + .5, 12.5): 8 + 7 + … + 1 = 36 pixels.
    assert_eq!(upper_right_only.stats.fragments, 36);
    for k in 4..12u32 {
        assert_eq!(
            upper_right_only.fragments[(k * 16 + k) as usize],
            1,
            "diagonal ({k},{k})"
        );
    }
}

/// A camera looking obliquely down at the z = 0 plane with a tilted up vector: the grid's
/// image is rotated and projectively sheared.
fn oblique_camera(width: u32, height: u32) -> Camera {
    Camera::new(
        Vec3::new(1.0, -1.5, 6.0),
        Vec3::new(0.3, 0.2, 0.0),
        Vec3::new(0.4, 1.0, 0.0),
        Projection::Perspective {
            fov_y_degrees: 50.0,
        },
        0.1,
        100.0,
        true,
        width as f32 / height as f32,
    )
}

#[test]
fn oblique_perspective_grid_covers_every_pixel_once() {
    let lines = [
        -12.0f32, -7.3, -3.1, -1.7, -0.9, -0.25, 0.0, 0.33, 0.8, 1.41, 2.0, 2.9, 4.4, 7.7, 12.0,
    ];
    let mut b = SceneBuilder::new(160, 112).camera(oblique_camera(160, 112));
    let mut tris = Vec::new();
    for (j, w) in lines.windows(2).enumerate() {
        for (i, v) in lines.windows(2).enumerate() {
            // Counter-clockwise seen from +z, where the camera is: front faces, single-sided.
            let r = rect(v[0], w[0], v[1], w[1], 0.0);
            if (i + j) % 2 == 0 {
                tris.push([r[0], r[1], r[2]]);
                tris.push([r[0], r[2], r[3]]);
            } else {
                tris.push([r[0], r[1], r[3]]);
                tris.push([r[1], r[2], r[3]]);
            }
        }
    }
    // Several draws, so that the grid is not one object.
    for chunk in tris.chunks(37) {
        b.triangles(blend([1.0; 3], 0.5), chunk, white());
    }
    let scene = b.build();
    assert_exactly_one(&scene, "oblique perspective grid");
    // The same grid seen from below is all back faces: nothing.
    let below = Scene {
        camera: Camera::new(
            Vec3::new(1.0, -1.5, -6.0),
            Vec3::new(0.3, 0.2, 0.0),
            Vec3::new(0.4, 1.0, 0.0),
            Projection::Perspective {
                fov_y_degrees: 50.0,
            },
            0.1,
            100.0,
            true,
            160.0 / 112.0,
        ),
        ..scene
    };
    let r = render(&below, &ReferenceOptions::default());
    assert_eq!(r.stats.fragments, 0, "back faces are culled");
}

#[test]
fn triangle_fans_around_an_interior_vertex_hit_each_hull_pixel_once() {
    // Centre on a pixel centre; rim vertices chosen so that several spokes run exactly
    // through pixel centres (horizontal, vertical, 45°) and others at arbitrary slopes.
    let size = 64u32;
    let centre = (31.5f64, 30.5f64);
    let rim: [(f64, f64); 9] = [
        (55.5, 30.5), // horizontal spoke through centres
        (50.5, 11.5), // 45° spoke
        (31.5, 4.5),  // vertical spoke
        (12.25, 8.75),
        (6.5, 30.5), // horizontal again
        (9.1, 51.3),
        (31.5, 59.5), // vertical
        (47.5, 46.5), // 45°
        (58.7, 40.2),
    ];
    let to_world = |(x, y): (f64, f64)| {
        Vec3::new(world_of_window_x(x, size), world_of_window_y(y, size), -1.0)
    };
    let mut tris = Vec::new();
    for i in 0..rim.len() {
        let (a, b) = (rim[i], rim[(i + 1) % rim.len()]);
        // The rim runs counter-clockwise as seen on screen: front faces, single-sided.
        tris.push([to_world(centre), to_world(a), to_world(b)]);
    }
    let mut s = SceneBuilder::new(size, size);
    for t in &tris {
        s.triangles(blend([1.0; 3], 0.5), std::slice::from_ref(t), white());
    }
    let r = render(&s.build(), &ReferenceOptions::default());
    // Inside the fan's outline (a star-shaped polygon around the centre) by more than 1e-3
    // pixel: exactly one hit; outside: none. Pixel centres on the outline itself follow the
    // fill rule and are only bounded by one. The spokes get no margin: they are the point.
    let cross = |a: (f64, f64), b: (f64, f64), p: (f64, f64)| {
        (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)
    };
    let segment_distance = |a: (f64, f64), b: (f64, f64), p: (f64, f64)| {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let t = (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
        ((p.0 - a.0 - t * dx).powi(2) + (p.1 - a.1 - t * dy).powi(2)).sqrt()
    };
    let mut interior = 0;
    for y in 0..size {
        for x in 0..size {
            let p = (f64::from(x) + 0.5, f64::from(y) + 0.5);
            let mut min_dist = f64::INFINITY;
            let mut inside = false;
            for i in 0..rim.len() {
                let (a, b) = (rim[i], rim[(i + 1) % rim.len()]);
                // Each fan triangle runs counter-clockwise on the y-down screen: interior
                // where all three cross products are <= 0.
                inside |= cross(centre, a, p) <= 0.0
                    && cross(a, b, p) <= 0.0
                    && cross(b, centre, p) <= 0.0;
                min_dist = min_dist.min(segment_distance(a, b, p));
            }
            let hits = r.fragments[(y * size + x) as usize];
            if min_dist > 1e-3 {
                assert_eq!(hits, u32::from(inside), "pixel ({x},{y}) inside={inside}");
                interior += u32::from(inside);
            } else {
                assert!(hits <= 1, "pixel ({x},{y}) on the outline hit {hits} times");
            }
        }
    }
    assert!(
        interior > 1500,
        "the fan covers a large area ({interior} pixels)"
    );
}

#[test]
fn culling_follows_ccw_front_faces() {
    // Counter-clockwise in NDC with y up: front. Its mirror: back.
    let ccw = [
        Vec3::new(-0.5, -0.5, -1.0),
        Vec3::new(0.5, -0.5, -1.0),
        Vec3::new(0.0, 0.5, -1.0),
    ];
    let cw = [ccw[0], ccw[2], ccw[1]];
    let count = |tri: [Vec3; 3], double: bool| {
        let mut m = blend([1.0; 3], 0.5);
        m.double_sided = double;
        let mut b = SceneBuilder::new(32, 32);
        b.triangles(m, &[tri], white());
        render(&b.build(), &ReferenceOptions::default())
            .stats
            .fragments
    };
    let front = count(ccw, false);
    assert!(front > 100, "a front face renders ({front} fragments)");
    assert_eq!(count(cw, false), 0, "a back face is culled");
    assert_eq!(
        count(cw, true),
        front,
        "a double-sided back face renders the same pixels"
    );
    assert_eq!(count(ccw, true), front);
    // A single-sided quad seen from behind (camera on the other side) renders nothing.
    let mut b = SceneBuilder::new(32, 32);
    b.quad(blend([1.0; 3], 0.5), fullscreen(0.0), white());
    let behind = Camera::new(
        Vec3::new(0.0, 0.0, -10.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Orthographic { height: 2.0 },
        0.5,
        100.0,
        true,
        1.0,
    );
    let scene = b.build();
    assert_eq!(
        render(&scene, &ReferenceOptions::default()).stats.fragments,
        32 * 32
    );
    let from_behind = Scene {
        camera: behind,
        ..scene
    };
    assert_eq!(
        render(&from_behind, &ReferenceOptions::default())
            .stats
            .fragments,
        0
    );
}

#[test]
fn zero_area_triangles_produce_nothing() {
    let mut b = SceneBuilder::new(32, 32);
    let line = [
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(1.0, 1.0, -1.0),
        Vec3::new(0.0, 0.0, -1.0),
    ];
    let point = [Vec3::new(0.01, 0.01, -1.0); 3];
    b.triangles(double_sided(blend([1.0; 3], 0.5)), &[line, point], white());
    let r = render(&b.build(), &ReferenceOptions::default());
    assert_eq!(r.stats.fragments, 0);
    assert_eq!(r.stats.raster_triangles, 0);
}
