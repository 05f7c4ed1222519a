//! Plots and the HTML report of a small hand-made results directory: every ok run is drawn,
//! axes are labelled, the Pareto front is the one worked out by hand, and the page renders in
//! headless Chromium with every image decoded.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use oit_report::{
    Metric, PlotKind, pareto_markdown, pareto_members, plot_data, render_png, render_svg,
};
use oit_results::{AdapterJson, GpuMs, Outputs, Results, Run, RunStatus, SCHEMA, SceneJson};

/// (technique, cost × unsorted, mean FLIP, bytes/px, RMSE)
type Row = (&'static str, f64, f64, f64, f64);

/// Scene `alpha`. By hand, on cost against FLIP: spp=1 is beaten by unsorted (cheaper, lower
/// error); spp=16 and passes=4 by sorted-triangle (cheaper and exact); spp=4 and passes=2 tie
/// exactly and both stay. Front: unsorted, sorted-object, spp=4, passes=2, sorted-triangle.
const ALPHA: [Row; 8] = [
    ("unsorted", 1.0, 0.20, 0.0, 0.10),
    ("sorted-object", 1.1, 0.15, 0.0, 0.08),
    ("sorted-triangle", 3.0, 0.0, 8.0, 0.0),
    ("stochastic:spp=1", 1.5, 0.30, 4.0, 0.20),
    ("stochastic:spp=16", 4.0, 0.05, 64.0, 0.02),
    ("stochastic:spp=4", 2.0, 0.10, 16.0, 0.05),
    ("dual-peel:passes=2,tail=drop", 2.0, 0.10, 24.0, 0.06),
    ("dual-peel:passes=4,tail=drop", 5.0, 0.0, 40.0, 0.0),
];

/// Scene `beta` (no reference.png on disk): sorted-object costs more for the same error.
const BETA: [Row; 3] = [
    ("unsorted", 1.0, 0.10, 0.0, 0.05),
    ("sorted-object", 1.2, 0.10, 0.0, 0.05),
    ("sorted-triangle", 2.0, 0.05, 8.0, 0.01),
];

fn ok_run(scene: &str, row: Row) -> Run {
    let (technique, cost, flip, bpp, rmse) = row;
    let stem = oit_results::file_stem(technique);
    let mut run = Run::not_rendered(
        scene,
        &format!("scenes/{scene}.json"),
        technique,
        [4, 4],
        RunStatus::Ok,
        String::new(),
    );
    run.reason = None;
    run.gpu_ms = Some(GpuMs {
        median: cost * 0.5,
        min: cost * 0.45,
        max: cost * 0.6,
        frames: 20,
        source: "timestamp".into(),
        interference: None,
        attempts: 1,
    });
    run.cost_vs_unsorted = Some(cost);
    run.bytes_per_pixel = Some(bpp);
    run.memory_bytes = Some((bpp * 16.0) as u64);
    run.error = Some(oit_metrics::Errors {
        rmse,
        psnr: if rmse > 0.0 {
            -20.0 * rmse.log10()
        } else {
            200.0
        },
        mean_abs: rmse,
        max_abs: rmse * 3.0,
        max_relative: rmse * 3.0,
        over_1_255: 0.0,
        over_1_64: 0.0,
        flip_mean: flip,
        nonfinite: 0,
        ..Default::default()
    });
    run.order_dependence = Some(0.0);
    run.outputs = Some(Outputs {
        exr: format!("{scene}/{stem}.exr"),
        render_png: format!("{scene}/{stem}.png"),
        diff_png: format!("{scene}/{stem}-diff.png"),
    });
    run
}

fn results() -> Results {
    let mut runs: Vec<Run> = ALPHA.iter().map(|&r| ok_run("alpha", r)).collect();
    runs.push(Run::not_rendered(
        "alpha",
        "scenes/alpha.json",
        "wboit",
        [4, 4],
        RunStatus::Skipped,
        "no <float32> blending".into(),
    ));
    runs.push(Run::not_rendered(
        "alpha",
        "scenes/alpha.json",
        "a2c:samples=4",
        [4, 4],
        RunStatus::Failed,
        "device lost".into(),
    ));
    runs.extend(BETA.iter().map(|&r| ok_run("beta", r)));
    runs[0].inexact = vec!["dropped layers on 3 px".into()];
    Results {
        schema: SCHEMA.into(),
        tool: None,
        complete: true,
        adapter: AdapterJson {
            name: "test adapter".into(),
            backend: "vulkan".into(),
            device_type: "cpu".into(),
            driver: "none".into(),
        },
        runs,
        floors: Vec::new(),
        scenes: vec![SceneJson {
            scene: "beta".into(),
            scene_file: "scenes/beta.json".into(),
            description: "Beta quads that cross: no order of objects is right.".into(),
            triangles: 12,
            scene_bytes: 3 << 20,
            texture_bytes: 2 << 20,
            credits: vec!["beta.glb: model by A. Modeller, CC0".into()],
            ignored: vec![
                "beta.glb: KHR_materials_transmission in /extensionsUsed: not modelled".into(),
            ],
            peak_memory_bytes: Some(300 << 20),
        }],
        shard: None,
        merged: Vec::new(),
    }
}

fn ok_count(results: &Results, scene: &str) -> usize {
    results
        .runs
        .iter()
        .filter(|r| r.scene == scene && r.status == RunStatus::Ok)
        .count()
}

/// A fresh directory under the system temp dir, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("oit-report-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn write_png(path: &Path, rgb: [u8; 3]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    image::RgbImage::from_pixel(4, 4, image::Rgb(rgb))
        .save(path)
        .unwrap();
}

/// A results directory as `oit compare` leaves it: results.json, every run's PNGs, and a
/// reference for `alpha` only.
fn results_dir(name: &str) -> TempDir {
    let dir = TempDir::new(name);
    let results = results();
    std::fs::write(
        dir.0.join("results.json"),
        serde_json::to_vec_pretty(&results).unwrap(),
    )
    .unwrap();
    for run in &results.runs {
        if let Some(o) = &run.outputs {
            write_png(&dir.0.join(&o.render_png), [200, 100, 50]);
            write_png(&dir.0.join(&o.diff_png), [0, 0, 0]);
        }
    }
    write_png(&dir.0.join("alpha/reference.png"), [200, 100, 60]);
    write_png(&dir.0.join("alpha/layers.png"), [20, 10, 60]);
    dir
}

const PALETTE_HEX: [&str; 5] = ["#1F77B4", "#FF7F0E", "#2CA02C", "#D62728", "#9467BD"];

/// Filled marker elements (circle, rect, polygon) of one colour in an SVG.
fn markers_of_colour(svg: &str, hex: &str) -> usize {
    svg.split('<')
        .filter(|el| {
            el.starts_with("circle") || el.starts_with("rect") || el.starts_with("polygon")
        })
        .filter(|el| el.to_ascii_uppercase().contains(&format!("FILL=\"{hex}\"")))
        .count()
}

#[test]
fn every_plot_has_one_point_per_ok_run_and_labelled_axes() {
    let results = results();
    for metric in [Metric::Flip, Metric::Rmse] {
        let plots = plot_data(&results, metric);
        assert_eq!(plots.len(), 4, "two scenes × two plots");
        for plot in &plots {
            let expected = ok_count(&results, &plot.scene);
            assert_eq!(plot.points.len(), expected, "{}", plot.stem);
            assert!(plot.omitted.is_empty(), "{:?}", plot.omitted);

            let svg = render_svg(plot).unwrap();
            // Families appear in run order: unsorted, sorted-object, sorted-triangle,
            // stochastic, dual-peel. Each family's colour: its points plus one legend marker
            // per configuration of the family.
            let mut drawn = 0;
            for (style, hex) in PALETTE_HEX.iter().enumerate() {
                let n = plot.points.iter().filter(|p| p.style == style).count();
                let configs = plot.legend.iter().filter(|e| e.style == style).count();
                let in_svg = markers_of_colour(&svg, hex);
                assert_eq!(in_svg, n + configs, "{} style {style}", plot.stem);
                drawn += in_svg - configs;
            }
            assert_eq!(drawn, expected, "{}", plot.stem);

            let x_unit = match plot.kind {
                PlotKind::CostError => "GPU time relative to unsorted",
                PlotKind::BytesError => "bytes per pixel",
            };
            assert!(svg.contains(x_unit), "{}: x axis label missing", plot.stem);
            let y_unit = match metric {
                Metric::Flip => "mean FLIP (HDR-FLIP on HDR scenes; 0-1, log scale)",
                Metric::Rmse => "RMSE (linear RGB, 1 = full scale; log scale)",
            };
            assert!(svg.contains(y_unit), "{}: y axis label missing", plot.stem);

            // The PNG is the same drawing: every family colour appears as exact pixels.
            let png = image::load_from_memory(&render_png(plot).unwrap())
                .unwrap()
                .to_rgb8();
            assert_eq!(png.dimensions(), oit_report::PLOT_SIZE);
            for (style, hex) in PALETTE_HEX.iter().enumerate().take(5) {
                if plot.points.iter().any(|p| p.style == style) {
                    let rgb = [0, 1, 2]
                        .map(|i| u8::from_str_radix(&hex[1 + 2 * i..3 + 2 * i], 16).unwrap());
                    assert!(
                        png.pixels().any(|p| p.0 == rgb),
                        "{} PNG lacks colour {hex}",
                        plot.stem
                    );
                }
            }
        }
    }
}

/// Left edge (SVG x) of every marker element filled with `hex`: a circle's centre, a square's
/// corner, a triangle's or diamond's first vertex.
fn marker_xs(svg: &str, hex: &str) -> Vec<f64> {
    let attr = |el: &str, name: &str| -> Option<f64> {
        let start = el.find(&format!(" {name}=\""))? + name.len() + 3;
        let value = &el[start..];
        value[..value.find('"')?]
            .split([',', ' '])
            .next()?
            .parse()
            .ok()
    };
    svg.split('<')
        .filter(|el| el.to_ascii_uppercase().contains(&format!("FILL=\"{hex}\"")))
        .filter_map(|el| {
            if el.starts_with("circle") {
                attr(el, "cx")
            } else if el.starts_with("rect") {
                attr(el, "x")
            } else if el.starts_with("polygon") {
                attr(el, "points")
            } else {
                None
            }
        })
        .collect()
}

/// The legend sits in its own strip right of the axes, so no data point can hide under it
/// (inside the axes, its box covered the markers of two techniques on a transmission scene):
/// every family's legend marker is in the strip, every data marker left of it.
#[test]
fn the_legend_is_beside_the_points_not_over_them() {
    let results = results();
    let strip = f64::from(oit_report::PLOT_SIZE.0 - oit_report::LEGEND_WIDTH);
    for metric in [Metric::Flip, Metric::Rmse] {
        for plot in plot_data(&results, metric) {
            let svg = render_svg(&plot).unwrap();
            for (style, hex) in PALETTE_HEX.iter().enumerate() {
                let n = plot.points.iter().filter(|p| p.style == style).count();
                if n == 0 {
                    continue;
                }
                let xs = marker_xs(&svg, hex);
                let (legend, data): (Vec<f64>, Vec<f64>) = xs.iter().partition(|&&x| x >= strip);
                let configs = plot.legend.iter().filter(|e| e.style == style).count();
                assert_eq!(legend.len(), configs, "{} style {style}: {xs:?}", plot.stem);
                assert_eq!(data.len(), n, "{} style {style}: {xs:?}", plot.stem);
            }
        }
    }
}

#[test]
fn sweeps_join_one_family_in_parameter_order_and_zero_error_is_drawn() {
    let plots = plot_data(&results(), Metric::Flip);
    let alpha = &plots[0];
    assert_eq!(alpha.kind, PlotKind::CostError);
    let names: Vec<Vec<&str>> = alpha
        .sweeps
        .iter()
        .map(|s| {
            s.iter()
                .map(|&i| alpha.points[i].technique.as_str())
                .collect()
        })
        .collect();
    assert_eq!(
        names,
        vec![
            vec![
                "dual-peel:passes=2,tail=drop",
                "dual-peel:passes=4,tail=drop"
            ],
            vec!["stochastic:spp=1", "stochastic:spp=4", "stochastic:spp=16"],
        ]
    );
    // Exact runs (FLIP 0) sit at a quarter of the smallest nonzero FLIP, 0.05.
    assert_eq!(alpha.zero_y, Some(0.0125));
    let exact: Vec<f64> = alpha
        .points
        .iter()
        .filter(|p| p.y == 0.0)
        .map(|p| p.y_drawn)
        .collect();
    assert_eq!(exact, vec![0.0125, 0.0125]);
}

#[test]
fn pareto_members_are_the_hand_computed_fronts() {
    let results = results();
    let expected: BTreeSet<(String, String)> = [
        ("alpha", "unsorted"),
        ("alpha", "sorted-object"),
        ("alpha", "stochastic:spp=4"),
        ("alpha", "dual-peel:passes=2,tail=drop"),
        ("alpha", "sorted-triangle"),
        ("beta", "unsorted"),
        ("beta", "sorted-triangle"),
    ]
    .iter()
    .map(|(s, t)| (s.to_string(), t.to_string()))
    .collect();
    assert_eq!(pareto_members(&results, Metric::Flip), expected);

    // On RMSE the alpha tie breaks: passes=2 (0.06) is beaten by spp=4 (0.05) at equal cost.
    let rmse = pareto_members(&results, Metric::Rmse);
    assert!(rmse.contains(&("alpha".into(), "stochastic:spp=4".into())));
    assert!(!rmse.contains(&("alpha".into(), "dual-peel:passes=2,tail=drop".into())));

    let md = pareto_markdown(&results, Metric::Flip);
    let alpha = md.split("### beta").next().unwrap();
    let order: Vec<&str> = alpha.lines().filter(|l| l.starts_with("| `")).collect();
    assert_eq!(
        order,
        vec![
            "| `unsorted` | 1.000 | 0.20000 |",
            "| `sorted-object` | 1.100 | 0.15000 |",
            "| `stochastic:spp=4` | 2.000 | 0.10000 |",
            "| `dual-peel:passes=2,tail=drop` | 2.000 | 0.10000 |",
            "| `sorted-triangle` | 3.000 | 0.00000 |",
        ]
    );
}

#[test]
fn write_plots_writes_svg_and_png_per_plot() {
    let dir = TempDir::new("plots");
    let files = oit_report::write_plots(&results(), &dir.0.join("plots"), Metric::Flip).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "alpha-flip-cost.svg",
            "alpha-flip-cost.png",
            "alpha-flip-bytes.svg",
            "alpha-flip-bytes.png",
            "beta-flip-cost.svg",
            "beta-flip-cost.png",
            "beta-flip-bytes.svg",
            "beta-flip-bytes.png"
        ]
    );
    for f in &files {
        assert!(
            std::fs::metadata(f).unwrap().len() > 1000,
            "{}",
            f.display()
        );
    }
}

#[test]
fn missing_or_foreign_results_are_errors_naming_the_file() {
    let dir = TempDir::new("bad");
    let err = oit_report::write_html_report(&dir.0, Metric::Flip, &|t| t.to_owned())
        .unwrap_err()
        .to_string();
    assert!(err.contains("results.json"), "{err}");
    std::fs::write(dir.0.join("results.json"), r#"{"schema":"other/v9","adapter":{"name":"","backend":"","device_type":"","driver":""},"runs":[]}"#).unwrap();
    let err = oit_report::write_html_report(&dir.0, Metric::Flip, &|t| t.to_owned())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("results.json") && err.contains("other/v9"),
        "{err}"
    );
}

/// Images the page shows: the two legends, 2 plots per scene, alpha's reference and layer map
/// once, render + reference (to flip to) + diff per ok alpha run, render + diff per ok beta run
/// (beta has no reference.png or layers.png: notes instead).
const EXPECTED_IMAGES: usize = 2 + 2 * 2 + 2 + 3 * ALPHA.len() + 2 * BETA.len();

#[test]
fn report_page_lists_every_run_and_notes_missing_images() {
    let dir = results_dir("page");
    let page = oit_report::write_html_report(&dir.0, Metric::Flip, &|t| t.to_owned()).unwrap();
    assert_eq!(page, dir.0.join("report.html"));
    let html = std::fs::read_to_string(&page).unwrap();
    assert_eq!(html.matches("<img ").count(), EXPECTED_IMAGES);
    assert_eq!(
        html.matches("reference not found (beta/reference.png)")
            .count(),
        BETA.len() + 1
    );
    assert!(html.contains("skipped: no &lt;float32&gt; blending"));
    assert!(html.contains("failed: device lost"));
    // What the scene brought: size on the GPU, its credit line, what is not modelled.
    assert!(html.contains(
        "Scene: 12 triangles, 3.0 MiB on the GPU shared by every technique (2.0 MiB of textures)."
    ));
    assert!(html.contains("Credits: beta.glb: model by A. Modeller, CC0."));
    assert!(html.contains("Not modelled: beta.glb: KHR_materials_transmission"));
    assert!(html.contains("Peak memory: 300 MiB resident while this scene ran"));
    assert!(html.contains("<td class=\"note\">dropped layers on 3 px</td>"));
    // Pareto members are bold (class "front"): 5 in alpha, 2 in beta.
    assert_eq!(html.matches("<tr class=\"front\">").count(), 7);
    // Nothing is fetched from elsewhere.
    for needle in ["http://", "https://", "src=\"/", "//cdn"] {
        assert!(!html.contains(needle), "page refers to {needle}");
    }
    for f in ["plots/alpha-flip-cost.svg", "plots/beta-rmse-bytes.png"] {
        assert!(dir.0.join(f).is_file(), "{f}");
    }
}

const BROWSER: &str = "/usr/bin/chromium";
const REQUIRE_BROWSER_ENV: &str = "OIT_REQUIRE_BROWSER";

/// `chromium --headless --dump-dom` of the page; `None` (with a message) when Chromium is not
/// installed, unless OIT_REQUIRE_BROWSER=1.
fn dump_dom(page: &Path, profile: &Path) -> Option<String> {
    if !Path::new(BROWSER).exists() {
        if std::env::var(REQUIRE_BROWSER_ENV).is_ok_and(|v| v == "1") {
            panic!("{REQUIRE_BROWSER_ENV}=1 but {BROWSER} is missing (apt-get install chromium)");
        }
        eprintln!(
            "skipped report_renders_in_headless_chromium: {BROWSER} not found (apt-get install chromium)"
        );
        return None;
    }
    let mut child = Command::new(BROWSER)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--virtual-time-budget=10000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("--dump-dom")
        .arg(format!("file://{}", page.display()))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("{BROWSER}: {e}"));
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("{BROWSER} did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let out = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{BROWSER} failed: {}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    Some(stdout)
}

fn body_attribute<'d>(dom: &'d str, name: &str) -> Option<&'d str> {
    let body = &dom[dom.find("<body")?..];
    let tag = &body[..body.find('>')?];
    let start = tag.find(&format!("{name}=\""))? + name.len() + 2;
    Some(&tag[start..start + tag[start..].find('"')?])
}

#[test]
fn report_renders_in_headless_chromium() {
    let dir = results_dir("chromium");
    let page = oit_report::write_html_report(&dir.0, Metric::Flip, &|t| t.to_owned()).unwrap();
    let profile = dir.0.join("chromium-profile");
    let Some(dom) = dump_dom(&page, &profile) else {
        return;
    };
    let images = body_attribute(&dom, "data-images-ok")
        .unwrap_or_else(|| panic!("no load check in DOM:\n{dom}"));
    assert_eq!(images, format!("{EXPECTED_IMAGES}/{EXPECTED_IMAGES}"));
    assert_eq!(body_attribute(&dom, "data-errors"), Some(""));

    // The check itself must be able to fail: a broken image is counted and reported.
    let html = std::fs::read_to_string(&page).unwrap();
    std::fs::remove_file(dir.0.join("alpha/unsorted.png")).unwrap();
    std::fs::write(dir.0.join("broken.html"), &html).unwrap();
    let dom = dump_dom(&dir.0.join("broken.html"), &profile).unwrap();
    assert_eq!(
        body_attribute(&dom, "data-images-ok"),
        Some(format!("{}/{EXPECTED_IMAGES}", EXPECTED_IMAGES - 1).as_str())
    );
    assert!(
        body_attribute(&dom, "data-errors")
            .unwrap()
            .contains("alpha/unsorted.png")
    );
}

/// The part of the page between `<section id="ID">` and its `</section>`.
fn section<'h>(html: &'h str, id: &str) -> &'h str {
    let start = html
        .find(&format!("<section id=\"{id}\">"))
        .unwrap_or_else(|| panic!("no section {id}"));
    let len = html[start..]
        .find("</section>")
        .expect("section not closed");
    &html[start..start + len]
}

/// What `results.json` says about a scene (size, credits, what is not modelled) is shown in
/// that scene's section, and nowhere else.
#[test]
fn scene_facts_are_shown_in_their_own_section_only() {
    let dir = results_dir("facts");
    let html = std::fs::read_to_string(
        oit_report::write_html_report(&dir.0, Metric::Flip, &|t| t.to_owned()).unwrap(),
    )
    .unwrap();
    let (alpha, beta) = (section(&html, "alpha"), section(&html, "beta"));
    assert!(
        beta.contains("<p class=\"about\">Scene: 12 triangles"),
        "{beta}"
    );
    assert!(beta.contains("Credits: beta.glb: model by A. Modeller, CC0."));
    // alpha has no entry in `scenes`: no facts at all.
    assert!(!alpha.contains("<p class=\"about\">"), "{alpha}");
}

/// Each section shows its cost-against-error plot first, then bytes-against-error (the order
/// of `write_plots`), each followed by its own PNG and RMSE links.
#[test]
fn each_section_shows_the_cost_plot_before_the_bytes_plot() {
    let dir = results_dir("plot-order");
    let html = std::fs::read_to_string(
        oit_report::write_html_report(&dir.0, Metric::Flip, &|t| t.to_owned()).unwrap(),
    )
    .unwrap();
    for scene in ["alpha", "beta"] {
        let s = section(&html, scene);
        let at = |needle: String| {
            s.find(&needle)
                .unwrap_or_else(|| panic!("{scene}: no {needle}"))
        };
        let order = [
            at(format!(
                "<img src=\"plots/{scene}-flip-cost.svg\" alt=\"{scene}: mean FLIP against cost\""
            )),
            at(format!("<a href=\"plots/{scene}-flip-cost.png\">PNG</a>")),
            at(format!(
                "<a href=\"plots/{scene}-rmse-cost.svg\">RMSE version</a>"
            )),
            at(format!(
                "<img src=\"plots/{scene}-flip-bytes.svg\" alt=\"{scene}: mean FLIP against bytes\""
            )),
            at(format!("<a href=\"plots/{scene}-flip-bytes.png\">PNG</a>")),
            at(format!(
                "<a href=\"plots/{scene}-rmse-bytes.svg\">RMSE version</a>"
            )),
        ];
        assert!(order.is_sorted(), "{scene}: {order:?}");
    }
}

/// Two configurations of one technique never share a marker or a legend name: each gets its
/// family's colour, its own shape and a label naming the parameters that tell it apart.
#[test]
fn every_configuration_has_its_own_marker_and_legend_name() {
    let plots = plot_data(&results(), Metric::Flip);
    let alpha = &plots[0];
    let labels: Vec<&str> = alpha.legend.iter().map(|e| e.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "unsorted",
            "sorted-object",
            "sorted-triangle",
            "stochastic:spp=1",
            "stochastic:spp=16",
            "stochastic:spp=4",
            "dual-peel:passes=2",
            "dual-peel:passes=4"
        ]
    );
    let mut looks: Vec<(usize, usize)> = alpha.legend.iter().map(|e| (e.style, e.shape)).collect();
    looks.sort_unstable();
    looks.dedup();
    assert_eq!(looks.len(), alpha.legend.len(), "{:?}", alpha.legend);
    let svg = render_svg(alpha).unwrap();
    for label in labels {
        assert!(svg.contains(label), "legend lacks {label}");
    }
}

/// The page follows `--metric`: with RMSE its fronts (bold rows, the line under each scene,
/// the summary) are the RMSE fronts and its first plots the RMSE ones.
#[test]
fn the_report_follows_the_metric() {
    let dir = results_dir("metric");
    let results = results();
    for metric in [Metric::Flip, Metric::Rmse] {
        let html = std::fs::read_to_string(
            oit_report::write_html_report(&dir.0, metric, &|t| t.to_owned()).unwrap(),
        )
        .unwrap();
        let members = pareto_members(&results, metric);
        assert_eq!(html.matches("<tr class=\"front\">").count(), members.len());
        let alpha = section(&html, "alpha");
        assert!(
            alpha.contains(&format!(
                "On the Pareto front of cost against {}",
                metric.name()
            )),
            "{alpha}"
        );
        let first_plot = alpha.find("<img src=\"plots/").unwrap();
        assert!(
            alpha[first_plot..].starts_with(&format!(
                "<img src=\"plots/alpha-{}-cost.svg\"",
                metric.key()
            )),
            "{metric:?}"
        );
        let passes2 = alpha.contains("<b><code>dual-peel:passes=2,tail=drop</code></b>");
        assert_eq!(
            passes2,
            metric == Metric::Flip,
            "passes=2 is on the FLIP front only"
        );
    }
}

/// What a reader asks of the page is on it: what each column means, what the heat-map and
/// layer colours mean (with their legends), the suite summary with every scene's front, what
/// each scene tests, tables that sort, and a render that flips to its reference and zooms.
#[test]
fn the_report_explains_itself() {
    let dir = results_dir("explains");
    let html = std::fs::read_to_string(
        oit_report::write_html_report(&dir.0, Metric::Flip, &|t| t.to_owned()).unwrap(),
    )
    .unwrap();
    for (name, _) in oit_results::report::COLUMNS {
        assert!(
            html.contains(&format!("<dt>{name}</dt>")),
            "no meaning for {name}"
        );
    }
    for legend in ["plots/legend-error.png", "plots/legend-layers.png"] {
        assert!(html.contains(&format!("<img src=\"{legend}\"")), "{legend}");
        assert!(dir.0.join(legend).is_file(), "{legend}");
    }
    assert!(html.contains("<section id=\"summary\">"));
    assert!(html.contains("<th>on the front of</th>"));
    // The front of every scene, in the summary.
    assert!(html.contains("<code>stochastic:spp=4</code>"), "{html}");
    let beta = section(&html, "beta");
    assert!(
        beta.contains(
            "<p class=\"description\">Beta quads that cross: no order of objects is right.</p>"
        ),
        "{beta}"
    );
    assert!(html.contains("<li><a href=\"#beta\">beta</a>: Beta quads that cross</li>"));
    assert_eq!(html.matches("<table class=\"sortable\">").count(), 2 + 2);
    assert_eq!(
        html.matches("<button type=\"button\" class=\"flip\">")
            .count(),
        ALPHA.len() + BETA.len()
    );
    assert!(section(&html, "alpha").contains("<img class=\"b\" src=\"alpha/reference.png\""));
    assert!(section(&html, "alpha").contains("src=\"alpha/layers.png\""));
}
