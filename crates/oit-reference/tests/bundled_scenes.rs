//! Every bundled scene renders at 128×128 with finite pixels and plausible statistics.

use std::path::Path;

use oit_reference::{ReferenceOptions, render};
use oit_scene::Resolution;

#[test]
fn every_bundled_scene_renders_finite_at_128() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let scenes =
        oit_scene::load_dir(&dir).unwrap_or_else(|e| panic!("loading {}: {e}", dir.display()));
    assert!(
        scenes.len() >= 15,
        "the hard-case suite has at least 15 scenes, found {}",
        scenes.len()
    );
    for (path, scene) in scenes {
        let scene = scene.with_resolution(Resolution {
            width: 128,
            height: 128,
        });
        let r = render(&scene, &ReferenceOptions::default());
        let name = path.display();
        for (i, p) in r.image.pixels.iter().enumerate() {
            assert!(
                p.iter().all(|c| c.is_finite()),
                "{name}: pixel {i} is {p:?}"
            );
            assert_eq!(p[3], 1.0, "{name}: alpha");
        }
        assert_eq!(r.layers.len(), 128 * 128);
        assert_eq!(
            r.stats.fragments,
            r.fragments.iter().map(|&f| u64::from(f)).sum::<u64>(),
            "{name}"
        );
        assert_eq!(
            r.stats.composited_fragments,
            r.layers.iter().map(|&l| u64::from(l)).sum::<u64>()
        );
        assert!(
            r.layers.iter().zip(&r.fragments).all(|(l, f)| l <= f),
            "{name}: layers <= fragments"
        );
        assert!(r.stats.fragments > 0, "{name}: renders something");
        // Every bundled scene exists to test transparency: some pixel has a layer.
        assert!(
            r.stats.max_depth_complexity >= 1,
            "{name}: no transparent layer visible"
        );
    }
}

#[test]
fn bundled_closed_form_scenes_match() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let layers64 = oit_scene::load(&dir.join("many-layers-64.json")).expect("many-layers-64 loads");
    let r = render(
        &layers64.with_resolution(Resolution {
            width: 128,
            height: 128,
        }),
        &ReferenceOptions::default(),
    );
    assert_eq!(
        r.stats.max_depth_complexity, 64,
        "many-layers-64 has 64 layers somewhere"
    );
}

#[test]
fn bundled_enderton_is_the_enderton_vector_everywhere() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let scene = oit_scene::load(&dir.join("enderton.json")).expect("enderton loads");
    let r = render(
        &scene.with_resolution(Resolution {
            width: 128,
            height: 128,
        }),
        &ReferenceOptions::default(),
    );
    for (i, p) in r.image.pixels.iter().enumerate() {
        for (k, want) in [0.45, 0.2475, 0.3025].into_iter().enumerate() {
            assert!((f64::from(p[k]) - want).abs() < 1e-6, "pixel {i}: {p:?}");
        }
    }
}

#[test]
fn bundled_particles_at_2048_stay_within_the_per_tile_bound() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let scene = oit_scene::load(&dir.join("particles.json")).expect("particles loads");
    assert!(
        scene.triangle_count() >= 20_000,
        "at least 10 000 billboards"
    );
    let r = render(
        &scene.with_resolution(Resolution {
            width: 2048,
            height: 2048,
        }),
        &ReferenceOptions::default(),
    );
    println!(
        "bundled particles 2048²: {} fragments, max depth {}, peak tile {} bytes",
        r.stats.fragments, r.stats.max_depth_complexity, r.stats.peak_tile_bytes
    );
    // The same stated bound as tests/memory.rs: 4 MiB per 32-pixel tile.
    assert!(
        r.stats.peak_tile_bytes < 4 << 20,
        "peak tile {} bytes",
        r.stats.peak_tile_bytes
    );
    assert!(r.stats.fragments > 1_000_000);
}
