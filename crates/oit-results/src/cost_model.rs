//! A per-adapter cost model fitted over a results.json's runs: GPU time per frame (median ms)
//! ≈ a·fragments + b·bytes + c·atomics + d·triangles·passes + e·pixels·full-screen passes,
//! from each run's `counts` (docs/results-schema.md, "counts").
//!
//! The fit is non-negative least squares (Lawson & Hanson's active set): every term is work
//! that takes time, so a negative coefficient could only be the fit trading one collinear
//! column against another, which would make the model predict less time for more work. The
//! unconstrained least-squares coefficients are kept beside it, to show how much the
//! constraint moved. No intercept: the model says what the counted work costs, as asked. The
//! residuals are relative by default ([`Weighting`]).
//!
//! The counts are the same on every GPU; the coefficients belong to the adapter that timed
//! the runs and carry to no other.

use serde::{Deserialize, Serialize};

use crate::{Results, Run, RunStatus};

/// `cost-model` JSON's schema string.
pub const SCHEMA: &str = "oit-lab/cost-model/v1";

/// What the model says about the adapter's coefficients, in every output.
pub const TRANSFER_NOTE: &str = "The counts are the same on every GPU; the coefficients are this adapter's alone (a CPU rasterizer prices bytes, atomics and passes nothing like a GPU does): refit them on each adapter.";

/// The model's terms, in order.
pub const TERMS: [Term; 5] = [
    Term {
        name: "fragments",
        unit: "ms per fragment",
    },
    Term {
        name: "bytes",
        unit: "ms per byte",
    },
    Term {
        name: "atomics",
        unit: "ms per atomic",
    },
    Term {
        name: "triangle_passes",
        unit: "ms per triangle per geometry pass",
    },
    Term {
        name: "fullscreen_pixels",
        unit: "ms per pixel per full-screen pass",
    },
];

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Term {
    pub name: &'static str,
    pub unit: &'static str,
}

/// Why no model could be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CostModelError {
    #[error(
        "{runs} runs have GPU times and counts, but the model has {terms} coefficients to fit: it needs more runs than coefficients (run `oit compare` on more scenes or techniques){skipped}"
    )]
    TooFewRuns {
        runs: usize,
        terms: usize,
        skipped: String,
    },
    #[error(
        "the column `{column}` is a linear combination of {others} over these {runs} runs (collinear), so their coefficients cannot be told apart; add runs that vary them independently"
    )]
    Collinear {
        column: &'static str,
        others: String,
        runs: usize,
    },
    #[error("run {scene} × {technique}: {what} is {value}, not a finite number ≥ 0")]
    BadValue {
        scene: String,
        technique: String,
        what: &'static str,
        value: f64,
    },
}

/// One coefficient of the fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Coefficient {
    pub term: String,
    pub unit: String,
    /// Non-negative least squares.
    pub value: f64,
    /// Unconstrained least squares over the same columns (may be negative).
    pub unconstrained: f64,
    /// Share of the summed predicted time this term accounts for over the runs.
    pub share: f64,
}

/// A run's measured and predicted time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Residual {
    pub scene: String,
    pub technique: String,
    pub measured_ms: f64,
    pub predicted_ms: f64,
}

impl Residual {
    pub fn residual_ms(&self) -> f64 {
        self.measured_ms - self.predicted_ms
    }
}

/// How the model fits one technique's runs: measured ÷ predicted, median and range. A median
/// far from 1 is work the counts do not see (shader arithmetic, a resolve's sorting).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TechniqueFit {
    /// The technique's name (its configurations together).
    pub technique: String,
    pub runs: usize,
    pub median_ratio: f64,
    pub min_ratio: f64,
    pub max_ratio: f64,
}

/// A run left out of the fit, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LeftOut {
    pub scene: String,
    pub technique: String,
    pub reason: String,
}

/// The fitted model of one adapter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CostModel {
    pub schema: String,
    /// The adapter that timed the runs: the only one these coefficients describe.
    pub adapter: String,
    pub note: String,
    pub runs: usize,
    pub weighting: Weighting,
    pub coefficients: Vec<Coefficient>,
    /// Terms no run has (an all-zero column): not fitted, coefficient 0.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub absent_terms: Vec<String>,
    /// 1 − Σ residual² / Σ (measured − mean)², unweighted whatever the weighting: against
    /// predicting every run the mean time.
    pub r_squared: f64,
    /// The median over runs of |measured − predicted| / measured.
    pub median_relative_error: f64,
    /// The worst runs by absolute residual, worst first.
    pub worst: Vec<Residual>,
    /// Per technique, measured ÷ predicted over its runs (runs predicted at 0 ms left out).
    pub by_technique: Vec<TechniqueFit>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub left_out: Vec<LeftOut>,
}

/// What the least squares minimise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Weighting {
    /// Σ ((measured − predicted) / measured)²: every run counts alike, whatever its time (the
    /// default: a suite's times span four orders of magnitude, and absolute residuals would
    /// fit the few slowest runs only).
    #[default]
    Relative,
    /// Σ (measured − predicted)²: the slowest runs decide the fit.
    Absolute,
}

/// Worst residuals kept.
pub const WORST: usize = 10;

/// A run's five counts and median time, when it has both.
fn row(run: &Run) -> Result<Option<([f64; 5], f64)>, LeftOut> {
    let left_out = |reason: &str| LeftOut {
        scene: run.scene.clone(),
        technique: run.technique_label(),
        reason: reason.to_owned(),
    };
    if run.status != RunStatus::Ok {
        return Ok(None);
    }
    let Some(gpu) = &run.gpu_ms else {
        return Err(left_out("no GPU time"));
    };
    let Some(c) = &run.counts else {
        return Err(left_out("no counts (a file written before 2026-12-06)"));
    };
    if !c.undeclared_passes.is_empty() {
        return Err(left_out(&format!(
            "passes without a declaration: {}",
            c.undeclared_passes.join(", ")
        )));
    }
    Ok(Some((
        [
            c.fragments as f64,
            c.bytes as f64,
            c.atomics,
            c.triangle_passes as f64,
            c.fullscreen_pixels as f64,
        ],
        gpu.median,
    )))
}

/// Fits the model over `results`' runs that have counts and a GPU time.
pub fn fit(results: &Results, weighting: Weighting) -> Result<CostModel, CostModelError> {
    let mut rows = Vec::new();
    let mut names = Vec::new();
    let mut left_out = Vec::new();
    for run in &results.runs {
        match row(run) {
            Ok(Some((x, y))) => {
                for (i, v) in x.iter().chain([&y]).enumerate() {
                    if !v.is_finite() || *v < 0.0 {
                        return Err(CostModelError::BadValue {
                            scene: run.scene.clone(),
                            technique: run.technique_label(),
                            what: TERMS.get(i).map_or("gpu_ms.median", |t| t.name),
                            value: *v,
                        });
                    }
                }
                rows.push((x, y));
                names.push((run.scene.clone(), run.technique_label()));
            }
            Ok(None) => {}
            Err(l) => left_out.push(l),
        }
    }
    let mut model = fit_rows(&rows, &names, weighting).map_err(|e| match e {
        CostModelError::TooFewRuns { runs, terms, .. } => CostModelError::TooFewRuns {
            runs,
            terms,
            skipped: if left_out.is_empty() {
                String::new()
            } else {
                format!(
                    "; {} runs were left out, e.g. {} × {}: {}",
                    left_out.len(),
                    left_out[0].scene,
                    left_out[0].technique,
                    left_out[0].reason
                )
            },
        },
        e => e,
    })?;
    model.adapter = format!(
        "{} ({}, {})",
        results.adapter.name, results.adapter.backend, results.adapter.driver
    );
    model.left_out = left_out;
    Ok(model)
}

/// Fits rows of (counts, ms); `names` are each row's (scene, technique).
pub fn fit_rows(
    rows: &[([f64; 5], f64)],
    names: &[(String, String)],
    weighting: Weighting,
) -> Result<CostModel, CostModelError> {
    let n = rows.len();
    // Relative: each run's row divided by its measured time, so the fit minimises relative
    // residuals (a run measured at 0 ms keeps weight 1).
    let weight = |y: f64| match weighting {
        Weighting::Relative if y > 0.0 => 1.0 / y,
        _ => 1.0,
    };
    // Columns with any work; an all-zero column has no coefficient to fit.
    let present: Vec<usize> = (0..TERMS.len())
        .filter(|&j| rows.iter().any(|(x, _)| x[j] != 0.0))
        .collect();
    if n <= present.len().max(1) {
        return Err(CostModelError::TooFewRuns {
            runs: n,
            terms: present.len().max(1),
            skipped: String::new(),
        });
    }
    // Columns scaled to unit norm: counts span 1 to 1e9, and the tolerances below are then
    // relative.
    let norms: Vec<f64> = present
        .iter()
        .map(|&j| {
            rows.iter()
                .map(|(x, y)| (x[j] * weight(*y)).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    let a: Vec<Vec<f64>> = present
        .iter()
        .zip(&norms)
        .map(|(&j, norm)| rows.iter().map(|(x, y)| x[j] * weight(*y) / norm).collect())
        .collect();
    let y: Vec<f64> = rows.iter().map(|(_, y)| y * weight(*y)).collect();
    let measured: Vec<f64> = rows.iter().map(|(_, y)| *y).collect();
    let all: Vec<usize> = (0..present.len()).collect();
    let unconstrained = solve(&a, &all, &y).map_err(|k| {
        let column = TERMS[present[k]].name;
        let others = present[..k]
            .iter()
            .map(|&j| format!("`{}`", TERMS[j].name))
            .collect::<Vec<_>>();
        CostModelError::Collinear {
            column,
            others: if others.is_empty() {
                "nothing (it is zero)".to_owned()
            } else {
                others.join(", ")
            },
            runs: n,
        }
    })?;
    let constrained = nnls(&a, &y);
    let mut value = [0.0; 5];
    let mut free = [0.0; 5];
    for (k, &j) in present.iter().enumerate() {
        value[j] = constrained[k] / norms[k];
        free[j] = unconstrained[k] / norms[k];
    }
    let predict = |x: &[f64; 5]| x.iter().zip(&value).map(|(x, c)| x * c).sum::<f64>();
    let mean = measured.iter().sum::<f64>() / n as f64;
    let ss_tot: f64 = measured.iter().map(|v| (v - mean).powi(2)).sum();
    let ss_res: f64 = rows.iter().map(|(x, y)| (y - predict(x)).powi(2)).sum();
    let r_squared = if ss_tot > 0.0 {
        1.0 - ss_res / ss_tot
    } else {
        f64::NAN
    };
    let total_predicted: f64 = rows.iter().map(|(x, _)| predict(x)).sum();
    let coefficients = TERMS
        .iter()
        .enumerate()
        .map(|(j, t)| Coefficient {
            term: t.name.to_owned(),
            unit: t.unit.to_owned(),
            value: value[j],
            unconstrained: free[j],
            share: if total_predicted > 0.0 {
                rows.iter().map(|(x, _)| x[j] * value[j]).sum::<f64>() / total_predicted
            } else {
                0.0
            },
        })
        .collect();
    let mut worst: Vec<Residual> = rows
        .iter()
        .zip(names)
        .map(|((x, y), (scene, technique))| Residual {
            scene: scene.clone(),
            technique: technique.clone(),
            measured_ms: *y,
            predicted_ms: predict(x),
        })
        .collect();
    let by_technique = by_technique(&worst);
    let mut relative: Vec<f64> = worst
        .iter()
        .filter(|r| r.measured_ms > 0.0)
        .map(|r| (r.residual_ms() / r.measured_ms).abs())
        .collect();
    relative.sort_by(f64::total_cmp);
    let median_relative_error = relative
        .get(relative.len() / 2)
        .copied()
        .unwrap_or(f64::NAN);
    worst.sort_by(|a, b| b.residual_ms().abs().total_cmp(&a.residual_ms().abs()));
    worst.truncate(WORST);
    Ok(CostModel {
        schema: SCHEMA.to_owned(),
        adapter: String::new(),
        weighting,
        note: TRANSFER_NOTE.to_owned(),
        runs: n,
        coefficients,
        absent_terms: (0..TERMS.len())
            .filter(|j| !present.contains(j))
            .map(|j| TERMS[j].name.to_owned())
            .collect(),
        r_squared,
        median_relative_error,
        worst,
        by_technique,
        left_out: Vec::new(),
    })
}

/// [`TechniqueFit`] per technique name, in first-seen order.
fn by_technique(runs: &[Residual]) -> Vec<TechniqueFit> {
    let mut names: Vec<&str> = Vec::new();
    for r in runs {
        let name = r.technique.split(':').next().unwrap_or(&r.technique);
        if !names.contains(&name) {
            names.push(name);
        }
    }
    names
        .into_iter()
        .filter_map(|name| {
            let mut ratios: Vec<f64> = runs
                .iter()
                .filter(|r| r.technique.split(':').next() == Some(name))
                .filter(|r| r.predicted_ms > 0.0)
                .map(|r| r.measured_ms / r.predicted_ms)
                .collect();
            ratios.sort_by(f64::total_cmp);
            let n = ratios.len();
            let median = match n {
                0 => return None,
                _ if n % 2 == 1 => ratios[n / 2],
                _ => 0.5 * (ratios[n / 2 - 1] + ratios[n / 2]),
            };
            Some(TechniqueFit {
                technique: name.to_owned(),
                runs: n,
                median_ratio: median,
                min_ratio: ratios[0],
                max_ratio: ratios[n - 1],
            })
        })
        .collect()
}

/// Relative size under which a column counts as dependent on the ones before it.
const RANK_TOLERANCE: f64 = 1e-9;

/// Least squares over the columns `cols` of `a` (column-major) by Householder QR; `Err(k)`
/// when column `cols[k]` depends linearly on the ones before it.
fn solve(a: &[Vec<f64>], cols: &[usize], y: &[f64]) -> Result<Vec<f64>, usize> {
    let m = y.len();
    let p = cols.len();
    let mut r: Vec<Vec<f64>> = cols.iter().map(|&j| a[j].clone()).collect();
    let mut qty = y.to_vec();
    for k in 0..p {
        let scale: f64 = r[k].iter().map(|v| v * v).sum::<f64>().sqrt();
        let norm: f64 = r[k][k..].iter().map(|v| v * v).sum::<f64>().sqrt();
        if m <= k || norm <= RANK_TOLERANCE * scale.max(f64::MIN_POSITIVE) || scale == 0.0 {
            return Err(k);
        }
        let alpha = if r[k][k] > 0.0 { -norm } else { norm };
        let mut v: Vec<f64> = r[k][k..].to_vec();
        v[0] -= alpha;
        let vv: f64 = v.iter().map(|x| x * x).sum();
        if vv > 0.0 {
            let reflect = |col: &mut [f64]| {
                let dot: f64 = col.iter().zip(&v).map(|(c, v)| c * v).sum();
                let f = 2.0 * dot / vv;
                for (c, v) in col.iter_mut().zip(&v) {
                    *c -= f * v;
                }
            };
            for col in r.iter_mut().skip(k) {
                reflect(&mut col[k..]);
            }
            reflect(&mut qty[k..]);
        }
    }
    let mut x = vec![0.0; p];
    for k in (0..p).rev() {
        let s: f64 = (k + 1..p).map(|j| r[j][k] * x[j]).sum();
        x[k] = (qty[k] - s) / r[k][k];
    }
    Ok(x)
}

/// Non-negative least squares (Lawson & Hanson 1974, the active-set method) over every
/// column of `a` (column-major, full column rank: checked by the caller's unconstrained solve).
fn nnls(a: &[Vec<f64>], y: &[f64]) -> Vec<f64> {
    let p = a.len();
    let mut x = vec![0.0; p];
    let mut passive: Vec<usize> = Vec::new();
    let gradient = |x: &[f64]| -> Vec<f64> {
        let residual: Vec<f64> = (0..y.len())
            .map(|i| y[i] - (0..p).map(|j| a[j][i] * x[j]).sum::<f64>())
            .collect();
        (0..p)
            .map(|j| a[j].iter().zip(&residual).map(|(a, r)| a * r).sum())
            .collect()
    };
    let tolerance = 1e-12 * y.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-300);
    for _ in 0..3 * p + 10 {
        let w = gradient(&x);
        let candidate = (0..p)
            .filter(|j| !passive.contains(j))
            .filter(|&j| w[j] > tolerance)
            .max_by(|&i, &j| w[i].total_cmp(&w[j]));
        let Some(j) = candidate else { break };
        passive.push(j);
        loop {
            let Ok(z) = solve(a, &passive, y) else {
                // A subset of full-rank columns is full rank; kept for safety.
                passive.pop();
                return x;
            };
            if z.iter().all(|&v| v > 0.0) {
                for (k, &j) in passive.iter().enumerate() {
                    x[j] = z[k];
                }
                break;
            }
            // Step toward z until the first passive coefficient reaches 0, and drop it.
            let mut step = f64::INFINITY;
            for (k, &j) in passive.iter().enumerate() {
                if z[k] <= 0.0 {
                    let d = x[j] - z[k];
                    step = step.min(if d > 0.0 { x[j] / d } else { 0.0 });
                }
            }
            for (k, &j) in passive.iter().enumerate() {
                x[j] += step * (z[k] - x[j]);
            }
            passive.retain(|&j| x[j] > tolerance);
            for (j, v) in x.iter_mut().enumerate() {
                if !passive.contains(&j) {
                    *v = 0.0;
                }
            }
            if passive.is_empty() {
                break;
            }
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-random numbers in [0, 1).
    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    fn names(n: usize) -> Vec<(String, String)> {
        (0..n).map(|i| (format!("s{i}"), "t".to_owned())).collect()
    }

    /// Counts of the magnitudes a suite has (fragments 1e4–1e6, bytes ×8–×200 of them, …).
    fn synthetic(n: usize, seed: u64) -> Vec<[f64; 5]> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                let fragments = 1e4 + 1e6 * lcg(&mut s);
                [
                    fragments,
                    fragments * (8.0 + 200.0 * lcg(&mut s)),
                    fragments * 3.0 * lcg(&mut s),
                    2e3 + 5e5 * lcg(&mut s),
                    65536.0 * (1.0 + (4.0 * lcg(&mut s)).floor()),
                ]
            })
            .collect()
    }

    const KNOWN: [f64; 5] = [2e-6, 3e-8, 5e-7, 1e-5, 4e-6];

    #[test]
    fn recovers_known_coefficients_from_exact_data() {
        let xs = synthetic(40, 7);
        let rows: Vec<_> = xs
            .iter()
            .map(|x| (*x, x.iter().zip(KNOWN).map(|(x, c)| x * c).sum()))
            .collect();
        for weighting in [Weighting::Absolute, Weighting::Relative] {
            let m = fit_rows(&rows, &names(rows.len()), weighting).unwrap();
            for (c, want) in m.coefficients.iter().zip(KNOWN) {
                assert!(
                    (c.value - want).abs() <= 1e-9 * want,
                    "{}: {} vs {want}",
                    c.term,
                    c.value
                );
                assert!((c.unconstrained - want).abs() <= 1e-9 * want);
            }
            assert!((m.r_squared - 1.0).abs() < 1e-12, "{}", m.r_squared);
            assert!(m.worst[0].residual_ms().abs() < 1e-9);
            let shares: f64 = m.coefficients.iter().map(|c| c.share).sum();
            assert!((shares - 1.0).abs() < 1e-9);
            assert!(m.median_relative_error < 1e-9);
        }
    }

    #[test]
    fn recovers_them_within_noise_and_names_the_worst_run() {
        let xs = synthetic(200, 11);
        let mut s = 99u64;
        let mut rows: Vec<_> = xs
            .iter()
            .map(|x| {
                let t: f64 = x.iter().zip(KNOWN).map(|(x, c)| x * c).sum();
                (*x, t * (1.0 + 0.01 * (lcg(&mut s) - 0.5)))
            })
            .collect();
        // One run far off the model: the worst residual.
        rows[17].1 += 500.0;
        let m = fit_rows(&rows, &names(rows.len()), Weighting::Absolute).unwrap();
        assert_eq!(m.worst[0].scene, "s17");
        assert!(m.worst[0].residual_ms() > 400.0);
        let clean: Vec<_> = rows
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != 17)
            .map(|(_, r)| *r)
            .collect();
        let m = fit_rows(&clean, &names(clean.len()), Weighting::Relative).unwrap();
        for (c, want) in m.coefficients.iter().zip(KNOWN) {
            assert!(
                (c.value - want).abs() <= 0.05 * want,
                "{}: {} vs {want}",
                c.term,
                c.value
            );
        }
        assert!(m.r_squared > 0.99);
        assert_eq!(m.by_technique.len(), 1);
        assert_eq!(m.by_technique[0].runs, 199);
        let t = &m.by_technique[0];
        assert!((t.median_ratio - 1.0).abs() < 0.01, "{t:?}");
        assert!(t.min_ratio <= t.median_ratio && t.median_ratio <= t.max_ratio);
    }

    #[test]
    fn a_negative_unconstrained_coefficient_is_held_at_zero() {
        // Time falls with atomics in the data: least squares says so, NNLS holds it at 0.
        let xs = synthetic(30, 3);
        let rows: Vec<_> = xs
            .iter()
            .map(|x| (*x, 2e-6 * x[0] + 1e-5 * x[3] - 1e-7 * x[2]))
            .collect();
        let m = fit_rows(&rows, &names(rows.len()), Weighting::Absolute).unwrap();
        assert!(m.coefficients[2].unconstrained < 0.0);
        assert_eq!(m.coefficients[2].value, 0.0);
        assert!(m.coefficients.iter().all(|c| c.value >= 0.0));
    }

    #[test]
    fn collinear_columns_are_an_error_naming_them() {
        // Bytes exactly 16 per fragment in every run.
        let rows: Vec<_> = synthetic(20, 5)
            .into_iter()
            .map(|mut x| {
                x[1] = 16.0 * x[0];
                (x, 1.0)
            })
            .collect();
        let e = fit_rows(&rows, &names(rows.len()), Weighting::Absolute).unwrap_err();
        assert!(
            matches!(
                e,
                CostModelError::Collinear {
                    column: "bytes",
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("`fragments`"), "{e}");
    }

    #[test]
    fn too_few_runs_are_an_error() {
        let rows: Vec<_> = synthetic(5, 1).into_iter().map(|x| (x, 1.0)).collect();
        let e = fit_rows(&rows, &names(5), Weighting::Relative).unwrap_err();
        assert!(
            matches!(
                e,
                CostModelError::TooFewRuns {
                    runs: 5,
                    terms: 5,
                    ..
                }
            ),
            "{e}"
        );
        let e = fit_rows(&[], &[], Weighting::Relative).unwrap_err();
        assert!(e.to_string().contains("0 runs"), "{e}");
    }

    /// A results file's runs: those with counts are fitted, the others left out with why.
    #[test]
    fn fits_a_results_file_and_says_which_runs_it_left_out() {
        let mut runs = Vec::new();
        for (i, x) in synthetic(9, 4).iter().enumerate() {
            let ms: f64 = x.iter().zip(KNOWN).map(|(x, c)| x * c).sum();
            runs.push(serde_json::json!({
                "scene": format!("s{i}"), "scene_file": "s.json", "technique": "t",
                "resolution": [8, 8], "status": "ok",
                "gpu_ms": {"median": ms, "min": ms, "max": ms, "frames": 1, "source": "timestamp"},
                "counts": {"fragments": x[0] as u64, "bytes": x[1] as u64, "atomics": x[2],
                    "triangle_passes": x[3] as u64, "geometry_passes": 2, "fullscreen_passes": 1,
                    "fullscreen_pixels": x[4] as u64}
            }));
        }
        runs.push(serde_json::json!({
            "scene": "old", "scene_file": "s.json", "technique": "t", "resolution": [8, 8],
            "status": "ok",
            "gpu_ms": {"median": 1.0, "min": 1.0, "max": 1.0, "frames": 1, "source": "timestamp"}
        }));
        let mut undeclared = runs[0].clone();
        undeclared["scene"] = "undeclared".into();
        undeclared["counts"]["undeclared_passes"] = serde_json::json!(["mystery"]);
        runs.push(undeclared);
        runs.push(serde_json::json!({
            "scene": "skipped", "scene_file": "s.json", "technique": "t", "resolution": [8, 8],
            "status": "skipped", "reason": "unsupported"
        }));
        let file = serde_json::json!({
            "schema": crate::SCHEMA,
            "adapter": {"name": "llvmpipe", "backend": "vulkan", "device_type": "cpu",
                "driver": "Mesa"},
            "runs": runs
        });
        let results: Results = serde_json::from_value(file).unwrap();
        let m = fit(&results, Weighting::Relative).unwrap();
        assert_eq!(m.runs, 9);
        assert_eq!(m.adapter, "llvmpipe (vulkan, Mesa)");
        let left: Vec<&str> = m.left_out.iter().map(|l| l.scene.as_str()).collect();
        assert_eq!(left, ["old", "undeclared"]);
        assert!(m.left_out[1].reason.contains("mystery"));
        assert!(m.note.contains("refit"));
        for (c, want) in m.coefficients.iter().zip(KNOWN) {
            // The counts were rounded to integers, the times not.
            assert!(
                (c.value - want).abs() <= 1e-4 * want,
                "{}: {}",
                c.term,
                c.value
            );
        }
        // Too few runs after leaving some out: the error says which were left out.
        let mut few = results.clone();
        few.runs.drain(..6);
        let e = fit(&few, Weighting::Absolute).unwrap_err().to_string();
        assert!(
            e.contains("3 runs") && e.contains("2 runs were left out"),
            "{e}"
        );
    }

    #[test]
    fn an_absent_term_is_not_fitted() {
        let rows: Vec<_> = synthetic(12, 2)
            .into_iter()
            .map(|mut x| {
                x[2] = 0.0;
                (x, x[0] * 1e-6 + x[4] * 1e-6)
            })
            .collect();
        let m = fit_rows(&rows, &names(12), Weighting::Relative).unwrap();
        assert_eq!(m.absent_terms, vec!["atomics".to_owned()]);
        assert_eq!(m.coefficients[2].value, 0.0);
        assert!((m.coefficients[0].value - 1e-6).abs() < 1e-12);
    }
}
