//! Peak memory depends on the tile, not on the frame: a particles-like scene at 2048×2048.

mod common;

use common::*;
use glam::Vec3;
use oit_reference::{ReferenceOptions, render};
use oit_scene::{Camera, Projection, Resolution, Scene};

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

/// Stated bound: 4 MiB per 32-pixel tile. A tile holds 32 bytes per pixel plus 28 bytes per
/// covered transparent fragment (and 12 per covered row of a triangle), so 4 MiB is a tile
/// where every pixel has about 140 layers; this scene peaks around 0.5 MiB (depth complexity
/// ≤ ~21) at 1024² and 2048² alike, while its whole frame of fragments would take over 1 GiB.
const PEAK_TILE_BOUND: u64 = 4 << 20;

#[test]
fn particles_at_2048_stay_within_a_per_tile_bound() {
    let small = billboards(10_000, 1024);
    let large = small.with_resolution(Resolution {
        width: 2048,
        height: 2048,
    });
    let a = render(&small, &ReferenceOptions::default());
    let r = render(&large, &ReferenceOptions::default());
    assert_all_finite(&r.image);
    let frame_bytes = r.stats.composited_fragments * 48;
    println!(
        "particles 2048²: {} fragments, {} composited, max depth {}, peak tile {} bytes (1024²: {}), \
         whole-frame fragment storage would be {} bytes",
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
}
