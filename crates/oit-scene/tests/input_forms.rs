//! Only the documented input forms are accepted (docs/scene-format.md): every struct of the
//! format is a JSON object with the listed fields, never serde's positional array form; a
//! UTF-8 byte order mark is skipped. Every error names the JSON path of the offending value
//! and says what is allowed in JSON terms, never in Rust types.

mod common;

use common::{fail, load_ok, with};
use oit_scene::Problem;
use serde_json::{Value, json};

/// A valid scene that uses every struct of the format at least once.
fn every_struct() -> Value {
    json!({
        "name": "forms",
        "description": "every struct",
        "resolution": [32, 16],
        "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 50},
        "background": [0, 0, 0],
        "reverse_z": true,
        "lighting": {"directional": {"direction": [0, 0, -1], "color": [1, 1, 1], "ambient": [0.1, 0.1, 0.1]}},
        "objects": [
            {"mesh": {"kind": "quad", "size": [1, 1], "corner_alpha": [1, 1, 1, 1]},
             "transform": {"translate": [0, 0, 0], "rotate": [0, 0, 0], "scale": [1, 1, 1]},
             "material": {"base_color": [1, 1, 1], "alpha": 0.5, "mode": "blend", "cutoff": 0.5,
                          "double_sided": false, "premultiplied": false, "intensity": 1},
             "render_group": 0, "alpha_index": 0,
             "instances": {"counts": [2, 1, 1], "spacing": [1, 0, 0]}},
            {"mesh": {"kind": "soup", "seed": 1, "count": 3, "size": 0.1,
                      "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]},
                      "color_min": [0, 0, 0], "color_max": [1, 1, 1], "alpha_min": 0, "alpha_max": 1}},
            {"mesh": {"kind": "layers", "count": 2, "spacing": 0.1, "size": [1, 1],
                      "color_from": [1, 1, 1], "color_to": [1, 1, 1], "alpha_from": 0.5, "alpha_to": 0.5}},
            {"mesh": {"kind": "box", "size": [1, 1, 1]}},
            {"mesh": {"kind": "uv-sphere", "radius": 0.5, "segments": 8, "rings": 4}},
            {"mesh": {"kind": "torus", "major_radius": 0.5, "minor_radius": 0.2, "segments": 8, "tube_segments": 4}},
            {"mesh": {"kind": "cylinder", "radius": 0.5, "height": 1, "segments": 8, "capped": true}},
            {"mesh": {"kind": "billboards", "seed": 2, "count": 3,
                      "bounds": {"min": [-1, -1, -1], "max": [1, 1, 1]}}}
        ]
    })
}

/// The dotted path (`objects[0].material.alpha`) of a JSON pointer.
fn dotted(pointer: &str) -> String {
    let mut out = String::new();
    for part in pointer.split('/').skip(1) {
        if part.parse::<usize>().is_ok() {
            out.push_str(&format!("[{part}]"));
        } else {
            if !out.is_empty() {
                out.push('.');
            }
            out.push_str(part);
        }
    }
    if out.is_empty() { "(root)".into() } else { out }
}

/// Every pointer into `v` (objects and arrays included), in document order.
fn pointers(v: &Value, at: String, out: &mut Vec<String>) {
    out.push(at.clone());
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                pointers(x, format!("{at}/{k}"), out);
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                pointers(x, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
}

/// An object's values as an array (serde's positional form, fields in alphabetical order).
fn positional(v: &Value) -> Value {
    Value::Array(v.as_object().unwrap().values().cloned().collect())
}

/// `common::with` for a pointer that may be the root.
fn replaced(v: &Value, pointer: &str, new: Value) -> Value {
    if pointer.is_empty() {
        new
    } else {
        with(v.clone(), pointer, new)
    }
}

#[test]
fn the_struct_battery_is_a_valid_scene() {
    let s = load_ok(&every_struct());
    // 2 instances of the quad, then one draw per other object (two layers).
    assert_eq!(s.draws.len(), 2 + 1 + 2 + 5);
}

/// Each struct of the format in serde's positional form (its field values in declaration
/// order, which serde's derive accepts), and one of its fields the error must name.
fn positional_forms() -> Vec<(&'static str, Value, &'static str)> {
    vec![
        (
            "",
            json!(["p", "", [8, 8], {"eye": [0, 0, 5], "target": [0, 0, 0]}, [0, 0, 0], true, "unlit", []]),
            "objects",
        ),
        (
            "/camera",
            json!([[0, 0, 5], [0, 0, 0], [0, 1, 0], 45, null, 0.1, 50]),
            "eye",
        ),
        (
            "/camera",
            json!({"eye": [0, 0, 5], "target": [0, 0, 0], "orthographic": [4]}),
            "height",
        ),
        (
            "/lighting/directional",
            json!([[0, 0, -1], [1, 1, 1], [0.1, 0.1, 0.1]]),
            "direction",
        ),
        (
            "/objects/0",
            json!([{"kind": "quad"}, {}, {"alpha": 0.5, "mode": "blend"}, 0, 0, null]),
            "mesh",
        ),
        (
            "/objects/0/transform",
            json!([[0, 0, 0], [0, 0, 0], [1, 1, 1]]),
            "translate",
        ),
        (
            "/objects/0/material",
            json!([[1, 1, 1], 0.5, "blend", 0.5, false, false, 1]),
            "base_color",
        ),
        (
            "/objects/0/instances",
            json!([[2, 1, 1], [1, 0, 0]]),
            "counts",
        ),
        (
            "/objects/1/mesh/bounds",
            json!([[-1, -1, -1], [1, 1, 1]]),
            "min",
        ),
    ]
}

#[test]
fn structs_given_as_arrays_are_errors_naming_the_field_and_its_fields() {
    for (pointer, form, field) in positional_forms() {
        let (path, problem) = fail(&replaced(&every_struct(), pointer, form));
        let want = if field == "height" {
            "camera.orthographic".into()
        } else {
            dotted(pointer)
        };
        assert_eq!(path, want, "{pointer}: {problem}");
        let Problem::WrongType { found, expected } = &problem else {
            panic!("{pointer}: {problem:?}")
        };
        assert!(found.contains("array"), "{pointer}: {problem}");
        assert!(
            expected.contains("object") && expected.contains(&format!("`{field}`")),
            "{pointer}: {problem}"
        );
    }
}

/// Words of Rust's type system or serde's data model that must not reach a scene author.
fn rust_words(message: &str) -> Vec<String> {
    const WORDS: &[&str] = &[
        "struct", "enum", "usize", "isize", "u8", "u16", "u32", "u64", "i8", "i16", "i32", "i64",
        "f64", "sequence", "map", "Vec", "Option", "tuple", "newtype", "unit",
    ];
    message
        .split(|c: char| !c.is_ascii_alphanumeric() && c != '_')
        .filter(|w| WORDS.contains(w) || (w.starts_with("Raw") && w.len() > 3))
        .map(str::to_string)
        .collect()
}

#[test]
fn wrong_types_everywhere_name_the_field_in_json_terms() {
    let base = every_struct();
    let mut all = Vec::new();
    pointers(&base, String::new(), &mut all);
    let replacements = [
        json!(3),
        json!(-1),
        json!(1.5),
        json!("x"),
        json!(true),
        json!(null),
        json!([]),
        json!([1, 2]),
        json!({}),
        json!({"zz": 1}),
    ];
    let mut bad = Vec::new();
    let mut errors = 0;
    for pointer in &all {
        let original = base.pointer(pointer).unwrap();
        let mut edits: Vec<Value> = replacements
            .iter()
            .filter(|r| std::mem::discriminant(*r) != std::mem::discriminant(original))
            .cloned()
            .collect();
        if original.is_object() {
            edits.push(positional(original));
            let mut extra = original.clone();
            extra["unknown_field"] = json!(1);
            edits.push(extra);
        }
        for edit in edits {
            let text = replaced(&base, pointer, edit.clone()).to_string();
            let err = match oit_scene::parse(&text, "forms.json") {
                Ok(_) if edit.is_null() => continue, // an optional field left out
                Ok(_) => {
                    bad.push(format!("{pointer} = {edit}: accepted"));
                    continue;
                }
                Err(e) => e,
            };
            errors += 1;
            let line = err.to_string();
            let want = dotted(pointer);
            let path = err.path().unwrap_or_default();
            let names_field = path == want
                || (want == "(root)" && !path.is_empty())
                || path.starts_with(&format!("{want}.")) && !want.contains('(')
                || path.starts_with(&format!("{want}["));
            if !names_field {
                bad.push(format!(
                    "{pointer} = {edit}: path `{path}`, want `{want}`: {line}"
                ));
            }
            let words = rust_words(&line);
            if !words.is_empty() || line.contains('\n') || !line.contains("; allowed: ") {
                bad.push(format!("{pointer} = {edit}: {words:?} in {line}"));
            }
        }
    }
    assert!(errors > 500, "only {errors} errors");
    assert!(
        bad.is_empty(),
        "{} bad messages:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn unknown_fields_and_enum_forms_are_named_in_json_terms() {
    let cases = [
        ("/lighting", json!("directional")),
        ("/lighting", json!({"unlit": {}})),
        ("/lighting", json!({"directional": 3})),
        ("/lighting", json!({"directional": {}, "unlit": null})),
        ("/objects/0/material/mode", json!({"blend": 1})),
        ("/objects/0/material/mode", json!(["blend"])),
        ("/objects/0/mesh/kind", json!(["quad"])),
    ];
    for (pointer, edit) in cases {
        let line = oit_scene::parse(
            &with(every_struct(), pointer, edit.clone()).to_string(),
            "forms.json",
        )
        .unwrap_err()
        .to_string();
        assert!(rust_words(&line).is_empty(), "{pointer} = {edit}: {line}");
        assert!(
            line.starts_with(&format!("forms.json: {}", dotted(pointer))),
            "{line}"
        );
    }
}

#[test]
fn odd_keys_are_quoted_in_paths_and_messages_stay_on_one_line() {
    // Found by the fuzzer: an empty key gave an empty path, a tab in a key a two-part line.
    let cases = [
        ("", json!(1), "[\"\"]"),
        ("/camera/f\tov_y", json!(45), "camera[\"f\\tov_y\"]"),
        (
            "/objects/0/material/a\nb",
            json!(1),
            "objects[0].material[\"a\\nb\"]",
        ),
        (
            "/objects/0/material/a.b",
            json!(1),
            "objects[0].material[\"a.b\"]",
        ),
    ];
    for (pointer, value, want) in cases {
        let v = if pointer.is_empty() {
            let mut v = every_struct();
            v[""] = value;
            v
        } else {
            with(every_struct(), pointer, value)
        };
        let err = oit_scene::parse(&v.to_string(), "keys.json").unwrap_err();
        assert_eq!(err.path(), Some(want), "{err}");
        assert!(
            matches!(err.problem(), Some(Problem::UnknownField { .. })),
            "{err:?}"
        );
        let line = err.to_string();
        assert!(!line.chars().any(char::is_control), "{line:?}");
    }
}

#[test]
fn a_utf8_byte_order_mark_is_skipped() {
    let text = every_struct().to_string();
    let scene = oit_scene::parse(&format!("\u{feff}{text}"), "bom.json").unwrap();
    assert_eq!(scene.name, "forms");
    // Only at the start: elsewhere it is not JSON whitespace.
    let (_, problem) = common::fail_text(&format!("{} \u{feff}", &text));
    assert!(matches!(problem, Problem::Syntax { .. }), "{problem:?}");
}

// ---- glTF: the same rules for the asset's JSON ----

use common::build::{Data, TRI, single_mesh};
use oit_scene::{LoadOptions, SceneError};

/// A one-triangle glTF JSON asset with an embedded buffer.
fn small_gltf() -> Value {
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let mut doc = single_mesh(pos, json!({"mode": 4}));
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.5]}, "alphaMode": "BLEND",
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}}}]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]);
    serde_json::from_str(&d.gltf(doc)).unwrap()
}

fn load_gltf(text: &str) -> Result<oit_scene::Scene, SceneError> {
    oit_scene::parse_gltf(text.as_bytes(), "asset.gltf", &LoadOptions::default())
}

#[test]
fn gltf_objects_given_as_arrays_are_errors_at_their_pointer() {
    assert_eq!(
        load_gltf(&small_gltf().to_string())
            .unwrap()
            .triangle_count(),
        1
    );
    for (pointer, form, field) in [
        ("/asset", json!(["2.0"]), "version"),
        ("/nodes/0", json!([0]), "mesh"),
        (
            "/cameras/0/perspective",
            json!([1.0, 0.8, 100, 0.1]),
            "yfov",
        ),
        (
            "/materials/0/pbrMetallicRoughness",
            json!([[1, 1, 1, 1]]),
            "baseColorFactor",
        ),
    ] {
        let err = load_gltf(&with(small_gltf(), pointer, form).to_string()).unwrap_err();
        assert_eq!(err.path(), Some(pointer), "{err}");
        let Some(Problem::WrongType { found, expected }) = err.problem() else {
            panic!("{pointer}: {err:?}")
        };
        assert!(found.contains("array"), "{err}");
        assert!(expected.contains(&format!("`{field}`")), "{err}");
        assert!(rust_words(&err.to_string()).is_empty(), "{err}");
    }
}

#[test]
fn gltf_wrong_types_are_named_at_their_pointer_in_json_terms() {
    let base = small_gltf();
    let mut all = Vec::new();
    pointers(&base, String::new(), &mut all);
    let mut bad = Vec::new();
    let mut typed = 0;
    for pointer in all.iter().filter(|p| !p.is_empty()) {
        let original = base.pointer(pointer).unwrap();
        for edit in [
            json!(-1),
            json!(1.5),
            json!("x"),
            json!(true),
            json!([]),
            json!({}),
        ] {
            if std::mem::discriminant(&edit) == std::mem::discriminant(original) {
                continue;
            }
            let Err(err) = load_gltf(&with(base.clone(), pointer, edit.clone()).to_string()) else {
                continue; // glTF ignores unknown extension settings and the like
            };
            let line = err.to_string();
            if !rust_words(&line).is_empty() || line.contains('\n') || !line.contains("; allowed: ")
            {
                bad.push(format!("{pointer} = {edit}: {line}"));
            }
            if let Some(Problem::WrongType { .. }) = err.problem() {
                typed += 1;
                if !err.path().unwrap().starts_with(pointer.as_str()) {
                    bad.push(format!("{pointer} = {edit}: wrong path: {line}"));
                }
            }
        }
    }
    assert!(typed > 100, "only {typed} type errors");
    assert!(
        bad.is_empty(),
        "{} bad messages:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn a_utf8_byte_order_mark_before_gltf_json_is_skipped() {
    let text = format!("\u{feff}{}", small_gltf());
    assert_eq!(load_gltf(&text).unwrap().triangle_count(), 1);
}
