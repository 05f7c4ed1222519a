//! `oit compare --shard K/N`: which runs of a comparison one machine makes (docs/sharding.md).
//!
//! The runs of a comparison are numbered scene-major: scene `i` (the loaded scenes in the
//! order given, then the files that did not load) with technique `j` is run `i × S + j`, `S`
//! the number of technique specs. Shard K of N makes the contiguous block of runs
//! `⌊(K−1)·T/N⌋ .. ⌊K·T/N⌋` of the `T` runs: the shards differ by at most one run, and
//! contiguous blocks keep a scene's runs together (at most N − 1 scenes are split between two
//! shards), so a scene's reference, floor and `unsorted` baseline are computed on as few
//! machines as possible. Every shard that makes any run of a scene times that scene's floor
//! (and `unsorted`, when it is not among its runs) itself, so every cost ratio divides two
//! times taken on one machine. The assignment depends only on the scene and technique lists,
//! never on the machine or the time.

use oit_gpu::TechniqueSpec;

use crate::results::ShardJson;
use crate::run::CompareOptions;
use crate::{SceneEntry, Unloadable, at_resolution};

/// Shard `index` (K, from 1) of `count` (N).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    /// Reads `K/N` with 1 ≤ K ≤ N.
    pub fn parse(text: &str) -> Result<Shard, String> {
        let usage = "`--shard K/N` with whole numbers 1 ≤ K ≤ N, e.g. 2/3";
        let (k, n) = text
            .split_once('/')
            .ok_or_else(|| format!("`{text}` is not K/N; {usage}"))?;
        let number = |v: &str| v.trim().parse::<u32>().ok();
        match (number(k), number(n)) {
            (Some(k), Some(n)) if n >= 1 && (1..=n).contains(&k) => {
                Ok(Shard { index: k, count: n })
            }
            (Some(_), Some(0)) => Err(format!("`{text}`: N is 0; {usage}")),
            (Some(k), Some(n)) => Err(format!("`{text}`: K {k} is outside 1..={n}; {usage}")),
            _ => Err(format!("`{text}` is not two whole numbers; {usage}")),
        }
    }

    /// The runs this shard makes, of `total`: a half-open range of run numbers.
    pub fn range(&self, total: u64) -> std::ops::Range<u64> {
        let at = |k: u32| (u128::from(total) * u128::from(k) / u128::from(self.count)) as u64;
        at(self.index - 1)..at(self.index)
    }

    /// The specs of scene `scene_index` that this shard runs, in order.
    pub fn specs_of<'a>(
        &self,
        scene_index: usize,
        specs: &'a [TechniqueSpec],
        total: u64,
    ) -> Vec<&'a TechniqueSpec> {
        let range = self.range(total);
        let first = scene_index as u64 * specs.len() as u64;
        specs
            .iter()
            .enumerate()
            .filter(|(j, _)| range.contains(&(first + *j as u64)))
            .map(|(_, s)| s)
            .collect()
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The name an unloadable scene file's runs carry: its file stem.
pub fn unloadable_name(u: &Unloadable) -> String {
    u.path.file_stem().map_or_else(
        || u.path.display().to_string(),
        |s| s.to_string_lossy().into_owned(),
    )
}

/// What `results.json` of `shard` records: the shard and the whole comparison's plan, a hash
/// of every scene (name and content as rendered), every spec, and the options that change a
/// run. Shards of one comparison, made with the same arguments, record the same plan.
pub(crate) fn shard_json(
    shard: Shard,
    scenes: &[SceneEntry],
    unloadable: &[Unloadable],
    specs: &[TechniqueSpec],
    options: &CompareOptions,
) -> ShardJson {
    use std::fmt::Write as _;
    let mut plan = String::new();
    for entry in scenes {
        let scene = at_resolution(&entry.scene, options.resolution);
        let _ = writeln!(plan, "scene {} {:016x}", scene.name, scene.content_hash());
    }
    for u in unloadable {
        let _ = writeln!(plan, "unloadable {}", unloadable_name(u));
    }
    for spec in specs {
        let _ = writeln!(plan, "technique {}", spec.canonical());
    }
    // Only when not the default alone, so plans of comparisons made before the option existed
    // stay the same.
    if options.target_formats != [oit_results::TargetFormat::default()] {
        let names: Vec<&str> = (options.target_formats.iter()).map(|f| f.name()).collect();
        let _ = writeln!(plan, "target formats {}", names.join(","));
    }
    let _ = writeln!(
        plan,
        "resolution {:?} frames {} warmup {} retime {} run_budget {:?} memory_budget {} animation_frames {:?} static_frames {}",
        options.resolution.map(|r| (r.width, r.height)),
        options.frames,
        options.warmup,
        options.retime,
        options.run_budget,
        options.memory_budget,
        options.animation_frames,
        options.static_frames
    );
    ShardJson {
        index: shard.index,
        count: shard.count,
        runs: ((scenes.len() + unloadable.len()) * specs.len()) as u64,
        plan: format!("{:016x}", crate::fnv1a64(plan.as_bytes())),
        complete: None,
        adapter: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_arguments_are_k_of_n() {
        assert_eq!(Shard::parse("2/3"), Ok(Shard { index: 2, count: 3 }));
        assert_eq!(Shard::parse("1/1"), Ok(Shard { index: 1, count: 1 }));
        for (bad, says) in [
            ("0/3", "K 0 is outside 1..=3"),
            ("4/3", "K 4 is outside 1..=3"),
            ("1/0", "N is 0"),
            ("3", "not K/N"),
            ("a/3", "not two whole numbers"),
            ("-1/3", "not two whole numbers"),
        ] {
            let err = Shard::parse(bad).unwrap_err();
            assert!(
                err.contains(says) && err.contains("1 ≤ K ≤ N"),
                "{bad}: {err}"
            );
        }
    }

    /// Every run falls in exactly one shard, the shards differ by at most one run, and a scene
    /// is split only where a block ends.
    #[test]
    fn shards_partition_the_runs_in_balanced_blocks() {
        for total in [0u64, 1, 2, 7, 9, 10, 64, 1001] {
            for count in 1..=7u32 {
                let ranges: Vec<_> = (1..=count)
                    .map(|index| Shard { index, count }.range(total))
                    .collect();
                assert_eq!(ranges[0].start, 0);
                assert_eq!(ranges[count as usize - 1].end, total);
                for w in ranges.windows(2) {
                    assert_eq!(w[0].end, w[1].start, "{total} runs, {count} shards");
                }
                let sizes: Vec<u64> = ranges.iter().map(|r| r.end - r.start).collect();
                let (min, max) = (sizes.iter().min(), sizes.iter().max());
                assert!(max.zip(min).is_some_and(|(a, b)| a - b <= 1), "{sizes:?}");
            }
        }
        let specs =
            crate::resolve_specs(&["unsorted".into(), "wboit".into(), "sorted-object".into()])
                .unwrap();
        // 3 scenes × 3 specs in 3 shards: one whole scene each.
        for index in 1..=3u32 {
            let shard = Shard { index, count: 3 };
            for scene in 0..3 {
                let mine = shard.specs_of(scene, &specs, 9).len();
                assert_eq!(mine, if scene + 1 == index as usize { 3 } else { 0 });
            }
        }
        // 2 scenes × 3 specs in 4 shards: runs 0..1, 1..3, 3..4, 4..6.
        let second = Shard { index: 2, count: 4 };
        let names = |scene| {
            (second.specs_of(scene, &specs, 6).iter())
                .map(|s| s.canonical())
                .collect::<Vec<_>>()
        };
        assert_eq!(names(0).len(), 2);
        assert!(names(1).is_empty());
    }
}
