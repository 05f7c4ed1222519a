//! What the loader generates: defaults, ramps, instancing, lighting, billboards, winding, bounds.

mod common;

use common::{
    centroid, geometric_normal, load_ok, minimal, scene_with, signed_area, triangles, with,
};
use glam::Vec3;
use oit_scene::{AlphaMode, Projection, Resolution};
use serde_json::json;

#[test]
fn defaults_are_applied() {
    let s = load_ok(&scene_with(json!([{"mesh": {"kind": "quad"}}])));
    assert_eq!(
        s.resolution,
        Resolution {
            width: 256,
            height: 256
        }
    );
    assert!(s.camera.reverse_z);
    assert_eq!(
        s.camera.projection,
        Projection::Perspective {
            fov_y_degrees: 45.0
        }
    );
    assert_eq!((s.camera.near, s.camera.far), (0.1, 100.0));
    assert_eq!(s.camera.up, Vec3::Y);
    assert_eq!(s.background, [0.0; 3]);
    assert_eq!(s.description, "");
    let m = s.materials[0];
    assert_eq!(m.base_color, [1.0; 3]);
    assert_eq!(m.alpha, 1.0);
    assert_eq!(m.mode, AlphaMode::Opaque);
    assert_eq!(m.cutoff, 0.5);
    assert!(!m.double_sided && !m.premultiplied);
    assert_eq!(m.intensity, 1.0);
    let d = &s.draws[0];
    assert_eq!(
        (d.id, d.name.as_str(), d.ordering.group, d.ordering.order),
        (0, "objects[0]", 0, 0)
    );
    assert_eq!(d.vertex_count, 6);
    // Unlit: vertex colours are white, alpha 1; the default quad is 1×1 in the XY plane.
    for v in &s.vertices {
        assert_eq!(v.color, [1.0; 4]);
        assert_eq!(v.position[0].abs(), 0.5);
        assert_eq!(v.position[1].abs(), 0.5);
        assert_eq!(v.position[2], 0.0);
    }
    // reverse_z: near maps to depth 1.
    let c = s.camera.clip(Vec3::new(0.0, 0.0, 5.0 - 0.1));
    assert!((c.z / c.w - 1.0).abs() < 1e-5, "{c}");
}

#[test]
fn explicit_fields_are_kept() {
    let v = scene_with(json!([{
        "mesh": {"kind": "quad"},
        "material": {"base_color": [0.5, 2, 0], "alpha": 0.25, "mode": "mask-blend", "cutoff": 0.1,
                     "double_sided": true, "premultiplied": true, "intensity": 30},
        "render_group": 3, "alpha_index": -7
    }]));
    let v = with(v, "/reverse_z", json!(false));
    let v = with(v, "/background", json!([0.1, 0.2, 0.3]));
    let v = with(v, "/resolution", json!([320, 200]));
    let s = load_ok(&v);
    let m = s.materials[0];
    assert_eq!(m.base_color, [0.5, 2.0, 0.0]);
    assert_eq!(
        (m.alpha, m.mode, m.cutoff, m.intensity),
        (0.25, AlphaMode::MaskBlend, 0.1, 30.0)
    );
    assert!(m.double_sided && m.premultiplied);
    assert_eq!(
        (s.draws[0].ordering.group, s.draws[0].ordering.order),
        (3, -7)
    );
    assert!(!s.camera.reverse_z);
    assert_eq!(s.background, [0.1, 0.2, 0.3]);
    assert_eq!(
        s.resolution,
        Resolution {
            width: 320,
            height: 200
        }
    );
    // Standard Z: near maps to 0.
    let c = s.camera.clip(Vec3::new(0.0, 0.0, 5.0 - 0.1));
    assert!((c.z / c.w).abs() < 1e-5, "{c}");
}

#[test]
fn orthographic_view_height() {
    let v = with(minimal(), "/camera/orthographic", json!({"height": 4}));
    let s = load_ok(&v);
    assert_eq!(
        s.camera.projection,
        Projection::Orthographic { height: 4.0 }
    );
    // Half the view height is at the top edge of the screen, at any depth.
    for z in [-3.0, 0.0, 2.0] {
        let c = s.camera.clip(Vec3::new(0.0, 2.0, z));
        assert!((c.y / c.w - 1.0).abs() < 1e-6, "{c}");
    }
}

#[test]
fn layers_ramp_colour_and_alpha_one_draw_per_layer() {
    let v = scene_with(json!([{"mesh": {"kind": "quad"}}, {
        "mesh": {"kind": "layers", "count": 5, "spacing": 0.25, "size": [2, 3],
                 "color_from": [1, 0, 0.5], "color_to": [0, 1, 0.5], "alpha_from": 0.2, "alpha_to": 0.6},
        "transform": {"translate": [0, 0, 1]},
        "material": {"mode": "blend"}
    }]));
    let s = load_ok(&v);
    assert_eq!(s.draws.len(), 6);
    for i in 0..5 {
        let d = &s.draws[1 + i];
        assert_eq!(d.id as usize, 1 + i);
        assert_eq!(d.name, format!("objects[1].layers[{i}]"));
        assert_eq!(d.vertex_count, 6);
        assert_eq!(d.material, 1);
        let t = i as f32 / 4.0;
        let want = [1.0 - t, t, 0.5, 0.2 + 0.4 * t];
        for v in &s.vertices[d.vertex_range()] {
            for k in 0..4 {
                assert!(
                    (v.color[k] - want[k]).abs() < 1e-6,
                    "layer {i}: {:?} vs {want:?}",
                    v.color
                );
            }
            // Layer 0 nearest the camera (z = 1), then 0.25 further back each.
            assert!((v.position[2] - (1.0 - 0.25 * i as f32)).abs() < 1e-6);
            assert_eq!(v.position[0].abs(), 1.0);
            assert_eq!(v.position[1].abs(), 1.5);
        }
    }
    // A single layer takes the `from` end of the ramps.
    let v = with(v, "/objects/1/mesh/count", json!(1));
    let s = load_ok(&v);
    assert_eq!(
        s.vertices[s.draws[1].vertex_range()][0].color,
        [1.0, 0.0, 0.5, 0.2]
    );
}

#[test]
fn instancing_expands_to_named_draws_on_a_grid() {
    let v = scene_with(json!([
        {"mesh": {"kind": "quad"}},
        {"mesh": {"kind": "box", "size": [0.5, 0.5, 0.5]}, "transform": {"translate": [-1, -1, 0]},
         "instances": {"counts": [3, 2, 2], "spacing": [1, 2, -0.5]}},
        {"mesh": {"kind": "quad"}}
    ]));
    let s = load_ok(&v);
    assert_eq!(s.draws.len(), 1 + 12 + 1);
    for k in 0..12 {
        let d = &s.draws[1 + k];
        assert_eq!(d.id as usize, 1 + k);
        assert_eq!(d.name, format!("objects[1].instances[{k}]"));
        assert_eq!(d.triangle_count(), 12);
        let (ix, iy, iz) = (k % 3, (k / 3) % 2, k / 6);
        let want = Vec3::new(-1.0 + ix as f32, -1.0 + 2.0 * iy as f32, -0.5 * iz as f32);
        assert!(
            (d.bounds_center - want).length() < 1e-6,
            "instance {k}: {} vs {want}",
            d.bounds_center
        );
        assert!((d.bounds_radius - 0.75f32.sqrt() * 0.5).abs() < 1e-6);
    }
    assert_eq!(s.draws[13].name, "objects[2]");
    assert_eq!(s.draws[13].id, 13);
    assert_eq!(s.triangle_count(), 2 + 12 * 12 + 2);

    // Instanced layers name both levels.
    let v = scene_with(json!([{"mesh": {"kind": "layers", "count": 2},
                               "instances": {"counts": [2, 1, 1], "spacing": [3, 0, 0]}}]));
    let names: Vec<_> = load_ok(&v).draws.iter().map(|d| d.name.clone()).collect();
    assert_eq!(
        names,
        [
            "objects[0].instances[0].layers[0]",
            "objects[0].instances[0].layers[1]",
            "objects[0].instances[1].layers[0]",
            "objects[0].instances[1].layers[1]"
        ]
    );
}

#[test]
fn transform_order_is_scale_then_x_y_z_rotation_then_translation() {
    // Rotating about X first takes the +z normal to -y; Y then leaves it there. (Y first would
    // give +x.)
    let v = scene_with(json!([{"mesh": {"kind": "quad"}, "transform": {"rotate": [90, 90, 0]}}]));
    let s = load_ok(&v);
    for tri in triangles(&s, 0) {
        let n = geometric_normal(tri);
        assert!((n - Vec3::NEG_Y).length() < 1e-5, "{n}");
    }
    let v = scene_with(json!([{"mesh": {"kind": "quad", "size": [2, 2]},
                               "transform": {"scale": [2, 1, 1], "rotate": [0, 0, 90], "translate": [1, 0, 0]}}]));
    let s = load_ok(&v);
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for v in &s.vertices {
        lo = lo.min(Vec3::from(v.position));
        hi = hi.max(Vec3::from(v.position));
    }
    // Scaled to 4×2 along x, turned 90° about z (x → y), moved by +1 in x.
    assert!((lo - Vec3::new(0.0, -2.0, 0.0)).length() < 1e-5, "{lo}");
    assert!((hi - Vec3::new(2.0, 2.0, 0.0)).length() < 1e-5, "{hi}");
}

#[test]
fn directional_light_is_baked_into_vertex_colours() {
    let quad = json!([{"mesh": {"kind": "quad"}, "material": {"base_color": [0.5, 0.5, 0.5]}}]);
    let lit = |direction: serde_json::Value| {
        let v = with(
            scene_with(quad.clone()),
            "/lighting",
            json!({"directional": {"direction": direction, "color": [0.8, 0.6, 0.4], "ambient": [0.1, 0.2, 0.3]}}),
        );
        load_ok(&v).vertices[0].color
    };
    // Light travelling straight into the quad (towards -z): ambient + colour · 1.
    let c = lit(json!([0, 0, -2]));
    for (k, want) in [0.9, 0.8, 0.7, 1.0].into_iter().enumerate() {
        assert!((c[k] - want).abs() < 1e-6, "{c:?}");
    }
    // At 60° from the normal: ambient + colour · cos 60°.
    let a = 60f32.to_radians();
    let c = lit(json!([0, -a.sin(), -a.cos()]));
    for (k, want) in [0.5, 0.5, 0.5].into_iter().enumerate() {
        assert!((c[k] - want).abs() < 1e-6, "{c:?}");
    }
    // From behind: ambient only. The material colour is never baked in.
    let c = lit(json!([0, 0, 1]));
    assert_eq!(c, [0.1, 0.2, 0.3, 1.0]);
}

#[test]
fn lighting_uses_outward_normals_of_closed_meshes() {
    // Light from +y: the top of a sphere is lit fully, the bottom gets ambient only.
    let v = scene_with(
        json!([{"mesh": {"kind": "uv-sphere", "radius": 1, "segments": 16, "rings": 8}}]),
    );
    let v = with(
        v,
        "/lighting",
        json!({"directional": {"direction": [0, -1, 0], "color": [1, 1, 1], "ambient": [0, 0, 0]}}),
    );
    let s = load_ok(&v);
    for v in &s.vertices {
        let y = v.position[1];
        assert!(
            (v.color[0] - y.max(0.0)).abs() < 1e-5,
            "y {y}: {:?}",
            v.color
        );
    }
}

/// One of every mesh kind with an outside, seen from a diagonal so both front and back faces
/// are visible. For each triangle, facing the eye (outward normal · (eye - centroid) > 0) must
/// mean counter-clockwise (positive area) after projection, and facing away clockwise.
#[test]
fn every_mesh_kind_is_counter_clockwise_seen_from_outside() {
    let meshes = [
        json!({"kind": "box", "size": [1, 0.7, 1.3]}),
        json!({"kind": "uv-sphere", "radius": 0.8, "segments": 12, "rings": 7}),
        json!({"kind": "torus", "major_radius": 0.8, "minor_radius": 0.3, "segments": 16, "tube_segments": 9}),
        json!({"kind": "cylinder", "radius": 0.6, "height": 1.2, "segments": 10}),
        json!({"kind": "cylinder", "radius": 0.6, "height": 1.2, "segments": 10, "capped": false}),
        json!({"kind": "quad", "size": [1, 2]}),
        json!({"kind": "layers", "count": 3, "spacing": 0.3}),
    ];
    for eye in [[2.0, 3.0, 6.0], [-4.0, -2.0, 3.0], [0.5, -5.0, -3.0]] {
        for mesh in &meshes {
            let v = scene_with(json!([{"mesh": mesh}]));
            let v = with(v, "/camera/eye", json!(eye));
            let s = load_ok(&v);
            let eye = Vec3::from(eye);
            let (mut front, mut back) = (0, 0);
            for d in 0..s.draws.len() {
                for tri in triangles(&s, d) {
                    let c = centroid(tri);
                    let outward = match mesh["kind"].as_str().unwrap() {
                        "quad" | "layers" => Vec3::Z,
                        // The face whose plane the centroid lies in.
                        "box" => {
                            let r = c / Vec3::new(0.5, 0.35, 0.65);
                            let k = (0..3)
                                .max_by(|&a, &b| r[a].abs().total_cmp(&r[b].abs()))
                                .unwrap();
                            Vec3::AXES[k] * r[k].signum()
                        }
                        "torus" => c - Vec3::new(c.x, 0.0, c.z).normalize() * 0.8,
                        "cylinder" if c.y.abs() > 0.59 => Vec3::new(0.0, c.y, 0.0),
                        "cylinder" => Vec3::new(c.x, 0.0, c.z),
                        _ => c,
                    };
                    // The face's own plane, oriented outwards whatever its winding, decides
                    // whether the eye sees its outside; the winding must then agree.
                    let n = geometric_normal(tri);
                    let n_out = if n.dot(outward) >= 0.0 { n } else { -n };
                    let facing = n_out.dot((eye - c).normalize());
                    if facing.abs() < 1e-3 {
                        continue; // edge-on: the sign is not meaningful
                    }
                    let area = signed_area(&s, tri);
                    assert!(
                        (facing > 0.0) == (area > 0.0),
                        "{mesh} from {eye}: facing {facing} but area {area}"
                    );
                    // The stored winding also agrees with the outward direction in 3D.
                    assert!(n.dot(outward) > 0.0, "{mesh}: inward triangle");
                    if facing > 0.0 { front += 1 } else { back += 1 }
                }
            }
            if !matches!(mesh["kind"].as_str(), Some("quad" | "layers")) {
                assert!(
                    front > 0 && back > 0,
                    "{mesh}: saw {front} front and {back} back faces"
                );
            }
        }
    }
}

#[test]
fn closed_meshes_have_the_expected_triangle_counts() {
    let cases = [
        (json!({"kind": "box"}), 12),
        (
            json!({"kind": "uv-sphere", "segments": 12, "rings": 7}),
            2 * 12 * 6,
        ),
        (
            json!({"kind": "torus", "segments": 16, "tube_segments": 9}),
            2 * 16 * 9,
        ),
        (json!({"kind": "cylinder", "segments": 10}), 4 * 10),
        (
            json!({"kind": "cylinder", "segments": 10, "capped": false}),
            2 * 10,
        ),
    ];
    for (mesh, want) in cases {
        let s = load_ok(&scene_with(json!([{"mesh": mesh}])));
        assert_eq!(s.triangle_count(), want, "{mesh}");
    }
}

#[test]
fn uv_sphere_vertices_lie_on_the_sphere_and_bounds_enclose_it() {
    let v = scene_with(
        json!([{"mesh": {"kind": "uv-sphere", "radius": 0.7, "segments": 20, "rings": 10},
                               "transform": {"translate": [0.3, -0.2, 0.1]}}]),
    );
    let s = load_ok(&v);
    let centre = Vec3::new(0.3, -0.2, 0.1);
    for v in &s.vertices {
        assert!((Vec3::from(v.position).distance(centre) - 0.7).abs() < 1e-5);
    }
    let d = &s.draws[0];
    assert!(
        (d.bounds_center - centre).length() < 1e-5,
        "{}",
        d.bounds_center
    );
    assert!((d.bounds_radius - 0.7).abs() < 1e-5, "{}", d.bounds_radius);
}

#[test]
fn bounds_enclose_every_vertex_of_every_draw() {
    for (_, s) in oit_scene::load_dir(&common_scenes_dir()).unwrap() {
        for d in &s.draws {
            for v in &s.vertices[d.vertex_range()] {
                let dist = Vec3::from(v.position).distance(d.bounds_center);
                assert!(
                    dist <= d.bounds_radius * (1.0 + 1e-6),
                    "{}: {}",
                    s.name,
                    d.name
                );
            }
        }
    }
}

fn common_scenes_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

fn billboard_scene(eye: [f32; 3], ortho: bool) -> oit_scene::Scene {
    let v = scene_with(json!([{
        "mesh": {"kind": "billboards", "seed": 42, "count": 200, "size": 0.1,
                 "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]},
                 "color_min": [0.1, 0.2, 0.3], "color_max": [0.4, 0.5, 0.6], "alpha_min": 0.25, "alpha_max": 0.75},
        "transform": {"translate": [0.2, 0, -0.5], "rotate": [10, 20, 30]},
        "material": {"mode": "blend"}
    }]));
    let v = with(v, "/camera/eye", json!(eye));
    let v = if ortho {
        with(v, "/camera/orthographic", json!({"height": 4}))
    } else {
        v
    };
    load_ok(&v)
}

#[test]
fn billboards_face_the_camera_and_are_front_facing() {
    for (eye, ortho) in [
        ([0.0, 0.0, 5.0], false),
        ([3.0, 2.5, 3.0], false),
        ([0.0, 4.0, 0.1], false),
        ([1.0, 1.0, 4.0], true),
    ] {
        let s = billboard_scene(eye, ortho);
        assert_eq!(s.triangle_count(), 400);
        let eye = Vec3::from(eye);
        let view_dir = (eye - s.camera.target).normalize();
        for quad in s.vertices.chunks_exact(6) {
            let tris = [
                [quad[0].position, quad[1].position, quad[2].position],
                [quad[3].position, quad[4].position, quad[5].position],
            ];
            let centre = (centroid(tris[0]) + centroid(tris[1])) * 0.5;
            let towards = if ortho {
                view_dir
            } else {
                (eye - centre).normalize()
            };
            for tri in tris {
                let n = geometric_normal(tri);
                assert!(
                    n.dot(towards) > 0.9999,
                    "billboard does not face the camera: {n} vs {towards}"
                );
                assert!(
                    signed_area(&s, tri) > 0.0,
                    "billboard is back-facing after projection"
                );
            }
            // Square of side `size`.
            let edge = Vec3::from(quad[1].position).distance(Vec3::from(quad[0].position));
            assert!((edge - 0.1).abs() < 1e-5, "{edge}");
            // One flat colour per billboard, inside the ranges.
            let c = quad[0].color;
            assert!(quad.iter().all(|v| v.color == c));
            assert!(
                (0.1..=0.4).contains(&c[0])
                    && (0.2..=0.5).contains(&c[1])
                    && (0.3..=0.6).contains(&c[2])
            );
            assert!((0.25..=0.75).contains(&c[3]));
        }
    }
}

#[test]
fn scatter_meshes_are_deterministic_per_seed() {
    let soup = |seed: u64| {
        let v = scene_with(json!([{
            "mesh": {"kind": "soup", "seed": seed, "count": 300, "size": 0.2,
                     "bounds": {"min": [-1, -2, -0.5], "max": [1, 2, 0.5]}, "alpha_min": 0.3, "alpha_max": 0.3}
        }]));
        load_ok(&v)
    };
    let (a, b, c) = (soup(9), soup(9), soup(10));
    assert_eq!(a.vertices, b.vertices);
    assert_ne!(a.vertices, c.vertices);
    assert_eq!(a.triangle_count(), 300);
    for tri in triangles(&a, 0) {
        let centre = centroid(tri);
        // Equilateral with circumradius 0.2, centred inside the bounds.
        for p in tri {
            assert!((Vec3::from(p).distance(centre) - 0.2).abs() < 1e-4);
        }
        assert!(
            centre.abs().cmple(Vec3::new(1.0, 2.0, 0.5) + 1e-5).all(),
            "{centre}"
        );
    }
    assert!(a.vertices.iter().all(|v| v.color[3] == 0.3));
    // Random orientations: roughly half the soup faces the camera.
    let front = triangles(&a, 0)
        .into_iter()
        .filter(|t| signed_area(&a, *t) > 0.0)
        .count();
    assert!((100..200).contains(&front), "{front} of 300 front-facing");
    assert_eq!(
        billboard_scene([0.0, 0.0, 5.0], false).vertices,
        billboard_scene([0.0, 0.0, 5.0], false).vertices
    );
}

#[test]
fn corner_alpha_is_per_vertex() {
    let v = scene_with(
        json!([{"mesh": {"kind": "quad", "corner_alpha": [0.1, 0.2, 0.3, 0.4]},
                               "material": {"mode": "mask"}}]),
    );
    let s = load_ok(&v);
    for v in &s.vertices {
        let want = match (v.position[0] > 0.0, v.position[1] > 0.0) {
            (false, false) => 0.1,
            (true, false) => 0.2,
            (true, true) => 0.3,
            (false, true) => 0.4,
        };
        assert_eq!(v.color[3], want);
    }
}

#[test]
fn reversed_draw_order_keeps_ids_and_names() {
    let s = oit_scene::load(&common_scenes_dir().join("many-layers-64.json")).unwrap();
    let r = s.with_reversed_draw_order();
    let n = s.draws.len();
    assert_eq!(n, 64);
    for i in 0..n {
        assert_eq!(r.draws[i].id, s.draws[n - 1 - i].id);
        assert_eq!(r.draws[i].name, s.draws[n - 1 - i].name);
        assert_eq!(r.draws[i].vertex_range(), s.draws[n - 1 - i].vertex_range());
    }
    assert_eq!(r.vertices, s.vertices);
    assert_eq!(r.with_reversed_draw_order(), s);
}

/// The order-dependence probe reverses the triangles inside each draw too (`particles` is one
/// draw of 24 000 triangles), keeping every triangle's vertices and winding, and is its own
/// inverse.
#[test]
fn reversed_order_reverses_triangles_within_draws_and_keeps_winding() {
    let s = oit_scene::load(&common_scenes_dir().join("particles.json")).unwrap();
    let r = s.with_reversed_order();
    assert_eq!(r.with_reversed_order(), s);
    for (i, draw) in s.draws.iter().enumerate() {
        let back = &r.draws[s.draws.len() - 1 - i];
        assert_eq!(back.id, draw.id);
        assert_eq!(back.vertex_range(), draw.vertex_range());
        let ours = &s.vertices[draw.vertex_range()];
        let theirs = &r.vertices[draw.vertex_range()];
        let n = ours.len() / 3;
        assert!(n > 1000, "{} has {n} triangles", draw.name);
        for t in 0..n {
            assert_eq!(
                ours[3 * t..3 * t + 3],
                theirs[3 * (n - 1 - t)..3 * (n - 1 - t) + 3],
                "triangle {t} of {} moved to {}, vertices in order",
                draw.name,
                n - 1 - t
            );
        }
    }
    assert_ne!(r.vertices, s.vertices, "a real reordering");
}

/// On generated content (soups, billboards, crossing planes, mask cards): the reversed scene is
/// the same triangles with their winding, each draw's in reverse, draws in reverse, and
/// reversing twice gives the scene back.
#[test]
fn reversed_order_on_random_scenes_is_an_involution_that_keeps_every_triangle() {
    for seed in 0..12u64 {
        let (text, about) = oit_scene::random::random_scene_json(seed);
        let s = oit_scene::parse(&text, &format!("random-{seed}")).unwrap();
        let r = s.with_reversed_order();
        assert_eq!(r.with_reversed_order(), s, "{about:?}");
        let ids: Vec<u32> = r.draws.iter().rev().map(|d| d.id).collect();
        assert_eq!(ids, s.draws.iter().map(|d| d.id).collect::<Vec<_>>());
        let mut reordered = false;
        for draw in &s.draws {
            let ours: Vec<_> = s.vertices[draw.vertex_range()].chunks(3).collect();
            let theirs: Vec<_> = r.vertices[draw.vertex_range()].chunks(3).rev().collect();
            assert_eq!(ours, theirs, "{} of {about:?}", draw.name);
            reordered |= ours.len() > 1 && ours.first() != ours.last();
        }
        if reordered {
            assert_ne!(r.vertices, s.vertices, "{about:?}");
        }
    }
}

#[test]
fn ids_are_draw_indices_in_file_order() {
    for (_, s) in oit_scene::load_dir(&common_scenes_dir()).unwrap() {
        let mut next = 0;
        for (i, d) in s.draws.iter().enumerate() {
            assert_eq!(d.id as usize, i, "{}", s.name);
            assert_eq!(d.first_vertex, next, "{}: draws are contiguous", s.name);
            assert_eq!(d.vertex_count % 3, 0);
            next += d.vertex_count;
        }
        assert_eq!(next as usize, s.vertices.len());
    }
}

/// Soup and billboard normals (used only for lighting) agree with their winding: baking a light
/// with no ambient gives exactly max(0, n · to_light) for the geometric normal of each triangle.
#[test]
fn scatter_normals_match_their_counter_clockwise_winding() {
    for kind in ["soup", "billboards"] {
        let v = scene_with(json!([{
            "mesh": {"kind": kind, "seed": 5, "count": 200, "size": 0.2,
                     "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]},
                     "color_min": [1, 1, 1], "color_max": [1, 1, 1]},
            "transform": {"rotate": [20, 40, 0], "scale": [1, 2, 0.5]}
        }]));
        let v = with(
            v,
            "/lighting",
            json!({"directional": {"direction": [0.3, -0.2, -1], "color": [1, 1, 1]}}),
        );
        let s = load_ok(&v);
        let to_light = -Vec3::new(0.3, -0.2, -1.0).normalize();
        let mut lit = 0;
        for (t, tri) in triangles(&s, 0).into_iter().enumerate() {
            let want = geometric_normal(tri).dot(to_light).max(0.0);
            lit += usize::from(want > 0.0);
            for v in &s.vertices[3 * t..3 * t + 3] {
                assert!(
                    (v.color[0] - want).abs() < 1e-4,
                    "{kind} triangle {t}: {} vs {want}",
                    v.color[0]
                );
            }
        }
        assert!(lit > 20, "{kind}: only {lit} lit triangles");
    }
}

/// Two transparent layers at view distances 6 and 8 (and an opaque one at 9 that must not
/// count): the interval is theirs, window depths invert to them, and an interval with no
/// transparent geometry is the frustum.
#[test]
fn transparent_view_depth_interval_and_view_distance() {
    for (ortho, reverse_z) in [(false, true), (false, false), (true, true)] {
        let projection = if ortho {
            r#""orthographic": {"height": 2}"#
        } else {
            r#""fov_y": 60"#
        };
        let layer = |z: f64, mode: &str| {
            format!(
                r#"{{"mesh": {{"kind": "layers", "count": 1, "spacing": 0.1, "size": [1, 1],
                    "color_from": [1, 1, 1], "color_to": [1, 1, 1], "alpha_from": 0.5, "alpha_to": 0.5}},
                  "transform": {{"translate": [0, 0, {z}]}}, "material": {{"mode": "{mode}"}}}}"#
            )
        };
        let json = format!(
            r#"{{"name": "interval", "resolution": [8, 8],
                "camera": {{"eye": [0, 0, 10], "target": [0, 0, 0], {projection},
                            "near": 0.5, "far": 30}}, "reverse_z": {reverse_z},
                "objects": [{}, {}, {}]}}"#,
            layer(4.0, "blend"),
            layer(2.0, "blend"),
            layer(1.0, "opaque")
        );
        let scene = oit_scene::parse(&json, "interval").unwrap_or_else(|e| panic!("{e}"));
        let (lo, hi) = scene.transparent_view_depth_interval(1e-6);
        assert!(
            (lo - 6.0).abs() < 1e-4 && (hi - 8.0).abs() < 1e-4,
            "{lo} {hi}"
        );
        let cam = &scene.camera;
        for d in [0.5f32, 6.0, 8.0, 29.0] {
            let clip = cam.proj * glam::Vec4::new(0.0, 0.0, -d, 1.0);
            let back = cam.view_distance(clip.z / clip.w);
            assert!(
                (back - d).abs() <= 1e-4 * d,
                "{d} -> {back} (ortho {ortho}, reverse {reverse_z})"
            );
        }
        let mut opaque_only = scene.clone();
        opaque_only
            .draws
            .retain(|d| !scene.material_of(d).mode.is_transparent());
        assert_eq!(
            opaque_only.transparent_view_depth_interval(1e-6),
            (0.5, 30.0)
        );
    }
}
