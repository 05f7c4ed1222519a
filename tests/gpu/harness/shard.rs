//! `compare --shard K/N` and `merge`: three shards merged are the unsharded comparison — every
//! run present once, in the same order, with identical errors and motion blocks — and a merge
//! refuses missing shards, a whole comparison and an output inside a shard.

use std::path::{Path, PathBuf};

use oit_harness::results::{Results, Run};
use oit_harness::{CompareOptions, Shard, compare, load_scenes, merge, resolve_specs};
use oit_scene::Resolution;

fn temp_dir(name: &str) -> oit_gpu::testing::ScratchDir {
    oit_gpu::testing::ScratchDir::new(&format!("shard-{name}"))
}

/// Four scenes (one animated) × three techniques: twelve runs, shards of four, so the second
/// and third scenes (the animated one among them) are split between two shards.
const SCENES: [&str; 4] = [
    "enderton.json",
    "motion/motion-sort-swap.json",
    "intersecting-quads.json",
    "sorted-quads.json",
];
const SPECS: [&str; 3] = ["unsorted", "sorted-object", "wboit"];

fn options(out: &Path, cache: &Path, shard: Option<Shard>) -> CompareOptions {
    CompareOptions {
        resolution: Some(Resolution {
            width: 32,
            height: 32,
        }),
        frames: 1,
        warmup: 0,
        out_dir: out.to_path_buf(),
        cache: oit_harness::ReferenceCache::Dir(cache.to_path_buf()),
        animation_frames: oit_harness::motion::FrameSelection::parse("0..4").expect("frames"),
        static_frames: 2,
        shard,
        ..CompareOptions::default()
    }
}

fn key(run: &Run) -> (String, String) {
    (run.scene.clone(), run.technique.clone())
}

#[test]
fn three_shards_merged_are_the_unsharded_comparison() {
    let Some(ctx) =
        oit_gpu::testing::context_or_skip("three_shards_merged_are_the_unsharded_comparison")
    else {
        return;
    };
    let root = temp_dir("merge");
    let cache = root.join("cache");
    let paths: Vec<PathBuf> = (SCENES.iter())
        .map(|s| crate::kit::scenes_dir().join(s))
        .collect();
    let scenes = load_scenes(&paths).unwrap();
    let specs = resolve_specs(&SPECS.map(String::from)).unwrap();
    let whole_dir = root.join("whole");
    let whole = compare(
        &ctx,
        &scenes,
        &specs,
        &options(&whole_dir, &cache, None),
        &|_| {},
    )
    .unwrap();
    assert_eq!(whole.runs.len(), 12);
    assert!(whole.shard.is_none() && whole.runs.iter().all(|r| r.shard.is_none()));
    let animated = whole.runs.iter().filter(|r| r.temporal.is_some()).count();
    assert_eq!(animated, 3, "the animated scene's runs carry motion blocks");

    let mut dirs = Vec::new();
    let mut union: Vec<(String, String)> = Vec::new();
    let mut plans = Vec::new();
    for index in 1..=3 {
        let dir = root.join(format!("shard-{index}"));
        let shard = Shard { index, count: 3 };
        let part = compare(
            &ctx,
            &scenes,
            &specs,
            &options(&dir, &cache, Some(shard)),
            &|_| {},
        )
        .unwrap();
        let on_disk = Results::read(&dir.join("results.json")).unwrap();
        assert_eq!(on_disk, part);
        let recorded = part.shard.clone().expect("a shard records itself");
        assert_eq!(
            (recorded.index, recorded.count, recorded.runs),
            (index, 3, 12)
        );
        plans.push(recorded.plan);
        assert_eq!(part.runs.len(), 4, "shard {index}: {:?}", part.runs);
        assert!(part.runs.iter().all(|r| r.shard == Some(index)));
        // A shard times the floor of every scene it runs, itself.
        for run in &part.runs {
            assert!(
                part.floors
                    .iter()
                    .any(|f| f.scene == run.scene && f.shard == Some(index)),
                "shard {index} has no floor of {}",
                run.scene
            );
        }
        union.extend(part.runs.iter().map(key));
        dirs.push(dir);
    }
    assert!(plans.windows(2).all(|w| w[0] == w[1]), "{plans:?}");
    let mut sorted_union = union.clone();
    sorted_union.sort();
    sorted_union.dedup();
    assert_eq!(sorted_union.len(), union.len(), "no run in two shards");
    let mut expected: Vec<_> = whole.runs.iter().map(key).collect();
    expected.sort();
    assert_eq!(
        sorted_union, expected,
        "the shards' runs are exactly the unsharded ones"
    );

    // Given in any order, merged in the order of K: the unsharded order.
    let merged_dir = root.join("merged");
    let given = [dirs[2].clone(), dirs[0].clone(), dirs[1].clone()];
    let merged = merge(&given, &merged_dir, false).unwrap();
    assert_eq!(
        Results::read(&merged_dir.join("results.json")).unwrap(),
        merged
    );
    assert!(merged.complete && merged.shard.is_none());
    assert_eq!(merged.merged.len(), 3);
    assert_eq!(
        merged.runs.iter().map(key).collect::<Vec<_>>(),
        whole.runs.iter().map(key).collect::<Vec<_>>()
    );
    for (m, w) in merged.runs.iter().zip(&whole.runs) {
        assert_eq!(m.status, w.status, "{:?}", key(m));
        assert_eq!(m.error, w.error, "{:?}", key(m));
        assert_eq!(m.order_dependence, w.order_dependence, "{:?}", key(m));
        assert_eq!(m.temporal, w.temporal, "{:?}", key(m));
        assert!(m.shard.is_some());
        let outputs = m.outputs.as_ref().expect("ok runs have files");
        for file in [&outputs.exr, &outputs.render_png, &outputs.diff_png] {
            assert!(merged_dir.join(file).is_file(), "{file} not in the merge");
        }
    }
    for scene in &merged.scenes {
        let dir = merged_dir.join(oit_harness::file_stem(&scene.scene));
        assert!(dir.join("reference.png").is_file(), "{}", dir.display());
    }
    assert_eq!(merged.scenes.len(), 4);
    assert_eq!(
        merged.floors.len(),
        6,
        "a split scene has a floor per shard"
    );
    let md = std::fs::read_to_string(merged_dir.join("results.md")).unwrap();
    assert!(md.contains("merged from shards 1, 2, 3 of 3"), "{md}");

    // A missing shard is named; merged anyway only when asked, and then incomplete.
    let partial = root.join("partial");
    let err = merge(&dirs[..2], &partial, false).unwrap_err().to_string();
    assert!(err.contains("shards 3 of 3 are missing"), "{err}");
    let some = merge(&dirs[..2], &partial, true).unwrap();
    assert!(!some.complete);
    assert_eq!(some.runs.len(), 8);
    // Never into a shard, never a whole comparison.
    let err = merge(&dirs, &dirs[0], false).unwrap_err().to_string();
    assert!(err.contains("shard folder"), "{err}");
    let err = merge(std::slice::from_ref(&whole_dir), &root.join("x"), false)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("no `shard` field") && err.contains("whole"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&root);
}
