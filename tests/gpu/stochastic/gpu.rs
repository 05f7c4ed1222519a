//! Stochastic techniques against the CPU reference on whatever adapter is present (lavapipe in
//! CI): determinism, convergence with spp, layer correlation, a2c edges, finiteness, memory.

use oit_gpu::testing::context_or_skip;
use oit_gpu::{
    ColorFormat, Context, GpuScene, GpuTimer, Targets, Technique, TechniqueSpec, read_color,
    render_frame,
};
use oit_scene::{LinearImage, Resolution, Scene};
use oit_stochastic::{AlphaToCoverage, Stochastic};
use std::time::Instant;

const RES: Resolution = Resolution {
    width: 128,
    height: 128,
};

fn scene_named(name: &str, res: Resolution) -> Scene {
    crate::kit::bundled(name, res)
}

fn build(spec: &str) -> Box<dyn Technique> {
    TechniqueSpec::build(spec, &oit_stochastic::techniques()).expect("valid spec")
}

/// A scene uploaded once with its targets, rendering any number of specs.
struct Bench<'c> {
    ctx: &'c Context,
    scene: GpuScene,
    targets: Targets,
    timer: GpuTimer,
}

impl<'c> Bench<'c> {
    fn new(ctx: &'c Context, scene: &Scene) -> Self {
        Bench {
            ctx,
            scene: GpuScene::upload(ctx, scene).expect("upload"),
            targets: Targets::new(ctx, scene.resolution, ColorFormat::Rgba16Float)
                .expect("targets"),
            timer: GpuTimer::new(ctx),
        }
    }

    fn render_with(&mut self, technique: &mut dyn Technique) -> LinearImage {
        render_frame(
            self.ctx,
            &self.scene,
            technique,
            &self.targets,
            &mut self.timer,
        )
        .unwrap_or_else(|e| panic!("{}: {e}", technique.spec()));
        read_color(self.ctx, &self.targets).expect("readback")
    }

    fn render(&mut self, spec: &str) -> LinearImage {
        self.render_with(build(spec).as_mut())
    }
}

fn rmse(a: &LinearImage, b: &LinearImage, keep: impl Fn(usize) -> bool) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0u64);
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        if keep(i) {
            for c in 0..3 {
                let d = f64::from(p[c]) - f64::from(q[c]);
                sum += d * d;
            }
            n += 3;
        }
    }
    (sum / n.max(1) as f64).sqrt()
}

/// Least-squares slope of log(y) against log(x).
fn log_log_slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let cov: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let var: f64 = lx.iter().map(|a| (a - mx) * (a - mx)).sum();
    cov / var
}

#[test]
fn same_spec_gives_a_bit_identical_image() {
    let Some(ctx) = context_or_skip("same_spec_gives_a_bit_identical_image") else {
        return;
    };
    let mut bench = Bench::new(&ctx, &scene_named("intersecting-quads", RES));
    for spec in [
        "stochastic:pattern=white,spp=4",
        "stochastic:pattern=blue,spp=4",
        "stochastic:pattern=bayer4",
        "stochastic:pattern=bayer8,seed=primitive",
        "stochastic:pattern=bayer256,seed=primitive,spp=2",
        "stochastic:pattern=hashed,spp=3",
        "a2c:samples=4",
    ] {
        // A fresh technique each time: nothing may depend on state left by an earlier run.
        let a = bench.render(spec);
        let b = bench.render(spec);
        let bits = |img: &LinearImage| -> Vec<u32> {
            img.pixels.iter().flatten().map(|v| v.to_bits()).collect()
        };
        assert!(bits(&a) == bits(&b), "{spec}: two renders differ");
        // And the same technique value rendering twice.
        let mut t = build(spec);
        let c = bench.render_with(t.as_mut());
        let d = bench.render_with(t.as_mut());
        assert!(
            bits(&c) == bits(&d) && bits(&a) == bits(&c),
            "{spec}: re-render differs"
        );
    }
}

/// 3x3 box filter (edge pixels clamp): what a display, the eye or a TAA resolve averages over.
fn box3(img: &LinearImage) -> LinearImage {
    let (w, h) = (img.width as i64, img.height as i64);
    let mut out = img.clone();
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0.0f32; 4];
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let p = img.pixels
                        [((y + dy).clamp(0, h - 1) * w + (x + dx).clamp(0, w - 1)) as usize];
                    for c in 0..4 {
                        sum[c] += p[c] / 9.0;
                    }
                }
            }
            out.pixels[(y * w + x) as usize] = sum;
        }
    }
    out
}

/// RMSE against the reference falls with spp; white noise at the Monte-Carlo rate N^(-1/2);
/// blue noise has the lower error at spp = 1 once the error is seen at more than one pixel
/// (3x3 box-filtered RMSE and FLIP). Per-pixel RMSE cannot tell blue from white: a pixel's
/// threshold is uniform either way, so its variance is the same; blue noise moves the error
/// to high spatial frequencies, which any filter (eye, display, TAA) removes.
#[test]
fn error_falls_with_spp() {
    let Some(ctx) = context_or_skip("error_falls_with_spp") else {
        return;
    };
    let spps = [1u32, 4, 16, 64];
    let mut report = String::new();
    for name in ["many-layers-64", "intersecting-quads"] {
        let scene = scene_named(name, RES);
        let reference = oit_reference::render(&scene, &Default::default());
        let filtered_reference = box3(&reference.image);
        let mut bench = Bench::new(&ctx, &scene);
        let mut at_spp1 = Vec::new();
        for pattern in ["white", "blue", "hashed", "bayer8"] {
            let mut errors = Vec::new();
            for &spp in &spps {
                let t0 = Instant::now();
                let image = bench.render(&format!("stochastic:pattern={pattern},spp={spp}"));
                let ms = t0.elapsed().as_secs_f64() * 1e3;
                let e = rmse(&image, &reference.image, |_| true);
                let filtered = rmse(&box3(&image), &filtered_reference, |_| true);
                let flip = oit_metrics::compare(&image, &reference.image)
                    .expect("compare")
                    .flip_mean;
                report += &format!(
                    "{name} {pattern} spp={spp}: rmse {e:.5}, 3x3 rmse {filtered:.5}, flip {flip:.4} ({ms:.0} ms)\n"
                );
                errors.push(e);
                if spp == 1 {
                    at_spp1.push((pattern, filtered, flip));
                }
            }
            let slope = log_log_slope(&spps.map(f64::from), &errors);
            report += &format!("{name} {pattern}: log-log slope {slope:.3}\n");
            for w in errors.windows(2) {
                assert!(
                    w[1] < w[0],
                    "{name} {pattern}: rmse does not fall: {errors:?}\n{report}"
                );
            }
            if pattern == "white" {
                assert!(
                    (-0.6..=-0.4).contains(&slope),
                    "{name}: white slope {slope}\n{report}"
                );
            } else {
                assert!(slope < -0.3, "{name} {pattern}: slope {slope}\n{report}");
            }
        }
        let (_, white_filtered, white_flip) = at_spp1[0];
        let (_, blue_filtered, blue_flip) = at_spp1[1];
        assert!(
            blue_filtered < 0.95 * white_filtered && blue_flip < white_flip,
            "{name} at spp=1: blue {blue_filtered}/{blue_flip} vs white {white_filtered}/{white_flip}\n{report}"
        );
    }
    println!("{report}");
}

/// Two screen-filling quads of exactly α = 0.5 over a black background.
fn two_halves(bg_alpha: f32) -> Scene {
    let json = format!(
        r#"{{
  "name": "two-halves",
  "resolution": [128, 128],
  "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100}},
  "background": [0, 0, 0],
  "objects": [
    {{"mesh": {{"kind": "quad", "size": [8, 8]}}, "transform": {{"translate": [0, 0, 0.5]}},
      "material": {{"base_color": [1, 0, 0], "alpha": 0.5, "mode": "blend"}}}},
    {{"mesh": {{"kind": "quad", "size": [8, 8]}}, "transform": {{"translate": [0, 0, 0]}},
      "material": {{"base_color": [0, 1, 0], "alpha": {bg_alpha}, "mode": "blend"}}}}
  ]
}}"#
    );
    oit_scene::parse(&json, "two-halves (inline)").expect("inline scene")
}

/// Fraction of pixels where at least one layer survived (not the black background).
fn coverage(image: &LinearImage) -> f64 {
    let covered = image
        .pixels
        .iter()
        .filter(|p| p[0] > 0.0 || p[1] > 0.0 || p[2] > 0.0)
        .count();
    covered as f64 / image.pixels.len() as f64
}

#[test]
fn correlated_layers_cover_half_and_seeds_fix_it() {
    let Some(ctx) = context_or_skip("correlated_layers_cover_half_and_seeds_fix_it") else {
        return;
    };
    let scene = two_halves(0.5);
    let mut bench = Bench::new(&ctx, &scene);
    let mut report = String::new();
    let mut cov = |spec: &str| {
        let c = coverage(&bench.render(spec));
        report += &format!("{spec}: coverage {:.4}\n", c);
        (c, report.clone())
    };
    // The same screen-fixed pattern on both layers: the same pixels survive, 50% not 75%.
    for spec in [
        "stochastic:pattern=bayer4,seed=none",
        "stochastic:pattern=bayer8,seed=none",
        "stochastic:pattern=bayer256,seed=none",
        "stochastic:pattern=blue,seed=none",
    ] {
        let (c, r) = cov(spec);
        assert!((c - 0.5).abs() < 1e-9, "{spec}: {c}\n{r}");
    }
    let (c, r) = cov("stochastic:pattern=white,seed=none");
    assert!((c - 0.5).abs() < 0.02, "white seed=none: {c}\n{r}");
    // Shifting an ordered-dither tile per object cannot decorrelate it: at α = 1/2 the
    // surviving set is a checkerboard, and a shifted checkerboard is either the same (50%)
    // or the complement (100%).
    for spec in [
        "stochastic:pattern=bayer4,seed=object",
        "stochastic:pattern=bayer8,seed=object",
        "stochastic:pattern=bayer64,seed=object",
        "stochastic:pattern=bayer256,seed=object",
    ] {
        let (c, r) = cov(spec);
        assert!(
            (c - 0.5).abs() < 1e-9 || (c - 1.0).abs() < 1e-9,
            "{spec}: {c}\n{r}"
        );
    }
    // Decorrelated seeds: within 2% of 1 − (1 − ½)² = 75%.
    for spec in [
        "stochastic:pattern=blue,seed=object",
        "stochastic:pattern=blue,seed=primitive",
        "stochastic:pattern=white,seed=object",
        "stochastic:pattern=white,seed=primitive",
        "stochastic:pattern=hashed,seed=object",
        "stochastic:pattern=hashed,seed=primitive",
    ] {
        let (c, r) = cov(spec);
        assert!((c - 0.75).abs() < 0.02, "{spec}: {c}\n{r}");
    }
    println!("{report}");
}

/// Pixels next to a change in the reference's transparent layer count: where a transparent
/// triangle edge crosses the pixel and MSAA sees partial coverage.
fn edge_pixels(layers: &[u32], res: Resolution) -> Vec<bool> {
    let (w, h) = (res.width as i64, res.height as i64);
    let at = |x: i64, y: i64| layers[(y.clamp(0, h - 1) * w + x.clamp(0, w - 1)) as usize];
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let c = at(x, y);
            [
                (-1, 0),
                (1, 0),
                (0, -1),
                (0, 1),
                (-1, -1),
                (1, 1),
                (-1, 1),
                (1, -1),
            ]
            .iter()
            .any(|&(dx, dy)| at(x + dx, y + dy) != c)
        })
        .collect()
}

#[test]
fn a2c_interior_and_edge_error() {
    let Some(ctx) = context_or_skip("a2c_interior_and_edge_error") else {
        return;
    };
    let mut report = String::new();
    // One tilted quad of α = 1/2 (exactly 2 of 4 samples) over an opaque quad and the
    // background: inside, a2c is exact; only edges differ from the pixel-centre reference.
    let tilted = oit_scene::parse(
        r#"{
  "name": "tilted-half",
  "resolution": [128, 128],
  "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100},
  "background": [0.1, 0.1, 0.2],
  "objects": [
    {"mesh": {"kind": "quad", "size": [2, 2]}, "transform": {"translate": [0.7, 0, -1]},
      "material": {"base_color": [0.9, 0.8, 0.1], "mode": "opaque"}},
    {"mesh": {"kind": "quad", "size": [2.2, 1.6]}, "transform": {"rotate": [0, 0, 27]},
      "material": {"base_color": [0.2, 0.6, 1], "alpha": 0.5, "mode": "blend"}}
  ]
}"#,
        "tilted-half (inline)",
    )
    .expect("inline scene");
    {
        let reference = oit_reference::render(&tilted, &Default::default());
        let edges = edge_pixels(&reference.layers, RES);
        let image = Bench::new(&ctx, &tilted).render("a2c:samples=4");
        let interior = rmse(&image, &reference.image, |i| !edges[i]);
        let edge = rmse(&image, &reference.image, |i| edges[i]);
        report += &format!("tilted-half a2c:samples=4: interior {interior:.5}, edge {edge:.5}\n");
        // f16 target rounding only inside; a visible difference along the edges.
        assert!(interior < 1e-3, "interior {interior}\n{report}");
        assert!(edge > 0.01, "edge {edge}\n{report}");
    }
    for name in ["intersecting-quads", "sorted-quads", "quad-through-sphere"] {
        let scene = scene_named(name, RES);
        let reference = oit_reference::render(&scene, &Default::default());
        let edges = edge_pixels(&reference.layers, RES);
        let n_edge = edges.iter().filter(|&&e| e).count();
        let mut bench = Bench::new(&ctx, &scene);
        for samples in [4u32, 8] {
            if let Err(e) =
                AlphaToCoverage::supported(&ctx, wgpu::TextureFormat::Rgba16Float, samples)
            {
                report += &format!("{name} a2c:samples={samples}: {e}\n");
                let mut t = build(&format!("a2c:samples={samples}"));
                let err = oit_gpu::render_frame(
                    &ctx,
                    &bench.scene,
                    t.as_mut(),
                    &bench.targets,
                    &mut bench.timer,
                )
                .expect_err("unsupported sample count must be an error");
                assert!(err.to_string().contains("samples"), "{err}");
                continue;
            }
            let image = bench.render(&format!("a2c:samples={samples}"));
            let interior = rmse(&image, &reference.image, |i| !edges[i]);
            let edge = rmse(&image, &reference.image, |i| edges[i]);
            let all = rmse(&image, &reference.image, |_| true);
            let st = rmse(
                &bench.render("stochastic:pattern=blue"),
                &reference.image,
                |_| true,
            );
            report += &format!(
                "{name} a2c:samples={samples}: rmse all {all:.4}, interior {interior:.4}, edge {edge:.4} ({n_edge} edge pixels of {}); stochastic:blue spp=1 all {st:.4}\n",
                RES.pixel_count()
            );
            assert!(interior.is_finite() && edge.is_finite());
        }
    }
    println!("{report}");
}

/// RMSE of each spec of [`every_pattern_and_a2c_is_finite_on_every_bundled_scene`] (in its
/// order) per bundled scene at 128², measured on lavapipe (llvmpipe 15, Mesa 22.3). The patterns
/// are deterministic (a spec renders bit-identically), so a run may exceed its value only by 25 %
/// plus 1e-3: room for another rasterizer's coverage, none for a changed pattern or composite.
/// The four transmission scenes: the stochastic patterns dither per colour channel there;
/// `a2c` (the last column) composites 1 − mean(t) and is not bounded on them.
const MEASURED_RMSE: [(&str, [f64; 7]); 27] = [
    (
        "alpha-099-stack",
        [
            2.6821e-3, 2.7948e-3, 2.7197e-4, 3.3652e-3, 2.7391e-3, 1.9352e-3, 2.7197e-4,
        ],
    ),
    (
        "alpha-extremes",
        [
            1.1878e-1, 1.1883e-1, 1.1868e-1, 1.1868e-1, 1.1883e-1, 1.0676e-1, 9.4855e-2,
        ],
    ),
    (
        "concave-self",
        [
            1.5735e-1, 1.5745e-1, 1.5636e-1, 1.5759e-1, 1.4479e-1, 1.0264e-1, 3.4354e-2,
        ],
    ),
    (
        "coplanar",
        [
            2.0233e-1, 2.0147e-1, 1.9936e-1, 1.9936e-1, 2.0132e-1, 1.4284e-1, 6.2023e-2,
        ],
    ),
    (
        "depth-range",
        [
            3.4381e-1, 3.4221e-1, 3.3209e-1, 3.3209e-1, 3.4221e-1, 2.4196e-1, 1.5522e-1,
        ],
    ),
    (
        "enderton",
        [
            4.6362e-1, 4.6362e-1, 4.5505e-1, 4.5399e-1, 4.6314e-1, 3.3110e-1, 1.8508e-1,
        ],
    ),
    (
        "faint-haze",
        [
            3.7549e-1, 3.7373e-1, 2.4762e-1, 2.4762e-1, 3.7629e-1, 2.6416e-1, 5.0107e-2,
        ],
    ),
    (
        "foliage-cards",
        [
            8.9657e-2, 8.9848e-2, 8.6743e-2, 8.6431e-2, 9.0704e-2, 6.3522e-2, 2.8257e-2,
        ],
    ),
    (
        // Measured again 2026-12-07, when glTF materials became lit per pixel.
        "gltf-alpha-blend-modes",
        [
            1.0834e-1, 1.0804e-1, 1.0988e-1, 1.0810e-1, 1.0880e-1, 7.6861e-2, 3.5072e-2,
        ],
    ),
    (
        "gltf-foliage-mipmaps",
        [
            4.3605e-2, 4.4461e-2, 4.3992e-2, 4.3798e-2, 4.3793e-2, 3.0941e-2, 1.8447e-2,
        ],
    ),
    (
        // a2c 2.2749e-2 → 3.1719e-2 when the right vase became clear transmissive glass (it
        // was drawn OPAQUE before): the flowers inside it are now visible to every technique.
        // Measured again 2026-12-07, lit per pixel.
        "gltf-glass-vase",
        [
            9.3284e-2, 9.3501e-2, 9.3422e-2, 9.3002e-2, 9.3630e-2, 6.5855e-2, 3.3573e-2,
        ],
    ),
    (
        "hdr-emissive",
        [
            1.8780e2, 1.8816e2, 1.5623e2, 1.4555e2, 1.8688e2, 1.3428e2, 7.4722e1,
        ],
    ),
    (
        "intersecting-quads",
        [
            1.8228e-1, 1.8215e-1, 1.6195e-1, 1.6609e-1, 1.8073e-1, 1.2896e-1, 7.9012e-2,
        ],
    ),
    (
        "many-layers-64",
        [
            2.0055e-1, 2.0164e-1, 1.5917e-1, 1.5424e-1, 2.0009e-1, 1.4245e-1, 3.3137e-1,
        ],
    ),
    (
        "opaque-interleaved",
        [
            1.8077e-1, 1.7847e-1, 1.9884e-1, 2.0211e-1, 1.7999e-1, 1.2851e-1, 2.7851e-1,
        ],
    ),
    (
        "particles",
        [
            2.7928e-1, 2.7974e-1, 2.7947e-1, 2.7979e-1, 2.1305e-1, 1.5053e-1, 1.5076e-1,
        ],
    ),
    (
        "quad-through-sphere",
        [
            2.0539e-1, 2.0632e-1, 2.0569e-1, 2.0433e-1, 1.9892e-1, 1.4145e-1, 7.9444e-2,
        ],
    ),
    (
        "sorted-quads",
        [
            1.9202e-1, 1.9188e-1, 1.8067e-1, 1.8064e-1, 1.9247e-1, 1.3689e-1, 5.6017e-2,
        ],
    ),
    (
        "transmission-complementary",
        [
            1.2998e-1, 1.3067e-1, 1.3500e-1, 1.3269e-1, 1.2968e-1, 9.2889e-2, 1.4034e-1,
        ],
    ),
    (
        // Measured again 2026-12-07, lit per pixel.
        "transmission-gltf",
        [
            1.0040e-1, 1.0061e-1, 1.0357e-1, 1.0245e-1, 1.0043e-1, 7.1549e-2, 7.5667e-2,
        ],
    ),
    (
        "transmission-over-blended",
        [
            1.6468e-1, 1.6467e-1, 1.5967e-1, 1.6008e-1, 1.6472e-1, 1.1685e-1, 1.0972e-1,
        ],
    ),
    (
        "transmission-stack-32",
        [
            8.8929e-2, 8.9687e-2, 8.5350e-2, 8.3424e-2, 8.9916e-2, 6.2628e-2, 2.3194e-1,
        ],
    ),
    // Measured 2026-12-07 by this test on lavapipe, additive fragments depth-tested
    // against the survivors.
    (
        "ops-additive-depth-write",
        [
            1.4745e-1, 1.4746e-1, 1.4666e-1, 1.4533e-1, 1.4791e-1, 1.1261e-1, 7.5739e-2,
        ],
    ),
    // Measured 2026-12-07 by this test on lavapipe, additive fragments depth-tested
    // against the survivors.
    (
        "ops-background-overlay",
        [
            1.5329e-1, 1.5322e-1, 1.5650e-1, 1.5777e-1, 1.5318e-1, 1.1143e-1, 7.2073e-2,
        ],
    ),
    // Measured 2026-12-07 by this test on lavapipe, additive fragments depth-tested
    // against the survivors.
    (
        "ops-multiply-tint",
        [
            1.6072e-1, 1.6164e-1, 1.6340e-1, 1.6482e-1, 1.6177e-1, 1.1432e-1, 8.5025e-2,
        ],
    ),
    // Measured 2026-12-07 by this test on lavapipe, additive fragments depth-tested
    // against the survivors.
    (
        "ops-pygfx-mixed",
        [
            9.1108e-2, 9.1034e-2, 9.0472e-2, 9.1069e-2, 9.3288e-2, 6.6291e-2, 2.7739e-2,
        ],
    ),
    // Measured 2026-12-07 by this test on lavapipe, additive fragments depth-tested
    // against the survivors.
    (
        "ops-sparks-smoke-glass",
        [
            3.8550e-1, 3.7575e-1, 3.9089e-1, 3.9060e-1, 3.0756e-1, 2.1315e-1, 2.5619e-1,
        ],
    ),
];

#[test]
fn every_pattern_and_a2c_is_finite_on_every_bundled_scene() {
    let Some(ctx) = context_or_skip("every_pattern_and_a2c_is_finite_on_every_bundled_scene")
    else {
        return;
    };
    let dir = crate::kit::scenes_dir();
    let scenes = oit_scene::load_dir(&dir).expect("bundled scenes");
    assert!(
        scenes.len() >= 10,
        "bundled scenes missing: {}",
        scenes.len()
    );
    let specs = [
        "stochastic:pattern=white",
        "stochastic:pattern=blue",
        "stochastic:pattern=bayer4",
        "stochastic:pattern=bayer8",
        "stochastic:pattern=hashed",
        "stochastic:pattern=blue,seed=primitive,spp=2",
        "a2c:samples=4",
    ];
    let mut report = String::new();
    let mut failures = Vec::new();
    for (path, scene) in scenes {
        let scene = scene.with_resolution(RES);
        let reference = oit_reference::render(&scene, &Default::default());
        let mut bench = Bench::new(&ctx, &scene);
        let mut line = format!(
            "{:24}",
            path.file_stem().unwrap_or_default().to_string_lossy()
        );
        for (index, spec) in specs.iter().enumerate() {
            let image = bench.render(spec);
            let errors = oit_metrics::compare(&image, &reference.image).expect("compare");
            assert_eq!(
                errors.nonfinite,
                0,
                "{spec} on {}: non-finite pixels",
                path.display()
            );
            line += &format!(" {:.4e}", errors.rmse);
            let stem = path.file_stem().unwrap_or_default().to_string_lossy();
            // a2c composites coloured transmission as 1 − mean(t) by design (flagged
            // `approximate transmission`): finite is asserted, the bound is for scalar scenes.
            if scene.has_coloured_transmission() && spec.starts_with("a2c") {
                continue;
            }
            let (_, measured) = MEASURED_RMSE
                .iter()
                .find(|(n, _)| *n == stem)
                .unwrap_or_else(|| panic!("{stem}: no measured RMSE in MEASURED_RMSE; add it"));
            let bound = 1.25 * measured[index] + 1e-3;
            if errors.rmse > bound {
                failures.push(format!(
                    "{spec} on {stem}: RMSE {:.4e} > {bound:.4e}",
                    errors.rmse
                ));
            }
        }
        report += &line;
        report.push('\n');
    }
    println!("rmse per scene for {specs:?}\n{report}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn memory_is_counted_exactly() {
    let Some(ctx) = context_or_skip("memory_is_counted_exactly") else {
        return;
    };
    let scene = scene_named("sorted-quads", RES);
    let mut bench = Bench::new(&ctx, &scene);
    let px = RES.pixel_count() as u64;
    let align = u64::from(ctx.device.limits().min_uniform_buffer_offset_alignment);
    let stride = |size: u64| size.div_ceil(align) * align;
    // `struct Dither` is 40 bytes (nine words padded to its vec2 alignment).
    let cases: [(&str, u64); 7] = [
        // Frame uniforms + 64x64 R32Float thresholds (one texel for procedural patterns).
        ("stochastic:pattern=blue", stride(40) + 4096 * 4),
        ("stochastic:pattern=bayer4", stride(40) + 16 * 4),
        ("stochastic:pattern=bayer256", stride(40) + 65536 * 4),
        ("stochastic:pattern=white", stride(40) + 4),
        // 32 slices of 64x64 stacked: 512 KiB.
        ("stochastic:pattern=stbn", stride(40) + 32 * 4096 * 4),
        // + frame colour (Rgba16Float) and depth, two Rgba32Float sums, 16 accumulate entries.
        (
            "stochastic:pattern=hashed,spp=16",
            16 * stride(40) + 4 + px * (8 + 4 + 16 + 16) + 16 * stride(12),
        ),
        // MSAA colour (Rgba16Float) and depth, 4 samples.
        ("a2c:samples=4", px * 4 * (8 + 4)),
    ];
    for (spec, expected) in cases {
        let mut t = build(spec);
        assert_eq!(
            t.memory_bytes(),
            0,
            "{spec}: nothing before the first render"
        );
        bench.render_with(t.as_mut());
        assert_eq!(t.memory_bytes(), expected, "{spec}");
    }
    // The threshold table is one 2D texture: it must fit the adapter's texture size.
    let mut caps = ctx.caps.clone();
    caps.max_texture_dimension_2d = 255;
    let e = build("stochastic:pattern=bayer256")
        .check(&caps)
        .unwrap_err();
    assert!(e.to_string().contains("256×256 texels"), "{e}");
    build("stochastic:pattern=bayer128").check(&caps).unwrap();
    // STBN's slices are stacked into one 64 × 2048 texture: its height must fit too.
    caps.max_texture_dimension_2d = 2047;
    let e = build("stochastic:pattern=stbn").check(&caps).unwrap_err();
    assert!(e.to_string().contains("64×2048 texels"), "{e}");
    caps.max_texture_dimension_2d = 2048;
    build("stochastic:pattern=stbn").check(&caps).unwrap();
}

/// One white quad of coverage `alpha` filling the screen over black.
fn one_layer(alpha: f32) -> Scene {
    let json = format!(
        r#"{{
  "name": "one-layer",
  "resolution": [32, 32],
  "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100}},
  "background": [0, 0, 0],
  "objects": [
    {{"mesh": {{"kind": "quad", "size": [8, 8]}},
      "material": {{"base_color": [1, 1, 1], "alpha": {alpha}, "mode": "blend"}}}}
  ]
}}"#
    );
    oit_scene::parse(&json, "one-layer (inline)").expect("inline scene")
}

/// The driver's α → sample-mask table, read back through the resolve: the resolved white
/// over black is the covered fraction. It must be a whole number of samples per pixel on
/// average, grow with α, and stay within one sample of α (what alpha-to-coverage promises).
#[test]
fn a2c_coverage_table() {
    let Some(ctx) = context_or_skip("a2c_coverage_table") else {
        return;
    };
    let samples = 4.0;
    let mut previous = -1.0;
    let mut table = String::new();
    for step in 0..=16 {
        let alpha = step as f32 / 16.0;
        let image = Bench::new(&ctx, &one_layer(alpha)).render("a2c:samples=4");
        let mean =
            image.pixels.iter().map(|p| f64::from(p[0])).sum::<f64>() / image.pixels.len() as f64;
        let distinct: std::collections::BTreeSet<u32> =
            image.pixels.iter().map(|p| p[0].to_bits()).collect();
        table += &format!(
            "alpha {alpha:.4}: covered {mean:.4} ({} distinct pixel values)\n",
            distinct.len()
        );
        assert!(mean >= previous, "coverage falls at alpha {alpha}\n{table}");
        assert!(
            (mean - f64::from(alpha)).abs() <= 1.0 / samples + 1e-3,
            "alpha {alpha}: covered {mean}\n{table}"
        );
        for p in &image.pixels {
            let k = f64::from(p[0]) * samples;
            assert!(
                (k - k.round()).abs() < 1e-2,
                "alpha {alpha}: pixel {}\n{table}",
                p[0]
            );
        }
        previous = mean;
    }
    println!("{table}");
}

/// The full-float target works too (frames copy from it, the average is written into it) and
/// agrees with the half-float one up to half rounding.
#[test]
fn rgba32float_target_agrees_with_rgba16float() {
    let Some(ctx) = context_or_skip("rgba32float_target_agrees_with_rgba16float") else {
        return;
    };
    if ctx
        .caps
        .require_target(wgpu::TextureFormat::Rgba32Float, true)
        .is_err()
    {
        eprintln!("skipped: no blendable Rgba32Float target on this adapter");
        return;
    }
    let scene = scene_named("intersecting-quads", RES);
    let gpu_scene = GpuScene::upload(&ctx, &scene).expect("upload");
    let mut timer = GpuTimer::new(&ctx);
    let mut images = Vec::new();
    for format in [ColorFormat::Rgba16Float, ColorFormat::Rgba32Float] {
        let targets = Targets::new(&ctx, RES, format).expect("targets");
        let mut t = build("stochastic:pattern=blue,spp=4");
        render_frame(&ctx, &gpu_scene, t.as_mut(), &targets, &mut timer).expect("render");
        images.push(read_color(&ctx, &targets).expect("readback"));
    }
    let max = images[0]
        .pixels
        .iter()
        .zip(&images[1].pixels)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
        .fold(0.0f32, f32::max);
    assert!(max < 2e-3, "max difference {max}");
}

/// The half-float running mean (what adapters without renderable Rgba32Float get) agrees with
/// the f32 sum up to half rounding, and has the same error against the reference.
#[test]
fn half_float_running_mean_agrees_with_f32_sum() {
    let Some(ctx) = context_or_skip("half_float_running_mean_agrees_with_f32_sum") else {
        return;
    };
    let scene = scene_named("intersecting-quads", RES);
    let reference = oit_reference::render(&scene, &Default::default());
    let mut bench = Bench::new(&ctx, &scene);
    let spec = TechniqueSpec::parse(
        "stochastic:pattern=blue,spp=16",
        &oit_stochastic::techniques(),
    )
    .expect("spec");
    let mut full = oit_stochastic::Stochastic::from_spec(&spec).expect("valid spec");
    let mut half = oit_stochastic::Stochastic::from_spec(&spec)
        .expect("valid spec")
        .with_half_float_sums();
    assert_eq!(half.sum_format(&ctx.caps), wgpu::TextureFormat::Rgba16Float);
    let a = bench.render_with(&mut full);
    let b = bench.render_with(&mut half);
    let max = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0f32, f32::max);
    let (ea, eb) = (
        rmse(&a, &reference.image, |_| true),
        rmse(&b, &reference.image, |_| true),
    );
    println!(
        "spp=16 f32 sum: rmse {ea:.5}; f16 running mean: rmse {eb:.5}; max difference {max:.5}"
    );
    assert!(max < 4e-3, "max difference {max}");
    assert!((ea - eb).abs() < 0.01 * ea, "{ea} vs {eb}");
    let px = RES.pixel_count() as u64;
    assert_eq!(
        full.memory_bytes() - half.memory_bytes(),
        px * 2 * 8,
        "two Rgba32Float sums become two Rgba16Float means"
    );
}

/// The GL backend (where it exists) converges like the default one: wgpu's GL backend once
/// left the per-frame depth copy undone, and every frame after the first showed only the
/// opaque pass. Compared by error against the reference, since rasterizers may differ.
#[test]
fn gl_backend_matches_the_default_backend() {
    let Some(ctx) = context_or_skip("gl_backend_matches_the_default_backend") else {
        return;
    };
    let Some(gl) = oit_gpu::testing::gl_context_or_skip("gl_backend_matches_the_default_backend")
    else {
        return;
    };
    let scene = scene_named("sorted-quads", RES);
    let reference = oit_reference::render(&scene, &Default::default());
    let mut report = String::new();
    for spec in [
        "stochastic:pattern=blue",
        "stochastic:pattern=white,spp=8",
        "stochastic:pattern=hashed,spp=8",
        "a2c:samples=4",
    ] {
        let e = |c: &Context| {
            rmse(
                &Bench::new(c, &scene).render(spec),
                &reference.image,
                |_| true,
            )
        };
        let (default, on_gl) = (e(&ctx), e(&gl));
        report += &format!("{spec}: default {default:.5}, gl {on_gl:.5}\n");
        assert!(
            (default - on_gl).abs() < 0.05 * default,
            "{spec}: default {default} vs gl {on_gl}\n{report}"
        );
    }
    println!("{report}");
}

/// Mean signed RGB difference over the image: a biased estimator leaves a systematic offset
/// that averaging frames does not remove, while noise averages toward 0.
fn mean_signed_difference(a: &LinearImage, b: &LinearImage) -> f64 {
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from(p[c]) - f64::from(q[c])))
        .sum();
    sum / (3 * a.pixels.len()) as f64
}

/// Averaged frames converge to the reference, not to something else: at spp = 64 the mean
/// signed difference over the image is below 1e-3 (1.5e-3 for the structured Bayer table) on
/// deep, intersecting and particle content. Measured at 128² on lavapipe, spp 64: at most
/// 3.6e-4 (white, blue, hashed) and 8.8e-4 (bayer8), the same at spp 128; what remains is the binary16 running
/// mean's rounding (half an ulp at 0.5 is 2.4e-4), while a threshold off by 0.01 moves it by
/// several 1e-3. Particles is one draw, so it needs `seed=primitive`: with the default
/// `seed=object` its layers share one threshold per pixel, the union covers max α rather than
/// 1 − Π(1 − α), and the average converges to a value 0.13 too dark — asserted too, as the
/// documented failure of correlated layers that this test must be able to see.
#[test]
fn averaged_frames_converge_to_the_reference_without_bias() {
    let Some(ctx) = context_or_skip("stochastic_bias") else {
        return;
    };
    let mut failures = Vec::new();
    let mut report = String::new();
    for (name, seed) in [
        ("many-layers-64", "object"),
        ("intersecting-quads", "object"),
        ("particles", "primitive"),
    ] {
        let scene = scene_named(name, RES);
        let reference = oit_reference::render(&scene, &Default::default());
        let mut bench = Bench::new(&ctx, &scene);
        for pattern in ["white", "blue", "hashed", "bayer8"] {
            let image = bench.render(&format!("stochastic:pattern={pattern},seed={seed},spp=64"));
            let bias = mean_signed_difference(&image, &reference.image);
            let bound = if pattern == "bayer8" { 1.5e-3 } else { 1e-3 };
            report +=
                &format!("{name} {pattern} seed={seed}: mean signed difference {bias:+.2e}\n");
            if bias.abs() > bound {
                failures.push(format!(
                    "{name} {pattern}: bias {bias:+.2e} beyond {bound:.1e}"
                ));
            }
        }
        if name == "particles" {
            let image = bench.render("stochastic:pattern=blue,seed=object,spp=64");
            let bias = mean_signed_difference(&image, &reference.image);
            report += &format!("particles blue seed=object: {bias:+.2e}\n");
            assert!(
                bias < -0.1,
                "correlated layers no longer biased? {bias}\n{report}"
            );
        }
    }
    println!("{report}");
    assert!(failures.is_empty(), "{}\n{report}", failures.join("\n"));
}

/// A seeded stack of 16 blended quads on 5 depth levels (so that many overlap exactly
/// coplanar, and ties decide pixels), offset, some tilted so that their depth ranges chain,
/// in random draw order, with random colours and α, in either depth convention.
fn quad_stack_json(seed: u64) -> String {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let objects: Vec<String> = (0..16)
        .map(|_| {
            let z = (next() * 5.0).floor() * 0.4 - 1.0;
            let (x, y) = (next() - 0.5, next() - 0.5);
            let tilt = if next() < 0.3 { 25.0 } else { 0.0 };
            let (r, g, b, a) = (next(), next(), next(), 0.2 + 0.7 * next());
            format!(
                r#"{{"mesh": {{"kind": "quad", "size": [1.2, 1.2]}}, "transform": {{"translate": [{x:.3}, {y:.3}, {z:.3}], "rotate": [0, {tilt}, 0]}}, "material": {{"base_color": [{r:.3}, {g:.3}, {b:.3}], "alpha": {a:.3}, "mode": "blend"}}}}"#
            )
        })
        .collect();
    format!(
        r#"{{"name": "stack-{seed}", "resolution": [64, 64], "reverse_z": {},
            "camera": {{"eye": [0, 0, 4], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100}},
            "objects": [{}]}}"#,
        seed.is_multiple_of(2),
        objects.join(",")
    )
}

/// Groups of draws issued nearest first ([`oit_stochastic::dither_order`]) give the image of
/// plain reverse draw order bit for bit: every bundled scene and 12 seeded quad stacks full of
/// exact coplanar ties ([`quad_stack_json`]), with blue noise, Bayer over two frames, and a2c.
/// The scenes whose order changes are counted (the layer stack must be among them), so the
/// comparison cannot be empty.
#[test]
fn nearest_first_groups_give_the_reverse_draw_order_image_bit_for_bit() {
    let Some(ctx) = context_or_skip("nearest_first_groups_give_the_reverse_draw_order_image")
    else {
        return;
    };
    let res = Resolution {
        width: 64,
        height: 64,
    };
    let dir = crate::kit::scenes_dir();
    let mut scenes: Vec<(String, Scene)> = oit_scene::load_dir(&dir)
        .expect("bundled scenes")
        .into_iter()
        .map(|(path, scene)| (path.display().to_string(), scene.with_resolution(res)))
        .collect();
    for seed in 0..12 {
        let text = quad_stack_json(seed);
        let scene = oit_scene::parse(&text, &format!("stack-{seed}")).expect("quad stack");
        scenes.push((format!("stack-{seed}"), scene.with_resolution(res)));
    }
    let registry = oit_stochastic::techniques();
    let mut reordered = Vec::new();
    let mut failures = Vec::new();
    for (name, scene) in &scenes {
        let mut reverse: Vec<usize> = (0..scene.draws.len())
            .filter(|&i| {
                let d = &scene.draws[i];
                d.vertex_count > 0 && scene.material_of(d).mode.is_transparent()
            })
            .collect();
        reverse.reverse();
        if oit_stochastic::dither_order(scene) != reverse {
            reordered.push(name.clone());
        }
        let mut bench = Bench::new(&ctx, scene);
        for spec in [
            "stochastic:pattern=blue",
            "stochastic:pattern=bayer8,spp=2",
            "a2c:samples=4",
        ] {
            let parsed = TechniqueSpec::parse(spec, &registry).expect("spec");
            let (mut nearest, mut plain): (Box<dyn Technique>, Box<dyn Technique>) =
                if spec.starts_with("a2c") {
                    (
                        Box::new(AlphaToCoverage::from_spec(&parsed).expect("a2c")),
                        Box::new(
                            AlphaToCoverage::from_spec(&parsed)
                                .expect("a2c")
                                .in_reverse_draw_order(),
                        ),
                    )
                } else {
                    (
                        Box::new(Stochastic::from_spec(&parsed).expect("stochastic")),
                        Box::new(
                            Stochastic::from_spec(&parsed)
                                .expect("stochastic")
                                .in_reverse_draw_order(),
                        ),
                    )
                };
            let a = bench.render_with(nearest.as_mut());
            let b = bench.render_with(plain.as_mut());
            let differ = a
                .pixels
                .iter()
                .zip(&b.pixels)
                .filter(|(p, q)| p.map(f32::to_bits) != q.map(f32::to_bits))
                .count();
            if differ > 0 {
                failures.push(format!("{spec} on {name}: {differ} pixels differ"));
            }
        }
    }
    println!(
        "reordered: {} of {} scenes: {reordered:?}",
        reordered.len(),
        scenes.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(
        reordered.iter().any(|n| n.contains("many-layers-64"))
            && reordered.iter().filter(|n| n.starts_with("stack-")).count() >= 6,
        "too few scenes reordered to compare anything: {reordered:?}"
    );
}
