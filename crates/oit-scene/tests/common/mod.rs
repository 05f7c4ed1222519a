//! Helpers shared by the integration tests.
#![allow(dead_code, reason = "each test binary uses a different subset")]

pub mod build;

use glam::{Vec2, Vec3};
use oit_scene::{Problem, Scene, SceneError};
use serde_json::{Value, json};

/// A valid scene with a camera on +z looking at the origin and the given objects.
pub fn scene_with(objects: Value) -> Value {
    json!({
        "name": "t",
        "camera": {"eye": [0, 0, 5], "target": [0, 0, 0]},
        "objects": objects,
    })
}

/// One blended quad: the smallest valid scene.
pub fn minimal() -> Value {
    scene_with(json!([{"mesh": {"kind": "quad"}, "material": {"mode": "blend", "alpha": 0.5}}]))
}

/// Sets the value at a JSON pointer, creating missing object members along the way.
pub fn with(mut v: Value, pointer: &str, new: Value) -> Value {
    let mut cur = &mut v;
    for part in pointer.split('/').skip(1) {
        if cur.is_null() {
            *cur = Value::Object(Default::default());
        }
        cur = match cur {
            Value::Array(a) => &mut a[part.parse::<usize>().expect("array index")],
            Value::Object(o) => o.entry(part.to_string()).or_insert(Value::Null),
            other => panic!("cannot descend into {other}"),
        };
    }
    *cur = new;
    v
}

pub fn parse(v: &Value) -> Result<Scene, SceneError> {
    oit_scene::parse(&v.to_string(), "test.json")
}

pub fn load_ok(v: &Value) -> Scene {
    parse(v).unwrap_or_else(|e| panic!("expected a valid scene, got: {e}"))
}

/// Parses text that must fail; returns (path, problem).
pub fn fail_text(text: &str) -> (String, Problem) {
    match oit_scene::parse(text, "test.json") {
        Ok(_) => panic!("expected an error for {text}"),
        Err(e) => {
            let line = e.to_string();
            assert!(!line.contains('\n'), "error is not one line: {line}");
            assert!(
                line.starts_with("test.json: "),
                "error does not name the file: {line}"
            );
            assert!(
                line.contains("; allowed: "),
                "error does not say what is allowed: {line}"
            );
            (
                e.path().expect("path").to_string(),
                e.problem().expect("problem").clone(),
            )
        }
    }
}

pub fn fail(v: &Value) -> (String, Problem) {
    fail_text(&v.to_string())
}

/// Window-space (NDC, y up) position of a world point.
pub fn ndc(scene: &Scene, p: [f32; 3]) -> Vec2 {
    let c = scene.camera.clip(Vec3::from(p));
    assert!(c.w > 0.0, "vertex behind the camera");
    Vec2::new(c.x / c.w, c.y / c.w)
}

/// Signed area of a projected triangle, positive when counter-clockwise with y up (front).
pub fn signed_area(scene: &Scene, tri: [[f32; 3]; 3]) -> f32 {
    let [a, b, c] = tri.map(|p| ndc(scene, p));
    0.5 * (b - a).perp_dot(c - a)
}

/// Triangles of a draw as world positions.
pub fn triangles(scene: &Scene, draw: usize) -> Vec<[[f32; 3]; 3]> {
    let r = scene.draws[draw].vertex_range();
    scene.vertices[r]
        .chunks_exact(3)
        .map(|t| [t[0].position, t[1].position, t[2].position])
        .collect()
}

pub fn geometric_normal(tri: [[f32; 3]; 3]) -> Vec3 {
    let [a, b, c] = tri.map(Vec3::from);
    (b - a).cross(c - a).normalize()
}

pub fn centroid(tri: [[f32; 3]; 3]) -> Vec3 {
    tri.map(Vec3::from).iter().sum::<Vec3>() / 3.0
}
