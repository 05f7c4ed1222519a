//! The `results.json` contract, from oit-results, and what only the harness can fill in: a
//! scene's GPU size and the adapter (both need oit-gpu), the reference's caveats.

pub use oit_results::schema::*;

/// What `scene` brings to a run: its size on the GPU and where its content came from.
pub fn scene_json(scene: &oit_scene::Scene, scene_file: &str) -> SceneJson {
    let bytes = oit_gpu::SceneBytes::of(scene);
    SceneJson {
        scene: scene.name.clone(),
        scene_file: scene_file.to_owned(),
        description: scene.description.clone(),
        triangles: scene.triangle_count() as u64,
        scene_bytes: bytes.total(),
        texture_bytes: if scene.textures.is_empty() {
            0
        } else {
            bytes.textures
        },
        credits: scene.credits.clone(),
        ignored: scene.ignored.clone(),
        peak_memory_bytes: None,
    }
}

/// The adapter of `ctx`, as every file the harness writes records it.
pub fn adapter_json(ctx: &oit_gpu::Context) -> AdapterJson {
    let info = ctx.adapter_info();
    AdapterJson {
        name: info.name,
        backend: info.backend,
        device_type: info.device_type,
        driver: format!("{} {}", info.driver, info.driver_info)
            .trim()
            .to_owned(),
    }
}

/// What in a scene's reference rounding decides, one short phrase each ([`caveats`]).
pub fn reference_caveats(stats: &oit_reference::ReferenceStats) -> Vec<String> {
    caveats(stats.undecided_pixels, stats.precision_tie_pixels)
}

/// The `auto` sizes a technique reported for a frame, as results.json records them.
pub fn auto_sizes_json(sizes: oit_gpu::AutoSizes) -> AutoSizes {
    AutoSizes {
        fragments: sizes.count.fragments,
        max_per_pixel: sizes.count.max_per_pixel,
        k: sizes.k,
        pool_nodes: sizes.pool_nodes,
        sort_max: sizes.sort_max,
        sized_bytes: sizes.sized_bytes,
        count_bytes: sizes.count_bytes,
    }
}
