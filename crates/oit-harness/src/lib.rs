//! oit-harness: runs scene × technique, diffs every render against the exact CPU reference
//! (cached on disk), and writes `results.json`, `results.md`, EXR and PNG reports.
//!
//! The registry of techniques lives here, and only here: technique crates never know about
//! each other, the harness concatenates their `techniques()` lists.

pub mod cache;
pub mod goldens;
pub mod report;
pub mod results;
mod run;

use std::path::{Path, PathBuf};

use oit_gpu::{Context, ContextOptions, TechniqueInfo, TechniqueSpec};
use oit_scene::{Resolution, Scene};

pub use run::{CompareOptions, RenderedFrame, compare, render_once};

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
}

impl HarnessError {
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        HarnessError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Every technique the project implements, in the order reports list them. `unsorted` comes
/// first: it is the baseline every cost is divided by.
pub fn registry() -> Vec<TechniqueInfo> {
    let mut all = oit_sorted::techniques();
    all.extend(oit_peel::techniques());
    all.extend(oit_wboit::techniques());
    all.extend(oit_stochastic::techniques());
    all.extend(oit_mboit::techniques());
    all.extend(oit_linked_list::techniques());
    all
}

/// Parses a spec against the registry.
pub fn parse_spec(text: &str) -> Result<TechniqueSpec, HarnessError> {
    Ok(TechniqueSpec::parse(text, &registry())?)
}

/// The specs to run: the given ones (parsed, deduplicated by canonical string, in order), or
/// every technique at its defaults when none is given.
pub fn resolve_specs(texts: &[String]) -> Result<Vec<TechniqueSpec>, HarnessError> {
    let registry = registry();
    let mut specs: Vec<TechniqueSpec> = Vec::new();
    if texts.is_empty() {
        specs = registry.iter().map(TechniqueInfo::default_spec).collect();
    }
    for text in texts {
        for one in expand_sweep(text) {
            let spec = TechniqueSpec::parse(&one, &registry)?;
            if !specs.iter().any(|s| s.canonical() == spec.canonical()) {
                specs.push(spec);
            }
        }
    }
    Ok(specs)
}

/// Expands a sweep into single specs, in parameter order: a value list `spp=1,4,16` (a token
/// without `=` continues the previous key's list) and an integer range `passes=1..8`
/// (inclusive). Several swept keys give their cartesian product, the first key varying
/// slowest. Text without sweeps comes back unchanged; validation is left to the spec parser.
pub fn expand_sweep(text: &str) -> Vec<String> {
    let Some((name, params)) = text.split_once(':') else {
        return vec![text.to_owned()];
    };
    let mut keys: Vec<(String, Vec<String>)> = Vec::new();
    for token in params.split(',') {
        match token.split_once('=') {
            Some((k, v)) => keys.push((k.to_owned(), vec![v.to_owned()])),
            None => match keys.last_mut() {
                Some((_, values)) => values.push(token.to_owned()),
                // A leading token without `=`: let the parser report it as written.
                None => return vec![text.to_owned()],
            },
        }
    }
    for (_, values) in &mut keys {
        *values = values.iter().flat_map(|v| expand_range(v)).collect();
    }
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

/// `oit techniques`: every technique with its parameters and defaults.
pub fn techniques_help() -> String {
    let mut out = String::new();
    for info in registry() {
        out.push_str(&format!("{}\n    {}\n", info.name, info.description));
        for p in &info.params {
            out.push_str(&format!(
                "    {}={} (default {}): {}\n",
                p.key, p.allowed, p.default, p.description
            ));
        }
        out.push_str(&format!(
            "    canonical default: {}\n",
            info.default_spec().canonical()
        ));
    }
    out
}

/// Opens the GPU and prints nothing: callers print the adapter.
pub fn open_context(options: &ContextOptions) -> Result<Context, HarnessError> {
    Ok(Context::new(options)?)
}

/// A loaded scene and the file it came from.
#[derive(Debug, Clone)]
pub struct SceneEntry {
    pub path: PathBuf,
    pub scene: Scene,
}

/// Loads scene files and directories of scene files (`*.json`, `*.gltf`, `*.glb`, sorted by
/// name within a directory), in the order given.
pub fn load_scenes(paths: &[PathBuf]) -> Result<Vec<SceneEntry>, HarnessError> {
    load_scenes_with(paths, &oit_scene::LoadOptions::default())
}

/// [`load_scenes`] with `options` (e.g. which glTF camera) applied to every glTF file.
pub fn load_scenes_with(
    paths: &[PathBuf],
    options: &oit_scene::LoadOptions,
) -> Result<Vec<SceneEntry>, HarnessError> {
    let mut out = Vec::new();
    for path in paths {
        if path.is_dir() {
            for (path, scene) in oit_scene::load_dir_with(path, options)? {
                out.push(SceneEntry { path, scene });
            }
        } else {
            out.push(SceneEntry {
                path: path.clone(),
                scene: oit_scene::load_with(path, options)?,
            });
        }
    }
    Ok(out)
}

/// Applies an optional resolution override.
pub fn at_resolution(scene: &Scene, resolution: Option<Resolution>) -> Scene {
    match resolution {
        Some(r) if r != scene.resolution => scene.with_resolution(r),
        _ => scene.clone(),
    }
}

/// A file-name-safe stem for a scene name or canonical technique string:
/// `dual-peel:passes=5,tail=wboit` → `dual-peel_passes-5_tail-wboit`.
pub fn file_stem(text: &str) -> String {
    text.chars()
        .map(|c| match c {
            ':' | ',' => '_',
            '=' => '-',
            c if c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.' => c,
            _ => '_',
        })
        .collect()
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
    fn file_stems_are_safe_and_readable() {
        assert_eq!(
            file_stem("dual-peel:passes=5,tail=wboit"),
            "dual-peel_passes-5_tail-wboit"
        );
        assert_eq!(file_stem("a/b c"), "a_b_c");
    }

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
            "dual-peel:depth=auto,encoding=window,passes=1,reverse-z=on,tail=drop"
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
