//! Peak memory and time of the reference under a memory budget, the numbers in the README's
//! "Memory" section. Run it under `/usr/bin/time -v` for the peak resident set:
//!
//! ```text
//! cargo build --release -p oit-tools --bin budget
//! /usr/bin/time -v target/release/budget layers [COUNT] [SIZE] [--memory-budget BYTES]
//! /usr/bin/time -v target/release/budget particles [SIZE] [--memory-budget BYTES]
//! ```
//!
//! `layers` builds COUNT (default 2 000 000) screen-filling blended quads, two triangles each,
//! at SIZE² (default 32²) in code: at the default count, the loader's 4 M triangle cap and
//! 2 M fragments in every pixel. `particles` loads the bundled scene at SIZE² (default 2048²).

use std::time::Instant;

use glam::Vec3;
use oit_reference::{ReferenceOptions, try_render};
use oit_scene::{AlphaMode, Camera, Draw, Material, Projection, Resolution, Scene, Vertex};

/// `count` full-screen quads (exactly the view volume, so none is clipped) at distinct depths
/// in one draw, colours varying per quad.
fn layers(count: u32, size: u32) -> Scene {
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
    let mut vertices = Vec::with_capacity(6 * count as usize);
    for i in 0..count {
        let t = i as f32 / count as f32;
        let z = 9.0 - 98.0 * t;
        let color = [t, 1.0 - t, 0.5, 0.01 + 0.2 * ((i * 7) % 11) as f32 / 10.0];
        for [x, y] in [
            [-1.0, -1.0],
            [1.0, -1.0],
            [1.0, 1.0],
            [-1.0, -1.0],
            [1.0, 1.0],
            [-1.0, 1.0],
        ] {
            vertices.push(Vertex {
                position: [x, y, z],
                color,
                uv: [0.0; 2],
                normal: [0.0; 3],
            });
        }
    }
    Scene {
        name: format!("layers-{count}"),
        description: "screen-filling blended layers".into(),
        resolution: Resolution {
            width: size,
            height: size,
        },
        camera,
        background: [0.0; 3],
        materials: vec![Material::plain([1.0; 3], 1.0, AlphaMode::Blend)],
        draws: vec![Draw {
            id: 0,
            name: "layers".into(),
            material: 0,
            first_vertex: 0,
            vertex_count: 6 * count,
            ordering: Default::default(),
            bounds_center: Vec3::ZERO,
            bounds_radius: 100.0,
        }],
        vertices,
        textures: Vec::new(),
        ignored: Vec::new(),
        credits: Vec::new(),
        frame: 0,
        animation: None,
        lights: oit_scene::LightRig::none(),
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut options = ReferenceOptions::default();
    if let Some(i) = args.iter().position(|a| a == "--memory-budget") {
        options.memory_budget = args.get(i + 1).ok_or("--memory-budget BYTES")?.parse()?;
        args.drain(i..i + 2);
    }
    let number = |i: usize, default: u32| -> Result<u32, Box<dyn std::error::Error>> {
        Ok(args
            .get(i)
            .map(|a| a.parse())
            .transpose()?
            .unwrap_or(default))
    };
    let start = Instant::now();
    let scene = match args.first().map(String::as_str) {
        Some("layers") => layers(number(1, 2_000_000)?, number(2, 32)?),
        Some("particles") => {
            let size = number(1, 2048)?;
            let path =
                std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/particles.json");
            oit_scene::load(&path)?.with_resolution(Resolution {
                width: size,
                height: size,
            })
        }
        _ => return Err("usage: budget layers [COUNT] [SIZE] | particles [SIZE]".into()),
    };
    let built = start.elapsed().as_secs_f64();
    println!(
        "{} at {}x{}: {} triangles, built in {built:.2} s; budget {} bytes, {} threads",
        scene.name,
        scene.resolution.width,
        scene.resolution.height,
        scene.triangle_count(),
        options.memory_budget,
        rayon::current_num_threads()
    );
    let render_start = Instant::now();
    match try_render(&scene, &options) {
        Ok(r) => {
            let s = &r.stats;
            println!(
                "rendered in {:.2} s (setup {:.2} s, binning {:.2} s; thread time raster {:.2} s, \
                 sort {:.2} s, composite {:.2} s): {} fragments, max depth {}, peak tile {} bytes, \
                 {} of {} tiles sliced, {} in order ({} in bands)",
                s.seconds,
                s.setup_seconds,
                s.binning_seconds,
                s.raster_seconds,
                s.sort_seconds,
                s.composite_seconds,
                s.fragments,
                s.max_depth_complexity,
                s.peak_tile_bytes,
                s.sliced_tiles,
                s.tiles,
                s.in_order_tiles,
                s.banded_tiles,
            );
        }
        Err(e) => println!(
            "error after {:.2} s: {e}",
            render_start.elapsed().as_secs_f64()
        ),
    }
    Ok(())
}
