//! The human-readable forms of results (results.md, the terminal table), from oit-results,
//! with the one thing that needs the technique registry: labels without default parameters.

pub use oit_results::report::*;

use crate::results::Results;

/// A technique's canonical spec without the parameters at their defaults (`linked-list`
/// rather than `linked-list:node=f32,nodes-per-pixel=16,sort-max=16,tail=average`): the label
/// of the terminal table, where every other parameter still shows.
pub fn short_spec(canonical: &str) -> String {
    let Ok(spec) = crate::parse_spec(canonical) else {
        return canonical.to_owned();
    };
    let registry = crate::registry();
    let Some(info) = registry.iter().find(|i| i.name == spec.name()) else {
        return canonical.to_owned();
    };
    let defaults = info.default_spec();
    let kept: Vec<String> = spec
        .params()
        .iter()
        .filter(|(k, v)| defaults.params().get(*k) != Some(*v))
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    if kept.is_empty() {
        spec.name().to_owned()
    } else {
        format!("{}:{}", spec.name(), kept.join(","))
    }
}

/// The terminal table, techniques labelled by [`short_spec`].
pub fn terminal_table(results: &Results) -> String {
    terminal_table_labelled(results, &short_spec)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::results::{AdapterJson, Run, RunStatus};

    fn run(scene: &str, technique: &str, cost: f64, max_abs: f64, flip: f64) -> Run {
        let mut r = Run::not_rendered(
            scene,
            "f.json",
            technique,
            [4, 4],
            RunStatus::Ok,
            String::new(),
        );
        r.reason = None;
        r.cost_vs_unsorted = Some(cost);
        r.cost_vs_floor = Some(cost * 2.0);
        r.order_dependence = Some(max_abs / 2.0);
        r.error = Some(oit_metrics::Errors {
            rmse: max_abs / 2.0,
            max_abs,
            flip_mean: flip,
            ..Default::default()
        });
        r
    }

    fn results_of(runs: Vec<Run>) -> Results {
        Results {
            schema: crate::results::SCHEMA.into(),
            tool: None,
            complete: true,
            adapter: AdapterJson {
                name: "a".into(),
                backend: "b".into(),
                device_type: "c".into(),
                driver: "d".into(),
            },
            runs,
            floors: Vec::new(),
            scenes: Vec::new(),
            shard: None,
            merged: Vec::new(),
        }
    }

    /// The terminal table of every technique at its defaults stays within
    /// [`TERMINAL_WIDTH`] columns, whatever the reasons and notes say: labels drop default
    /// parameters, long text goes to numbered notes under the table, wrapped.
    #[test]
    fn the_terminal_table_fits_a_terminal() {
        let mut runs: Vec<Run> = crate::resolve_specs(&[])
            .unwrap()
            .iter()
            .map(|s| {
                let mut r = run("a-scene-with-a-long-name", &s.canonical(), 12.5, 3e-4, 0.25);
                r.bytes_per_pixel = Some(1234.5);
                r.inexact =
                    vec!["dropped layers on 123456 px; tail approximated on 654321 px".into()];
                r
            })
            .collect();
        runs.push(Run::not_rendered(
            "a-scene-with-a-long-name",
            "f.json",
            "linked-list:node=f16,nodes-per-pixel=64,sort-max=128,tail=drop",
            [4, 4],
            RunStatus::Skipped,
            "unsupported here because this adapter has no storage buffers in the fragment stage, which the lists need ".repeat(3),
        ));
        let mut results = results_of(runs);
        results.scenes.push(crate::results::SceneJson {
            scene: "a-scene-with-a-long-name".into(),
            scene_file: "f.json".into(),
            description: "A description long enough to need wrapping on any terminal, since scene descriptions say what breaks and why in a sentence or three.".repeat(2),
            triangles: 2,
            scene_bytes: 1,
            texture_bytes: 0,
            credits: Vec::new(),
            ignored: Vec::new(),
            peak_memory_bytes: Some(987_654_321_000),
        });
        let table = terminal_table(&results);
        for line in table.lines() {
            assert!(
                line.chars().count() <= TERMINAL_WIDTH,
                "{} columns: {line}",
                line.chars().count()
            );
        }
        assert!(
            table.contains("  linked-list "),
            "default parameters dropped: {table}"
        );
        // One note per default run, then the skipped run's.
        let note = crate::registry().len() + 1;
        assert!(
            table.contains(&format!("[{note}] linked-list:node=f16,nodes-per-pixel=64,sort-max=128,tail=drop: skipped: unsupported here")),
            "{table}"
        );
    }

    #[test]
    fn short_specs_drop_only_default_parameters() {
        assert_eq!(
            short_spec("linked-list:node=f32,nodes-per-pixel=16,sort-max=16,tail=average"),
            "linked-list"
        );
        assert_eq!(
            short_spec("dual-peel:depth=auto,encoding=window,passes=3,reverse-z=on,tail=wboit"),
            "dual-peel:passes=3,tail=wboit"
        );
        assert_eq!(short_spec("not-a-technique:x=1"), "not-a-technique:x=1");
    }
}
