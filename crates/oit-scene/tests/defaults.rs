//! Omitted fields take the defaults docs/scene-format.md states, checked on the loaded scene
//! (a default changed in the loader alone, e.g. by a mutation, fails here).

const HEADER: &str = r#""resolution": [8, 8],
    "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100},
    "background": [0, 0, 0]"#;

fn load(objects: &str) -> oit_scene::Scene {
    let json =
        format!(r#"{{"name": "defaults", "description": "", {HEADER}, "objects": [{objects}]}}"#);
    oit_scene::parse(&json, "defaults.json").expect("valid scene")
}

fn positions(scene: &oit_scene::Scene) -> Vec<[f32; 3]> {
    scene.vertices.iter().map(|v| v.position).collect()
}

fn max_by(points: &[[f32; 3]], f: impl Fn(&[f32; 3]) -> f32) -> f32 {
    points.iter().map(f).fold(f32::NEG_INFINITY, f32::max)
}

#[test]
fn mesh_sizes_default_as_documented() {
    // quad: size [1, 1].
    let quad = positions(&load(r#"{"mesh": {"kind": "quad"}}"#));
    assert_eq!(max_by(&quad, |p| p[0]), 0.5);
    assert_eq!(max_by(&quad, |p| p[1]), 0.5);
    assert_eq!(max_by(&quad, |p| -p[0]), 0.5);
    // uv-sphere: radius 0.5.
    let sphere = positions(&load(r#"{"mesh": {"kind": "uv-sphere"}}"#));
    let r = max_by(&sphere, |p| {
        (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
    });
    assert!((r - 0.5).abs() < 1e-6, "sphere radius {r}");
    // cylinder: radius 0.5, height 1.
    let cylinder = positions(&load(r#"{"mesh": {"kind": "cylinder"}}"#));
    let r = max_by(&cylinder, |p| (p[0] * p[0] + p[2] * p[2]).sqrt());
    assert!((r - 0.5).abs() < 1e-6, "cylinder radius {r}");
    assert!((max_by(&cylinder, |p| p[1]) - 0.5).abs() < 1e-6);
}

#[test]
fn layers_default_as_documented() {
    // spacing 0.1, size [2, 2], colours [1, 1, 1], alphas 0.5.
    let scene = load(r#"{"mesh": {"kind": "layers", "count": 3}}"#);
    assert_eq!(scene.draws.len(), 3);
    let points = positions(&scene);
    assert_eq!(max_by(&points, |p| p[0]), 1.0);
    assert_eq!(max_by(&points, |p| p[1]), 1.0);
    let deepest = max_by(&points, |p| -p[2]);
    assert!((deepest - 0.2).abs() < 1e-6, "layer 2 at z = -{deepest}");
    for v in &scene.vertices {
        assert_eq!(v.color, [1.0, 1.0, 1.0, 0.5], "{v:?}");
    }
}

#[test]
fn material_cutoff_defaults_to_one_half() {
    let scene = load(r#"{"mesh": {"kind": "quad"}, "material": {"mode": "mask"}}"#);
    assert_eq!(
        scene.materials[scene.draws[0].material as usize].cutoff,
        0.5
    );
}
