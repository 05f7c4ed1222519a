//! Render queues and the techniques (docs/scene-format.md, "Render queues"): what a technique
//! does where the exact answer composites transparent fragments by (render group, queue)
//! level before depth, and lets depth-writing transparent fragments hide later levels behind
//! them. Runs report what they do not model ([`Queues::inexact`]); predictions say so
//! ([`predict_with_queues`]).

use oit_scene::Scene;

use crate::predict::{Layer, MODEL_EXACT, Pixel, PixelLists, composite};
use crate::{Caps, Prediction, Technique, Verdict};

/// How a technique composites a scene whose transparent draws span several levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Queues {
    /// By depth alone, as if every transparent draw were in one queue.
    Ignored,
    /// Levels in order (lower levels first, so underneath), but a depth-writing transparent
    /// draw hides nothing of later levels.
    Ordered,
    /// As the reference: level order and depth writes.
    Exact,
}

/// The run's `inexact` phrase when queues are composited by depth alone.
pub const QUEUE_ORDER_NOT_MODELLED: &str = "queue order not modelled";
/// The run's `inexact` phrase when depth-writing transparent draws hide nothing.
pub const QUEUE_DEPTH_WRITES_NOT_MODELLED: &str = "queue depth writes not modelled";

impl Queues {
    /// What a run of a technique with this support on `scene` does not model, as phrases
    /// for the run's `inexact` list (empty on scenes without queue effects).
    pub fn inexact(self, scene: &Scene) -> Vec<String> {
        if self == Queues::Exact || !scene.has_queue_effects() {
            return Vec::new();
        }
        let mut phrases = Vec::new();
        if self == Queues::Ignored {
            phrases.push(QUEUE_ORDER_NOT_MODELLED.to_owned());
        }
        if has_queue_depth_writes(scene) {
            phrases.push(QUEUE_DEPTH_WRITES_NOT_MODELLED.to_owned());
        }
        phrases
    }
}

/// Whether some transparent depth writer is in a lower level than some transparent draw: only
/// then can it hide a fragment.
pub fn has_queue_depth_writes(scene: &Scene) -> bool {
    let transparent = || {
        scene
            .draws
            .iter()
            .filter(|d| scene.material_of(d).mode.is_transparent())
    };
    let Some(highest) = transparent().map(|d| scene.queue_level(d)).max() else {
        return false;
    };
    transparent().any(|d| scene.material_of(d).depth_write && scene.queue_level(d) < highest)
}

/// `technique`'s prediction on `scene`, where render queues change the answer and the
/// technique does not model them: the depth writes it ignores are unmodelled (the lists hold
/// only the fragments they leave visible); a depth-only order is modelled on the lists (each
/// pixel's layers re-sorted nearest first) and decides when it differs. Otherwise, the
/// technique's own model ([`Technique::predict`]).
pub fn predict_with_queues(
    technique: &dyn Technique,
    scene: &Scene,
    lists: &PixelLists,
    caps: &Caps,
) -> Prediction {
    let support = technique.queues();
    if support == Queues::Exact || !scene.has_queue_effects() {
        return technique.predict(scene, lists, caps);
    }
    if has_queue_depth_writes(scene) {
        return Prediction::unmodelled(format!(
            "{QUEUE_DEPTH_WRITES_NOT_MODELLED}: depth-writing transparent draws hide later queues' fragments, which the reference's lists no longer hold"
        ));
    }
    if support == Queues::Ignored {
        let error = lists.model_error(MODEL_EXACT, |px| (depth_order(scene, px), false));
        let by_depth = Prediction::from_model(
            &error,
            "depth order is the queue order wherever it changes the colour",
            QUEUE_ORDER_NOT_MODELLED,
        );
        if by_depth.verdict != Verdict::Exact {
            return by_depth;
        }
    }
    technique.predict(scene, lists, caps)
}

/// A pixel's layers composited nearest first by depth alone (stable: queue order among equal
/// depths).
fn depth_order(scene: &Scene, px: Pixel<'_>) -> [f64; 3] {
    let mut layers: Vec<Layer> = px.layers.to_vec();
    let cam = &scene.camera;
    layers.sort_by(|a, b| {
        if cam.nearer(a.depth, b.depth) {
            std::cmp::Ordering::Less
        } else if cam.nearer(b.depth, a.depth) {
            std::cmp::Ordering::Greater
        } else {
            std::cmp::Ordering::Equal
        }
    });
    composite(layers.iter(), px.behind)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two blended panes, the second with `queue` and `depth_write` as given.
    fn two(queue: Option<u16>, depth_write: bool) -> Scene {
        let queue = queue
            .map(|q| format!(r#", "render_queue": {q}"#))
            .unwrap_or_default();
        let json = format!(
            r#"{{"name": "t", "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0]}}, "objects": [
                {{"mesh": {{"kind": "quad"}}, "material": {{"mode": "blend", "alpha": 0.5}}}},
                {{"mesh": {{"kind": "quad"}}, "material": {{"mode": "blend", "alpha": 0.5, "depth_write": {depth_write}}}{queue}}}
            ]}}"#
        );
        oit_scene::parse(&json, "t.json").unwrap()
    }

    #[test]
    fn runs_report_what_they_do_not_model() {
        let overlay = two(Some(4000), false);
        assert_eq!(
            Queues::Ignored.inexact(&overlay),
            [QUEUE_ORDER_NOT_MODELLED]
        );
        assert!(Queues::Ordered.inexact(&overlay).is_empty());
        assert!(Queues::Exact.inexact(&overlay).is_empty());
        // A writer in 2600 below a 3000 pane hides it where it is nearer.
        let writer = two(None, true);
        assert!(has_queue_depth_writes(&writer));
        assert_eq!(
            Queues::Ignored.inexact(&writer),
            [QUEUE_ORDER_NOT_MODELLED, QUEUE_DEPTH_WRITES_NOT_MODELLED]
        );
        assert_eq!(
            Queues::Ordered.inexact(&writer),
            [QUEUE_DEPTH_WRITES_NOT_MODELLED]
        );
        // A writer in the highest level hides nothing; one level has no queue effects at all.
        assert!(!has_queue_depth_writes(&two(Some(4000), true)));
        let same = two(Some(3000), true);
        assert!(Queues::Ignored.inexact(&same).is_empty());
    }
}
