//! CPU reference throughput: fragments per second on the bundled scenes that stress it most
//! (`many-layers-64`: 64 full-screen layers; `particles`: 10 000+ small billboards).

use std::path::Path;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use oit_reference::{ReferenceOptions, render};
use oit_scene::Resolution;

fn scene(name: &str, size: u32) -> oit_scene::Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(format!("{name}.json"));
    oit_scene::load(&path)
        .unwrap_or_else(|e| panic!("{e}"))
        .with_resolution(Resolution {
            width: size,
            height: size,
        })
}

fn reference(c: &mut Criterion) {
    let mut group = c.benchmark_group("reference");
    group.sample_size(10);
    for name in ["many-layers-64", "particles"] {
        for size in [256, 512] {
            let scene = scene(name, size);
            let fragments = render(&scene, &ReferenceOptions::default()).stats.fragments;
            group.throughput(Throughput::Elements(fragments));
            group.bench_function(format!("{name}/{size}x{size}"), |b| {
                b.iter(|| render(&scene, &ReferenceOptions::default()))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, reference);
criterion_main!(benches);
