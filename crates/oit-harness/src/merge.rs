//! `oit merge`: the shards of one comparison (`oit compare --shard K/N`, [`crate::shard`]) made
//! into one results.json, with every run's files (docs/sharding.md).
//!
//! The shards must be of one comparison: the same build of oit (`tool`), the same plan (scenes,
//! techniques, options) and the same N, each K once. Runs, floors and scenes are joined in the
//! order of K, which is the order of the unsharded comparison; every run and floor keeps its
//! `shard`, and `merged` lists each shard with its adapter: cost ratios compare only within one
//! shard.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use crate::results::{AdapterJson, Results, SCHEMA, ShardJson};
use crate::run::{OutputLock, write_outputs};
use crate::{HarnessError, file_stem};

/// Reads the shards in `dirs`, checks they are of one comparison, and writes the merged
/// results.json and results.md, and every scene folder's files, into `out` (atomically, file
/// by file; no input is written). Missing or interrupted shards are an error naming them
/// unless `allow_missing`: then the merged results say they are incomplete.
pub fn merge(dirs: &[PathBuf], out: &Path, allow_missing: bool) -> Result<Results, HarnessError> {
    if dirs.is_empty() {
        return Err(HarnessError::Options(
            "no shard folders to merge; name the --out folders of `oit compare --shard K/N`".into(),
        ));
    }
    let shards = read_shards(dirs)?;
    let (_, first, first_shard) = &shards[0];
    let count = first_shard.count;
    let present: Vec<u32> = shards.iter().map(|(_, _, s)| s.index).collect();
    let missing: Vec<String> = (1..=count)
        .filter(|k| !present.contains(k))
        .map(|k| k.to_string())
        .collect();
    let interrupted: Vec<String> = (shards.iter())
        .filter(|(_, r, _)| !r.complete)
        .map(|(p, _, _)| p.display().to_string())
        .collect();
    if !allow_missing && !missing.is_empty() {
        return Err(HarnessError::Options(format!(
            "shards {} of {count} are missing (given: {}); merge them all, or pass --allow-missing to merge these alone",
            missing.join(", "),
            (present.iter())
                .map(u32::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    if !allow_missing && !interrupted.is_empty() {
        return Err(HarnessError::Options(format!(
            "{}: interrupted (`complete` is false); finish the shard with `oit compare … --resume`, or pass --allow-missing",
            interrupted.join(", ")
        )));
    }
    check_out(dirs, out)?;
    std::fs::create_dir_all(out).map_err(|e| HarnessError::io(out, e))?;
    refuse_foreign_results(out)?;
    let _lock = OutputLock::acquire(out)?;
    oit_metrics::remove_stale_temporaries(out);

    let mut merged = Results {
        schema: SCHEMA.to_owned(),
        tool: first.tool.clone(),
        complete: missing.is_empty() && interrupted.is_empty(),
        adapter: adapter_of(shards.iter().map(|(_, r, _)| &r.adapter)),
        runs: Vec::new(),
        floors: Vec::new(),
        scenes: Vec::new(),
        shard: None,
        merged: Vec::new(),
    };
    let mut seen: Vec<(String, String, [u32; 2], &Path)> = Vec::new();
    let mut placed = HashSet::new();
    for (path, results, shard) in &shards {
        for run in &results.runs {
            // A run is its scene, technique at its target format, and resolution.
            let key = (run.scene.clone(), run.technique_label(), run.resolution);
            if let Some((.., other)) = seen
                .iter()
                .find(|(s, t, r, _)| (s, t, r) == (&key.0, &key.1, &key.2))
            {
                return Err(HarnessError::Invalid {
                    path: path.clone(),
                    message: format!(
                        "run {} × {} is also in {}: shards overlap (made with other scene or technique lists?)",
                        run.scene,
                        run.technique_label(),
                        other.display()
                    ),
                });
            }
            seen.push((key.0, key.1, key.2, path));
            merged.runs.push(crate::results::Run {
                shard: Some(shard.index),
                ..run.clone()
            });
        }
        for floor in &results.floors {
            merged.floors.push(crate::results::FloorJson {
                shard: Some(shard.index),
                ..floor.clone()
            });
        }
        for scene in &results.scenes {
            if !merged.scenes.iter().any(|s| s.scene == scene.scene) {
                merged.scenes.push(scene.clone());
            }
            let dir = path.parent().map_or_else(PathBuf::new, Path::to_path_buf);
            let stem = file_stem(&scene.scene);
            place_tree(&dir.join(&stem), &out.join(&stem), &mut placed)?;
        }
        merged.merged.push(ShardJson {
            complete: Some(results.complete),
            adapter: Some(results.adapter.clone()),
            ..shard.clone()
        });
    }
    write_outputs(out, &mut merged)?;
    Ok(merged)
}

/// Each DIR/results.json, in the order of K, each checked to be a shard of the same comparison
/// as the first.
fn read_shards(dirs: &[PathBuf]) -> Result<Vec<(PathBuf, Results, ShardJson)>, HarnessError> {
    let mut shards: Vec<(PathBuf, Results, ShardJson)> = Vec::new();
    for dir in dirs {
        let path = dir.join("results.json");
        let results = Results::read(&path)?;
        let invalid = |message: String| HarnessError::Invalid {
            path: path.clone(),
            message,
        };
        if !results.merged.is_empty() {
            return Err(invalid(
                "`merged` is set: already a merge; merge the shards it was made from".into(),
            ));
        }
        let Some(shard) = results.shard.clone() else {
            return Err(invalid(
                "no `shard` field: not the results of `oit compare --shard K/N` (a whole comparison needs no merge)".into(),
            ));
        };
        if let Some((first_path, first, first_shard)) = shards.first() {
            let first_name = first_path.display();
            if results.tool != first.tool {
                let build =
                    |r: &Results| r.tool.as_ref().map_or("none".into(), |t| t.build.clone());
                return Err(invalid(format!(
                    "`tool.build` is {}, {first_name} has {}: made by another build of oit; make every shard with one build",
                    build(&results),
                    build(first)
                )));
            }
            if (shard.count, shard.runs) != (first_shard.count, first_shard.runs) {
                return Err(invalid(format!(
                    "`shard` is {}/{} of {} runs, {first_name} has {}/{} of {} runs: shards of another split or comparison",
                    shard.index,
                    shard.count,
                    shard.runs,
                    first_shard.index,
                    first_shard.count,
                    first_shard.runs
                )));
            }
            if shard.plan != first_shard.plan {
                return Err(invalid(format!(
                    "`shard.plan` is {}, {first_name} has {}: another comparison (other scenes, scene content, techniques or options)",
                    shard.plan, first_shard.plan
                )));
            }
        }
        if let Some((other, ..)) = shards.iter().find(|(_, _, s)| s.index == shard.index) {
            return Err(invalid(format!(
                "shard {}/{} again ({} holds it too); give each K once",
                shard.index,
                shard.count,
                other.display()
            )));
        }
        let expected = crate::shard::Shard {
            index: shard.index,
            count: shard.count,
        }
        .range(shard.runs);
        let expected = expected.end - expected.start;
        // A shard splits scene × technique pairs; each pair is a run per target format.
        let mut pairs: Vec<(&str, &str, [u32; 2])> = (results.runs.iter())
            .map(|r| (r.scene.as_str(), r.technique.as_str(), r.resolution))
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        if results.complete && pairs.len() as u64 != expected {
            return Err(invalid(format!(
                "`runs` holds {} runs; shard {}/{} of {} runs makes {expected}",
                pairs.len(),
                shard.index,
                shard.count,
                shard.runs
            )));
        }
        shards.push((path, results, shard));
    }
    shards.sort_by_key(|(_, _, s)| s.index);
    Ok(shards)
}

/// `out` is none of the shard folders, and no shard folder is inside it or it inside one.
fn check_out(dirs: &[PathBuf], out: &Path) -> Result<(), HarnessError> {
    let full = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let mut target = full(out);
    if !out.exists() {
        // Resolve what exists of it: a new folder inside a shard is still inside it.
        if let (Some(parent), Some(name)) = (out.parent(), out.file_name()) {
            let parent = if parent.as_os_str().is_empty() {
                Path::new(".")
            } else {
                parent
            };
            target = full(parent).join(name);
        }
    }
    for dir in dirs {
        let dir_full = full(dir);
        if target.starts_with(&dir_full) || dir_full.starts_with(&target) {
            return Err(HarnessError::Invalid {
                path: out.to_path_buf(),
                message: format!(
                    "--out is {} shard folder {}: the merge never writes into its inputs; choose another --out",
                    if target == dir_full {
                        "the"
                    } else {
                        "nested with the"
                    },
                    dir.display()
                ),
            });
        }
    }
    Ok(())
}

/// An earlier results.json in `out` is replaced only when `oit merge` wrote it.
fn refuse_foreign_results(out: &Path) -> Result<(), HarnessError> {
    let path = out.join("results.json");
    if !path.exists() {
        return Ok(());
    }
    match Results::read(&path) {
        Ok(r) if !r.merged.is_empty() => Ok(()),
        _ => Err(HarnessError::Invalid {
            path,
            message:
                "not written by `oit merge`, so not replaced; move it away or choose another --out"
                    .into(),
        }),
    }
}

/// One adapter when every shard ran on the same; otherwise each field lists the distinct
/// values, ` | ` between them (`merged` has each shard's).
fn adapter_of<'a>(adapters: impl Iterator<Item = &'a AdapterJson>) -> AdapterJson {
    let all: Vec<&AdapterJson> = adapters.collect();
    let join = |field: &dyn Fn(&AdapterJson) -> &str| {
        let mut values: Vec<&str> = Vec::new();
        for a in &all {
            if !values.contains(&field(a)) {
                values.push(field(a));
            }
        }
        values.join(" | ")
    };
    AdapterJson {
        name: join(&|a| &a.name),
        backend: join(&|a| &a.backend),
        device_type: join(&|a| &a.device_type),
        driver: join(&|a| &a.driver),
    }
}

/// Places every regular file under `from` at the same place under `to`: a hard link where the
/// file system allows it (the shards write atomically, by rename, so a later write to a shard
/// never changes the merge), a copy otherwise; each published by rename. A file this merge
/// already placed (a scene's reference, from a scene split between shards) is kept.
fn place_tree(from: &Path, to: &Path, placed: &mut HashSet<PathBuf>) -> Result<(), HarnessError> {
    let Ok(entries) = std::fs::read_dir(from) else {
        return Ok(()); // a scene that failed before writing anything has no folder
    };
    std::fs::create_dir_all(to).map_err(|e| HarnessError::io(to, e))?;
    oit_metrics::remove_stale_temporaries(to);
    for entry in entries {
        let entry = entry.map_err(|e| HarnessError::io(from, e))?;
        let name = entry.file_name();
        let (src, dst) = (entry.path(), to.join(&name));
        let kind = entry.file_type().map_err(|e| HarnessError::io(&src, e))?;
        if name.to_string_lossy().starts_with('.') {
            continue; // temporaries of an interrupted write
        } else if kind.is_dir() {
            place_tree(&src, &dst, placed)?;
        } else if kind.is_file() && placed.insert(dst.clone()) {
            // Named as oit_metrics names its temporaries, so a stale one is removed later.
            static COUNTER: std::sync::atomic::AtomicU64 =
                std::sync::atomic::AtomicU64::new(1 << 40);
            let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let tmp = to.join(format!(
                ".{}.{}-{n}.tmp",
                name.to_string_lossy(),
                std::process::id()
            ));
            let _ = std::fs::remove_file(&tmp);
            if std::fs::hard_link(&src, &tmp).is_err() {
                std::fs::copy(&src, &tmp).map_err(|e| HarnessError::io(&dst, e))?;
            }
            std::fs::rename(&tmp, &dst).map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                HarnessError::io(&dst, e)
            })?;
        }
    }
    Ok(())
}
