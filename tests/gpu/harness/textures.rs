//! Textured content: every GPU pass samples textures with the rule the reference mirrors
//! (`Texture::sample` / `sample_texture`: 8-bit codes decoded through shared tables, nearest,
//! bilinear or trilinear with the level of detail from fine derivatives, wrap modes, f32 in
//! one order), so
//! fragment counts and exact techniques agree with the reference on textured scenes too, with
//! the undecided class widened by the texture's reach where a cutoff reads textured alpha.
//!
//! The scenes are the seeded random scenes of `oit_scene::random` with random textures, wrap
//! modes, texture coordinates and emission added to their materials: content nobody placed.

use oit_gpu::GpuScene;
use oit_gpu::testing::context_or_skip;
use oit_harness::{render_once, resolve_specs};
use oit_scene::{Encoding, Filter, MipFilter, Sampler, Scene, Texture, Wrap};

/// A small deterministic generator (xorshift64*), enough to vary test content.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

fn random_texture(rng: &mut Rng, i: usize) -> Texture {
    let width = 1 + rng.below(40) as u32;
    let height = 1 + rng.below(40) as u32;
    let wrap = |r: &mut Rng| match r.below(3) {
        0 => Wrap::Repeat,
        1 => Wrap::MirroredRepeat,
        _ => Wrap::ClampToEdge,
    };
    let filter = |r: &mut Rng| {
        if r.below(3) == 0 {
            Filter::Nearest
        } else {
            Filter::Linear
        }
    };
    let sampler = Sampler {
        wrap_u: wrap(rng),
        wrap_v: wrap(rng),
        mag: filter(rng),
        min: filter(rng),
        mip: match rng.below(4) {
            0 => MipFilter::None,
            1 => MipFilter::Nearest,
            _ => MipFilter::Linear,
        },
    };
    // Random 8-bit codes, as an image stores them: sRGB colour or UNORM data, UNORM alpha.
    let codes = (0..width * height).map(|_| rng.next() as u32).collect();
    let encoding = if rng.below(4) == 0 {
        Encoding::Unorm
    } else {
        Encoding::Srgb
    };
    Texture::new(
        format!("random texture {i}"),
        width,
        height,
        codes,
        encoding,
        sampler,
    )
    .expect("valid texture")
}

/// Random scene `seed` with textures on most materials, emission on some, and each draw's
/// texture coordinates scaled and offset so that every wrap mode is exercised.
fn textured_scene(seed: u64) -> Scene {
    let (text, _) = oit_scene::random::random_scene_json(seed);
    let mut scene = oit_scene::parse(&text, "random").expect("random scene");
    let mut rng = Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    let count = 1 + rng.below(4) as usize;
    scene.textures = (0..count).map(|i| random_texture(&mut rng, i)).collect();
    for m in &mut scene.materials {
        if rng.below(5) > 0 {
            m.base_texture = Some(rng.below(count as u64) as u32);
        }
        if rng.below(3) == 0 {
            m.emissive = [rng.unit(), rng.unit(), rng.unit()];
            m.emissive_texture = (rng.below(2) == 0).then(|| rng.below(count as u64) as u32);
        }
    }
    for d in scene.draws.clone() {
        let (scale, offset) = (0.5 + 3.0 * rng.unit(), [rng.unit() * 4.0 - 2.0, rng.unit()]);
        for v in &mut scene.vertices[d.vertex_range()] {
            v.uv = [v.uv[0] * scale + offset[0], v.uv[1] * scale - offset[1]];
        }
    }
    scene
}

/// Pixels whose value rounding may decide: undecided cutoff fragments or precision ties.
fn decided(reference: &oit_reference::Reference, p: usize) -> bool {
    reference.undecided[p] == 0 && !reference.precision_ties[p]
}

/// Asserts that the GPU's per-pixel fragment counts equal the reference's, except by at most a
/// pixel's undecided fragments; returns how many pixels needed that tolerance.
pub(super) fn counts_conform(
    ctx: &oit_gpu::Context,
    scene: &Scene,
    reference: &oit_reference::Reference,
    what: &str,
) -> usize {
    let gpu = GpuScene::upload(ctx, scene).expect("upload");
    let counts = oit_gpu::count_fragments(ctx, &gpu).expect("count");
    let cmp = reference.compare_fragment_counts(&counts);
    assert!(
        cmp.unexplained.is_empty(),
        "{what}: {} pixels differ in fragment count beyond the undecided ones, first {:?}",
        cmp.unexplained.len(),
        &cmp.unexplained[..cmp.unexplained.len().min(8)]
    );
    cmp.undecided
}

/// The largest per-channel error of `image` against the reference (relative above 1) over the
/// pixels rounding does not decide, with its pixel; and how many pixels were compared.
pub(super) fn worst_decided_error(
    image: &oit_scene::LinearImage,
    reference: &oit_reference::Reference,
) -> ((f32, usize), u64) {
    let mut worst = (0.0f32, 0usize);
    let mut compared = 0;
    for (p, (a, b)) in image.pixels.iter().zip(&reference.image.pixels).enumerate() {
        if !decided(reference, p) {
            continue;
        }
        compared += 1;
        for c in 0..3 {
            let e = (a[c] - b[c]).abs() / b[c].abs().max(1.0);
            if e > worst.0 {
                worst = (e, p);
            }
        }
    }
    (worst, compared)
}

/// Fragment counts on the GPU equal the reference's on textured random scenes, except by at
/// most the undecided fragments of a pixel; and the textures are really read (a scene whose
/// textures are replaced by white renders differently).
#[test]
fn fragment_counts_match_on_textured_random_scenes() {
    let Some(ctx) = context_or_skip("fragment_counts_match_on_textured_random_scenes") else {
        return;
    };
    let mut undecided_pixels = 0;
    let mut textured_cutoffs = 0;
    for seed in 0..40 {
        let scene = textured_scene(seed);
        textured_cutoffs += scene
            .materials
            .iter()
            .filter(|m| m.mode.uses_cutoff() && m.base_texture.is_some())
            .count();
        let reference = oit_reference::render(&scene, &Default::default());
        undecided_pixels += counts_conform(&ctx, &scene, &reference, &format!("seed {seed}"));
    }
    println!(
        "{textured_cutoffs} textured cutoff materials; {undecided_pixels} pixels differed within their undecided fragments"
    );
    assert!(
        textured_cutoffs > 10,
        "the random scenes must exercise textured cutoffs"
    );
}

/// Exact techniques equal the reference on textured random scenes to 4e-3 (relative above 1)
/// on every pixel that rounding does not decide, and a texture changes the image.
#[test]
fn exact_techniques_match_the_reference_on_textured_scenes() {
    let Some(ctx) = context_or_skip("exact_techniques_match_the_reference_on_textured_scenes")
    else {
        return;
    };
    let specs = resolve_specs(&[
        "front-peel:layers=auto".into(),
        "dual-peel:passes=auto,depth=rg32f".into(),
    ])
    .expect("specs");
    let mut failures = Vec::new();
    let mut compared = 0u64;
    for seed in 0..24 {
        let scene = textured_scene(seed);
        let reference = oit_reference::render(&scene, &Default::default());
        let mut white = scene.clone();
        for t in &mut white.textures {
            let texels = (t.width() * t.height()) as usize;
            *t = Texture::new(
                "white",
                t.width(),
                t.height(),
                vec![u32::MAX; texels],
                t.encoding(),
                t.sampler(),
            )
            .expect("valid texture");
        }
        let plain = oit_reference::render(&white, &Default::default());
        assert_ne!(
            plain.image.pixels, reference.image.pixels,
            "seed {seed}: the textures change nothing"
        );
        for spec in &specs {
            let frame = match render_once(&ctx, &scene, spec) {
                Ok(f) => f,
                Err(e) => {
                    println!("seed {seed}: {} skipped: {e}", spec.canonical());
                    continue;
                }
            };
            let (worst, compared_here) = worst_decided_error(&frame.image, &reference);
            compared += compared_here;
            if worst.0 > 4e-3 || frame.stats.pixels_with_dropped_layers > 0 {
                failures.push(format!(
                    "seed {seed} {}: max error {:e} at pixel {}, dropped layers on {} px",
                    spec.canonical(),
                    worst.0,
                    worst.1,
                    frame.stats.pixels_with_dropped_layers
                ));
            }
        }
    }
    assert!(compared > 0, "nothing compared");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn repo() -> std::path::PathBuf {
    crate::kit::root()
}

/// The bundled glTF scenes (real assets: textured MASK and BLEND, an OPAQUE texture whose α
/// must be ignored, lighting through the asset's normals; mipmapped MASK foliage, trilinear and
/// nearest-mip): fragment counts conform, and the
/// exact techniques equal the reference to 4e-3 outside the pixels rounding decides.
#[test]
fn bundled_gltf_scenes_are_exact_for_exact_techniques() {
    let Some(ctx) = context_or_skip("bundled_gltf_scenes_are_exact_for_exact_techniques") else {
        return;
    };
    let specs = resolve_specs(&[
        "front-peel:layers=auto".into(),
        "dual-peel:passes=auto,depth=rg32f".into(),
    ])
    .expect("specs");
    for name in [
        "gltf-alpha-blend-modes",
        "gltf-glass-vase",
        "gltf-foliage-mipmaps",
    ] {
        let path = repo().join("scenes").join(format!("{name}.json"));
        let scene = oit_scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(!scene.textures.is_empty(), "{name}: textures loaded");
        assert!(!scene.credits.is_empty(), "{name}: the asset's credit line");
        let reference = oit_reference::render(&scene, &Default::default());
        counts_conform(&ctx, &scene, &reference, name);
        for spec in &specs {
            let frame = render_once(&ctx, &scene, spec).expect("exact techniques run here");
            let ((worst, _), compared) = worst_decided_error(&frame.image, &reference);
            assert!(compared > 0, "{name}: nothing compared");
            println!("{name} {}: max error {worst:e}", spec.canonical());
            assert!(
                worst <= 4e-3,
                "{name} {}: max error {worst:e} outside undecided pixels",
                spec.canonical()
            );
        }
    }
}

/// `compare` on a directory holding a JSON scene and a `.glb` runs every technique on both,
/// and results.json says where the asset came from and what of it is not modelled.
#[test]
fn compare_runs_every_technique_on_a_directory_with_a_glb() {
    let Some(ctx) = context_or_skip("compare_runs_every_technique_on_a_directory_with_a_glb")
    else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("oit-glb-dir-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scenes_dir = dir.join("scenes");
    std::fs::create_dir_all(&scenes_dir).unwrap();
    let glb = repo().join("assets/GlassVaseFlowers/GlassVaseFlowers.glb");
    std::fs::copy(&glb, scenes_dir.join("GlassVaseFlowers.glb")).unwrap();
    std::fs::write(
        scenes_dir.join("sheet.json"),
        r#"{"name": "sheet", "camera": {"eye": [0, 0, 3], "target": [0, 0, 0]},
            "objects": [{"mesh": {"kind": "quad", "size": [1, 1]},
                         "material": {"alpha": 0.5, "mode": "blend"}}]}"#,
    )
    .unwrap();
    let scenes = oit_harness::load_scenes(std::slice::from_ref(&scenes_dir)).unwrap();
    let names: Vec<&str> = scenes.iter().map(|e| e.scene.name.as_str()).collect();
    assert_eq!(names, ["GlassVaseFlowers", "sheet"]);
    let specs = resolve_specs(&[]).unwrap();
    assert!(specs.len() >= 10, "every technique: {}", specs.len());
    let options = oit_harness::CompareOptions {
        resolution: Some(oit_scene::Resolution {
            width: 48,
            height: 48,
        }),
        frames: 1,
        warmup: 0,
        out_dir: dir.join("out"),
        cache: oit_harness::ReferenceCache::Dir(dir.join("cache")),
        ..oit_harness::CompareOptions::default()
    };
    let results = oit_harness::compare(&ctx, &scenes, &specs, &options, &|_| {}).unwrap();
    assert_eq!(results.runs.len(), 2 * specs.len());
    let failed: Vec<_> = (results.runs.iter())
        .filter(|r| r.status == oit_harness::results::RunStatus::Failed)
        .map(|r| format!("{} {}: {:?}", r.scene, r.technique, r.reason))
        .collect();
    assert!(failed.is_empty(), "{failed:?}");
    let vase = (results.scenes.iter())
        .find(|s| s.scene == "GlassVaseFlowers")
        .expect("scene entry");
    assert!(vase.texture_bytes > 0 && vase.scene_bytes > vase.texture_bytes);
    assert!(vase.credits.iter().any(|c| c.contains("Eric Chadwick")));
    assert!(
        (vase.ignored.iter()).any(|i| i.contains("KHR_materials_transmission")),
        "{:?}",
        vase.ignored
    );
    let markdown = std::fs::read_to_string(dir.join("out/results.md")).unwrap();
    assert!(markdown.contains("Credits: GlassVaseFlowers.glb: CC0"));
    let _ = std::fs::remove_dir_all(&dir);
}
