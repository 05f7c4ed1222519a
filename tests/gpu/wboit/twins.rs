//! The WGSL weight functions against their CPU twins (`Weight::eval`, `RangeParams::weight`,
//! `Camera::view_distance`), evaluated on the GPU by a compute kernel that calls the shader's
//! own functions over a grid of inputs. cargo-mutants does not mutate WGSL: a constant changed
//! in the shader alone (or in the twin alone) fails here. The grid reaches every term and both
//! sides of every clamp: view distances from 0.05 to 2000 (eq7's and eq8's (z/200)^6 term is
//! visible just below their clamp, around z = 150), depths up to 0.999 and coverages down to
//! 5e-4 (where McGuire's weight leaves its 3e2 cap).

use oit_gpu::testing::{context_or_skip, eval_f32, is_llvmpipe};
use oit_wboit::RangeParams;
use oit_wboit::Weight;

const Z: [f32; 16] = [
    0.05, 0.5, 1.0, 2.5, 5.0, 9.0, 20.0, 50.0, 100.0, 140.0, 150.0, 158.0, 190.0, 300.0, 800.0,
    2000.0,
];
const D: [f32; 8] = [0.0, 0.05, 0.3, 0.7, 0.95, 0.98, 0.995, 0.999];
const ALPHA: [f32; 6] = [0.0005, 0.004, 0.1, 0.5, 0.9, 1.0];

/// Pure f32 arithmetic on both sides; the GPU may contract into fma and round the powers
/// differently: a few ulps. The measured worst case is printed.
const ARITHMETIC_TOLERANCE: f32 = 4e-6;
/// `exp2` on the GPU is allowed 3 + 2|x| ulps (Vulkan); x ≤ 21 here.
const EXP2_TOLERANCE: f32 = 2e-5;
/// On llvmpipe, which repeats bit for bit, every weight and the view distance are bounded near
/// what it achieves: worst 1.65e-7 relative (mcguire2015), 1.77e-7 (`range`, exp2), 1.05e-7
/// (eq10), 0 for the rest and for the view distance; 4e-7 is 2.3× the worst (about 3 ulps).
/// Other adapters get the spec-derived bounds above.
const LLVMPIPE_TOLERANCE: f32 = 4e-7;

/// `(arithmetic, exp2)` tolerances for this adapter.
fn tolerances(ctx: &oit_gpu::Context) -> (f32, f32) {
    if is_llvmpipe(ctx) {
        (LLVMPIPE_TOLERANCE, LLVMPIPE_TOLERANCE)
    } else {
        (ARITHMETIC_TOLERANCE, EXP2_TOLERANCE)
    }
}

fn accum_source() -> String {
    oit_gpu::shaders::compose_with(oit_wboit::ACCUM_WGSL, &[oit_wboit::SHADERS])
        .expect("includes resolve")
}

/// `WboitParams` of shaders/wboit_accum.wgsl with the `range` inputs set (48 bytes).
fn params(range: &RangeParams) -> Vec<u8> {
    let words: [u32; 12] = [
        7,
        0,
        0,
        range.fall.to_bits(),
        0,
        0,
        range.z_near.to_bits(),
        range.z_far.to_bits(),
        1.0f32.to_bits(),
        0,
        0,
        0,
    ];
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

fn relative(gpu: f32, cpu: f32) -> f32 {
    (gpu - cpu).abs() / cpu.abs().max(f32::MIN_POSITIVE)
}

#[test]
fn every_weight_on_the_gpu_equals_its_cpu_twin() {
    let Some(ctx) = context_or_skip("wboit_weights_against_twins") else {
        return;
    };
    let range = RangeParams {
        z_near: 1.0,
        z_far: 300.0,
        fall: 9.0,
        color_scale: 1.0,
    };
    let mut inputs = Vec::new();
    for z in Z {
        for d in D {
            for a in ALPHA {
                inputs.push([z, d, a, 0.0]);
            }
        }
    }
    let source = accum_source();
    let uniform = params(&range);
    let mut failures = Vec::new();
    for weight in Weight::ALL {
        let expr = format!("weight({}u, x.x, x.y, x.z)", weight.index());
        let gpu =
            eval_f32(&ctx, &source, &expr, &inputs, Some(&uniform), &[]).expect("kernel runs");
        let (arithmetic, exp2) = tolerances(&ctx);
        let tolerance = if *weight == Weight::Range {
            exp2
        } else {
            arithmetic
        };
        let mut worst = 0.0f32;
        for (x, g) in inputs.iter().zip(&gpu) {
            let cpu = weight.eval(x[0], x[1], x[2], &range);
            let e = relative(*g, cpu);
            worst = worst.max(e);
            if e > tolerance || !g.is_finite() {
                failures.push(format!(
                    "{}: z {} d {} α {}: GPU {g} CPU {cpu} (relative {e:.1e})",
                    weight.name(),
                    x[0],
                    x[1],
                    x[2]
                ));
            }
        }
        println!("{:12} worst relative difference {worst:.2e}", weight.name());
    }
    failures.truncate(20);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The weights differ where the grid says they do: a grid on which a term or a clamp never
/// mattered would let a changed constant through.
#[test]
fn the_grid_reaches_every_term_and_clamp() {
    let range = RangeParams {
        z_near: 1.0,
        z_far: 300.0,
        fall: 9.0,
        color_scale: 1.0,
    };
    let grid = || {
        Z.iter().flat_map(|&z| {
            D.iter()
                .flat_map(move |&d| ALPHA.iter().map(move |&a| (z, d, a)))
        })
    };
    // eq7/eq8: (z/200)^6 moves the unclamped weight by more than the tolerance somewhere.
    let sixth = |z: f32| (z / 200.0).powi(6);
    assert!(grid().any(|(z, _, a)| {
        let w = Weight::Eq7.eval(z, 0.0, a, &range) / a;
        w > 1e-2 && w < 3e3 && sixth(z) / (z / 5.0).powi(2) > 100.0 * ARITHMETIC_TOLERANCE
    }));
    assert!(grid().any(|(z, _, a)| {
        let w = Weight::Eq8.eval(z, 0.0, a, &range) / a;
        w > 1e-2 && w < 3e3 && sixth(z) / (z / 10.0).powi(3) > 100.0 * ARITHMETIC_TOLERANCE
    }));
    // Every clamped weight is inside and at its caps somewhere. McGuire's low cap is out of
    // reach for α, d in [0, 1] (its smallest value is (0.01)³·1e8·(0.05)³ = 0.0125 > 1e-2), so
    // only its high cap is required.
    for (weight, lo, hi) in [
        (Weight::Eq7, 1e-2, 3e3),
        (Weight::Eq8, 1e-2, 3e3),
        (Weight::Eq9, 1e-2, 3e3),
        (Weight::McGuire2015, 0.0, 3e2),
    ] {
        let unscaled = |(z, d, a): (f32, f32, f32)| {
            let w = weight.eval(z, d, a, &range);
            if weight == Weight::McGuire2015 {
                w
            } else {
                w / a
            }
        };
        assert!(
            lo == 0.0 || grid().any(|x| unscaled(x) == lo),
            "{} low cap",
            weight.name()
        );
        assert!(
            grid().any(|x| unscaled(x) == hi),
            "{} high cap",
            weight.name()
        );
        assert!(
            grid().any(|x| unscaled(x) > lo && unscaled(x) < hi),
            "{} unclamped",
            weight.name()
        );
    }
    assert!(grid().any(|(_, d, a)| Weight::Eq10.eval(0.0, d, a, &range) / a > 1e-2));
    assert!(grid().any(|(_, d, a)| Weight::Eq10.eval(0.0, d, a, &range) / a == 1e-2));
}

/// The view distance the weights see, from window depth, for a perspective and an
/// orthographic camera in both depth directions.
#[test]
fn view_distance_on_the_gpu_equals_the_camera_twin() {
    let Some(ctx) = context_or_skip("wboit_view_distance_twin") else {
        return;
    };
    let source = accum_source();
    for (projection, reverse_z) in [
        (
            oit_scene::Projection::Perspective {
                fov_y_degrees: 50.0,
            },
            false,
        ),
        (
            oit_scene::Projection::Perspective {
                fov_y_degrees: 50.0,
            },
            true,
        ),
        (oit_scene::Projection::Orthographic { height: 4.0 }, false),
        (oit_scene::Projection::Orthographic { height: 4.0 }, true),
    ] {
        let camera = oit_scene::Camera::new(
            glam::Vec3::ZERO,
            glam::Vec3::new(0.0, 0.0, -1.0),
            glam::Vec3::Y,
            projection,
            0.1,
            500.0,
            reverse_z,
            1.0,
        );
        let (a, b, ortho) = camera.view_depth_terms();
        let windows: Vec<f32> = (1..200).map(|i| i as f32 / 200.0).collect();
        let inputs: Vec<[f32; 4]> = windows.iter().map(|&w| [w, a, b, 0.0]).collect();
        let expr = format!("wboit_view_distance(x.x, x.y, x.z, {ortho})");
        let gpu = eval_f32(&ctx, &source, &expr, &inputs, None, &[]).expect("kernel runs");
        let mut worst = 0.0f32;
        for (w, g) in windows.iter().zip(&gpu) {
            let cpu = camera.view_distance(*w);
            worst = worst.max(relative(*g, cpu));
            assert!(
                relative(*g, cpu) <= tolerances(&ctx).0,
                "{projection:?} reverse_z {reverse_z}: window {w}: GPU {g} CPU {cpu}"
            );
        }
        println!("{projection:?} reverse_z {reverse_z}: worst relative difference {worst:.2e}");
    }
}
