//! Scene-parameter sweeps end to end (`oit compare --vary`): a layer-count sweep of the bundled
//! `scenes/growth/layer-stack.json` at 32² makes one run per value × technique, each recording
//! the swept parameter and value, and the error of the order-dependent approximations grows
//! with the layers while sorting stays exact.

use oit_harness::results::{Results, RunStatus};
use oit_harness::vary::{parse_scene_sweeps, vary_scenes};
use oit_harness::{CompareOptions, compare, load_scenes, resolve_specs};
use oit_scene::Resolution;

#[test]
fn a_layer_sweep_records_each_value_and_error_grows_with_the_layers() {
    let Some(ctx) = oit_gpu::testing::context_or_skip(
        "a_layer_sweep_records_each_value_and_error_grows_with_the_layers",
    ) else {
        return;
    };
    let out = std::env::temp_dir().join(format!("oit-growth-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let base = load_scenes(&[crate::kit::scenes_dir().join("growth/layer-stack.json")]).unwrap();
    let sweeps = parse_scene_sweeps(&["/objects/0/mesh/count=1..4:x2".into()]).unwrap();
    let scenes = vary_scenes(base, &sweeps).unwrap();
    let techniques = ["unsorted", "wboit", "sorted-object"];
    let specs = resolve_specs(&techniques.map(String::from)).unwrap();
    let options = CompareOptions {
        resolution: Some(Resolution {
            width: 32,
            height: 32,
        }),
        frames: 1,
        warmup: 0,
        out_dir: out.clone(),
        cache: oit_harness::ReferenceCache::Off,
        ..CompareOptions::default()
    };
    let results = compare(&ctx, &scenes, &specs, &options, &|_| {}).unwrap();
    assert_eq!(Results::read(&out.join("results.json")).unwrap(), results);
    assert_eq!(results.runs.len(), 3 * techniques.len());

    let errors = |technique: &str, layers: u32| -> oit_metrics::Errors {
        let matching: Vec<_> = results
            .runs
            .iter()
            .filter(|r| {
                r.technique.starts_with(technique)
                    && r.varied
                        .as_ref()
                        .is_some_and(|v| v.value == layers.to_string())
            })
            .collect();
        assert_eq!(matching.len(), 1, "{technique} at {layers} layers");
        let run = matching[0];
        assert_eq!(run.status, RunStatus::Ok, "{run:?}");
        assert_eq!(run.scene, format!("layer-stack[count={layers}]"));
        let v = run.varied.as_ref().unwrap();
        assert_eq!(v.base_scene, "layer-stack");
        assert_eq!(v.parameter, "/objects/0/mesh/count");
        assert_eq!(v.label, "count");
        assert_eq!(v.x, f64::from(layers));
        run.error.unwrap()
    };
    let flip = |technique: &str, layers: u32| errors(technique, layers).flip_mean;
    for technique in ["unsorted", "wboit"] {
        let e: Vec<f64> = [1, 2, 4].iter().map(|&n| flip(technique, n)).collect();
        // One layer is composited exactly by both (to the 16-bit target's rounding); every
        // layer added moves them further off.
        assert!(errors(technique, 1).max_abs < 1e-3, "{technique}");
        assert!(e[0] < e[1] && e[1] < e[2], "{technique}: {e:?}");
    }
    for n in [1, 2, 4] {
        let e = errors("sorted-object", n);
        assert!(
            e.max_abs < 1e-3 && e.flip_mean < 0.01,
            "sorted-object at {n}: {e:?}"
        );
        assert!(flip("unsorted", n) >= e.flip_mean, "{n}");
    }

    // The growth table reads the same runs: a fit per technique over three values; at a bound
    // of 0.02 unsorted breaks at two layers (ꟻLIP about 0.045 there, 0.003 at one).
    let sweeps = oit_report::growth_data(&results, oit_report::Metric::Flip, 0.02);
    assert_eq!(sweeps.len(), 1);
    let sweep = &sweeps[0];
    assert_eq!(
        (sweep.base_scene.as_str(), sweep.label.as_str()),
        ("layer-stack", "count")
    );
    let row = |t: &str| {
        sweep
            .rows
            .iter()
            .find(|r| r.technique.starts_with(t))
            .unwrap()
    };
    for t in ["unsorted", "wboit", "sorted-object"] {
        let fit = row(t).ms_fit.as_ref().unwrap();
        assert_eq!(fit.points, 3, "{t}");
        assert!(fit.b.is_finite() && fit.r2 <= 1.0 + 1e-12, "{t}: {fit:?}");
    }
    assert_eq!(row("unsorted").breaks_at.as_ref().unwrap().value, "2");
    assert!(row("sorted-object").breaks_at.is_none());
    assert!(row("floor").ms_fit.is_ok());
    let _ = std::fs::remove_dir_all(&out);
}
