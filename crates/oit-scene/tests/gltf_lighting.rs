//! Per-pixel lighting of glTF materials: `KHR_lights_punctual` lights read into the scene's
//! rig, the default rig, `KHR_materials_unlit`, flat normals, the JSON overrides, and the
//! shading rule's Faded / Kept distinction.

use std::path::PathBuf;

use oit_scene::{
    AlphaMode, LightKind, LightRig, LoadOptions, Material, Problem, Reflectance, SceneError,
    Shaded, Specular, SurfacePoint, Texels,
};
use serde_json::{Value, json};

mod common;
use common::build::{Data, TRI, single_mesh};

/// A scratch directory unique to this test process and `tag`, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("oit-gltf-light-{}-{tag}", std::process::id()));
        std::fs::create_dir_all(dir.join("models")).unwrap();
        Scratch(dir)
    }
    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// One triangle (no NORMAL) with material 0 = `material`, plus `lights` placed by extra nodes
/// (node i + 1 places light i with the given node fields).
fn asset(material: Value, lights: &[(Value, Value)]) -> String {
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let mut doc = single_mesh(pos, json!({"material": 0}));
    doc["materials"] = json!([material]);
    if !lights.is_empty() {
        let defs: Vec<Value> = lights.iter().map(|(l, _)| l.clone()).collect();
        doc["extensions"] = json!({"KHR_lights_punctual": {"lights": defs}});
        doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        for (i, (_, node)) in lights.iter().enumerate() {
            let mut n = node.clone();
            n["extensions"] = json!({"KHR_lights_punctual": {"light": i}});
            doc["nodes"].as_array_mut().unwrap().push(n);
            doc["scenes"][0]["nodes"]
                .as_array_mut()
                .unwrap()
                .push(json!(i + 1));
        }
    }
    d.gltf(doc)
}

#[test]
fn punctual_lights_are_read_in_world_space() {
    let dir = Scratch::new("punctual");
    let text = asset(
        json!({"pbrMetallicRoughness": {"metallicFactor": 0.25, "roughnessFactor": 0.5}}),
        &[
            (
                json!({"type": "directional", "color": [1, 0.5, 0.25], "intensity": 2}),
                json!({"rotation": [std::f32::consts::FRAC_1_SQRT_2, 0, 0, std::f32::consts::FRAC_1_SQRT_2]}),
            ),
            (
                json!({"type": "point", "intensity": 3, "range": 10}),
                json!({"translation": [1, 2, 3]}),
            ),
            (
                json!({"type": "spot", "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}}),
                json!({"translation": [0, 0, 5]}),
            ),
        ],
    );
    let path = dir.write("lights.gltf", text.as_bytes());
    let s = oit_scene::load(&path).unwrap();
    let m = s.materials[0];
    assert_eq!(
        m.reflectance,
        Some(Reflectance {
            metallic: 0.25,
            roughness: 0.5,
            specular: Specular::Faded
        })
    );
    let l = &s.lights.lights;
    assert_eq!(l.len(), 3, "{:?}", s.lights);
    assert_eq!(s.lights.ambient, [0.0; 3]);
    assert_eq!(l[0].kind, LightKind::Directional);
    assert_eq!(l[0].radiance, [2.0, 1.0, 0.5]);
    // −Z rotated +90° about x points along +y.
    let d = l[0].direction;
    assert!(
        (d[1] - 1.0).abs() < 1e-6 && d[0].abs() < 1e-6 && d[2].abs() < 1e-6,
        "{d:?}"
    );
    assert_eq!(l[1].kind, LightKind::Point);
    assert_eq!((l[1].position, l[1].range), ([1.0, 2.0, 3.0], 10.0));
    assert_eq!(l[1].radiance, [3.0; 3]);
    assert_eq!(l[2].kind, LightKind::Spot);
    assert_eq!(l[2].range, 0.0, "absent range is infinite");
    let (scale, offset) = oit_scene::PunctualLight::cone(0.2, 0.6);
    assert_eq!((l[2].cone_scale, l[2].cone_offset), (scale, offset));
    // The vertices carry the flat face normal (+z) the spec asks for without NORMAL.
    assert!(s.vertices.iter().all(|v| v.normal == [0.0, 0.0, 1.0]));
    assert!(s.ignored.iter().all(|l| !l.contains("KHR_lights_punctual")));
}

#[test]
fn without_lights_the_default_rig_and_unlit_materials_stay_unlit() {
    let dir = Scratch::new("default");
    let path = dir.write("plain.gltf", asset(json!({}), &[]).as_bytes());
    let s = oit_scene::load(&path).unwrap();
    assert_eq!(s.lights, LightRig::default_rig());
    // glTF's defaults: metallic 1, roughness 1.
    assert_eq!(s.materials[0].reflectance, Some(Reflectance::GLTF_DEFAULT));
    // `LoadOptions::unlit` renders it unlit, with no lights.
    let options = LoadOptions {
        unlit: true,
        ..Default::default()
    };
    let s = oit_scene::load_with(&path, &options).unwrap();
    assert!(!s.materials[0].is_lit());
    assert_eq!(s.lights, LightRig::none());
    // KHR_materials_unlit: unlit whatever the scene.
    let unlit = asset(
        json!({"extensions": {"KHR_materials_unlit": {}}}),
        &[(json!({"type": "directional"}), json!({}))],
    );
    let path = dir.write("unlit.gltf", unlit.as_bytes());
    let s = oit_scene::load(&path).unwrap();
    assert!(!s.materials[0].is_lit());
    assert!(
        s.ignored.iter().all(|l| !l.contains("unlit")),
        "{:?}",
        s.ignored
    );
}

#[test]
fn light_errors_name_the_field() {
    let dir = Scratch::new("errors");
    let nine: Vec<(Value, Value)> = (0..9)
        .map(|_| (json!({"type": "directional"}), json!({})))
        .collect();
    let path = dir.write("nine.gltf", asset(json!({}), &nine).as_bytes());
    match oit_scene::load(&path) {
        Err(SceneError::Invalid { path, problem, .. }) => {
            assert!(
                path.contains("/extensions/KHR_lights_punctual/lights/8"),
                "{path}"
            );
            assert!(problem.to_string().contains("at most 8"), "{problem}");
        }
        other => panic!("expected a light count error, got {other:?}"),
    }
    let cone = asset(
        json!({}),
        &[(
            json!({"type": "spot", "spot": {"innerConeAngle": 0.7, "outerConeAngle": 0.5}}),
            json!({}),
        )],
    );
    let path = dir.write("cone.gltf", cone.as_bytes());
    match oit_scene::load(&path) {
        Err(SceneError::Invalid { path, .. }) => {
            assert_eq!(path, "/extensions/KHR_lights_punctual/lights/0/spot")
        }
        other => panic!("expected a cone error, got {other:?}"),
    }
}

fn json_scene(mesh_extra: Value, lighting: Value) -> Value {
    let mut mesh = json!({"kind": "gltf", "file": "models/tri.gltf"});
    if let Value::Object(m) = mesh_extra {
        for (k, v) in m {
            mesh[k] = v;
        }
    }
    json!({
        "name": "placed",
        "camera": {"eye": [0, 0, 10], "target": [0, 0, 0]},
        "lighting": lighting,
        "objects": [{"mesh": mesh}]
    })
}

#[test]
fn json_gltf_objects_are_lit_per_pixel_with_overrides() {
    let dir = Scratch::new("json");
    dir.write("models/tri.gltf", asset(json!({}), &[]).as_bytes());
    let directional = json!({"directional": {"direction": [0, 0, -1], "color": [0.5, 0.5, 0.5], "ambient": [0.25, 0.25, 0.25]}});
    // Per pixel by default: the scene's directional light becomes the rig (π·color), not baked.
    let p = dir.write(
        "a.json",
        json_scene(json!({}), directional.clone())
            .to_string()
            .as_bytes(),
    );
    let s = oit_scene::load(&p).unwrap();
    assert!(s.materials[0].is_lit());
    assert_eq!(s.vertices[0].color, [1.0; 4], "not baked");
    assert_eq!(s.lights.ambient, [0.25; 3]);
    assert_eq!(s.lights.lights.len(), 1);
    let pi_half = std::f32::consts::PI * 0.5;
    assert_eq!(s.lights.lights[0].radiance, [pi_half; 3]);
    // `specular: kept` overrides every lit material.
    let p = dir.write(
        "b.json",
        json_scene(json!({"specular": "kept"}), json!("unlit"))
            .to_string()
            .as_bytes(),
    );
    let s = oit_scene::load(&p).unwrap();
    assert_eq!(
        s.materials[0].reflectance.map(|r| r.specular),
        Some(Specular::Kept)
    );
    assert_eq!(s.lights, LightRig::default_rig());
    // `lighting: unlit` bakes the scene light as before.
    let p = dir.write(
        "c.json",
        json_scene(json!({"lighting": "unlit"}), directional)
            .to_string()
            .as_bytes(),
    );
    let s = oit_scene::load(&p).unwrap();
    assert!(!s.materials[0].is_lit());
    assert_eq!(s.vertices[0].color, [0.75, 0.75, 0.75, 1.0]);
    assert_eq!(s.lights, LightRig::none());
    // Strict: unknown values and specular on an unlit object are errors naming the field.
    for (extra, field) in [
        (json!({"specular": "shiny"}), "objects[0].mesh.specular"),
        (json!({"lighting": "baked"}), "objects[0].mesh.lighting"),
        (
            json!({"lighting": "unlit", "specular": "kept"}),
            "objects[0].mesh.specular",
        ),
    ] {
        let p = dir.write(
            "bad.json",
            json_scene(extra.clone(), json!("unlit"))
                .to_string()
                .as_bytes(),
        );
        match oit_scene::load(&p) {
            Err(SceneError::Invalid { path, .. }) => assert_eq!(path, field, "{extra}"),
            other => panic!("{extra}: expected an error at {field}, got {other:?}"),
        }
    }
}

#[test]
fn json_materials_take_a_lit_block() {
    let scene = json!({
        "name": "lit",
        "camera": {"eye": [0, 0, 10], "target": [0, 0, 0]},
        "objects": [{"mesh": {"kind": "quad"}, "material": {"alpha": 0.5, "mode": "blend",
            "lit": {"metallic": 0.5, "roughness": 0.3, "specular": "kept"}}}]
    });
    let s = oit_scene::parse(&scene.to_string(), "lit.json").unwrap();
    assert_eq!(
        s.materials[0].reflectance,
        Some(Reflectance {
            metallic: 0.5,
            roughness: 0.3,
            specular: Specular::Kept
        })
    );
    assert_eq!(s.lights, LightRig::default_rig());
    assert!(s.vertices.iter().all(|v| v.normal == [0.0, 0.0, 1.0]));
    let mut bad = scene.clone();
    bad["objects"][0]["material"]["lit"]["roughness"] = json!(1.5);
    match oit_scene::parse(&bad.to_string(), "bad.json") {
        Err(SceneError::Invalid { path, problem, .. }) => {
            assert_eq!(path, "objects[0].material.lit.roughness");
            assert!(matches!(problem, Problem::BadValue { .. }), "{problem}");
        }
        other => panic!("expected a roughness error, got {other:?}"),
    }
}

/// Faded and Kept differ by exactly (1 − α)·specular, and the transmittance of a
/// transmissive material stays the unlit filter.
#[test]
fn kept_specular_adds_what_faded_scales_by_alpha() {
    let rig = LightRig::default_rig();
    let point = SurfacePoint {
        position: [0.0; 3],
        normal: [0.3, 0.8, 0.5],
        eye: [-1.0, 2.0, 3.0],
    };
    let mut m = Material::plain([0.6, 0.3, 0.9], 0.25, AlphaMode::Blend);
    m.reflectance = Some(Reflectance {
        metallic: 0.0,
        roughness: 0.3,
        specular: Specular::Faded,
    });
    let mut kept = m;
    kept.reflectance = Some(Reflectance {
        specular: Specular::Kept,
        ..m.reflectance.unwrap()
    });
    let rgba = [1.0, 1.0, 1.0, 1.0];
    let parts = oit_scene::reflect_lights([0.6, 0.3, 0.9], &m.reflectance.unwrap(), &rig, &point);
    assert!(parts.specular.iter().all(|&s| s > 1e-3), "{parts:?}");
    let premultiplied =
        |mat: &Material| match mat.shade_lit(rgba, Texels::UNTEXTURED, Some((&rig, &point))) {
            Shaded::Transparent {
                premultiplied,
                alpha,
            } => {
                assert_eq!(alpha, 0.25);
                premultiplied
            }
            other => panic!("{other:?}"),
        };
    let (f, k) = (premultiplied(&m), premultiplied(&kept));
    for c in 0..3 {
        let difference = f64::from(k[c]) - f64::from(f[c]);
        let expected = 0.75 * f64::from(parts.specular[c]);
        assert!(
            (difference - expected).abs() <= 1e-6 * expected.max(1.0),
            "channel {c}: {difference} vs {expected}"
        );
    }
    // Unlit (no surface point) is the old rule: α·albedo.
    assert_eq!(
        m.shade(rgba, Texels::UNTEXTURED),
        Shaded::Transparent {
            premultiplied: [0.25 * 0.6, 0.25 * 0.3, 0.25 * 0.9],
            alpha: 0.25
        }
    );
    // Transmission: the filter stays the unlit base colour, lighting scales the reflected part.
    let mut glass = m;
    glass.transmission = 0.5;
    match glass.shade_lit(rgba, Texels::UNTEXTURED, Some((&rig, &point))) {
        Shaded::Transmissive { transmittance, .. } => {
            for (c, base) in [0.6f32, 0.3, 0.9].into_iter().enumerate() {
                assert_eq!(transmittance[c], (1.0 - 0.25) + 0.25 * 0.5 * base);
            }
        }
        other => panic!("{other:?}"),
    }
}
