//! What the `range` weight knows about a scene, computed on the CPU from the flattened scene:
//! the view-depth interval of its transparent geometry, how much light that geometry absorbs on
//! average, and how bright its fragments can be.
//!
//! The ideal WBOIT weight of a fragment is the transmittance in front of it (then the weighted
//! sum is the exact front-to-back composite: Σ α_i·T_i = 1 − Π(1 − α_i)). `range` approximates
//! that transmittance by assuming the scene's absorbance is spread evenly across its
//! transparent depth interval: a fragment at position t ∈ [0, 1] of the interval sits behind a
//! fraction t of it, so w = 256 · 2^(−fall · t), where `fall` is the absorbance (in bits,
//! −log2 T) a pixel's fragments put in front of the farthest one, averaged over the pixels
//! where two or more fragments overlap (with one fragment WBOIT is exact for any weight, so
//! those pixels say nothing about the curve). Two α = 0.45 layers give fall ≈ 0.86 (the back
//! layer's weight is 0.55 of the front's, as in the exact composite); a 1/512 haze gives
//! fall ≈ 0 (uniform weights); 32 layers of α = 0.99 give a steep fall, capped by
//! [`fall_cap`] so that α·w of the scene's faintest fragment stays inside fp16's normal range.
//!
//! The weight has no α factor (the paper's weights have one): the fragment's own α already
//! enters the sums as C = α·c and α·w, and a second factor α over-weights dense layers against
//! faint ones. On `hdr-emissive` (an α = 0.3 sphere in front of α = 0.1 emissive quads) the α
//! factor alone took the weight term of the error from RMSE 8.2 to 13.2.
//!
//! HDR colour: without the α factor one layer of colour 100 adds 100·256 to a colour sum, and
//! three such layers overflow fp16. The colour sums are therefore accumulated in units of
//! [`RangeParams::color_scale`] (a power of two at least as large as any transparent
//! fragment's premultiplied colour, 1 for colours in [0, 1]), which the composite multiplies
//! back; α·w is not scaled, so faint layers keep their precision.

use oit_scene::{Scene, Shaded, Texels};

/// Largest weight: 2^8, so 255 layers of α = 1 (and colour at most the colour scale) still sum
/// below fp16's 65504.
pub const MAX_WEIGHT: f32 = 256.0;
/// Largest fall in bits, for a scene whose faintest fragment has α = 1: the smallest weight
/// 256 · 2^−21 = 2^−13 is one bit above fp16's smallest normal (2^−14). [`fall_cap`] lowers it
/// by the faintest α's bits.
pub const MAX_FALL: f32 = 21.0;
/// The cap [`fall_cap`] never goes below: 256 · 2^−12 = 1/16 keeps α·w of α = 1/512 layers
/// (1.2e-4) above fp16's smallest normal (6.1e-5). Fainter layers are lost to r16f revealage
/// rounding near 1 anyway, so they do not flatten the curve further.
pub const MIN_FALL_CAP: f32 = 12.0;
/// Edge of the coarse screen grid the absorbance is estimated on.
pub const GRID: usize = 64;

/// The scene-dependent inputs of the `range` weight and of the colour scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeParams {
    /// View distance of the nearest transparent vertex (clamped to the camera's near plane).
    pub z_near: f32,
    /// View distance of the farthest transparent vertex (clamped to the far plane).
    pub z_far: f32,
    /// Bits of absorbance in front of the farthest fragment of a pixel, averaged over pixels
    /// with two or more fragments, in [0, fall_cap(scene)] ⊂ [0, MAX_FALL].
    pub fall: f32,
    /// Unit of the accumulated colour sums: the smallest power of two ≥ 1 that bounds every
    /// transparent fragment's premultiplied colour ([`color_scale`]).
    pub color_scale: f32,
}

impl RangeParams {
    pub fn of(scene: &Scene) -> RangeParams {
        let (z_near, z_far) = scene.transparent_view_depth_interval(f32::MIN_POSITIVE);
        RangeParams {
            z_near,
            z_far,
            fall: absorbance_fall(scene),
            color_scale: color_scale(scene),
        }
    }

    /// CPU twin of `wboit_weight_range` in shaders/wboit_tail.wgsl.
    pub fn weight(&self, view_z: f32) -> f32 {
        let span = self.z_far - self.z_near;
        let t = if span > 0.0 {
            ((view_z - self.z_near) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        MAX_WEIGHT * (-self.fall.clamp(0.0, MAX_FALL) * t).exp2()
    }
}

/// The unit the WBOIT colour sums are kept in: the smallest power of two ≥ 1 that is at least
/// every premultiplied colour channel a transparent fragment of `scene` can have (per triangle,
/// its largest vertex colour times its largest vertex α, through the material). A power of two,
/// so dividing by it and multiplying back is exact; 1 for colours in [0, 1], which leaves
/// those scenes' sums bit for bit as they were. With it, Σ (C/scale)·w ≤ Σ w, which fp16 holds
/// for 255 layers of the largest weight. Lit materials (per-pixel lighting) are bounded here by
/// their unlit colour; their specular reflection can exceed it (not bounded since 2026-12-07:
/// a point light's radiance grows without limit near it), so only the fp16 range, 65504,
/// guards their sums.
pub fn color_scale(scene: &Scene) -> f32 {
    let mut largest = 1.0f32;
    let bounds: Vec<Texels> = (scene.materials.iter())
        .map(|m| m.max_texels(&scene.textures))
        .collect();
    for d in &scene.draws {
        let m = scene.material_of(d);
        if !m.mode.is_transparent() {
            continue;
        }
        let texels = bounds[d.material as usize];
        let verts = &scene.vertices[d.vertex_range()];
        for tri in verts.chunks_exact(3) {
            // Colour and α are interpolated separately, so their product is bounded by the
            // product of their largest values, not by the largest vertex product.
            let mut top = [0.0f32; 4];
            for v in tri {
                for (t, c) in top.iter_mut().zip(v.color) {
                    *t = t.max(c);
                }
            }
            if let Shaded::Transparent { premultiplied, .. }
            | Shaded::Transmissive { premultiplied, .. } = m.shade(top, texels)
            {
                for c in premultiplied {
                    if c.is_finite() {
                        largest = largest.max(c);
                    }
                }
            }
        }
    }
    // 2^127 is the largest power of two in f32.
    2f32.powi((largest.log2().ceil() as i32).min(127))
}

/// The steepest fall fp16 allows for `scene`: α·w of its faintest transparent fragment must
/// stay a normal fp16 number (one bit of margin), 2^−13 ≤ α_min · 256 · 2^−cap, so
/// cap = 21 + log2(α_min), within [MIN_FALL_CAP, MAX_FALL]. α_min is the smallest vertex α
/// (times the material's; at least the cutoff for mask-blend) of any transparent triangle
/// that is not entirely α = 0 (such fragments add nothing to Σα·w); α is interpolated
/// linearly, so no fragment of a triangle is fainter than its faintest vertex.
pub fn fall_cap(scene: &Scene) -> f32 {
    let mut faintest = 1.0f32;
    for d in &scene.draws {
        let m = scene.material_of(d);
        if !m.mode.is_transparent() {
            continue;
        }
        for tri in scene.vertices[d.vertex_range()].chunks_exact(3) {
            let alpha: [f32; 3] = std::array::from_fn(|i| {
                let a = tri[i].color[3] * m.alpha;
                if m.mode.uses_cutoff() {
                    a.max(m.cutoff)
                } else {
                    a
                }
            });
            if alpha.iter().all(|&a| a <= 0.0) {
                continue;
            }
            faintest = alpha.into_iter().fold(faintest, f32::min);
        }
    }
    (MAX_FALL + faintest.max(0.0).log2()).clamp(MIN_FALL_CAP, MAX_FALL)
}

/// The mean, over grid cells where two or more transparent fragments overlap, of the
/// absorbance (bits) in front of the cell's farthest fragment: Σ −log2(1 − α_i) · (n − 1)/n
/// for the n fragments at the cell centre (the farthest fragment's own absorbance is not in
/// front of it; with n equal layers, (n − 1)/n of the total is). Cells with one fragment are
/// left out: WBOIT is exact there for any weight, and counting them flattened the curve for
/// the pixels where it matters (on `hdr-emissive`, fall 0.125 over all covered cells, 0.31
/// over the overlapping ones). Opaque occluders are ignored, α is the triangle's mean vertex α
/// times the material's, and back faces of single-sided materials do not count. Clamped to
/// [0, fall_cap(scene)].
pub fn absorbance_fall(scene: &Scene) -> f32 {
    let cam = &scene.camera;
    let mut bits = vec![0.0f64; GRID * GRID];
    let mut count = vec![0u32; GRID * GRID];
    for d in &scene.draws {
        let m = scene.material_of(d);
        if !m.mode.is_transparent() {
            continue;
        }
        let verts = &scene.vertices[d.vertex_range()];
        for tri in verts.chunks_exact(3) {
            let alpha = tri.iter().map(|v| v.color[3]).sum::<f32>() / 3.0 * m.alpha;
            if m.mode.uses_cutoff() && alpha < m.cutoff {
                continue;
            }
            let a = f64::from(alpha.clamp(0.0, 0.999));
            let absorb = -(1.0 - a).log2();
            let clip: [glam::Vec4; 3] =
                std::array::from_fn(|i| cam.clip(glam::Vec3::from(tri[i].position)));
            if clip.iter().any(|c| c.w <= 1e-6) {
                // Crosses or lies behind the eye plane: left out of the estimate.
                continue;
            }
            // Grid coordinates with y up (NDC orientation, so counter-clockwise is front).
            let p = clip.map(|c| {
                [
                    (c.x / c.w * 0.5 + 0.5) * GRID as f32,
                    (c.y / c.w * 0.5 + 0.5) * GRID as f32,
                ]
            });
            let area = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
            if area == 0.0 || (area < 0.0 && !m.double_sided) {
                continue;
            }
            // Counter-clockwise order, so that "inside" is the left of every edge.
            let p = if area < 0.0 { [p[0], p[2], p[1]] } else { p };
            let min = |k: usize| p.iter().map(|q| q[k]).fold(f32::INFINITY, f32::min);
            let max = |k: usize| p.iter().map(|q| q[k]).fold(f32::NEG_INFINITY, f32::max);
            let range = |lo: f32, hi: f32| {
                let a = (lo - 0.5).ceil().max(0.0) as usize;
                let b = ((hi - 0.5).floor() + 1.0).clamp(0.0, GRID as f32) as usize;
                a..b
            };
            for gy in range(min(1), max(1)) {
                for gx in range(min(0), max(0)) {
                    let (x, y) = (gx as f32 + 0.5, gy as f32 + 0.5);
                    let inside = (0..3).all(|i| {
                        let (a, b) = (p[i], p[(i + 1) % 3]);
                        let e = (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
                        // A centre on a shared edge belongs to one of the two triangles: the
                        // one that runs the edge downwards (or leftwards when horizontal).
                        e > 0.0 || (e == 0.0 && (b[1] < a[1] || (b[1] == a[1] && b[0] < a[0])))
                    });
                    if inside {
                        bits[gy * GRID + gx] += absorb;
                        count[gy * GRID + gx] += 1;
                    }
                }
            }
        }
    }
    let (mut sum, mut overlapping) = (0.0f64, 0u32);
    for (b, &n) in bits.iter().zip(&count) {
        if n >= 2 {
            sum += b * f64::from(n - 1) / f64::from(n);
            overlapping += 1;
        }
    }
    if overlapping == 0 {
        return 0.0;
    }
    ((sum / f64::from(overlapping)) as f32).clamp(0.0, fall_cap(scene))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(objects: &str, camera: &str) -> Scene {
        let json = format!(
            r#"{{"name": "t", "description": "", "resolution": [64, 64],
                "camera": {camera}, "background": [0, 0, 0], "objects": [{objects}]}}"#
        );
        oit_scene::parse(&json, "range test").expect("valid scene")
    }

    const CAMERA: &str = r#"{"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100}"#;

    fn quad(z: f32, alpha: f32) -> String {
        format!(
            r#"{{"mesh": {{"kind": "quad", "size": [20, 20]}}, "transform": {{"translate": [0, 0, {z}]}},
                "material": {{"base_color": [1, 1, 1], "alpha": {alpha}, "mode": "blend"}}}}"#
        )
    }

    #[test]
    fn two_screen_filling_layers() {
        // Two layers of alpha 0.45 cover every cell: the back one sits behind -log2(0.55) bits.
        let s = scene(
            &format!("{}, {}", quad(0.5, 0.45), quad(-0.5, 0.45)),
            CAMERA,
        );
        let r = RangeParams::of(&s);
        assert!((r.fall - 0.55f32.log2().abs()).abs() < 1e-4, "{r:?}");
        assert!(
            (r.z_near - 4.5).abs() < 1e-4 && (r.z_far - 5.5).abs() < 1e-4,
            "{r:?}"
        );
        // The back layer's weight relative to the front's is then the exact 1 - 0.45.
        let ratio = r.weight(5.5) / r.weight(4.5);
        assert!((ratio - 0.55).abs() < 1e-4, "{ratio}");
        assert!((r.weight(4.5) - MAX_WEIGHT).abs() < 1e-3);
        assert_eq!(r.color_scale, 1.0);
    }

    #[test]
    fn one_layer_is_flat_and_none_is_the_frustum() {
        let s = scene(&quad(0.0, 0.5), CAMERA);
        let r = RangeParams::of(&s);
        assert_eq!(r.fall, 0.0);
        assert_eq!(r.weight(5.0), MAX_WEIGHT);
        let empty = scene("", CAMERA);
        let r = RangeParams::of(&empty);
        assert_eq!(
            (r.z_near, r.z_far, r.fall, r.color_scale),
            (0.1, 100.0, 0.0, 1.0)
        );
    }

    #[test]
    fn deep_opaque_stacks_are_capped() {
        let layers: Vec<String> = (0..8).map(|i| quad(i as f32 * -0.1, 0.99)).collect();
        let s = scene(&layers.join(", "), CAMERA);
        let r = RangeParams::of(&s);
        // 7/8 of 8 · 6.6 bits in front of the farthest layer, capped at 21 + log2(0.99).
        assert_eq!(fall_cap(&s), MAX_FALL + 0.99f32.log2());
        assert_eq!(r.fall, fall_cap(&s));
        // α·w of the faintest fragment stays a normal fp16 number (2^-14), with a bit to spare.
        assert!(r.weight(r.z_far) * 0.99 >= 2f32.powi(-13) * 0.999);
    }

    #[test]
    fn the_cap_follows_the_faintest_alpha() {
        let stack = |alphas: &[f32]| {
            let layers: Vec<String> = alphas
                .iter()
                .enumerate()
                .map(|(i, &a)| quad(i as f32 * -0.1, a))
                .collect();
            scene(&layers.join(", "), CAMERA)
        };
        assert_eq!(fall_cap(&stack(&[1.0, 1.0])), MAX_FALL);
        assert_eq!(fall_cap(&stack(&[0.99, 0.25])), MAX_FALL - 2.0);
        // α = 1/512 sits at the floor; fainter layers do not lower it further.
        assert_eq!(fall_cap(&stack(&[0.99, 1.0 / 512.0])), MIN_FALL_CAP);
        assert_eq!(fall_cap(&stack(&[0.99, 1e-6])), MIN_FALL_CAP);
        // Fragments with α = 0 add nothing to Σα·w: they do not count.
        assert_eq!(fall_cap(&stack(&[0.5, 0.0])), MAX_FALL - 1.0);
        // Without transparent geometry the cap is the largest.
        assert_eq!(fall_cap(&scene("", CAMERA)), MAX_FALL);
    }

    #[test]
    fn single_fragment_cells_do_not_flatten_the_fall() {
        // A small pair of α = 0.5 quads (1 bit in front of the back one) beside a large single
        // quad: only the overlapping cells count, so the fall is the pair's, not diluted.
        let small = |z: f32| {
            format!(
                r#"{{"mesh": {{"kind": "quad", "size": [0.5, 0.5]}}, "transform": {{"translate": [-1, 0, {z}]}},
                    "material": {{"base_color": [1, 1, 1], "alpha": 0.5, "mode": "blend"}}}}"#
            )
        };
        let big = r#"{"mesh": {"kind": "quad", "size": [2, 2]}, "transform": {"translate": [1.2, 0, 0]},
            "material": {"base_color": [1, 1, 1], "alpha": 0.5, "mode": "blend"}}"#;
        let s = scene(&format!("{}, {}, {big}", small(0.5), small(0.0)), CAMERA);
        let fall = absorbance_fall(&s);
        // (n − 1)/n of 2 bits for n = 2.
        assert!((fall - 1.0).abs() < 1e-6, "{fall}");
    }

    #[test]
    fn color_scale_bounds_the_brightest_premultiplied_colour() {
        let hdr = |intensity: f32, alpha: f32| {
            format!(
                r#"{{"mesh": {{"kind": "quad", "size": [2, 2]}},
                    "material": {{"base_color": [0.2, 0.6, 1], "alpha": {alpha}, "mode": "blend", "intensity": {intensity}}}}}"#
            )
        };
        // 1000 · 0.1 = 100 → 128; 1000 · 0.128 = 128 exactly → 128; 0.5 → 1 (LDR is unscaled).
        for (intensity, alpha, scale) in [
            (1000.0, 0.1, 128.0),
            (1000.0, 0.128, 128.0),
            (0.5, 1.0, 1.0),
        ] {
            let s = scene(&hdr(intensity, alpha), CAMERA);
            assert_eq!(
                color_scale(&s),
                scale,
                "intensity {intensity} alpha {alpha}"
            );
        }
        // Opaque draws do not count.
        let opaque = r#"{"mesh": {"kind": "quad", "size": [2, 2]},
            "material": {"base_color": [1, 1, 1], "intensity": 1000}}"#;
        assert_eq!(color_scale(&scene(opaque, CAMERA)), 1.0);
    }

    #[test]
    fn back_faces_of_single_sided_layers_do_not_count() {
        // Seen from behind (eye at -5), single-sided quads are culled: nothing absorbs.
        let behind = r#"{"eye": [0, 0, -5], "target": [0, 0, 0], "up": [0, 1, 0], "fov_y": 45, "near": 0.1, "far": 100}"#;
        let s = scene(
            &format!("{}, {}", quad(0.5, 0.45), quad(-0.5, 0.45)),
            behind,
        );
        assert_eq!(absorbance_fall(&s), 0.0);
    }
}
