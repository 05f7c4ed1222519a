//! Animated scenes in the minimum form (docs/scene-format.md, "Animation"): every field a track
//! of the keys that hold it, linear between the nearest keys, held outside them, static where
//! unkeyed; every frame validated; billboards facing their own frame's camera.

use glam::Vec3;
use oit_scene::{Frames, Projection, Scene, SceneError, parse, parse_frames};
use serde_json::{Value, json};

fn frames(v: &Value) -> Frames {
    parse_frames(&v.to_string(), "anim.json").expect("scene loads")
}

fn frame(v: &Value, t: u32) -> Scene {
    frames(v).frame(t).expect("frame flattens")
}

fn error(v: &Value) -> SceneError {
    parse_frames(&v.to_string(), "anim.json").expect_err("scene must be refused")
}

/// A quad at the origin and a camera on +Z, animated over `n` frames.
fn animated(n: u64, camera_keys: Value, object_keys: Value) -> Value {
    json!({
        "name": "anim",
        "resolution": [32, 24],
        "animation": {"frames": n, "fps": 24},
        "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "fov_y": 40, "keyframes": camera_keys},
        "objects": [{
            "mesh": {"kind": "quad"},
            "transform": {"translate": [0.5, 0, 0], "rotate": [0, 0, 10], "scale": [1, 2, 1]},
            "material": {"mode": "blend", "alpha": 0.5},
            "keyframes": object_keys
        }]
    })
}

fn lerp(a: f32, b: f32, s: f32) -> f32 {
    a + (b - a) * s
}

#[test]
fn camera_keys_interpolate_between_keys_and_hold_outside_them() {
    let v = animated(
        12,
        json!([
            {"frame": 2, "eye": [-2, 0, 5]},
            {"frame": 6, "eye": [2, 1, 5], "fov_y": 60},
            {"frame": 10, "eye": [2, 1, 9]}
        ]),
        json!([]),
    );
    let f = frames(&v);
    assert_eq!(f.count(), 12);
    assert_eq!(f.animation().map(|a| (a.frames, a.fps)), Some((12, 24.0)));
    for t in 0..12 {
        let s = f.frame(t).expect("frame");
        assert_eq!(s.frame, t);
        let eye = s.camera.eye;
        let want = match t {
            0..=2 => Vec3::new(-2.0, 0.0, 5.0),
            3..=5 => {
                let s = (t - 2) as f32 / 4.0;
                Vec3::new(lerp(-2.0, 2.0, s), lerp(0.0, 1.0, s), 5.0)
            }
            6..=9 => {
                let s = (t - 6) as f32 / 4.0;
                Vec3::new(2.0, 1.0, lerp(5.0, 9.0, s))
            }
            _ => Vec3::new(2.0, 1.0, 9.0),
        };
        assert_eq!(eye, want, "eye at frame {t}");
        // The target is never keyed: its static value holds.
        assert_eq!(s.camera.target, Vec3::ZERO);
        // fov_y has one key (frame 6): held on both sides of it, the static 40 never used.
        assert_eq!(
            s.camera.projection,
            Projection::Perspective {
                fov_y_degrees: 60.0
            },
            "frame {t}"
        );
    }
}

#[test]
fn object_tracks_are_independent_and_unkeyed_fields_stay_static() {
    let v = animated(
        9,
        json!([]),
        json!([
            {"frame": 0, "rotate": [0, 0, 0], "alpha": 1.0},
            {"frame": 4, "translate": [0, 3, 0]},
            {"frame": 8, "rotate": [0, 0, 90], "alpha": 0.0}
        ]),
    );
    let expected = |t: u32| {
        // translate: one key (frame 4), held everywhere; rotate z and alpha: 0..8 linear;
        // scale: never keyed, static [1, 2, 1].
        let s = t as f32 / 8.0;
        let alpha = lerp(1.0, 0.0, s);
        let rz = lerp(0.0, 90.0, s);
        (Vec3::new(0.0, 3.0, 0.0), rz, alpha)
    };
    for t in 0..9 {
        let s = frame(&v, t);
        let (translate, rz, alpha) = expected(t);
        assert_eq!(s.materials[0].alpha, alpha, "alpha at frame {t}");
        // The quad's corners are ±(0.5, 0.5) scaled by (1, 2), rotated about z, translated.
        let (sin, cos) = rz.to_radians().sin_cos();
        let corner = |x: f32, y: f32| {
            let (x, y) = (x, y * 2.0);
            Vec3::new(x * cos - y * sin, x * sin + y * cos, 0.0) + translate
        };
        let want = [
            corner(-0.5, -0.5),
            corner(0.5, -0.5),
            corner(0.5, 0.5),
            corner(-0.5, 0.5),
        ];
        for v in &s.vertices {
            let p = Vec3::from(v.position);
            let near = want.iter().map(|w| w.distance(p)).fold(f32::MAX, f32::min);
            assert!(
                near < 1e-5,
                "frame {t}: vertex {p} is no corner of {want:?}"
            );
        }
    }
}

#[test]
fn frame_zero_is_what_a_still_load_returns_and_still_scenes_have_one_frame() {
    let v = animated(
        5,
        json!([{"frame": 1, "eye": [1, 1, 4]}, {"frame": 4, "eye": [-1, 1, 4]}]),
        json!([{"frame": 3, "alpha": 0.25}]),
    );
    let still = parse(&v.to_string(), "anim.json").expect("loads");
    assert_eq!(still, frame(&v, 0));
    assert_eq!(still.frame, 0);
    assert_ne!(frame(&v, 0).content_hash(), frame(&v, 2).content_hash());

    let mut plain = animated(1, json!([]), json!([]));
    let obj = plain.as_object_mut().expect("object");
    obj.remove("animation");
    obj["camera"]
        .as_object_mut()
        .expect("camera")
        .remove("keyframes");
    obj["objects"][0]
        .as_object_mut()
        .expect("object")
        .remove("keyframes");
    let f = frames(&plain);
    assert_eq!((f.count(), f.animation()), (1, None));
    assert!(f.frame(1).is_err(), "a still scene has frame 0 only");
}

#[test]
fn an_orbit_circles_its_centre_once_per_turn() {
    let mut v = animated(8, json!([]), json!([]));
    v["camera"]["orbit"] = json!({"center": [0, 0.5, 0], "radius": 4, "height": 1, "turns": 1});
    for t in 0..8 {
        let s = frame(&v, t);
        let e = s.camera.eye;
        assert!(
            ((e.x * e.x + e.z * e.z).sqrt() - 4.0).abs() < 1e-5,
            "radius at {t}"
        );
        assert!((e.y - 1.5).abs() < 1e-6);
        assert_eq!(s.camera.target, Vec3::new(0.0, 0.5, 0.0));
        let angle = e.x.atan2(e.z).to_degrees().rem_euclid(360.0);
        assert!(
            (angle - 45.0 * t as f32).abs() < 1e-3,
            "frame {t} at {angle}°"
        );
    }
}

#[test]
fn billboards_face_the_camera_of_their_own_frame() {
    let v = json!({
        "name": "orbiting billboards",
        "animation": {"frames": 6, "fps": 30},
        "camera": {"eye": [0, 0, 5], "target": [0, 0, 0],
                   "orbit": {"center": [0, 0, 0], "radius": 5, "turns": 0.5}},
        "objects": [{"mesh": {"kind": "billboards", "seed": 3, "count": 5,
                     "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}},
                     "material": {"mode": "blend", "alpha": 0.5}}]
    });
    for t in 0..6 {
        let s = frame(&v, t);
        for tri in s.vertices.chunks_exact(3) {
            let p: Vec<Vec3> = tri.iter().map(|v| Vec3::from(v.position)).collect();
            let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            let to_eye = (s.camera.eye - (p[0] + p[1] + p[2]) / 3.0).normalize();
            assert!(
                normal.dot(to_eye) > 0.99,
                "frame {t}: a billboard does not face this frame's eye"
            );
        }
    }
}

#[test]
fn keys_are_validated_with_file_path_and_what_is_allowed() {
    let cases = [
        (
            animated(
                4,
                json!([{"frame": 2, "eye": [1, 0, 5]}, {"frame": 2, "eye": [0, 1, 5]}]),
                json!([]),
            ),
            "camera.keyframes[1].frame",
            "strictly increasing",
        ),
        (
            animated(4, json!([{"frame": 4, "eye": [1, 0, 5]}]), json!([])),
            "camera.keyframes[0].frame",
            "0..4",
        ),
        (
            animated(4, json!([]), json!([{"frame": 1, "alpha": 1.5}])),
            "objects[0].keyframes[0].alpha",
            "[0, 1]",
        ),
        (
            animated(4, json!([]), json!([{"frame": 1, "scale": [1, 0, 1]}])),
            "objects[0].keyframes[0].scale[1]",
            "",
        ),
        (
            animated(
                4,
                json!([{"frame": 1, "orthographic": {"height": 2}}]),
                json!([]),
            ),
            "camera.keyframes[0].orthographic",
            "",
        ),
        (
            animated(0, json!([]), json!([])),
            "animation.frames",
            "1..=10000",
        ),
        (
            {
                let mut v = animated(4, json!([]), json!([]));
                v["animation"]["fps"] = json!(0);
                v
            },
            "animation.fps",
            "frames per second > 0",
        ),
        (
            animated(
                4,
                json!([{"frame": 0, "eye": [0, 0, 5]}, {"frame": 2, "eye": [0, 0, -5]}]),
                json!([]),
            ),
            "(at frame 1, from the keyframes)",
            "",
        ),
        (
            animated(
                4,
                json!([{"frame": 1, "eye": [0, 0, 5], "zoom": 2}]),
                json!([]),
            ),
            "camera.keyframes[0].zoom",
            "",
        ),
    ];
    for (v, path, allowed) in cases {
        let e = error(&v).to_string();
        assert!(e.starts_with("anim.json: "), "{e}");
        assert!(e.contains(path), "`{e}` should name {path}");
        assert!(e.contains(allowed), "`{e}` should say {allowed}");
        assert!(!e.contains('\n'));
    }
    let mut without = animated(4, json!([{"frame": 1, "eye": [1, 0, 5]}]), json!([]));
    without.as_object_mut().expect("object").remove("animation");
    let e = error(&without).to_string();
    assert!(
        e.contains("camera.keyframes") && e.contains("\"animation\""),
        "{e}"
    );
    let past = frames(&animated(3, json!([]), json!([])))
        .frame(3)
        .expect_err("frame 3 of 3");
    assert!(past.to_string().contains("0..3"), "{past}");
}
