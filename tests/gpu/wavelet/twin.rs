//! The WGSL basis (shaders/wavelet_math.wgsl) against its CPU twin (`oit_wavelet::math`),
//! evaluated on the GPU by a compute kernel that calls the shader's own functions: the
//! projection, the reconstruction, the signal correction and the total, on every rank, over
//! fragment sets that put steps at cell boundaries, inside cells, at both ends and in one cell
//! together. A constant or index changed on one side alone fails here. Also: the shaders parse
//! and validate with naga and share their constants with the CPU.

use oit_gpu::testing::{context_or_skip, eval_f32, is_llvmpipe};
use oit_wavelet::math::{self, MAX_COEFFICIENTS};

/// Fragments (absorbance, normalised depth): both ends, a cell boundary of every rank (8/15 is
/// a boundary of 16 cells after the (N − 1)/N scale), and a pair in one cell.
const FRAGMENTS: [(f32, f32); 8] = [
    (0.7, 0.0),
    (1.3, 1.0),
    (0.2, 0.533_333_3),
    (2.5, 0.31),
    (0.05, 0.3125),
    (11.512_925, 0.77),
    (0.9, 0.125),
    (0.4, 0.999),
];

/// WGSL that builds the coefficients of the fragments selected by the bits of `mask` and
/// evaluates one of the basis functions (`what`: 0 absorbance at `depth`, 1 the absorbance in
/// front of fragment `which` (its own step taken out), 2 the total, 3 coefficient `which`).
fn kernel_source() -> String {
    let table: Vec<String> = FRAGMENTS
        .iter()
        .map(|(a, d)| format!("vec2<f32>({a:?}, {d:?})"))
        .collect();
    format!(
        "{math}\n\
         const FRAGMENTS = array<vec2<f32>, 8>({table});\n\
         fn twin_eval(x: vec4<f32>) -> f32 {{\n\
             let bits = u32(x.x);\n\
             let rank = bits >> 16u;\n\
             let mask = bits & 255u;\n\
             let what = (bits >> 8u) & 15u;\n\
             let which = u32(x.w);\n\
             var c: array<f32, 32>;\n\
             for (var i = 0u; i < 8u; i++) {{\n\
                 if (mask & (1u << i)) != 0u {{\n\
                     wavelet_project(&c, rank, FRAGMENTS[i].x, FRAGMENTS[i].y);\n\
                 }}\n\
             }}\n\
             if what == 0u {{ return wavelet_absorbance_at(&c, rank, x.z); }}\n\
             if what == 1u {{ return wavelet_absorbance_before(&c, rank, FRAGMENTS[which].y, FRAGMENTS[which].x); }}\n\
             if what == 2u {{ return wavelet_total_absorbance(&c, rank); }}\n\
             return c[which];\n\
         }}\n",
        math = oit_wavelet::MATH_WGSL,
        table = table.join(", ")
    )
}

fn cpu_eval(rank: u32, mask: u32, what: u32, depth: f32, which: usize) -> f32 {
    let mut c = [0.0f32; MAX_COEFFICIENTS];
    for (i, &(a, d)) in FRAGMENTS.iter().enumerate() {
        if mask & (1 << i) != 0 {
            math::project(&mut c, rank, a, d);
        }
    }
    match what {
        0 => math::absorbance_at(&c, rank, depth),
        1 => {
            let (a, d) = FRAGMENTS[which];
            math::absorbance_before(&c, rank, d, a)
        }
        2 => math::total_absorbance(&c, rank),
        _ => c[which],
    }
}

/// f32 arithmetic on both sides; the GPU may contract a · b + c into an fma: a few ulps of the
/// largest term (absorbances reach 18 here). On llvmpipe the measured worst is printed and
/// bounded at 2× it.
const TOLERANCE: f32 = 2e-5;
const LLVMPIPE_TOLERANCE: f32 = 4e-6;

#[test]
fn the_basis_on_the_gpu_equals_its_cpu_twin() {
    let Some(ctx) = context_or_skip("wavelet_basis_against_twin") else {
        return;
    };
    let masks = [
        1u32,
        0b11,
        0b1_0001,
        0b1_1000,
        0b111_1111,
        0xff,
        0b1010_0110,
    ];
    let depths = [0.0f32, 0.1, 0.3125, 0.5, 0.533_333_3, 0.77, 0.999, 1.0];
    let mut inputs = Vec::new();
    let mut expected = Vec::new();
    for rank in 2..=4u32 {
        for &mask in &masks {
            for what in 0..4u32 {
                let whiches: Vec<usize> = match what {
                    1 => (0..8).filter(|i| mask & (1 << i) != 0).collect(),
                    3 => (0..math::coefficient_count(rank) as usize).collect(),
                    _ => vec![0],
                };
                let ds: &[f32] = if what == 0 { &depths } else { &[0.0] };
                for &which in &whiches {
                    for &d in ds {
                        let bits = (rank << 16) | (what << 8) | mask;
                        inputs.push([bits as f32, 0.0, d, which as f32]);
                        expected.push((
                            (rank, mask, what, d, which),
                            cpu_eval(rank, mask, what, d, which),
                        ));
                    }
                }
            }
        }
    }
    let gpu =
        eval_f32(&ctx, &kernel_source(), "twin_eval(x)", &inputs, None, &[]).expect("kernel runs");
    let tolerance = if is_llvmpipe(&ctx) {
        LLVMPIPE_TOLERANCE
    } else {
        TOLERANCE
    };
    let mut worst = 0.0f32;
    let mut failures = Vec::new();
    for ((case, cpu), g) in expected.iter().zip(&gpu) {
        let e = (g - cpu).abs() / cpu.abs().max(1.0);
        worst = worst.max(e);
        if e > tolerance || !g.is_finite() {
            failures.push(format!("{case:?}: GPU {g} CPU {cpu}"));
        }
    }
    println!(
        "{} evaluations, worst |GPU − CPU| / max(|CPU|, 1) = {worst:.2e}",
        inputs.len()
    );
    failures.truncate(20);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // The grid reaches what it claims: signal correction changes the answer (a fragment
    // behind another sees it), and rank changes the reconstruction between cells.
    let a = cpu_eval(3, 0b11, 1, 0.0, 1);
    let b = cpu_eval(3, 0b10, 0, FRAGMENTS[1].1, 0);
    assert!((a - 0.7).abs() < 1e-5 && a != b, "{a} {b}");
    assert_ne!(
        cpu_eval(2, 0b1_1000, 1, 0.0, 3),
        cpu_eval(4, 0b1_1000, 1, 0.0, 3)
    );
}

fn validate(name: &str, code: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(code)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(code)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(code)));
    module
}

#[test]
fn passes_and_composite_validate_and_share_the_constants() {
    let code = oit_gpu::shaders::compose_with(oit_wavelet::PASSES_WGSL, &[oit_wavelet::SHADERS])
        .expect("includes resolve");
    let m = validate("wavelet.wgsl", &code);
    let entries: Vec<&str> = m.entry_points.iter().map(|e| e.name.as_str()).collect();
    for e in ["fs_range", "fs_coefficients", "fs_shade", "fs_additive"] {
        assert!(entries.contains(&e), "{e} in {entries:?}");
    }
    let code = oit_gpu::shaders::compose_with(oit_wavelet::COMPOSITE_WGSL, &[oit_wavelet::SHADERS])
        .expect("includes resolve");
    validate("wavelet_composite.wgsl", &code);
    assert!(
        !oit_wavelet::MATH_WGSL.contains("@group") && !oit_wavelet::MATH_WGSL.contains("#include")
    );
    for (name, value) in [
        ("WAVELET_MIN_TRANSMITTANCE", math::MIN_TRANSMITTANCE),
        ("WAVELET_MAX_TRANSMITTANCE", math::MAX_TRANSMITTANCE),
        ("WAVELET_SQRT_HALF", math::SQRT_HALF),
    ] {
        let line = (oit_wavelet::MATH_WGSL.lines())
            .find(|l| l.starts_with(&format!("const {name}: f32 = ")))
            .unwrap_or_else(|| panic!("{name} missing"));
        let v: f32 = line
            .rsplit(' ')
            .next()
            .unwrap()
            .trim_end_matches(';')
            .parse()
            .unwrap();
        assert_eq!(v, value, "{name}");
    }
}
