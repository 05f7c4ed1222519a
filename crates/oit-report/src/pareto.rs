//! Pareto fronts: the configurations worth choosing, because no other one is both cheaper and
//! more accurate.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use oit_results::{Results, Run, RunStatus};

use crate::plot::Metric;

/// Indices (ascending) of the non-dominated points of `points`, given as `(cost, error)` with
/// lower better on both axes.
///
/// `p` dominates `q` when `p.cost <= q.cost` and `p.error <= q.error` and at least one of the
/// two is strictly smaller.
///
/// **Tie rule: equal points are all kept.** Two identical points do not dominate each other, so
/// when the best trade-off is reached by several configurations every one of them is on the
/// front. This keeps the answer independent of the order of the runs (the run order in
/// `results.json` carries no meaning) and never hides a configuration that is as good as the
/// one shown. `-0.0` and `0.0` are equal.
///
/// Points with a NaN or infinite coordinate are excluded: they are neither on the front nor
/// allowed to dominate anything.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    // `+ 0.0` turns -0.0 into 0.0 so that sorting by total order groups them.
    let mut finite: Vec<(f64, f64, usize)> = points
        .iter()
        .enumerate()
        .filter(|(_, (c, e))| c.is_finite() && e.is_finite())
        .map(|(i, &(c, e))| (c + 0.0, e + 0.0, i))
        .collect();
    finite.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));

    let mut front = Vec::new();
    // Smallest error among points with strictly smaller cost than the current group.
    let mut best_cheaper = f64::INFINITY;
    let mut start = 0;
    while start < finite.len() {
        let cost = finite[start].0;
        let end = start + finite[start..].iter().take_while(|p| p.0 == cost).count();
        let group_min = finite[start].1;
        // A cheaper point with error <= group_min would dominate the whole group.
        if group_min < best_cheaper {
            front.extend(
                finite[start..end]
                    .iter()
                    .take_while(|p| p.1 == group_min)
                    .map(|p| p.2),
            );
            best_cheaper = group_min;
        }
        start = end;
    }
    front.sort_unstable();
    front
}

/// The ok runs of one scene that are on its front of `cost_vs_unsorted` against `metric`
/// (runs without a cost or an error are left out of the computation).
pub fn scene_front<'r>(runs: &[&'r Run], metric: Metric) -> Vec<&'r Run> {
    let candidates: Vec<&Run> = runs
        .iter()
        .copied()
        .filter(|r| r.status == RunStatus::Ok)
        .filter(|r| r.cost_vs_unsorted.is_some() && r.error.is_some())
        .collect();
    let points: Vec<(f64, f64)> = candidates
        .iter()
        .map(|r| {
            (
                r.cost_vs_unsorted.unwrap_or(f64::NAN),
                r.error.as_ref().map_or(f64::NAN, |e| metric.of(e)),
            )
        })
        .collect();
    pareto_front(&points)
        .into_iter()
        .map(|i| candidates[i])
        .collect()
}

/// `(scene, canonical technique with its target format, `Run::technique_label`)` of every run on its scene's Pareto front.
pub fn pareto_members(results: &Results, metric: Metric) -> BTreeSet<(String, String)> {
    let mut members = BTreeSet::new();
    for (_, runs) in crate::plot::runs_by_scene(results) {
        for run in scene_front(&runs, metric) {
            members.insert((run.scene.clone(), run.technique_label()));
        }
    }
    members
}

/// A markdown section listing each scene's Pareto front, cheapest first, for `results.md`.
pub fn pareto_markdown(results: &Results, metric: Metric) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "## Pareto fronts ({} against GPU cost relative to `unsorted`)\n\n\
         A configuration is on the front when no other run of the same scene is both cheaper and \
         more accurate; equal points are all listed.\n",
        metric.name()
    );
    for (scene, runs) in crate::plot::runs_by_scene(results) {
        let mut front = scene_front(&runs, metric);
        front.sort_by(|a, b| {
            a.cost_vs_unsorted
                .unwrap_or(f64::NAN)
                .total_cmp(&b.cost_vs_unsorted.unwrap_or(f64::NAN))
        });
        let _ = writeln!(out, "### {scene}\n");
        if front.is_empty() {
            let _ = writeln!(out, "No run has both a cost and an error.\n");
            continue;
        }
        let _ = writeln!(out, "| technique | cost × unsorted | {} |", metric.name());
        let _ = writeln!(out, "|---|---:|---:|");
        for run in front {
            let cost = run.cost_vs_unsorted.unwrap_or(f64::NAN);
            let err = run.error.as_ref().map_or(f64::NAN, |e| metric.of(e));
            let _ = writeln!(
                out,
                "| `{}` | {cost:.3} | {err:.5} |",
                run.technique_label()
            );
        }
        let _ = writeln!(out);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::pareto_front;

    #[test]
    fn empty_and_single() {
        assert_eq!(pareto_front(&[]), Vec::<usize>::new());
        assert_eq!(pareto_front(&[(2.0, 3.0)]), vec![0]);
    }

    #[test]
    fn staircase_with_dominated_points() {
        // Front by hand: (1,9) cheapest; (2,5) better error; (4,2); (8,1). Dominated: (3,6) by
        // (2,5); (5,5) by (4,2); (9,1) by (8,1) (equal error, costlier).
        let pts = [
            (3.0, 6.0),
            (1.0, 9.0),
            (8.0, 1.0),
            (2.0, 5.0),
            (5.0, 5.0),
            (4.0, 2.0),
            (9.0, 1.0),
        ];
        assert_eq!(pareto_front(&pts), vec![1, 2, 3, 5]);
    }

    #[test]
    fn one_point_dominating_everything() {
        let pts = [(5.0, 5.0), (1.0, 1.0), (2.0, 3.0), (1.0, 2.0), (3.0, 1.0)];
        assert_eq!(pareto_front(&pts), vec![1]);
    }

    #[test]
    fn identical_points_are_all_kept() {
        let pts = [(2.0, 2.0), (1.0, 3.0), (2.0, 2.0), (3.0, 3.0), (2.0, 2.0)];
        assert_eq!(pareto_front(&pts), vec![0, 1, 2, 4]);
    }

    #[test]
    fn equal_cost_keeps_only_the_lowest_error() {
        // Same cost: (2,4) dominates (2,7) (strictly lower error), both (2,4) kept as ties.
        let pts = [(2.0, 7.0), (2.0, 4.0), (2.0, 4.0), (1.0, 8.0)];
        assert_eq!(pareto_front(&pts), vec![1, 2, 3]);
    }

    #[test]
    fn equal_error_keeps_only_the_lowest_cost() {
        let pts = [(3.0, 1.0), (1.0, 1.0), (2.0, 1.0)];
        assert_eq!(pareto_front(&pts), vec![1]);
    }

    #[test]
    fn a_tie_with_a_dominated_point_is_still_dominated() {
        // (2,2) twice, but (1,2) is cheaper at the same error: both copies are dominated.
        let pts = [(2.0, 2.0), (2.0, 2.0), (1.0, 2.0)];
        assert_eq!(pareto_front(&pts), vec![2]);
    }

    #[test]
    fn negative_zero_equals_zero() {
        let pts = [(1.0, -0.0), (1.0, 0.0), (0.5, 1.0)];
        assert_eq!(pareto_front(&pts), vec![0, 1, 2]);
    }

    #[test]
    fn non_finite_points_are_excluded_and_dominate_nothing() {
        // (NaN, 0) and (0, -inf) would beat everything if they counted.
        let pts = [
            (f64::NAN, 0.0),
            (1.0, 1.0),
            (0.0, f64::NEG_INFINITY),
            (f64::INFINITY, 0.5),
            (2.0, 0.5),
        ];
        assert_eq!(pareto_front(&pts), vec![1, 4]);
    }

    #[test]
    fn front_is_independent_of_input_order() {
        let pts = [
            (1.0, 4.0),
            (2.0, 2.0),
            (2.0, 2.0),
            (3.0, 1.0),
            (3.0, 3.0),
            (0.5, 9.0),
        ];
        let expected: Vec<(f64, f64)> = {
            let mut v: Vec<_> = pareto_front(&pts).into_iter().map(|i| pts[i]).collect();
            v.sort_by(|a, b| a.partial_cmp(b).unwrap());
            v
        };
        assert_eq!(
            expected,
            vec![(0.5, 9.0), (1.0, 4.0), (2.0, 2.0), (2.0, 2.0), (3.0, 1.0)]
        );
        let mut reversed = pts;
        reversed.reverse();
        let mut got: Vec<_> = pareto_front(&reversed)
            .into_iter()
            .map(|i| reversed[i])
            .collect();
        got.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert_eq!(got, expected);
    }
}
