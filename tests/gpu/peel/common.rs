//! Shared helpers of the GPU tests: bundled scenes at 128×128, rendering into full-float
//! targets (so errors are the technique's, not the Rgba16Float target's ~1e-3 rounding), and
//! the reference.

#![allow(dead_code, reason = "each test binary uses a subset")]

use oit_gpu::{ColorFormat, Context, GpuScene, RenderStats, Technique};
use oit_scene::{LinearImage, Resolution, Scene};

pub const RES: Resolution = Resolution {
    width: 128,
    height: 128,
};

pub fn scene(name: &str) -> Scene {
    crate::kit::bundled(name, RES)
}

pub fn bundled_names() -> Vec<String> {
    let dir = crate::kit::scenes_dir();
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("scenes/ exists")
        .filter_map(|e| {
            let p = e.ok()?.path();
            if p.extension()? != "json" {
                return None;
            }
            Some(p.file_stem()?.to_string_lossy().into_owned())
        })
        .collect();
    names.sort();
    names
}

pub fn reference(scene: &Scene) -> oit_reference::Reference {
    oit_reference::render(scene, &oit_reference::ReferenceOptions::default())
}

/// Renders one frame of `technique` into Rgba32Float targets.
pub fn render(
    ctx: &Context,
    scene: &Scene,
    technique: &mut dyn Technique,
) -> (LinearImage, RenderStats) {
    let (image, frame) = crate::kit::render(ctx, scene, technique, ColorFormat::Rgba32Float);
    (image, frame.stats)
}

pub fn render_uploaded(
    ctx: &Context,
    gpu: &GpuScene,
    technique: &mut dyn Technique,
) -> (LinearImage, RenderStats) {
    let (image, frame) = crate::kit::render_uploaded(ctx, gpu, technique, ColorFormat::Rgba32Float);
    (image, frame.stats)
}

pub fn errors(image: &LinearImage, reference: &LinearImage) -> oit_metrics::Errors {
    oit_metrics::compare(image, reference).expect("same size")
}

/// Largest per-channel RGB difference between two renders.
pub fn max_diff(a: &LinearImage, b: &LinearImage) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| f64::from((p[c] - q[c]).abs())))
        .fold(0.0, f64::max)
}

pub fn build(spec: &str) -> Box<dyn Technique> {
    oit_gpu::TechniqueSpec::build(spec, &oit_peel::techniques()).unwrap_or_else(|e| panic!("{e}"))
}

/// Pixels where the GPU rasterizes a different number of fragments than the reference (the
/// rasterization conformance of oit-gpu/oit-reference, not a property of peeling). The
/// peel tests compare every other pixel and bound how many are excluded.
pub fn conformance_mismatches(
    ctx: &Context,
    scene: &Scene,
    reference: &oit_reference::Reference,
) -> Vec<usize> {
    let gpu = GpuScene::upload(ctx, scene).expect("upload");
    let counts = oit_gpu::count_fragments(ctx, &gpu).expect("count fragments");
    counts
        .iter()
        .zip(&reference.fragments)
        .enumerate()
        .filter(|(_, (a, b))| a != b)
        .map(|(i, _)| i)
        .collect()
}

/// `errors` with the given pixels taken from the reference.
pub fn errors_except(
    image: &LinearImage,
    reference: &LinearImage,
    skip: &[usize],
) -> oit_metrics::Errors {
    let mut image = image.clone();
    for &i in skip {
        image.pixels[i] = reference.pixels[i];
    }
    errors(&image, reference)
}
