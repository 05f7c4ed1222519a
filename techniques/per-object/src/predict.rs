//! What `per-object` does to a pixel's list, for [`oit_gpu::Technique::predict`], where that is
//! deterministic: runs of `opaque` and `blended` objects. Their fragments reach the target in
//! the order `render` submits them (draw order, then triangle order); an `opaque` fragment
//! replaces the colour with its straight colour, a `blended` one composites `P + t ⊙ dst`, and
//! a fragment behind a depth already written (by an `opaque` object, or a blended one whose
//! material writes depth) fails the depth test. `stochastic` (noise) and `weighted` runs are
//! measured only.

use crate::order::{Config, draw_order};
use oit_gpu::predict::{Layer, PixelLists, f16_round, model_error};
use oit_gpu::{Caps, Prediction};
use oit_scene::{ObjectMethod, Scene};

/// How one draw's fragments reach the target.
#[derive(Debug, Clone, Copy)]
struct DrawModel {
    /// Position in the frame's draw order.
    position: u64,
    solid: bool,
    writes_depth: bool,
}

pub(crate) fn predict(
    config: Config,
    scene: &Scene,
    lists: &PixelLists,
    caps: &Caps,
) -> Prediction {
    let order = draw_order(config, scene);
    for method in [ObjectMethod::Stochastic, ObjectMethod::Weighted] {
        if order.iter().any(|&(_, m)| m == method) {
            return Prediction::unmodelled(format!(
                "some objects are drawn {}: {}",
                method.name(),
                match method {
                    ObjectMethod::Stochastic => "blue-noise dithering is measured only",
                    _ => "weighted blending is measured only",
                }
            ));
        }
    }
    let mut draws: Vec<Option<DrawModel>> = vec![None; scene.draws.len()];
    for (position, &(i, method)) in order.iter().enumerate() {
        let solid = method == ObjectMethod::Opaque;
        draws[i] = Some(DrawModel {
            position: position as u64,
            solid,
            writes_depth: solid || scene.material_of(&scene.draws[i]).depth_write,
        });
    }
    // Without dual-source blending, coloured transmittance is blended as scalar 1 − mean(t).
    let scalar = scene.has_transmission() && !caps.dual_source_blending;
    let error = model_error(lists, |px| {
        let key = |l: &Layer| {
            let position = draws[l.draw as usize].map_or(u64::from(u32::MAX), |d| d.position);
            (position << 32) | u64::from(l.triangle)
        };
        // Layer indices (nearest first) in submission order.
        let mut submitted: Vec<usize> = (0..px.layers.len()).collect();
        submitted.sort_by_key(|&i| key(&px.layers[i]));
        let mut nearest_written = usize::MAX;
        let mut dst = px.behind.map(|c| f16_round(c as f32));
        for i in submitted {
            if i >= nearest_written {
                continue;
            }
            let l = &px.layers[i];
            let Some(d) = draws[l.draw as usize] else {
                continue;
            };
            if d.solid {
                let a = l.alpha;
                dst = [0, 1, 2].map(|c| {
                    let p = l.premultiplied[c];
                    f16_round(if a > 0.0 { p / a } else { p })
                });
            } else {
                let t = |c: usize| {
                    if scalar {
                        1.0 - l.alpha
                    } else {
                        l.transmittance[c]
                    }
                };
                dst = [0, 1, 2].map(|c| f16_round(l.premultiplied[c] + t(c) * dst[c]));
            }
            if d.writes_depth {
                nearest_written = nearest_written.min(i);
            }
        }
        dst.map(f64::from)
    });
    let opaque = order.iter().any(|&(_, m)| m == ObjectMethod::Opaque);
    Prediction::from_model(
        &error,
        if opaque {
            "pygfx's object order composites every layer the opaque-method objects do not change or hide back to front"
        } else {
            "pygfx's object order, triangles in index order, is back to front wherever the order changes the colour"
        },
        if opaque {
            "opaque-method objects replace or hide transparent layers, or objects overlap out of order"
        } else {
            "objects intersect, interleave or overlap themselves out of order, or depth-writing blended objects hide layers"
        },
    )
}
