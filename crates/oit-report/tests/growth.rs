//! The growth tables and plots of a hand-made sweep: `linear` costs x ms and `square` x² ms
//! over x = 1, 2, 4, 8 (times a seeded jitter of at most 1 %), the floor ½·x ms; `square`'s
//! error passes the bound at x = 4, and its run at x = 8 was skipped, which is a note, not a
//! break. The fitted exponents, the break points, the files and the report section follow.

use oit_report::{
    GrowthKind, Metric, growth_charts, growth_data, growth_markdown, write_growth_plots,
    write_html_report_with,
};
use oit_results::{AdapterJson, FloorJson, GpuMs, Results, Run, RunStatus, SCHEMA, Varied};

fn gpu_ms(median: f64) -> GpuMs {
    GpuMs {
        median,
        min: median,
        max: median,
        frames: 1,
        source: "timestamp".into(),
        interference: None,
        attempts: 1,
    }
}

fn varied(x: u32) -> Varied {
    Varied {
        base_scene: "stack".into(),
        parameter: "/objects/0/mesh/count".into(),
        label: "count".into(),
        value: x.to_string(),
        x: f64::from(x),
    }
}

fn results(seed: u64) -> Results {
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let mut jitter = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        1.0 + 0.01 * ((state % 2001) as f64 / 1000.0 - 1.0)
    };
    let mut runs = Vec::new();
    let mut floors = Vec::new();
    for x in [1u32, 2, 4, 8] {
        let scene = format!("stack[count={x}]");
        let xf = f64::from(x);
        let floor = 0.5 * xf;
        floors.push(FloorJson {
            scene: scene.clone(),
            resolution: [8, 8],
            gpu_ms: gpu_ms(floor),
            passes: Vec::new(),
            shard: None,
            target_format: Default::default(),
        });
        for (technique, ms, flip) in [
            ("linear", xf * jitter(), 0.001 * xf),
            ("square", xf * xf * jitter(), 0.02 * xf),
        ] {
            let mut run = Run::not_rendered(
                &scene,
                "stack.json",
                technique,
                [8, 8],
                RunStatus::Ok,
                String::new(),
            );
            run.varied = Some(varied(x));
            if technique == "square" && x == 8 {
                run.status = RunStatus::Skipped;
                run.reason = Some("past the run budget".into());
            } else {
                run.reason = None;
                run.gpu_ms = Some(gpu_ms(ms));
                run.cost_vs_floor = Some(ms / floor);
                run.error = Some(oit_metrics::Errors {
                    flip_mean: flip,
                    rmse: flip,
                    ..Default::default()
                });
            }
            runs.push(run);
        }
    }
    // A run of another scene, not swept: no growth row of its own.
    runs.push(Run::not_rendered(
        "other",
        "other.json",
        "linear",
        [8, 8],
        RunStatus::Failed,
        "x".into(),
    ));
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
        floors,
        scenes: Vec::new(),
        shard: None,
        merged: Vec::new(),
    }
}

#[test]
fn exponents_breaks_and_skipped_values_of_a_sweep() {
    for seed in 1..6 {
        let results = results(seed);
        let sweeps = growth_data(&results, Metric::Flip, 0.05);
        assert_eq!(sweeps.len(), 1);
        let sweep = &sweeps[0];
        assert_eq!(sweep.label, "count");
        let names: Vec<&str> = sweep.rows.iter().map(|r| r.technique.as_str()).collect();
        assert_eq!(names, ["floor", "linear", "square"]);
        let [floor, linear, square] = &sweep.rows[..] else {
            panic!("{names:?}");
        };
        let b = |r: &oit_report::GrowthRow| r.ms_fit.as_ref().unwrap().b;
        assert!((b(floor) - 1.0).abs() < 1e-9);
        assert!((b(linear) - 1.0).abs() < 0.02, "seed {seed}: {}", b(linear));
        assert!((b(square) - 2.0).abs() < 0.02, "seed {seed}: {}", b(square));
        assert_eq!(square.ms_fit.as_ref().unwrap().points, 3);
        // Cost × floor: linear stays flat against the floor, square grows as x.
        let bf = |r: &oit_report::GrowthRow| r.floor_fit.as_ref().unwrap().as_ref().unwrap().b;
        assert!(bf(linear).abs() < 0.02 && (bf(square) - 1.0).abs() < 0.02);
        // 0.02·x passes 0.05 at x = 4; linear's 0.001·x never does.
        assert_eq!(square.breaks_at.as_ref().unwrap().value, "4");
        assert!(linear.breaks_at.is_none());
        assert!(
            square.points[3]
                .not_run
                .as_deref()
                .unwrap()
                .contains("run budget")
        );

        let table = growth_markdown(&results, Metric::Flip, 0.05);
        assert!(
            table.contains("## How cost grows: stack over `count`"),
            "{table}"
        );
        assert!(table.contains("exceeds 0.05"), "{table}");
        let square_line = table.lines().find(|l| l.starts_with("| square")).unwrap();
        let b_cell: f64 = square_line
            .split('|')
            .nth(2)
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        assert!((b_cell - 2.0).abs() <= 0.02, "{square_line}");
        assert!(
            square_line.contains("count = 4 (mean FLIP 0.08)"),
            "{square_line}"
        );
        assert!(square_line.contains("not run at 8"), "{square_line}");
        let linear_line = table.lines().find(|l| l.starts_with("| linear")).unwrap();
        assert!(linear_line.contains("holds"), "{linear_line}");

        // A higher bound moves the break.
        let later = growth_data(&results, Metric::Flip, 0.07);
        assert_eq!(later[0].rows[2].breaks_at.as_ref().unwrap().value, "4");
        let none = growth_data(&results, Metric::Flip, 0.1);
        assert!(none[0].rows[2].breaks_at.is_none());
    }
}

#[test]
fn a_sweep_of_one_value_says_why_it_has_no_fit() {
    let mut results = results(1);
    results
        .runs
        .retain(|r| r.varied.as_ref().is_none_or(|v| v.value == "2"));
    let table = growth_markdown(&results, Metric::Flip, 0.05);
    assert!(
        table.contains("no fit: a power law needs at least 2 points, got 1"),
        "{table}"
    );
}

#[test]
fn results_without_sweeps_have_no_growth_section() {
    let mut results = results(1);
    for run in &mut results.runs {
        run.varied = None;
    }
    assert!(growth_data(&results, Metric::Flip, 0.05).is_empty());
    assert!(growth_markdown(&results, Metric::Flip, 0.05).is_empty());
}

#[test]
fn plots_and_the_report_section_are_written() {
    let dir = std::env::temp_dir().join(format!("oit-report-growth-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let results = results(3);
    let charts = growth_charts(&results, Metric::Flip, 0.05);
    let kinds: Vec<GrowthKind> = charts.iter().map(|c| c.kind).collect();
    assert_eq!(kinds, GrowthKind::ALL);
    // The floor is drawn on the ms plot only; the error plot carries the bound.
    assert_eq!(charts[0].lines.len(), 3);
    assert_eq!(charts[2].lines.len(), 2);
    assert_eq!(charts[2].bound, Some(0.05));
    assert!(
        charts[0].lines[1].0.label.starts_with("linear (b "),
        "{:?}",
        charts[0].lines[1].0
    );
    let files = write_growth_plots(&results, &dir.join("plots"), Metric::Flip, 0.05).unwrap();
    assert_eq!(files.len(), 6);
    for f in &files {
        assert!(
            std::fs::metadata(f).unwrap().len() > 1000,
            "{}",
            f.display()
        );
    }
    let svg = std::fs::read_to_string(dir.join("plots/stack-count-growth-error.svg")).unwrap();
    assert!(svg.contains("break bound 0.05"));

    std::fs::write(
        dir.join("results.json"),
        serde_json::to_string(&results).unwrap(),
    )
    .unwrap();
    let page = write_html_report_with(&dir, Metric::Flip, &|t| t.to_owned(), 0.05).unwrap();
    let html = std::fs::read_to_string(page).unwrap();
    assert!(
        html.contains("<section id=\"growth\">"),
        "no growth section"
    );
    for kind in GrowthKind::ALL {
        assert!(
            html.contains(&format!("plots/stack-count-{}.png", kind.suffix())),
            "{kind:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
