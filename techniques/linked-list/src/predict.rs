//! What `linked-list` and `k-buffer` do to a pixel's list, for
//! [`oit_gpu::Technique::predict`]: every fragment packed as the GPU packs it (the CPU twins
//! [`crate::node::pack_node`] and [`crate::kbuffer::to_slot`]), then the twins' resolves: the
//! nearest `sort_max` (or `k`) composited front to back, the rest by the tail rule.

use oit_gpu::predict::{Layer, PixelLists, model_error};
use oit_gpu::{Caps, Prediction, Verdict};
use oit_scene::Scene;

use crate::config::{LinkedListConfig, MAX_SORT, TailRule};
use crate::kbuffer::MAX_K;
use crate::kbuffer::{self, KBufferConfig};
use crate::node;
use crate::sizing::Sizing;

/// Whether the technique stores rgb opacity on this scene and adapter.
fn transmit(scene: &Scene, caps: &Caps) -> bool {
    scene.has_transmission() && caps.dual_source_blending
}

/// A per-pixel size: the fixed one, or for `auto` the deepest pixel's layer count, as the GPU
/// count pass finds it; a run that `auto` refuses (deeper than `max`) is unmodelled.
fn per_pixel<const MIN: u32, const MAX: u32>(
    size: Sizing<oit_gpu::Bounded<MIN, MAX>>,
    layers: u32,
    max: u64,
    name: &str,
    whose: &str,
) -> Result<usize, Prediction> {
    match size {
        Sizing::Fixed(n) => Ok(n.get() as usize),
        Sizing::Auto if u64::from(layers) > max => Err(Prediction::unmodelled(format!(
            "{name}=auto refuses the scene: its deepest pixel's {layers} layers are more than {whose} {max}"
        ))),
        Sizing::Auto => Ok(layers.max(1) as usize),
    }
}

fn opacity(l: &Layer) -> [f32; 3] {
    l.transmittance.map(|t| 1.0 - t)
}

pub(crate) fn predict_list(
    config: LinkedListConfig,
    scene: &Scene,
    lists: &PixelLists,
    caps: &Caps,
) -> Prediction {
    // Packed nodes on a scene that subtracts take the transmit layout, as the GPU does.
    let transmit =
        transmit(scene, caps) || crate::list::node_layout_transmits(&config, scene, caps);
    let reverse_z = scene.camera.reverse_z;
    let layers = lists.max_layers();
    let window = match per_pixel(
        config.sort_max,
        layers,
        MAX_SORT,
        "sort-max",
        "the window's",
    ) {
        Ok(n) => n,
        Err(refused) => return refused,
    };
    let average = config.tail == TailRule::Average;
    let error = model_error(lists, |px| {
        let nodes: Vec<node::Node> = px
            .layers
            .iter()
            .map(|l| {
                node::pack_node(
                    config.node,
                    transmit,
                    l.premultiplied,
                    l.alpha,
                    opacity(l),
                    l.depth,
                    reverse_z,
                )
            })
            .collect();
        let (c, t, _) = node::resolve(config.node, transmit, &nodes, window, average);
        [0, 1, 2].map(|i| f64::from(c[i]) + f64::from(t[i]) * px.behind[i])
    });
    let mut p = Prediction::from_model(
        &error,
        &format!(
            "the sort window of {window} holds every pixel's {layers} layers, stored in {} nodes",
            config.node.name()
        ),
        &format!(
            "layers beyond the sort window of {window} are {}, or node storage rounds them",
            if average { "averaged" } else { "dropped" }
        ),
    );
    let fragments = lists.fragment_count();
    // `nodes-per-pixel=auto` holds every fragment (or the run is refused over its cap).
    let capacity = match config.nodes_per_pixel {
        Sizing::Fixed(n) => u64::from(n.get()) * lists.pixel_count() as u64,
        Sizing::Auto => fragments,
    };
    if fragments > capacity && p.verdict != Verdict::Inexact {
        // Which fragments a full pool loses depends on the order they arrive in.
        p.verdict = Verdict::Borderline;
        p.because = format!(
            "the pool of {capacity} nodes cannot hold the {fragments} fragments (which are lost depends on arrival order); {}",
            p.because
        );
    }
    p
}

pub(crate) fn predict_kbuffer(
    config: KBufferConfig,
    scene: &Scene,
    lists: &PixelLists,
    caps: &Caps,
) -> Prediction {
    // Two chains also for `subtract` (its sign sits in the opacity slot), as the GPU keeps.
    let transmit = transmit(scene, caps) || kbuffer::two_chains(scene, caps);
    let reverse_z = scene.camera.reverse_z;
    let layers = lists.max_layers();
    let k = match per_pixel(config.k, layers, MAX_K, "k", "k's") {
        Ok(n) => n,
        Err(refused) => return refused,
    };
    let error = model_error(lists, |px| {
        let (c, t) = if transmit {
            let slots: Vec<[u64; 2]> = px
                .layers
                .iter()
                .map(|l| {
                    kbuffer::to_transmit_slots(l.premultiplied, opacity(l), l.depth, reverse_z)
                })
                .collect();
            kbuffer::resolve_transmit(&slots, k, config.tail)
        } else {
            let slots: Vec<u64> = px
                .layers
                .iter()
                .map(|l| kbuffer::to_slot(l.premultiplied, l.alpha, l.depth, reverse_z))
                .collect();
            let (c, t) = kbuffer::resolve(&slots, k, config.tail);
            (c, [t; 3])
        };
        [0, 1, 2].map(|i| f64::from(c[i]) + f64::from(t[i]) * px.behind[i])
    });
    Prediction::from_model(
        &error,
        &format!("k = {k} slots hold every pixel's {layers} layers, stored as 64-bit slots"),
        &format!(
            "layers beyond the {k} nearest are {}, or the slots' rgb9e5 colour and 8-bit α round them",
            if config.tail == TailRule::Average {
                "averaged"
            } else {
                "dropped"
            }
        ),
    )
}
