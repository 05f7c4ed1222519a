//! What a person watches, as one picture: a few frames of a technique's path, one row each,
//! render | reference | error heat map side by side (`SCENE/TECHNIQUE-motion.png`).

use std::path::{Path, PathBuf};

use oit_metrics::Srgb8Image;
use oit_scene::LinearImage;

use crate::{HarnessError, file_stem};

/// The strip's file name for a technique.
pub fn file_name(canonical: &str) -> String {
    format!("{}-motion.png", file_stem(canonical))
}

/// Writes the strip of `frames` (`(frame, render, reference)`, all the same size) into
/// `scene_dir`, atomically, and returns its path.
pub fn write(
    scene_dir: &Path,
    canonical: &str,
    frames: &[(u32, LinearImage, LinearImage)],
) -> Result<PathBuf, HarnessError> {
    let Some((_, first, _)) = frames.first() else {
        return Err(HarnessError::Options("a motion strip needs a frame".into()));
    };
    let (w, h) = (first.width as usize, first.height as usize);
    let mut strip = Srgb8Image {
        width: 3 * w as u32,
        height: (h * frames.len()) as u32,
        pixels: vec![[0; 3]; 3 * w * h * frames.len()],
    };
    for (row, (_, render, reference)) in frames.iter().enumerate() {
        let panels = [
            oit_metrics::preview_srgb8(render)?,
            oit_metrics::preview_srgb8(reference)?,
            oit_metrics::heatmap(render, reference)?,
        ];
        for (col, panel) in panels.iter().enumerate() {
            for y in 0..h {
                let dst = (row * h + y) * 3 * w + col * w;
                strip.pixels[dst..dst + w].copy_from_slice(&panel.pixels[y * w..(y + 1) * w]);
            }
        }
    }
    let path = scene_dir.join(file_name(canonical));
    oit_metrics::write_png_srgb8(&path, &strip)?;
    Ok(path)
}
