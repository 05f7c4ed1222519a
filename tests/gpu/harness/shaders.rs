//! Every WGSL file of every crate — oit-gpu's shared modules and passes, and each technique's
//! own `shaders/` — parses and validates with naga after include expansion, with no GPU, and
//! through the one include mechanism the crates use at run time
//! (`oit_gpu::shaders::compose_with`). Each crate's embedded `SHADERS` must hold exactly the
//! files of its folder, byte for byte: a shader added to a folder but not to its crate, or
//! edited on one side, fails here.

use std::path::{Path, PathBuf};

use oit_gpu::shaders::{self, Library};

/// Each crate: oit-gpu's shared shaders, then every family of the registry with its folder and
/// the libraries its passes include from, its own first.
fn crates() -> Vec<(&'static str, &'static str, Vec<Library>)> {
    let mut all = vec![("oit-gpu", shaders::SHADER_DIR, vec![shaders::SHADERS])];
    all.extend(
        oit_harness::FAMILIES
            .iter()
            .map(|family| (family.folder, family.shader_dir, family.shaders.to_vec())),
    );
    all
}

/// Every `.wgsl` under `dir`, as paths relative to it with `/` separators, sorted.
fn wgsl_files(dir: &Path) -> Vec<String> {
    fn walk(base: &Path, dir: &Path, out: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
            let path: PathBuf = entry.expect("readable entry").path();
            if path.is_dir() {
                walk(base, &path, out);
            } else if path.extension().is_some_and(|e| e == "wgsl") {
                let rel = path.strip_prefix(base).expect("inside the folder");
                out.push(rel.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

#[test]
fn every_crate_embeds_exactly_the_files_of_its_shader_folder() {
    let mut total = 0;
    for (name, dir, libraries) in crates() {
        let own = libraries[0];
        let on_disk = wgsl_files(Path::new(dir));
        let mut embedded: Vec<String> = own.iter().map(|(n, _)| (*n).to_owned()).collect();
        embedded.sort();
        assert_eq!(embedded, on_disk, "{name}: SHADERS against {dir}");
        for (file, source) in own {
            let disk = std::fs::read_to_string(Path::new(dir).join(file)).expect("readable");
            assert_eq!(
                &disk, source,
                "{name}: {file} differs from its embedded copy"
            );
        }
        total += on_disk.len();
    }
    assert!(total >= 31, "{total} WGSL files in all");
}

#[test]
fn every_wgsl_file_validates() {
    let mut failures = Vec::new();
    let mut validated = 0;
    let mut per_draw = 0;
    for (crate_name, _, libraries) in crates() {
        // scene_io/ holds the scene pass interface and lighting.wgsl the lighting, fragments of
        // common.wgsl (they read its bindings): they validate inside every pass that includes
        // them, not alone.
        for (file, source) in libraries[0]
            .iter()
            .filter(|(f, _)| !f.starts_with("scene_io/") && *f != "lighting.wgsl")
        {
            let name = format!("{crate_name} {file}");
            match shaders::compose_with(source, &libraries) {
                Ok(code) => match validate(&code) {
                    Ok(entry_points) => {
                        validated += 1;
                        println!("validated {name}: {entry_points} entry points");
                    }
                    Err(e) => failures.push(format!("{name}: {e}")),
                },
                Err(e) => failures.push(format!("{name}: {e}")),
            }
            // The per-draw forms of a scene pass (scene_io/draw.wgsl or draw_untextured.wgsl in
            // place of scene_io/vertex.wgsl), which `ScenePipelines` builds for draws of small
            // triangles. stochastic_dither.wgsl and per_object_dither.wgsl have their own
            // vertex outputs that repeat the per-vertex fields, and ray_query.wgsl is a
            // full-screen pass that runs the per-vertex `scene_vertex` for each hit: their
            // pipelines never use a per-draw form.
            for (textured, lit) in [(false, false), (true, false), (true, true)] {
                match shaders::compose_per_draw_with(source, &libraries, textured, lit) {
                    Some(Ok(code))
                        if ![
                            "stochastic_dither.wgsl",
                            "per_object_dither.wgsl",
                            "ray_query.wgsl",
                        ]
                        .contains(file) =>
                    {
                        match validate(&code) {
                            Ok(_) => per_draw += 1,
                            Err(e) => failures.push(format!("{name} (per-draw form): {e}")),
                        }
                    }
                    Some(Err(e)) => failures.push(format!("{name} (per-draw form): {e}")),
                    _ => {}
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "invalid shaders:\n{}",
        failures.join("\n")
    );
    assert!(validated >= 30, "only {validated} files validated");
    // Every scene pass but the floor and stochastic dither reads materials through vs_main.
    assert!(per_draw >= 24, "only {per_draw} per-draw forms validated");
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
