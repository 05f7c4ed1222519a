//! Compositing in arrival order (`ReferenceOptions::in_order`, the default) gives the stored,
//! sorted path's output bit for bit: image, per-pixel counts, ties and statistics, on every
//! bundled scene and on seeded random scenes nobody placed by hand.

mod common;

use std::path::Path;

use common::*;
use glam::Vec3;
use oit_reference::{Reference, ReferenceOptions, render};
use oit_scene::{Resolution, Scene};

fn options(in_order: bool, tile_size: u32) -> ReferenceOptions {
    ReferenceOptions {
        in_order,
        tile_size,
        ..ReferenceOptions::default()
    }
}

/// Everything but timings, peak storage and which path rendered the tiles must agree.
fn assert_same(a: &Reference, b: &Reference, what: &str) {
    let (ia, ib) = (image_bits(&a.image), image_bits(&b.image));
    if let Some(i) = ia.iter().zip(&ib).position(|(x, y)| x != y) {
        let w = a.image.width as usize;
        panic!(
            "{what}: pixel ({}, {}) differs: in order {:?}, stored {:?}",
            i / 4 % w,
            i / 4 / w,
            a.image.pixels[i / 4],
            b.image.pixels[i / 4]
        );
    }
    assert_eq!(a.layers, b.layers, "{what}: layers");
    assert_eq!(a.fragments, b.fragments, "{what}: fragments");
    assert_eq!(a.undecided, b.undecided, "{what}: undecided");
    assert_eq!(a.precision_ties, b.precision_ties, "{what}: precision ties");
    let (s, t) = (&a.stats, &b.stats);
    let counts = |s: &oit_reference::ReferenceStats| {
        (
            s.triangles,
            s.raster_triangles,
            s.fragments,
            s.transparent_fragments,
            s.composited_fragments,
            s.max_depth_complexity,
            s.covered_pixels,
            s.undecided_fragments,
            s.undecided_pixels,
            s.precision_tie_pixels,
        )
    };
    assert_eq!(counts(s), counts(t), "{what}: statistics");
    assert_eq!(
        s.mean_depth_complexity.to_bits(),
        t.mean_depth_complexity.to_bits(),
        "{what}: mean depth complexity"
    );
    assert_eq!(t.in_order_tiles, 0, "{what}: the stored path was forced");
}

fn bundled() -> Vec<(String, Scene)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    oit_scene::load_dir(&dir)
        .unwrap_or_else(|e| panic!("loading {}: {e}", dir.display()))
        .into_iter()
        .map(|(path, scene)| (path.display().to_string(), scene))
        .collect()
}

#[test]
fn in_order_equals_stored_on_every_bundled_scene() {
    let mut in_order_tiles = 0;
    let mut tiles = 0;
    let mut partly_stored = Vec::new();
    // Odd sizes put partial tiles on the right and bottom edges; 8-pixel tiles make many.
    for (name, scene) in bundled() {
        for (width, height, tile) in [(100, 70, 32), (64, 64, 8)] {
            let scene = scene.with_resolution(Resolution { width, height });
            let a = render(&scene, &options(true, tile));
            let b = render(&scene, &options(false, tile));
            let what = format!("{name} at {width}x{height}, {tile}-pixel tiles");
            assert_same(&a, &b, &what);
            in_order_tiles += a.stats.in_order_tiles;
            tiles += a.stats.tiles;
            if a.stats.in_order_tiles < a.stats.tiles {
                partly_stored.push(what);
            }
        }
    }
    println!(
        "{in_order_tiles} of {tiles} tiles in order; tiles with stored runs in: {partly_stored:?}"
    );
    // Both paths ran: the comparison above tests something.
    assert!(in_order_tiles * 2 > tiles, "{in_order_tiles} of {tiles}");
    assert!(
        partly_stored
            .iter()
            .any(|w| w.contains("intersecting-quads")),
        "intersecting planes must need the stored path somewhere: {partly_stored:?}"
    );
}

#[test]
fn layered_content_is_composited_in_order_everywhere() {
    for name in ["many-layers-64", "faint-haze", "alpha-099-stack"] {
        let (_, scene) = bundled()
            .into_iter()
            .find(|(path, _)| path.ends_with(&format!("{name}.json")))
            .unwrap_or_else(|| panic!("{name} is bundled"));
        let r = render(&scene, &ReferenceOptions::default());
        assert_eq!(
            r.stats.in_order_tiles, r.stats.tiles,
            "{name}: every tile's layers arrive nearest first"
        );
    }
}

#[test]
fn in_order_equals_stored_on_random_scenes() {
    let (mut in_order_tiles, mut tiles) = (0, 0);
    for seed in 0..300 {
        let (text, about) = oit_scene::random::random_scene_json(seed);
        let scene = oit_scene::parse(&text, &format!("random-{seed}")).expect("random scene");
        for tile in [32, 8] {
            let a = render(&scene, &options(true, tile));
            let b = render(&scene, &options(false, tile));
            assert_same(
                &a,
                &b,
                &format!("seed {seed}, {tile}-pixel tiles: {about:?}"),
            );
            in_order_tiles += a.stats.in_order_tiles;
            tiles += a.stats.tiles;
        }
    }
    println!("{in_order_tiles} of {tiles} tiles of random scenes in order");
    assert!(in_order_tiles > 0 && in_order_tiles < tiles);
}

/// Row bands ([`oit_reference::ReferenceStats::banded_tiles`]) on content nobody placed:
/// with 4 threads and 160 KiB, a thread's share is below a 32-pixel tile's in-order state, so
/// tiles are deferred and composited in bands of 8 rows (or, where a band's stored pixels do
/// not fit, whole or in slices); the output is the stored path's at the default budget.
#[test]
fn bands_equal_the_stored_path_on_random_scenes() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .expect("a thread pool");
    let tight = ReferenceOptions {
        memory_budget: 160 << 10,
        ..ReferenceOptions::default()
    };
    let (mut banded, mut rendered) = (0, 0);
    for seed in 0..150 {
        let (text, about) = oit_scene::random::random_scene_json(seed);
        let scene = oit_scene::parse(&text, &format!("random-{seed}")).expect("random scene");
        let Ok(a) = pool.install(|| oit_reference::try_render(&scene, &tight)) else {
            // A pixel over the tight budget: an error naming it, tested elsewhere.
            continue;
        };
        let b = render(&scene, &options(false, 32));
        assert_same(&a, &b, &format!("seed {seed}, banded: {about:?}"));
        banded += a.stats.banded_tiles;
        rendered += 1;
    }
    println!("{banded} banded tiles in {rendered} random scenes");
    assert!(
        rendered > 100 && banded > 100,
        "{banded} banded tiles in {rendered} scenes"
    );
}

/// Full-screen layers in pairs a few f32 ulps of window depth apart, nearest first, so they
/// arrive in depth order: where the two of a pair are within the tie distance, rounding could
/// swap them on a GPU, and the in-order path must hand those pixels to the stored path, which
/// flags them, instead of compositing them as if the order were certain.
#[test]
fn layers_within_the_tie_distance_are_flagged_as_the_stored_path_does() {
    for reverse_z in [false, true] {
        let mut b = SceneBuilder::new(40, 40).camera(ortho_camera(40, 40, reverse_z));
        // One f32 ulp of window depth near z = 0 is about 7.5e-7 in world units here.
        for (i, gap) in [2e-7f32, 1.5e-6, 6e-6, 4e-5].into_iter().enumerate() {
            let z = -(i as f32) * 0.5;
            let x0 = -1.0 + 0.5 * i as f32;
            b.quad(
                blend([1.0, 0.2, 0.1], 0.4),
                rect(x0, -1.0, x0 + 0.5, 1.0, z),
                white(),
            );
            b.quad(
                blend([0.1, 0.3, 1.0], 0.6),
                rect(x0, -1.0, x0 + 0.5, 1.0, z - gap),
                white(),
            );
        }
        let scene = b.build();
        let a = render(&scene, &options(true, 16));
        let s = render(&scene, &options(false, 16));
        assert_same(&a, &s, &format!("reverse_z {reverse_z}"));
        // Pair i covers the pixel columns 10·i..10·i + 10.
        let tied = |column: usize| (0..40).all(|row| s.precision_ties[row * 40 + column]);
        let apart = |column: usize| (0..40).all(|row| !s.precision_ties[row * 40 + column]);
        assert!(
            tied(5) && apart(35),
            "reverse_z {reverse_z}: the closest pair ties, the farthest does not"
        );
    }
}

/// Tiles no triangle touches take a short cut (the background, no per-pixel state): it must
/// give the general path's bits, including `0 + 1 · (−0) = +0` for a background channel of
/// −0, and zero counts, beside tiles that composite.
#[test]
fn untouched_tiles_are_the_background_as_the_general_path_writes_it() {
    let mut b = SceneBuilder::new(64, 64).background([-0.0, 0.25, 3.0]);
    b.quad(
        blend([0.9, 0.4, 0.1], 0.5),
        rect(-0.2, -0.2, 0.2, 0.2, 0.0),
        white(),
    );
    let scene = b.build();
    let a = render(&scene, &options(true, 8));
    let s = render(&scene, &options(false, 8));
    assert_same(&a, &s, "a small quad in a large empty frame");
    // The top-left pixel is background; −0 came out as +0, as the stored path writes it.
    assert_eq!(
        a.image.pixels[0].map(f32::to_bits),
        [0.0f32, 0.25, 3.0, 1.0].map(f32::to_bits)
    );
    assert_eq!((a.layers[0], a.fragments[0]), (0, 0));
    // The quad's pixels composited: the comparison covered both kinds of tile.
    assert!(a.stats.covered_pixels > 0 && a.stats.covered_pixels < 64 * 64 / 4);
    assert_eq!(a.stats.in_order_tiles, a.stats.tiles);
}

/// Sixteen full-screen planes tilted every which way through one another: nearly every pixel
/// receives them out of the order they were binned in, so the in-order pass gives the tile
/// up early and renders it with stored lists. Same output as the stored path alone.
#[test]
fn a_mostly_disordered_tile_gives_up_compositing_in_order() {
    let mut b = SceneBuilder::new(32, 32);
    let mut state = 0x2545_f491_u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state as f32 / u32::MAX as f32 * 2.0 - 1.0
    };
    for i in 0..16 {
        let (gx, gy, z) = (next(), next(), next() * 0.5);
        let corner = |x: f32, y: f32| Vec3::new(x, y, z + gx * x + gy * y);
        b.quad(
            blend([i as f32 / 16.0, 0.5, 1.0 - i as f32 / 16.0], 0.3),
            [
                corner(-1.5, -1.5),
                corner(1.5, -1.5),
                corner(1.5, 1.5),
                corner(-1.5, 1.5),
            ],
            white(),
        );
    }
    let scene = b.build();
    let a = render(&scene, &options(true, 32));
    let s = render(&scene, &options(false, 32));
    assert_same(&a, &s, "sixteen tilted planes");
    assert_eq!(a.stats.tiles, 1);
    assert_eq!(a.stats.given_up_tiles, 1, "{:?}", a.stats);
    assert_eq!(
        (a.stats.in_order_tiles, a.stats.stored_pixels),
        (0, 32 * 32)
    );
    // Every pixel has all sixteen layers: no plane left the view volume.
    assert!(a.layers.iter().all(|&l| l == 16));
}
