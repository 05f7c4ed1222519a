//! Times the per-triangle back-to-front sort of `sorted-triangle` on N random triangles
//! (default 1 000 000): `cargo run --release -p oit-tools --bin sort_triangles [N]`.

use glam::Vec3;
use std::time::Instant;

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1_000_000);
    // Deterministic xorshift centroids in a 20-unit cube in front of the camera.
    let mut x = 0x2545_f491_u32;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        x as f32 / u32::MAX as f32 * 20.0 - 10.0
    };
    let centroids: Vec<Vec3> = (0..n).map(|_| Vec3::new(next(), next(), next())).collect();
    let view = glam::camera::rh::view::look_at_mat4(Vec3::new(0.0, 0.0, 30.0), Vec3::ZERO, Vec3::Y);
    let mut sorter = oit_sorted::DepthSorter::new();
    let mut times = Vec::new();
    for _ in 0..12 {
        let t = Instant::now();
        let order = sorter.sort_back_to_front(&view, &centroids);
        std::hint::black_box(order);
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    // First run allocates the scratch buffers; report the steady state.
    let mut steady = times[2..].to_vec();
    steady.sort_by(f64::total_cmp);
    println!(
        "{n} triangles: median {:.2} ms, min {:.2} ms (first run {:.2} ms), {} threads",
        steady[steady.len() / 2],
        steady[0],
        times[0],
        rayon::current_num_threads()
    );
}
