//! `peel_key` and `half_uniform` of shaders/peel_common.wgsl against their CPU twins in
//! `oit_peel::encoding`, evaluated on the GPU by a compute kernel calling the shader's own
//! functions with the override constants the passes set, for every encoding, key direction and
//! key precision, on perspective (standard and reverse-Z) and orthographic cameras. cargo-mutants
//! does not mutate WGSL: a constant or branch changed on one side only fails here.

use oit_gpu::testing::{context_or_skip, eval_f32};
use oit_peel::{DepthEncoding, KeyParams, half_uniform, peel_key};

/// peel_common.wgsl with its includes, as the peel passes compose it.
fn source() -> String {
    let common = oit_gpu::shaders::resolve("peel_common.wgsl", &[oit_peel::SHADERS])
        .expect("peel_common.wgsl in the crate's shaders");
    oit_gpu::shaders::compose_with(common, &[oit_peel::SHADERS, oit_wboit::SHADERS])
        .expect("includes resolve")
}

/// Quads from view distance 1 to 60 (so the key interval is [1, 60]) under `camera`.
fn scene(camera: &str, reverse_z: bool) -> oit_scene::Scene {
    let json = format!(
        r#"{{"name": "keys", "description": "", "resolution": [8, 8], "reverse_z": {reverse_z},
        "camera": {camera}, "background": [0, 0, 0],
        "objects": [
          {{"mesh": {{"kind": "quad", "size": [1, 1]}}, "transform": {{"translate": [0, 0, -1]}},
            "material": {{"base_color": [1, 1, 1], "alpha": 0.5, "mode": "blend"}}}},
          {{"mesh": {{"kind": "quad", "size": [1, 1]}}, "transform": {{"translate": [0, 0, -60]}},
            "material": {{"base_color": [1, 1, 1], "alpha": 0.5, "mode": "blend"}}}}
        ]}}"#
    );
    oit_scene::parse(&json, "keys.json").expect("valid scene")
}

/// One binary16 step at `x` (relative 2^-10 of the value's binade).
fn half_step(x: f32) -> f32 {
    if x <= 0.0 {
        return 2f32.powi(-24);
    }
    2f32.powi(x.log2().floor() as i32 - 10)
}

#[test]
fn peel_keys_on_the_gpu_equal_their_cpu_twin() {
    let Some(ctx) = context_or_skip("peel_key_twins") else {
        return;
    };
    let source = source();
    let cameras = [
        (
            r#"{"eye": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov_y": 50, "near": 0.5, "far": 100}"#,
            false,
        ),
        (
            r#"{"eye": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "fov_y": 50, "near": 0.5, "far": 100}"#,
            true,
        ),
        (
            r#"{"eye": [0, 0, 0], "target": [0, 0, -1], "up": [0, 1, 0], "orthographic": {"height": 4}, "near": 0.5, "far": 100}"#,
            false,
        ),
    ];
    let windows: Vec<f32> = (0..=400)
        .map(|i| i as f32 / 400.0)
        .chain([1e-6, 0.999_999, 0.9995, 0.99, 0.5, 0.123_456_7])
        .collect();
    let inputs: Vec<[f32; 4]> = windows.iter().map(|&z| [z, 0.0, 0.0, 0.0]).collect();
    let mut failures = Vec::new();
    for (camera, reverse_z) in cameras {
        let scene = scene(camera, reverse_z);
        let params = KeyParams::new(&scene);
        let uniform = bytemuck::bytes_of(&params);
        for encoding in [
            DepthEncoding::Window,
            DepthEncoding::Linear,
            DepthEncoding::Log,
        ] {
            for key_reverse in [false, true] {
                for half in [false, true] {
                    let constants = [
                        ("ENCODING", f64::from(encoding.index())),
                        ("KEY_REVERSE", f64::from(u8::from(key_reverse))),
                        ("KEY_HALF", f64::from(u8::from(half))),
                        ("SCENE_REVERSE_Z", f64::from(u8::from(reverse_z))),
                    ];
                    let gpu = eval_f32(
                        &ctx,
                        &source,
                        "peel_key(x.x)",
                        &inputs,
                        Some(uniform),
                        &constants,
                    )
                    .expect("kernel runs");
                    let mut off_by_a_step = 0;
                    for (z, g) in windows.iter().zip(&gpu) {
                        let cpu = peel_key(&params, encoding, key_reverse, half, *z);
                        let label = format!(
                            "reverse_z {reverse_z} ortho {} {encoding:?} key_reverse {key_reverse} half {half}: z {z}: GPU {g} CPU {cpu}",
                            camera.contains("orthographic")
                        );
                        let diff = (g - cpu).abs();
                        // Window keys are exact; linear and log keys are a few f32 ulps apart
                        // at most (`log` on the GPU has 2^-21 absolute error near 1).
                        let tolerance = match encoding {
                            DepthEncoding::Window => 0.0,
                            _ => 4e-6,
                        };
                        if !half {
                            if diff > tolerance {
                                failures.push(label);
                            }
                        } else if diff > 0.0 {
                            // An input within an ulp of a rounding boundary may round to the
                            // neighbouring binary16 value; never further, and only rarely.
                            if diff > half_step(cpu.max(*g)) * 1.001
                                || encoding == DepthEncoding::Window
                            {
                                failures.push(label);
                            } else {
                                off_by_a_step += 1;
                            }
                        }
                    }
                    if off_by_a_step * 100 > windows.len() {
                        failures.push(format!(
                            "reverse_z {reverse_z} {encoding:?} key_reverse {key_reverse}: {off_by_a_step} of {} half keys a step off",
                            windows.len()
                        ));
                    }
                }
            }
        }
    }
    failures.truncate(20);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn half_uniform_on_the_gpu_equals_its_cpu_twin() {
    let Some(ctx) = context_or_skip("half_uniform_twin") else {
        return;
    };
    let source = source();
    let ts: Vec<f32> = (0..=2000)
        .map(|i| i as f32 / 2000.0)
        .chain([-0.5, 1.5, 1e-9, 0.999_99])
        .collect();
    let inputs: Vec<[f32; 4]> = ts.iter().map(|&t| [t, 0.0, 0.0, 0.0]).collect();
    let gpu =
        eval_f32(&ctx, &source, "half_uniform(x.x)", &inputs, None, &[]).expect("kernel runs");
    for (t, g) in ts.iter().zip(&gpu) {
        assert_eq!(g.to_bits(), half_uniform(*t).to_bits(), "t {t}: GPU {g}");
    }
}
