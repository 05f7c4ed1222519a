//! Writes test pairs and this crate's ꟻLIP results for `xtask/flip-check/check.py`, which runs
//! NVIDIA's `flip-evaluator` on the same pixels and compares.
//!
//! `cargo run --release -p oit-tools --bin flip_pairs -- OUT_DIR [NAME=REF.exr,TEST.exr]...`
//!
//! The built-in pairs are synthetic (noise, flat fields with a 1e-4 offset, edges, HDR up to
//! 1000); each `NAME=REF.exr,TEST.exr` argument adds a pair read from EXR files (RGB of the first
//! layer).
//!
//! For each pair `NAME`: `NAME.ref.f32` and `NAME.test.f32` (linear RGB, row-major, 3 little-endian
//! f32 per pixel), `NAME.ldr.f32` and `NAME.hdr.f32` (the LDR- and HDR-ꟻLIP maps, one f32 per
//! pixel), and one entry in `pairs.json` with the size, the means, the HDR exposures and the SSIM
//! of the green channels.

use std::path::{Path, PathBuf};

use oit_metrics::{DEFAULT_PPD, flip_hdr, flip_ldr, flip_map_mean, read_exr_rgba, ssim};
use serde_json::json;

/// Deterministic pseudo-random numbers in [0, 1) (64-bit LCG, top 24 bits).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

struct Pair {
    name: String,
    width: usize,
    height: usize,
    reference: Vec<[f32; 3]>,
    test: Vec<[f32; 3]>,
}

fn pairs() -> Vec<Pair> {
    let mut rng = Lcg(2024);
    let mut out = Vec::new();

    let (w, h) = (64, 64);
    let reference = (0..w * h)
        .map(|_| [rng.next(), rng.next(), rng.next()])
        .collect();
    let test = (0..w * h)
        .map(|_| [rng.next(), rng.next(), rng.next()])
        .collect();
    out.push(Pair {
        name: "noise-independent".into(),
        width: w,
        height: h,
        reference,
        test,
    });

    let (w, h) = (97, 61);
    let reference: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
            [x, y, 0.5 + 0.5 * (9.0 * x * y).sin()].map(|c| (0.8 * c + 0.2 * rng.next()).min(1.0))
        })
        .collect();
    let test = reference
        .iter()
        .map(|p| p.map(|c| (c + 0.1 * (rng.next() - 0.5)).clamp(0.0, 1.0)))
        .collect();
    out.push(Pair {
        name: "noise-perturbed-97x61".into(),
        width: w,
        height: h,
        reference,
        test,
    });

    for (name, base) in [
        ("flat-0.5-plus-1e-4", 0.5f32),
        ("flat-0.02-plus-1e-4", 0.02),
    ] {
        let (w, h) = (64, 64);
        out.push(Pair {
            name: name.into(),
            width: w,
            height: h,
            reference: vec![[base; 3]; w * h],
            test: vec![[base + 1e-4; 3]; w * h],
        });
    }

    let (w, h) = (128, 96);
    let square =
        |x: usize, y: usize, x0: usize| (x0..x0 + 40).contains(&x) && (30..70).contains(&y);
    let scene = |x0: usize| -> Vec<[f32; 3]> {
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if square(x, y, x0) {
                    [0.9, 0.3, 0.05]
                } else {
                    [x as f32 / w as f32 * 0.5, 0.25, y as f32 / h as f32]
                }
            })
            .collect()
    };
    out.push(Pair {
        name: "square-shifted".into(),
        width: w,
        height: h,
        reference: scene(40),
        test: scene(43),
    });

    let (w, h) = (96, 80);
    let reference: Vec<[f32; 3]> = (0..w * h)
        .map(|_| [rng.next(), rng.next(), rng.next()].map(|u| 1e-2 * 1e5f32.powf(u)))
        .collect();
    let test = reference
        .iter()
        .map(|p| p.map(|c| c * (1.0 + 0.4 * (rng.next() - 0.5))))
        .collect();
    out.push(Pair {
        name: "hdr-lognoise-to-1000".into(),
        width: w,
        height: h,
        reference,
        test,
    });

    let (w, h) = (64, 64);
    let mut reference = vec![[0.05f32; 3]; w * h];
    let mut test = reference.clone();
    for y in 0..h {
        for x in 0..w {
            if (x / 8 + y / 8) % 3 == 0 {
                let v = 10.0 * 100f32.powf(x as f32 / w as f32);
                reference[y * w + x] = [v, v * 0.8, v * 0.5];
                test[y * w + x] = [v * 0.6, v * 0.48, v * 0.3];
            }
        }
    }
    out.push(Pair {
        name: "hdr-emissive-dim-highlights".into(),
        width: w,
        height: h,
        reference,
        test,
    });
    out
}

/// `NAME=REF.exr,TEST.exr` → the pair of RGB images.
fn exr_pair(arg: &str) -> Pair {
    let (name, files) = arg.split_once('=').expect("NAME=REF.exr,TEST.exr");
    let (reference, test) = files.split_once(',').expect("NAME=REF.exr,TEST.exr");
    let read = |p: &str| read_exr_rgba(Path::new(p), None).unwrap_or_else(|e| panic!("{e}"));
    let (reference, test) = (read(reference), read(test));
    assert_eq!(
        (reference.width, reference.height),
        (test.width, test.height),
        "{name}: sizes"
    );
    let rgb = |i: &oit_metrics::LinearImage| i.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect();
    Pair {
        name: name.to_string(),
        width: reference.width as usize,
        height: reference.height as usize,
        reference: rgb(&reference),
        test: rgb(&test),
    }
}

fn write_f32(path: &Path, values: impl IntoIterator<Item = f32>) {
    let bytes: Vec<u8> = values.into_iter().flat_map(f32::to_le_bytes).collect();
    std::fs::write(path, bytes).unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (dir, extra) = args
        .split_first()
        .expect("usage: flip_pairs OUT_DIR [NAME=REF.exr,TEST.exr]...");
    let dir = PathBuf::from(dir);
    std::fs::create_dir_all(&dir).expect("creating the output directory");
    let mut entries = Vec::new();
    for p in pairs().into_iter().chain(extra.iter().map(|a| exr_pair(a))) {
        let ldr = flip_ldr(&p.reference, &p.test, p.width, p.height, DEFAULT_PPD);
        let hdr = flip_hdr(&p.reference, &p.test, p.width, p.height, DEFAULT_PPD);
        let green =
            |v: &[[f32; 3]]| -> Vec<f32> { v.iter().map(|c| c[1].clamp(0.0, 1.0)).collect() };
        let ssim_g = ssim(&green(&p.test), &green(&p.reference), p.width, p.height);
        let file = |kind: &str| dir.join(format!("{}.{kind}.f32", p.name));
        write_f32(&file("ref"), p.reference.iter().flatten().copied());
        write_f32(&file("test"), p.test.iter().flatten().copied());
        write_f32(&file("ldr"), ldr.iter().copied());
        write_f32(&file("hdr"), hdr.map.iter().copied());
        println!(
            "{}: LDR {:.6} HDR {:.6} ({} exposures)",
            p.name,
            flip_map_mean(&ldr),
            flip_map_mean(&hdr.map),
            hdr.exposures.count
        );
        entries.push(json!({
            "name": p.name,
            "width": p.width,
            "height": p.height,
            "ppd": DEFAULT_PPD,
            "ldr_mean": flip_map_mean(&ldr),
            "hdr_mean": flip_map_mean(&hdr.map),
            "start_exposure": hdr.exposures.start,
            "stop_exposure": hdr.exposures.stop,
            "num_exposures": hdr.exposures.count,
            "ssim_green": ssim_g,
        }));
    }
    let json = serde_json::to_string_pretty(&entries).expect("JSON");
    std::fs::write(dir.join("pairs.json"), json).expect("writing pairs.json");
}
