//! Every class of invalid scene gives its own error variant at the right JSON path, on one line
//! that names the file and says what is allowed.

mod common;

use common::{fail, fail_text, minimal, scene_with, with};
use oit_scene::{MAX_TRIANGLES, Problem, Resolution, SceneError};
use serde_json::json;

#[test]
fn display_is_one_line_with_file_path_problem_and_allowed() {
    let objs = json!([{"mesh": {"kind": "quad"}}, {"mesh": {"kind": "quad"}}, {"mesh": {"kind": "quad"}},
                      {"mesh": {"kind": "quad"}, "material": {"alpha": 1.5}}]);
    let err = oit_scene::parse(&scene_with(objs).to_string(), "scenes/x.json").unwrap_err();
    assert_eq!(
        err.to_string(),
        "scenes/x.json: objects[3].material.alpha: 1.5 is outside [0, 1]; allowed: alpha in [0, 1]"
    );
    assert_eq!(err.file(), "scenes/x.json");
}

#[test]
fn nan_and_infinity_literals_are_non_finite() {
    let text = minimal().to_string();
    for bad in ["NaN", "Infinity", "-Infinity", "1e999", "-1e999"] {
        let t = text.replace("\"alpha\":0.5", &format!("\"alpha\":{bad}"));
        assert_ne!(t, text, "replacement did not apply");
        let (path, problem) = fail_text(&t);
        assert_eq!(path, "objects[0].material.alpha", "{bad}");
        assert!(
            matches!(&problem, Problem::NonFinite { value } if value == bad),
            "{bad}: {problem:?}"
        );
    }
}

#[test]
fn numbers_that_overflow_f32_are_non_finite() {
    let (path, problem) = fail(&with(minimal(), "/camera/eye/2", json!(1e39)));
    assert_eq!(path, "camera.eye[2]");
    assert!(matches!(problem, Problem::NonFinite { .. }), "{problem:?}");
    let (path, problem) = fail(&with(minimal(), "/objects/0/mesh/size", json!([1, -1e39])));
    assert_eq!(path, "objects[0].mesh.size[1]");
    assert!(matches!(problem, Problem::NonFinite { .. }), "{problem:?}");
}

#[test]
fn derived_values_that_overflow_are_rejected() {
    // Each factor is finite; the vertex 1.5 · 3e38 is not.
    let v = with(
        minimal(),
        "/objects/0/mesh",
        json!({"kind": "box", "size": [3, 1, 1]}),
    );
    let v = with(v, "/objects/0/transform/scale", json!([3e38, 1, 1]));
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].transform");
    assert!(
        matches!(problem, Problem::DerivedNonFinite { .. }),
        "{problem:?}"
    );
    // Instancing offsets 2 · 3e38 overflow.
    let v = with(
        minimal(),
        "/objects/0/instances",
        json!({"counts": [3, 1, 1], "spacing": [3e38, 0, 0]}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].instances");
    assert!(
        matches!(problem, Problem::DerivedNonFinite { .. }),
        "{problem:?}"
    );
    // Colour × intensity overflows.
    let v = with(minimal(), "/objects/0/material/intensity", json!(3e38));
    let v = with(v, "/objects/0/material/base_color", json!([10, 1, 1]));
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].material.intensity");
    assert!(
        matches!(problem, Problem::DerivedNonFinite { .. }),
        "{problem:?}"
    );
    // Eye and target so far apart that target - eye overflows.
    let v = with(minimal(), "/camera/eye", json!([-3e38, 0, 0]));
    let v = with(v, "/camera/target", json!([3e38, 0, 0]));
    let (path, problem) = fail(&v);
    assert_eq!(path, "camera.target");
    assert!(
        matches!(problem, Problem::DerivedNonFinite { .. }),
        "{problem:?}"
    );
}

#[test]
fn alpha_outside_unit_interval() {
    for a in [1.5, -0.25] {
        let (path, problem) = fail(&with(minimal(), "/objects/0/material/alpha", json!(a)));
        assert_eq!(path, "objects[0].material.alpha");
        assert_eq!(problem, Problem::AlphaOutOfRange { value: a as f32 });
    }
    let v = with(
        minimal(),
        "/objects/0/mesh",
        json!({"kind": "layers", "count": 2, "alpha_to": 1.01}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].mesh.alpha_to");
    assert_eq!(problem, Problem::AlphaOutOfRange { value: 1.01 });
    let v = with(
        minimal(),
        "/objects/0/mesh/corner_alpha",
        json!([1, 1, 2, 1]),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].mesh.corner_alpha[2]");
    assert_eq!(problem, Problem::AlphaOutOfRange { value: 2.0 });
}

#[test]
fn cutoff_outside_unit_interval() {
    let (path, problem) = fail(&with(minimal(), "/objects/0/material/cutoff", json!(1.25)));
    assert_eq!(path, "objects[0].material.cutoff");
    assert_eq!(problem, Problem::CutoffOutOfRange { value: 1.25 });
}

#[test]
fn negative_intensity() {
    let (path, problem) = fail(&with(minimal(), "/objects/0/material/intensity", json!(-2)));
    assert_eq!(path, "objects[0].material.intensity");
    assert_eq!(problem, Problem::NegativeIntensity { value: -2.0 });
}

#[test]
fn negative_colours() {
    let (path, problem) = fail(&with(
        minimal(),
        "/objects/0/material/base_color",
        json!([1, -0.5, 0]),
    ));
    assert_eq!(path, "objects[0].material.base_color[1]");
    assert_eq!(problem, Problem::NegativeColor { value: -0.5 });
    let (path, problem) = fail(&with(minimal(), "/background", json!([0, 0, -1])));
    assert_eq!(path, "background[2]");
    assert_eq!(problem, Problem::NegativeColor { value: -1.0 });
}

#[test]
fn non_positive_sizes_radii_and_scales() {
    let cases = [
        (
            json!({"kind": "quad", "size": [0, 1]}),
            "objects[0].mesh.size[0]",
            0.0,
        ),
        (
            json!({"kind": "box", "size": [1, 1, -2]}),
            "objects[0].mesh.size[2]",
            -2.0,
        ),
        (
            json!({"kind": "uv-sphere", "radius": -1}),
            "objects[0].mesh.radius",
            -1.0,
        ),
        (
            json!({"kind": "torus", "minor_radius": 0}),
            "objects[0].mesh.minor_radius",
            0.0,
        ),
        (
            json!({"kind": "torus", "major_radius": -1}),
            "objects[0].mesh.major_radius",
            -1.0,
        ),
        (
            json!({"kind": "cylinder", "height": 0}),
            "objects[0].mesh.height",
            0.0,
        ),
        (
            json!({"kind": "cylinder", "radius": -0.1}),
            "objects[0].mesh.radius",
            -0.1,
        ),
        (
            json!({"kind": "layers", "count": 3, "size": [1, 0]}),
            "objects[0].mesh.size[1]",
            0.0,
        ),
        (
            json!({"kind": "billboards", "seed": 1, "count": 3, "size": 0,
                   "bounds": {"min": [0, 0, 0], "max": [1, 1, 1]}}),
            "objects[0].mesh.size",
            0.0,
        ),
        (
            json!({"kind": "soup", "seed": 1, "count": 3, "size": -1,
                   "bounds": {"min": [0, 0, 0], "max": [1, 1, 1]}}),
            "objects[0].mesh.size",
            -1.0,
        ),
    ];
    for (mesh, want_path, value) in cases {
        let (path, problem) = fail(&with(minimal(), "/objects/0/mesh", mesh.clone()));
        assert_eq!(path, want_path, "{mesh}");
        assert_eq!(problem, Problem::NotPositive { value }, "{mesh}");
    }
    let (path, problem) = fail(&with(
        minimal(),
        "/objects/0/transform/scale",
        json!([1, 0, 1]),
    ));
    assert_eq!(path, "objects[0].transform.scale[1]");
    assert_eq!(problem, Problem::NotPositive { value: 0.0 });
    let v = with(minimal(), "/camera/orthographic", json!({"height": 0}));
    let (path, problem) = fail(&v);
    assert_eq!(path, "camera.orthographic.height");
    assert_eq!(problem, Problem::NotPositive { value: 0.0 });
}

#[test]
fn too_few_segments() {
    let cases = [
        (
            json!({"kind": "uv-sphere", "segments": 2}),
            "objects[0].mesh.segments",
            2,
            3,
        ),
        (
            json!({"kind": "uv-sphere", "rings": 1}),
            "objects[0].mesh.rings",
            1,
            2,
        ),
        (
            json!({"kind": "torus", "tube_segments": 0}),
            "objects[0].mesh.tube_segments",
            0,
            3,
        ),
        (
            json!({"kind": "torus", "segments": 2}),
            "objects[0].mesh.segments",
            2,
            3,
        ),
        (
            json!({"kind": "cylinder", "segments": 0}),
            "objects[0].mesh.segments",
            0,
            3,
        ),
    ];
    for (mesh, want_path, value, min) in cases {
        let (path, problem) = fail(&with(minimal(), "/objects/0/mesh", mesh.clone()));
        assert_eq!(path, want_path, "{mesh}");
        assert_eq!(problem, Problem::TooFewSegments { value, min }, "{mesh}");
    }
}

#[test]
fn torus_minor_radius_must_be_below_major() {
    let v = with(
        minimal(),
        "/objects/0/mesh",
        json!({"kind": "torus", "major_radius": 1, "minor_radius": 1}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].mesh.minor_radius");
    assert_eq!(
        problem,
        Problem::TorusRadii {
            minor: 1.0,
            major: 1.0
        }
    );
}

#[test]
fn empty_meshes() {
    let bounds = json!({"min": [0, 0, 0], "max": [1, 1, 1]});
    let cases = [
        (json!({"kind": "layers", "count": 0}), "layer count"),
        (
            json!({"kind": "soup", "seed": 1, "count": 0, "bounds": bounds}),
            "triangle count",
        ),
        (
            json!({"kind": "billboards", "seed": 1, "count": 0, "bounds": bounds}),
            "billboard count",
        ),
    ];
    for (mesh, what) in cases {
        let (path, problem) = fail(&with(minimal(), "/objects/0/mesh", mesh.clone()));
        assert_eq!(path, "objects[0].mesh.count", "{mesh}");
        assert_eq!(problem, Problem::EmptyMesh { what }, "{mesh}");
    }
    let v = with(
        minimal(),
        "/objects/0/instances",
        json!({"counts": [2, 0, 1], "spacing": [1, 1, 1]}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].instances.counts[1]");
    assert_eq!(
        problem,
        Problem::EmptyMesh {
            what: "instance count"
        }
    );
}

#[test]
fn empty_ranges_and_negative_spacing() {
    let v = with(
        minimal(),
        "/objects/0/mesh",
        json!({"kind": "soup", "seed": 1, "count": 4, "bounds": {"min": [0, 2, 0], "max": [1, 1, 1]}}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].mesh.bounds.max[1]");
    assert_eq!(problem, Problem::EmptyRange { min: 2.0, max: 1.0 });
    let v = with(
        minimal(),
        "/objects/0/mesh",
        json!({"kind": "billboards", "seed": 1, "count": 4, "alpha_min": 0.8, "alpha_max": 0.2,
               "bounds": {"min": [0, 0, 0], "max": [1, 1, 1]}}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].mesh.alpha_max");
    assert_eq!(problem, Problem::EmptyRange { min: 0.8, max: 0.2 });
    let v = with(
        minimal(),
        "/objects/0/mesh",
        json!({"kind": "layers", "count": 2, "spacing": -0.5}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0].mesh.spacing");
    assert_eq!(problem, Problem::NegativeSpacing { value: -0.5 });
}

#[test]
fn near_and_far() {
    let v = with(
        with(minimal(), "/camera/near", json!(10)),
        "/camera/far",
        json!(10),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "camera.far");
    assert_eq!(
        problem,
        Problem::NearNotBeforeFar {
            near: 10.0,
            far: 10.0
        }
    );
    let v = with(
        with(minimal(), "/camera/near", json!(20)),
        "/camera/far",
        json!(10),
    );
    assert_eq!(
        fail(&v).1,
        Problem::NearNotBeforeFar {
            near: 20.0,
            far: 10.0
        }
    );
    for near in [0.0, -1.0] {
        let (path, problem) = fail(&with(minimal(), "/camera/near", json!(near)));
        assert_eq!(path, "camera.near");
        assert_eq!(problem, Problem::NearNotPositive { near });
    }
    // Orthographic cameras may start at or behind the eye, but not after far.
    let ortho = with(minimal(), "/camera/orthographic", json!({"height": 4}));
    common::load_ok(&with(ortho.clone(), "/camera/near", json!(-1)));
    let (path, problem) = fail(&with(
        with(ortho, "/camera/near", json!(5)),
        "/camera/far",
        json!(1),
    ));
    assert_eq!(path, "camera.far");
    assert_eq!(
        problem,
        Problem::NearNotBeforeFar {
            near: 5.0,
            far: 1.0
        }
    );
}

#[test]
fn field_of_view_outside_open_interval() {
    for fov in [0.0, 180.0, -10.0, 200.0] {
        let (path, problem) = fail(&with(minimal(), "/camera/fov_y", json!(fov)));
        assert_eq!(path, "camera.fov_y");
        assert_eq!(problem, Problem::FovOutOfRange { value: fov });
    }
    common::load_ok(&with(minimal(), "/camera/fov_y", json!(179.5)));
}

#[test]
fn perspective_and_orthographic_conflict() {
    let v = with(
        with(minimal(), "/camera/fov_y", json!(30)),
        "/camera/orthographic",
        json!({"height": 2}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "camera.orthographic");
    assert_eq!(problem, Problem::ProjectionConflict);
}

#[test]
fn resolution_zero_or_over_the_cap() {
    let max = u64::from(Resolution::MAX_DIMENSION);
    let (path, problem) = fail(&with(minimal(), "/resolution", json!([0, 256])));
    assert_eq!(path, "resolution[0]");
    assert_eq!(problem, Problem::ResolutionOutOfRange { value: 0 });
    let v = with(minimal(), "/resolution", json!([256, max + 1]));
    let text = oit_scene::parse(&v.to_string(), "r.json")
        .unwrap_err()
        .to_string();
    assert!(text.contains("8192"), "the cap is stated: {text}");
    let (path, problem) = fail(&v);
    assert_eq!(path, "resolution[1]");
    assert_eq!(problem, Problem::ResolutionOutOfRange { value: max + 1 });
    let (path, problem) = fail(&with(minimal(), "/resolution", json!([1u64 << 40, 4])));
    assert_eq!(path, "resolution[0]");
    assert_eq!(problem, Problem::ResolutionOutOfRange { value: 1 << 40 });
    let s = common::load_ok(&with(minimal(), "/resolution", json!([max, 1])));
    assert_eq!(
        s.resolution,
        Resolution {
            width: 8192,
            height: 1
        }
    );
}

#[test]
fn degenerate_camera_vectors() {
    let (path, problem) = fail(&with(minimal(), "/camera/up", json!([0, 0, 0])));
    assert_eq!(path, "camera.up");
    assert_eq!(problem, Problem::ZeroUp);
    for up in [json!([0, 0, 1]), json!([0, 0, -3])] {
        let (path, problem) = fail(&with(minimal(), "/camera/up", up));
        assert_eq!(path, "camera.up");
        assert_eq!(problem, Problem::UpParallel);
    }
    let (path, problem) = fail(&with(minimal(), "/camera/target", json!([0, 0, 5])));
    assert_eq!(path, "camera.target");
    assert_eq!(problem, Problem::EyeAtTarget);
    let v = with(
        minimal(),
        "/lighting",
        json!({"directional": {"direction": [0, 0, 0]}}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "lighting.directional.direction");
    assert_eq!(problem, Problem::ZeroVector);
}

#[test]
fn unknown_fields_everywhere() {
    let cases = [
        ("/colour", "colour"),
        ("/camera/fov", "fov"),
        ("/objects/0/materal", "materal"),
        ("/objects/0/material/alpah", "alpah"),
        ("/objects/0/mesh/radius", "radius"),
        ("/objects/0/transform/rotation", "rotation"),
        ("/objects/0/instances", "count"),
    ];
    for (pointer, field) in cases {
        let v = if field == "count" {
            with(
                minimal(),
                pointer,
                json!({"counts": [1, 1, 1], "spacing": [0, 0, 0], "count": 3}),
            )
        } else {
            with(minimal(), pointer, json!(1))
        };
        let (path, problem) = fail(&v);
        let want = pointer
            .trim_start_matches('/')
            .replace("/0/", "[0].")
            .replace('/', ".");
        let want = if field == "count" {
            format!("{want}.count")
        } else {
            want
        };
        assert_eq!(path, want, "{pointer}");
        assert!(
            matches!(&problem, Problem::UnknownField { field: f, expected } if f == field && !expected.is_empty()),
            "{pointer}: {problem:?}"
        );
    }
    // The list of valid fields is part of the message.
    let (_, problem) = fail(&with(minimal(), "/objects/0/material/alpah", json!(1)));
    assert!(problem.to_string().contains("`alpha`"), "{problem}");
}

#[test]
fn unknown_mesh_kinds_and_alpha_modes_list_the_valid_ones() {
    let (path, problem) = fail(&with(minimal(), "/objects/0/mesh/kind", json!("cone")));
    assert_eq!(path, "objects[0].mesh.kind");
    let Problem::UnknownVariant { value, expected } = problem else {
        panic!("{problem:?}")
    };
    assert_eq!(value, "cone");
    for kind in [
        "quad",
        "box",
        "uv-sphere",
        "torus",
        "cylinder",
        "layers",
        "soup",
        "billboards",
    ] {
        assert!(
            expected.contains(&format!("`{kind}`")),
            "{kind} missing from {expected}"
        );
    }
    let (path, problem) = fail(&with(
        minimal(),
        "/objects/0/material/mode",
        json!("additive"),
    ));
    assert_eq!(path, "objects[0].material.mode");
    let Problem::UnknownVariant { value, expected } = problem else {
        panic!("{problem:?}")
    };
    assert_eq!(value, "additive");
    for mode in ["opaque", "mask", "blend", "mask-blend"] {
        assert!(
            expected.contains(&format!("`{mode}`")),
            "{mode} missing from {expected}"
        );
    }
    let (path, problem) = fail(&with(minimal(), "/lighting", json!("sun")));
    assert_eq!(path, "lighting");
    assert!(
        matches!(problem, Problem::UnknownVariant { .. }),
        "{problem:?}"
    );
}

#[test]
fn missing_fields_and_wrong_types() {
    let mut v = minimal();
    v["camera"].as_object_mut().unwrap().remove("eye");
    let (path, problem) = fail(&v);
    assert_eq!(path, "camera.eye");
    assert_eq!(
        problem,
        Problem::MissingField {
            field: "eye".into()
        }
    );
    let (path, problem) = fail(&with(minimal(), "/objects/0/mesh", json!({"size": [1, 1]})));
    assert_eq!(path, "objects[0].mesh.kind");
    assert_eq!(
        problem,
        Problem::MissingField {
            field: "kind".into()
        }
    );
    let (path, problem) = fail(&with(minimal(), "/objects/0/mesh/size", json!([1, "a"])));
    assert_eq!(path, "objects[0].mesh.size[1]");
    assert!(
        matches!(&problem, Problem::WrongType { expected, .. } if expected == "a number"),
        "{problem:?}"
    );
    let (path, problem) = fail(&with(minimal(), "/resolution", json!([-1, 5])));
    assert_eq!(path, "resolution[0]");
    assert!(matches!(problem, Problem::WrongType { .. }), "{problem:?}");
    let (path, problem) = fail(&with(minimal(), "/camera/eye", json!([1, 2, 3, 4])));
    assert_eq!(path, "camera.eye");
    assert!(matches!(problem, Problem::WrongType { .. }), "{problem:?}");
}

#[test]
fn json_syntax_errors_give_line_and_column() {
    let (path, problem) = fail_text("{\n  \"name\": \"x\",\n}");
    assert_eq!(path, "(root)");
    assert!(
        matches!(problem, Problem::Syntax { line: 3, .. }),
        "{problem:?}"
    );
    let (_, problem) = fail_text("");
    assert!(matches!(problem, Problem::Syntax { .. }), "{problem:?}");
    let (_, problem) = fail_text(&format!("{} trailing", minimal()));
    assert!(matches!(problem, Problem::Syntax { .. }), "{problem:?}");
}

#[test]
fn triangle_cap_stops_absurd_instancing_before_allocating() {
    let v = with(minimal(), "/objects/0/mesh", json!({"kind": "box"}));
    let v = with(
        v,
        "/objects/0/instances",
        json!({"counts": [4_000_000_000u32, 4_000_000_000u32, 4_000_000_000u32], "spacing": [1, 1, 1]}),
    );
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[0]");
    assert!(
        matches!(problem, Problem::TooManyTriangles { count } if count > MAX_TRIANGLES),
        "{problem:?}"
    );
    // The cap counts the whole scene: two objects just under it each are too many together.
    let half = json!({"kind": "soup", "seed": 1, "count": MAX_TRIANGLES / 2 + 1,
                      "bounds": {"min": [0, 0, 0], "max": [1, 1, 1]}});
    let v = scene_with(json!([{"mesh": {"kind": "quad"}}, {"mesh": half}, {"mesh": half}]));
    let (path, problem) = fail(&v);
    assert_eq!(path, "objects[2]");
    assert_eq!(
        problem,
        Problem::TooManyTriangles {
            count: 2 + 2 * (MAX_TRIANGLES / 2 + 1)
        }
    );
}

#[test]
fn unreadable_files_are_io_errors() {
    let missing = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("no-such-scene.json");
    let err = oit_scene::load(&missing).unwrap_err();
    assert!(matches!(err, SceneError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("no-such-scene.json"), "{err}");
    assert!(err.path().is_none());
}
