//! oit-harness: runs scene × technique, diffs every render against the exact CPU reference
//! (cached on disk), and writes `results.json`, `results.md`, EXR and PNG reports.
//!
//! The registry of techniques lives here, and only here: technique crates never know about
//! each other, the harness concatenates their `techniques()` lists.

pub mod budget;
pub mod cache;
pub mod candidates;
mod clip;
mod counts;
pub mod goldens;
pub mod inputs;
mod isolate;
pub mod listing;
pub mod merge;
pub mod motion;
mod operator_table;
mod peak;
pub mod predict;
pub mod report;
pub mod results;
mod resume;
mod run;
pub mod scene_files;
pub mod shard;
mod timing;
pub mod vary;

pub use budget::{MemoryPlan, RUN_BYTES_PER_PIXEL};
pub use listing::{MarkdownTable, techniques_help, techniques_json, techniques_markdown};
pub use merge::merge;
pub use operator_table::operators_markdown;
pub use scene_files::SkippedFile;
pub use shard::Shard;
pub use timing::time_technique;

pub use oit_results::interference;
pub use oit_results::{
    LAYERS_PNG, MAX_STEM_CHARS, RESERVED_STEMS, file_stem, fnv1a64, fnv1a64_wide,
};

use std::path::{Path, PathBuf};

use oit_gpu::{Context, ContextOptions, Family, TechniqueInfo, TechniqueSpec};
use oit_scene::{Resolution, Scene};

pub use run::{
    APPROXIMATE_TRANSMISSION, CompareOptions, DEFAULT_MEMORY_BUDGET, DEFAULT_RUN_BUDGET, Event,
    LOCK_FILE, MAX_WARMUP, ReferenceCache, RenderedFrame, color_format, compare, compare_all,
    render_once, render_once_at,
};

/// Errors of the harness. Each names the file it concerns.
#[derive(Debug, thiserror::Error)]
pub enum HarnessError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
    /// More memory than `--memory-budget` allows (the message says what needs it, in MiB).
    #[error("{0}")]
    OverMemoryBudget(String),
    /// Options that make no comparison (e.g. zero timed frames, a sweep too large).
    #[error("{0}")]
    Options(String),
    #[error(transparent)]
    Scene(#[from] oit_scene::SceneError),
    #[error(transparent)]
    Spec(#[from] oit_gpu::SpecError),
    #[error(transparent)]
    Gpu(#[from] oit_gpu::GpuError),
    #[error(transparent)]
    Metrics(#[from] oit_metrics::MetricsError),
    #[error(transparent)]
    Reference(#[from] oit_reference::ReferenceError),
    #[error(transparent)]
    Results(#[from] oit_results::ResultsError),
}

impl HarnessError {
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        HarnessError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Every technique family, in the order reports list them. `sorted` comes first: its
/// `unsorted` is the baseline every cost is divided by. A new family is one line here and one
/// dependency line in this crate's Cargo.toml (docs/adding-a-technique.md).
pub const FAMILIES: &[Family] = &[
    oit_sorted::FAMILY,
    oit_peel::FAMILY,
    oit_wboit::FAMILY,
    oit_stochastic::FAMILY,
    oit_mboit::FAMILY,
    oit_wavelet::FAMILY,
    oit_linked_list::FAMILY,
    oit_abuffer::FAMILY,
    oit_ray_query::FAMILY,
    oit_opaque_copy::FAMILY,
    oit_per_object::FAMILY,
];

/// Every technique the project implements, in the order reports list them. `unsorted` comes
/// first: it is the baseline every cost is divided by.
pub fn registry() -> Vec<TechniqueInfo> {
    FAMILIES
        .iter()
        .flat_map(|family| (family.techniques)())
        .collect()
}

/// Parses a spec against the registry.
pub fn parse_spec(text: &str) -> Result<TechniqueSpec, HarnessError> {
    Ok(TechniqueSpec::parse(text, &registry())?)
}

/// Most specs one `-t` sweep may expand to: a typo such as `a=1..1000,b=1..1000` must be an
/// error, not a billion strings.
pub const MAX_SWEEP_SPECS: u64 = 4096;

/// The specs to run: the given ones (parsed, deduplicated by canonical string, in order), or
/// every technique at its defaults when none is given. Every key and value of a sweep is
/// validated on its own before the sweep is expanded, and a sweep larger than
/// [`MAX_SWEEP_SPECS`] is refused before anything is built.
pub fn resolve_specs(texts: &[String]) -> Result<Vec<TechniqueSpec>, HarnessError> {
    let registry = registry();
    let mut specs: Vec<TechniqueSpec> = Vec::new();
    if texts.is_empty() {
        specs = registry.iter().map(TechniqueInfo::default_spec).collect();
    }
    for text in texts {
        if let Some((name, axes)) = sweep_axes(text) {
            let mut count: u64 = 1;
            for (key, values) in &axes {
                for value in values {
                    TechniqueSpec::parse(&format!("{name}:{key}={value}"), &registry)?;
                }
                count = count.saturating_mul(values.len() as u64);
            }
            if count > MAX_SWEEP_SPECS {
                return Err(HarnessError::Options(format!(
                    "`{text}` expands to {count} technique specs; at most {MAX_SWEEP_SPECS} per sweep (narrow the lists or ranges)"
                )));
            }
        }
        for one in expand_sweep(text) {
            let spec = TechniqueSpec::parse(&one, &registry)?;
            if !specs.iter().any(|s| s.canonical() == spec.canonical()) {
                specs.push(spec);
            }
        }
    }
    Ok(specs)
}

/// One swept key and its values.
type SweepAxis = (String, Vec<String>);

/// A sweep's technique name and its keys with their values (lists and ranges expanded), in
/// order; `None` for text without parameters or with a leading token that has no `=`.
fn sweep_axes(text: &str) -> Option<(&str, Vec<SweepAxis>)> {
    let (name, params) = text.split_once(':')?;
    let mut keys: Vec<SweepAxis> = Vec::new();
    for token in params.split(',') {
        match token.split_once('=') {
            Some((k, v)) => keys.push((k.to_owned(), vec![v.to_owned()])),
            None => keys.last_mut()?.1.push(token.to_owned()),
        }
    }
    for (_, values) in &mut keys {
        *values = values.iter().flat_map(|v| expand_range(v)).collect();
    }
    Some((name, keys))
}

/// Expands a sweep into single specs, in parameter order: a value list `spp=1,4,16` (a token
/// without `=` continues the previous key's list) and an integer range `passes=1..8`
/// (inclusive). Several swept keys give their cartesian product, the first key varying
/// slowest. Text without sweeps comes back unchanged; validation is left to the spec parser
/// ([`resolve_specs`] validates and bounds a sweep before expanding it).
pub fn expand_sweep(text: &str) -> Vec<String> {
    let Some((name, keys)) = sweep_axes(text) else {
        return vec![text.to_owned()];
    };
    let mut out = vec![String::new()];
    for (key, values) in &keys {
        out = out
            .iter()
            .flat_map(|prefix| {
                values.iter().map(move |v| {
                    if prefix.is_empty() {
                        format!("{key}={v}")
                    } else {
                        format!("{prefix},{key}={v}")
                    }
                })
            })
            .collect();
    }
    out.into_iter().map(|p| format!("{name}:{p}")).collect()
}

/// `a..b` with integers a ≤ b and at most 1024 values expands; anything else is kept as is.
fn expand_range(value: &str) -> Vec<String> {
    if let Some((a, b)) = value.split_once("..")
        && let (Ok(a), Ok(b)) = (a.parse::<u64>(), b.parse::<u64>())
        && a <= b
        && b - a < 1024
    {
        return (a..=b).map(|v| v.to_string()).collect();
    }
    vec![value.to_owned()]
}

/// Opens the GPU and prints nothing: callers print the adapter.
pub fn open_context(options: &ContextOptions) -> Result<Context, HarnessError> {
    Ok(Context::new(options)?)
}

/// A loaded scene, the file it came from and every file read for it.
#[derive(Debug, Clone)]
pub struct SceneEntry {
    pub path: PathBuf,
    pub scene: Scene,
    /// Every file the loader read, `path` first (glTF assets, buffers, images): outputs
    /// never land on them ([`inputs`]).
    pub inputs: Vec<PathBuf>,
    /// Every frame of an animated scene (`None` for a still one); `scene` is its frame 0.
    pub frames: Option<std::rc::Rc<oit_scene::Frames>>,
    /// The parameter `oit compare --vary` set to make this scene from a scene file (`None`
    /// for a scene as read); recorded in each of its runs ([`vary`]).
    pub varied: Option<oit_results::Varied>,
}

impl SceneEntry {
    /// An entry for a scene built in memory, as if read from `path` (and nothing else).
    pub fn new(path: impl Into<PathBuf>, scene: Scene) -> Self {
        let path = path.into();
        SceneEntry {
            inputs: vec![path.clone()],
            path,
            scene,
            frames: None,
            varied: None,
        }
    }

    /// Loads one scene file.
    pub fn load(path: &Path, options: &oit_scene::LoadOptions) -> Result<Self, HarnessError> {
        let (frames, inputs) = oit_scene::load_frames(path, options)?;
        let scene = frames.frame(0)?;
        let frames = frames.animation().map(|_| std::rc::Rc::new(frames));
        Ok(SceneEntry {
            path: path.to_path_buf(),
            scene,
            inputs,
            frames,
            varied: None,
        })
    }
}

/// A scene file of a comparison that could not be loaded: its runs are reported as failed
/// with `error`, and the other scenes still run.
#[derive(Debug, Clone)]
pub struct Unloadable {
    pub path: PathBuf,
    pub error: String,
}

/// Loads scene files and directories of scene files (`*.json`, `*.gltf`, `*.glb`, sorted by
/// name within a directory), in the order given.
pub fn load_scenes(paths: &[PathBuf]) -> Result<Vec<SceneEntry>, HarnessError> {
    load_scenes_with(paths, &oit_scene::LoadOptions::default())
}

/// [`load_scenes`] with `options` (e.g. which glTF camera) applied to every glTF file. Stops
/// at the first scene that does not load.
pub fn load_scenes_with(
    paths: &[PathBuf],
    options: &oit_scene::LoadOptions,
) -> Result<Vec<SceneEntry>, HarnessError> {
    Ok(load_scenes_noting(paths, options)?.0)
}

/// [`load_scenes_with`], and the JSON files of the folders given that are not scenes
/// ([`scene_files::not_a_scene`]): skipped, for the caller to note. A file named on its own
/// is always loaded as a scene.
pub fn load_scenes_noting(
    paths: &[PathBuf],
    options: &oit_scene::LoadOptions,
) -> Result<(Vec<SceneEntry>, Vec<SkippedFile>), HarnessError> {
    let mut out = Vec::new();
    let mut skipped = Vec::new();
    for path in paths {
        if path.is_dir() {
            let (files, not_scenes) = scene_files::scene_files(path)?;
            skipped.extend(not_scenes);
            for file in files {
                out.push(SceneEntry::load(&file, options)?);
            }
        } else {
            out.push(SceneEntry::load(path, options)?);
        }
    }
    Ok((out, skipped))
}

/// What [`load_scenes_lenient`] found: the scenes that loaded, the scene files that did not,
/// and the JSON files of the folders that are not scenes.
pub type LenientScenes = (Vec<SceneEntry>, Vec<Unloadable>, Vec<SkippedFile>);

/// Like [`load_scenes_noting`], but a scene file that fails to load is returned as
/// [`Unloadable`] instead of ending the load: one bad scene never ends a comparison. A path
/// that does not exist, or a folder that cannot be listed, is still an error (a typo on the
/// command line, not a bad scene). Returns the loaded scenes, the unloadable ones and the
/// JSON files of the folders that are not scenes.
pub fn load_scenes_lenient(
    paths: &[PathBuf],
    options: &oit_scene::LoadOptions,
) -> Result<LenientScenes, HarnessError> {
    let mut files = Vec::new();
    let mut skipped = Vec::new();
    for path in paths {
        if path.is_dir() {
            let (scenes, not_scenes) = scene_files::scene_files(path)?;
            files.extend(scenes);
            skipped.extend(not_scenes);
        } else if path.exists() {
            files.push(path.clone());
        } else {
            // Loading names the file and the OS error.
            SceneEntry::load(path, options)?;
        }
    }
    let mut entries = Vec::new();
    let mut unloadable = Vec::new();
    for file in files {
        match SceneEntry::load(&file, options) {
            Ok(entry) => entries.push(entry),
            Err(e) => unloadable.push(Unloadable {
                error: e.to_string(),
                path: file,
            }),
        }
    }
    Ok((entries, unloadable, skipped))
}

/// Applies an optional resolution override.
pub fn at_resolution(scene: &Scene, resolution: Option<Resolution>) -> Scene {
    match resolution {
        Some(r) if r != scene.resolution => scene.with_resolution(r),
        _ => scene.clone(),
    }
}

/// Writes a reference as a linear EXR: layer `reference` (RGBA) plus single channels `layers`
/// (transparent fragments composited per pixel) and `fragments` (all rasterized fragments).
pub fn write_reference_exr(
    path: &Path,
    reference: &oit_reference::Reference,
) -> Result<(), HarnessError> {
    let to_f32 = |v: &[u32]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    let layers = to_f32(&reference.layers);
    let fragments = to_f32(&reference.fragments);
    oit_metrics::write_exr(
        path,
        &[oit_metrics::ExrLayer::new("reference", &reference.image)
            .with_channel("layers", &layers)
            .with_channel("fragments", &fragments)],
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_specs_cover_the_registry_with_unsorted_first() {
        let specs = resolve_specs(&[]).unwrap();
        assert_eq!(specs.len(), registry().len());
        assert_eq!(specs[0].canonical(), "unsorted");
    }

    #[test]
    fn sweeps_expand_lists_ranges_and_products_in_parameter_order() {
        assert_eq!(expand_sweep("unsorted"), ["unsorted"]);
        assert_eq!(
            expand_sweep("stochastic:spp=1,4,16,64"),
            [
                "stochastic:spp=1",
                "stochastic:spp=4",
                "stochastic:spp=16",
                "stochastic:spp=64"
            ]
        );
        assert_eq!(
            expand_sweep("dual-peel:passes=1..3,tail=drop"),
            [
                "dual-peel:passes=1,tail=drop",
                "dual-peel:passes=2,tail=drop",
                "dual-peel:passes=3,tail=drop"
            ]
        );
        assert_eq!(
            expand_sweep("x:a=1..2,b=p,q"),
            ["x:a=1,b=p", "x:a=1,b=q", "x:a=2,b=p", "x:a=2,b=q"]
        );
        // Not a range: left for the spec parser to judge.
        assert_eq!(expand_sweep("x:a=3..1"), ["x:a=3..1"]);
    }

    /// A huge sweep is refused before it is expanded, and a bad key or value is named before
    /// anything is multiplied out (this once grew to 9.2 GB before any validation).
    #[test]
    fn sweeps_are_validated_and_bounded_before_they_expand() {
        let start = std::time::Instant::now();
        let err = resolve_specs(&["linked-list:nodes-per-pixel=1..1024,sort-max=1..128".into()])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("131072") && err.contains("at most 4096"),
            "{err}"
        );
        let err = resolve_specs(&["unsorted:a=1..1000,b=1..1000,c=1..1000".into()])
            .unwrap_err()
            .to_string();
        assert!(err.contains('a') && err.contains("unsorted"), "{err}");
        assert!(start.elapsed().as_secs() < 5, "{:?}", start.elapsed());
        let ok = resolve_specs(&["stochastic:spp=1..64".into()]).unwrap();
        assert_eq!(ok.len(), 64);
    }

    #[test]
    fn a_sweep_resolves_to_one_canonical_spec_per_value() {
        let specs = resolve_specs(&[
            "dual-peel:passes=1..8".into(),
            "stochastic:spp=1,4,16,64".into(),
        ])
        .unwrap();
        assert_eq!(specs.len(), 12);
        assert_eq!(
            specs[0].canonical(),
            "dual-peel:accum=auto,depth=auto,encoding=window,passes=1,reverse-z=on,tail=drop"
        );
        assert_eq!(
            specs[11].canonical(),
            "stochastic:pattern=blue,seed=object,spp=64"
        );
    }

    #[test]
    fn duplicate_specs_collapse_by_canonical_string() {
        let specs = resolve_specs(&["unsorted".into(), "unsorted".into()]).unwrap();
        assert_eq!(specs.len(), 1);
    }

    #[test]
    fn unknown_technique_is_an_error_listing_valid_names() {
        let err = resolve_specs(&["no-such-technique".into()])
            .unwrap_err()
            .to_string();
        assert!(err.contains("no-such-technique"), "{err}");
        assert!(err.contains("unsorted"), "{err}");
    }
}
