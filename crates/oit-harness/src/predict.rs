//! Every rendered run's predicted exactness ([`oit_gpu::predict`]), checked against its
//! measured error: the reference's per-pixel lists are kept once per scene, and each
//! technique's model of a pixel runs on them.

use oit_gpu::predict::{EXACT_BOUND, PixelLists};
use oit_gpu::{Caps, Prediction, TechniqueSpec};
use oit_results::{PredictionRecord, Run, RunStatus};
use oit_scene::Scene;

use crate::HarnessError;

/// The per-pixel lists of `scene`'s reference, within `memory_budget` bytes.
pub fn lists_of(scene: &Scene, memory_budget: u64) -> Result<PixelLists, HarnessError> {
    let options = oit_reference::ReferenceOptions {
        memory_budget,
        ..Default::default()
    };
    Ok(oit_reference::lists::render_lists(scene, &options)?.1)
}

/// `spec`'s prediction on `scene`.
pub fn predict(
    spec: &TechniqueSpec,
    scene: &Scene,
    lists: &PixelLists,
    caps: &Caps,
) -> Result<Prediction, HarnessError> {
    let technique = crate::run::build(spec)?;
    Ok(oit_gpu::predict_with_queues(
        technique.as_ref(),
        scene,
        lists,
        caps,
    ))
}

/// Whether a run measured exact: its largest channel error, relative above 1, within
/// [`EXACT_BOUND`], and no pixel that is not finite.
pub fn measured_exact(run: &Run) -> Option<bool> {
    run.error
        .map(|e| e.nonfinite == 0 && e.max_relative <= EXACT_BOUND)
}

/// The record of `prediction` for `run` (rendered runs only), with its agreement.
pub fn record(prediction: &Prediction, run: &Run) -> Option<PredictionRecord> {
    if run.status != RunStatus::Ok {
        return None;
    }
    let measured = run.error.map(|e| {
        if e.nonfinite > 0 {
            f64::INFINITY
        } else {
            e.max_relative
        }
    })?;
    Some(PredictionRecord {
        verdict: prediction.verdict.label_word().to_string(),
        because: prediction.because.clone(),
        modelled_error: prediction.modelled_error,
        agrees: prediction.agrees(measured),
    })
}

/// The lists for a comparison's predictions: `None` when predictions are off, or with a
/// warning when the lists do not fit the scene's memory budget (the reference's share of it,
/// [`crate::MemoryPlan`]; the render and the lists share that, `render_lists`).
pub(crate) fn lists_for(
    scene: &Scene,
    options: &crate::CompareOptions,
    on_event: &dyn Fn(crate::Event<'_>),
) -> Option<PixelLists> {
    if !options.predict {
        return None;
    }
    // The share of the scene's budget the reference's fragments get (the rest is one run's
    // images, held beside the lists while the runs are made).
    let budget = match crate::MemoryPlan::of(scene, options.memory_budget) {
        Ok(plan) => plan.reference_bytes,
        Err(_) => return None,
    };
    match lists_of(scene, budget) {
        Ok(lists) => Some(lists),
        Err(e) => {
            on_event(crate::Event::Warning(&format!(
                "{}: no exactness predictions: {e}",
                scene.name
            )));
            None
        }
    }
}

/// Sets a freshly made run's prediction (nothing without lists).
pub(crate) fn fill(run: &mut Run, scene: &Scene, lists: Option<&PixelLists>, caps: &Caps) {
    let Some(lists) = lists else { return };
    let Ok(spec) = TechniqueSpec::parse(&run.technique, &crate::registry()) else {
        return;
    };
    if let Ok(prediction) = predict(&spec, scene, lists, caps) {
        run.prediction = record(&prediction, run);
    }
}
