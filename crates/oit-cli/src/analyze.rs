//! `oit analyze`: what each scene asks of a technique, from the reference's fragment lists
//! (`oit_reference::analyze`; definitions in docs/analyze.md). No GPU.

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use oit_harness::report::{printable, wrap};
use oit_reference::analyze::{Analysis, OrderConflicts, SCHEMA};
use oit_scene::Resolution;

/// Table width.
const WIDTH: usize = 100;
/// Pairs and draws shown per list in the table (JSON lists up to `LISTED_PAIRS`).
const SHOWN: usize = 5;

/// One scene's entry of the JSON output: its analysis, or why there is none.
#[derive(Debug, serde::Serialize)]
struct Entry {
    file: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    analysis: Option<Analysis>,
    /// What the loader read but does not model (`Scene::ignored`), one line each.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    not_modelled: Vec<String>,
}

/// The scene files of `paths` (a directory: every scene in it), in order.
fn files(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let (scenes, skipped) = oit_harness::scene_files::scene_files(p)?;
            for s in &skipped {
                eprintln!("note: {}", s.note());
            }
            out.extend(scenes);
        } else {
            out.push(p.clone());
        }
    }
    if out.is_empty() {
        return Err(crate::no_scene_files(paths));
    }
    Ok(out)
}

/// Analyses every scene of `paths`; a scene that fails is reported and the others go on, and
/// the command then fails naming how many did.
pub fn run(
    paths: &[PathBuf],
    json: bool,
    resolution: Option<Resolution>,
    memory_budget: u64,
    load: &oit_scene::LoadOptions,
) -> Result<()> {
    let files = files(paths)?;
    if let [file] = files.as_slice()
        && !json
    {
        // One scene: its error is the command's, said once.
        let (a, notes) = analyze_file(file, resolution, memory_budget, load)?;
        print!("{}", table(file, &a, &notes));
        return Ok(());
    }
    let mut entries = Vec::new();
    for file in &files {
        let entry = match analyze_file(file, resolution, memory_budget, load) {
            Ok((a, notes)) => {
                if !json {
                    print!("{}", table(file, &a, &notes));
                }
                Entry {
                    file: file.display().to_string(),
                    error: None,
                    analysis: Some(a),
                    not_modelled: notes.ignored,
                }
            }
            Err(e) => {
                let line = crate::one_line(&e);
                eprintln!("oit: error: {line}");
                Entry {
                    file: file.display().to_string(),
                    error: Some(line),
                    analysis: None,
                    not_modelled: Vec::new(),
                }
            }
        };
        entries.push(entry);
    }
    if json {
        let out = serde_json::json!({ "schema": SCHEMA, "scenes": entries });
        println!("{}", serde_json::to_string_pretty(&out)?);
    }
    let failed = entries.iter().filter(|e| e.error.is_some()).count();
    if failed > 0 {
        bail!("{failed} of {} scenes could not be analysed", entries.len());
    }
    Ok(())
}

fn analyze_file(
    file: &Path,
    resolution: Option<Resolution>,
    memory_budget: u64,
    load: &oit_scene::LoadOptions,
) -> Result<(Analysis, Notes)> {
    let scene = oit_scene::load_with(file, load)?;
    let notes = Notes {
        lines: crate::notes::scene_lines(&scene),
        ignored: scene.ignored.clone(),
    };
    let scene = match resolution {
        Some(r) => scene.with_resolution(r),
        None => scene,
    };
    let bar = crate::progress_bar(0, &format!("analyze {}", scene.name));
    let tick = bar.clone();
    let progress: oit_reference::Progress =
        std::sync::Arc::new(move |done: usize, total: usize| {
            tick.set_length(total as u64);
            tick.set_position(done as u64);
        });
    let options = oit_reference::ReferenceOptions {
        progress: Some(progress),
        memory_budget,
        ..Default::default()
    };
    let analysis = oit_reference::analyze::analyze(&scene, &options)
        .map_err(|e| anyhow::anyhow!("{}: analysis: {e}", file.display()));
    bar.finish_and_clear();
    Ok((analysis?, notes))
}

/// A scene's credit and "Not modelled" lines for the table, and the bare `ignored` lines for
/// the JSON.
struct Notes {
    lines: Vec<String>,
    ignored: Vec<String>,
}

fn range(r: Option<[f32; 2]>) -> String {
    r.map_or_else(|| "-".to_owned(), |[lo, hi]| format!("{lo:.6} .. {hi:.6}"))
}

fn pct(n: u64, of: u64) -> String {
    if of == 0 {
        return format!("{n}");
    }
    format!("{n} ({:.1} %)", 100.0 * n as f64 / of as f64)
}

/// Rows of one granularity's order conflicts.
fn conflict_rows<T>(
    rows: &mut Vec<(String, String)>,
    what: &str,
    c: &OrderConflicts<T>,
    pixels: u64,
    technique: &str,
    label: impl Fn(&T) -> String,
) {
    rows.push((
        format!("{what} cycles"),
        format!(
            "{} pixels; {} cycles (largest {}), {} pairs",
            pct(c.conflict_pixels, pixels),
            c.cycles,
            c.largest_cycle,
            c.conflict_pairs
        ),
    ));
    for p in c.pairs.iter().take(SHOWN) {
        rows.push((
            String::new(),
            format!(
                "{} / {}: {} / {} in front, {} interleaved",
                label(&p.a),
                label(&p.b),
                p.a_in_front,
                p.b_in_front,
                p.interleaved
            ),
        ));
    }
    rows.push((
        format!("{technique} wrong"),
        pct(c.technique_order_wrong_pixels, pixels),
    ));
}

/// The terminal table of one scene, wrapped to [`WIDTH`] columns.
fn table(file: &Path, a: &Analysis, notes: &Notes) -> String {
    let l = &a.layers;
    let mut rows: Vec<(String, String)> = vec![
        (
            "layers".into(),
            format!(
                "max {}, p50 {}, p95 {}, p99 {}; covered {}",
                l.max,
                l.p50,
                l.p95,
                l.p99,
                pct(l.covered_pixels, a.pixels)
            ),
        ),
        (
            "histogram".into(),
            l.histogram
                .iter()
                .map(|[n, c]| format!("{n}:{c}"))
                .collect::<Vec<_>>()
                .join(" "),
        ),
        (
            "fragments".into(),
            format!(
                "{} composited of {} transparent, {} in all",
                a.fragments.composited, a.fragments.transparent, a.fragments.produced
            ),
        ),
    ];
    conflict_rows(
        &mut rows,
        "object",
        &a.objects,
        a.pixels,
        "sorted-object",
        |d| d.name.clone(),
    );
    rows.push((
        " + order in object".into(),
        pct(a.objects.technique_draw_order_wrong_pixels, a.pixels),
    ));
    conflict_rows(
        &mut rows,
        "triangle",
        &a.triangles,
        a.pixels,
        "sorted-triangle",
        |t| format!("{}#{}", t.name, t.triangle),
    );
    let overlap = a
        .self_overlap
        .draws
        .iter()
        .take(SHOWN)
        .map(|d| format!("{} {}", d.name, d.pixels))
        .collect::<Vec<_>>()
        .join(", ");
    rows.push((
        "self-overlap".into(),
        if overlap.is_empty() {
            pct(a.self_overlap.pixels, a.pixels)
        } else {
            format!("{}: {overlap}", pct(a.self_overlap.pixels, a.pixels))
        },
    ));
    rows.push((
        "alpha".into(),
        format!(
            "< 1/255: {}; > 254/255: {} fragments",
            a.alpha.near_zero, a.alpha.near_one
        ),
    ));
    rows.push((
        "radiance".into(),
        format!(
            "premultiplied {}; composite {}",
            range(a.radiance.premultiplied),
            range(a.radiance.composite)
        ),
    ));
    let d = &a.depth;
    rows.push((
        "depth".into(),
        format!("window {}; view {}", range(d.window), range(d.view)),
    ));
    rows.push((
        "16-bit depth".into(),
        format!(
            "{}: {} pixels share a key; {} pixels have equal f32 depths",
            if d.depth16_separates {
                "separates"
            } else {
                "does not separate"
            },
            d.depth16_shared_pixels,
            d.equal_depth_pixels
        ),
    ));
    let mut out = format!(
        "{} ({}, {}x{}, {:.3} s)\n",
        printable(&a.scene),
        printable(&file.display().to_string()),
        a.resolution[0],
        a.resolution[1],
        a.seconds
    );
    let label_width = 22;
    for (label, value) in rows {
        let mut first = true;
        let mut lines = wrap(&printable(&value), WIDTH - label_width - 3);
        if lines.is_empty() {
            lines.push("-".into());
        }
        for line in lines {
            let label = if first { label.as_str() } else { "" };
            out.push_str(&format!("  {label:<label_width$} {line}\n"));
            first = false;
        }
    }
    for line in &notes.lines {
        for (k, part) in wrap(&printable(line), WIDTH - 4).into_iter().enumerate() {
            let indent = if k == 0 { "  " } else { "    " };
            out.push_str(&format!("{indent}{part}\n"));
        }
    }
    out.push('\n');
    out
}
