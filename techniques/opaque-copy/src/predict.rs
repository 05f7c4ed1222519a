//! What `opaque-copy` does to a pixel's list, for [`oit_gpu::Technique::predict`]: the nearest
//! transmissive layer over the copied opaque colour (`C + t ⊙ copy`), everything behind it
//! hidden by its depth, the ordinary transparent layers in front OVER-blended in Babylon's
//! object order.

use oit_gpu::Prediction;
use oit_gpu::predict::{Layer, Pixel, PixelLists, blend_in_order, model_error};
use oit_scene::Scene;

pub(crate) fn predict(scene: &Scene, lists: &PixelLists) -> Prediction {
    let transmissive: Vec<bool> = scene
        .draws
        .iter()
        .map(|d| scene.material_of(d).is_transmissive())
        .collect();
    let mut position = vec![u64::from(u32::MAX); scene.draws.len()];
    for (p, d) in scene.babylon_object_order().into_iter().enumerate() {
        position[d] = p as u64;
    }
    let key = |l: &Layer| (position[l.draw as usize] << 32) | u64::from(l.triangle);
    let error = model_error(lists, |px| {
        let glass = px.layers.iter().position(|l| transmissive[l.draw as usize]);
        let (front, behind) = match glass {
            Some(j) => {
                let g = &px.layers[j];
                let behind = [0, 1, 2].map(|c| {
                    f64::from(g.premultiplied[c]) + f64::from(g.transmittance[c]) * px.behind[c]
                });
                (&px.layers[..j], behind)
            }
            None => (px.layers, px.behind),
        };
        blend_in_order(
            Pixel {
                layers: front,
                behind,
            },
            key,
        )
    });
    Prediction::from_model(
        &error,
        "nothing transparent lies behind the nearest transmissive surface, and object order is back to front where it matters",
        "layers behind the nearest transmissive surface are missing from the copy, or object order is wrong",
    )
}
