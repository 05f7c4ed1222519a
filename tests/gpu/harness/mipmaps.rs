//! The texel store and mipmaps on the GPU: a scene whose textures exceed one 128 MiB storage
//! binding runs every technique, and the GPU's trilinear and nearest-mip sampling with the
//! level of detail from fine derivatives matches the reference's on the bundled foliage scene.

use oit_gpu::testing::context_or_skip;
use oit_harness::{CompareOptions, SceneEntry, compare, render_once, resolve_specs};
use oit_scene::{Encoding, MipFilter, Sampler, Scene, Texture, Wrap};

/// A 2048² texture of hashed codes (alpha at least 128), its sampler's wrap by `seed`.
fn large_texture(seed: u32) -> Texture {
    let side = 2048u32;
    let codes = (0..side * side)
        .map(|k| {
            let mut h = k.wrapping_mul(0x9e37_79b9) ^ seed.wrapping_mul(0x85eb_ca6b);
            h ^= h >> 15;
            h = h.wrapping_mul(0x2c1b_3c6d);
            h ^= h >> 12;
            h | 0x8000_0000
        })
        .collect();
    let wrap = [Wrap::Repeat, Wrap::MirroredRepeat, Wrap::ClampToEdge][seed as usize % 3];
    let sampler = Sampler {
        wrap_u: wrap,
        wrap_v: wrap,
        ..Sampler::default()
    };
    Texture::new(
        format!("large {seed}"),
        side,
        side,
        codes,
        Encoding::Srgb,
        sampler,
    )
    .expect("valid texture")
}

/// Seven 2048² textures with their mip chains: 7 · 4/3 · 16 MiB ≈ 149 MiB of codes, more than
/// one storage binding may hold on lavapipe (128 MiB), on blended and opaque materials (no
/// cutoff reads texture α, so no pixel is undecided), with texture coordinates scaled so that
/// several levels are read.
fn scene_with_large_textures() -> Scene {
    let (text, _) = oit_scene::random::random_scene_json(5);
    let mut scene = oit_scene::parse(&text, "large-textures").expect("random scene");
    scene.textures = (0..7).map(large_texture).collect();
    for (i, m) in scene.materials.iter_mut().enumerate() {
        if !m.mode.uses_cutoff() {
            m.base_texture = Some(i as u32 % 7);
        }
    }
    for (k, d) in scene.draws.clone().iter().enumerate() {
        let scale = [0.5, 1.0, 3.0, 9.0][k % 4];
        for v in &mut scene.vertices[d.vertex_range()] {
            v.uv = [v.uv[0] * scale, v.uv[1] * scale];
        }
    }
    scene
}

#[test]
fn textures_beyond_one_storage_binding_run_every_technique() {
    let Some(ctx) = context_or_skip("textures_beyond_one_storage_binding_run_every_technique")
    else {
        return;
    };
    let scene = scene_with_large_textures();
    assert!(scene.materials.iter().any(|m| m.base_texture.is_some()));
    let bytes = oit_gpu::SceneBytes::of(&scene).textures;
    assert!(
        bytes > 128 << 20 && bytes > ctx.caps.max_storage_buffer_binding_size,
        "{bytes} bytes of texels fit one binding ({})",
        ctx.caps.max_storage_buffer_binding_size
    );
    let dir = std::env::temp_dir().join(format!("oit-large-textures-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // `ray-query` needs an adapter with ray queries (tests/ray_query runs it on one); every
    // other technique runs everywhere.
    let specs: Vec<_> = resolve_specs(&[])
        .unwrap()
        .into_iter()
        .filter(|s| ctx.caps.ray_query || s.name() != "ray-query")
        .collect();
    let options = CompareOptions {
        resolution: Some(oit_scene::Resolution {
            width: 48,
            height: 48,
        }),
        frames: 1,
        warmup: 0,
        out_dir: dir.join("out"),
        cache: oit_harness::ReferenceCache::Dir(dir.join("cache")),
        ..CompareOptions::default()
    };
    let scenes = [SceneEntry::new(dir.join("large-textures.json"), scene)];
    let results = compare(&ctx, &scenes, &specs, &options, &|_| {}).unwrap();
    assert_eq!(results.runs.len(), specs.len());
    assert_eq!(results.scenes[0].texture_bytes, bytes);
    let mut exact = 0;
    for run in &results.runs {
        assert_eq!(
            run.status,
            oit_harness::results::RunStatus::Ok,
            "{}: {:?}",
            run.technique,
            run.reason
        );
        assert_eq!(run.undecided_pixels, Some(0), "{}", run.technique);
        let error = run.error.as_ref().expect("error figures");
        let predicted_exact = run
            .prediction
            .as_ref()
            .is_some_and(|p| p.verdict == "exact");
        let peeled = run.technique.starts_with("front-peel:layers=auto")
            || run.technique.starts_with("dual-peel:passes=auto");
        if predicted_exact || peeled {
            exact += 1;
            assert!(
                error.max_relative <= 4e-3,
                "{} (predicted exact: {predicted_exact}): max error {:e}",
                run.technique,
                error.max_relative
            );
            if let Some(p) = &run.prediction
                && p.verdict == "exact"
            {
                assert_eq!(p.agrees, Some(true), "{}: {p:?}", run.technique);
            }
        }
    }
    assert!(exact >= 2, "the peeling techniques at least are exact here");
    let _ = std::fs::remove_dir_all(&dir);
}

fn foliage() -> Scene {
    let path = crate::kit::root().join("scenes/gltf-foliage-mipmaps.json");
    oit_scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// The scene with every texture sampled from level 0 only (same codes and wrap modes).
fn without_mipmaps(scene: &Scene) -> Scene {
    let mut flat = scene.clone();
    for t in &mut flat.textures {
        let sampler = Sampler {
            mip: MipFilter::None,
            ..t.sampler()
        };
        *t = Texture::new(
            t.name.clone(),
            t.width(),
            t.height(),
            t.level_codes(0).to_vec(),
            t.encoding(),
            sampler,
        )
        .expect("valid texture");
    }
    flat
}

/// Pixels where the GPU's image differs from the reference's at all, where it differs by more
/// than 1e-6, and the largest difference (relative above 1), over the pixels rounding does
/// not decide; and how many pixels were compared.
fn differences(
    image: &oit_scene::LinearImage,
    reference: &oit_reference::Reference,
) -> (usize, usize, f32, usize) {
    let (mut any, mut visible, mut worst, mut compared) = (0, 0, 0.0f32, 0);
    for (p, (a, b)) in image.pixels.iter().zip(&reference.image.pixels).enumerate() {
        if reference.undecided[p] != 0 || reference.precision_ties[p] {
            continue;
        }
        compared += 1;
        let e = (0..3)
            .map(|c| (a[c] - b[c]).abs() / b[c].abs().max(1.0))
            .fold(0.0f32, f32::max);
        any += usize::from(e > 0.0);
        visible += usize::from(e > 1e-6);
        worst = worst.max(e);
    }
    (any, visible, worst, compared)
}

/// The foliage scene really is mipmapped (two 9-level textures; sampling level 0 alone
/// changes the reference image, the far cards' blades survive the cutoff), and the GPU
/// samples it like the reference: front-to-back peeling equals the reference to 4e-3 on every
/// pixel rounding does not decide, with and without mipmaps. How many pixels differ at all
/// is printed for both, so the share the level of detail adds can be read off.
#[test]
fn gpu_mipmapped_sampling_matches_the_reference_on_the_foliage_scene() {
    let Some(ctx) =
        context_or_skip("gpu_mipmapped_sampling_matches_the_reference_on_the_foliage_scene")
    else {
        return;
    };
    let scene = foliage();
    assert_eq!(scene.textures.len(), 2);
    assert!(scene.textures.iter().all(|t| t.levels() == 9));
    let flat = without_mipmaps(&scene);
    let spec = resolve_specs(&["front-peel:layers=auto".into()]).unwrap();
    let mut coverage = Vec::new();
    for (what, s) in [("mipmapped", &scene), ("level 0 only", &flat)] {
        let reference = oit_reference::render(s, &Default::default());
        let frame = render_once(&ctx, s, &spec[0]).expect("front-peel runs");
        let (any, visible, worst, compared) = differences(&frame.image, &reference);
        let undecided = reference.undecided.iter().filter(|&&u| u > 0).count();
        println!(
            "{what}: {compared} pixels compared, {any} differ at all, {visible} by more than 1e-6, max {worst:e}; {undecided} undecided"
        );
        assert!(compared > 0);
        assert!(worst <= 4e-3, "{what}: max error {worst:e}");
        coverage.push(
            reference
                .fragments
                .iter()
                .map(|&c| u64::from(c))
                .sum::<u64>(),
        );
        if what == "mipmapped" {
            let flat_reference = oit_reference::render(&flat, &Default::default());
            let changed = (reference.image.pixels.iter())
                .zip(&flat_reference.image.pixels)
                .filter(|(a, b)| a != b)
                .count();
            assert!(changed > 500, "mipmaps change only {changed} pixels");
        }
    }
    // Mipmapped alpha thins the cutoff: fewer fragments survive than from level 0 alone.
    assert!(
        coverage[0] < coverage[1],
        "fragments kept: mipmapped {} vs level 0 {}",
        coverage[0],
        coverage[1]
    );
}
