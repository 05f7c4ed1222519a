//! `oit scenes`: every scene of a file or folder with its size, triangles and depth
//! complexity (from its reference), what it tests, and where real content came from.

use std::path::Path;

use anyhow::{Context, Result};

use crate::load_some_scenes;

/// What `oit scenes --json` prints for one scene.
#[derive(Debug, serde::Serialize)]
struct SceneListing {
    scene: String,
    file: String,
    description: String,
    resolution: [u32; 2],
    triangles: u64,
    transparent_triangles: u64,
    draws: u64,
    max_depth_complexity: u32,
    mean_depth_complexity: f64,
    credits: Vec<String>,
    not_modelled: Vec<String>,
}

pub(crate) fn scenes(path: &Path, json: bool, load: &oit_scene::LoadOptions) -> Result<()> {
    let entries = load_some_scenes(&[path.to_path_buf()], load)?;
    let mut listings = Vec::new();
    for entry in &entries {
        let s = &entry.scene;
        let reference = oit_reference::try_render(s, &oit_reference::ReferenceOptions::default())
            .with_context(|| format!("reference of {}", entry.path.display()))?;
        listings.push(SceneListing {
            scene: s.name.clone(),
            file: entry.path.display().to_string(),
            description: s.description.clone(),
            resolution: [s.resolution.width, s.resolution.height],
            triangles: s.triangle_count() as u64,
            transparent_triangles: s.transparent_triangle_count() as u64,
            draws: s.draws.len() as u64,
            max_depth_complexity: reference.stats.max_depth_complexity,
            mean_depth_complexity: reference.stats.mean_depth_complexity,
            credits: s.credits.clone(),
            not_modelled: s.ignored.clone(),
        });
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&listings)?);
        return Ok(());
    }
    println!(
        "{:<26} {:>9} {:>9} {:>9} {:>6} {:>9} {:>10}",
        "scene", "size", "triangles", "transp.", "draws", "max depth", "mean depth"
    );
    for (entry, l) in entries.iter().zip(&listings) {
        let s = &entry.scene;
        println!(
            "{:<26} {:>9} {:>9} {:>9} {:>6} {:>9} {:>10.2}",
            oit_harness::report::printable(&l.scene),
            s.resolution.to_string(),
            l.triangles,
            l.transparent_triangles,
            l.draws,
            l.max_depth_complexity,
            l.mean_depth_complexity,
        );
        // What the scene tests, wrapped to the table's width.
        for line in oit_harness::report::wrap(&oit_harness::report::printable(&l.description), 86) {
            println!("    {line}");
        }
        if let Some(a) = s.animation {
            println!(
                "    animated: {} frames at {} fps (the figures above are frame 0's)",
                a.frames, a.fps
            );
        }
        // Real content says where it came from and what of it is not modelled.
        if !(s.textures.is_empty() && s.credits.is_empty() && s.ignored.is_empty()) {
            for line in oit_harness::results::scene_json(s, "").report_lines() {
                println!("    {}", oit_harness::report::printable(&line));
            }
        }
    }
    Ok(())
}
