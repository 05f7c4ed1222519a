//! Peak memory depends on the tile, not on the frame: a particles-like scene at 2048×2048.
//! The memory budget: tiles beyond it render in slices with the same output, a pixel beyond it
//! and a budget below one tile's state are errors.

mod common;

use common::*;
use glam::Vec3;
use oit_reference::{Reference, ReferenceError, ReferenceOptions, render, try_render};
use oit_scene::{AlphaMode, Camera, Projection, Resolution, Scene};

/// 10 000 camera-facing billboards (two triangles each) scattered in a view frustum, from a
/// fixed-seed generator so the numbers below are reproducible.
pub fn billboards(count: usize, size: u32) -> Scene {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f32 / (1u64 << 53) as f32
    };
    let camera = Camera::new(
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 60.0,
        },
        0.1,
        100.0,
        true,
        1.0,
    );
    let mut b = SceneBuilder::new(size, size)
        .camera(camera)
        .background([0.02, 0.02, 0.05]);
    let mut tris = Vec::with_capacity(2 * count);
    let mut colours = Vec::with_capacity(2 * count);
    for _ in 0..count {
        let d = 2.0 + 18.0 * next();
        let c = Vec3::new(
            (2.0 * next() - 1.0) * 0.6 * d,
            (2.0 * next() - 1.0) * 0.6 * d,
            -d,
        );
        let h = 0.03 + 0.12 * next();
        let q = [
            c + Vec3::new(-h, -h, 0.0),
            c + Vec3::new(h, -h, 0.0),
            c + Vec3::new(h, h, 0.0),
            c + Vec3::new(-h, h, 0.0),
        ];
        let colour = [next(), next(), next(), 0.1 + 0.5 * next()];
        tris.push([q[0], q[1], q[2]]);
        tris.push([q[0], q[2], q[3]]);
        colours.push(colour);
        colours.push(colour);
    }
    // One draw per 100 billboards keeps the draw list realistic without 10 000 materials.
    for (t, c) in tris.chunks(200).zip(colours.chunks(200)) {
        let coloured: Vec<_> = t.iter().zip(c).map(|(t, c)| t.map(|p| (p, *c))).collect();
        b.colored_triangles(blend([1.0; 3], 1.0), &coloured);
    }
    b.build()
}

/// Stated bound: 4 MiB per 32-pixel tile. Stored, a tile holds 37 bytes per pixel plus 24 per
/// covered transparent fragment (and 12 per covered row of a triangle), so 4 MiB is a tile
/// where every pixel has about 140 layers; composited in arrival order, as these flat
/// billboards are, 77 bytes per pixel whatever the depth (79.4 kB a tile), at 1024² and 2048²
/// alike, while the whole frame of fragments would take over 1 GiB.
const PEAK_TILE_BOUND: u64 = 4 << 20;

#[test]
fn particles_at_2048_stay_within_a_per_tile_bound() {
    let small = billboards(10_000, 1024);
    let large = small.with_resolution(Resolution {
        width: 2048,
        height: 2048,
    });
    // Stored and sorted, and composited in arrival order: both bounded per tile.
    for in_order in [false, true] {
        let options = ReferenceOptions {
            in_order,
            ..ReferenceOptions::default()
        };
        let a = render(&small, &options);
        let r = render(&large, &options);
        assert_all_finite(&r.image);
        let frame_bytes = r.stats.composited_fragments * 48;
        println!(
            "particles 2048², in order {in_order}: {} fragments, {} composited, max depth {}, \
             peak tile {} bytes (1024²: {}), whole-frame fragment storage would be {} bytes",
            r.stats.fragments,
            r.stats.composited_fragments,
            r.stats.max_depth_complexity,
            r.stats.peak_tile_bytes,
            a.stats.peak_tile_bytes,
            frame_bytes
        );
        assert!(
            r.stats.fragments > 5_000_000,
            "a heavy scene: {} fragments",
            r.stats.fragments
        );
        assert!(
            r.stats.peak_tile_bytes < PEAK_TILE_BOUND,
            "peak tile storage {} bytes exceeds the stated {PEAK_TILE_BOUND}",
            r.stats.peak_tile_bytes
        );
        // Four times the pixels and fragments, but not four times the tile storage.
        assert!(r.stats.fragments > 3 * a.stats.fragments);
        assert!(
            r.stats.peak_tile_bytes * 2 < a.stats.peak_tile_bytes * 3,
            "peak tile bytes grew with the frame: {} at 1024², {} at 2048²",
            a.stats.peak_tile_bytes,
            r.stats.peak_tile_bytes
        );
        assert!(r.stats.peak_tile_bytes * 50 < frame_bytes);
        if in_order {
            // Flat billboards arrive nearest first: per-pixel state only.
            assert_eq!(r.stats.in_order_tiles, r.stats.tiles);
            assert!(r.stats.peak_tile_bytes <= 32 * 32 * 80);
        }
    }
}

/// Renders on a pool of `threads` workers (the budget is shared among them).
fn render_on(threads: usize, scene: &Scene, budget: u64) -> Result<Reference, ReferenceError> {
    render_on_with(threads, scene, budget, true)
}

/// [`render_on`] with the in-order path allowed or not.
fn render_on_with(
    threads: usize,
    scene: &Scene,
    budget: u64,
    in_order: bool,
) -> Result<Reference, ReferenceError> {
    let options = ReferenceOptions {
        memory_budget: budget,
        in_order,
        ..ReferenceOptions::default()
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
        .install(|| try_render(scene, &options))
}

fn assert_same_output(a: &Reference, b: &Reference, what: &str) {
    assert!(
        image_bits(&a.image) == image_bits(&b.image),
        "{what}: image differs"
    );
    assert_eq!(a.layers, b.layers, "{what}: layers");
    assert_eq!(a.fragments, b.fragments, "{what}: fragments");
    assert_eq!(a.undecided, b.undecided, "{what}: undecided");
    assert_eq!(a.precision_ties, b.precision_ties, "{what}: precision ties");
    assert_eq!(
        a.stats.fragments, b.stats.fragments,
        "{what}: fragment total"
    );
}

/// 400 full-screen layers in shuffled depth order with varied colours, an opaque quad in the
/// middle of the stack over part of the screen and a mask-blend one: 64×64, deep enough that a
/// 32-pixel tile's fragments (about 11 MiB) are far over a 256 KiB budget.
fn deep_stack() -> Scene {
    let mut b = SceneBuilder::new(64, 64).background([0.1, 0.2, 0.3]);
    for i in 0..400u32 {
        let z = -(((i * 37) % 400) as f32) * 0.05;
        let t = i as f32 / 400.0;
        let alpha = 0.02 + 0.3 * ((i * 7) % 11) as f32 / 10.0;
        b.quad(blend([t, 1.0 - t, 0.5], alpha), fullscreen(z), white());
    }
    b.quad(
        opaque([0.9, 0.8, 0.1]),
        rect(-0.6, -0.8, 0.3, 0.4, -10.0),
        white(),
    );
    // Mask-blend with α interpolated from 0.2 to 0.9: discards on part of it.
    let [p, q, r, t] = rect(0.1, -0.3, 0.9, 0.9, -4.0);
    let alpha = |a: f32| [0.2, 0.9, 0.9, a];
    b.colored_triangles(
        material([1.0; 3], 1.0, AlphaMode::MaskBlend),
        &[
            [(p, alpha(0.2)), (q, alpha(0.9)), (r, alpha(0.9))],
            [(p, alpha(0.2)), (r, alpha(0.9)), (t, alpha(0.2))],
        ],
    );
    b.build()
}

const SMALL_BUDGET: u64 = 256 << 10;

#[test]
fn tiles_over_the_budget_render_in_slices_bit_identically() {
    let scene = deep_stack();
    let stored = ReferenceOptions {
        in_order: false,
        ..ReferenceOptions::default()
    };
    let full = render(&scene, &stored);
    assert_eq!(full.stats.sliced_tiles, 0, "the default budget holds it");
    assert!(
        full.stats.peak_tile_bytes > 10 * SMALL_BUDGET,
        "a tile at once takes {} bytes",
        full.stats.peak_tile_bytes
    );
    // Every tile is over a thread's share at once, so each is rendered alone afterwards, its
    // slices in parallel (on 8 threads a share is even below a tile's per-pixel state). The
    // layers are shuffled in depth, so the in-order path hands every tile on too.
    for threads in [1, 2, 8] {
        for in_order in [false, true] {
            let r =
                render_on_with(threads, &scene, SMALL_BUDGET, in_order).expect("renders in slices");
            let what = format!("{threads} threads, in order {in_order}");
            assert_same_output(&full, &r, &what);
            // In order (the shuffled layers are binned nearest first), but for the pixels
            // where the mask-blend quad is coplanar with a layer, which the stored path
            // renders; or sliced where that does not fit.
            if !in_order {
                assert_eq!(r.stats.sliced_tiles, 4, "{what}: every tile is sliced");
            }
            assert!(
                r.stats.peak_tile_bytes <= SMALL_BUDGET,
                "{what}: a tile held {} bytes, over the budget of {SMALL_BUDGET}",
                r.stats.peak_tile_bytes
            );
        }
    }
}

/// 6 000 tiny quads over pixel (5, 9) only, beside three full-screen layers, and a fragment
/// count there of 6 003; with `coplanar_pairs` the quads come in pairs at one depth, which no
/// arrival order decides, so the pixel's fragments must be stored and sorted.
fn deep_pixel(coplanar_pairs: bool) -> Scene {
    let mut b = SceneBuilder::new(64, 64);
    for z in [-1.0, -2.0, -3.0] {
        b.quad(blend([0.5, 0.5, 0.9], 0.3), fullscreen(z), white());
    }
    let (x, y) = (
        world_of_window_x(5.5, 64) as f64,
        world_of_window_y(9.5, 64) as f64,
    );
    let h = 0.3 * 2.0 / 64.0;
    let quads: Vec<[Vec3; 3]> = (0..6000)
        .flat_map(|i| {
            let step = if coplanar_pairs { i / 2 } else { i };
            let z = -5.0 - step as f32 * 0.01;
            let [a, b, c, d] = rect(
                (x - h) as f32,
                (y - h) as f32,
                (x + h) as f32,
                (y + h) as f32,
                z,
            );
            [[a, b, c], [a, c, d]]
        })
        .collect();
    b.triangles(blend([0.9, 0.1, 0.1], 0.1), &quads, white());
    b.build()
}

#[test]
fn a_deep_pixel_whose_fragments_arrive_in_order_needs_no_storage() {
    let scene = deep_pixel(false);
    let fits = render(&scene, &ReferenceOptions::default());
    assert_eq!(fits.fragments[9 * 64 + 5], 6003);
    assert_eq!(fits.stats.in_order_tiles, fits.stats.tiles);
    for threads in [1, 2, 4] {
        let r = render_on(threads, &scene, SMALL_BUDGET).expect("composited in order");
        assert_same_output(&fits, &r, &format!("{threads} threads"));
        // A 32×32 tile's per-pixel state (77 bytes a pixel in order), nothing per fragment.
        assert!(
            r.stats.peak_tile_bytes <= 32 * 32 * 80,
            "{} bytes",
            r.stats.peak_tile_bytes
        );
    }
    // Stored and sorted, the same pixel needs more than the budget.
    let e = render_on_with(1, &scene, SMALL_BUDGET, false).expect_err("stored");
    assert!(
        matches!(e, ReferenceError::PixelOverBudget { x: 5, y: 9, .. }),
        "{e:?}"
    );
}

/// `count` full-screen layers of varied colour and alpha at `size`².
fn layer_stack(count: u32, size: u32) -> Scene {
    let mut b = SceneBuilder::new(size, size).background([0.1, 0.2, 0.3]);
    for i in 0..count {
        let t = i as f32 / count as f32;
        let alpha = 0.02 + 0.2 * ((i * 7) % 11) as f32 / 10.0;
        b.quad(
            blend([t, 1.0 - t, 0.5], alpha),
            fullscreen(-0.5 - i as f32 * 0.01),
            white(),
        );
    }
    b.build()
}

#[test]
fn a_tile_over_a_thread_share_is_composited_in_bands_on_every_thread() {
    // Four 32-pixel tiles.
    let scene = layer_stack(300, 64);
    let whole = render(&scene, &ReferenceOptions::default());
    assert_eq!(whole.stats.in_order_tiles, 4);
    assert_eq!(
        whole.stats.banded_tiles, 0,
        "the default budget holds every tile"
    );
    // A tile's in-order state (77 bytes a pixel: 79 KB) is over a thread's share of 128 KiB
    // on two or four threads, so every tile is deferred; a band of 16 or 8 rows fits its
    // share of the whole budget.
    let budget = 128 << 10;
    for threads in [2, 4] {
        let r = render_on(threads, &scene, budget).expect("fits in bands");
        let what = format!("{threads} threads");
        assert_same_output(&whole, &r, &what);
        assert_eq!(r.stats.banded_tiles, 4, "{what}");
        assert_eq!(r.stats.in_order_tiles, 4, "{what}");
        assert_eq!(r.stats.sliced_tiles, 0, "{what}");
        assert!(
            r.stats.peak_tile_bytes <= budget,
            "{what}: the bands held {} bytes at once",
            r.stats.peak_tile_bytes
        );
    }
    // On one thread its share is the whole budget: nothing is deferred.
    let one = render_on(1, &scene, budget).expect("fits");
    assert_same_output(&whole, &one, "1 thread");
    assert_eq!(one.stats.banded_tiles, 0);
}

#[test]
fn a_deep_tile_that_is_the_whole_frame_runs_on_every_thread() {
    // One 32-pixel tile of 1200 triangles: it would keep one thread busy while the other has
    // nothing to do, so it waits for the others (none) and renders in bands on all threads.
    let scene = layer_stack(600, 32);
    let one = render_on(1, &scene, ReferenceOptions::DEFAULT_MEMORY_BUDGET).expect("renders");
    assert_eq!(one.stats.banded_tiles, 0, "one thread has nothing to share");
    for threads in [2, 3] {
        let r =
            render_on(threads, &scene, ReferenceOptions::DEFAULT_MEMORY_BUDGET).expect("renders");
        assert_same_output(&one, &r, &format!("{threads} threads"));
        assert_eq!(r.stats.banded_tiles, 1, "{threads} threads");
    }
    // A tile that is not the critical path stays in the parallel pass: many-layers-like
    // content over 16 tiles.
    let spread = render_on(
        2,
        &layer_stack(600, 128),
        ReferenceOptions::DEFAULT_MEMORY_BUDGET,
    )
    .expect("renders");
    assert_eq!(spread.stats.banded_tiles, 0);
    assert_eq!(spread.stats.in_order_tiles, 16);
}

#[test]
fn a_pixel_over_the_budget_is_an_error_naming_it() {
    // 6 003 fragments at pixel (5, 9) that must be sorted: about 312 KB to sort and
    // composite, over a 256 KiB budget.
    let scene = deep_pixel(true);
    let fits = render(&scene, &ReferenceOptions::default());
    assert_eq!(fits.fragments[9 * 64 + 5], 6003);

    for threads in [1, 2, 4] {
        let e = render_on(threads, &scene, SMALL_BUDGET).expect_err("pixel (5, 9) cannot fit");
        let ReferenceError::PixelOverBudget {
            x,
            y,
            fragments,
            bytes,
            available,
            budget,
        } = e
        else {
            panic!("{threads} threads: expected PixelOverBudget, got {e:?}");
        };
        assert_eq!((x, y, fragments, budget), (5, 9, 6003, SMALL_BUDGET));
        // Key, colour, sorted index, span and sort buffers per fragment.
        assert!(bytes >= 6003 * 48 && bytes > available && available < budget);
        let message = e.to_string();
        assert!(
            !message.contains('\n')
                && message.contains("pixel (5, 9)")
                && message.contains("6003")
                && message.contains(&bytes.to_string())
                && message.contains(&SMALL_BUDGET.to_string())
                && message.contains("--memory-budget"),
            "{message}"
        );
    }
}

#[test]
fn a_budget_below_one_tile_state_is_rejected() {
    let mut b = SceneBuilder::new(64, 48);
    b.quad(blend([0.5; 3], 0.5), fullscreen(-1.0), white());
    let scene = b.build();
    let options = |memory_budget| ReferenceOptions {
        memory_budget,
        ..ReferenceOptions::default()
    };
    let e = try_render(&scene, &options(0)).expect_err("a budget of 0");
    let ReferenceError::MemoryBudget {
        budget: 0,
        minimum,
        width: 32,
        height: 32,
    } = e
    else {
        panic!("expected MemoryBudget for a 32x32 tile, got {e:?}");
    };
    // At least the opaque key and colour, counts, list bounds and tie flag of each pixel.
    assert!(minimum >= 32 * 32 * 37, "{minimum}");
    assert!(e.to_string().contains("--memory-budget"), "{e}");
    assert!(matches!(
        try_render(&scene, &options(minimum - 1)),
        Err(ReferenceError::MemoryBudget { .. })
    ));
    // Just enough for the tile state renders (binning needs a little more than the tile).
    let e = try_render(&scene, &options(minimum)).expect_err("no room for the bins");
    assert!(
        matches!(e, ReferenceError::BinningOverBudget { overlaps, .. } if overlaps > 0),
        "{e:?}"
    );
    let tight = try_render(&scene, &options(minimum + 4096)).expect("fits");
    assert_same_output(
        &render(&scene, &ReferenceOptions::default()),
        &tight,
        "tight",
    );
}
