//! Per-triangle sorting, the CPU cost of `sorted-triangle`: 1 000 000 triangles sorted back to
//! front by the view depth of their centroids (u32 keys from the float bits, split by their
//! leading bits into L2-sized buckets that are radix-sorted in place). Three layouts, because a
//! radix sort's speed depends on how the keys spread: random centroids in a cube, a thin slab
//! (every depth within 0.5 % of the others: most key bits equal), and a tight cluster with a few
//! far outliers (the key range is mostly empty). A comparison sort of the same keys is the
//! baseline it must beat.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Mat4, Vec3};
use oit_sorted::{DepthSorter, back_to_front_key};

/// Deterministic uniform numbers in [0, 1) (splitmix64).
fn uniform() -> impl FnMut() -> f32 {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// `n` centroids in one of the layouts (the camera is at (3, 2, 10) looking at the origin).
fn centroids(layout: &str, n: usize) -> Vec<Vec3> {
    let mut next = uniform();
    (0..n)
        .map(|i| match layout {
            // A 100-unit cube in front of the camera.
            "cube" => Vec3::new(
                next() * 100.0 - 50.0,
                next() * 100.0 - 50.0,
                -next() * 100.0 - 1.0,
            ),
            // A 100 × 100 wall, half a unit thick, about 100 units away.
            "slab" => Vec3::new(
                next() * 100.0 - 50.0,
                next() * 100.0 - 50.0,
                -90.0 - next() * 0.5,
            ),
            // A unit cube of triangles, and one in 100 000 far away in either direction.
            _ if i % 100_000 == 7 => Vec3::new(0.0, 0.0, if i % 2 == 0 { -1e5 } else { 9.9 }),
            _ => Vec3::new(next(), next(), -next()),
        })
        .collect()
}

fn sorting(c: &mut Criterion) {
    let view = glam::camera::rh::view::look_at_mat4(Vec3::new(3.0, 2.0, 10.0), Vec3::ZERO, Vec3::Y);
    let mut group = c.benchmark_group("sort-triangles");
    group.sample_size(10);
    for (layout, n) in [
        ("cube", 100_000usize),
        ("cube", 1_000_000),
        ("slab", 1_000_000),
        ("cluster", 1_000_000),
    ] {
        let points = centroids(layout, n);
        group.throughput(Throughput::Elements(n as u64));
        let mut sorter = DepthSorter::new();
        let id = format!("{layout}/{n}");
        group.bench_with_input(BenchmarkId::new("radix", &id), &points, |b, p| {
            b.iter(|| sorter.sort_back_to_front(&view, p).len())
        });
        group.bench_with_input(
            BenchmarkId::new("std-sort-baseline", &id),
            &points,
            |b, p| b.iter(|| comparison_sort(&view, p).len()),
        );
    }
    group.finish();
}

/// The obvious alternative: keys, then `sort_unstable_by_key` on (key, index).
fn comparison_sort(view: &Mat4, points: &[Vec3]) -> Vec<u32> {
    let row = view.row(2);
    let mut pairs: Vec<(u32, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            (
                back_to_front_key(-(row.x * p.x + row.y * p.y + row.z * p.z + row.w)),
                i as u32,
            )
        })
        .collect();
    pairs.sort_unstable();
    pairs.into_iter().map(|(_, i)| i).collect()
}

criterion_group!(benches, sorting);
criterion_main!(benches);
