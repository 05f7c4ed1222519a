//! How `stochastic`'s patterns converge over animation frames at a static camera: the scene is
//! rendered as frames 0, 1, 2, … (`Scene::frame`, so every frame gets fresh thresholds) and
//! each frame's image is accumulated two ways, against the exact CPU reference:
//!
//! - the plain mean of the first N frames (white noise: RMSE ∝ N^−½);
//! - an exponential history `h_t = 0.9·h_{t−1} + 0.1·frame_t`, `h_0 = frame_0`, what a TAA
//!   resolve keeps and what the spatiotemporal blue-noise paper's figures use.
//!
//! Printed per pattern (white, blue, bayer8, stbn, hashed): per-pixel RGB RMSE after N frames,
//! the mean's log-log slope over N = 1..frames (powers of two), and the flicker (RMS of the
//! change of the error image from one frame to the next, averaged over frames).
//!
//! `cargo run --release -p oit-tools --bin temporal_noise -- SCENE.json [--resolution WxH]
//! [--frames N] [--spp N]` (defaults: 128x128, 64 frames, spp 1).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context as _, Result, anyhow, bail};
use oit_gpu::{ColorFormat, Context, ContextOptions, GpuScene, GpuTimer, Targets, TechniqueSpec};
use oit_scene::{LinearImage, Resolution, Scene};

const PATTERNS: [&str; 5] = ["white", "blue", "bayer8", "stbn", "hashed"];

struct Args {
    scene: PathBuf,
    resolution: Resolution,
    frames: u32,
    spp: u32,
}

fn parse_args() -> Result<Args> {
    let mut args = std::env::args().skip(1);
    let mut scene = None;
    let mut resolution = Resolution {
        width: 128,
        height: 128,
    };
    let mut frames = 64;
    let mut spp = 1;
    while let Some(a) = args.next() {
        let mut value = |name: &str| args.next().ok_or_else(|| anyhow!("{name} needs a value"));
        match a.as_str() {
            "--resolution" => {
                let v = value("--resolution")?;
                let (w, h) = v
                    .split_once('x')
                    .ok_or_else(|| anyhow!("--resolution is WxH, got {v}"))?;
                resolution = Resolution {
                    width: w.parse().with_context(|| format!("width in {v}"))?,
                    height: h.parse().with_context(|| format!("height in {v}"))?,
                };
            }
            "--frames" => frames = value("--frames")?.parse().context("--frames")?,
            "--spp" => spp = value("--spp")?.parse().context("--spp")?,
            other if other.starts_with("--") => bail!("unknown option {other}"),
            path => scene = Some(PathBuf::from(path)),
        }
    }
    if frames == 0 {
        bail!("--frames must be at least 1");
    }
    Ok(Args {
        scene: scene.ok_or_else(|| {
            anyhow!("usage: temporal_noise SCENE.json [--resolution WxH] [--frames N] [--spp N]")
        })?,
        resolution,
        frames,
        spp,
    })
}

/// Per-pixel RGB RMSE of `values` (RGB triples, f64) against `reference`.
fn rmse(values: &[[f64; 3]], reference: &LinearImage) -> f64 {
    let mut sum = 0.0;
    for (v, r) in values.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let d = v[c] - f64::from(r[c]);
            sum += d * d;
        }
    }
    (sum / (3 * values.len()) as f64).sqrt()
}

/// Least-squares slope of ln(y) against ln(x).
fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + x.ln() / n, b + y.ln() / n)
    });
    let (mut cov, mut var) = (0.0, 0.0);
    for (x, y) in points {
        cov += (x.ln() - mx) * (y.ln() - my);
        var += (x.ln() - mx) * (x.ln() - mx);
    }
    cov / var
}

struct Series {
    /// (N, RMSE of the mean of the first N frames, RMSE of the history after N frames).
    at: Vec<(u32, f64, f64)>,
    flicker: f64,
    ms_per_frame: f64,
}

fn measure(
    ctx: &Context,
    scene: &Scene,
    reference: &LinearImage,
    spec: &str,
    frames: u32,
) -> Result<Series> {
    let mut technique = TechniqueSpec::build(spec, &oit_harness::registry())?;
    let mut gpu = GpuScene::upload(ctx, scene)?;
    let targets = Targets::new(ctx, scene.resolution, ColorFormat::Rgba16Float)?;
    let mut timer = GpuTimer::new(ctx);
    let pixels = reference.pixels.len();
    let mut sum = vec![[0.0f64; 3]; pixels];
    let mut history = vec![[0.0f64; 3]; pixels];
    let mut previous_error: Option<Vec<[f64; 3]>> = None;
    let (mut flicker_sum, mut flicker_count) = (0.0, 0);
    let mut at = Vec::new();
    let mut started = std::time::Instant::now();
    for t in 0..frames {
        if t == 1 {
            // Frame 0 builds the pipelines and the threshold table: not timed.
            started = std::time::Instant::now();
        }
        gpu.scene = Scene {
            frame: t,
            ..scene.clone()
        };
        oit_gpu::render_frame(ctx, &gpu, technique.as_mut(), &targets, &mut timer)?;
        let image = oit_gpu::read_color(ctx, &targets)?;
        let mut error = vec![[0.0f64; 3]; pixels];
        for (p, px) in image.pixels.iter().enumerate() {
            for c in 0..3 {
                let v = f64::from(px[c]);
                sum[p][c] += v;
                history[p][c] = if t == 0 {
                    v
                } else {
                    0.9 * history[p][c] + 0.1 * v
                };
                error[p][c] = v - f64::from(reference.pixels[p][c]);
            }
        }
        if let Some(prev) = &previous_error {
            let mut s = 0.0;
            for (e, q) in error.iter().zip(prev) {
                for c in 0..3 {
                    s += (e[c] - q[c]) * (e[c] - q[c]);
                }
            }
            flicker_sum += (s / (3 * pixels) as f64).sqrt();
            flicker_count += 1;
        }
        previous_error = Some(error);
        let n = t + 1;
        if n.is_power_of_two() || n == frames {
            let mean: Vec<[f64; 3]> = sum.iter().map(|s| s.map(|v| v / f64::from(n))).collect();
            at.push((n, rmse(&mean, reference), rmse(&history, reference)));
        }
    }
    Ok(Series {
        at,
        flicker: flicker_sum / f64::from(flicker_count.max(1)),
        ms_per_frame: started.elapsed().as_secs_f64() * 1e3 / f64::from(frames.max(2) - 1),
    })
}

fn run() -> Result<()> {
    let args = parse_args()?;
    let scene = oit_scene::load(&args.scene)
        .with_context(|| format!("loading {}", args.scene.display()))?
        .with_resolution(args.resolution);
    let ctx = Context::new(&ContextOptions::default())?;
    let info = ctx.adapter_info();
    println!("adapter: {} ({}, {})", info.name, info.backend, info.driver);
    println!(
        "scene {} at {}x{}, {} frames, spp {}, static camera",
        args.scene.display(),
        args.resolution.width,
        args.resolution.height,
        args.frames,
        args.spp
    );
    let reference = oit_reference::render(&scene, &Default::default()).image;
    let mut rows = Vec::new();
    for pattern in PATTERNS {
        let spec = format!("stochastic:pattern={pattern},spp={}", args.spp);
        let series = measure(&ctx, &scene, &reference, &spec, args.frames)?;
        rows.push((pattern, series));
    }
    let ns: Vec<u32> = rows[0].1.at.iter().map(|a| a.0).collect();
    let header: String = ns.iter().map(|n| format!(" | {n}")).collect();
    let rule: String = ns.iter().map(|_| "|---").collect();
    println!("\nRMSE of the exponential history (0.1) after N frames\n");
    println!("| pattern{header} | flicker |");
    println!("|---{rule}|---|");
    for (pattern, s) in &rows {
        let cells: String = s.at.iter().map(|a| format!(" | {:.4}", a.2)).collect();
        println!("| {pattern}{cells} | {:.4} |", s.flicker);
    }
    println!(
        "\nSTBN volume generated in {:.3} s (once per process)",
        oit_stochastic::stbn::stbn().1.as_secs_f64()
    );
    println!(
        "\nRMSE of the mean of the first N frames (ms/frame: frames 1.., render and readback)\n"
    );
    println!("| pattern{header} | slope | ms/frame |");
    println!("|---{rule}|---|---|");
    for (pattern, s) in &rows {
        let cells: String = s.at.iter().map(|a| format!(" | {:.4}", a.1)).collect();
        let points: Vec<(f64, f64)> = s.at.iter().map(|a| (f64::from(a.0), a.1)).collect();
        let slope = if points.len() > 1 {
            format!("{:.3}", log_log_slope(&points))
        } else {
            "-".to_owned()
        };
        println!("| {pattern}{cells} | {slope} | {:.1} |", s.ms_per_frame);
    }
    Ok(())
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("temporal_noise: {e:#}");
            ExitCode::from(2)
        }
    }
}
