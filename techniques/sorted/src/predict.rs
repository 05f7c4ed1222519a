//! What each blended baseline does to a pixel's list, for [`oit_gpu::Technique::predict`]: the
//! order its one blending pass receives the fragments in (the same orders `render` submits),
//! or, for `depth-prepass`, the layer it keeps.

use std::collections::BTreeMap;

use oit_gpu::predict::{
    Layer, Pixel, PixelLists, blend_in_order, draw_order_key, front_facing, model_error,
    predict_draw_order,
};
use oit_gpu::{Caps, Prediction};
use oit_scene::Scene;

use crate::sort::{DepthSorter, centroid, object_order};
use crate::technique::Kind;

/// `kind`'s prediction on `scene`.
pub(crate) fn predict(kind: Kind, scene: &Scene, lists: &PixelLists, caps: &Caps) -> Prediction {
    // Without dual-source blending, coloured transmittance is blended as scalar 1 − mean(t).
    let scalar = scene.has_transmission() && !caps.dual_source_blending;
    let blend = |px: Pixel<'_>, key: &(dyn Fn(&Layer) -> u64 + Sync)| {
        if scalar {
            let layers: Vec<Layer> = px.layers.iter().map(scalar_opacity).collect();
            blend_in_order(
                Pixel {
                    layers: &layers,
                    behind: px.behind,
                },
                key,
            )
        } else {
            blend_in_order(px, key)
        }
    };
    match kind {
        Kind::Unsorted if !scalar => predict_draw_order(lists),
        Kind::Unsorted => {
            let error = model_error(lists, |px| blend(px, &draw_order_key));
            Prediction::from_model(
                &error,
                "draw order is back to front wherever the order changes the colour",
                "draw order is not back to front, or scalar opacity misses coloured transmission",
            )
        }
        Kind::SortedObject => {
            let position = object_positions(scene);
            let key = |l: &Layer| (position[l.draw as usize] << 32) | u64::from(l.triangle);
            let error = model_error(lists, |px| blend(px, &key));
            Prediction::from_model(
                &error,
                "Babylon's object order, triangles in index order, is back to front wherever the order changes the colour",
                "objects intersect, interleave or overlap themselves out of order",
            )
        }
        Kind::CullSplit => {
            let position = object_positions(scene);
            let facing = triangle_facing(scene);
            let key = |l: &Layer| {
                let front = facing[l.draw as usize][l.triangle as usize];
                (position[l.draw as usize] << 33) | (u64::from(front) << 32) | u64::from(l.triangle)
            };
            let error = model_error(lists, |px| blend(px, &key));
            Prediction::from_model(
                &error,
                "object order with back faces before front faces is back to front wherever the order changes the colour",
                "objects intersect or interleave, or a surface overlaps itself within one facing",
            )
        }
        Kind::SortedTriangle => {
            let position = triangle_positions(scene);
            let key = |l: &Layer| position[l.draw as usize][l.triangle as usize];
            let error = model_error(lists, |px| blend(px, &key));
            Prediction::from_model(
                &error,
                "centroid order is back to front wherever the order changes the colour",
                "triangles intersect or overlap cyclically, or centroid depth misorders them",
            )
        }
        Kind::DepthPrepass => {
            let error = model_error(lists, |px| {
                let Some(nearest) = px.layers.first() else {
                    return px.behind;
                };
                let kept: Vec<Layer> = px
                    .layers
                    .iter()
                    .filter(|l| l.depth == nearest.depth)
                    .map(|l| if scalar { scalar_opacity(l) } else { *l })
                    .collect();
                blend_in_order(
                    Pixel {
                        layers: &kept,
                        behind: px.behind,
                    },
                    draw_order_key,
                )
            });
            Prediction::from_model(
                &error,
                "every pixel's layers behind the nearest change nothing",
                "layers behind the nearest transparent surface are hidden by its depth",
            )
        }
    }
}

/// The layer as scalar-opacity blending sees it: transmittance `1 − α` in every channel.
fn scalar_opacity(l: &Layer) -> Layer {
    Layer {
        transmittance: [1.0 - l.alpha; 3],
        ..*l
    }
}

/// Per draw: its position in Babylon's object order (opaque draws: past the end).
fn object_positions(scene: &Scene) -> Vec<u64> {
    let mut position = vec![u64::from(u32::MAX); scene.draws.len()];
    for (p, d) in object_order(scene).into_iter().enumerate() {
        position[d] = p as u64;
    }
    position
}

/// Per draw, per triangle: whether the camera sees its front.
fn triangle_facing(scene: &Scene) -> Vec<Vec<bool>> {
    scene
        .draws
        .iter()
        .map(|d| {
            (0..d.triangle_count())
                .map(|t| {
                    let v = (d.first_vertex + 3 * t) as usize;
                    let p = |k: usize| scene.vertices[v + k].position;
                    front_facing(scene, [p(0), p(1), p(2)])
                })
                .collect()
        })
        .collect()
}

/// One (render group, queue) level's transparent triangles, as (draw, triangle index), and their centroids.
type Group = (Vec<(usize, u32)>, Vec<glam::Vec3>);

/// Per draw, per triangle: its position in `sorted-triangle`'s stream, built as `render`
/// builds it ((render group, queue) levels ascending; in each, the transparent draws' triangles in draw order,
/// sorted back to front by centroid view depth, stable).
fn triangle_positions(scene: &Scene) -> Vec<Vec<u64>> {
    let mut position: Vec<Vec<u64>> = scene
        .draws
        .iter()
        .map(|d| vec![u64::MAX; d.triangle_count() as usize])
        .collect();
    let mut groups: BTreeMap<oit_scene::QueueLevel, Group> = BTreeMap::new();
    for (i, d) in scene.draws.iter().enumerate() {
        if !scene.material_of(d).mode.is_transparent() {
            continue;
        }
        let g = groups.entry(scene.queue_level(d)).or_default();
        for t in 0..d.triangle_count() {
            let v = (d.first_vertex + 3 * t) as usize;
            let p = |k: usize| scene.vertices[v + k].position;
            g.0.push((i, t));
            g.1.push(centroid(p(0), p(1), p(2)));
        }
    }
    let mut sorter = DepthSorter::new();
    let mut next = 0u64;
    for (triangles, centroids) in groups.values() {
        for &t in sorter.sort_back_to_front(&scene.camera.view, centroids) {
            let (draw, triangle) = triangles[t as usize];
            position[draw][triangle as usize] = next;
            next += 1;
        }
    }
    position
}
