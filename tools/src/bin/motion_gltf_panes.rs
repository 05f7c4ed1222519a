//! Writes scenes/motion/motion-gltf-panes.gltf and its .bin: four coloured, double-sided BLEND
//! panes (alpha 0.4–0.55) that rotate and slide through each other over 2 seconds (LINEAR
//! rotation and translation channels), seen from a perspective camera node on a slow arc and
//! dolly. Made for oit-lab, CC0 1.0 (scenes/motion/motion-gltf-panes.LICENSE.md).
//!
//! `cargo run -p oit-tools --bin motion_gltf_panes [-- OUT_DIR]` (default `scenes/motion`).
//! The output is deterministic: only exact binary fractions and square roots (correctly
//! rounded everywhere) go into it, so regenerating gives identical bytes; the oit-scene test
//! `bundled_gltf_panes_match_their_generator` includes this file and checks the committed
//! files against [`motion_gltf_panes`].

use serde_json::{Value, json};

/// File stem of the asset.
pub const STEM: &str = "motion-gltf-panes";

/// Binary data with the bufferViews and accessors that describe it.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    /// Appends `bytes` as a bufferView (4-byte aligned) with one accessor over it.
    fn add(&mut self, bytes: &[u8], accessor: Value) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": bytes.len()}));
        self.bytes.extend_from_slice(bytes);
        let mut a = accessor;
        a["bufferView"] = json!(self.views.len() - 1);
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    /// FLOAT elements of `n` components; `bounds` adds min and max (required for POSITION
    /// and for animation inputs).
    fn floats(&mut self, values: &[f32], ty: &str, n: usize, bounds: bool) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|x| x.to_le_bytes()).collect();
        let mut a = json!({"componentType": 5126, "type": ty, "count": values.len() / n});
        if bounds {
            let fold = |f: fn(f32, f32) -> f32| -> Vec<f64> {
                (0..n)
                    .map(|k| {
                        let column = values.iter().skip(k).step_by(n).copied();
                        f64::from(column.reduce(f).unwrap_or(0.0))
                    })
                    .collect()
            };
            a["min"] = json!(fold(f32::min));
            a["max"] = json!(fold(f32::max));
        }
        self.add(&bytes, a)
    }
}

/// The unit quaternion (x, y, z, w) of a turn about axis `k` (0 = X, 1 = Y) by the angle whose
/// half-angle has sine `s` and cosine `c`.
fn turn(k: usize, s: f64, c: f64) -> [f32; 4] {
    let mut q = [0.0, 0.0, 0.0, c as f32];
    q[k] = s as f32;
    q
}

/// The glTF JSON (pretty-printed, ending in a newline) and the bytes of its `.bin` buffer.
pub fn motion_gltf_panes() -> (String, Vec<u8>) {
    let h = 0.5f64.sqrt();
    let mut bin = Bin::default();
    // One quad in the z = 0 plane, counter-clockwise seen from +Z: 1.5 × 1.0.
    let positions = bin.floats(
        &[
            -0.75, -0.5, 0.0, 0.75, -0.5, 0.0, 0.75, 0.5, 0.0, -0.75, 0.5, 0.0,
        ],
        "VEC3",
        3,
        true,
    );
    let index_bytes: Vec<u8> = [0u16, 1, 2, 0, 2, 3]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let indices = bin.add(
        &index_bytes,
        json!({"componentType": 5123, "type": "SCALAR", "count": 6}),
    );
    let t3 = bin.floats(&[0.0, 1.0, 2.0], "SCALAR", 1, true);
    let t2 = bin.floats(&[0.0, 2.0], "SCALAR", 1, true);
    // Half a turn about an axis in two quarter turns (each key pair 90° apart).
    let half_turn =
        |k: usize| -> Vec<f32> { [turn(k, 0.0, 1.0), turn(k, h, h), turn(k, 1.0, 0.0)].concat() };
    let red_rotation = bin.floats(&half_turn(1), "VEC4", 4, false);
    let green_translation = bin.floats(&[0.0, 0.15, -1.25, 0.0, 0.15, 1.25], "VEC3", 3, false);
    let blue_translation = bin.floats(&[1.125, -0.1, 0.0, -1.125, -0.1, 0.0], "VEC3", 3, false);
    let yellow_rotation = bin.floats(&half_turn(0), "VEC4", 4, false);
    // The camera arcs from −22.5° to +22.5° about +Y, looking at the origin, and dollies from
    // 5.5 to 4.75 and back (sin and cos of 22.5° and 11.25° from half-angle square roots).
    let (s22, c22) = (
        (2.0 - 2f64.sqrt()).sqrt() / 2.0,
        (2.0 + 2f64.sqrt()).sqrt() / 2.0,
    );
    let (s11, c11) = (((1.0 - c22) / 2.0).sqrt(), ((1.0 + c22) / 2.0).sqrt());
    let eye = |r: f64, s: f64, c: f64| [(r * s) as f32, 0.5, (r * c) as f32];
    let camera_translation = bin.floats(
        &[eye(5.5, -s22, c22), eye(4.75, 0.0, 1.0), eye(5.5, s22, c22)].concat(),
        "VEC3",
        3,
        false,
    );
    let camera_rotation = bin.floats(
        &[turn(1, -s11, c11), turn(1, 0.0, 1.0), turn(1, s11, c11)].concat(),
        "VEC4",
        4,
        false,
    );
    let linear = |input: usize, output: usize| json!({"input": input, "output": output, "interpolation": "LINEAR"});
    let channel = |sampler: usize, node: usize, path: &str| json!({"sampler": sampler, "target": {"node": node, "path": path}});
    let panes = [
        ("red", [0.9, 0.15, 0.1, 0.5]),
        ("green", [0.1, 0.8, 0.2, 0.45]),
        ("blue", [0.15, 0.3, 0.95, 0.55]),
        ("yellow", [0.95, 0.85, 0.1, 0.4]),
    ];
    let materials: Vec<Value> = panes
        .iter()
        .map(|(name, color)| {
            json!({
                "name": name,
                "pbrMetallicRoughness": {"baseColorFactor": color, "metallicFactor": 0.0},
                "alphaMode": "BLEND",
                "doubleSided": true
            })
        })
        .collect();
    let meshes: Vec<Value> = (0..panes.len())
        .map(|m| {
            json!({
                "name": format!("{} pane", panes[m].0),
                "primitives": [{"attributes": {"POSITION": positions}, "indices": indices, "material": m}]
            })
        })
        .collect();
    let doc = json!({
        "asset": {
            "version": "2.0",
            "generator": "oit-lab tools/src/bin/motion_gltf_panes.rs",
            "copyright": "oit-lab contributors: made for oit-lab, CC0 1.0"
        },
        "scene": 0,
        "scenes": [{"name": "panes", "nodes": [0, 1, 2, 3, 4]}],
        "nodes": [
            {"name": "camera", "camera": 0, "translation": [0.0, 0.5, 5.5]},
            {"name": "red (turns about Y)", "mesh": 0},
            {"name": "green (slides along Z)", "mesh": 1, "translation": [0.0, 0.15, -1.25]},
            {"name": "blue (slides along X)", "mesh": 2, "rotation": [0.0, h, 0.0, h], "translation": [1.125, -0.1, 0.0]},
            {"name": "yellow (turns about X)", "mesh": 3, "translation": [0.0, 0.1, 0.25], "scale": [0.75, 0.75, 0.75]}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.5, "zfar": 20.0}}],
        "meshes": meshes,
        "materials": materials,
        "animations": [{
            "name": "panes pass through each other",
            "channels": [
                channel(0, 1, "rotation"),
                channel(1, 2, "translation"),
                channel(2, 3, "translation"),
                channel(3, 4, "rotation"),
                channel(4, 0, "translation"),
                channel(5, 0, "rotation")
            ],
            "samplers": [
                linear(t3, red_rotation),
                linear(t2, green_translation),
                linear(t2, blue_translation),
                linear(t3, yellow_rotation),
                linear(t3, camera_translation),
                linear(t3, camera_rotation)
            ]
        }],
        "buffers": [{"uri": format!("{STEM}.bin"), "byteLength": bin.bytes.len()}],
        "bufferViews": bin.views,
        "accessors": bin.accessors
    });
    let mut text = serde_json::to_string_pretty(&doc).unwrap_or_default();
    text.push('\n');
    (text, bin.bytes)
}

fn main() -> std::process::ExitCode {
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "scenes/motion".to_string());
    let dir = std::path::Path::new(&dir);
    let (text, bytes) = motion_gltf_panes();
    for (name, data) in [
        (format!("{STEM}.gltf"), text.as_bytes()),
        (format!("{STEM}.bin"), &bytes[..]),
    ] {
        let path = dir.join(name);
        if let Err(e) = std::fs::write(&path, data) {
            eprintln!("motion_gltf_panes: {}: {e}", path.display());
            return std::process::ExitCode::FAILURE;
        }
        println!("wrote {}", path.display());
    }
    std::process::ExitCode::SUCCESS
}
