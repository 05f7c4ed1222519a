//! oit-results: the `results.json` contract (schema `oit-lab/results/v1`,
//! docs/results-schema.md) and its human-readable forms — `results.md` and the terminal table —
//! without wgpu, so that reports and tools read results without linking a GPU stack.
//!
//! - [`schema`]: the types of results.json ([`Results`], [`Run`], …), read with
//!   [`Results::read`], which checks the schema first.
//! - [`report`]: results.md, the terminal table and the phrases both use.
//! - [`counts`]: a run's work in units every GPU shares; [`cost_model`]: time fitted to it.
//! - [`interference`]: how much of the machine's CPU time went elsewhere while frames were timed.
//! - [`file_stem`]: how scene names and specs become file names in an output folder.

pub mod cost_model;
pub mod counts;
pub mod interference;
pub mod report;
pub mod schema;

use std::path::PathBuf;

pub use counts::{PassCounts, RunCounts};
pub use schema::*;

/// Errors reading a results file. Each names the file.
#[derive(Debug, thiserror::Error)]
pub enum ResultsError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
}

/// The per-pixel layer count of a scene's reference as a picture, beside `reference.png`.
pub const LAYERS_PNG: &str = "layers.png";

/// A file-name-safe stem for a scene name or canonical technique string:
/// `dual-peel:passes=5,tail=wboit` → `dual-peel_passes-5_tail-wboit`.
///
/// A scene's name is data, not a path: the stem has no separators, never starts with `.` (so
/// never `.` or `..`), is never empty, never one of the names `compare` writes itself
/// ([`RESERVED_STEMS`]) or a Windows device name, and has at most [`MAX_STEM_CHARS`] characters
/// (longer text keeps its start and gains a hash of the whole, so distinct texts stay distinct).
pub fn file_stem(text: &str) -> String {
    let mut stem: String = text
        .chars()
        .map(|c| match c {
            ':' | ',' => '_',
            '=' => '-',
            c if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' => c,
            _ => '_',
        })
        .collect();
    if stem.starts_with('.') {
        stem.replace_range(..1, "_");
    }
    if stem.is_empty() {
        stem.push_str("unnamed");
    }
    let lower = stem.to_ascii_lowercase();
    let device = lower.split('.').next().unwrap_or_default();
    let windows_device = matches!(device, "con" | "prn" | "aux" | "nul")
        || ((device.starts_with("com") || device.starts_with("lpt"))
            && device.len() == 4
            && device.as_bytes()[3].is_ascii_digit());
    if RESERVED_STEMS.contains(&lower.as_str()) || windows_device {
        stem.push('_');
    }
    if stem.chars().count() > MAX_STEM_CHARS {
        let keep: String = stem.chars().take(MAX_STEM_CHARS - 17).collect();
        stem = format!("{keep}-{:016x}", fnv1a64(text.as_bytes()));
    }
    stem
}

/// Names `compare` writes in its output folder: no scene or technique stem may take them.
pub const RESERVED_STEMS: &[&str] = &[
    "results.json",
    "results.md",
    "report.html",
    "plots",
    "cache",
    "reference.exr",
    "reference.png",
    "lock",
];

/// Longest stem [`file_stem`] returns (file systems allow 255 bytes; suffixes need room).
pub const MAX_STEM_CHARS: usize = 120;

/// FNV-1a, 64 bit: a stable hash for names and checksums (the same on every platform and build).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// FNV-1a over 8-byte words (a byte-wise tail): the same stable hash idea as [`fnv1a64`] at
/// a word a step, for hashing executables of tens of megabytes.
pub fn fnv1a64_wide(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut words = bytes.chunks_exact(8);
    for w in &mut words {
        h = (h ^ u64::from_le_bytes(w.try_into().expect("8 bytes")))
            .wrapping_mul(0x0000_0100_0000_01b3);
    }
    for &b in words.remainder() {
        h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_stems_are_safe_and_readable() {
        assert_eq!(
            file_stem("dual-peel:passes=5,tail=wboit"),
            "dual-peel_passes-5_tail-wboit"
        );
        assert_eq!(file_stem("a/b c"), "a_b_c");
    }

    /// Names that are paths, hidden files, empty, reserved or device names never become one.
    #[test]
    fn scene_names_never_become_paths_or_reserved_names() {
        for (name, stem) in [
            ("/tmp/x", "_tmp_x"),
            ("..", "_."),
            (".", "_"),
            ("../../etc/passwd", "_._.._etc_passwd"),
            (".hidden", "_hidden"),
            ("", "unnamed"),
            ("results.json", "results.json_"),
            ("PLOTS", "PLOTS_"),
            ("nul", "nul_"),
            ("com1.txt", "com1.txt_"),
            ("c:\\windows", "c__windows"),
        ] {
            assert_eq!(file_stem(name), stem, "{name:?}");
        }
        for name in ["a", "x/../..", "..", "/", "\u{0}", "résumé", "\n"] {
            let stem = file_stem(name);
            assert!(
                !stem.contains(['/', '\\', '\0']) && !stem.starts_with('.') && !stem.is_empty(),
                "{name:?} → {stem:?}"
            );
        }
        let long_a = "a".repeat(300);
        let long_b = format!("{}b", "a".repeat(299));
        assert_eq!(file_stem(&long_a).chars().count(), MAX_STEM_CHARS);
        assert_ne!(file_stem(&long_a), file_stem(&long_b));
    }
}
