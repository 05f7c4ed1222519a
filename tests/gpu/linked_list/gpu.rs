//! GPU tests of the linked list (lavapipe in CI) against the exact reference and against its
//! CPU twin (`oit_linked_list::node`). Skips with a message when there is no adapter (fails in
//! CI with OIT_REQUIRE_GPU=1).

use oit_gpu::testing::{context_or_skip, gl_context_or_skip, is_llvmpipe};
use oit_gpu::{ColorFormat, Context, RenderStats, Technique};
use oit_linked_list::node::{self, NodeFormat};
use oit_linked_list::{LinkedList, LinkedListConfig, TailRule};
use oit_scene::{LinearImage, Resolution, Scene};

const RES: Resolution = Resolution {
    width: 128,
    height: 128,
};

/// The Rgba16Float target's rounding, relative above 1: a binary16 target (and the f32 node's
/// binary16 colour) rounds values to 2^-11 of themselves each, e.g. 0.03 at 64. Measured on
/// lavapipe at 128² (Vulkan and GL alike): worst 9.7e-4 on the bundled scenes
/// (gltf-alpha-blend-modes; hdr-emissive 8.8e-4), 8.4e-4 on the random ones; the bound is
/// 2.1× that (the issue's Done-when bound was 4e-3).
const MAX_HALF: f64 = 2e-3;

/// Bound on |GPU − CPU twin| relative to max(1, |value|) for a resolve whose every value stays
/// in f32 (Rgba32Float target): measured ≤ 6.2e-8 on lavapipe (one ulp), bounded there at 4×;
/// other adapters may contract the compositing chain into FMAs otherwise, so 1e-5 there.
fn f32_twin_tolerance(ctx: &Context) -> f32 {
    if is_llvmpipe(ctx) { 2.5e-7 } else { 1e-5 }
}

fn scene(name: &str) -> Scene {
    let path = crate::kit::scenes_dir().join(format!("{name}.json"));
    oit_scene::load(&path)
        .unwrap_or_else(|e| panic!("bundled scene {name}: {e}"))
        .with_resolution(RES)
}

/// The bundled scenes; those with coloured transmission only for a technique that composites
/// it exactly on this adapter (`Technique::transmission`).
fn bundled_names(ctx: &Context, technique: &dyn Technique) -> Vec<String> {
    let dir = crate::kit::scenes_dir();
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("scenes/ exists")
        .filter_map(|e| {
            let p = e.ok()?.path();
            (p.extension()? == "json")
                .then(|| p.file_stem().map(|s| s.to_string_lossy().into_owned()))?
        })
        .collect();
    names.sort();
    assert!(names.len() >= 10, "bundled scenes missing: {names:?}");
    // Render-queue scenes: lists composite by depth alone and say so (`queue order not
    // modelled`); harness::predictions holds them to that.
    names.retain(|n| {
        oit_scene::load(&dir.join(format!("{n}.json")))
            .map(|s| !s.has_queue_effects())
            .unwrap_or(true)
    });
    // Where the technique composites 1 − mean(t) (no dual-source blending), coloured
    // transmission is approximate by design (flagged `approximate transmission` in every
    // report) and not an exactness case; grey filters (gltf-glass-vase) always stay in.
    let support = technique.transmission(&ctx.caps);
    if support != oit_gpu::Support::Exact {
        names.retain(|name| {
            let coloured = scene(name).has_coloured_transmission();
            if coloured {
                println!("{name}: coloured transmission, {support:?}: left out");
            }
            !coloured
        });
    }
    names
}

fn render(
    ctx: &Context,
    scene: &Scene,
    technique: &mut dyn Technique,
    format: ColorFormat,
) -> (LinearImage, RenderStats) {
    let (image, frame) = crate::kit::render(ctx, scene, technique, format);
    (image, frame.stats)
}

/// Largest RGB difference from `b`, relative to `max(1, |b|)`, over the pixels not skipped.
fn max_diff_except(a: &LinearImage, b: &LinearImage, skip: &[bool]) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .zip(skip)
        .filter(|(_, s)| !**s)
        .flat_map(|((p, q), _)| {
            (0..3).map(move |c| f64::from((p[c] - q[c]).abs() / q[c].abs().max(1.0)))
        })
        .fold(0.0, f64::max)
}

fn ample(reference: &oit_reference::Reference, pixels: u64) -> LinkedListConfig {
    LinkedListConfig {
        nodes_per_pixel: oit_linked_list::Sizing::Fixed(
            oit_linked_list::NodesPerPixel::new(
                (reference.stats.transparent_fragments.div_ceil(pixels) as u32 + 1)
                    .min(oit_linked_list::MAX_NODES_PER_PIXEL as u32),
            )
            .expect("clamped to the range"),
        ),
        sort_max: oit_linked_list::Sizing::Fixed(
            oit_linked_list::SortMax::new(
                reference
                    .stats
                    .max_depth_complexity
                    .clamp(1, oit_linked_list::MAX_SORT as u32),
            )
            .expect("clamped to the range"),
        ),
        ..LinkedListConfig::default()
    }
}

#[test]
fn an_ample_pool_equals_the_reference_on_every_bundled_scene_in_both_draw_orders() {
    if let Some(ctx) = context_or_skip("linked_list_ample_pool") {
        ample_pool_equals_the_reference(&ctx);
    }
}

/// The GL backend too (llvmpipe GL in CI): the resolve's insertion sort once came out one node
/// long there (a Mesa miscompile, see shaders/linked_list.wgsl), which only this catches.
#[test]
fn an_ample_pool_equals_the_reference_on_the_gl_backend() {
    if let Some(ctx) = gl_context_or_skip("linked_list_ample_pool_gl") {
        ample_pool_equals_the_reference(&ctx);
    }
}

fn ample_pool_equals_the_reference(ctx: &Context) {
    let mut failures = Vec::new();
    for name in bundled_names(ctx, &LinkedList::new(LinkedListConfig::default())) {
        // GL takes clip z through [-1, 1] (naga's ADJUST_COORDINATE_SPACE, then the window
        // transform back), which rounds the standard-Z depths of depth-range's far pairs (0.1 %
        // apart at 1000 and 50000) otherwise than the convention the reference models:
        // front-peel on GL merges them too (RMSE 0.099 there, 2.0e-4 on Vulkan).
        if ctx.caps.is_gl() && name == "depth-range" {
            continue;
        }
        let scene = scene(&name);
        let reference = oit_reference::render(&scene, &Default::default());
        let skip = crate::kit::undecidable(ctx, &scene, &reference);
        let skipped = skip.iter().filter(|s| **s).count();
        let pixels = RES.pixel_count() as u64;
        let config = ample(&reference, pixels);
        let mut list = LinkedList::new(config);
        let (image, stats) = render(ctx, &scene, &mut list, ColorFormat::Rgba16Float);
        let counts = list.last_counts();
        let mut reversed_list = LinkedList::new(config);
        let (reversed, _) = render(
            ctx,
            &scene.with_reversed_draw_order(),
            &mut reversed_list,
            ColorFormat::Rgba16Float,
        );
        let max = max_diff_except(&image, &reference.image, &skip);
        let order = max_diff_except(&image, &reversed, &vec![false; skip.len()]);
        println!(
            "{name:24} L {:3} skipped {skipped:4} px: max (rel. above 1) {max:.2e}, order dependence {order:.1e}, {} fragments stored",
            reference.stats.max_depth_complexity, counts.fragments
        );
        // Coplanar layers tie everywhere they overlap (the reference breaks ties by draw
        // order, the list by colour): not a tie-free scene, so only determinism is asserted.
        let tie_free = name != "coplanar";
        if (tie_free && max > MAX_HALF) || order != 0.0 {
            failures.push(format!(
                "{name}: max {max:.2e}, order dependence {order:.2e}"
            ));
        }
        if stats.pixels_with_dropped_layers != 0 || stats.pixels_with_approximated_layers != 0 {
            failures.push(format!("{name}: inexact with an ample pool: {stats:?}"));
        }
        // Every composited fragment is stored once (conformance pixels may differ).
        if counts
            .fragments
            .abs_diff(reference.stats.composited_fragments)
            > 2 * skipped as u64
        {
            failures.push(format!(
                "{name}: {} fragments stored, the reference composites {}",
                counts.fragments, reference.stats.composited_fragments
            ));
        }
        assert!(
            skipped < skip.len() / 4 || name == "coplanar",
            "{name}: {skipped} px left out"
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_small_pool_and_a_short_window_are_counted_per_pixel() {
    let Some(ctx) = context_or_skip("linked_list_small_pool") else {
        return;
    };
    let scene = scene("many-layers-64");
    let reference = oit_reference::render(&scene, &Default::default());
    let pixels = RES.pixel_count() as u64;
    // The window: exactly the pixels with more than 4 layers lose (drop) or average their
    // tail; the rest are untouched.
    let deep = reference.layers.iter().filter(|&&l| l > 4).count() as u64;
    assert!(deep > 1000, "many-layers-64 should be deep: {deep} px");
    let short = |tail| LinkedListConfig {
        nodes_per_pixel: oit_linked_list::Sizing::Fixed(oit_linked_list::NodesPerPixel::of(64)),
        sort_max: oit_linked_list::Sizing::Fixed(oit_linked_list::SortMax::of(4)),
        node: NodeFormat::F32,
        tail,
    };
    let mut dropping = LinkedList::new(short(TailRule::Drop));
    let (dropped_image, dropped) = render(&ctx, &scene, &mut dropping, ColorFormat::Rgba32Float);
    let mut averaging = LinkedList::new(short(TailRule::Average));
    let (averaged_image, averaged) = render(&ctx, &scene, &mut averaging, ColorFormat::Rgba32Float);
    let tolerance = pixels / 200; // conformance pixels at silhouettes
    assert!(
        dropped.pixels_with_dropped_layers.abs_diff(deep) <= tolerance
            && dropped.pixels_with_approximated_layers == 0,
        "tail=drop: {dropped:?}, {deep} px have more than 4 layers"
    );
    assert!(
        averaged.pixels_with_approximated_layers.abs_diff(deep) <= tolerance
            && averaged.pixels_with_dropped_layers == 0,
        "tail=average: {averaged:?}, {deep} px have more than 4 layers"
    );
    let e_drop = oit_metrics::compare(&dropped_image, &reference.image).unwrap();
    let e_avg = oit_metrics::compare(&averaged_image, &reference.image).unwrap();
    println!(
        "window 4: drop rmse {:.3e}, average rmse {:.3e}",
        e_drop.rmse, e_avg.rmse
    );
    assert!(
        e_avg.rmse < 0.5 * e_drop.rmse,
        "average {e_avg:?} vs drop {e_drop:?}"
    );

    // A pool of one node per pixel on a scene with more fragments: the lost fragments are
    // counted, every pixel that lost one is reported, and nothing else breaks.
    let mut starved = LinkedList::new(LinkedListConfig {
        nodes_per_pixel: oit_linked_list::Sizing::Fixed(oit_linked_list::NodesPerPixel::of(1)),
        sort_max: oit_linked_list::Sizing::Fixed(oit_linked_list::SortMax::of(64)),
        ..LinkedListConfig::default()
    });
    let (image, stats) = render(&ctx, &scene, &mut starved, ColorFormat::Rgba16Float);
    let counts = starved.last_counts();
    assert!(counts.fragments > pixels, "{counts:?}");
    assert!(
        stats.pixels_with_dropped_layers > 0
            && stats.pixels_with_dropped_layers <= reference.stats.covered_pixels,
        "{stats:?} ({} covered px)",
        reference.stats.covered_pixels
    );
    assert!(image.pixels.iter().all(|p| p.iter().all(|c| c.is_finite())));
    // The same technique value renders exactly again once the pool is ample.
    let mut ample_list = LinkedList::new(ample(&reference, pixels));
    let (_, again) = render(&ctx, &scene, &mut ample_list, ColorFormat::Rgba16Float);
    assert_eq!(again.pixels_with_dropped_layers, 0);
}

/// Three screen-filling layers (HDR, coverages that do not cancel) drawn far to near over a
/// known background, orthographic, so every pixel holds the same three fragments.
fn three_layers() -> Scene {
    let layer = |z: f64, color: [f64; 3], alpha: f64| {
        format!(
            r#"{{"mesh": {{"kind": "layers", "count": 1, "spacing": 0.1, "size": [4, 4],
                "color_from": {color:?}, "color_to": {color:?}, "alpha_from": {alpha}, "alpha_to": {alpha}}},
              "transform": {{"translate": [0, 0, {z}]}}, "material": {{"mode": "blend"}}}}"#
        )
    };
    let json = format!(
        r#"{{"name": "three-layers", "resolution": [8, 8],
            "camera": {{"eye": [0, 0, 10], "target": [0, 0, 0], "orthographic": {{"height": 2}},
                        "near": 0.5, "far": 30}},
            "background": [0.25, 0.5, 0.75],
            "objects": [{}, {}, {}]}}"#,
        layer(0.0, [0.5, 0.5, 3.0], 0.6),
        layer(2.0, [0.2, 0.9, 0.1], 0.35),
        layer(4.0, [40.0, 2.5, 0.3], 0.7),
    );
    oit_scene::parse(&json, "three-layers").unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn the_gpu_resolve_matches_its_cpu_twin_for_every_node_format_and_tail_rule() {
    let Some(ctx) = context_or_skip("linked_list_cpu_twin") else {
        return;
    };
    let scene = three_layers();
    let background = [0.25f32, 0.5, 0.75];
    // Near to far: the premultiplied colours and coverages the layers shade to.
    let layers = [
        ([40.0f32 * 0.7, 2.5 * 0.7, 0.3 * 0.7], 0.7f32, 0.3f32),
        ([0.2 * 0.35, 0.9 * 0.35, 0.1 * 0.35], 0.35, 0.5),
        ([0.5 * 0.6, 0.5 * 0.6, 3.0 * 0.6], 0.6, 0.7),
    ];
    let mut failures = Vec::new();
    for format in [NodeFormat::F32, NodeFormat::Packed] {
        for (sort_max, tail) in [
            (3, TailRule::Average),
            (1, TailRule::Average),
            (1, TailRule::Drop),
        ] {
            let nodes: Vec<node::Node> = layers
                .iter()
                .map(|(c, a, z)| node::pack_node(format, false, *c, *a, [*a; 3], *z, false))
                .collect();
            let (c, t, _) =
                node::resolve(format, false, &nodes, sort_max, tail == TailRule::Average);
            let expect: Vec<f32> = (0..3).map(|i| c[i] + t[i] * background[i]).collect();
            let mut list = LinkedList::new(LinkedListConfig {
                nodes_per_pixel: oit_linked_list::Sizing::Fixed(
                    oit_linked_list::NodesPerPixel::of(4),
                ),
                sort_max: oit_linked_list::Sizing::Fixed(
                    oit_linked_list::SortMax::new(sort_max as u32).expect("in 1..=128"),
                ),
                node: format,
                tail,
            });
            let (image, _) = render(&ctx, &scene, &mut list, ColorFormat::Rgba32Float);
            let got = image.pixels[image.pixels.len() / 2];
            for i in 0..3 {
                let tol = f32_twin_tolerance(&ctx) * expect[i].abs().max(1.0);
                if (got[i] - expect[i]).abs() > tol {
                    failures.push(format!(
                        "{format:?} sort-max {sort_max} {tail:?}: channel {i} GPU {} CPU twin {}",
                        got[i], expect[i]
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn memory_is_every_buffer_and_a_pool_too_large_is_refused_with_the_numbers() {
    let Some(ctx) = context_or_skip("linked_list_memory") else {
        return;
    };
    let scene = three_layers();
    for format in [NodeFormat::F32, NodeFormat::Packed] {
        let config = LinkedListConfig {
            nodes_per_pixel: oit_linked_list::Sizing::Fixed(oit_linked_list::NodesPerPixel::of(5)),
            node: format,
            ..LinkedListConfig::default()
        };
        let mut list = LinkedList::new(config);
        render(&ctx, &scene, &mut list, ColorFormat::Rgba16Float);
        let pixels = 64;
        // Pool, heads, lost counts, 16 B params, 16 B counters and their 16 B readback.
        assert_eq!(
            list.memory_bytes(),
            pixels * config.bytes_per_pixel(false).expect("fixed sizes") + 48,
            "{format:?}"
        );
    }
    let huge = LinkedList::new(LinkedListConfig {
        nodes_per_pixel: oit_linked_list::Sizing::Fixed(oit_linked_list::NodesPerPixel::of(1024)),
        ..LinkedListConfig::default()
    });
    let res = Resolution {
        width: 4096,
        height: 4096,
    };
    let e = huge.pool(&ctx.caps, res, false).unwrap_err().to_string();
    assert!(e.contains("node pool") && e.contains("at most"), "{e}");
}

// ---- k-buffer -------------------------------------------------------------------------------

use oit_linked_list::kbuffer::{self, KBuffer, KBufferConfig};

/// The k-buffer's packing (rgb9e5 colour: 2^-10 of the largest channel; 8-bit α: 1/510) on top
/// of the Rgba16Float target's rounding. Measured at 128² over the 12 tie-free bundled scenes
/// with ≤ 8 layers: worst 3.1e-3 on LDR content (foliage-cards), 5.0e-3 relative on
/// hdr-emissive; the bound is 1.2× the worst.
const MAX_KBUFFER: f64 = 6e-3;

/// The k-buffer where the adapter has 64-bit atomics, else `None` after checking the reason.
fn kbuffer_or_reason(ctx: &Context, config: KBufferConfig) -> Option<KBuffer> {
    let k = KBuffer::new(config);
    match k.check(&ctx.caps) {
        Ok(()) => Some(k),
        Err(e) => {
            assert!(
                !ctx.caps.int64_atomics && e.reason.contains("64-bit"),
                "{e}"
            );
            eprintln!("k-buffer unsupported on this adapter: {e}");
            None
        }
    }
}

#[test]
fn k8_is_exact_up_to_its_packing_on_every_bundled_scene_with_at_most_8_layers() {
    let Some(ctx) = context_or_skip("kbuffer_exact") else {
        return;
    };
    if ctx.caps.backend == oit_gpu::wgpu::Backend::Vulkan {
        // lavapipe, like every Vulkan driver with shaderBufferInt64Atomics and
        // shaderSharedInt64Atomics, has them: CI must exercise the technique.
        assert!(
            ctx.caps.int64_atomics,
            "Vulkan adapter without 64-bit atomics"
        );
    }
    let mut failures = Vec::new();
    let mut measured = 0;
    for name in bundled_names(&ctx, &KBuffer::new(KBufferConfig::default())) {
        let scene = scene(&name);
        let reference = oit_reference::render(&scene, &Default::default());
        if reference.stats.max_depth_complexity > 8 || name == "coplanar" {
            continue;
        }
        let Some(mut k) = kbuffer_or_reason(&ctx, KBufferConfig::default()) else {
            return;
        };
        let skip = crate::kit::undecidable(&ctx, &scene, &reference);
        let (image, stats) = render(&ctx, &scene, &mut k, ColorFormat::Rgba16Float);
        let mut reversed_k = KBuffer::new(KBufferConfig::default());
        let (reversed, _) = render(
            &ctx,
            &scene.with_reversed_draw_order(),
            &mut reversed_k,
            ColorFormat::Rgba16Float,
        );
        let max = max_diff_except(&image, &reference.image, &skip);
        let order = max_diff_except(&image, &reversed, &vec![false; skip.len()]);
        println!(
            "{name:24} L {:2}: max (rel. above 1) {max:.2e}, order dependence {order:.1e}",
            reference.stats.max_depth_complexity
        );
        measured += 1;
        if max > MAX_KBUFFER || order != 0.0 {
            failures.push(format!(
                "{name}: max {max:.2e}, order dependence {order:.2e}"
            ));
        }
        if stats.pixels_with_dropped_layers != 0 || stats.pixels_with_approximated_layers != 0 {
            failures.push(format!("{name}: inexact within k: {stats:?}"));
        }
    }
    assert!(measured >= 8, "only {measured} scenes with ≤ 8 layers");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn beyond_k_layers_the_tail_is_counted_and_averaging_beats_dropping() {
    let Some(ctx) = context_or_skip("kbuffer_tail") else {
        return;
    };
    let scene = scene("particles");
    let reference = oit_reference::render(&scene, &Default::default());
    let k = 4;
    let deep = reference.layers.iter().filter(|&&l| l > k).count() as u64;
    assert!(
        deep > 100,
        "particles should exceed {k} layers somewhere: {deep} px"
    );
    let tolerance = RES.pixel_count() as u64 / 200;
    let mut errors = Vec::new();
    for tail in [TailRule::Drop, TailRule::Average] {
        let k = oit_linked_list::Sizing::Fixed(oit_linked_list::K::new(k).expect("k in 1..=32"));
        let Some(mut kb) = kbuffer_or_reason(&ctx, KBufferConfig { k, tail }) else {
            return;
        };
        let (image, stats) = render(&ctx, &scene, &mut kb, ColorFormat::Rgba32Float);
        let counted = match tail {
            TailRule::Drop => (
                stats.pixels_with_dropped_layers,
                stats.pixels_with_approximated_layers,
            ),
            TailRule::Average => (
                stats.pixels_with_approximated_layers,
                stats.pixels_with_dropped_layers,
            ),
        };
        assert!(
            counted.0.abs_diff(deep) <= tolerance && counted.1 == 0,
            "{tail:?}: {stats:?}, {deep} px have more than {k} layers"
        );
        errors.push(oit_metrics::compare(&image, &reference.image).unwrap().rmse);
    }
    println!(
        "k=4 on particles: drop rmse {:.3e}, average rmse {:.3e}",
        errors[0], errors[1]
    );
    assert!(
        errors[1] < 0.5 * errors[0],
        "average {} vs drop {}",
        errors[1],
        errors[0]
    );
}

#[test]
fn the_kbuffer_matches_its_cpu_twin_and_counts_its_memory() {
    let Some(ctx) = context_or_skip("kbuffer_cpu_twin") else {
        return;
    };
    let scene = three_layers();
    let background = [0.25f32, 0.5, 0.75];
    // Near to far, as window depths under reverse-Z (only their order matters here).
    let layers = [
        ([40.0f32 * 0.7, 2.5 * 0.7, 0.3 * 0.7], 0.7f32, 0.7f32),
        ([0.2 * 0.35, 0.9 * 0.35, 0.1 * 0.35], 0.35, 0.5),
        ([0.5 * 0.6, 0.5 * 0.6, 3.0 * 0.6], 0.6, 0.3),
    ];
    let slots: Vec<u64> = layers
        .iter()
        .map(|(c, a, z)| kbuffer::to_slot(*c, *a, *z, true))
        .collect();
    let mut failures = Vec::new();
    for (k, tail) in [
        (3, TailRule::Average),
        (1, TailRule::Average),
        (1, TailRule::Drop),
    ] {
        let config = KBufferConfig {
            k: oit_linked_list::Sizing::Fixed(oit_linked_list::K::of(k)),
            tail,
        };
        let Some(mut kb) = kbuffer_or_reason(&ctx, config) else {
            return;
        };
        let (c, t) = kbuffer::resolve(&slots, k as usize, tail);
        let (image, _) = render(&ctx, &scene, &mut kb, ColorFormat::Rgba32Float);
        let got = image.pixels[image.pixels.len() / 2];
        for i in 0..3 {
            let expect = c[i] + t * background[i];
            // The tail sums pass through Rgba16Float targets: 2^-11 relative per rounding,
            // measured 4.0e-4 on lavapipe (k = 1, average); 1e-3 is 2.5× that.
            let tol = if k < 3 {
                1e-3
            } else {
                f32_twin_tolerance(&ctx)
            } * expect.abs().max(1.0);
            if (got[i] - expect).abs() > tol {
                failures.push(format!(
                    "k {k} {tail:?}: channel {i} GPU {} CPU twin {expect}",
                    got[i]
                ));
            }
        }
        assert_eq!(
            kb.memory_bytes(),
            64 * config.bytes_per_pixel(false).expect("fixed sizes") + 80,
            "k {k}"
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let huge = KBuffer::new(KBufferConfig {
        k: oit_linked_list::Sizing::Fixed(oit_linked_list::K::of(32)),
        tail: TailRule::Average,
    });
    let e = huge
        .slot_bytes(
            &ctx.caps,
            Resolution {
                width: 4096,
                height: 4096,
            },
            false,
        )
        .unwrap_err()
        .to_string();
    assert!(e.contains("k-buffer slots") && e.contains("at most"), "{e}");
}

#[test]
fn the_gl_backend_refuses_the_k_buffer_with_the_reason() {
    let Some(ctx) = gl_context_or_skip("gl_refuses_the_k_buffer") else {
        return;
    };
    assert!(!ctx.caps.int64_atomics, "llvmpipe GL has no 64-bit atomics");
    let e = KBuffer::new(KBufferConfig::default())
        .check(&ctx.caps)
        .unwrap_err();
    assert!(e.reason.contains("64-bit"), "{e}");
    LinkedList::new(LinkedListConfig::default())
        .check(&ctx.caps)
        .expect("the list runs on GL");
}

/// Builds a fresh technique (one per draw order, so no state carries over).
type Maker = Box<dyn Fn() -> Box<dyn Technique>>;

/// Content nobody placed by hand (`oit_scene::random`: soups, intersecting planes, clipping,
/// standard- and reverse-Z, orthographic): with room for every fragment both techniques equal
/// the reference on every decidable pixel, in both draw orders.
#[test]
fn both_techniques_are_exact_on_seeded_random_scenes_when_nothing_overflows() {
    let Some(ctx) = context_or_skip("stored_fragments_random_scenes") else {
        return;
    };
    let mut failures = Vec::new();
    let mut kbuffer_scenes = 0;
    for seed in 0..12u64 {
        let (json, about) = oit_scene::random::random_scene_json(seed);
        let scene = oit_scene::parse(&json, "random").unwrap_or_else(|e| panic!("{seed}: {e}"));
        let reference = oit_reference::render(&scene, &Default::default());
        let skip = crate::kit::undecidable(&ctx, &scene, &reference);
        let pixels = scene.resolution.pixel_count() as u64;
        let layers = reference.stats.max_depth_complexity;
        let mut techniques: Vec<(String, Maker)> = Vec::new();
        let config = ample(&reference, pixels);
        if u64::from(layers) <= oit_linked_list::MAX_SORT {
            techniques.push((
                "linked-list".into(),
                Box::new(move || Box::new(LinkedList::new(config))),
            ));
        }
        let k = layers.max(1);
        if u64::from(k) <= oit_linked_list::MAX_K && ctx.caps.int64_atomics {
            kbuffer_scenes += 1;
            techniques.push((
                format!("k-buffer:k={k}"),
                Box::new(move || {
                    Box::new(KBuffer::new(KBufferConfig {
                        k: oit_linked_list::Sizing::Fixed(
                            oit_linked_list::K::new(k).expect("k within MAX_K"),
                        ),
                        tail: TailRule::Drop,
                    }))
                }),
            ));
        }
        for (label, make) in &techniques {
            let bound = if label.starts_with("k-buffer") {
                MAX_KBUFFER
            } else {
                MAX_HALF
            };
            let (image, stats) = render(&ctx, &scene, make().as_mut(), ColorFormat::Rgba16Float);
            let (reversed, _) = render(
                &ctx,
                &scene.with_reversed_draw_order(),
                make().as_mut(),
                ColorFormat::Rgba16Float,
            );
            let max = max_diff_except(&image, &reference.image, &skip);
            let order = max_diff_except(&image, &reversed, &skip);
            println!(
                "seed {seed} {label} L {layers}: max {max:.2e}, order {order:.1e} ({about:?})"
            );
            if max > bound
                || order != 0.0
                || stats.pixels_with_dropped_layers != 0
                || stats.pixels_with_approximated_layers != 0
            {
                failures.push(format!(
                    "seed {seed} {label}: max {max:.2e}, order dependence {order:.1e}, {stats:?}"
                ));
            }
        }
    }
    assert!(
        kbuffer_scenes >= 8 || !ctx.caps.int64_atomics,
        "{kbuffer_scenes}"
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
