//! Seeded random scenes: content nobody placed by hand, for conformance and exactness tests.
//!
//! [`random_scene_json`] writes an ordinary scene file (so the loader, its validation and the
//! flattening are exercised too) from a seed. Every scene mixes what makes rasterization and
//! compositing hard on content the bundled suite never showed: triangle soups, camera-facing
//! billboards, tilted and mutually intersecting planes, geometry crossing the near and far
//! planes, standard-Z and reverse-Z, perspective and orthographic cameras (negative orthographic
//! near included), non-square and odd resolutions, and mask cards whose cutoff contour runs
//! through triangles. Not bundled: tests generate them (`cargo xtask conformance --scenes N`).

use crate::rng::SplitMix64;
use serde_json::{Value, json};

/// What [`random_scene_json`] put in the scene, for test messages.
#[derive(Debug, Clone, PartialEq)]
pub struct RandomSceneInfo {
    pub seed: u64,
    pub orthographic: bool,
    pub reverse_z: bool,
    pub resolution: [u32; 2],
    /// Object kinds in file order (`soup`, `billboards`, `plane`, `card`, `crossing`, ...).
    pub objects: Vec<&'static str>,
}

/// The JSON text of random scene `seed`, and what it contains. The same seed gives the same
/// text in every version (the crate's own SplitMix64, fixed decimal printing).
pub fn random_scene_json(seed: u64) -> (String, RandomSceneInfo) {
    let mut r = SplitMix64::new(seed ^ 0x5eed_0f5c_e4e5);
    // Odd and non-square sizes are the point; keep them small so hundreds run in seconds.
    let width = 8 + (r.next_u64() % 90) as u32;
    let height = 8 + (r.next_u64() % 90) as u32;
    let orthographic = r.next_f32() < 0.3;
    let reverse_z = r.next_f32() < 0.5;
    let eye = [r.range(-1.5, 1.5), r.range(-1.5, 1.5), r.range(3.0, 6.0)];
    let target = [r.range(-0.3, 0.3), r.range(-0.3, 0.3), r.range(-0.5, 0.5)];
    let distance = ((eye[0] - target[0]).powi(2)
        + (eye[1] - target[1]).powi(2)
        + (eye[2] - target[2]).powi(2))
    .sqrt();
    // The near and far planes cut through the content on purpose (clipping), sometimes far
    // away from it. An orthographic near may be zero or negative.
    let (near, far) = if r.next_f32() < 0.5 {
        (r.range(0.05, 0.5), distance + r.range(0.5, 20.0))
    } else {
        (
            r.range(distance - 2.0, distance - 0.2).max(0.01),
            distance + r.range(-0.3, 1.5),
        )
    };
    let mut camera = json!({
        "eye": eye, "target": target, "up": [r.range(-0.2, 0.2), 1.0, 0.0],
        "near": round(near), "far": round(far.max(near + 0.1)),
    });
    if orthographic {
        camera["orthographic"] = json!({"height": round(r.range(1.5, 4.0))});
        if r.next_f32() < 0.4 {
            camera["near"] = json!(round(-r.range(0.0, 3.0)));
        }
    } else {
        camera["fov_y"] = json!(round(r.range(25.0, 80.0)));
    }

    let mut objects = Vec::new();
    let mut kinds = Vec::new();
    let count = 2 + (r.next_u64() % 6) as usize;
    for _ in 0..count {
        let (kind, object) = random_object(&mut r);
        kinds.push(kind);
        objects.push(object);
    }
    let scene = json!({
        "name": format!("random-{seed}"),
        "description": "seeded random conformance scene (oit_scene::random)",
        "resolution": [width, height],
        "camera": camera,
        "background": [round(r.range(0.0, 0.3)), round(r.range(0.0, 0.3)), round(r.range(0.0, 0.3))],
        "reverse_z": reverse_z,
        "objects": objects,
    });
    let info = RandomSceneInfo {
        seed,
        orthographic,
        reverse_z,
        resolution: [width, height],
        objects: kinds,
    };
    (
        serde_json::to_string_pretty(&scene).expect("a JSON value serializes"),
        info,
    )
}

/// Random scene `seed` set in motion: an `animation` of 3 to 6 frames, camera keyframes (eye
/// and target moved, sometimes the field of view or orthographic height) and, on most objects,
/// keyframes of translation, rotation and scale, and of alpha on objects with a material.
/// Content nobody keyed by hand, for tests that every frame of an animated scene is exact.
pub fn random_animated_scene_json(seed: u64) -> (String, RandomSceneInfo) {
    let (text, info) = random_scene_json(seed);
    let mut scene: Value = serde_json::from_str(&text).expect("the generator writes valid JSON");
    let mut r = SplitMix64::new(seed ^ 0xa417_a7ed_5ce7);
    let frames = 3 + r.next_u64() % 4;
    scene["animation"] = json!({"frames": frames, "fps": 24});
    let last = frames - 1;
    let shift = |r: &mut SplitMix64, v: &Value, by: f32| -> Value {
        let a = v.as_array().cloned().unwrap_or_default();
        Value::Array(
            a.iter()
                .map(|x| json!(round(x.as_f64().unwrap_or(0.0) as f32 + r.range(-by, by))))
                .collect(),
        )
    };
    let camera = scene["camera"].clone();
    let mut key0 = json!({"frame": 0, "eye": shift(&mut r, &camera["eye"], 0.4)});
    let mut key1 = json!({"frame": last, "eye": shift(&mut r, &camera["eye"], 0.4),
                          "target": shift(&mut r, &camera["target"], 0.2)});
    if let Some(fov) = camera["fov_y"].as_f64() {
        key1["fov_y"] = json!(round((fov as f32 * r.range(0.8, 1.2)).clamp(20.0, 85.0)));
    } else if let Some(h) = camera["orthographic"]["height"].as_f64() {
        key0["orthographic"] = json!({"height": round(h as f32 * r.range(0.8, 1.2))});
    }
    scene["camera"]["keyframes"] = json!([key0, key1]);
    if let Some(objects) = scene["objects"].as_array_mut() {
        for object in objects {
            if r.next_f32() < 0.25 {
                continue;
            }
            let mid = 1 + r.next_u64() % last;
            let mut first = json!({"frame": 0, "translate": [0, 0, 0]});
            let mut second = json!({"frame": mid, "rotate": rotation(&mut r)});
            let scale = round(r.range(0.6, 1.4));
            let third = json!({"frame": last,
                "translate": [round(r.range(-0.5, 0.5)), round(r.range(-0.5, 0.5)), round(r.range(-0.5, 0.5))],
                "scale": [scale, scale, scale]});
            if object.get("material").is_some() {
                first["alpha"] = json!(round(r.range(0.05, 1.0)));
                second["alpha"] = json!(round(r.range(0.05, 1.0)));
            }
            let keys = if mid == last {
                vec![first, second]
            } else {
                vec![first, second, third]
            };
            object["keyframes"] = Value::Array(keys);
        }
    }
    (
        serde_json::to_string_pretty(&scene).expect("a JSON value serializes"),
        info,
    )
}

/// What [`random_mixed_operator_scene_json`] gave the transparent materials, for test messages
/// and for tests that need a scene to use an operator.
#[derive(Debug, Clone, PartialEq)]
pub struct MixedOperatorInfo {
    pub scene: RandomSceneInfo,
    /// The operator of each object's material in file order (`None`: no transparent material).
    pub operators: Vec<Option<crate::BlendOperator>>,
    /// Objects whose material is lit per pixel.
    pub lit: usize,
}

/// Random scene `seed` (the geometry, camera and modes of [`random_scene_json`]) with every
/// transparent material given one of the four blend operators (`over`, `add`, `subtract`,
/// `multiply`, a quarter each), `add` often above intensity 1, and about a third of the
/// materials lit per pixel; the resolution is fixed to 48²–64² so many seeds run in seconds.
/// Content for tests that the exact techniques stay exact whatever operators a pixel's layers
/// mix. [`random_scene_json`] itself is unchanged: its seeds keep their scenes.
pub fn random_mixed_operator_scene_json(seed: u64) -> (String, MixedOperatorInfo) {
    let (text, mut info) = random_scene_json(seed);
    let mut scene: Value = serde_json::from_str(&text).expect("the generator writes valid JSON");
    let mut r = SplitMix64::new(seed ^ 0x0b1e_4d0b_5ca7);
    let side = 48 + (r.next_u64() % 17) as u32;
    let other = 48 + (r.next_u64() % 17) as u32;
    scene["resolution"] = json!([side, other]);
    info.resolution = [side, other];
    let (mut operators, mut lit) = (Vec::new(), 0);
    if let Some(objects) = scene["objects"].as_array_mut() {
        for object in objects {
            let material = &mut object["material"];
            let transparent = matches!(material["mode"].as_str(), Some("blend" | "mask-blend"));
            if r.next_f32() < 0.35 {
                material["lit"] = json!({
                    "metallic": round(r.range(0.0, 1.0)),
                    "roughness": round(r.range(0.1, 0.9)),
                    "specular": if r.next_f32() < 0.5 { "faded" } else { "kept" },
                });
                lit += 1;
            }
            if !transparent {
                operators.push(None);
                continue;
            }
            let operator = match r.next_u64() % 4 {
                0 => crate::BlendOperator::Over,
                1 => crate::BlendOperator::Add,
                2 => crate::BlendOperator::Subtract,
                _ => crate::BlendOperator::Multiply,
            };
            material["operator"] = json!(operator.name());
            if operator == crate::BlendOperator::Add && r.next_f32() < 0.6 {
                material["intensity"] = json!(round(r.range(1.0, 4.0)));
            }
            operators.push(Some(operator));
        }
    }
    let text = serde_json::to_string_pretty(&scene).expect("a JSON value serializes");
    let info = MixedOperatorInfo {
        scene: info,
        operators,
        lit,
    };
    (text, info)
}

/// Six decimals: the file is what the loader reads, so the values must survive the round trip.
fn round(x: f32) -> f64 {
    (f64::from(x) * 1e6).round() / 1e6
}

fn rgb(r: &mut SplitMix64) -> [f64; 3] {
    [
        round(r.next_f32()),
        round(r.next_f32()),
        round(r.next_f32()),
    ]
}

fn rotation(r: &mut SplitMix64) -> [f64; 3] {
    [
        round(r.range(-80.0, 80.0)),
        round(r.range(-80.0, 80.0)),
        round(r.range(-180.0, 180.0)),
    ]
}

fn material(r: &mut SplitMix64) -> Value {
    let mode = match r.next_u64() % 8 {
        0 => "opaque",
        1 => "mask",
        2 => "mask-blend",
        _ => "blend",
    };
    json!({
        "base_color": rgb(r),
        "alpha": round(r.range(0.05, 1.0)),
        "mode": mode,
        "cutoff": round(r.range(0.1, 0.9)),
        "double_sided": r.next_f32() < 0.5,
    })
}

fn random_object(r: &mut SplitMix64) -> (&'static str, Value) {
    let bounds = json!({"min": [-1.5, -1.5, -1.5], "max": [1.5, 1.5, 1.5]});
    match r.next_u64() % 6 {
        0 => (
            "soup",
            json!({
                "mesh": {"kind": "soup", "seed": r.next_u64() >> 11, "count": 1 + r.next_u64() % 60,
                         "bounds": bounds, "size": round(r.range(0.05, 0.8))},
                "material": material(r),
            }),
        ),
        1 => (
            "billboards",
            json!({
                "mesh": {"kind": "billboards", "seed": r.next_u64() >> 11, "count": 1 + r.next_u64() % 40,
                         "bounds": bounds, "size": round(r.range(0.05, 0.6))},
                "material": material(r),
            }),
        ),
        2 => (
            "plane",
            json!({
                "mesh": {"kind": "quad", "size": [round(r.range(0.5, 4.0)), round(r.range(0.5, 4.0))]},
                "transform": {"translate": [round(r.range(-1.0, 1.0)), round(r.range(-1.0, 1.0)), round(r.range(-1.0, 1.0))],
                              "rotate": rotation(r)},
                "material": material(r),
            }),
        ),
        3 => {
            // A mask card: corner alphas on both sides of the cutoff, so the contour runs
            // through both triangles.
            let cutoff = round(r.range(0.2, 0.8));
            let corner = [
                round(r.range(0.0, 1.0)),
                round(r.range(0.0, 1.0)),
                round(r.range(0.0, 1.0)),
                round(r.range(0.0, 1.0)),
            ];
            (
                "card",
                json!({
                    "mesh": {"kind": "quad", "size": [round(r.range(0.5, 3.0)), round(r.range(0.5, 3.0))],
                             "corner_alpha": corner},
                    "transform": {"translate": [round(r.range(-1.0, 1.0)), round(r.range(-1.0, 1.0)), round(r.range(-1.0, 1.0))],
                                  "rotate": rotation(r)},
                    "material": {"base_color": rgb(r), "alpha": 1.0,
                                 "mode": if r.next_f32() < 0.5 { "mask" } else { "mask-blend" },
                                 "cutoff": cutoff, "double_sided": true},
                }),
            )
        }
        4 => (
            // Long thin planes along the view axis: they cross the near and far planes.
            "crossing",
            json!({
                "mesh": {"kind": "quad", "size": [round(r.range(0.3, 2.0)), round(r.range(20.0, 60.0))]},
                "transform": {"translate": [round(r.range(-0.8, 0.8)), round(r.range(-0.8, 0.8)), 0.0],
                              "rotate": [round(90.0 + r.range(-20.0, 20.0)), round(r.range(-30.0, 30.0)), 0.0]},
                "material": material(r),
            }),
        ),
        _ => (
            // Layers turned away from the view: many depths per pixel, none coplanar.
            "layers",
            json!({
                "mesh": {"kind": "layers", "count": 2 + r.next_u64() % 12, "spacing": round(r.range(0.02, 0.3)),
                         "size": [round(r.range(1.0, 4.0)), round(r.range(1.0, 4.0))],
                         "color_from": rgb(r), "color_to": rgb(r),
                         "alpha_from": round(r.range(0.05, 1.0)), "alpha_to": round(r.range(0.05, 1.0))},
                "transform": {"translate": [0.0, 0.0, round(r.range(-0.5, 0.5))], "rotate": rotation(r)},
                "material": {"base_color": [1, 1, 1], "alpha": 1.0, "mode": "blend", "double_sided": true},
            }),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_seed_loads_and_the_same_seed_gives_the_same_text() {
        let mut kinds = std::collections::BTreeSet::new();
        let (mut ortho, mut reverse) = (0, 0);
        for seed in 0..300 {
            let (text, info) = random_scene_json(seed);
            assert_eq!(text, random_scene_json(seed).0);
            let scene = crate::parse(&text, &format!("random-{seed}"))
                .unwrap_or_else(|e| panic!("seed {seed}: {e}\n{text}"));
            assert_eq!(
                [scene.resolution.width, scene.resolution.height],
                info.resolution
            );
            assert_eq!(scene.camera.reverse_z, info.reverse_z);
            kinds.extend(info.objects.iter().copied());
            ortho += usize::from(info.orthographic);
            reverse += usize::from(info.reverse_z);
        }
        // Every kind of content and both conventions appear in a few hundred seeds.
        assert_eq!(kinds.len(), 6, "{kinds:?}");
        assert!((50..250).contains(&ortho) && (100..200).contains(&reverse));
    }

    #[test]
    fn mixed_operator_seeds_load_and_mix_every_operator() {
        use crate::BlendOperator;
        let mut seen = std::collections::BTreeMap::new();
        let (mut lit, mut mixed_scenes) = (0, 0);
        for seed in 0..200 {
            let (text, info) = random_mixed_operator_scene_json(seed);
            assert_eq!(text, random_mixed_operator_scene_json(seed).0);
            let scene = crate::parse(&text, &format!("random-ops-{seed}"))
                .unwrap_or_else(|e| panic!("seed {seed}: {e}\n{text}"));
            let [w, h] = info.scene.resolution;
            assert!((48..=64).contains(&w) && (48..=64).contains(&h));
            assert_eq!([scene.resolution.width, scene.resolution.height], [w, h]);
            for op in info.operators.iter().flatten() {
                *seen.entry(op.name()).or_insert(0) += 1;
            }
            let used = scene.operators_used();
            assert!(
                info.operators
                    .iter()
                    .flatten()
                    .all(|op| *op == BlendOperator::Over || used.contains(op)),
                "seed {seed}: {used:?} vs {:?}",
                info.operators
            );
            mixed_scenes += usize::from(used.len() >= 2);
            lit += usize::from(scene.materials.iter().any(crate::Material::is_lit));
            // Same geometry as the plain generator's seed: only materials and size differ.
            let plain = crate::parse(&random_scene_json(seed).0, "plain").expect("plain seed");
            assert_eq!(plain.vertices.len(), scene.vertices.len(), "seed {seed}");
        }
        assert_eq!(seen.len(), 4, "{seen:?}");
        assert!(seen.values().all(|&n| n >= 40), "{seen:?}");
        assert!(mixed_scenes >= 50 && lit >= 50, "{mixed_scenes} {lit}");
    }

    #[test]
    fn animated_seeds_load_and_move() {
        for seed in 0..200 {
            let (text, _) = random_animated_scene_json(seed);
            assert_eq!(text, random_animated_scene_json(seed).0);
            let frames = crate::parse_frames(&text, &format!("random-{seed}"))
                .unwrap_or_else(|e| panic!("seed {seed}: {e}\n{text}"));
            assert!((3..=6).contains(&frames.count()));
            let first = frames.frame(0).expect("frame 0");
            let last = frames.frame(frames.count() - 1).expect("last frame");
            assert_ne!(first.camera.view_proj, last.camera.view_proj, "seed {seed}");
        }
    }
}
