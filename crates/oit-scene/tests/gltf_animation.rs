//! glTF node animations (docs/scene-format.md, "glTF animations"): small assets built here
//! with base64 buffers, one rule each — LINEAR, STEP, slerp, CUBICSPLINE, holding outside the
//! keys, the animated camera — and the errors, each at its JSON pointer.

use std::path::PathBuf;

use glam::Vec3;
use oit_scene::{Frames, GLTF_FPS, LoadOptions, Problem, SceneError};
use serde_json::{Value, json};

mod common;
use common::build::{Data, TRI};

/// A scratch directory unique to this test process and `tag`, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("oit-gltf-anim-{}-{tag}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
    fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Data whose accessor 0 is the positions of [`TRI`] (vertex 0 at the node's origin).
fn data() -> Data {
    let mut d = Data::default();
    d.f32s(&TRI, "VEC3");
    d
}

/// A sampler over new accessors: `times` (SCALAR) and `values` of type `ty`.
fn sampler(d: &mut Data, times: &[f32], values: &[f32], ty: &str, interpolation: &str) -> Value {
    let input = d.f32s(times, "SCALAR");
    let output = d.f32s(values, ty);
    json!({"input": input, "output": output, "interpolation": interpolation})
}

/// A document with mesh 0 (the triangle), `nodes` (all roots of scene 0) and `animations`.
fn document(d: &Data, nodes: Value, animations: Value) -> String {
    let roots: Vec<usize> = (0..nodes.as_array().map_or(0, Vec::len)).collect();
    d.gltf(json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": nodes,
        "scenes": [{"nodes": roots}],
        "animations": animations,
    }))
}

/// One animation of node 0's `path` with one sampler.
fn one_channel(path: &str, s: Value) -> Value {
    json!([{"channels": [{"sampler": 0, "target": {"node": 0, "path": path}}], "samplers": [s]}])
}

fn load(tag: &str, text: &str) -> Result<Frames, SceneError> {
    let dir = Scratch::new(tag);
    let path = dir.write("anim.gltf", text);
    oit_scene::load_frames(&path, &LoadOptions::default()).map(|(f, _)| f)
}

fn frames(tag: &str, text: &str) -> Frames {
    load(tag, text).unwrap_or_else(|e| panic!("{tag}: {e}"))
}

/// Position of vertex `k` of draw 0 at frame `t`.
fn vertex(f: &Frames, t: u32, k: usize) -> Vec3 {
    let s = f.frame(t).unwrap();
    Vec3::from(s.vertices[s.draws[0].vertex_range()][k].position)
}

/// The error of loading `text`, which must be one line naming the file, `pointer` and what is
/// allowed.
fn error_at(tag: &str, text: &str, pointer: &str) -> Problem {
    let e = match load(tag, text) {
        Ok(_) => panic!("{tag}: expected an error at {pointer}, loaded fine"),
        Err(e) => e,
    };
    let line = e.to_string();
    assert!(!line.contains('\n'), "{line}");
    assert!(e.file().ends_with("anim.gltf"), "{line}");
    assert!(line.contains("; allowed: "), "{line}");
    assert_eq!(e.path(), Some(pointer), "{line}");
    e.problem().unwrap().clone()
}

/// `a + (b − a)·s` as the loader computes it: in f64 from the f32 keys, rounded once.
fn lerp(a: f32, b: f32, s: f64) -> f32 {
    (f64::from(a) + (f64::from(b) - f64::from(a)) * s) as f32
}

#[test]
fn linear_translation_is_the_lerp_of_its_keys() {
    let mut d = data();
    let s = sampler(
        &mut d,
        &[0.0, 1.0],
        &[0.0, 0.0, 0.0, 2.0, -1.0, 0.5],
        "VEC3",
        "LINEAR",
    );
    let f = frames(
        "linear",
        &document(&d, json!([{"mesh": 0}]), one_channel("translation", s)),
    );
    // frames = round(1 s × 30) + 1.
    assert_eq!(GLTF_FPS, 30.0);
    let a = f.animation().expect("animated");
    assert_eq!((a.frames, a.fps, f.count()), (31, 30.0, 31));
    // Mid-key: exactly halfway.
    assert_eq!(vertex(&f, 15, 0), Vec3::new(1.0, -0.5, 0.25));
    for t in [0, 1, 7, 22, 30] {
        let s = f64::from(t) / 30.0;
        let want = Vec3::new(lerp(0.0, 2.0, s), lerp(0.0, -1.0, s), lerp(0.0, 0.5, s));
        assert_eq!(vertex(&f, t, 0), want, "frame {t}");
    }
    let scene = f.frame(12).unwrap();
    assert_eq!(scene.frame, 12);
    assert_eq!(scene.animation, Some(a));
    assert!(scene.ignored.is_empty(), "{:?}", scene.ignored);
    assert!(
        scene.description.contains("/animations/0"),
        "{}",
        scene.description
    );
    assert!(f.frame(31).is_err(), "frame past the end");
}

#[test]
fn a_node_keeps_the_static_properties_its_channels_do_not_animate() {
    let mut d = data();
    let s = sampler(
        &mut d,
        &[0.0, 1.0],
        &[0.0, 0.0, 0.0, 4.0, 0.0, 0.0],
        "VEC3",
        "LINEAR",
    );
    let nodes = json!([{"mesh": 0, "scale": [2, 2, 2], "translation": [9, 9, 9]}, {"mesh": 0, "translation": [0, 3, 0]}]);
    let f = frames(
        "static-trs",
        &document(&d, nodes, one_channel("translation", s)),
    );
    // Node 0: scale 2 kept, translation animated (its static [9, 9, 9] replaced).
    assert_eq!(vertex(&f, 15, 1), Vec3::new(2.0 + 2.0, 0.0, 0.0));
    // Node 1: not animated, at its static translation on every frame.
    for t in [0, 15, 30] {
        let s = f.frame(t).unwrap();
        let p = s.vertices[s.draws[1].vertex_range()][0].position;
        assert_eq!(p, [0.0, 3.0, 0.0], "frame {t}");
    }
}

#[test]
fn step_holds_each_key_until_the_next() {
    let mut d = data();
    let s = sampler(
        &mut d,
        &[0.0, 0.5, 1.0],
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 3.0, 0.0, 0.0],
        "VEC3",
        "STEP",
    );
    let f = frames(
        "step",
        &document(&d, json!([{"mesh": 0}]), one_channel("translation", s)),
    );
    for t in 0..31 {
        let want = match t {
            0..=14 => 0.0,
            15..=29 => 1.0,
            _ => 3.0,
        };
        assert_eq!(vertex(&f, t, 0).x, want, "frame {t}");
    }
}

/// The angle about +Y that takes +X to `v` (degrees, counter-clockwise seen from +Y).
fn yaw_degrees(v: Vec3) -> f32 {
    (-v.z).atan2(v.x).to_degrees()
}

#[test]
fn rotation_is_slerped_along_the_shorter_arc() {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    // Identity to 90° about +Y; the second key also as its negation (the same rotation).
    for (tag, end) in [
        ("slerp", [0.0, h, 0.0, h]),
        ("slerp-neg", [0.0, -h, 0.0, -h]),
    ] {
        let mut d = data();
        let mut values = vec![0.0, 0.0, 0.0, 1.0];
        values.extend(end);
        let s = sampler(&mut d, &[0.0, 1.0], &values, "VEC4", "LINEAR");
        let f = frames(
            tag,
            &document(&d, json!([{"mesh": 0}]), one_channel("rotation", s)),
        );
        // Vertex 1 is (1, 0, 0): its yaw is the rotation angle.
        let mid = yaw_degrees(vertex(&f, 15, 1));
        assert!((mid - 45.0).abs() < 1e-4, "{tag}: {mid}° at the midpoint");
        // Slerp turns at a constant rate: 8/30 of 90° at frame 8 (normalised lerp: 22.4°).
        let early = yaw_degrees(vertex(&f, 8, 1));
        assert!((early - 24.0).abs() < 1e-4, "{tag}: {early}° at frame 8");
        assert!((yaw_degrees(vertex(&f, 30, 1)) - 90.0).abs() < 1e-4);
    }
}

#[test]
fn rotation_reads_normalized_short_quaternions() {
    let mut d = data();
    let input = d.f32s(&[0.0, 1.0], "SCALAR");
    // 23170 / 32767 ≈ √½: 90° about +Y at the second key.
    let output = d.add(
        &[0i16, 0, 0, 32767, 0, 23170, 0, 23170]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect::<Vec<u8>>(),
        5122,
        "VEC4",
        2,
        true,
    );
    let s = json!({"input": input, "output": output});
    let f = frames(
        "short",
        &document(&d, json!([{"mesh": 0}]), one_channel("rotation", s)),
    );
    let end = yaw_degrees(vertex(&f, 30, 1));
    assert!((end - 90.0).abs() < 1e-3, "{end}");
}

/// The cubic Hermite spline of glTF 2.0 between values `v0`, `v1` with out-tangent `b0`,
/// in-tangent `a1` over an interval of `td` seconds, at `s` in [0, 1].
fn hermite(v0: f64, b0: f64, a1: f64, v1: f64, td: f64, s: f64) -> f64 {
    let (s2, s3) = (s * s, s * s * s);
    (2.0 * s3 - 3.0 * s2 + 1.0) * v0
        + (s3 - 2.0 * s2 + s) * td * b0
        + (-2.0 * s3 + 3.0 * s2) * v1
        + (s3 - s2) * td * a1
}

/// CUBICSPLINE output for x-only translation keys: (in-tangent, value, out-tangent) per key.
fn cubic_x(keys: &[(f32, f32, f32)]) -> Vec<f32> {
    keys.iter()
        .flat_map(|&(a, v, b)| [a, 0.0, 0.0, v, 0.0, 0.0, b, 0.0, 0.0])
        .collect()
}

#[test]
fn cubic_spline_with_zero_tangents_passes_through_its_keys_smoothly() {
    let mut d = data();
    let keys = [(0.0, 0.0, 0.0), (0.0, 2.0, 0.0), (0.0, 1.0, 0.0)];
    let s = sampler(
        &mut d,
        &[0.0, 1.0, 2.0],
        &cubic_x(&keys),
        "VEC3",
        "CUBICSPLINE",
    );
    let f = frames(
        "cubic",
        &document(&d, json!([{"mesh": 0}]), one_channel("translation", s)),
    );
    assert_eq!(f.count(), 61);
    let x = |t: u32| vertex(&f, t, 0).x;
    assert_eq!((x(0), x(30), x(60)), (0.0, 2.0, 1.0), "through the keys");
    for t in [5, 10, 15, 20, 29] {
        let want = hermite(0.0, 0.0, 0.0, 2.0, 1.0, f64::from(t) / 30.0) as f32;
        assert!((x(t) - want).abs() <= 1e-6, "frame {t}: {} vs {want}", x(t));
    }
    assert_eq!(x(15), 1.0, "the midpoint of a zero-tangent segment");
    let want = hermite(2.0, 0.0, 0.0, 1.0, 1.0, 10.0 / 30.0) as f32;
    assert!((x(40) - want).abs() <= 1e-6);
    // Zero tangents: the path slows into each key (a linear path moves 2/30 a frame).
    let near_key = (x(30) - x(29)).abs();
    let mid = (x(16) - x(15)).abs();
    assert!(near_key < mid / 10.0, "{near_key} vs {mid}");
}

#[test]
fn cubic_spline_tangents_are_scaled_by_the_key_interval() {
    let mut d = data();
    // Keys 2 s apart, out-tangent 1 and in-tangent −1: at the midpoint
    // 0.5 + 0.125·2·1 − 0.125·2·(−1) = 1 (0.75 without the interval).
    let s = sampler(
        &mut d,
        &[0.0, 2.0],
        &cubic_x(&[(5.0, 0.0, 1.0), (-1.0, 1.0, 5.0)]),
        "VEC3",
        "CUBICSPLINE",
    );
    let f = frames(
        "cubic-td",
        &document(&d, json!([{"mesh": 0}]), one_channel("translation", s)),
    );
    let x = vertex(&f, 30, 0).x;
    assert!((x - 1.0).abs() <= 1e-6, "{x}");
    let want = hermite(0.0, 1.0, -1.0, 1.0, 2.0, 0.25) as f32;
    let x = vertex(&f, 15, 0).x;
    assert!((x - want).abs() <= 1e-6, "{x} vs {want}");
}

#[test]
fn values_are_held_before_the_first_key_and_after_the_last() {
    let mut d = data();
    let a = sampler(
        &mut d,
        &[0.5, 1.0],
        &[1.0, 0.0, 0.0, 3.0, 0.0, 0.0],
        "VEC3",
        "LINEAR",
    );
    let b = sampler(
        &mut d,
        &[0.0, 2.0],
        &[0.0, 0.0, 0.0, 0.0, 4.0, 0.0],
        "VEC3",
        "LINEAR",
    );
    let anim = json!([{
        "channels": [
            {"sampler": 0, "target": {"node": 0, "path": "translation"}},
            {"sampler": 1, "target": {"node": 1, "path": "translation"}}
        ],
        "samplers": [a, b]
    }]);
    let f = frames(
        "hold",
        &document(&d, json!([{"mesh": 0}, {"mesh": 0}]), anim),
    );
    // The longest sampler sets the length: 2 s.
    assert_eq!(f.count(), 61);
    for t in 0..61 {
        let x = vertex(&f, t, 0).x;
        let want = match t {
            0..=15 => 1.0,
            16..=29 => lerp(1.0, 3.0, (f64::from(t) / 30.0 - 0.5) / 0.5),
            _ => 3.0,
        };
        assert_eq!(x, want, "frame {t}");
    }
}

#[test]
fn an_animated_camera_node_moves_the_eye_every_frame() {
    let mut d = data();
    let s = sampler(
        &mut d,
        &[0.0, 1.0],
        &[0.0, 0.0, 5.0, 1.0, 0.0, 3.0],
        "VEC3",
        "LINEAR",
    );
    let nodes = json!([{"mesh": 0}, {"camera": 0, "translation": [0, 0, 9]}]);
    let anim = json!([{"channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}], "samplers": [s]}]);
    let mut doc: Value = serde_json::from_str(&document(&d, nodes, anim)).unwrap();
    doc["cameras"] =
        json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 50}}]);
    let f = frames("camera", &doc.to_string());
    let eyes: Vec<Vec3> = (0..31).map(|t| f.frame(t).unwrap().camera.eye).collect();
    assert_eq!(eyes[0], Vec3::new(0.0, 0.0, 5.0));
    assert_eq!(eyes[30], Vec3::new(1.0, 0.0, 3.0));
    assert_eq!(eyes[15], Vec3::new(0.5, 0.0, 4.0));
    for t in 1..31 {
        assert!(eyes[t].z < eyes[t - 1].z, "eye moves at frame {t}");
    }
    // It looks down its node's −Z whatever the position.
    let c = f.frame(20).unwrap().camera;
    assert!((c.target - c.eye).normalize().distance(Vec3::NEG_Z) < 1e-6);
}

#[test]
fn without_a_camera_the_framing_camera_of_frame_0_is_kept() {
    let mut d = data();
    let s = sampler(
        &mut d,
        &[0.0, 1.0],
        &[0.0, 0.0, 0.0, 3.0, 0.0, 0.0],
        "VEC3",
        "LINEAR",
    );
    let text = document(&d, json!([{"mesh": 0}]), one_channel("translation", s));
    let f = frames("framing", &text);
    let first = f.frame(0).unwrap().camera;
    assert_eq!(f.frame(30).unwrap().camera, first);
    assert_eq!(vertex(&f, 30, 0).x, 3.0, "the geometry moves");
    assert!(
        f.frame(30)
            .unwrap()
            .description
            .contains("frame 0's bounds")
    );
    // Frame 0 of `load` is frame 0 of the frames.
    let dir = Scratch::new("framing-load");
    let path = dir.write("anim.gltf", &text);
    assert_eq!(oit_scene::load(&path).unwrap(), f.frame(0).unwrap());
}

#[test]
fn other_animations_and_weights_are_listed_as_ignored() {
    let mut d = data();
    let s = sampler(
        &mut d,
        &[0.0, 1.0],
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        "VEC3",
        "LINEAR",
    );
    let w = sampler(&mut d, &[0.0, 1.0], &[0.0, 1.0], "SCALAR", "LINEAR");
    let anim = json!([
        {"channels": [
            {"sampler": 0, "target": {"node": 0, "path": "translation"}},
            {"sampler": 1, "target": {"node": 0, "path": "weights"}}
        ], "samplers": [s.clone(), w]},
        {"channels": [{"sampler": 0, "target": {"node": 0, "path": "scale"}}], "samplers": [s.clone()]},
        {"channels": [{"sampler": 0, "target": {"node": 0, "path": "scale"}}], "samplers": [s]}
    ]);
    let f = frames("ignored", &document(&d, json!([{"mesh": 0}]), anim));
    let ignored = f.frame(3).unwrap().ignored;
    assert_eq!(ignored.len(), 2, "{ignored:?}");
    assert!(ignored[0].contains("2 more animations"), "{ignored:?}");
    assert!(
        ignored[1].contains("1 channel of /animations/0 targeting `weights`"),
        "{ignored:?}"
    );
    // Scale (animation 1) is not played: the triangle keeps its size.
    assert_eq!(vertex(&f, 30, 1), Vec3::new(2.0, 0.0, 0.0));
}

#[test]
fn an_asset_without_animations_is_a_still() {
    let d = data();
    let text = d.gltf(json!({
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]
    }));
    let f = frames("still", &text);
    assert_eq!((f.animation(), f.count()), (None, 1));
    let s = f.frame(0).unwrap();
    assert_eq!((s.frame, s.animation), (0, None));
}

#[test]
fn a_gltf_object_in_a_json_scene_lists_its_animations_as_not_played() {
    let mut d = data();
    let s = sampler(
        &mut d,
        &[0.0, 1.0],
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
        "VEC3",
        "LINEAR",
    );
    let dir = Scratch::new("object");
    dir.write(
        "anim.gltf",
        &document(&d, json!([{"mesh": 0}]), one_channel("translation", s)),
    );
    let scene = json!({
        "name": "t",
        "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
        "objects": [{"mesh": {"kind": "gltf", "file": "anim.gltf"}}]
    });
    let path = dir.write("scene.json", &scene.to_string());
    let s = oit_scene::load(&path).unwrap();
    assert_eq!(
        s.ignored,
        ["anim.gltf: 1 animation: not played for a glTF object inside a JSON scene"]
    );
    // The node stays at its static (untranslated) place.
    assert_eq!(s.vertices[0].position, [0.0, 0.0, 0.0]);
}

#[test]
fn decreasing_key_times_are_refused_at_the_sampler_input() {
    let mut d = data();
    let s = sampler(&mut d, &[0.0, 1.0, 0.5], &[0.0; 9], "VEC3", "LINEAR");
    let text = document(&d, json!([{"mesh": 0}]), one_channel("translation", s));
    let p = error_at("decreasing", &text, "/animations/0/samplers/0/input");
    assert!(
        matches!(p, Problem::BadValue { ref value, .. } if value.contains("0.5 s after 1 s")),
        "{p}"
    );
}

#[test]
fn negative_key_times_are_refused() {
    let mut d = data();
    let s = sampler(&mut d, &[-0.5, 1.0], &[0.0; 6], "VEC3", "LINEAR");
    let text = document(&d, json!([{"mesh": 0}]), one_channel("translation", s));
    error_at("negative", &text, "/animations/0/samplers/0/input");
}

#[test]
fn a_wrong_output_count_is_refused_at_the_sampler_output() {
    let mut d = data();
    // LINEAR needs one value per key; CUBICSPLINE three.
    let s = sampler(&mut d, &[0.0, 1.0], &[0.0; 9], "VEC3", "LINEAR");
    let text = document(&d, json!([{"mesh": 0}]), one_channel("translation", s));
    let p = error_at("count", &text, "/animations/0/samplers/0/output");
    assert!(matches!(p, Problem::AccessorFormat { .. }), "{p}");
    let mut d = data();
    let s = sampler(&mut d, &[0.0, 1.0], &[0.0; 6], "VEC3", "CUBICSPLINE");
    let text = document(&d, json!([{"mesh": 0}]), one_channel("translation", s));
    let p = error_at("count-cubic", &text, "/animations/0/samplers/0/output");
    assert!(p.to_string().contains("6 elements"), "{p}");
}

#[test]
fn a_wrong_output_type_is_refused_at_the_sampler_output() {
    let mut d = data();
    let s = sampler(&mut d, &[0.0, 1.0], &[0.0; 8], "VEC4", "LINEAR");
    let text = document(&d, json!([{"mesh": 0}]), one_channel("translation", s));
    let p = error_at("type", &text, "/animations/0/samplers/0/output");
    assert!(p.to_string().contains("VEC3 FLOAT"), "{p}");
}

#[test]
fn an_animated_node_with_a_matrix_is_refused() {
    let mut d = data();
    let s = sampler(&mut d, &[0.0, 1.0], &[0.0; 6], "VEC3", "LINEAR");
    let nodes = json!([{"mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}]);
    let text = document(&d, nodes, one_channel("translation", s));
    let p = error_at("matrix", &text, "/animations/0/channels/0/target/node");
    assert!(p.to_string().contains("matrix"), "{p}");
}

#[test]
fn a_target_node_out_of_range_is_refused() {
    let mut d = data();
    let s = sampler(&mut d, &[0.0, 1.0], &[0.0; 6], "VEC3", "LINEAR");
    let anim = json!([{"channels": [{"sampler": 0, "target": {"node": 7, "path": "translation"}}], "samplers": [s]}]);
    let text = document(&d, json!([{"mesh": 0}]), anim);
    let p = error_at("node", &text, "/animations/0/channels/0/target/node");
    assert_eq!(p, Problem::NoSuchItem { index: 7, count: 1 });
}

#[test]
fn a_node_path_animated_twice_is_refused() {
    let mut d = data();
    let s = sampler(&mut d, &[0.0, 1.0], &[0.0; 6], "VEC3", "LINEAR");
    let anim = json!([{"channels": [
        {"sampler": 0, "target": {"node": 0, "path": "translation"}},
        {"sampler": 0, "target": {"node": 0, "path": "translation"}}
    ], "samplers": [s]}]);
    let text = document(&d, json!([{"mesh": 0}]), anim);
    error_at("twice", &text, "/animations/0/channels/1/target");
}

#[test]
fn an_animation_longer_than_max_frames_is_refused() {
    let mut d = data();
    let s = sampler(&mut d, &[0.0, 1000.0], &[0.0; 6], "VEC3", "LINEAR");
    let text = document(&d, json!([{"mesh": 0}]), one_channel("translation", s));
    let p = error_at("long", &text, "/animations/0/samplers/0/input");
    assert!(p.to_string().contains("30001 frames"), "{p}");
}

#[test]
fn a_zero_rotation_is_refused() {
    let mut d = data();
    let s = sampler(&mut d, &[0.0, 1.0], &[0.0; 8], "VEC4", "LINEAR");
    let text = document(&d, json!([{"mesh": 0}]), one_channel("rotation", s));
    error_at("zero-quat", &text, "/animations/0/samplers/0/output");
    // A rotation is not a translation: VEC4 is right, and a unit quaternion loads.
    let mut d = data();
    let s = sampler(&mut d, &[0.0], &[0.0, 0.0, 0.0, 2.0], "VEC4", "STEP");
    let f = frames(
        "one-key",
        &document(&d, json!([{"mesh": 0}]), one_channel("rotation", s)),
    );
    assert_eq!(f.count(), 1);
    assert!(f.animation().is_some());
    // [0, 0, 0, 2] normalised is the identity.
    assert_eq!(vertex(&f, 0, 1), Vec3::new(1.0, 0.0, 0.0));
}

// ---- The bundled asset scenes/motion/motion-gltf-panes.gltf and its generator ----

#[path = "../../../tools/src/bin/motion_gltf_panes.rs"]
#[allow(dead_code, reason = "the tool's `main` is not called here")]
mod generator;

fn motion_dir() -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/motion")
}

#[test]
fn bundled_gltf_panes_match_their_generator() {
    let (text, bytes) = generator::motion_gltf_panes();
    let dir = motion_dir();
    let stem = generator::STEM;
    let on_disk = |ext: &str| std::fs::read(dir.join(format!("{stem}.{ext}"))).ok();
    if on_disk("gltf").as_deref() != Some(text.as_bytes())
        || on_disk("bin").as_deref() != Some(&bytes[..])
    {
        let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"));
        std::fs::write(out.join(format!("{stem}.gltf")), &text).unwrap();
        std::fs::write(out.join(format!("{stem}.bin")), &bytes).unwrap();
        panic!(
            "scenes/motion/{stem}.gltf or .bin differs from what tools/src/bin/motion_gltf_panes.rs writes; \
             regenerate with `cargo run -p oit-tools --bin motion_gltf_panes` (this run's output is in {})",
            out.display()
        );
    }
    assert!(text.len() + bytes.len() < 50_000, "keep the asset small");
    // Regenerating gives identical bytes.
    assert_eq!(generator::motion_gltf_panes(), (text, bytes));
}

#[test]
fn bundled_gltf_panes_pass_through_each_other_inside_the_view() {
    let path = motion_dir().join(format!("{}.gltf", generator::STEM));
    let (f, inputs) = oit_scene::load_frames(&path, &LoadOptions::default()).unwrap();
    assert_eq!(inputs.len(), 2, "the .gltf and its .bin: {inputs:?}");
    assert_eq!(f.count(), 61, "2 s at 30 fps");
    let first = f.frame(0).unwrap();
    assert_eq!((first.draws.len(), first.triangle_count()), (4, 8));
    for m in &first.materials {
        assert_eq!(m.mode, oit_scene::AlphaMode::Blend);
        assert!(m.double_sided && (0.4..=0.6).contains(&m.alpha), "{m:?}");
    }
    assert!(
        first.credits.iter().any(|c| c.contains("CC0 1.0")),
        "{:?}",
        first.credits
    );
    assert!(first.ignored.is_empty(), "{:?}", first.ignored);
    let mut eyes = Vec::new();
    let mut centres = Vec::new();
    for t in 0..f.count() {
        let s = f.frame(t).unwrap();
        // Every vertex of every frame inside the view, clear of its edges and of near and far.
        for v in &s.vertices {
            let c = s.camera.clip(Vec3::from(v.position));
            assert!(
                c.w > 0.0
                    && c.x.abs() <= 0.95 * c.w
                    && c.y.abs() <= 0.95 * c.w
                    && c.z > 0.0
                    && c.z < c.w,
                "frame {t}: {:?} at clip {c}",
                v.position
            );
        }
        eyes.push(s.camera.eye);
        centres.push(s.draws.iter().map(|d| d.bounds_center).collect::<Vec<_>>());
    }
    // The camera arcs (x from − to +) and dollies in and out again.
    assert!(eyes[0].x < -1.0 && eyes[60].x > 1.0, "{eyes:?}");
    assert!(eyes[30].length() < eyes[0].length() - 0.5, "{eyes:?}");
    // Green slides along Z through the red and yellow panes at the origin, blue along X.
    assert!(centres[0][1].z < -1.0 && centres[60][1].z > 1.0);
    assert!(centres[0][2].x > 1.0 && centres[60][2].x < -1.0);
}
