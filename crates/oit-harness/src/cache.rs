//! On-disk cache of CPU references, keyed by scene content and resolution, so a comparison
//! computes each reference once even across invocations.
//!
//! Format (little endian): magic `OITREF01`, width u32, height u32, stats JSON length u32, stats
//! JSON, then width·height RGBA f32 pixels, layer counts u32, fragment counts u32, undecided
//! counts u32, precision-tie flags u8 (0 or 1). Written
//! atomically; a file that does not parse is recomputed, never trusted.

use std::path::{Path, PathBuf};

use oit_reference::{Reference, ReferenceStats};
use oit_scene::{LinearImage, Scene};

use crate::HarnessError;

const MAGIC: &[u8; 8] = b"OITREF02";

/// The default cache directory: `$OIT_CACHE_DIR`, else `$XDG_CACHE_HOME/oit-lab/references`,
/// else `$HOME/.cache/oit-lab/references`, else `.oit-cache` in the working directory.
pub fn default_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("OIT_CACHE_DIR") {
        return PathBuf::from(d);
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(d).join("oit-lab/references");
    }
    if let Some(d) = std::env::var_os("HOME") {
        return PathBuf::from(d).join(".cache/oit-lab/references");
    }
    PathBuf::from(".oit-cache")
}

/// File name for a scene's reference: the name keeps it readable, the hash makes it exact, and
/// the reference's output version keeps references of an older build from being reused.
pub fn key_path(dir: &Path, scene: &Scene) -> PathBuf {
    dir.join(format!(
        "{}-{}-{:016x}-v{}.oitref",
        crate::file_stem(&scene.name),
        scene.resolution,
        scene.content_hash(),
        oit_reference::OUTPUT_VERSION
    ))
}

/// The cached reference, or a freshly computed one (then stored). `compute` runs only on a miss.
pub fn reference(
    dir: &Path,
    scene: &Scene,
    compute: impl FnOnce() -> Result<Reference, HarnessError>,
) -> Result<(Reference, bool), HarnessError> {
    let path = key_path(dir, scene);
    if let Ok(bytes) = std::fs::read(&path)
        && let Some(reference) = decode(&bytes, scene)
    {
        return Ok((reference, true));
    }
    let reference = compute()?;
    std::fs::create_dir_all(dir).map_err(|e| HarnessError::io(dir, e))?;
    oit_metrics::write_atomic_bytes(&path, &encode(&reference)).map_err(HarnessError::from)?;
    Ok((reference, false))
}

fn encode(r: &Reference) -> Vec<u8> {
    let stats = serde_json::to_vec(&r.stats).expect("stats serialize");
    let n = r.image.pixels.len();
    let mut out = Vec::with_capacity(24 + stats.len() + n * 24);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&r.image.width.to_le_bytes());
    out.extend_from_slice(&r.image.height.to_le_bytes());
    out.extend_from_slice(&(stats.len() as u32).to_le_bytes());
    out.extend_from_slice(&stats);
    for p in &r.image.pixels {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for v in r.layers.iter().chain(&r.fragments).chain(&r.undecided) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend(r.precision_ties.iter().map(|&t| u8::from(t)));
    out
}

fn decode(bytes: &[u8], scene: &Scene) -> Option<Reference> {
    let mut at = 0usize;
    let mut take = |n: usize| -> Option<&[u8]> {
        let s = bytes.get(at..at + n)?;
        at += n;
        Some(s)
    };
    if take(8)? != MAGIC {
        return None;
    }
    let u32_at = |s: &[u8]| u32::from_le_bytes(s.try_into().expect("4 bytes"));
    let width = u32_at(take(4)?);
    let height = u32_at(take(4)?);
    if width != scene.resolution.width || height != scene.resolution.height {
        return None;
    }
    let stats_len = u32_at(take(4)?) as usize;
    let stats: ReferenceStats = serde_json::from_slice(take(stats_len)?).ok()?;
    let n = width as usize * height as usize;
    let px = take(n * 16)?;
    let pixels = px
        .chunks_exact(16)
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes(c[i * 4..i * 4 + 4].try_into().expect("4 bytes"));
            [f(0), f(1), f(2), f(3)]
        })
        .collect();
    let layers = take(n * 4)?.chunks_exact(4).map(u32_at).collect();
    let fragments = take(n * 4)?.chunks_exact(4).map(u32_at).collect();
    let undecided = take(n * 4)?.chunks_exact(4).map(u32_at).collect();
    let precision_ties = take(n)?
        .iter()
        .map(|&b| match b {
            0 => Some(false),
            1 => Some(true),
            _ => None,
        })
        .collect::<Option<Vec<bool>>>()?;
    if at != bytes.len() {
        return None;
    }
    Some(Reference {
        image: LinearImage {
            width,
            height,
            pixels,
        },
        layers,
        fragments,
        undecided,
        precision_ties,
        stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = r#"{
        "name": "cache-test", "description": "two layers", "resolution": [16, 8],
        "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100},
        "background": [0.2, 0.3, 0.4],
        "objects": [
            {"mesh": {"kind": "quad", "size": [3, 3]}, "material": {"base_color": [1, 0, 0], "alpha": 0.5, "mode": "blend"}},
            {"mesh": {"kind": "quad", "size": [2, 2]}, "transform": {"translate": [0, 0, 0.5]},
             "material": {"base_color": [0, 1, 0], "alpha": 0.25, "mode": "blend"}}
        ]
    }"#;

    #[test]
    fn encode_decode_round_trip_is_exact_and_checks_size() {
        let scene = oit_scene::parse(SCENE, "cache-test.json").unwrap();
        let reference = oit_reference::render(&scene, &Default::default());
        let bytes = encode(&reference);
        assert_eq!(decode(&bytes, &scene), Some(reference.clone()));
        // Another resolution, a truncated file or trailing bytes are misses, never wrong data.
        let other = scene.with_resolution(oit_scene::Resolution {
            width: 8,
            height: 8,
        });
        assert_eq!(decode(&bytes, &other), None);
        assert_eq!(decode(&bytes[..bytes.len() - 1], &scene), None);
        let mut longer = bytes.clone();
        longer.push(0);
        assert_eq!(decode(&longer, &scene), None);
    }

    #[test]
    fn second_lookup_hits_and_does_not_compute() {
        let scene = oit_scene::parse(SCENE, "cache-test.json").unwrap();
        let dir = std::env::temp_dir().join(format!("oit-cache-unit-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let (first, hit) = reference(&dir, &scene, || {
            Ok(oit_reference::render(&scene, &Default::default()))
        })
        .unwrap();
        assert!(!hit);
        let (second, hit) = reference(&dir, &scene, || panic!("must not recompute")).unwrap();
        assert!(hit);
        assert_eq!(first, second);
        // A changed scene (different content hash) is a different entry.
        let moved = scene.with_reversed_draw_order();
        assert_ne!(key_path(&dir, &moved), key_path(&dir, &scene));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
