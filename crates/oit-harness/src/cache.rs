//! On-disk cache of CPU references, keyed by scene content and resolution, so a comparison
//! computes each reference once even across invocations.
//!
//! Format (little endian): magic `OITREF03`, the inputs' hash u64 ([`inputs_hash`]: scene content,
//! resolution, reference output version), width u32, height u32, stats JSON length u32, stats
//! JSON, then width·height RGBA f32 pixels, layer counts u32, fragment counts u32, undecided
//! counts u32, precision-tie flags u8 (0 or 1), and last a checksum u64 (FNV-1a of every byte
//! before it). Written atomically. A file whose checksum, inputs or layout do not match is never
//! trusted: it is recomputed with a one-line warning ([`CacheOutcome::Recomputed`]).
//!
//! The folder is capped ([`DEFAULT_CAP`], `oit compare --cache-cap`): after a reference is
//! stored, the least recently used `*.oitref` files are removed until the folder's references
//! fit, and a reference larger than the cap is not stored (the comparison says so). A hit
//! marks its file as recently used.

use std::path::{Path, PathBuf};

use oit_reference::{Reference, ReferenceStats};
use oit_scene::{LinearImage, Scene};

use crate::HarnessError;

const MAGIC: &[u8; 8] = b"OITREF03";

/// The cache folder's default cap: 1 GiB of reference files (a 1024² reference takes 29 MiB,
/// an 8192² one 1.9 GB and is not cached unless the cap is raised).
pub const DEFAULT_CAP: u64 = 1 << 30;

/// File extension of cached references; only these are counted and evicted.
const EXTENSION: &str = "oitref";

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

/// Where a reference came from. The last two deserve a warning where people look.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum CacheOutcome {
    /// Read from the cache, checksum and inputs verified.
    Hit,
    /// Not in the cache: computed and stored.
    Computed,
    /// A cached file was there but could not be trusted (`why`): computed again and replaced.
    Recomputed { why: String },
    /// Computed, but the cache could not store it (`why`, e.g. an unwritable folder): the
    /// comparison goes on without the cache.
    NotStored { why: String },
    /// Computed, and larger than the cache's cap (`bytes` against `cap`): not stored.
    TooLarge { bytes: u64, cap: u64 },
}

impl CacheOutcome {
    /// The one-line warning this outcome deserves, if any.
    pub fn warning(&self, scene: &str) -> Option<String> {
        match self {
            CacheOutcome::Hit | CacheOutcome::Computed => None,
            CacheOutcome::Recomputed { why } => Some(format!(
                "cached reference of {scene} not trusted ({why}): recomputed"
            )),
            CacheOutcome::NotStored { why } => Some(format!(
                "reference of {scene} not cached ({why}): continuing without the cache"
            )),
            CacheOutcome::TooLarge { bytes, cap } => Some(format!(
                "reference of {scene} not cached: {} MiB is more than the cache's cap of {} MiB (--cache-cap)",
                bytes.div_ceil(1 << 20),
                cap >> 20
            )),
        }
    }
}

/// The hash a cached file must carry: the scene's content, its resolution and the reference's
/// output version (the file name has them too, but a renamed or copied file must not pass).
pub fn inputs_hash(scene: &Scene) -> u64 {
    let mut bytes = Vec::with_capacity(20);
    bytes.extend_from_slice(&scene.content_hash().to_le_bytes());
    bytes.extend_from_slice(&scene.resolution.width.to_le_bytes());
    bytes.extend_from_slice(&scene.resolution.height.to_le_bytes());
    bytes.extend_from_slice(&oit_reference::OUTPUT_VERSION.to_le_bytes());
    crate::fnv1a64(&bytes)
}

/// The cached reference, or a freshly computed one (then stored, within `cap` bytes for the
/// whole folder). `compute` runs only when no trustworthy file exists. A cache that cannot be
/// written never fails the comparison.
pub fn reference(
    dir: &Path,
    scene: &Scene,
    cap: u64,
    compute: impl FnOnce() -> Result<Reference, HarnessError>,
) -> Result<(Reference, CacheOutcome), HarnessError> {
    let path = key_path(dir, scene);
    let distrust = match std::fs::read(&path) {
        Ok(bytes) => match decode(&bytes, scene) {
            Ok(reference) => {
                touch(&path);
                return Ok((reference, CacheOutcome::Hit));
            }
            Err(why) => Some(why),
        },
        Err(_) => None,
    };
    let reference = compute()?;
    let bytes = encode(&reference, scene);
    if bytes.len() as u64 > cap {
        // An untrusted file of this key would be found again: remove it.
        let _ = std::fs::remove_file(&path);
        let outcome = CacheOutcome::TooLarge {
            bytes: bytes.len() as u64,
            cap,
        };
        return Ok((reference, outcome));
    }
    let stored = std::fs::create_dir_all(dir)
        .map_err(|e| format!("cannot create {}: {e}", dir.display()))
        .and_then(|()| {
            oit_metrics::remove_stale_temporaries(dir);
            oit_metrics::write_atomic_bytes(&path, &bytes).map_err(|e| e.to_string())
        });
    if stored.is_ok() {
        evict(dir, cap, &path);
    }
    let outcome = match (stored, distrust) {
        (Err(why), _) => CacheOutcome::NotStored { why },
        (Ok(()), Some(why)) => CacheOutcome::Recomputed { why },
        (Ok(()), None) => CacheOutcome::Computed,
    };
    Ok((reference, outcome))
}

/// Marks a cached file as just used (its modification time), so eviction keeps it longest.
fn touch(path: &Path) {
    if let Ok(file) = std::fs::OpenOptions::new().append(true).open(path) {
        let _ = file.set_modified(std::time::SystemTime::now());
    }
}

/// Removes the least recently used references of `dir` until the rest fit in `cap` bytes;
/// `keep` (the one just stored) is never removed. Returns how many were removed.
pub fn evict(dir: &Path, cap: u64, keep: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut files: Vec<(std::time::SystemTime, u64, PathBuf)> = entries
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == EXTENSION))
        .filter_map(|e| {
            let meta = e.metadata().ok().filter(std::fs::Metadata::is_file)?;
            Some((meta.modified().ok()?, meta.len(), e.path()))
        })
        .collect();
    let mut total: u64 = files.iter().map(|f| f.1).sum();
    files.sort_by_key(|f| f.0);
    let mut removed = 0;
    for (_, len, path) in files {
        if total <= cap {
            break;
        }
        if path == keep {
            continue;
        }
        if std::fs::remove_file(&path).is_ok() {
            total -= len;
            removed += 1;
        }
    }
    removed
}

fn encode(r: &Reference, scene: &Scene) -> Vec<u8> {
    let stats = serde_json::to_vec(&r.stats).expect("stats serialize");
    let n = r.image.pixels.len();
    let mut out = Vec::with_capacity(40 + stats.len() + n * 29);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&inputs_hash(scene).to_le_bytes());
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
    let checksum = crate::fnv1a64(&out);
    out.extend_from_slice(&checksum.to_le_bytes());
    out
}

/// The reference in `bytes`, or why it cannot be trusted.
fn decode(bytes: &[u8], scene: &Scene) -> Result<Reference, String> {
    if bytes.len() < 16 || &bytes[..8] != MAGIC {
        return Err("not a reference file of this format".into());
    }
    let (body, sum) = bytes.split_at(bytes.len() - 8);
    let stored = u64::from_le_bytes(sum.try_into().expect("8 bytes"));
    if crate::fnv1a64(body) != stored {
        return Err("checksum mismatch: the file was altered or cut".into());
    }
    if u64::from_le_bytes(body[8..16].try_into().expect("8 bytes")) != inputs_hash(scene) {
        return Err("made from other inputs".into());
    }
    decode_body(&body[16..], scene).ok_or_else(|| "malformed contents".into())
}

fn decode_body(bytes: &[u8], scene: &Scene) -> Option<Reference> {
    let mut at = 0usize;
    let mut take = |n: usize| -> Option<&[u8]> {
        let s = bytes.get(at..at + n)?;
        at += n;
        Some(s)
    };
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
        let bytes = encode(&reference, &scene);
        assert_eq!(decode(&bytes, &scene), Ok(reference.clone()));
        // Another resolution, a truncated file or trailing bytes are misses, never wrong data.
        let other = scene.with_resolution(oit_scene::Resolution {
            width: 8,
            height: 8,
        });
        assert!(decode(&bytes, &other).is_err());
        assert!(decode(&bytes[..bytes.len() - 1], &scene).is_err());
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer, &scene).is_err());
    }

    #[test]
    fn second_lookup_hits_and_does_not_compute() {
        let scene = oit_scene::parse(SCENE, "cache-test.json").unwrap();
        let dir = std::env::temp_dir().join(format!("oit-cache-unit-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let (first, outcome) = reference(&dir, &scene, DEFAULT_CAP, || {
            Ok(oit_reference::render(&scene, &Default::default()))
        })
        .unwrap();
        assert_eq!(outcome, CacheOutcome::Computed);
        let (second, outcome) =
            reference(&dir, &scene, DEFAULT_CAP, || panic!("must not recompute")).unwrap();
        assert_eq!(outcome, CacheOutcome::Hit);
        assert_eq!(first, second);
        // A changed scene (different content hash) is a different entry.
        let moved = scene.with_reversed_draw_order();
        assert_ne!(key_path(&dir, &moved), key_path(&dir, &scene));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A cached file whose pixels were altered (same length) is never used: it is recomputed,
    /// with the reason, and replaced by a good one.
    #[test]
    fn an_altered_file_is_recomputed_with_a_warning() {
        let scene = oit_scene::parse(SCENE, "cache-test.json").unwrap();
        let dir = std::env::temp_dir().join(format!("oit-cache-altered-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let good = oit_reference::render(&scene, &Default::default());
        reference(&dir, &scene, DEFAULT_CAP, || Ok(good.clone())).unwrap();
        let path = key_path(&dir, &scene);
        let mut bytes = std::fs::read(&path).unwrap();
        let pixel = bytes.len() - 8 - 16 * 8 * 13 - 100;
        bytes[pixel] ^= 0x40;
        std::fs::write(&path, &bytes).unwrap();
        let (r, outcome) = reference(&dir, &scene, DEFAULT_CAP, || Ok(good.clone())).unwrap();
        assert_eq!(r, good);
        let CacheOutcome::Recomputed { why } = &outcome else {
            panic!("altered file trusted: {outcome:?}");
        };
        assert!(why.contains("checksum"), "{why}");
        assert!(
            outcome
                .warning("cache-test")
                .unwrap()
                .contains("cache-test")
        );
        let (_, outcome) = reference(&dir, &scene, DEFAULT_CAP, || {
            panic!("replaced file is good")
        })
        .unwrap();
        assert_eq!(outcome, CacheOutcome::Hit);
        // Another scene's file under this scene's name fails the inputs check.
        let other = scene.with_reversed_draw_order();
        let r_other = oit_reference::render(&other, &Default::default());
        std::fs::write(&path, encode(&r_other, &other)).unwrap();
        let (_, outcome) = reference(&dir, &scene, DEFAULT_CAP, || Ok(good.clone())).unwrap();
        assert!(
            matches!(&outcome, CacheOutcome::Recomputed { why } if why.contains("other inputs")),
            "{outcome:?}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A cache folder that cannot be created leaves the reference usable and says why.
    #[test]
    fn an_unwritable_cache_never_fails_the_comparison() {
        let scene = oit_scene::parse(SCENE, "cache-test.json").unwrap();
        let file = std::env::temp_dir().join(format!("oit-cache-blocked-{}", std::process::id()));
        std::fs::write(&file, b"a file where the folder should be").unwrap();
        let good = oit_reference::render(&scene, &Default::default());
        let (r, outcome) =
            reference(&file.join("sub"), &scene, DEFAULT_CAP, || Ok(good.clone())).unwrap();
        assert_eq!(r, good);
        assert!(
            matches!(&outcome, CacheOutcome::NotStored { .. }),
            "{outcome:?}"
        );
        assert!(
            outcome
                .warning("cache-test")
                .unwrap()
                .contains("without the cache")
        );
        let _ = std::fs::remove_file(&file);
    }

    /// The folder never holds more than its cap: the least recently used references go first
    /// (a hit counts as a use), the one just stored stays, and a reference larger than the
    /// cap is not stored at all, with a warning that says so.
    #[test]
    fn the_cache_stays_within_its_cap_least_recently_used_first() {
        let dir = std::env::temp_dir().join(format!("oit-cache-cap-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let base = oit_scene::parse(SCENE, "cache-test.json").unwrap();
        let sized = |w: u32| {
            base.with_resolution(oit_scene::Resolution {
                width: w,
                height: 8,
            })
        };
        let (a, b, c) = (sized(16), sized(17), sized(18));
        let size =
            |s: &Scene| encode(&oit_reference::render(s, &Default::default()), s).len() as u64;
        // Room for two of the three, not all three. (A file's size moves by a few bytes between
        // renders: its statistics hold the render's timings.)
        let cap = size(&a) + size(&b) + size(&c) - 256;
        let render = |s: &Scene| Ok(oit_reference::render(s, &Default::default()));
        let at =
            |secs: u64| std::time::SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(secs);
        let age = |s: &Scene, secs: u64| {
            let f = std::fs::OpenOptions::new()
                .append(true)
                .open(key_path(&dir, s))
                .unwrap();
            f.set_modified(at(secs)).unwrap();
        };
        reference(&dir, &a, cap, || render(&a)).unwrap();
        age(&a, 1000);
        reference(&dir, &b, cap, || render(&b)).unwrap();
        age(&b, 2000);
        // A hit on `a` makes `b` the least recently used.
        let (_, outcome) = reference(&dir, &a, cap, || panic!("cached")).unwrap();
        assert_eq!(outcome, CacheOutcome::Hit);
        reference(&dir, &c, cap, || render(&c)).unwrap();
        assert!(key_path(&dir, &a).is_file() && key_path(&dir, &c).is_file());
        assert!(!key_path(&dir, &b).exists(), "the least recently used goes");
        let held: u64 = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().metadata().unwrap().len())
            .sum();
        assert!(held <= cap, "{held} > {cap}");
        // Larger than the whole cap: computed, not stored, said.
        let small = size(&a) - 1;
        let (_, outcome) = reference(&dir, &b, small, || render(&b)).unwrap();
        assert!(
            matches!(outcome, CacheOutcome::TooLarge { .. }),
            "{outcome:?}"
        );
        assert!(outcome.warning("b").unwrap().contains("--cache-cap"));
        assert!(!key_path(&dir, &b).exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
