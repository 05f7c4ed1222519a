//! Reference throughput and scaling, the numbers quoted in the README:
//!
//! ```text
//! cargo run --release -p oit-tools --bin reference_perf [SCENES_DIR]
//! ```
//!
//! Prints fragments per second on `many-layers-64` and `particles` at 1024×1024, time against
//! resolution (4 sizes) and against layer count (4 counts, synthetic full-screen layers), the
//! per-phase times (setup and binning are wall time; raster, sort and composite are summed
//! over the worker threads) and the peak per-tile storage. Each figure is the best of 3 runs.

use std::path::{Path, PathBuf};

use glam::Vec3;
use oit_reference::{Reference, ReferenceOptions, render};
use oit_scene::{AlphaMode, Camera, Draw, Material, Projection, Resolution, Scene, Vertex, load};

fn best_of(scene: &Scene, options: &ReferenceOptions, runs: usize) -> Reference {
    let mut best: Option<Reference> = None;
    for _ in 0..runs {
        let r = render(scene, options);
        if best
            .as_ref()
            .is_none_or(|b| r.stats.seconds < b.stats.seconds)
        {
            best = Some(r);
        }
    }
    best.expect("at least one run")
}

fn row(label: &str, r: &Reference) {
    let s = &r.stats;
    println!(
        "{label:<28} {:>9.1} ms {:>12} frags {:>8.1} Mfrag/s | setup {:>6.1} bin {:>6.1} raster {:>7.1} sort {:>7.1} composite {:>7.1} ms | max {:>3} mean {:>6.2} | peak tile {:>9} B | in order {}/{} tiles ({} in bands, {} given up), {} px stored",
        s.seconds * 1e3,
        s.fragments,
        s.fragments_per_second / 1e6,
        s.setup_seconds * 1e3,
        s.binning_seconds * 1e3,
        s.raster_seconds * 1e3,
        s.sort_seconds * 1e3,
        s.composite_seconds * 1e3,
        s.max_depth_complexity,
        s.mean_depth_complexity,
        s.peak_tile_bytes,
        s.in_order_tiles,
        s.tiles,
        s.banded_tiles,
        s.given_up_tiles,
        s.stored_pixels,
    );
}

/// `n` full-screen blended layers with varied colour and alpha, orthographic, 1024².
fn layers_scene(n: usize, size: u32) -> Scene {
    let camera = Camera::new(
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Orthographic { height: 2.0 },
        0.5,
        100.0,
        true,
        1.0,
    );
    let mut materials = Vec::new();
    let mut draws = Vec::new();
    let mut vertices = Vec::new();
    for i in 0..n {
        let t = i as f32 / n as f32;
        materials.push(Material::plain(
            [t, 1.0 - t, 0.5],
            0.05 + 0.4 * ((i * 7) % 11) as f32 / 10.0,
            AlphaMode::Blend,
        ));
        let z = -(i as f32) * 0.01;
        let c = [
            [-1.5, -1.5],
            [1.5, -1.5],
            [1.5, 1.5],
            [-1.5, -1.5],
            [1.5, 1.5],
            [-1.5, 1.5],
        ];
        let first = vertices.len() as u32;
        for [x, y] in c {
            vertices.push(Vertex {
                position: [x, y, z],
                color: [1.0; 4],
                uv: [0.0; 2],
                normal: [0.0; 3],
            });
        }
        draws.push(Draw {
            id: i as u32,
            name: format!("layers[{i}]"),
            material: i as u32,
            first_vertex: first,
            vertex_count: 6,
            ordering: Default::default(),
            bounds_center: Vec3::new(0.0, 0.0, z),
            bounds_radius: 2.2,
        });
    }
    Scene {
        name: format!("layers-{n}"),
        description: "synthetic full-screen layers".into(),
        resolution: Resolution {
            width: size,
            height: size,
        },
        camera,
        background: [0.1, 0.1, 0.1],
        materials,
        draws,
        vertices,
        textures: Vec::new(),
        ignored: Vec::new(),
        credits: Vec::new(),
        frame: 0,
        animation: None,
        lights: oit_scene::LightRig::none(),
    }
}

fn main() {
    // Arguments: [SCENES_DIR] [--quick] [--stored] [--tile N] [--only SCENE]; --quick stops
    // after the two scenes.
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let tile = args
        .iter()
        .position(|a| a == "--tile")
        .and_then(|i| args.get(i + 1));
    let tile_size = match tile {
        Some(t) => t
            .parse()
            .unwrap_or_else(|_| panic!("--tile {t}: expected a number of pixels")),
        None => ReferenceOptions::DEFAULT_TILE_SIZE,
    };
    let dir = args
        .iter()
        .enumerate()
        .find(|(i, a)| {
            !a.starts_with("--")
                && (*i == 0
                    || !["--tile", "--only", "--each", "--size"].contains(&args[i - 1].as_str()))
        })
        .map(|(_, a)| PathBuf::from(a))
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes"));
    // --stored: every tile with stored, sorted lists (no in-order compositing).
    let stored = args.iter().any(|a| a == "--stored");
    let options = ReferenceOptions {
        tile_size,
        progress: None,
        in_order: !stored,
        ..Default::default()
    };
    println!(
        "oit-reference perf: {} rayon threads, tile {} px, best of 3",
        rayon::current_num_threads(),
        options.tile_size
    );
    // --each DIR: every scene file (.json, .gltf, .glb) in DIR at 512², composited in order (with stored
    // rectangles where needed) against stored lists everywhere: whether the in-order path
    // pays off on content nobody tuned it for.
    if let Some(each) = args
        .iter()
        .position(|a| a == "--each")
        .and_then(|i| args.get(i + 1))
    {
        let size = args
            .iter()
            .position(|a| a == "--size")
            .and_then(|i| args.get(i + 1))
            .map_or(512, |s| s.parse().expect("--size N: pixels"));
        each_scene(Path::new(each), &options, size);
        return;
    }
    let at = |s: &Scene, n: u32| {
        s.with_resolution(Resolution {
            width: n,
            height: n,
        })
    };

    println!("\n== bundled scenes at 1024x1024 ==");
    // --only NAME: just that scene (for profiling one of them).
    let only = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|i| args.get(i + 1));
    for name in ["many-layers-64", "particles"] {
        if only.is_some_and(|o| o != name) {
            continue;
        }
        match load(&dir.join(format!("{name}.json"))) {
            Ok(scene) => row(name, &best_of(&at(&scene, 1024), &options, 3)),
            Err(e) => println!("{name}: cannot load ({e})"),
        }
    }

    if quick {
        return;
    }
    println!("\n== time vs resolution ==");
    for name in ["many-layers-64", "particles"] {
        if let Ok(scene) = load(&dir.join(format!("{name}.json"))) {
            for n in [256, 512, 1024, 2048] {
                row(
                    &format!("{name} {n}x{n}"),
                    &best_of(&at(&scene, n), &options, 3),
                );
            }
        }
    }

    println!("\n== time vs layer count (synthetic full-screen layers, 1024x1024) ==");
    for n in [8, 32, 128, 512] {
        row(
            &format!("layers-{n}"),
            &best_of(&layers_scene(n, 1024), &options, 3),
        );
    }

    println!("\n== tile size (layers-64 and particles, 1024x1024) ==");
    let particles = load(&dir.join("particles.json")).ok().map(|s| at(&s, 1024));
    for tile_size in [8, 16, 32, 64, 128] {
        let o = ReferenceOptions {
            tile_size,
            progress: None,
            ..Default::default()
        };
        row(
            &format!("layers-64 tile {tile_size}"),
            &best_of(&layers_scene(64, 1024), &o, 3),
        );
        if let Some(p) = &particles {
            row(&format!("particles tile {tile_size}"), &best_of(p, &o, 3));
        }
    }
}

/// `--each DIR`: in-order against stored-only time per scene, and the ratio over them all.
fn each_scene(dir: &Path, options: &ReferenceOptions, size: u32) {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .is_some_and(|x| x == "json" || x == "gltf" || x == "glb")
        })
        .collect();
    paths.sort();
    let stored = ReferenceOptions {
        in_order: false,
        ..options.clone()
    };
    let (mut in_order_total, mut stored_total) = (0.0, 0.0);
    println!(
        "scene                     in order ms  stored ms  ratio  stored px %  given up  fragments"
    );
    for path in &paths {
        let scene = match load(path) {
            Ok(s) => s.with_resolution(Resolution {
                width: size,
                height: size,
            }),
            Err(e) => {
                println!("{}: cannot load ({e})", path.display());
                continue;
            }
        };
        let a = best_of(&scene, options, 3).stats;
        let b = best_of(&scene, &stored, 3).stats;
        in_order_total += a.seconds;
        stored_total += b.seconds;
        println!(
            "{:<25} {:>11.2} {:>10.2} {:>6.2} {:>12.1} {:>9} {:>10}",
            path.file_stem().unwrap_or_default().to_string_lossy(),
            a.seconds * 1e3,
            b.seconds * 1e3,
            a.seconds / b.seconds,
            100.0 * a.stored_pixels as f64 / (f64::from(size) * f64::from(size)),
            a.given_up_tiles,
            a.fragments,
        );
    }
    println!(
        "total: in order {:.1} ms, stored {:.1} ms, ratio {:.2}",
        in_order_total * 1e3,
        stored_total * 1e3,
        in_order_total / stored_total
    );
}
