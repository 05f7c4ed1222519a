//! Prints every metric of `compare` for renders against a reference EXR, with the time taken.
//!
//! `cargo run --release -p oit-tools --bin compare_exr -- REFERENCE.exr RENDER.exr...`

use std::path::Path;
use std::time::Instant;

use oit_metrics::{compare, hdr_exposures, read_exr_rgba};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (reference, renders) = args
        .split_first()
        .expect("usage: compare_exr REFERENCE.exr RENDER.exr...");
    let reference = read_exr_rgba(Path::new(reference), None).expect("reading the reference");
    let rgb: Vec<[f32; 3]> = reference
        .pixels
        .iter()
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    println!(
        "reference {}x{}, HDR-FLIP exposures {:?}",
        reference.width,
        reference.height,
        hdr_exposures(&rgb)
    );
    for path in renders {
        let render = read_exr_rgba(Path::new(path), None).expect("reading a render");
        let t = Instant::now();
        let e = compare(&render, &reference).expect("same size");
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let (flip, kind) = e.headline_flip();
        println!("{path}: {kind} {flip:.4} ({ms:.1} ms)\n  {e:?}");
    }
}
