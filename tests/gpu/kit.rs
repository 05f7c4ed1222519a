//! The test kit every GPU test shares: where the repository's scenes are, a bundled scene at a
//! size, one frame of a technique read back, and the error of one image against another. The
//! GPU-side twins of CPU formulas are `oit_gpu::testing::eval_f32` / `eval_u32`; every WGSL
//! file is validated by `harness::shaders`.

use std::path::{Path, PathBuf};

use oit_gpu::{
    ColorFormat, Context, FrameResult, GpuScene, GpuTimer, Targets, Technique, TechniqueSpec,
};
use oit_scene::{LinearImage, Resolution, Scene};

/// The repository's root (this package is `tests/`).
pub fn root() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    // Failure messages name files; `tests/../scenes` reads badly.
    root.canonicalize().unwrap_or(root)
}

/// The bundled scenes, `scenes/`.
pub fn scenes_dir() -> PathBuf {
    root().join("scenes")
}

/// The bundled scene `name` (`scenes/NAME.json`), at `resolution`.
pub fn bundled(name: &str, resolution: Resolution) -> Scene {
    let path = scenes_dir().join(format!("{name}.json"));
    oit_scene::load(&path)
        .unwrap_or_else(|e| panic!("bundled scene {name}: {e}"))
        .with_resolution(resolution)
}

/// One frame of `technique` on `scene` into targets of `format`, read back: the image and what
/// the frame reports.
pub fn render(
    ctx: &Context,
    scene: &Scene,
    technique: &mut dyn Technique,
    format: ColorFormat,
) -> (LinearImage, FrameResult) {
    let gpu = GpuScene::upload(ctx, scene).expect("upload");
    render_uploaded(ctx, &gpu, technique, format)
}

/// [`render`] of a scene already uploaded (tests that render one upload many times).
pub fn render_uploaded(
    ctx: &Context,
    gpu: &GpuScene,
    technique: &mut dyn Technique,
    format: ColorFormat,
) -> (LinearImage, FrameResult) {
    let targets = Targets::new(ctx, gpu.scene.resolution, format).expect("targets");
    let mut timer = GpuTimer::new(ctx);
    let frame = oit_gpu::render_frame(ctx, gpu, technique, &targets, &mut timer)
        .unwrap_or_else(|e| panic!("{}: {e}", technique.spec()));
    let image = oit_gpu::read_color(ctx, &targets).expect("readback");
    (image, frame)
}

/// [`render`] of the technique `spec` names (any registered technique): the image, the frame
/// and the technique's memory.
pub fn render_spec(
    ctx: &Context,
    scene: &Scene,
    spec: &str,
    format: ColorFormat,
) -> (LinearImage, FrameResult, u64) {
    let mut technique = TechniqueSpec::build(spec, &oit_harness::registry()).expect("valid spec");
    let (image, frame) = render(ctx, scene, technique.as_mut(), format);
    (image, frame, technique.memory_bytes())
}

/// Largest per-channel error of `render` against `reference`, relative above 1 (absolute
/// below): the exactness measure of the exact techniques on HDR and LDR content alike.
pub fn max_relative_rgb(render: &LinearImage, reference: &LinearImage) -> f32 {
    assert_eq!(
        render.pixels.len(),
        reference.pixels.len(),
        "images of different sizes"
    );
    render
        .pixels
        .iter()
        .zip(&reference.pixels)
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / b[c].abs().max(1.0)))
        .fold(0.0, f32::max)
}

/// The largest absolute difference of any RGB channel of any pixel.
pub fn max_abs_rgb(a: &LinearImage, b: &LinearImage) -> f32 {
    assert_eq!(a.pixels.len(), b.pixels.len(), "images of different sizes");
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0, f32::max)
}

/// Pixels a comparison leaves out, each for a reason that is not the technique's: the GPU
/// rasterized a different fragment count than the reference (conformance), or the reference
/// itself says rounding decides the pixel (precision ties, cutoff knife edges).
pub fn undecidable(
    ctx: &Context,
    scene: &Scene,
    reference: &oit_reference::Reference,
) -> Vec<bool> {
    let gpu = GpuScene::upload(ctx, scene).expect("upload");
    let counts = oit_gpu::count_fragments(ctx, &gpu).expect("count fragments");
    (0..counts.len())
        .map(|i| {
            counts[i] != reference.fragments[i]
                || reference.precision_ties[i]
                || reference.undecided[i] > 0
        })
        .collect()
}

/// [`max_relative_rgb`] over the pixels `skip` does not mark.
pub fn max_relative_rgb_except(a: &LinearImage, b: &LinearImage, skip: &[bool]) -> f64 {
    assert_eq!(a.pixels.len(), b.pixels.len(), "images of different sizes");
    a.pixels
        .iter()
        .zip(&b.pixels)
        .zip(skip)
        .filter(|(_, s)| !**s)
        .flat_map(|((p, q), _)| {
            (0..3).map(move |c| f64::from((p[c] - q[c]).abs() / q[c].abs().max(1.0)))
        })
        .fold(0.0, f64::max)
}

/// How many seeded random scenes a random-scene test runs: `OIT_RANDOM_SCENES`, else `default`.
pub fn random_scene_count(default: u64) -> u64 {
    std::env::var("OIT_RANDOM_SCENES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}
