//! The motion plots and the report's motion section on a small hand-made results file: one
//! animated scene (`swap`, three techniques over eight frames, one of them with a static-camera
//! measurement) and one still scene (`still`), which gets no motion plot or section.

use std::path::PathBuf;

use oit_report::{
    MotionKind, YScale, motion_plot_data, render_motion_png, render_motion_svg, write_motion_plots,
};
use oit_results::{AdapterJson, Results, Run, RunStatus, SCHEMA, StaticCamera, Temporal};

fn temporal(flip: &[f64], pops: &[u32]) -> Temporal {
    let worst_flip = flip.iter().copied().fold(0.0, f64::max);
    Temporal {
        frames: (0..flip.len() as u32).collect(),
        rmse: flip.iter().map(|f| f / 2.0).collect(),
        flip: flip.to_vec(),
        flip_name: "LDR-FLIP".into(),
        max_abs: flip.to_vec(),
        change: vec![1e-3; flip.len() - 1],
        flicker: 0.01,
        pop_events: pops.to_vec(),
        pop_multiple: 4.0,
        pop_floor: 1.0 / 1020.0,
        worst_frame: flip.iter().position(|&f| f == worst_flip).unwrap_or(0) as u32,
        worst_flip,
        mean_flip: flip.iter().sum::<f64>() / flip.len() as f64,
        mean_rmse: 0.0,
        max_order_dependence: 0.5,
        inexact_frames: Vec::new(),
        static_camera: None,
    }
}

fn run(scene: &str, technique: &str, temporal: Option<Temporal>) -> Run {
    let mut r = Run::not_rendered(
        scene,
        &format!("scenes/{scene}.json"),
        technique,
        [8, 8],
        RunStatus::Ok,
        String::new(),
    );
    r.reason = None;
    r.temporal = temporal;
    r
}

/// `unsorted` pops when the sort order swaps at frames 3 and 6; `front-peel` is exact (0 on
/// every frame); `stochastic` is noisy, and was also measured at a static camera.
fn results() -> Results {
    let mut noisy = temporal(&[0.02, 0.03, 0.02, 0.025, 0.02, 0.03, 0.02, 0.03], &[]);
    noisy.static_camera = Some(StaticCamera {
        frames: 8,
        bias_rmse: 1e-3,
        noise_rms: 0.05,
        mse: 0.05f64.powi(2) + 1e-6,
        history_rmse: vec![0.05, 0.04, 0.03, 0.025, 0.02, 0.018, 0.017, 0.016],
        history_blend: 0.1,
        mean_rmse: vec![0.05, 0.035, 0.029, 0.025, 0.022, 0.02, 0.019, 0.018],
    });
    let mut skipped = run("swap", "wboit", None);
    skipped.status = RunStatus::Skipped;
    skipped.reason = Some("no float blending".into());
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
        runs: vec![
            run("still", "unsorted", None),
            run(
                "swap",
                "unsorted",
                Some(temporal(
                    &[0.01, 0.01, 0.01, 0.4, 0.4, 0.4, 0.01, 0.01],
                    &[3, 6],
                )),
            ),
            run(
                "swap",
                "front-peel:layers=auto",
                Some(temporal(&[0.0; 8], &[])),
            ),
            run("swap", "stochastic:spp=1", Some(noisy)),
            skipped,
            run("still", "front-peel:layers=auto", None),
        ],
        floors: Vec::new(),
        scenes: Vec::new(),
        shard: None,
        merged: Vec::new(),
    }
}

/// A fresh directory under the system temp dir, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("oit-motion-{name}-{}", std::process::id()));
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

#[test]
fn one_line_per_temporal_run_with_its_pop_events_and_none_for_a_still_scene() {
    let plots = motion_plot_data(&results());
    let kinds: Vec<(&str, MotionKind)> = plots.iter().map(|p| (p.scene.as_str(), p.kind)).collect();
    assert_eq!(
        kinds,
        [
            ("swap", MotionKind::FlipOverFrames),
            ("swap", MotionKind::Convergence)
        ],
        "the still scene has no motion plot"
    );
    let frames = &plots[0];
    assert_eq!(frames.stem, "swap-flip-frames");
    let techniques: Vec<&str> = frames.series.iter().map(|s| s.technique.as_str()).collect();
    assert_eq!(
        techniques,
        ["unsorted", "front-peel:layers=auto", "stochastic:spp=1"]
    );
    assert!(frames.series.iter().all(|s| s.points.len() == 8));
    assert_eq!(frames.series[0].pops, [(3.0, 0.4), (6.0, 0.01)]);
    assert!(frames.series[1].pops.is_empty() && frames.series[2].pops.is_empty());
    assert_eq!(frames.x_range, (0.0, 7.0));
    // 0 (front-peel) to 0.4 spans decades: a symmetric log whose threshold is the smallest
    // nonzero FLIP, with 0 drawn at the bottom.
    assert_eq!(
        frames.y_scale,
        YScale::SymLog {
            threshold: 0.01,
            hi: 0.4
        }
    );
    assert!(frames.y_label.contains("linear below 0.01, log above"));
    // Colours follow the families of the whole results: unsorted, front-peel, stochastic.
    let styles: Vec<usize> = frames.series.iter().map(|s| s.legend.style).collect();
    assert_eq!(styles, [0, 1, 2]);

    let convergence = &plots[1];
    assert_eq!(convergence.stem, "swap-convergence");
    assert_eq!(convergence.series.len(), 1);
    assert_eq!(convergence.series[0].technique, "stochastic:spp=1");
    assert_eq!(convergence.series[0].points[0], (1.0, 0.05));
    assert_eq!(convergence.series[0].points[7], (8.0, 0.016));
    assert!(
        convergence.title.contains("blend 0.1"),
        "{}",
        convergence.title
    );
}

#[test]
fn a_run_whose_series_does_not_match_its_frames_is_left_out_with_the_reason() {
    let mut results = results();
    if let Some(t) = results.runs[2].temporal.as_mut() {
        t.flip.pop();
    }
    let plots = motion_plot_data(&results);
    assert_eq!(plots[0].series.len(), 2);
    assert_eq!(
        plots[0].omitted,
        [(
            "front-peel:layers=auto".to_owned(),
            "7 FLIP values for 8 frames".to_owned()
        )]
    );
}

#[test]
fn the_pictures_name_every_technique_and_the_pop_mark() {
    for plot in motion_plot_data(&results()) {
        let svg = render_motion_svg(&plot).unwrap();
        for s in &plot.series {
            assert!(
                svg.contains(&s.legend.label),
                "{}: legend lacks {}",
                plot.stem,
                s.legend.label
            );
        }
        assert_eq!(
            svg.contains("pop event"),
            plot.kind == MotionKind::FlipOverFrames,
            "{}",
            plot.stem
        );
        assert!(svg.contains(&plot.x_label) && svg.contains(&plot.y_label));
        let png = image::load_from_memory(&render_motion_png(&plot).unwrap())
            .unwrap()
            .to_rgb8();
        assert_eq!(png.dimensions(), oit_report::PLOT_SIZE);
        for s in &plot.series {
            let (r, g, b) = oit_report::style_colour(s.legend.style);
            assert!(
                png.pixels().any(|p| p.0 == [r, g, b]),
                "{}: no pixel of {}'s colour",
                plot.stem,
                s.technique
            );
        }
    }
}

#[test]
fn motion_plots_are_written_beside_the_others_only_for_animated_scenes() {
    let dir = TempDir::new("write");
    let files = write_motion_plots(&results(), &dir.0.join("plots")).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "swap-flip-frames.svg",
            "swap-flip-frames.png",
            "swap-convergence.svg",
            "swap-convergence.png"
        ]
    );
    for f in &files {
        assert!(
            std::fs::metadata(f).unwrap().len() > 1000,
            "{}",
            f.display()
        );
    }
    let mut still = results();
    still.runs.retain(|r| r.scene == "still");
    let none = dir.0.join("none");
    assert!(write_motion_plots(&still, &none).unwrap().is_empty());
    assert!(!none.exists(), "nothing written, not even the folder");
}

#[test]
fn the_report_shows_motion_for_the_animated_scene_only() {
    let dir = TempDir::new("page");
    std::fs::write(
        dir.0.join("results.json"),
        serde_json::to_vec_pretty(&results()).unwrap(),
    )
    .unwrap();
    // unsorted's clip is on disk, the others' are not.
    std::fs::create_dir_all(dir.0.join("swap")).unwrap();
    image::RgbImage::from_pixel(6, 4, image::Rgb([9, 9, 9]))
        .save(dir.0.join("swap/unsorted-motion.png"))
        .unwrap();
    let page =
        oit_report::write_html_report(&dir.0, oit_report::Metric::Flip, &|t| t.to_owned()).unwrap();
    let html = std::fs::read_to_string(page).unwrap();
    assert_eq!(html.matches("<div class=\"motion\"").count(), 1);
    let motion = &html[html
        .find("<div class=\"motion\" id=\"swap-motion\">")
        .unwrap()..];
    let motion = &motion[..motion.find("</div>\n<div class=\"triple\">").unwrap()];
    assert!(motion.contains("<h3>Motion over 8 frames</h3>"), "{motion}");
    for plot in ["swap-flip-frames", "swap-convergence"] {
        assert!(
            motion.contains(&format!("<img src=\"plots/{plot}.svg\"")),
            "{plot}: {motion}"
        );
        assert!(dir.0.join(format!("plots/{plot}.png")).is_file(), "{plot}");
    }
    let mean = results().runs[1]
        .temporal
        .as_ref()
        .map_or(f64::NAN, |t| t.mean_flip);
    assert!(
        motion.contains(&format!(
            "<tr><td>unsorted</td><td>0.0100</td><td>2 (3, 6)</td><td>3 (0.4000)</td>\
             <td>{mean:.4}</td><td>0.5000</td><td>–</td><td>–</td>\
             <td class=\"text\"><a href=\"swap/unsorted-motion.png\">play</a></td></tr>"
        )),
        "{motion}"
    );
    assert!(
        motion.contains("<td>1.0e-3 / 0.0500</td>"),
        "static bias / noise: {motion}"
    );
    assert_eq!(motion.matches("-motion.png").count(), 1, "{motion}");
    // The skipped run has no motion row; the still scene's section has no motion part.
    assert!(!motion.contains("wboit"));
    let still = &html[html.find("<section id=\"still\">").unwrap()..];
    let still = &still[..still.find("</section>").unwrap()];
    assert!(!still.contains("motion"), "{still}");
}

/// The motion plots decode in a browser: headless Chromium loads the page of an animated scene
/// with every image (skipped, with a message, where Chromium is not installed, unless
/// OIT_REQUIRE_BROWSER=1).
#[test]
fn the_motion_plots_decode_in_headless_chromium() {
    const BROWSER: &str = "/usr/bin/chromium";
    if !std::path::Path::new(BROWSER).exists() {
        assert!(
            !std::env::var("OIT_REQUIRE_BROWSER").is_ok_and(|v| v == "1"),
            "OIT_REQUIRE_BROWSER=1 but {BROWSER} is missing"
        );
        eprintln!("skipped the_motion_plots_decode_in_headless_chromium: {BROWSER} not found");
        return;
    }
    let dir = TempDir::new("chromium");
    std::fs::write(
        dir.0.join("results.json"),
        serde_json::to_vec_pretty(&results()).unwrap(),
    )
    .unwrap();
    let page =
        oit_report::write_html_report(&dir.0, oit_report::Metric::Flip, &|t| t.to_owned()).unwrap();
    let out = std::process::Command::new(BROWSER)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--virtual-time-budget=10000",
        ])
        .arg(format!(
            "--user-data-dir={}",
            dir.0.join("profile").display()
        ))
        .arg("--dump-dom")
        .arg(format!("file://{}", page.display()))
        .output()
        .unwrap();
    assert!(out.status.success(), "{BROWSER} failed: {}", out.status);
    let dom = String::from_utf8_lossy(&out.stdout);
    let body = &dom[dom.find("<body").unwrap()..];
    let body = &body[..body.find('>').unwrap()];
    // The two legend bars, two speed plots per scene and the two motion plots; no run has
    // render PNGs on disk (notes instead).
    assert!(body.contains("data-images-ok=\"8/8\""), "{body}");
    assert!(body.contains("data-errors=\"\""), "{body}");
}
