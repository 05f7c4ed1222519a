//! `parse` never panics: random text, mutated bundled scenes and random edits of a valid scene
//! all come back as `Ok` or `Err`; neither does loading a glTF asset with flipped bytes, cut
//! files, edited GLB length fields or edited glTF JSON. Sizes stay small so the suite runs in
//! seconds.

mod common;

use proptest::prelude::*;
use serde_json::{Value, json};

/// Values that sit on or past every boundary the loader checks.
fn nasty_number_text() -> impl Strategy<Value = &'static str> {
    prop::sample::select(vec![
        "0",
        "-0",
        "-1",
        "1",
        "2",
        "3",
        "0.5",
        "1.0000001",
        "1e-45",
        "1e-39",
        "1e38",
        "3.4e38",
        "-3.4e38",
        "1e39",
        "1e999",
        "-1e999",
        "NaN",
        "Infinity",
        "4294967295",
        "4294967296",
        "18446744073709551616",
        "1e10",
        "180",
        "8192",
        "8193",
        "\"x\"",
        "null",
        "true",
        "[]",
        "{}",
        "[1, 2]",
        "[0, 0, 0]",
        "[1e39, 0, 0]",
    ])
}

fn nasty_value() -> impl Strategy<Value = Value> {
    prop_oneof![
        prop::sample::select(vec![
            json!(0),
            json!(-1),
            json!(1),
            json!(0.5),
            json!(1e-45),
            json!(3.4e38),
            json!(-3.4e38),
            json!(1e39),
            json!(4294967295u64),
            json!(1u64 << 40),
            json!("blend"),
            json!("mask-blend"),
            json!("layers"),
            json!("billboards"),
            json!(null),
            json!(true),
            json!([]),
            json!({}),
            json!([0, 0, 0]),
            json!([1, 1, 1]),
            json!([0, 1, 0]),
            json!([0, 0, 5]),
            json!([3e38, 3e38, 3e38]),
            json!({"height": 0}),
            json!({"directional": {"direction": [0, 0, 0]}}),
            json!({"counts": [2, 2, 2], "spacing": [3e38, 0, 0]}),
        ]),
        any::<f64>().prop_map(|x| json!(x)),
        any::<i64>().prop_map(|x| json!(x)),
    ]
}

/// JSON pointers into [`base_scene`] (some to members that do not exist yet).
const POINTERS: &[&str] = &[
    "/resolution",
    "/resolution/0",
    "/resolution/1",
    "/background",
    "/background/1",
    "/reverse_z",
    "/lighting",
    "/camera/eye",
    "/camera/eye/2",
    "/camera/target",
    "/camera/up",
    "/camera/up/1",
    "/camera/fov_y",
    "/camera/near",
    "/camera/far",
    "/camera/orthographic",
    "/camera/extra",
    "/objects/0/mesh/kind",
    "/objects/0/mesh/count",
    "/objects/0/mesh/spacing",
    "/objects/0/mesh/size",
    "/objects/0/mesh/alpha_from",
    "/objects/0/mesh/color_to",
    "/objects/0/transform/scale",
    "/objects/0/transform/scale/0",
    "/objects/0/transform/rotate",
    "/objects/0/transform/translate",
    "/objects/0/material/alpha",
    "/objects/0/material/mode",
    "/objects/0/material/cutoff",
    "/objects/0/material/intensity",
    "/objects/0/material/base_color",
    "/objects/0/instances",
    "/objects/0/render_group",
    "/objects/0/alpha_index",
    "/objects/1/mesh/kind",
    "/objects/1/mesh/seed",
    "/objects/1/mesh/count",
    "/objects/1/mesh/size",
    "/objects/1/mesh/bounds",
    "/objects/1/mesh/bounds/min",
    "/objects/1/mesh/alpha_min",
    "/objects/1/mesh/color_max",
    "/objects/2/mesh/kind",
    "/objects/2/mesh/segments",
    "/objects/2/mesh/rings",
    "/objects/2/mesh/radius",
    "/objects/2/mesh/minor_radius",
    "/objects/2/mesh/major_radius",
    "/objects/2/mesh/tube_segments",
    "/objects/2/mesh/capped",
    "/objects/2/mesh/height",
    "/objects/2/mesh",
    "/objects/1",
];

fn base_scene() -> Value {
    json!({
        "name": "fuzz",
        "resolution": [64, 48],
        "camera": {"eye": [0, 1, 5], "target": [0, 0, 0], "near": 0.1, "far": 50},
        "lighting": {"directional": {"direction": [0, -1, -1], "ambient": [0.1, 0.1, 0.1]}},
        "objects": [
            {"mesh": {"kind": "layers", "count": 4, "spacing": 0.2, "size": [2, 2]},
             "material": {"mode": "blend", "alpha": 0.5},
             "instances": {"counts": [2, 1, 1], "spacing": [0.5, 0, 0]}},
            {"mesh": {"kind": "billboards", "seed": 3, "count": 20, "size": 0.1,
                      "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}},
             "material": {"mode": "mask-blend"}},
            {"mesh": {"kind": "torus", "segments": 8, "tube_segments": 6},
             "transform": {"rotate": [30, 0, 0]}, "material": {"mode": "opaque"}}
        ]
    })
}

/// Like `common::with`, but an edit that cannot reach its target (a scalar or a short array on
/// the way, left there by an earlier edit) replaces the blocking value instead of failing.
fn set_lenient(v: &mut Value, pointer: &str, new: Value) {
    let mut cur = v;
    for part in pointer.split('/').skip(1) {
        let index = part.parse::<usize>().ok();
        let reachable = match (&*cur, index) {
            (Value::Array(a), Some(i)) => i < a.len(),
            (Value::Object(_), _) => true,
            _ => false,
        };
        if !reachable {
            *cur = Value::Object(Default::default());
        }
        cur = match cur {
            Value::Array(a) => &mut a[index.unwrap_or(0)],
            Value::Object(o) => o.entry(part.to_string()).or_insert(Value::Null),
            _ => return,
        };
    }
    *cur = new;
}

fn small_bundled_texts() -> Vec<String> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    [
        "sorted-quads",
        "depth-range",
        "foliage-cards",
        "opaque-interleaved",
        "alpha-extremes",
    ]
    .iter()
    .map(|n| std::fs::read_to_string(dir.join(format!("{n}.json"))).unwrap())
    .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn random_text_never_panics(text in ".{0,200}") {
        let _ = oit_scene::parse(&text, "fuzz.json");
    }

    #[test]
    fn edited_valid_scene_never_panics(
        edits in prop::collection::vec((prop::sample::select(POINTERS), nasty_value()), 1..4)
    ) {
        let mut v = base_scene();
        for (pointer, value) in edits {
            set_lenient(&mut v, pointer, value);
        }
        let _ = oit_scene::parse(&v.to_string(), "fuzz.json");
    }

    #[test]
    fn mutated_bundled_text_never_panics(
        which in 0usize..5,
        at in any::<prop::sample::Index>(),
        len in 0usize..12,
        replacement in nasty_number_text(),
    ) {
        let texts = small_bundled_texts();
        let text = &texts[which];
        // The files are ASCII, so any byte index is a character boundary.
        let start = at.index(text.len());
        let end = (start + len).min(text.len());
        let mutated = format!("{}{}{}", &text[..start], replacement, &text[end..]);
        let _ = oit_scene::parse(&mutated, "fuzz.json");
    }
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let deep = format!("{}{}", "[".repeat(100_000), "]".repeat(100_000));
    assert!(oit_scene::parse(&deep, "deep.json").is_err());
    let deep_mesh = format!(
        r#"{{"name":"d","camera":{{"eye":[0,0,5],"target":[0,0,0]}},"objects":[{{"mesh":{}{}}}]}}"#,
        "[".repeat(5000),
        "]".repeat(5000)
    );
    assert!(oit_scene::parse(&deep_mesh, "deep.json").is_err());
}

#[test]
fn fuzz_starting_points_are_valid_scenes() {
    // Edits start from valid scenes, so they reach validation and flattening, not just serde.
    let s = common::load_ok(&base_scene());
    assert_eq!(s.draws.len(), 2 * 4 + 1 + 1);
    for text in small_bundled_texts() {
        oit_scene::parse(&text, "bundled.json").unwrap();
    }
}

// ---- glTF: mutated GLB bytes and edited glTF JSON load as `Ok` or `Err`, never panic ----

use common::build::{Data, glb, png};

/// A small valid GLB exercising most of the loader: a two-level node hierarchy with TRS and
/// matrix, indexed and strip primitives, normalized colours and texcoords, a textured
/// material with a sampler and a texture transform, and a camera.
fn small_glb_json() -> (Value, Vec<u8>) {
    let mut d = Data::default();
    let pos = d.f32s(
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0],
        "VEC3",
    );
    let color = d.add(
        &[255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 64, 9, 9, 9, 9],
        5121,
        "VEC4",
        4,
        true,
    );
    let uv = d.u16s(&[0, 0, 65535, 0, 0, 65535, 65535, 65535], "VEC2", 4, true);
    let idx = d.u16s(&[0, 1, 2, 2, 1, 3], "SCALAR", 6, false);
    let image = d.view(&png(
        2,
        2,
        6,
        8,
        &[255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 0, 9, 9, 9, 9],
    ));
    let attrs = json!({"POSITION": pos, "COLOR_0": color, "TEXCOORD_0": uv});
    let doc = json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 2]}],
        "nodes": [
            {"translation": [1, 2, 3], "rotation": [0, 0.6, 0, 0.8], "scale": [1, -2, 1], "children": [1]},
            {"mesh": 0, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,-1,1]},
            {"camera": 0, "translation": [0, 0, 9]}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "meshes": [{"primitives": [
            {"attributes": attrs, "indices": idx, "material": 0},
            {"attributes": attrs, "mode": 5}
        ]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.5],
            "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [2, 2]}}}},
            "alphaMode": "BLEND", "emissiveFactor": [0.1, 0, 0]}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"wrapS": 33648}],
        "images": [{"bufferView": image, "mimeType": "image/png"}],
        "extensionsUsed": ["KHR_texture_transform"],
    });
    let mut text: Value = serde_json::from_str(&d.gltf(doc)).unwrap();
    // In a GLB the buffer is the BIN chunk, not a data URI.
    text["buffers"] = json!([{"byteLength": d.bytes.len()}]);
    (text, d.bytes.clone())
}

/// Pointers into [`small_glb_json`] that the edits below replace.
const GLTF_POINTERS: &[&str] = &[
    "/scene",
    "/scenes/0/nodes",
    "/nodes/0/scale",
    "/nodes/0/rotation",
    "/nodes/0/children",
    "/nodes/1/matrix",
    "/nodes/1/mesh",
    "/nodes/2/camera",
    "/cameras/0/type",
    "/cameras/0/perspective",
    "/cameras/0/perspective/yfov",
    "/cameras/0/perspective/znear",
    "/meshes/0/primitives/0/mode",
    "/meshes/0/primitives/0/indices",
    "/meshes/0/primitives/1/attributes/POSITION",
    "/meshes/0/primitives/1/attributes/COLOR_0",
    "/accessors/0/count",
    "/accessors/0/byteOffset",
    "/accessors/1/componentType",
    "/accessors/1/type",
    "/accessors/2/normalized",
    "/accessors/3/count",
    "/accessors/3/bufferView",
    "/bufferViews/0/byteLength",
    "/bufferViews/0/byteOffset",
    "/bufferViews/1/byteStride",
    "/bufferViews/4/byteLength",
    "/buffers/0/byteLength",
    "/buffers/0/uri",
    "/materials/0/alphaMode",
    "/materials/0/alphaCutoff",
    "/materials/0/pbrMetallicRoughness/baseColorFactor",
    "/materials/0/pbrMetallicRoughness/baseColorTexture/index",
    "/materials/0/emissiveFactor",
    "/images/0/mimeType",
    "/images/0/uri",
    "/images/0/bufferView",
    "/samplers/0/wrapS",
    "/extensionsRequired",
];

fn glb_of(doc: &Value, bin: &[u8]) -> Vec<u8> {
    glb(&doc.to_string(), Some(bin))
}

/// Loads `bytes` as `<tmp>/<name>` (one file per test, rewritten per case).
fn load_bytes(name: &str, bytes: &[u8]) -> Result<oit_scene::Scene, oit_scene::SceneError> {
    let path = std::env::temp_dir().join(format!("oit-nopanic-{}-{name}", std::process::id()));
    std::fs::write(&path, bytes).unwrap();
    let r = oit_scene::load(&path);
    let _ = std::fs::remove_file(&path);
    r
}

#[test]
fn small_glb_is_valid() {
    let (doc, bin) = small_glb_json();
    let s = load_bytes("valid.glb", &glb_of(&doc, &bin)).unwrap();
    // 2 indexed + 2 strip triangles, both primitives drawn.
    assert_eq!((s.draws.len(), s.triangle_count()), (2, 4));
    assert_eq!(s.textures.len(), 1);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 150, ..ProptestConfig::default() })]

    #[test]
    fn mutated_glb_bytes_never_panic(
        flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..6),
        cut in prop::option::of(any::<prop::sample::Index>()),
    ) {
        let (doc, bin) = small_glb_json();
        let mut bytes = glb_of(&doc, &bin);
        for (at, value) in flips {
            let i = at.index(bytes.len());
            bytes[i] = value;
        }
        if let Some(c) = cut {
            let n = c.index(bytes.len());
            bytes.truncate(n);
        }
        let _ = load_bytes("flip.glb", &bytes);
    }

    #[test]
    fn edited_glb_length_fields_never_panic(
        field in prop::sample::select(vec![4usize, 8, 12, 16]),
        bin_header in any::<bool>(),
        value in prop::sample::select(vec![0u32, 1, 4, 11, 12, 13, 20, 0x7fff_ffff, u32::MAX, 0x004E_4942]),
    ) {
        let (doc, bin) = small_glb_json();
        let mut bytes = glb_of(&doc, &bin);
        // Either a header/JSON-chunk field, or the BIN chunk's length or type.
        let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let at = if bin_header { 20 + json_len + (field % 8) } else { field };
        bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
        let _ = load_bytes("len.glb", &bytes);
    }

    #[test]
    fn edited_gltf_json_never_panics(
        edits in prop::collection::vec((prop::sample::select(GLTF_POINTERS), nasty_value()), 1..4)
    ) {
        let (mut doc, bin) = small_glb_json();
        for (pointer, value) in edits {
            set_lenient(&mut doc, pointer, value);
        }
        let _ = load_bytes("edit.glb", &glb_of(&doc, &bin));
    }
}
