//! Every WGSL file in shaders/ parses and validates with naga after include expansion, with no
//! GPU. Includes are resolved from the files on disk with the same `compose` the crates use, and
//! the embedded shared modules must equal those files.

use std::path::{Path, PathBuf};

fn shader_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders")
}

#[test]
fn every_wgsl_file_validates() {
    let dir = shader_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("shaders/ exists")
        .map(|e| e.expect("readable entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "wgsl"))
        .collect();
    files.sort();
    assert!(
        files.len() >= 4,
        "expected the shared module and the pass files, found {files:?}"
    );
    let resolve = |name: &str| std::fs::read_to_string(dir.join(name)).ok();
    let mut failures = Vec::new();
    let mut per_draw = 0;
    for file in &files {
        let name = file
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        let source = std::fs::read_to_string(file).expect("readable shader");
        let code = match oit_gpu::shaders::compose(&source, &resolve) {
            Ok(c) => c,
            Err(e) => {
                failures.push(format!("{name}: {e}"));
                continue;
            }
        };
        match validate(&code) {
            Ok(entry_points) => println!("validated {name}: {entry_points} entry points"),
            Err(e) => failures.push(format!("{name}: {e}")),
        }
        // The per-draw forms of a scene pass (scene_io/draw.wgsl or draw_untextured.wgsl in
        // place of scene_io/vertex.wgsl), which `ScenePipelines` builds for draws of small
        // triangles. stochastic_dither.wgsl has its own vertex outputs that repeat the
        // per-vertex fields; its pipelines never use them.
        for textured in [false, true] {
            match oit_gpu::shaders::compose_per_draw(&source, &resolve, textured) {
                Some(Ok(code)) if name != "stochastic_dither.wgsl" => match validate(&code) {
                    Ok(_) => per_draw += 1,
                    Err(e) => failures.push(format!("{name} (per-draw form): {e}")),
                },
                Some(Err(e)) => failures.push(format!("{name} (per-draw form): {e}")),
                _ => {}
            }
        }
    }
    // Every scene pass but the floor and stochastic dither reads materials through vs_main.
    assert!(per_draw >= 24, "only {per_draw} per-draw forms validated");
    assert!(
        failures.is_empty(),
        "invalid shaders:\n{}",
        failures.join("\n")
    );
}

/// Parses and validates composed WGSL; the number of entry points, or the error as text.
fn validate(code: &str) -> Result<usize, String> {
    let module = naga::front::wgsl::parse_str(code).map_err(|e| e.emit_to_string(code))?;
    let mut validator = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    );
    validator
        .validate(&module)
        .map_err(|e| e.emit_to_string(code))?;
    Ok(module.entry_points.len())
}

#[test]
fn embedded_modules_match_disk() {
    let dir = shader_dir();
    for (name, embedded) in oit_gpu::shaders::SHARED_MODULES {
        let disk = std::fs::read_to_string(dir.join(name)).expect("shared module on disk");
        assert_eq!(
            &disk, embedded,
            "{name}: embedded copy differs from shaders/{name}"
        );
    }
    for (name, embedded) in [
        ("opaque.wgsl", oit_gpu::shaders::OPAQUE),
        ("blend.wgsl", oit_gpu::shaders::BLEND),
        ("count_fragments.wgsl", oit_gpu::shaders::COUNT_FRAGMENTS),
        ("floor.wgsl", oit_gpu::shaders::FLOOR),
        ("scene_io/draw.wgsl", oit_gpu::shaders::SCENE_IO_DRAW),
        (
            "scene_io/draw_untextured.wgsl",
            oit_gpu::shaders::SCENE_IO_DRAW_UNTEXTURED,
        ),
    ] {
        let disk = std::fs::read_to_string(dir.join(name)).expect("pass file on disk");
        assert_eq!(disk, embedded, "{name}");
    }
}

#[test]
fn unprocessed_includes_do_not_parse() {
    // The include syntax must be invalid WGSL, so a forgotten `compose` cannot go unnoticed.
    let raw = oit_gpu::shaders::OPAQUE;
    assert!(raw.contains("#include"));
    assert!(naga::front::wgsl::parse_str(raw).is_err());
}
