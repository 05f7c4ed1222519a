//! results.json's `counts`: every technique declares every pass it makes (`Technique::work`),
//! on a scalar scene and on one with coloured transmission, and the counts add up from the
//! passes.

use oit_harness::results::RunStatus;
use oit_harness::{CompareOptions, compare, resolve_specs};
use oit_scene::Resolution;

fn temp_dir(name: &str) -> oit_gpu::testing::ScratchDir {
    oit_gpu::testing::ScratchDir::new(&format!("counts-{name}"))
}

#[test]
fn every_technique_declares_every_pass_and_the_counts_add_up() {
    let Some(ctx) = oit_gpu::testing::context_or_skip(
        "every_technique_declares_every_pass_and_the_counts_add_up",
    ) else {
        return;
    };
    if !oit_gpu::occlusion_counts_samples(&ctx.caps) {
        println!(
            "skipped: occlusion queries on {:?} are boolean in wgpu",
            ctx.caps.backend
        );
        return;
    }
    let out = temp_dir("declared");
    let dir = crate::kit::scenes_dir();
    let scenes = oit_harness::load_scenes(&[
        dir.join("many-layers-64.json"),
        dir.join("transmission-stack-32.json"),
        dir.join("intersecting-quads.json"),
    ])
    .unwrap();
    let mut texts: Vec<String> = Vec::new();
    // Every technique at its defaults, and the paths their options switch to.
    texts.extend(
        [
            "stochastic:spp=3",
            "dual-peel:tail=wboit",
            "front-peel:layers=2",
            "k-buffer:k=2",
            "a2c:samples=8",
        ]
        .map(String::from),
    );
    let mut specs = resolve_specs(&[]).unwrap();
    specs.extend(resolve_specs(&texts).unwrap());
    let options = CompareOptions {
        resolution: Some(Resolution {
            width: 24,
            height: 20,
        }),
        frames: 1,
        warmup: 0,
        out_dir: out.to_path_buf(),
        cache: oit_harness::ReferenceCache::Dir(out.join("cache")),
        ..CompareOptions::default()
    };
    let results = compare(&ctx, &scenes, &specs, &options, &|_| {}).unwrap();
    let mut rendered = 0;
    for run in &results.runs {
        let what = format!("{} × {}", run.scene, run.technique);
        if run.status != RunStatus::Ok {
            assert!(run.counts.is_none(), "{what}");
            continue;
        }
        rendered += 1;
        let c = run
            .counts
            .as_ref()
            .unwrap_or_else(|| panic!("{what}: no counts"));
        assert!(
            c.undeclared_passes.is_empty(),
            "{what}: undeclared {:?}",
            c.undeclared_passes
        );
        // The counted frame makes the timed frames' passes (with timestamps, whose passes are
        // named one by one; wall-clock timing names a submission's passes together).
        if run.gpu_ms.as_ref().is_some_and(|g| g.source == "timestamp") {
            let timed: Vec<&str> = run.passes.iter().map(|p| p.name.as_str()).collect();
            let counted: Vec<&str> = c.passes.iter().map(|p| p.name.as_str()).collect();
            assert_eq!(counted, timed, "{what}");
        }
        assert_eq!(c.passes[0].name, "opaque", "{what}");
        let pixels = 24 * 20;
        let fullscreen = c
            .passes
            .iter()
            .filter(|p| p.draws.as_deref() == Some("full-screen"))
            .count();
        assert_eq!(c.fullscreen_passes as usize, fullscreen, "{what}");
        assert_eq!(c.fullscreen_pixels, pixels * fullscreen as u64, "{what}");
        let geometry: u64 = c
            .passes
            .iter()
            .filter(|p| !matches!(p.draws.as_deref(), Some("full-screen" | "compute")))
            .filter_map(|p| p.samples)
            .sum();
        assert_eq!(c.fragments, geometry, "{what}");
        assert_eq!(
            c.bytes,
            c.passes.iter().filter_map(|p| p.bytes).sum::<u64>(),
            "{what}"
        );
        let triangles: u64 = c.passes.iter().map(|p| p.triangles).sum();
        assert_eq!(c.triangle_passes, triangles, "{what}");
        assert!(
            c.triangle_passes > 0 && c.bytes > 0 && c.fragments > 0,
            "{what}: {c:?}"
        );
        // A technique whose passes write anything moves bytes in every pass that passed samples.
        for p in &c.passes {
            if p.samples.is_some_and(|s| s > 0) {
                assert!(
                    p.bytes.is_some_and(|b| b > 0),
                    "{what}: pass {} moves nothing",
                    p.name
                );
            }
        }
    }
    assert!(rendered >= 40, "only {rendered} runs rendered");
    // The list and the k-buffer make atomics; sorting does not.
    let atomics = |technique: &str| {
        results
            .runs
            .iter()
            .filter(|r| r.technique.starts_with(technique))
            .filter_map(|r| r.counts.as_ref())
            .map(|c| c.atomics)
            .fold(0.0, f64::max)
    };
    assert!(atomics("linked-list") > 0.0);
    assert!(atomics("k-buffer") > 0.0);
    assert_eq!(atomics("sorted-object"), 0.0);
}
