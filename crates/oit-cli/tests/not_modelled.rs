//! Every command that renders says what of a model it did not model: a glTF glass dome whose
//! transmission a metallic factor of 1 cancels and whose normal map is not sampled prints the
//! same "Not modelled" lines from `reference`, `analyze` (table and JSON), `render`,
//! `compare` (terminal, results.md, report.html) and `recommend`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn oit() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_oit"));
    c.current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."));
    c
}

fn temp_dir(name: &str) -> oit_gpu::testing::ScratchDir {
    oit_gpu::testing::ScratchDir::new(&format!("cli-nm-{name}"))
}

/// The two lines the dome's material must produce.
const METAL: &str = "Not modelled: dome.gltf: metallic transmission on /materials/0 (Dome): transmissionFactor 1 applies to the dielectric part only: τ = 1 × (1 − metallic 1) = 0 (metallicFactor 1, also glTF's default when absent)";
const NORMALS: &str = "Not modelled: dome.gltf: normalTexture on /materials/0 (Dome): not modelled (geometric or vertex normals only)";

/// Two overlapping BLEND quads of one material (transmissionFactor 1, no metallicFactor, a
/// normal map) in one draw.
fn dome(dir: &Path) -> PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    let quads = [(-1.0f32, 0.0f32), (-0.5, -0.5)];
    for (x, z) in quads {
        for [u, v] in [
            [0.0f32, 0.0],
            [1.5, 0.0],
            [1.5, 1.5],
            [0.0, 0.0],
            [1.5, 1.5],
            [0.0, 1.5],
        ] {
            for c in [x + u, -1.0 + v, z] {
                bin.extend(c.to_le_bytes());
            }
        }
    }
    std::fs::write(dir.join("dome.bin"), &bin).unwrap();
    let normal = oit_metrics::Srgb8Image {
        width: 1,
        height: 1,
        pixels: vec![[128, 128, 255]],
    };
    oit_metrics::write_png_srgb8(&dir.join("normal.png"), &normal).unwrap();
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0"}},
        "extensionsUsed": ["KHR_materials_transmission"],
        "buffers": [{{"uri": "dome.bin", "byteLength": {}}}],
        "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {}}}],
        "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 12, "type": "VEC3",
            "min": [-1, -1, -0.5], "max": [1, 1, 0]}}],
        "images": [{{"uri": "normal.png"}}],
        "textures": [{{"source": 0}}],
        "materials": [{{"name": "Dome", "alphaMode": "BLEND", "doubleSided": true,
            "normalTexture": {{"index": 0}},
            "pbrMetallicRoughness": {{"baseColorFactor": [0.9, 0.3, 0.2, 0.5]}},
            "extensions": {{"KHR_materials_transmission": {{"transmissionFactor": 1}}}}}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "material": 0}}]}}],
        "nodes": [{{"mesh": 0}}],
        "scenes": [{{"nodes": [0]}}]}}"#,
        bin.len(),
        bin.len()
    );
    let path = dir.join("dome.gltf");
    std::fs::write(&path, gltf).unwrap();
    path
}

fn says_both(what: &str, text: &str) {
    for line in [METAL, NORMALS] {
        assert!(text.contains(line), "{what} lacks {line:?}:\n{text}");
    }
}

fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn reference_and_analyze_print_what_is_not_modelled() {
    let dir = temp_dir("cpu");
    let scene = dome(&dir);
    let out = oit()
        .arg("reference")
        .arg(&scene)
        .args(["--resolution", "16x16", "-o"])
        .arg(dir.join("r.exr"))
        .output()
        .unwrap();
    says_both("oit reference", &ok(&out));
    let out = oit()
        .arg("analyze")
        .arg(&scene)
        .args(["--resolution", "16x16"])
        .output()
        .unwrap();
    // The table wraps at its width: compare with the line breaks taken out.
    let table = ok(&out).replace("\n    ", " ");
    says_both("oit analyze", &table);
    let out = oit()
        .arg("analyze")
        .arg(&scene)
        .args(["--resolution", "16x16", "--json"])
        .output()
        .unwrap();
    let json: serde_json::Value = serde_json::from_str(&ok(&out)).unwrap();
    let lines = json["scenes"][0]["not_modelled"]
        .as_array()
        .unwrap()
        .clone();
    for line in [METAL, NORMALS] {
        let bare = line.trim_start_matches("Not modelled: ");
        assert!(
            lines
                .iter()
                .any(|l| l.as_str().is_some_and(|l| l.starts_with(bare))),
            "{bare:?} not in {lines:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn render_compare_and_recommend_print_what_is_not_modelled() {
    if oit_gpu::testing::context_or_skip("cli not modelled").is_none() {
        return;
    }
    let dir = temp_dir("gpu");
    let scene = dome(&dir);
    let out = oit()
        .arg("render")
        .arg(&scene)
        .args(["-t", "unsorted", "--resolution", "16x16", "-o"])
        .arg(dir.join("u.exr"))
        .output()
        .unwrap();
    says_both("oit render", &ok(&out));
    let run = |command: &str, out_dir: &Path| {
        oit()
            .arg(command)
            .arg(&scene)
            .args(["-t", "unsorted", "--resolution", "16x16"])
            .args(["--frames", "1", "--warmup", "0", "--no-cache", "--out"])
            .arg(out_dir)
            .output()
            .unwrap()
    };
    let compared = dir.join("compare");
    // The terminal table wraps at its width: compare with the line breaks taken out.
    let table = ok(&run("compare", &compared)).replace("\n    ", " ");
    says_both("oit compare", &table);
    let md = std::fs::read_to_string(compared.join("results.md")).unwrap();
    says_both("results.md", &md);
    let html = std::fs::read_to_string(compared.join("report.html")).unwrap();
    assert!(
        html.contains("metallic transmission on /materials/0 (Dome)")
            && html.contains("normalTexture on /materials/0 (Dome)"),
        "report.html lacks the lines"
    );
    let out = oit()
        .arg("recommend")
        .arg(&scene)
        .args(["--max-flip", "1", "-t", "unsorted", "--resolution", "16x16"])
        .args(["--frames", "1", "--warmup", "0", "--no-cache", "--out"])
        .arg(dir.join("recommend"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for line in [METAL, NORMALS] {
        assert!(
            text.contains(&format!("dome: {line}")),
            "oit recommend lacks {line:?}:\n{text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
