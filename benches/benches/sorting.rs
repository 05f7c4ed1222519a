//! Per-triangle sorting, the CPU cost of `sorted-triangle`: 1 000 000 triangles with random
//! centroids sorted back to front by view depth (u32 keys from the float bits, then an LSD radix
//! sort of (key, index) pairs in 8, 8 and 16-bit digits). A comparison sort of the same keys is
//! the baseline it must beat.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Mat4, Vec3};
use oit_sorted::{DepthSorter, back_to_front_key};

/// Deterministic centroids in a 100-unit cube in front of the camera (splitmix64).
fn centroids(n: usize) -> Vec<Vec3> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            Vec3::new(
                next() * 100.0 - 50.0,
                next() * 100.0 - 50.0,
                -next() * 100.0 - 1.0,
            )
        })
        .collect()
}

fn sorting(c: &mut Criterion) {
    let view = glam::camera::rh::view::look_at_mat4(Vec3::new(3.0, 2.0, 10.0), Vec3::ZERO, Vec3::Y);
    let mut group = c.benchmark_group("sort-triangles");
    group.sample_size(10);
    for n in [100_000usize, 1_000_000] {
        let points = centroids(n);
        group.throughput(Throughput::Elements(n as u64));
        let mut sorter = DepthSorter::new();
        group.bench_with_input(BenchmarkId::new("radix", n), &points, |b, p| {
            b.iter(|| sorter.sort_back_to_front(&view, p).len())
        });
        group.bench_with_input(BenchmarkId::new("std-sort-baseline", n), &points, |b, p| {
            b.iter(|| comparison_sort(&view, p).len())
        });
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
