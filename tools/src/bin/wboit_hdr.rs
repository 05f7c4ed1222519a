//! Per-pixel error budget of the default `wboit` on one scene (default `hdr-emissive`):
//! `cargo run -p oit-tools --release --bin wboit_hdr -- [SCENE] [SIZE]`.
//!
//! Recovers every pixel's transparent fragments (premultiplied colour, α, view distance) from
//! one CPU reference render per transparent draw, so it needs scenes where no draw covers a
//! pixel twice (checked). Then it splits the GPU's error into
//!
//! - the *weight* term: WBOIT evaluated in f64 with the same weights, against the exact
//!   composite (what no accumulation format can fix), and
//! - the *precision* term: the GPU output against that f64 WBOIT (fp16 sums, r16f revealage,
//!   the fp16 target, saturation at 65504),
//!
//! and prints the guard counts, the largest raw accumulation value, and the worst pixels with
//! their fragment lists. Alternative weights are evaluated in f64 next to the default.

use anyhow::{Result, bail};
use oit_gpu::{ColorFormat, GpuScene, GpuTimer, Targets, read_color, render_frame};
use oit_scene::{AlphaMode, Resolution, Scene};
use oit_wboit::{Config, RangeParams, Wboit};
use std::path::Path;

/// One transparent fragment of a pixel.
#[derive(Debug, Clone, Copy)]
struct Fragment {
    draw: usize,
    z: f64,
    alpha: f64,
    color: [f64; 3],
}

/// What [`isolate`] does to the kept draw's material.
#[derive(Clone, Copy, PartialEq)]
enum Keep {
    /// As it is: the image is the premultiplied colour.
    Colour,
    /// Base colour 1, intensity 1, straight colour: with vertex rgb 1 the image is α.
    Coverage,
    /// Opaque with base colour 1 and intensity 1: the image is the vertex rgb.
    Opaque,
}

/// The scene with only draw `keep` transparent, every other transparent draw removed, opaque
/// draws black, on a black background; `vertex` rewrites the kept draw's vertex colours.
fn isolate(
    scene: &Scene,
    keep: usize,
    vertex: impl Fn([f32; 3], [f32; 4]) -> [f32; 4],
    how: Keep,
) -> Scene {
    let mut s = scene.clone();
    s.background = [0.0; 3];
    let mut draws = Vec::new();
    for (i, d) in scene.draws.iter().enumerate() {
        let m = scene.material_of(d);
        if i == keep {
            let mut m = *m;
            if how != Keep::Colour {
                if how == Keep::Opaque {
                    m.mode = AlphaMode::Opaque;
                }
                m.base_color = [1.0; 3];
                m.intensity = 1.0;
                m.premultiplied = false;
            }
            let mut d = d.clone();
            d.material = s.materials.len() as u32;
            s.materials.push(m);
            for v in &mut s.vertices[d.vertex_range()] {
                v.color = vertex(v.position, v.color);
            }
            draws.push(d);
        } else if !m.mode.is_transparent() {
            let mut m = *m;
            m.base_color = [0.0; 3];
            let mut d = d.clone();
            d.material = s.materials.len() as u32;
            s.materials.push(m);
            draws.push(d);
        }
    }
    s.draws = draws;
    s
}

/// Per pixel, the transparent fragments in front of the opaque surface, front to back.
fn fragments(scene: &Scene) -> Result<Vec<Vec<Fragment>>> {
    let opts = Default::default();
    let n = scene.resolution.pixel_count();
    let mut out = vec![Vec::new(); n];
    let view = scene.camera.view;
    for (i, d) in scene.draws.iter().enumerate() {
        let m = scene.material_of(d);
        if !m.mode.is_transparent() {
            continue;
        }
        let colour = oit_reference::render(&isolate(scene, i, |_, c| c, Keep::Colour), &opts);
        if let Some(p) = colour.layers.iter().position(|&l| l > 1) {
            bail!(
                "{}: draw {} covers pixel {p} {} times; this diagnostic needs at most once",
                scene.name,
                d.name,
                colour.layers[p]
            );
        }
        let alpha = oit_reference::render(
            &isolate(scene, i, |_, c| [1.0, 1.0, 1.0, c[3]], Keep::Coverage),
            &opts,
        );
        // View distance is affine in world position, so perspective-correct interpolation of
        // it as a vertex colour is exact (up to f32).
        let depth = oit_reference::render(
            &isolate(
                scene,
                i,
                |p, c| {
                    let z = -view.transform_point3(glam::Vec3::from(p)).z;
                    [z, z, z, c[3]]
                },
                Keep::Opaque,
            ),
            &opts,
        );
        for (p, list) in out.iter_mut().enumerate() {
            if colour.layers[p] == 1 {
                let c = colour.image.pixels[p];
                list.push(Fragment {
                    draw: i,
                    z: f64::from(depth.image.pixels[p][0]),
                    alpha: f64::from(alpha.image.pixels[p][0]),
                    color: [c[0], c[1], c[2]].map(f64::from),
                });
            }
        }
    }
    for list in &mut out {
        list.sort_by(|a, b| a.z.total_cmp(&b.z));
    }
    Ok(out)
}

/// WBOIT in f64 with weight `w(fragment, transmittance in front)`: avg·(1 − T) + T·dst.
fn wboit(list: &[Fragment], dst: [f64; 3], w: impl Fn(&Fragment, f64) -> f64) -> [f64; 3] {
    let (mut sum, mut sum_a, mut t) = ([0.0; 3], 0.0, 1.0);
    for f in list {
        let wt = w(f, t);
        for (s, c) in sum.iter_mut().zip(f.color) {
            *s += c * wt;
        }
        sum_a += f.alpha * wt;
        t *= 1.0 - f.alpha;
    }
    if list.is_empty() {
        return dst;
    }
    std::array::from_fn(|c| {
        let avg = if sum_a > 0.0 { sum[c] / sum_a } else { 0.0 };
        avg * (1.0 - t) + t * dst[c]
    })
}

fn exact(list: &[Fragment], dst: [f64; 3]) -> [f64; 3] {
    let (mut out, mut t) = ([0.0; 3], 1.0);
    for f in list {
        for (o, c) in out.iter_mut().zip(f.color) {
            *o += t * c;
        }
        t *= 1.0 - f.alpha;
    }
    std::array::from_fn(|c| out[c] + t * dst[c])
}

/// RMSE and max absolute error over RGB.
fn errors(a: &[[f64; 3]], b: &[[f64; 3]]) -> (f64, f64) {
    let (mut sq, mut max) = (0.0, 0.0f64);
    for (p, q) in a.iter().zip(b) {
        for c in 0..3 {
            let d = p[c] - q[c];
            sq += d * d;
            max = max.max(d.abs());
        }
    }
    ((sq / (3 * a.len()) as f64).sqrt(), max)
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("hdr-emissive", String::as_str);
    let size: u32 = args.get(1).map_or(Ok(128), |s| s.parse())?;
    let Some(ctx) = oit_gpu::testing::context_or_skip("wboit_hdr") else {
        bail!("no GPU adapter");
    };
    println!(
        "adapter: {} ({})",
        ctx.adapter_info().name,
        ctx.adapter_info().backend
    );
    let res = Resolution {
        width: size,
        height: size,
    };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.json"));
    let scene = oit_scene::load(&path)?.with_resolution(res);
    let reference = oit_reference::render(&scene, &Default::default());
    let lists = fragments(&scene)?;
    let mut opaque_only = scene.clone();
    opaque_only
        .draws
        .retain(|d| !scene.material_of(d).mode.is_transparent());
    let dst: Vec<[f64; 3]> = oit_reference::render(&opaque_only, &Default::default())
        .image
        .pixels
        .iter()
        .map(|p| [p[0], p[1], p[2]].map(f64::from))
        .collect();
    let refimg: Vec<[f64; 3]> = reference
        .image
        .pixels
        .iter()
        .map(|p| [p[0], p[1], p[2]].map(f64::from))
        .collect();
    let emulated_exact: Vec<[f64; 3]> = lists.iter().zip(&dst).map(|(l, &d)| exact(l, d)).collect();
    let (e, m) = errors(&emulated_exact, &refimg);
    println!(
        "fragment lists recovered: exact composite of them vs the reference rmse {e:.2e} max {m:.2e}"
    );

    let range = RangeParams::of(&scene);
    println!("range params: {range:?}");
    let max_premultiplied = lists
        .iter()
        .flatten()
        .flat_map(|f| f.color)
        .fold(0.0f64, f64::max);
    // What the colour sums would reach without the colour scale (fp16 holds 65504).
    let unscaled_sum = lists
        .iter()
        .flat_map(|l| {
            (0..3).map(move |c| {
                l.iter()
                    .map(|f| f.color[c] * f64::from(range.weight(f.z as f32)))
                    .sum::<f64>()
            })
        })
        .fold(0.0f64, f64::max);
    println!(
        "largest premultiplied fragment colour: {max_premultiplied:.1}; largest colour sum with the range weight in units of 1: {unscaled_sum:.0}, in units of the colour scale: {:.0}",
        unscaled_sum / f64::from(range.color_scale)
    );

    // The GPU's default wboit, its guards and raw sums.
    let gpu = GpuScene::upload(&ctx, &scene)?;
    let targets = Targets::new(&ctx, res, ColorFormat::Rgba16Float)?;
    let mut technique = Wboit::new(Config::DEFAULT);
    render_frame(
        &ctx,
        &gpu,
        &mut technique,
        &targets,
        &mut GpuTimer::wall_clock(),
    )?;
    let image = read_color(&ctx, &targets)?;
    let guards = technique.last_guard_counts(&ctx)?.unwrap_or_default();
    let accum = technique.accum_targets().expect("rendered");
    let raw = oit_gpu::read_texture(&ctx, &accum.accum, 8, "accumulation")?;
    let raw_max = raw
        .chunks_exact(2)
        .map(|b| oit_gpu::f16_to_f32(u16::from_le_bytes([b[0], b[1]])))
        .fold(0.0f32, f32::max);
    println!(
        "default wboit guards: [{guards}]; largest raw accumulation channel {raw_max} (fp16 max 65504)"
    );
    let gpu_img: Vec<[f64; 3]> = image
        .pixels
        .iter()
        .map(|p| [p[0], p[1], p[2]].map(f64::from))
        .collect();
    let e = oit_metrics::compare(&image, &reference.image)?;
    println!(
        "default wboit on the GPU vs reference: rmse {:.4} max {:.4} flip {:.4}",
        e.rmse,
        e.max_abs,
        e.headline_flip().0
    );

    // The weight term and the precision term of the default.
    let w_range = move |f: &Fragment, _: f64| f64::from(range.weight(f.z as f32));
    let f64_range: Vec<[f64; 3]> = lists
        .iter()
        .zip(&dst)
        .map(|(l, &d)| wboit(l, d, w_range))
        .collect();
    let (we, wm) = errors(&f64_range, &refimg);
    let (pe, pm) = errors(&gpu_img, &f64_range);
    println!(
        "weight term (f64 WBOIT with the range weight vs reference): rmse {we:.4} max {wm:.4}"
    );
    println!("precision term (GPU vs f64 WBOIT, same weight): rmse {pe:.4} max {pm:.4}");

    // The fall from the exact per-pixel lists, over every covered pixel (what RangeParams
    // estimated before) and over pixels with two or more layers (what it estimates now, on its
    // 64x64 grid), for comparison with the grid estimate printed above.
    let fall_over = |min_layers: usize| {
        let (mut sum, mut n) = (0.0, 0usize);
        for l in lists.iter().filter(|l| l.len() >= min_layers.max(1)) {
            let bits: f64 = l.iter().map(|f| -(1.0 - f.alpha.min(0.999)).log2()).sum();
            sum += bits * (l.len() - 1) as f64 / l.len() as f64;
            n += 1;
        }
        if n == 0 { 0.0 } else { sum / n as f64 }
    };
    let (fall_all, fall_multi) = (fall_over(1), fall_over(2));
    println!(
        "fall from the pixel lists: every covered pixel {fall_all:.4}, pixels with >= 2 layers {fall_multi:.4}"
    );
    // 2^(-fall * t) on the scene's transparent depth interval.
    let curve = move |f: &Fragment, fall: f64| {
        let span = f64::from(range.z_far - range.z_near);
        let t = if span > 0.0 {
            ((f.z - f64::from(range.z_near)) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (-fall * t).exp2()
    };
    type WeightFn<'a> = Box<dyn Fn(&Fragment, f64) -> f64 + 'a>;
    let variants: Vec<(&str, WeightFn)> = vec![
        ("range (the default)", Box::new(w_range)),
        (
            "range times alpha",
            Box::new(move |f: &Fragment, _| f.alpha * f64::from(range.weight(f.z as f32))),
        ),
        (
            "alpha * 2^(-fall t), fall over all pixels",
            Box::new(move |f: &Fragment, _| f.alpha * curve(f, fall_all)),
        ),
        (
            "2^(-fall t), fall over all pixels",
            Box::new(move |f: &Fragment, _| curve(f, fall_all)),
        ),
        ("const", Box::new(|_: &Fragment, _| 1.0)),
        ("alpha", Box::new(|f: &Fragment, _| f.alpha)),
        (
            "exact transmittance in front (ideal)",
            Box::new(|_: &Fragment, t| t),
        ),
        (
            "alpha * exact transmittance",
            Box::new(|f: &Fragment, t| f.alpha * t),
        ),
    ];
    println!("weights in f64 against the reference:");
    for (label, w) in &variants {
        let img: Vec<[f64; 3]> = lists
            .iter()
            .zip(&dst)
            .map(|(l, &d)| wboit(l, d, w))
            .collect();
        let (e, m) = errors(&img, &refimg);
        println!("  {label:40} rmse {e:8.4} max {m:8.4}");
    }

    // Where the default's error is, by layer count.
    let mut by_layers: std::collections::BTreeMap<usize, (usize, f64, f64)> = Default::default();
    for (p, l) in lists.iter().enumerate() {
        let entry = by_layers.entry(l.len()).or_default();
        entry.0 += 1;
        for c in 0..3 {
            let d = gpu_img[p][c] - refimg[p][c];
            entry.1 += d * d;
            entry.2 = entry.2.max(d.abs());
        }
    }
    let total: f64 = by_layers.values().map(|v| v.1).sum();
    println!("default wboit error by layer count (share of the squared error, max):");
    for (layers, (pixels, sq, max)) in &by_layers {
        println!(
            "  {layers} layers: {pixels:6} px, {:5.1} % of squared error, max {max:.3}",
            100.0 * sq / total.max(f64::MIN_POSITIVE)
        );
    }
    let mut worst: Vec<usize> = (0..lists.len()).collect();
    let err = |p: usize| {
        (0..3)
            .map(|c| (gpu_img[p][c] - refimg[p][c]).abs())
            .fold(0.0, f64::max)
    };
    worst.sort_by(|&a, &b| err(b).total_cmp(&err(a)));
    println!(
        "worst pixels (front to back: draw, view distance, alpha, premultiplied colour, range weight):"
    );
    for &p in worst.iter().take(3) {
        println!(
            "  pixel ({}, {}): reference {:.2?} gpu {:.2?} f64 range {:.2?}",
            p % size as usize,
            p / size as usize,
            refimg[p],
            gpu_img[p],
            f64_range[p]
        );
        for f in &lists[p] {
            println!(
                "    {} z {:.4} alpha {:.3} C {:.2?} w {:.3}",
                scene.draws[f.draw].name,
                f.z,
                f.alpha,
                f.color,
                w_range(f, 0.0)
            );
        }
    }
    Ok(())
}
