//! The blended baselines against the CPU reference (lavapipe in CI), at 128x128.

use oit_gpu::testing::context_or_skip;
use oit_gpu::{ColorFormat, Context, TechniqueSpec};
use oit_scene::{LinearImage, Resolution, Scene};

const RES: Resolution = Resolution {
    width: 128,
    height: 128,
};

fn scene_named(name: &str) -> Scene {
    crate::kit::bundled(name, RES)
}

fn render(ctx: &Context, scene: &Scene, spec: &str) -> (LinearImage, oit_gpu::FrameResult, u64) {
    crate::kit::render_spec(ctx, scene, spec, ColorFormat::Rgba16Float)
}

use crate::kit::max_abs_rgb;

/// RMSE over RGB.
fn rmse(a: &LinearImage, b: &LinearImage) -> f64 {
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from(p[c] - q[c]).powi(2)))
        .sum();
    (sum / (3 * a.pixels.len()) as f64).sqrt()
}

fn error(ctx: &Context, scene: &Scene, spec: &str) -> f32 {
    let reference = oit_reference::render(scene, &Default::default());
    let (image, _, _) = render(ctx, scene, spec);
    max_abs_rgb(&image, &reference.image)
}

#[test]
fn registry_is_valid_and_canonical() {
    let registry = oit_sorted::techniques();
    let names: Vec<&str> = registry.iter().map(|t| t.name).collect();
    assert_eq!(
        names,
        [
            "unsorted",
            "sorted-object",
            "sorted-triangle",
            "depth-prepass",
            "cull-split"
        ]
    );
    for info in &registry {
        info.validate().expect("valid registry entry");
        let spec = TechniqueSpec::parse(info.name, &registry).expect("parses");
        assert_eq!(spec.to_string(), info.name);
        assert_eq!((info.build)(&spec).unwrap().spec(), spec);
        assert!(TechniqueSpec::parse(&format!("{}:x=1", info.name), &registry).is_err());
    }
}

#[test]
fn sorted_object_matches_reference_on_sorted_quads() {
    let Some(ctx) = context_or_skip("sorted_object_matches_reference_on_sorted_quads") else {
        return;
    };
    let scene = scene_named("sorted-quads");
    let e = error(&ctx, &scene, "sorted-object");
    println!("sorted-object on sorted-quads: max abs error {e:e}");
    assert!(e <= 2e-3, "max abs error {e}");
    // Sorting makes the result independent of the draw order.
    let e_rev = error(&ctx, &scene.with_reversed_draw_order(), "sorted-object");
    println!("sorted-object on reversed sorted-quads: max abs error {e_rev:e}");
    assert!(e_rev <= 2e-3, "reversed: max abs error {e_rev}");
}

#[test]
fn sorted_triangle_beats_sorted_object_on_intersecting_quads() {
    let Some(ctx) = context_or_skip("sorted_triangle_beats_sorted_object_on_intersecting_quads")
    else {
        return;
    };
    let scene = scene_named("intersecting-quads");
    let reference = oit_reference::render(&scene, &Default::default());
    let (object_image, _, _) = render(&ctx, &scene, "sorted-object");
    let (image, frame, bytes) = render(&ctx, &scene, "sorted-triangle");
    let (object_max, object_mean) = (
        max_abs_rgb(&object_image, &reference.image),
        mean_abs_rgb(&object_image, &reference.image),
    );
    let (max, mean) = (
        max_abs_rgb(&image, &reference.image),
        mean_abs_rgb(&image, &reference.image),
    );
    println!(
        "intersecting-quads: sorted-object max {object_max:e} mean {object_mean:e}; sorted-triangle max {max:e} mean {mean:e}; cpu {} ms",
        frame.stats.cpu_ms
    );
    // Where the quads interpenetrate no triangle order is right, so the worst pixel stays about
    // as wrong; the mean error must drop.
    assert!(
        mean < object_mean,
        "sorted-triangle mean {mean} not below sorted-object {object_mean}"
    );
    assert!(
        max <= object_max,
        "sorted-triangle max {max} above sorted-object {object_max}"
    );
    assert_eq!(
        bytes,
        12 * scene.transparent_triangle_count() as u64,
        "one u32 index per vertex"
    );
    assert!(frame.stats.cpu_ms >= 0.0 && frame.stats.cpu_ms.is_finite());
}

fn mean_abs_rgb(a: &LinearImage, b: &LinearImage) -> f64 {
    let sum: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from((p[c] - q[c]).abs())))
        .sum();
    sum / (3 * a.pixels.len()) as f64
}

#[test]
fn unsorted_is_wrong_and_order_dependent_on_sorted_quads() {
    let Some(ctx) = context_or_skip("unsorted_is_wrong_and_order_dependent_on_sorted_quads") else {
        return;
    };
    let scene = scene_named("sorted-quads");
    let reference = oit_reference::render(&scene, &Default::default());
    let (natural, frame, bytes) = render(&ctx, &scene, "unsorted");
    let (reversed, _, _) = render(&ctx, &scene.with_reversed_draw_order(), "unsorted");
    let e_nat = max_abs_rgb(&natural, &reference.image);
    let e_rev = max_abs_rgb(&reversed, &reference.image);
    let order_dependence = max_abs_rgb(&natural, &reversed);
    println!(
        "unsorted on sorted-quads: error natural {e_nat:e}, reversed {e_rev:e}, order dependence {order_dependence:e}"
    );
    assert!(
        e_nat.max(e_rev) > 0.05,
        "unsorted should be visibly wrong in one order"
    );
    assert!(
        order_dependence > 0.05,
        "unsorted should depend on draw order"
    );
    assert_eq!(bytes, 0);
    assert_eq!(frame.stats.geometry_passes, 1);
}

#[test]
fn depth_prepass_is_exact_with_one_transparent_layer() {
    let Some(ctx) = context_or_skip("depth_prepass_is_exact_with_one_transparent_layer") else {
        return;
    };
    // sorted-quads with its opaque draws and only the first transparent draw.
    let full = scene_named("sorted-quads");
    let first = (0..full.draws.len())
        .find(|&i| full.material_of(&full.draws[i]).mode.is_transparent())
        .expect("a transparent draw");
    let draws = full
        .draws
        .iter()
        .enumerate()
        .filter(|(i, d)| *i == first || !full.material_of(d).mode.is_transparent())
        .map(|(_, d)| d.clone())
        .collect();
    let scene = Scene { draws, ..full };
    let reference = oit_reference::render(&scene, &Default::default());
    assert!(
        reference.layers.iter().all(|&l| l <= 1),
        "test scene must have at most one transparent layer"
    );
    assert!(
        reference.layers.contains(&1),
        "test scene must have a transparent layer"
    );
    let (image, frame, _) = render(&ctx, &scene, "depth-prepass");
    let e = max_abs_rgb(&image, &reference.image);
    println!("depth-prepass, one layer: max abs error {e:e}");
    assert!(e <= 2e-3, "max abs error {e}");
    assert_eq!(frame.stats.geometry_passes, 2);
    assert_eq!(frame.timings.passes.len(), 3, "{:?}", frame.timings.passes);
    // With several layers it keeps only the nearest and is wrong.
    let e_full = error(&ctx, &scene_named("sorted-quads"), "depth-prepass");
    println!("depth-prepass on sorted-quads: max abs error {e_full:e}");
    assert!(e_full > 0.05);
}

/// RMSE of each baseline (`unsorted`, `sorted-object`, `sorted-triangle`, `depth-prepass`,
/// `cull-split`, the registry's order) on each bundled scene at 128² (Rgba16Float), measured on
/// lavapipe (llvmpipe 15, Mesa 22.3). A run may exceed its value by 25 % plus 2e-5 (binary16
/// rounding of the target): enough for another adapter's rounding, far too little for a changed
/// technique (cull-split without back faces: foliage-cards 1.9e-4 → 4.1e-2).
const MEASURED_RMSE: [(&str, [f64; 5]); 23] = [
    (
        "ops-additive-depth-write",
        [5.705e-2, 9.321e-2, 9.321e-2, 1.002e-1, 9.321e-2],
    ),
    (
        "ops-background-overlay",
        [2.277e-2, 1.905e-4, 1.905e-4, 6.849e-2, 1.905e-4],
    ),
    (
        "ops-multiply-tint",
        [3.500e-2, 3.167e-4, 3.167e-4, 1.285e-1, 3.167e-4],
    ),
    (
        "ops-pygfx-mixed",
        [1.295e-2, 1.276e-2, 1.731e-4, 2.533e-2, 1.256e-3],
    ),
    (
        "ops-sparks-smoke-glass",
        [3.147e-1, 3.147e-1, 1.653e-2, 3.436e-1, 3.147e-1],
    ),
    (
        "alpha-099-stack",
        [8.340e-1, 9.378e-5, 9.378e-5, 5.462e-3, 9.378e-5],
    ),
    (
        "alpha-extremes",
        [7.270e-2, 1.873e-4, 1.873e-4, 9.955e-2, 1.873e-4],
    ),
    (
        "concave-self",
        [1.771e-2, 1.771e-2, 5.601e-5, 1.258e-2, 4.319e-3],
    ),
    (
        "coplanar",
        [1.366e-4, 1.366e-4, 1.366e-4, 1.366e-4, 1.366e-4],
    ),
    (
        "depth-range",
        [1.642e-1, 2.507e-4, 2.507e-4, 1.478e-1, 2.507e-4],
    ),
    (
        "enderton",
        [1.653e-1, 1.537e-4, 1.537e-4, 2.020e-1, 1.537e-4],
    ),
    (
        "faint-haze",
        [1.401e-2, 1.017e-2, 1.017e-2, 2.444e-1, 1.017e-2],
    ),
    (
        "foliage-cards",
        [1.911e-4, 1.911e-4, 1.911e-4, 3.291e-2, 1.911e-4],
    ),
    (
        "gltf-alpha-blend-modes",
        [5.564e-3, 5.564e-3, 5.564e-3, 2.747e-2, 5.564e-3],
    ),
    (
        "gltf-foliage-mipmaps",
        [1.683e-4, 1.683e-4, 1.683e-4, 1.683e-4, 1.683e-4],
    ),
    (
        // Lit per pixel since 2026-12-07: draw order and per-object sorting now show on the
        // glass (2.507e-4 unlit), per-triangle sorting stays exact.
        "gltf-glass-vase",
        [1.410e-3, 1.410e-3, 2.768e-4, 3.232e-2, 1.410e-3],
    ),
    (
        "hdr-emissive",
        [3.794e0, 3.763e-2, 3.763e-2, 5.428e1, 3.763e-2],
    ),
    (
        "intersecting-quads",
        [1.221e-1, 1.133e-1, 8.118e-2, 7.511e-2, 1.133e-1],
    ),
    (
        "many-layers-64",
        [4.909e-1, 5.204e-4, 5.204e-4, 5.102e-1, 5.204e-4],
    ),
    (
        "opaque-interleaved",
        [3.475e-1, 7.635e-4, 7.635e-4, 3.989e-1, 7.635e-4],
    ),
    (
        "particles",
        [5.086e-2, 5.086e-2, 2.726e-3, 2.172e-1, 5.086e-2],
    ),
    (
        "quad-through-sphere",
        [5.479e-2, 5.479e-2, 3.012e-2, 8.985e-2, 5.479e-2],
    ),
    (
        "sorted-quads",
        [8.600e-2, 1.482e-4, 1.482e-4, 8.023e-2, 1.482e-4],
    ),
];

fn rmse_bound(scene: &str, technique: usize) -> f64 {
    let (_, values) = MEASURED_RMSE
        .iter()
        .find(|(n, _)| *n == scene)
        .unwrap_or_else(|| panic!("{scene}: no measured RMSE in MEASURED_RMSE; add it"));
    1.25 * values[technique] + 2e-5
}

#[test]
fn every_technique_on_every_bundled_scene_is_finite_and_within_its_measured_error() {
    let Some(ctx) = context_or_skip("every_technique_on_every_bundled_scene_is_finite") else {
        return;
    };
    let dir = crate::kit::scenes_dir();
    let scenes = oit_scene::load_dir(&dir).expect("bundled scenes");
    assert!(!scenes.is_empty());
    let registry = oit_sorted::techniques();
    let mut failures = Vec::new();
    for (path, scene) in scenes {
        let scene = scene.with_resolution(RES);
        let reference = oit_reference::render(&scene, &Default::default());
        let mut line = format!(
            "{:>22}",
            path.file_stem().unwrap_or_default().to_string_lossy()
        );
        for (index, info) in registry.iter().enumerate() {
            let (image, _, _) = render(&ctx, &scene, info.name);
            let nonfinite = image
                .pixels
                .iter()
                .filter(|p| p.iter().any(|c| !c.is_finite()))
                .count();
            assert_eq!(
                nonfinite, 0,
                "{} on {}: {nonfinite} non-finite pixels",
                info.name, scene.name
            );
            let e = rmse(&image, &reference.image);
            line += &format!("  {}={e:.3e}", info.name);
            // Coloured transmission: sorted::transmission bounds sorted-object there.
            if scene.has_coloured_transmission() {
                continue;
            }
            let bound = rmse_bound(&scene.name, index);
            if e > bound {
                failures.push(format!(
                    "{} on {}: RMSE {e:.3e} > {bound:.3e}",
                    info.name, scene.name
                ));
            }
        }
        println!("{line}");
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
