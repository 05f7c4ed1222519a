//! Every technique's exactness prediction (`Technique::predict`, `oit_gpu::predict`) against
//! its measured error, on content nobody tuned the models to: every bundled scene, seeded
//! random scenes (`OIT_RANDOM_SCENES=N` for more than the default) and the glTF assets, with
//! every default configuration and, on the bundled scenes and the assets, a few sized ones
//! ([`SIZED`]). A prediction of exact or inexact that the measurement contradicts is a bug in the model or in
//! the technique. Borderline and unmodelled predictions are counted, and must stay a minority.

use std::path::{Path, PathBuf};

use oit_gpu::Verdict;
use oit_gpu::testing::context_or_skip;
use oit_harness::{render_once, resolve_specs};
use oit_scene::{Resolution, Scene};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Scenes rendered at this size (their own aspect kept is not needed: the checks are per pixel).
const SIZE: u32 = 48;

#[derive(Default)]
struct Tally {
    agree: usize,
    borderline: usize,
    unmodelled: usize,
    disagreements: Vec<String>,
}

/// Configurations beyond the defaults whose models differ: fewer peels, a small k-buffer and
/// sort window, another weight, trigonometric moments.
const SIZED: [&str; 6] = [
    "front-peel:layers=2",
    "dual-peel:passes=1",
    "k-buffer:k=2,tail=drop",
    "linked-list:sort-max=2",
    "wboit:weight=mcguire2015",
    "mboit:moments=trig3",
];

fn check(ctx: &oit_gpu::Context, scene: &Scene, label: &str, extra: &[&str], tally: &mut Tally) {
    let options = oit_reference::ReferenceOptions {
        memory_budget: 1 << 30,
        ..Default::default()
    };
    let (reference, lists) =
        oit_reference::lists::render_lists(scene, &options).expect("lists fit 1 GiB");
    let mut specs = resolve_specs(&[]).expect("default specs");
    // (`resolve_specs` of nothing is every default: only sized configurations extend them.)
    if !extra.is_empty() {
        let extra: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
        specs.extend(resolve_specs(&extra).expect("sized specs"));
    }
    for spec in &specs {
        let technique = TechniqueFor::build(spec);
        if oit_gpu::check_scene(technique.as_ref(), &ctx.caps, scene).is_err() {
            continue;
        }
        let prediction = oit_gpu::predict_with_queues(technique.as_ref(), scene, &lists, &ctx.caps);
        let frame = match render_once(ctx, scene, spec) {
            Ok(f) => f,
            Err(e) => panic!("{label} {}: {e}", spec.canonical()),
        };
        let errors = oit_metrics::compare(&frame.image, &reference.image).expect("same size");
        let measured = if errors.nonfinite > 0 {
            f64::INFINITY
        } else {
            errors.max_relative
        };
        match (prediction.verdict, prediction.agrees(measured)) {
            (Verdict::Borderline, _) => tally.borderline += 1,
            (Verdict::Unmodelled, _) => tally.unmodelled += 1,
            (_, Some(true)) => tally.agree += 1,
            (v, _) => tally.disagreements.push(format!(
                "{label} {}: predicted {v:?} (model {:.2e}) but measured {measured:.2e}: {}",
                spec.canonical(),
                prediction.modelled_error.unwrap_or(f64::NAN),
                prediction.because
            )),
        }
    }
}

/// Builds a technique from a spec through the harness's registry.
struct TechniqueFor;

impl TechniqueFor {
    fn build(spec: &oit_gpu::TechniqueSpec) -> Box<dyn oit_gpu::Technique> {
        oit_gpu::TechniqueSpec::build(&spec.canonical(), &oit_harness::registry())
            .expect("registered technique")
    }
}

fn at_size(scene: &Scene) -> Scene {
    oit_harness::at_resolution(
        scene,
        Some(Resolution {
            width: SIZE,
            height: SIZE,
        }),
    )
}

fn report(tally: &Tally, what: &str) {
    println!(
        "{what}: {} agree, {} borderline, {} unmodelled, {} disagree",
        tally.agree,
        tally.borderline,
        tally.unmodelled,
        tally.disagreements.len()
    );
    assert!(
        tally.disagreements.is_empty(),
        "{}",
        tally.disagreements.join("\n")
    );
    let decided = tally.agree;
    let all = decided + tally.borderline + tally.unmodelled;
    assert!(
        decided * 3 >= all * 2,
        "{what}: only {decided} of {all} predictions decided: the models say too little"
    );
}

#[test]
fn predictions_agree_with_measurement_on_the_bundled_scenes() {
    let Some(ctx) = context_or_skip("predictions_agree_with_measurement_on_the_bundled_scenes")
    else {
        return;
    };
    let mut tally = Tally::default();
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join("scenes"))
        .expect("scenes/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    assert!(files.len() >= 20, "the bundled scenes are missing");
    for file in &files {
        let scene = oit_scene::load(file).expect("bundled scene loads");
        let name = file.file_stem().map(|s| s.to_string_lossy().into_owned());
        check(
            &ctx,
            &at_size(&scene),
            &name.unwrap_or_default(),
            &SIZED,
            &mut tally,
        );
    }
    report(&tally, "bundled scenes");
}

#[test]
fn predictions_agree_with_measurement_on_random_scenes_and_gltf_assets() {
    let Some(ctx) =
        context_or_skip("predictions_agree_with_measurement_on_random_scenes_and_gltf_assets")
    else {
        return;
    };
    let mut tally = Tally::default();
    let scenes = crate::kit::random_scene_count(12);
    for seed in 0..scenes {
        let (text, about) = oit_scene::random::random_scene_json(seed);
        let scene = oit_scene::parse(&text, "random").expect("random scene");
        check(
            &ctx,
            &at_size(&scene),
            &format!("seed {seed} ({about:?})"),
            &[],
            &mut tally,
        );
    }
    for asset in [
        "AlphaBlendModeTest/AlphaBlendModeTest.glb",
        "GlassVaseFlowers/GlassVaseFlowers.glb",
        "TintedPanes/TintedPanes.gltf",
    ] {
        let scene = oit_scene::load(&repo().join("assets").join(asset)).expect("asset loads");
        check(&ctx, &at_size(&scene), asset, &SIZED, &mut tally);
    }
    report(
        &tally,
        &format!("{scenes} random scenes and the glTF assets"),
    );
}
