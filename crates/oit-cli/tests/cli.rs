//! The `oit` binary as a user runs it: outputs, exit codes and one-line errors.

use std::path::{Path, PathBuf};
use std::process::Command;

fn oit() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_oit"));
    c.current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."));
    c
}

fn temp_dir(name: &str) -> oit_gpu::testing::ScratchDir {
    oit_gpu::testing::ScratchDir::new(&format!("cli-{name}"))
}

#[test]
fn reference_writes_exr_with_layers_and_png_and_matches_enderton() {
    let dir = temp_dir("reference");
    let exr = dir.join("enderton.exr");
    let out = oit()
        .args([
            "reference",
            "scenes/enderton.json",
            "--resolution",
            "64x48",
            "-o",
        ])
        .arg(&exr)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let image = oit_metrics::read_exr_rgba(&exr, None).unwrap();
    assert_eq!((image.width, image.height), (64, 48));
    // Red .45 over green .45 over blue: (0.45, 0.2475, 0.3025) on every pixel.
    for p in &image.pixels {
        assert!(
            (p[0] - 0.45).abs() < 1e-6
                && (p[1] - 0.2475).abs() < 1e-6
                && (p[2] - 0.3025).abs() < 1e-6,
            "{p:?}"
        );
    }
    let layers = oit_metrics::read_exr_channel(&exr, None, "layers").unwrap();
    assert!(
        layers.samples.iter().all(|&l| l == 2.0),
        "two transparent layers everywhere"
    );
    assert!(dir.join("enderton.png").is_file());
    // Nothing but the outputs: no temporary files left behind.
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["enderton.exr", "enderton.png"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_scene_fails_with_one_line_naming_file_and_field() {
    let dir = temp_dir("bad");
    let scene = dir.join("bad.json");
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/enderton.json"),
    )
    .unwrap()
    .replacen("\"alpha\": 0.45", "\"alpha\": 1.5", 1);
    std::fs::write(&scene, text).unwrap();
    let exr = dir.join("never.exr");
    let out = oit()
        .arg("reference")
        .arg(&scene)
        .arg("-o")
        .arg(&exr)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("bad.json") && stderr.contains("objects[0].material.alpha"),
        "{stderr}"
    );
    assert!(!exr.exists(), "no output for a failed run");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn unknown_technique_lists_the_valid_ones() {
    let out = oit()
        .args(["render", "scenes/enderton.json", "--technique", "magic"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("magic") && stderr.contains("sorted-object"),
        "{stderr}"
    );
}

#[test]
fn bad_resolution_is_a_usage_error() {
    let out = oit()
        .args(["reference", "scenes/enderton.json", "--resolution", "0x10"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("width 0"));
}

#[test]
fn techniques_lists_every_registered_technique_with_defaults() {
    let out = oit().arg("techniques").output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for info in oit_harness::registry() {
        assert!(text.contains(info.name), "{} missing", info.name);
        for p in &info.params {
            assert!(
                text.contains(&format!("{}=", p.key)),
                "{}.{} missing",
                info.name,
                p.key
            );
        }
    }
}

/// Every table under a `<!-- generated: oit ARGS -->` marker in the README and docs/ is what
/// `oit ARGS` prints now: a technique added, renamed or re-described cannot leave a stale
/// table behind (`cargo xtask readme-tables` rewrites them).
#[test]
fn generated_tables_in_the_docs_are_what_oit_prints_now() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut found = 0;
    for doc in ["README.md", "docs/coloured-transmission.md"] {
        let text = std::fs::read_to_string(root.join(doc)).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let Some(args) = line
                .trim()
                .strip_prefix("<!-- generated: oit ")
                .and_then(|rest| rest.strip_suffix("-->"))
            else {
                continue;
            };
            found += 1;
            let out = oit().args(args.split_whitespace()).output().unwrap();
            assert!(out.status.success(), "{doc}:{}: `oit {args}` failed", i + 1);
            let table: Vec<&str> = lines[i + 1..]
                .iter()
                .take_while(|l| l.starts_with('|'))
                .copied()
                .collect();
            let printed = String::from_utf8(out.stdout).unwrap();
            assert_eq!(
                table,
                printed.lines().collect::<Vec<_>>(),
                "{doc}:{}: the table differs from `oit {args}`; run `cargo xtask readme-tables`",
                i + 1
            );
        }
    }
    assert_eq!(
        found, 3,
        "the techniques, operators and transmission tables"
    );
}

#[test]
fn scenes_lists_the_suite_with_depth_complexity() {
    let out = oit().args(["scenes", "scenes"]).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let enderton = text
        .lines()
        .find(|l| l.starts_with("enderton "))
        .expect("enderton listed");
    let cols: Vec<&str> = enderton.split_whitespace().collect();
    // name, size, triangles, transparent triangles, draws, max depth, mean depth
    assert_eq!(cols[2], "6");
    assert_eq!(cols[3], "4");
    assert_eq!(cols[5], "2", "max depth complexity: {enderton}");
    let scenes = text.lines().filter(|l| !l.starts_with(' ')).count();
    assert_eq!(scenes, 1 + bundled_scene_count(), "{text}");
    // A glTF scene carries its asset's credit and what of it is not modelled.
    assert!(
        text.contains("    Credits: GlassVaseFlowers.glb: CC0"),
        "{text}"
    );
    assert!(
        text.contains("    Not modelled: GlassVaseFlowers.glb: KHR_materials_transmission"),
        "{text}"
    );
    // What each scene tests is shown under it.
    assert!(
        text.contains("    Red (alpha 0.45) in front of green"),
        "{text}"
    );
    assert!(
        !text.contains("animated:"),
        "the still suite has no animation"
    );
    let motion = oit().args(["scenes", "scenes/motion"]).output().unwrap();
    let text = String::from_utf8_lossy(&motion.stdout);
    assert!(
        text.contains("    animated: 48 frames at 24 fps (the figures above are frame 0's)"),
        "{text}"
    );
    assert!(text.contains("    animated: 61 frames at 30 fps"), "{text}");
}

#[test]
fn render_writes_an_image_close_to_the_reference() {
    if oit_gpu::testing::context_or_skip("cli render").is_none() {
        return;
    }
    let dir = temp_dir("render");
    let exr = dir.join("r.exr");
    let out = oit()
        .args([
            "render",
            "scenes/enderton.json",
            "--technique",
            "sorted-object",
            "--resolution",
            "32x32",
            "-o",
        ])
        .arg(&exr)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let image = oit_metrics::read_exr_rgba(&exr, Some("render")).unwrap();
    let p = image.get(16, 16);
    assert!(
        (p[0] - 0.45).abs() < 2e-3 && (p[1] - 0.2475).abs() < 2e-3 && (p[2] - 0.3025).abs() < 2e-3,
        "{p:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn compare_writes_the_report_and_report_rebuilds_it() {
    if oit_gpu::testing::context_or_skip("cli compare").is_none() {
        return;
    }
    let dir = temp_dir("compare");
    let out = oit()
        .args([
            "compare",
            "scenes/enderton.json",
            "--resolution",
            "32x32",
            "--frames",
            "1",
            "--warmup",
            "0",
        ])
        .args([
            "--technique",
            "unsorted",
            "--technique",
            "sorted-object",
            "--out",
        ])
        .arg(&dir)
        .arg("--cache")
        .arg(dir.join("cache"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("enderton") && stdout.contains("sorted-object"),
        "{stdout}"
    );
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("adapter: "),
        "the adapter is named first"
    );
    let md = std::fs::read_to_string(dir.join("results.md")).unwrap();
    assert!(
        md.contains("## Summary over the suite") && md.contains("## Pareto fronts"),
        "{md}"
    );
    assert!(dir.join("report.html").is_file());
    assert!(dir.join("plots/enderton-flip-cost.svg").is_file());
    // `oit report` rebuilds from results.json alone, here with the other metric.
    std::fs::remove_file(dir.join("report.html")).unwrap();
    let out = oit()
        .arg("report")
        .arg(&dir)
        .args(["--metric", "rmse"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.join("report.html").is_file());
    assert!(
        std::fs::read_to_string(dir.join("results.md"))
            .unwrap()
            .contains("RMSE")
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `reference` refuses outputs that would replace its input or lose the EXR to the preview,
/// and a special file (a FIFO) at the output path; the default name of a scene named like a
/// path stays in the working directory.
#[test]
fn outputs_never_replace_inputs_special_files_or_leave_the_working_directory() {
    let dir = temp_dir("outputs");
    let scene = dir.join("scene.json");
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/enderton.json"),
    )
    .unwrap();
    let escape = dir.join("escaped");
    let renamed = text.replacen(
        "\"name\": \"enderton\"",
        &format!("\"name\": {:?}", escape.display().to_string()),
        1,
    );
    assert_ne!(renamed, text, "enderton.json names itself");
    std::fs::write(&scene, &renamed).unwrap();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_oit"))
            .current_dir(&dir)
            .args(args)
            .args(["--resolution", "16x16"])
            .output()
            .unwrap()
    };
    for (output, expect) in [
        ("scene.json", "must be an .exr"),
        ("x.png", "must be an .exr"),
        ("scene.exr", "which the scene reads"),
    ] {
        // scene.exr's preview, scene.png, is not the scene; make the input the .png case.
        let out = run(&["reference", "scene.json", "-o", output]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        if output == "scene.exr" {
            assert!(out.status.success(), "{stderr}");
            continue;
        }
        assert_eq!(out.status.code(), Some(1), "{output}: {stderr}");
        assert!(stderr.contains(expect), "{output}: {stderr}");
    }
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), renamed);
    // The preview would replace a scene file named like it.
    std::fs::copy(&scene, dir.join("view.png")).unwrap();
    let out = run(&["reference", "view.png", "-o", "view.exr"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("which the scene reads"));

    let fifo = dir.join("pipe.exr");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let out = run(&["reference", "scene.json", "-o", "pipe.exr"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("FIFO"), "{stderr}");

    // Default output: the file-safe name, in the working directory.
    let out = run(&["reference", "scene.json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stem = oit_harness::file_stem(&escape.display().to_string());
    assert!(dir.join(format!("{stem}-reference.exr")).is_file());
    assert!(!escape.exists() && !dir.join("escaped-reference.exr").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// An I/O error names its cause once (it was printed twice), on one line.
#[test]
fn a_missing_file_is_one_line_with_its_cause_once() {
    let out = oit()
        .args(["reference", "scenes/no-such-scene.json"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert_eq!(stderr.matches("No such file").count(), 1, "{stderr}");
}

/// `scenes` on a folder without scenes is an error, as `compare` is; `--frames 0` is a usage
/// error, not one frame; a sweep too large is refused before the GPU is opened.
#[test]
fn empty_folders_zero_frames_and_huge_sweeps_are_errors() {
    let dir = temp_dir("empty");
    let out = oit().arg("scenes").arg(&dir).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no scene files"));

    let out = oit()
        .args(["compare", "scenes/enderton.json", "--frames", "0", "--out"])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("frames"));

    let start = std::time::Instant::now();
    let out = oit()
        .args([
            "compare",
            "scenes/enderton.json",
            "-t",
            "unsorted:a=1..1000,b=1..1000,c=1..1000",
            "--out",
        ])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(start.elapsed().as_secs() < 10, "{:?}", start.elapsed());
    let out = oit()
        .args([
            "compare",
            "scenes",
            "-t",
            "stochastic:spp=1..64",
            "--max-runs",
            "100",
            "--out",
        ])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--max-runs 100"), "{stderr}");
    assert!(
        !dir.join("out").exists(),
        "nothing written for a refused comparison"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every argument of every command says what it is (`--help` has no bare flags).
#[test]
fn every_argument_has_a_description() {
    for command in [
        "scenes",
        "techniques",
        "reference",
        "render",
        "compare",
        "report",
        "merge",
    ] {
        let out = oit().args([command, "--help"]).output().unwrap();
        let help = String::from_utf8_lossy(&out.stdout);
        for line in help.lines() {
            let t = line.trim_start();
            if (t.starts_with('-') || t.starts_with('<') || t.starts_with('['))
                && line.starts_with("  ")
            {
                let described = t.split("  ").filter(|p| !p.trim().is_empty()).count() >= 2;
                assert!(
                    described,
                    "`oit {command}`: `{t}` has no description\n{help}"
                );
            }
        }
    }
}

/// A reference that cannot fit its memory budget fails with one line naming the budget, fast.
#[test]
fn a_reference_over_its_memory_budget_is_one_clear_line() {
    let dir = temp_dir("budget");
    // 60 000 screen-filling layers on 8×8 pixels, `spacing` apart in depth.
    let deep = |name: &str, spacing: &str| {
        let scene = dir.join(name);
        std::fs::write(
            &scene,
            format!(
                r#"{{"name": "deep", "description": "", "resolution": [8, 8],
                "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100}},
                "background": [0, 0, 0],
                "objects": [{{"mesh": {{"kind": "quad", "size": [20, 20]}},
                    "material": {{"base_color": [1, 1, 1], "alpha": 0.01, "mode": "blend"}},
                    "instances": {{"counts": [1, 1, 60000], "spacing": [0, 0, {spacing}]}}}}]}}"#
            ),
        )
        .unwrap();
        scene
    };
    // Several f32 ulps of window depth apart, the layers arrive in depth order and are
    // composited as they come: no pixel stores its fragments, 1 MiB is plenty.
    let exr = dir.join("in-order.exr");
    let out = oit()
        .arg("reference")
        .arg(deep("apart.json", "-0.0001"))
        .args(["--memory-budget", "1", "-o"])
        .arg(&exr)
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(exr.exists());
    // Within the tie distance of each other, every pixel's 60 000 fragments must be stored
    // and sorted: more than 1 MiB each.
    let exr = dir.join("never.exr");
    let start = std::time::Instant::now();
    let out = oit()
        .arg("reference")
        .arg(deep("tied.json", "-0.000001"))
        .args(["--memory-budget", "1", "-o"])
        .arg(&exr)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("pixel (0, 0)")
            && stderr.contains("60000")
            && stderr.contains("--memory-budget"),
        "{stderr}"
    );
    assert!(!exr.exists());
    assert!(start.elapsed().as_secs() < 30, "{:?}", start.elapsed());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A glTF asset whose texture and buffer are files beside it (`base.png`, `model.bin`): one
/// blended, textured quad. Returns the asset's path.
fn textured_gltf(dir: &Path) -> PathBuf {
    let mut bin: Vec<u8> = Vec::new();
    for v in [
        [-1.0f32, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ] {
        bin.extend(v.iter().flat_map(|x| x.to_le_bytes()));
    }
    for uv in [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]] {
        bin.extend(uv.iter().flat_map(|x| x.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    std::fs::write(dir.join("model.bin"), &bin).unwrap();
    let texture = oit_metrics::Srgb8Image {
        width: 2,
        height: 2,
        pixels: vec![[255, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 0]],
    };
    oit_metrics::write_png_srgb8(&dir.join("base.png"), &texture).unwrap();
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0"}},
        "buffers": [{{"uri": "model.bin", "byteLength": {}}}],
        "bufferViews": [
            {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
            {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
            {{"buffer": 0, "byteOffset": 80, "byteLength": 12}}],
        "accessors": [
            {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
            {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
            {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}}],
        "images": [{{"uri": "base.png"}}],
        "textures": [{{"source": 0}}],
        "materials": [{{"alphaMode": "BLEND",
            "pbrMetallicRoughness": {{"baseColorFactor": [1, 1, 1, 0.5], "baseColorTexture": {{"index": 0}}}}}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": 0}}]}}],
        "nodes": [{{"mesh": 0}}],
        "scenes": [{{"nodes": [0]}}]}}"#,
        bin.len()
    );
    let path = dir.join("model.gltf");
    std::fs::write(&path, gltf).unwrap();
    path
}

/// Outputs never land on a file a scene reads: the texture of a glTF asset (its preview once
/// replaced `base.png` with exit 0), the same through a JSON scene that names the asset, any
/// spelling of the path, and `compare`'s output folder over or around the scene files. Each
/// is refused before anything is written or the GPU is opened.
#[test]
fn outputs_never_land_on_files_a_scene_reads() {
    let dir = temp_dir("inputs");
    textured_gltf(&dir);
    let wrapper = dir.join("wrapper.json");
    std::fs::write(
        &wrapper,
        r#"{"name": "wrapped", "description": "", "resolution": [16, 16],
        "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100},
        "background": [0, 0, 0],
        "objects": [{"mesh": {"kind": "gltf", "file": "model.gltf"}}]}"#,
    )
    .unwrap();
    let (_, inputs) = oit_scene::load_with_inputs(&wrapper, &Default::default()).unwrap();
    let names: Vec<String> = inputs
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        ["wrapper.json", "model.gltf", "model.bin", "base.png"]
    );
    let texture = std::fs::read(dir.join("base.png")).unwrap();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_oit"))
            .current_dir(&dir)
            .args(args)
            .output()
            .unwrap()
    };
    for args in [
        &["reference", "model.gltf", "-o", "base.exr"][..],
        &["reference", "wrapper.json", "-o", "base.exr"],
        &["reference", "model.gltf", "-o", "sub/../base.exr"],
        &["render", "model.gltf", "-t", "unsorted", "-o", "./base.exr"],
    ] {
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let out = run(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(
            stderr.contains("base.png") && stderr.contains("which the scene reads"),
            "{args:?}: {stderr}"
        );
        assert!(
            !stderr.contains("adapter:"),
            "refused before the GPU: {stderr}"
        );
        assert!(!dir.join("base.exr").exists());
    }
    assert_eq!(std::fs::read(dir.join("base.png")).unwrap(), texture);
    // Another name beside it is fine.
    let out = run(&[
        "reference",
        "model.gltf",
        "-o",
        "model.exr",
        "--resolution",
        "16x16",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.join("model.png").is_file());
    // compare: never into the scene folder, nor into a folder holding a scene's files.
    for (args, expect) in [
        (&["compare", ".", "--out", "."][..], "is the scene folder"),
        (&["compare", "model.gltf", "--out", "."], "holds"),
        (&["compare", "wrapper.json", "--out", "."], "holds"),
    ] {
        let out = run(args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        assert!(stderr.contains(expect), "{args:?}: {stderr}");
        assert!(!dir.join("results.json").exists());
    }
    assert_eq!(std::fs::read(dir.join("base.png")).unwrap(), texture);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `oit techniques --json` and `oit scenes --json` are for scripts: they parse, and say what
/// the text listings say.
#[test]
fn listings_are_machine_readable() {
    let out = oit().args(["techniques", "--json"]).output().unwrap();
    assert!(out.status.success());
    let list: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    let registry = oit_harness::registry();
    assert_eq!(list.len(), registry.len());
    for (item, info) in list.iter().zip(&registry) {
        assert_eq!(item["name"], info.name);
        assert_eq!(item["default_spec"], info.default_spec().canonical());
        assert_eq!(item["params"].as_array().unwrap().len(), info.params.len());
    }
    let out = oit()
        .args(["scenes", "scenes/enderton.json", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let scenes: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(scenes.len(), 1);
    assert_eq!(scenes[0]["scene"], "enderton");
    assert_eq!(scenes[0]["max_depth_complexity"], 2);
    assert!(
        scenes[0]["description"]
            .as_str()
            .unwrap()
            .starts_with("Red")
    );
}

/// A results file of another schema is named as such (it said "missing field adapter"), and
/// warm-up past 1000 frames is a usage error instead of a run that never ends.
#[test]
fn a_foreign_results_file_and_endless_warm_up_are_named() {
    let dir = temp_dir("schema");
    std::fs::write(dir.join("results.json"), r#"{"schema": "x"}"#).unwrap();
    let out = oit().arg("report").arg(&dir).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("schema is `x`") && stderr.contains("oit-lab/results/v1"),
        "{stderr}"
    );
    let out = oit()
        .args(["compare", "scenes/enderton.json", "--warmup", "4294967295"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("4294967295"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A temporary left by an interrupted `reference` or `render` (a killed process's
/// `.NAME.PID-N.tmp`) is removed by the next run writing into that folder.
#[test]
fn reference_removes_temporaries_an_interrupted_run_left() {
    let dir = temp_dir("temporaries");
    // PIDs stop at 2^22 on Linux: this writer is gone.
    let stale = dir.join(".enderton.exr.999999999-0.tmp");
    std::fs::write(&stale, b"half an EXR").unwrap();
    let out = oit()
        .args([
            "reference",
            "scenes/enderton.json",
            "--resolution",
            "8x8",
            "-o",
        ])
        .arg(dir.join("enderton.exr"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!stale.exists(), "the stale temporary was left");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Warnings (a cached reference that was not trusted, a cache that cannot be written) reach
/// stderr when it is a pipe, as in CI logs and cron, not only on a terminal; Mesa's
/// `XDG_RUNTIME_DIR` complaint does not.
#[test]
fn warnings_reach_logs_and_mesa_noise_does_not() {
    if oit_gpu::testing::context_or_skip("cli warnings").is_none() {
        return;
    }
    let dir = temp_dir("warnings");
    let cache = dir.join("cache");
    let compare = |cache: &Path| {
        oit()
            .env_remove("XDG_RUNTIME_DIR")
            .args(["compare", "scenes/enderton.json", "--resolution", "16x16"])
            .args(["--frames", "1", "--warmup", "0", "-t", "unsorted", "--out"])
            .arg(dir.join("out"))
            .arg("--cache")
            .arg(cache)
            .output()
            .unwrap()
    };
    let out = compare(&cache);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    // Alter the cached file: recomputed, and said.
    let file = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "oitref"))
        .unwrap();
    let mut bytes = std::fs::read(&file).unwrap();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x55;
    std::fs::write(&file, bytes).unwrap();
    let out = compare(&cache);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: cached reference of enderton not trusted"),
        "{stderr}"
    );
    // A cache folder that cannot exist (a file is in the way): said, and the run goes on.
    let blocked = dir.join("blocked");
    std::fs::write(&blocked, b"a file").unwrap();
    let out = compare(&blocked.join("cache"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("warning: reference of enderton not cached"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Ctrl-C (SIGINT to the process group, as a terminal sends it) stops `compare` after the run
/// in progress: exit 130, a line saying how to resume, and results.json marked incomplete
/// with what finished; `--resume` then completes it.
#[test]
fn ctrl_c_stops_compare_with_what_finished_and_resume_completes_it() {
    use std::os::unix::process::CommandExt;
    if oit_gpu::testing::context_or_skip("cli ctrl-c").is_none() {
        return;
    }
    let dir = temp_dir("ctrlc");
    let out_dir = dir.join("out");
    let args = |c: &mut Command| {
        c.args([
            "compare",
            "scenes",
            "--resolution",
            "16x16",
            "--frames",
            "1",
        ])
        .args([
            "--warmup",
            "0",
            "-t",
            "unsorted",
            "-t",
            "sorted-object",
            "--no-cache",
        ])
        .arg("--out")
        .arg(&out_dir);
    };
    let mut command = oit();
    args(&mut command);
    let child = command
        .process_group(0)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let results = out_dir.join("results.json");
    let start = std::time::Instant::now();
    while !std::fs::read_to_string(&results).is_ok_and(|t| t.contains("\"technique\"")) {
        assert!(start.elapsed().as_secs() < 300, "no run finished");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let group = format!("-{}", child.id());
    assert!(
        Command::new("kill")
            .args(["-INT", "--", &group])
            .status()
            .unwrap()
            .success()
    );
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("--resume"), "{stderr}");
    let partial: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&results).unwrap()).unwrap();
    assert_eq!(partial["complete"], false);
    let done = partial["runs"].as_array().unwrap().len();
    let all_runs = 2 * bundled_scene_count();
    assert!((1..all_runs).contains(&done), "{done} runs");
    let mut command = oit();
    args(&mut command);
    let out = command.arg("--resume").output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let full: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&results).unwrap()).unwrap();
    assert!(
        full.get("complete").is_none(),
        "complete files omit the flag"
    );
    assert_eq!(full["runs"].as_array().unwrap().len(), all_runs);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `oit reference --animation-frames A..B` writes one EXR and PNG per frame, `-fNNNN` before
/// the extension, and each frame is that frame (the fading sphere's alpha, hence the image,
/// changes); a frame the scene does not have is one clear line, and nothing is written.
#[test]
fn reference_writes_the_asked_frames_of_an_animated_scene() {
    let dir = temp_dir("reference-frames");
    let exr = dir.join("fade.exr");
    let out = oit()
        .args([
            "reference",
            "scenes/motion/motion-fade.json",
            "--resolution",
            "32x32",
            "--animation-frames",
            "0..24:11",
            "-o",
        ])
        .arg(&exr)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let frames: Vec<_> = [0, 11, 22]
        .iter()
        .map(|t| {
            let path = dir.join(format!("fade-f{t:04}.exr"));
            assert!(dir.join(format!("fade-f{t:04}.png")).is_file());
            oit_metrics::read_exr_rgba(&path, None).unwrap()
        })
        .collect();
    assert_ne!(frames[0].pixels, frames[1].pixels);
    assert_ne!(frames[1].pixels, frames[2].pixels);
    assert!(
        !exr.exists(),
        "no unnumbered file when several frames are written"
    );

    let empty = temp_dir("reference-frames-bad");
    let out = oit()
        .args([
            "reference",
            "scenes/motion/motion-fade.json",
            "--animation-frames",
            "20..30",
            "-o",
        ])
        .arg(empty.join("x.exr"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("0..24") && stderr.contains("motion-fade.json"),
        "{stderr}"
    );
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert_eq!(std::fs::read_dir(&empty).unwrap().count(), 0);
}

/// `--shard` takes K/N with 1 ≤ K ≤ N, and says so in one line naming the flag and what it got.
#[test]
fn a_bad_shard_is_a_usage_error_naming_what_is_allowed() {
    for (bad, says) in [
        ("0/3", "K 0 is outside 1..=3"),
        ("4/3", "K 4 is outside 1..=3"),
        ("1/0", "N is 0"),
        ("2", "not K/N"),
    ] {
        let out = oit()
            .args(["compare", "scenes/enderton.json", "--shard", bad])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{bad}: {stderr}");
        let line = stderr.lines().next().unwrap_or_default();
        assert!(
            line.contains("--shard") && line.contains(says) && line.contains("1 ≤ K ≤ N"),
            "{bad}: {stderr}"
        );
    }
}

/// `--target-format` of `compare` takes a comma-separated list and of `render` one format; a
/// bad name is a usage error naming the flag, the value and every allowed format.
#[test]
fn a_bad_target_format_is_a_usage_error_naming_the_flag_and_allowed_values() {
    for args in [
        &[
            "compare",
            "scenes/enderton.json",
            "--target-format",
            "rgba8unorm,rgba8",
        ][..],
        &["compare", "scenes/enderton.json", "--target-format", ""][..],
        &[
            "render",
            "scenes/enderton.json",
            "-t",
            "unsorted",
            "--target-format",
            "bgra8unorm",
        ][..],
    ] {
        let out = oit().args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        let line = stderr.lines().next().unwrap_or_default();
        assert!(
            line.contains("--target-format")
                && line.contains("not a target format")
                && line.contains("allowed: rgba8unorm, rgba16float, rgba32float"),
            "{args:?}: {stderr}"
        );
    }
}

/// The list is read in full (case-insensitive, each format once) and multiplies the runs:
/// `--max-runs` counts a run per scene × technique × format, before any GPU is opened.
#[test]
fn target_formats_multiply_the_runs_counted_against_max_runs() {
    let out = oit()
        .args([
            "compare",
            "scenes/enderton.json",
            "-t",
            "unsorted",
            "--target-format",
            "rgba8unorm,RGBA32Float,rgba16float,rgba8unorm",
            "--max-runs",
            "2",
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(
            "3 runs (1 scenes × 1 techniques × 3 target formats) is more than --max-runs 2"
        ),
        "{stderr}"
    );
}

/// `oit render --target-format rgba8unorm`: every channel is a whole number of 1/255 steps and
/// the image is within a step of the rgba16float render.
#[test]
fn render_into_rgba8unorm_quantises_to_255_steps() {
    if oit_gpu::testing::context_or_skip("cli render rgba8unorm").is_none() {
        return;
    }
    let dir = temp_dir("render-unorm");
    let render = |format: &str| {
        let exr = dir.join(format!("{format}.exr"));
        let out = oit()
            .args([
                "render",
                "scenes/enderton.json",
                "--technique",
                "sorted-object",
                "--resolution",
                "32x32",
                "--target-format",
                format,
                "-o",
            ])
            .arg(&exr)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        oit_metrics::read_exr_rgba(&exr, Some("render")).unwrap()
    };
    let (byte, half) = (render("rgba8unorm"), render("rgba16float"));
    let mut apart = 0f32;
    for (p, q) in byte.pixels.iter().zip(&half.pixels) {
        for c in 0..4 {
            let steps = p[c] * 255.0;
            assert!((steps - steps.round()).abs() < 1e-3, "{p:?} is not n/255");
            apart = apart.max((p[c] - q[c]).abs());
        }
    }
    assert!(apart > 0.0 && apart <= 2.0 / 255.0, "{apart}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A results.json as `oit compare --shard K/N` writes it, with no runs (no GPU needed).
fn shard_file(dir: &Path, index: u32, count: u32, plan: &str) {
    std::fs::create_dir_all(dir).unwrap();
    let json = format!(
        r#"{{"schema": "oit-lab/results/v1",
            "adapter": {{"name": "a{index}", "backend": "vulkan", "device_type": "cpu", "driver": "d"}},
            "runs": [],
            "shard": {{"index": {index}, "count": {count}, "runs": 0, "plan": "{plan}"}}}}"#
    );
    std::fs::write(dir.join("results.json"), json).unwrap();
}

/// `oit merge` refuses, in one line naming the file and the field, a foreign file, a whole
/// comparison, a shard of another comparison, a shard given twice and a missing shard; it
/// merges shards of one comparison, says where the timings came from, and never writes into a
/// shard.
#[test]
fn merge_refuses_foreign_files_and_joins_shards_of_one_comparison() {
    let dir = temp_dir("merge");
    let (one, two, out) = (dir.join("s1"), dir.join("s2"), dir.join("merged"));
    shard_file(&one, 1, 2, "abc");
    let merge = |dirs: &[&Path], extra: &[&str]| {
        let mut c = oit();
        c.arg("merge").args(dirs).arg("--out").arg(&out).args(extra);
        c.output().unwrap()
    };
    let fails = |dirs: &[&Path], extra: &[&str], file: &Path, says: &[&str]| {
        let o = merge(dirs, extra);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(&file.display().to_string()), "{stderr}");
        for s in says {
            assert!(stderr.contains(s), "{s} in {stderr}");
        }
        assert!(!out.join("results.json").exists(), "nothing merged");
    };
    std::fs::create_dir_all(&two).unwrap();
    std::fs::write(two.join("results.json"), r#"{"schema": "x"}"#).unwrap();
    fails(
        &[&one, &two],
        &[],
        &two.join("results.json"),
        &["schema is `x`"],
    );
    std::fs::write(
        two.join("results.json"),
        r#"{"schema": "oit-lab/results/v1", "adapter": {"name": "a", "backend": "b", "device_type": "c", "driver": "d"}, "runs": []}"#,
    )
    .unwrap();
    fails(
        &[&one, &two],
        &[],
        &two.join("results.json"),
        &["no `shard` field"],
    );
    shard_file(&two, 2, 2, "other");
    fails(
        &[&one, &two],
        &[],
        &two.join("results.json"),
        &["`shard.plan` is other", "abc"],
    );
    shard_file(&two, 1, 2, "abc");
    fails(
        &[&one, &two],
        &[],
        &two.join("results.json"),
        &["shard 1/2 again"],
    );
    let o = merge(&[&one], &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("shards 2 of 2 are missing") && stderr.contains("--allow-missing"));

    shard_file(&two, 2, 2, "abc");
    let o = merge(&[&two, &one], &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("merged from shards 1, 2 of 2"));
    let merged: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(merged["merged"].as_array().map(Vec::len), Some(2));
    assert_eq!(merged["merged"][1]["adapter"]["name"], "a2");
    assert_eq!(merged["adapter"]["name"], "a1 | a2");
    assert!(merged.get("shard").is_none());
    let md = std::fs::read_to_string(out.join("results.md")).unwrap();
    assert!(md.contains("compare only within one shard"), "{md}");
    assert!(out.join("report.html").is_file());
    // Merging again replaces its own merge, never a shard.
    assert!(merge(&[&one, &two], &[]).status.success());
    let o = oit()
        .args(["merge"])
        .args([&one, &two])
        .arg("--out")
        .arg(&one)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("the merge never writes into its inputs"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A downloaded model's folder holds `metadata.json` beside it: skipped with a note, not read
/// as a broken scene; a file meant as a scene (it has `objects`) that is malformed still fails.
/// `compare` on a folder with a broken scene writes everything for the good one and exits 4.
#[test]
fn non_scene_files_are_skipped_and_failed_runs_exit_4() {
    let out = oit()
        .args(["scenes", "assets/GlassVaseFlowers"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("note: skipped: not a scene: assets/GlassVaseFlowers/metadata.json"),
        "{stderr}"
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("GlassVaseFlowers"));
    let dir = temp_dir("non-scenes");
    let scenes = dir.join("scenes");
    std::fs::create_dir_all(&scenes).unwrap();
    std::fs::copy("../../scenes/enderton.json", scenes.join("a-enderton.json")).unwrap();
    std::fs::write(
        scenes.join("b-broken.json"),
        r#"{"name": "b", "objects": 3}"#,
    )
    .unwrap();
    let out = oit().arg("scenes").arg(&scenes).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("b-broken.json"));
    if oit_gpu::testing::context_or_skip("cli failed runs").is_none() {
        return;
    }
    let results = dir.join("out");
    let out = oit()
        .arg("compare")
        .arg(&scenes)
        .args(["--resolution", "16x16", "--frames", "1", "--warmup", "0"])
        .args(["-t", "unsorted", "--no-cache", "--out"])
        .arg(&results)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(4), "{stderr}");
    assert!(stderr.contains("oit: 1 of 2 runs failed"), "{stderr}");
    assert!(results.join("report.html").is_file());
    assert!(results.join("enderton/unsorted.exr").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The scene files in scenes/ (not its subfolders): what `oit scenes scenes` lists and
/// `oit compare scenes` runs.
fn bundled_scene_count() -> usize {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    std::fs::read_dir(dir)
        .unwrap()
        .filter(|e| {
            let path = e.as_ref().unwrap().path();
            path.extension().is_some_and(|x| x == "json")
        })
        .count()
}
