//! Wall-clock time of `compare` (all metrics) and of LDR-/HDR-ꟻLIP alone on synthetic pairs.
//!
//! `cargo run --release -p oit-tools --bin flip_timing [SIZE...]` (default 256 1024).
//! Each time is the best of several runs (`FLIP_TIMING_RUNS`, default 7 up to 512², else 3):
//! the minimum is the least disturbed by other work on the machine.

use std::time::Instant;

use oit_metrics::{DEFAULT_PPD, LinearImage, compare, flip_hdr, flip_ldr};

/// A scene-like image: smooth gradients, a checker of bright patches (HDR when `peak > 1`).
fn image(n: u32, peak: f32, shift: f32) -> LinearImage {
    let mut img = LinearImage::new(n, n, [0.0; 4]);
    for y in 0..n {
        for x in 0..n {
            let (u, v) = (x as f32 / n as f32, y as f32 / n as f32);
            let hot = ((x / 16 + y / 16) % 5 == 0) as u8 as f32;
            let base = [0.3 * u + shift, 0.4 * v, 0.2 + 0.1 * (u * 20.0).sin()];
            img.pixels[(y * n + x) as usize] = [
                base[0] + hot * peak * u,
                base[1] + hot * peak * 0.5,
                base[2] + hot * peak * v,
                1.0,
            ];
        }
    }
    img
}

fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> f64 {
    (0..runs)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(f());
            t.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let sizes: Vec<u32> = std::env::args()
        .skip(1)
        .map(|s| s.parse().expect("size in pixels"))
        .collect();
    let sizes = if sizes.is_empty() {
        vec![256, 1024]
    } else {
        sizes
    };
    println!("threads: {}", rayon::current_num_threads());
    for n in sizes {
        let runs = std::env::var("FLIP_TIMING_RUNS")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(if n <= 512 { 7 } else { 3 });
        for (label, peak) in [("LDR", 0.5f32), ("HDR", 1000.0)] {
            let reference = image(n, peak, 0.0);
            let render = image(n, peak * 0.9, 0.01);
            let rgb = |i: &LinearImage| -> Vec<[f32; 3]> {
                i.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect()
            };
            let (a, b) = (rgb(&reference), rgb(&render));
            let ldr = best_of(runs, || {
                flip_ldr(&a, &b, n as usize, n as usize, DEFAULT_PPD)
            });
            let hdr = flip_hdr(&a, &b, n as usize, n as usize, DEFAULT_PPD);
            let hdr_ms = best_of(runs, || {
                flip_hdr(&a, &b, n as usize, n as usize, DEFAULT_PPD)
            });
            let all = best_of(runs, || compare(&render, &reference).unwrap());
            println!(
                "{n}x{n} {label}: compare {all:.1} ms | LDR-FLIP {ldr:.1} ms | HDR-FLIP {hdr_ms:.1} ms ({} exposures)",
                hdr.exposures.count
            );
        }
    }
}
