//! The committed goldens in `reference/`: the exact CPU reference of every bundled scene at
//! 64×64, bit for bit, and a baseline of every technique's default configuration's error
//! against it, valid on the adapter that recorded it.
//!
//! `cargo xtask goldens` writes them ([`generate`], then [`write`]); the test
//! `tests/gpu/harness/goldens.rs` checks them ([`bit_mismatches`], [`check_run`]).
//! Everything is computed before anything is written, so a failed generation leaves the
//! previous goldens untouched.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use oit_gpu::{Context, TechniqueSpec};
use oit_reference::Reference;
use oit_scene::{LinearImage, Resolution, Scene};
use serde::{Deserialize, Serialize};

use crate::results::{AdapterJson, RunStatus};
use crate::{HarnessError, SceneEntry, file_stem, registry};

/// Schema of `baseline.json`.
pub const SCHEMA: &str = "oit-lab/goldens/v1";
/// Small enough that 15 scenes stay a few hundred kB in git and the check takes seconds in a
/// debug build; large enough that every scene still shows its hard case.
pub const RESOLUTION: Resolution = Resolution {
    width: 64,
    height: 64,
};
pub const BASELINE_FILE: &str = "baseline.json";
pub const README_FILE: &str = "README.md";
/// The EXR part [`crate::write_reference_exr`] writes.
const EXR_LAYER: &str = "reference";

/// How far a technique's error may move from the baseline before the test fails:
/// `|actual − baseline| ≤ max(absolute, relative · |baseline|)`, per metric.
///
/// Why this loose: on the adapter that recorded the baseline every technique is deterministic
/// (on lavapipe, three generations in a row, from a debug and a release build, wrote
/// byte-identical `baseline.json` files: run-to-run noise is zero), so any movement at all is a
/// code change. The slack lets changes that only reorder float
/// arithmetic (a shader refactor, a different summation order) pass, while a real change of a
/// technique's answer moves RMSE or FLIP by far more than 5 %.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    pub relative: f64,
    /// Floor for RMSE: a uniform 1e-4 shift is below one 8-bit step.
    pub rmse: f64,
    /// Floor for max error: about one f16 step at 1.0 (2⁻¹⁰ ≈ 9.8e-4) in the Rgba16Float
    /// target, since a single pixel rounding the other way moves it by that much.
    pub max_abs: f64,
    /// Floor for FLIP: means of 4096 pixels; 1e-4 is far below a visible change.
    pub flip: f64,
}

/// The tolerance the golden test applies.
pub const TOLERANCE: Tolerance = Tolerance {
    relative: 0.05,
    rmse: 1e-4,
    max_abs: 1e-3,
    flip: 1e-4,
};

/// `baseline.json`: what the goldens were made with and every technique's error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Baseline {
    pub schema: String,
    /// [`oit_reference::OUTPUT_VERSION`] of the build that wrote the EXRs.
    pub reference_output_version: u32,
    pub resolution: [u32; 2],
    /// The adapter the errors were measured on; they are only checked on the same one.
    pub adapter: AdapterJson,
    /// The final colour target every technique rendered into.
    pub target_format: String,
    pub scenes: Vec<GoldenScene>,
    pub runs: Vec<BaselineRun>,
}

/// One golden reference.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GoldenScene {
    pub name: String,
    pub scene_file: String,
    /// File name inside the goldens folder.
    pub exr: String,
}

/// One technique's default configuration on one scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaselineRun {
    pub scene: String,
    /// Canonical spec.
    pub technique: String,
    /// `ok` or `skipped` (the adapter cannot run it; `reason` says why).
    pub status: RunStatus,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<BaselineError>,
}

/// The error numbers the baseline keeps (see oit-metrics for their definitions).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaselineError {
    pub rmse: f64,
    pub max_abs: f64,
    /// [`oit_metrics::Errors::headline_flip`].
    pub flip: f64,
    /// `LDR-FLIP` or `HDR-FLIP`.
    pub flip_kind: String,
}

impl BaselineError {
    pub fn of(errors: &oit_metrics::Errors) -> Self {
        let (flip, kind) = errors.headline_flip();
        BaselineError {
            rmse: errors.rmse,
            max_abs: errors.max_abs,
            flip,
            flip_kind: kind.to_owned(),
        }
    }
}

/// A golden reference as stored: RGBA and the two per-pixel counts, all f32.
#[derive(Debug, Clone, PartialEq)]
pub struct Golden {
    pub image: LinearImage,
    pub layers: Vec<f32>,
    pub fragments: Vec<f32>,
}

impl Golden {
    /// What [`crate::write_reference_exr`] stores of a reference (counts as f32, exact below 2²⁴).
    pub fn of(reference: &Reference) -> Self {
        let to_f32 = |v: &[u32]| v.iter().map(|&x| x as f32).collect();
        Golden {
            image: reference.image.clone(),
            layers: to_f32(&reference.layers),
            fragments: to_f32(&reference.fragments),
        }
    }
}

/// The scene at the goldens' resolution.
pub fn golden_scene(scene: &Scene) -> Scene {
    crate::at_resolution(scene, Some(RESOLUTION))
}

/// The reference of a scene at the goldens' resolution, computed now (never from a cache).
pub fn render_reference(scene: &Scene) -> Result<Reference, HarnessError> {
    Ok(oit_reference::try_render(
        &golden_scene(scene),
        &oit_reference::ReferenceOptions::default(),
    )?)
}

/// The golden EXR's file name for a scene.
pub fn exr_name(scene_name: &str) -> String {
    format!("{}.exr", file_stem(scene_name))
}

/// Reads a golden EXR written by [`write`].
pub fn read_golden(path: &Path) -> Result<Golden, HarnessError> {
    let image = oit_metrics::read_exr_rgba(path, Some(EXR_LAYER))?;
    let layers = oit_metrics::read_exr_channel(path, Some(EXR_LAYER), "layers")?.samples;
    let fragments = oit_metrics::read_exr_channel(path, Some(EXR_LAYER), "fragments")?.samples;
    Ok(Golden {
        image,
        layers,
        fragments,
    })
}

/// Reads `baseline.json`, checking its schema.
pub fn read_baseline(path: &Path) -> Result<Baseline, HarnessError> {
    let text = std::fs::read_to_string(path).map_err(|e| HarnessError::io(path, e))?;
    let baseline: Baseline = serde_json::from_str(&text).map_err(|e| HarnessError::Invalid {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    if baseline.schema != SCHEMA {
        return Err(HarnessError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "schema is `{}`; this build reads `{SCHEMA}`",
                baseline.schema
            ),
        });
    }
    Ok(baseline)
}

/// One sample whose bits differ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BitMismatch {
    pub x: u32,
    pub y: u32,
    /// `R`, `G`, `B`, `A`, `layers` or `fragments`.
    pub channel: &'static str,
    pub expected: f32,
    pub actual: f32,
}

impl std::fmt::Display for BitMismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "({}, {}) {}: expected {:e} ({:#010x}), got {:e} ({:#010x})",
            self.x,
            self.y,
            self.channel,
            self.expected,
            self.expected.to_bits(),
            self.actual,
            self.actual.to_bits()
        )
    }
}

/// Every sample of `actual` whose f32 bits differ from `expected` (NaN payloads included), in
/// row-major order, channels R, G, B, A, layers, fragments per pixel. Different sizes are an
/// error, not a list.
pub fn bit_mismatches(expected: &Golden, actual: &Golden) -> Result<Vec<BitMismatch>, String> {
    let (w, h) = (expected.image.width, expected.image.height);
    let n = w as usize * h as usize;
    let sizes = |g: &Golden| {
        (
            g.image.width,
            g.image.height,
            g.image.pixels.len(),
            g.layers.len(),
            g.fragments.len(),
        )
    };
    if sizes(expected) != (w, h, n, n, n) || sizes(actual) != sizes(expected) {
        return Err(format!(
            "sizes differ: expected {:?}, got {:?} (width, height, pixels, layers, fragments)",
            sizes(expected),
            sizes(actual)
        ));
    }
    const RGBA: [&str; 4] = ["R", "G", "B", "A"];
    let mut out = Vec::new();
    for i in 0..n {
        let (x, y) = ((i % w as usize) as u32, (i / w as usize) as u32);
        let samples = (0..4)
            .map(|c| {
                (
                    RGBA[c],
                    expected.image.pixels[i][c],
                    actual.image.pixels[i][c],
                )
            })
            .chain([
                ("layers", expected.layers[i], actual.layers[i]),
                ("fragments", expected.fragments[i], actual.fragments[i]),
            ]);
        for (channel, e, a) in samples {
            if e.to_bits() != a.to_bits() {
                out.push(BitMismatch {
                    x,
                    y,
                    channel,
                    expected: e,
                    actual: a,
                });
            }
        }
    }
    Ok(out)
}

/// Why the baseline's errors do not apply to `current`, or `None` when it is the adapter that
/// recorded them (same name, backend and driver: another driver version may rasterize or round
/// differently, which is not a technique regression).
pub fn adapter_mismatch(recorded: &AdapterJson, current: &AdapterJson) -> Option<String> {
    let fields = [
        ("name", &recorded.name, &current.name),
        ("backend", &recorded.backend, &current.backend),
        ("driver", &recorded.driver, &current.driver),
    ];
    let differ: Vec<String> = fields
        .iter()
        .filter(|(_, r, c)| r != c)
        .map(|(k, r, c)| format!("{k} {c:?} (baseline: {r:?})"))
        .collect();
    (!differ.is_empty()).then(|| format!("this adapter differs in {}", differ.join(", ")))
}

/// What moved between a baseline run and the same run now, one message per problem (empty
/// when within [`Tolerance`]).
pub fn check_run(expected: &BaselineRun, actual: &BaselineRun, tol: &Tolerance) -> Vec<String> {
    let what = format!("{} {}", expected.scene, expected.technique);
    if expected.status != actual.status {
        return vec![format!(
            "{what}: status {:?} (baseline: {:?}){}",
            actual.status,
            expected.status,
            actual
                .reason
                .as_deref()
                .map(|r| format!(", reason: {r}"))
                .unwrap_or_default()
        )];
    }
    let (Some(e), Some(a)) = (&expected.error, &actual.error) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    if e.flip_kind != a.flip_kind {
        out.push(format!(
            "{what}: headline FLIP is {} (baseline: {})",
            a.flip_kind, e.flip_kind
        ));
    }
    for (name, base, now, floor) in [
        ("RMSE", e.rmse, a.rmse, tol.rmse),
        ("max error", e.max_abs, a.max_abs, tol.max_abs),
        ("FLIP", e.flip, a.flip, tol.flip),
    ] {
        let allowed = floor.max(tol.relative * base.abs());
        let delta = (now - base).abs();
        // A NaN error (or baseline) is never within tolerance.
        if delta.is_nan() || delta > allowed {
            out.push(format!(
                "{what}: {name} {now:.6e} (baseline {base:.6e}, |Δ| {delta:.3e} > allowed {allowed:.3e})"
            ));
        }
    }
    out
}

/// Renders one technique on a scene (already at the goldens' resolution) the way the baseline
/// does — one frame after a warm-up frame into an Rgba16Float target — and measures it against
/// `reference`. Returns the run and the rendered image (`None` when skipped).
pub fn measure(
    ctx: &Context,
    scene: &Scene,
    spec: &TechniqueSpec,
    reference: &LinearImage,
) -> Result<(BaselineRun, Option<LinearImage>), HarnessError> {
    let canonical = spec.canonical();
    let technique = TechniqueSpec::build(&canonical, &registry())?;
    if let Err(unsupported) = oit_gpu::check_scene(technique.as_ref(), &ctx.caps, scene) {
        let run = BaselineRun {
            scene: scene.name.clone(),
            technique: canonical,
            status: RunStatus::Skipped,
            reason: Some(unsupported.reason),
            error: None,
        };
        return Ok((run, None));
    }
    let frame = crate::render_once(ctx, scene, spec)?;
    let errors = oit_metrics::compare(&frame.image, reference)?;
    let run = BaselineRun {
        scene: scene.name.clone(),
        technique: canonical,
        status: RunStatus::Ok,
        reason: None,
        error: Some(BaselineError::of(&errors)),
    };
    Ok((run, Some(frame.image)))
}

/// Goldens computed in memory, ready for [`write`].
#[derive(Debug, Clone)]
pub struct Goldens {
    pub baseline: Baseline,
    /// One per `baseline.scenes`, same order.
    pub references: Vec<Reference>,
}

/// Computes the reference of every scene and every technique's default configuration against
/// it on `ctx`'s adapter. Fails, writing nothing, if a scene name repeats or a run fails.
pub fn generate(
    ctx: &Context,
    scenes: &[SceneEntry],
    progress: &dyn Fn(&str),
) -> Result<Goldens, HarnessError> {
    let specs = crate::resolve_specs(&[])?;
    let mut baseline = Baseline {
        schema: SCHEMA.to_owned(),
        reference_output_version: oit_reference::OUTPUT_VERSION,
        resolution: [RESOLUTION.width, RESOLUTION.height],
        adapter: crate::results::adapter_json(ctx),
        target_format: "rgba16float".to_owned(),
        scenes: Vec::new(),
        runs: Vec::new(),
    };
    let mut references = Vec::new();
    for entry in scenes {
        let exr = exr_name(&entry.scene.name);
        if let Some(other) = baseline.scenes.iter().find(|s| s.exr == exr) {
            return Err(HarnessError::Invalid {
                path: entry.path.clone(),
                message: format!(
                    "scene name {:?} gives the golden file {exr}, as {} does; scene names must differ",
                    entry.scene.name, other.scene_file
                ),
            });
        }
        let scene = golden_scene(&entry.scene);
        let reference = render_reference(&entry.scene)?;
        progress(&format!("{} reference", scene.name));
        for spec in &specs {
            let (run, _) = measure(ctx, &scene, spec, &reference.image).map_err(|e| {
                HarnessError::Invalid {
                    path: entry.path.clone(),
                    message: format!("{} failed: {e}", spec.canonical()),
                }
            })?;
            progress(&format!("{} {}", scene.name, run.technique));
            baseline.runs.push(run);
        }
        baseline.scenes.push(GoldenScene {
            name: entry.scene.name.clone(),
            scene_file: entry.path.display().to_string(),
            exr,
        });
        references.push(reference);
    }
    Ok(Goldens {
        baseline,
        references,
    })
}

/// Writes the goldens into `dir`: one EXR per scene, `baseline.json` and `README.md` (each
/// atomically), and removes EXRs of scenes that are gone.
pub fn write(dir: &Path, goldens: &Goldens) -> Result<(), HarnessError> {
    std::fs::create_dir_all(dir).map_err(|e| HarnessError::io(dir, e))?;
    let mut exr_bytes = 0u64;
    for (scene, reference) in goldens.baseline.scenes.iter().zip(&goldens.references) {
        let path = dir.join(&scene.exr);
        crate::write_reference_exr(&path, reference)?;
        exr_bytes += std::fs::metadata(&path)
            .map_err(|e| HarnessError::io(&path, e))?
            .len();
    }
    for entry in std::fs::read_dir(dir).map_err(|e| HarnessError::io(dir, e))? {
        let path = entry.map_err(|e| HarnessError::io(dir, e))?.path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let stale =
            name.ends_with(".exr") && !goldens.baseline.scenes.iter().any(|s| s.exr == name);
        if stale {
            std::fs::remove_file(&path).map_err(|e| HarnessError::io(&path, e))?;
        }
    }
    let json = serde_json::to_vec_pretty(&goldens.baseline).expect("baseline serializes");
    oit_metrics::write_atomic_bytes(&dir.join(BASELINE_FILE), &json)?;
    oit_metrics::write_atomic_bytes(
        &dir.join(README_FILE),
        readme(&goldens.baseline, exr_bytes).as_bytes(),
    )?;
    Ok(())
}

/// The goldens folder's README: what the files are, how they are checked, and the baseline as
/// three scene × technique tables.
pub fn readme(baseline: &Baseline, exr_bytes: u64) -> String {
    let a = &baseline.adapter;
    let [w, h] = baseline.resolution;
    let t = TOLERANCE;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Goldens\n\n\
         Written by `cargo xtask goldens`; do not edit by hand. Checked by \
         `tests/gpu/harness/goldens.rs`, part of `cargo test --workspace`.\n\n\
         - `SCENE.exr` ({n} files, {exr_bytes} bytes in all): the exact CPU reference \
         (`oit_reference`, `OUTPUT_VERSION` {v}) of every bundled scene at {w}×{h}, part \
         `reference`: linear f32 `R`, `G`, `B`, `A` and the per-pixel counts `layers` and \
         `fragments`. The test renders every scene again and fails if one bit of one sample \
         differs.\n\
         - `{BASELINE_FILE}` (schema `{SCHEMA}`): every technique at its defaults (what \
         `oit compare` runs without `--technique`), one frame after a warm-up frame into an \
         {fmt} target, against these references, on **{name}** ({backend}, {device}, driver \
         `{driver}`). The test checks it only on that adapter (on any other it says so and \
         skips that part): it fails when RMSE, max error or FLIP moves by more than \
         max(floor, {rel} % of the baseline), with floors {rmse:e} (RMSE), {max:e} (max \
         error: one f16 step at 1.0) and {flip:e} (FLIP), or when a technique's status \
         changes.\n\n\
         After an intended change to the reference (bump `oit_reference::OUTPUT_VERSION`) or \
         to a technique's output, run `cargo xtask goldens` and commit the result.\n",
        n = baseline.scenes.len(),
        v = baseline.reference_output_version,
        fmt = baseline.target_format,
        name = a.name,
        backend = a.backend,
        device = a.device_type,
        driver = a.driver,
        rel = t.relative * 100.0,
        rmse = t.rmse,
        max = t.max_abs,
        flip = t.flip,
    );
    let mut techniques: Vec<&str> = Vec::new();
    for run in &baseline.runs {
        if !techniques.contains(&run.technique.as_str()) {
            techniques.push(&run.technique);
        }
    }
    let short = |t: &str| t.split(':').next().unwrap_or(t).to_owned();
    let _ = writeln!(
        out,
        "Columns are technique names; their default configurations:\n"
    );
    for t in &techniques {
        let _ = writeln!(out, "- `{}`: `{t}`", short(t));
    }
    type Cell = fn(&BaselineError) -> String;
    let tables: [(&str, Cell); 3] = [
        ("RMSE", |e| crate::report::sci(e.rmse)),
        ("Max error", |e| crate::report::sci(e.max_abs)),
        ("FLIP (HDR-FLIP where marked HDR)", |e| {
            let hdr = if e.flip_kind == "HDR-FLIP" {
                " HDR"
            } else {
                ""
            };
            format!("{}{hdr}", crate::report::sci(e.flip))
        }),
    ];
    for (title, cell) in tables {
        let _ = writeln!(out, "\n## {title}\n");
        let names: Vec<String> = techniques.iter().map(|t| short(t)).collect();
        let _ = writeln!(out, "| scene | {} |", names.join(" | "));
        let _ = writeln!(out, "|---|{}", "---:|".repeat(techniques.len()));
        for scene in &baseline.scenes {
            let cells: Vec<String> = techniques
                .iter()
                .map(|t| {
                    match baseline
                        .runs
                        .iter()
                        .find(|r| r.scene == scene.name && r.technique == *t)
                    {
                        Some(BaselineRun { error: Some(e), .. }) => cell(e),
                        Some(_) => "skipped".to_owned(),
                        None => "–".to_owned(),
                    }
                })
                .collect();
            let _ = writeln!(out, "| {} | {} |", scene.name, cells.join(" | "));
        }
    }
    let skipped: Vec<&BaselineRun> = baseline
        .runs
        .iter()
        .filter(|r| r.status != RunStatus::Ok)
        .collect();
    if !skipped.is_empty() {
        let _ = writeln!(out, "\n## Skipped on this adapter\n");
        for r in skipped {
            let _ = writeln!(
                out,
                "- {} `{}`: {}",
                r.scene,
                r.technique,
                r.reason.as_deref().unwrap_or("")
            );
        }
    }
    out
}

/// Writes `STEM-expected`, `STEM-actual` and `STEM-diff` (per-channel |actual − expected|) as
/// linear EXRs, their PNG previews (the diff as the log-scale heat map), and
/// `STEM-bits.png` (white where any RGBA bit differs) into `dir`; returns the paths.
pub fn write_failure_images(
    dir: &Path,
    stem: &str,
    expected: &LinearImage,
    actual: &LinearImage,
) -> Result<Vec<PathBuf>, HarnessError> {
    std::fs::create_dir_all(dir).map_err(|e| HarnessError::io(dir, e))?;
    let diff = oit_metrics::diff_image(actual, expected)?;
    let mut paths = Vec::new();
    for (suffix, image) in [("expected", expected), ("actual", actual), ("diff", &diff)] {
        let path = dir.join(format!("{stem}-{suffix}.exr"));
        oit_metrics::write_exr(&path, &[oit_metrics::ExrLayer::new("", image)])?;
        paths.push(path);
    }
    for (suffix, image) in [("expected", expected), ("actual", actual)] {
        let path = dir.join(format!("{stem}-{suffix}.png"));
        oit_metrics::write_png_preview(&path, image)?;
        paths.push(path);
    }
    let path = dir.join(format!("{stem}-diff.png"));
    oit_metrics::write_png_srgb8(&path, &oit_metrics::heatmap(actual, expected)?)?;
    paths.push(path);
    let bits = oit_metrics::Srgb8Image {
        width: expected.width,
        height: expected.height,
        pixels: expected
            .pixels
            .iter()
            .zip(&actual.pixels)
            .map(|(e, a)| {
                let same = e.iter().zip(a).all(|(e, a)| e.to_bits() == a.to_bits());
                if same { [0; 3] } else { [255; 3] }
            })
            .collect(),
    };
    let path = dir.join(format!("{stem}-bits.png"));
    oit_metrics::write_png_srgb8(&path, &bits)?;
    paths.push(path);
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(rmse: f64, max_abs: f64, flip: f64) -> BaselineRun {
        BaselineRun {
            scene: "s".into(),
            technique: "t".into(),
            status: RunStatus::Ok,
            reason: None,
            error: Some(BaselineError {
                rmse,
                max_abs,
                flip,
                flip_kind: "LDR-FLIP".into(),
            }),
        }
    }

    #[test]
    fn runs_within_tolerance_pass_and_beyond_it_fail() {
        let base = run(0.1, 0.5, 0.2);
        assert!(check_run(&base, &base, &TOLERANCE).is_empty());
        // 4 % is inside the relative band, 6 % is not.
        assert!(check_run(&base, &run(0.104, 0.5, 0.2), &TOLERANCE).is_empty());
        let moved = check_run(&base, &run(0.106, 0.5, 0.2), &TOLERANCE);
        assert_eq!(moved.len(), 1, "{moved:?}");
        assert!(moved[0].contains("RMSE"), "{moved:?}");
        // Near zero the absolute floor decides: 0 → 9e-5 passes, 0 → 2e-4 fails.
        let exact = run(0.0, 0.0, 0.0);
        assert!(check_run(&exact, &run(9e-5, 9e-4, 9e-5), &TOLERANCE).is_empty());
        assert_eq!(
            check_run(&exact, &run(2e-4, 2e-3, 2e-4), &TOLERANCE).len(),
            3
        );
        // NaN is never within tolerance.
        assert_eq!(
            check_run(&base, &run(f64::NAN, 0.5, 0.2), &TOLERANCE).len(),
            1
        );
    }

    #[test]
    fn status_and_flip_kind_changes_fail() {
        let base = run(0.1, 0.5, 0.2);
        let skipped = BaselineRun {
            status: RunStatus::Skipped,
            reason: Some("no float blending".into()),
            error: None,
            ..base.clone()
        };
        let msg = check_run(&base, &skipped, &TOLERANCE);
        assert!(
            msg.len() == 1 && msg[0].contains("no float blending"),
            "{msg:?}"
        );
        let mut hdr = base.clone();
        hdr.error.as_mut().unwrap().flip_kind = "HDR-FLIP".into();
        assert_eq!(check_run(&base, &hdr, &TOLERANCE).len(), 1);
    }

    #[test]
    fn adapters_match_on_name_backend_and_driver() {
        let a = AdapterJson {
            name: "llvmpipe".into(),
            backend: "vulkan".into(),
            device_type: "cpu".into(),
            driver: "Mesa 22.3.6".into(),
        };
        assert_eq!(adapter_mismatch(&a, &a), None);
        let b = AdapterJson {
            driver: "Mesa 24.0".into(),
            ..a.clone()
        };
        let why = adapter_mismatch(&a, &b).unwrap();
        assert!(
            why.contains("Mesa 24.0") && why.contains("Mesa 22.3.6"),
            "{why}"
        );
    }

    #[test]
    fn bit_comparison_sees_sizes_and_every_channel() {
        let golden = Golden {
            image: LinearImage::new(3, 2, [0.25, 0.5, 0.75, 1.0]),
            layers: vec![1.0; 6],
            fragments: vec![2.0; 6],
        };
        assert_eq!(bit_mismatches(&golden, &golden), Ok(Vec::new()));
        let mut other = golden.clone();
        other.fragments[4] = 3.0;
        // −0.0 and 0.0 compare equal as floats but not as bits.
        other.image.pixels[0][3] = -0.0;
        let mut zero = golden.clone();
        zero.image.pixels[0][3] = 0.0;
        let found = bit_mismatches(&zero, &other).unwrap();
        assert_eq!(
            found
                .iter()
                .map(|m| (m.x, m.y, m.channel))
                .collect::<Vec<_>>(),
            [(0, 0, "A"), (1, 1, "fragments")]
        );
        let mut small = golden.clone();
        small.image = LinearImage::new(2, 3, [0.0; 4]);
        assert!(bit_mismatches(&golden, &small).is_err());
    }
}
