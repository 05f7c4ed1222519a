//! What `abuffer` does to a pixel's list, for [`oit_gpu::Technique::predict`]: every fragment
//! packed as the GPU packs it and all of them composited in order (the list's CPU twins,
//! `oit_linked_list::node`, with a window of every fragment). Exact up to the node format, or
//! refused when the array is over its cap.

use crate::abuffer::{Abuffer, AbufferConfig};
use oit_gpu::predict::{PixelLists, model_error};
use oit_gpu::{Caps, Prediction};
use oit_linked_list::node;
use oit_scene::Scene;

pub(crate) fn predict(
    config: AbufferConfig,
    scene: &Scene,
    lists: &PixelLists,
    caps: &Caps,
) -> Prediction {
    // The layout the GPU takes on this scene and adapter.
    let transmit = oit_linked_list::stores_opacity(config.node, scene, caps);
    let fragments = lists.fragment_count();
    if let Err(e) = Abuffer::new(config).array_bytes(caps, fragments, transmit) {
        return Prediction::unmodelled(format!("refused: {e}"));
    }
    let reverse_z = scene.camera.reverse_z;
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
                    l.transmittance.map(|t| 1.0 - t),
                    l.depth,
                    reverse_z,
                )
            })
            .collect();
        let (c, t, _) = node::resolve(config.node, transmit, &nodes, nodes.len(), false);
        [0, 1, 2].map(|i| f64::from(c[i]) + f64::from(t[i]) * px.behind[i])
    });
    Prediction::from_model(
        &error,
        &format!(
            "every pixel's {} layers are stored and sorted, in {} nodes",
            lists.max_layers(),
            config.node.name()
        ),
        "node storage rounds the layers",
    )
}
