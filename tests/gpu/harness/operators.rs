//! Blend operators on content nobody placed by hand: seeded random scenes whose transparent
//! materials mix `over`, `add` (often above intensity 1), `subtract` and `multiply`, some lit
//! (`oit_scene::random::random_mixed_operator_scene_json`). Every exact technique that
//! declares `Support::Exact` for the operators a scene uses must equal the reference there, in
//! the scene's draw order and reversed.

use oit_gpu::testing::context_or_skip;
use oit_gpu::{ColorFormat, GpuScene, Support, Technique, TechniqueSpec};

/// The exact configurations (as the other random-scene exactness tests run them) and the
/// error each must stay within, relative above 1, in the Rgba16Float target.
const EXACT: [(&str, f64); 5] = [
    ("front-peel:layers=auto", 4e-3),
    ("dual-peel:passes=auto,depth=rg32f", 4e-3),
    ("linked-list:nodes-per-pixel=auto,sort-max=auto", 4e-3),
    (
        "linked-list:nodes-per-pixel=auto,sort-max=auto,node=packed",
        PACKED_BOUND,
    ),
    ("k-buffer:k=auto", PACKED_BOUND),
];

/// The rgb9e5 colour of packed nodes and k-buffer slots on top of the 4e-3 (2^-10 of a
/// fragment's largest channel, 8-bit α; `MAX_KBUFFER_PACKING` of linked_list::auto, measured
/// on the over-only random scenes), over the pixels whose layers the k-buffer's 15-bit nearness
/// keys keep apart.
const PACKED_BOUND: f64 = 7e-3;

/// Seeds run by default (`OIT_RANDOM_SCENES=N` runs more); at least [`MIN_COMPARED`] of them
/// must be tie-free and use a non-`over` operator for every configuration.
const SEEDS: u64 = 60;
const MIN_COMPARED: usize = 50;

/// Largest RGB error relative above 1 outside `skip`.
fn max_relative_except(
    a: &oit_scene::LinearImage,
    b: &oit_scene::LinearImage,
    skip: &[bool],
) -> f64 {
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

/// Whether `technique` declares every operator `scene` uses exact on this adapter.
fn exact_for(technique: &dyn Technique, caps: &oit_gpu::Caps, scene: &oit_scene::Scene) -> bool {
    scene
        .operators_used()
        .into_iter()
        .all(|op| technique.operator(op, caps) == Support::Exact)
        && (!scene.has_transmission() || technique.transmission(caps) == Support::Exact)
}

/// ≥ 50 tie-free mixed-operator random scenes (48²–64²): front-peel, dual-peel, the linked
/// list (f32 and packed nodes) and the k-buffer equal the reference within their bounds in
/// both draw orders, drop and average nothing — wherever they declare the scene's operators
/// exact; where one does not, the scene is counted as skipped for it and printed.
#[test]
fn exact_techniques_are_exact_on_mixed_operator_random_scenes() {
    let Some(ctx) = context_or_skip("exact_techniques_are_exact_on_mixed_operator_random_scenes")
    else {
        return;
    };
    let started = std::time::Instant::now();
    let seeds = crate::kit::random_scene_count(SEEDS);
    let registry = oit_harness::registry();
    let mut techniques: Vec<(Box<dyn Technique>, f64)> = EXACT
        .iter()
        .map(|(spec, bound)| {
            let t = TechniqueSpec::build(spec, &registry).expect("valid spec");
            (t, *bound)
        })
        .collect();
    let mut compared = vec![0usize; techniques.len()];
    let mut worst = vec![0.0f64; techniques.len()];
    let mut skipped = vec![Vec::new(); techniques.len()];
    let mut failures = Vec::new();
    let mut operators_seen = std::collections::BTreeSet::new();
    let mut seconds = vec![0.0f64; techniques.len()];
    let mut reference_seconds = 0.0;
    for seed in 0..seeds {
        let (text, about) = oit_scene::random::random_mixed_operator_scene_json(seed);
        let scene = oit_scene::parse(&text, "random-ops").expect("random scene");
        if scene.operators_used().is_empty() {
            continue;
        }
        let clock = std::time::Instant::now();
        let (reference, key_ties) = crate::linked_list::reference_and_key_ties(&scene);
        reference_seconds += clock.elapsed().as_secs_f64();
        if reference.stats.undecided_pixels + reference.stats.precision_tie_pixels > 0 {
            continue;
        }
        operators_seen.extend(scene.operators_used().into_iter().map(|op| op.name()));
        let no_skip = vec![false; key_ties.len()];
        let reversed = scene.with_reversed_draw_order();
        let uploads = [
            GpuScene::upload(&ctx, &scene).expect("upload"),
            GpuScene::upload(&ctx, &reversed).expect("upload"),
        ];
        for (i, (technique, bound)) in techniques.iter_mut().enumerate() {
            let name = technique.spec().to_string();
            if oit_gpu::check_scene(technique.as_ref(), &ctx.caps, &scene).is_err()
                || !exact_for(technique.as_ref(), &ctx.caps, &scene)
            {
                skipped[i].push(seed);
                continue;
            }
            let skip = if name.starts_with("k-buffer") {
                &key_ties
            } else {
                &no_skip
            };
            compared[i] += 1;
            let clock = std::time::Instant::now();
            for (order, gpu) in ["natural", "reversed"].iter().zip(&uploads) {
                let (image, frame) = crate::kit::render_uploaded(
                    &ctx,
                    gpu,
                    technique.as_mut(),
                    ColorFormat::Rgba16Float,
                );
                let error = max_relative_except(&image, &reference.image, skip);
                worst[i] = worst[i].max(error);
                let s = frame.stats;
                if error > *bound
                    || s.pixels_with_dropped_layers + s.pixels_with_approximated_layers > 0
                {
                    failures.push(format!(
                        "seed {seed} {name} ({order} order): max error {error:.3e} (bound {bound:e}), dropped on {} px, averaged on {} px; operators {:?}; {about:?}",
                        s.pixels_with_dropped_layers,
                        s.pixels_with_approximated_layers,
                        scene.operators_used(),
                    ));
                }
            }
            seconds[i] += clock.elapsed().as_secs_f64();
        }
    }
    for (i, (spec, _)) in EXACT.iter().enumerate() {
        println!(
            "{spec}: {} scenes, worst {:.3e}, {:.1} s, skipped seeds {:?}",
            compared[i], worst[i], seconds[i], skipped[i]
        );
    }
    println!(
        "{seeds} seeds in {:.1} s ({reference_seconds:.1} s references)",
        started.elapsed().as_secs_f64()
    );
    assert_eq!(operators_seen.len(), 3, "{operators_seen:?}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    for (i, (spec, _)) in EXACT.iter().enumerate() {
        assert!(
            compared[i] >= MIN_COMPARED,
            "{spec}: only {} mixed-operator scenes compared (skipped {:?})",
            compared[i],
            skipped[i]
        );
    }
}

/// What a fragment composites as the shader's `Shaded` holds it: premultiplied colour, scalar
/// alpha and per-channel transmittance, from the reference's `Shaded`.
fn as_shader_holds(s: oit_scene::Shaded) -> [f32; 7] {
    match s {
        oit_scene::Shaded::Transparent {
            premultiplied: p,
            alpha,
        } => {
            let t = 1.0 - alpha;
            [p[0], p[1], p[2], alpha, t, t, t]
        }
        oit_scene::Shaded::Transmissive {
            premultiplied: p,
            opacity,
            transmittance: t,
        } => [p[0], p[1], p[2], opacity, t[0], t[1], t[2]],
        other => panic!("a blend material shaded as {other:?}"),
    }
}

/// The shader's `apply_operator` (shaders/common.wgsl, what `shade()` does to a transparent
/// fragment of each operator) against the operator arms of `Material::shade_lit`, evaluated on
/// the GPU for every operator on a grid of colours, alphas (0 and 1 included) and intensities
/// (add above 1): colour (subtract's negation, multiply's zero), alpha and the per-channel
/// transmittance (multiply's filter `(1 − α) + α·c`) agree within one f32 rounding (the
/// shader may fuse a multiply-add). An operator changed on one side only fails here.
#[test]
fn the_shaders_operators_equal_the_references() {
    let Some(ctx) = context_or_skip("the_shaders_operators_equal_the_references") else {
        return;
    };
    let source = oit_gpu::shaders::compose_with(oit_gpu::shaders::COMMON, &[])
        .expect("common.wgsl composes");
    let colours = [
        [0.0, 0.0, 0.0],
        [1.0, 0.5, 0.25],
        [0.3, 0.9, 0.4],
        [0.9, 0.8, 0.2],
    ];
    let (mut inputs, mut materials) = (Vec::new(), Vec::new());
    for base in colours {
        for alpha in [0.0f32, 0.05, 0.37, 0.5, 0.8, 1.0] {
            for intensity in [1.0f32, 2.5] {
                let mut m = oit_scene::Material::plain(base, alpha, oit_scene::AlphaMode::Blend);
                m.intensity = intensity;
                // The colour the over path multiplies by α: base × intensity (lit = base, one
                // light-free reflected factor of 1, no emission).
                inputs.push([
                    base[0] * intensity,
                    base[1] * intensity,
                    base[2] * intensity,
                    alpha,
                ]);
                materials.push(m);
            }
        }
    }
    let fields = [
        "color.r",
        "color.g",
        "color.b",
        "alpha",
        "transmittance.r",
        "transmittance.g",
        "transmittance.b",
    ];
    let mut checked = std::collections::BTreeSet::new();
    for op in oit_scene::BlendOperator::ALL {
        let expected: Vec<[f32; 7]> = materials
            .iter()
            .map(|m| {
                let mut m = *m;
                m.operator = op;
                as_shader_holds(m.shade_lit([1.0; 4], oit_scene::Texels::UNTEXTURED, None))
            })
            .collect();
        for (f, field) in fields.iter().enumerate() {
            let expr = format!(
                "apply_operator(Shaded(true, x.a * x.rgb, x.a, vec3<f32>(1.0 - x.a)), x.a, {}u).{field}",
                op.code()
            );
            let got = oit_gpu::testing::eval_f32(&ctx, &source, &expr, &inputs, None, &[])
                .expect("kernel runs");
            for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
                let want = e[f];
                assert!(
                    (g - want).abs() <= 2.0 * f32::EPSILON * want.abs().max(1.0),
                    "{} {field}: shader {g} reference {want} for input {:?}",
                    op.name(),
                    inputs[i]
                );
            }
            checked.insert((op.name(), *field));
        }
        // What each operator must do, so a twin drifting on both sides at once fails too.
        for (x, e) in inputs.iter().zip(&expected) {
            let p = [x[3] * x[0], x[3] * x[1], x[3] * x[2]];
            let want = match op {
                oit_scene::BlendOperator::Over => {
                    [p[0], p[1], p[2], x[3], 1.0 - x[3], 1.0 - x[3], 1.0 - x[3]]
                }
                oit_scene::BlendOperator::Add => [p[0], p[1], p[2], 0.0, 1.0, 1.0, 1.0],
                oit_scene::BlendOperator::Subtract => [-p[0], -p[1], -p[2], 0.0, 1.0, 1.0, 1.0],
                oit_scene::BlendOperator::Multiply => {
                    let t = p.map(|c| 1.0 - x[3] + c);
                    [
                        0.0,
                        0.0,
                        0.0,
                        1.0 - (t[0] + t[1] + t[2]) / 3.0,
                        t[0],
                        t[1],
                        t[2],
                    ]
                }
            };
            for c in 0..7 {
                assert!(
                    (e[c] - want[c]).abs() <= 1e-6 * want[c].abs().max(1.0),
                    "{} component {c}: {} vs {}",
                    op.name(),
                    e[c],
                    want[c]
                );
            }
        }
    }
    assert_eq!(checked.len(), 4 * 7);
}
