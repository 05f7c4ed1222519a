//! Regenerates the committed goldens: `cargo xtask goldens` runs
//! `cargo run --release -p oit-tools --bin goldens -- [OUT_DIR [SCENES_DIR]]`
//! (defaults `reference` and `scenes`, relative to the working directory) on the default
//! adapter, the one the golden test opens.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context as _, Result};
use oit_harness::goldens;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "reference".to_owned()));
    let scenes_dir = PathBuf::from(args.next().unwrap_or_else(|| "scenes".to_owned()));
    if let Some(extra) = args.next() {
        anyhow::bail!("unexpected argument {extra:?}; usage: goldens [OUT_DIR [SCENES_DIR]]");
    }
    let started = Instant::now();
    let scenes = oit_harness::load_scenes(std::slice::from_ref(&scenes_dir))
        .with_context(|| format!("loading scenes from {}", scenes_dir.display()))?;
    anyhow::ensure!(
        !scenes.is_empty(),
        "{} holds no scene files (*.json)",
        scenes_dir.display()
    );
    let ctx = oit_harness::open_context(&Default::default()).context(
        "the baseline needs a GPU adapter (on a machine without one: install mesa-vulkan-drivers)",
    )?;
    let adapter = oit_harness::results::adapter_json(&ctx);
    println!(
        "goldens: {} scenes at {}x{} on {} ({}, {})",
        scenes.len(),
        goldens::RESOLUTION.width,
        goldens::RESOLUTION.height,
        adapter.name,
        adapter.backend,
        adapter.driver
    );
    let computed = goldens::generate(&ctx, &scenes, &|what| println!("  {what}"))?;
    goldens::write(&out, &computed).with_context(|| format!("writing {}", out.display()))?;
    println!(
        "goldens: wrote {} ({:.1} s)",
        out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
