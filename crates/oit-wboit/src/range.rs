//! What the `range` weight knows about a scene, computed on the CPU from the flattened scene:
//! the view-depth interval of its transparent geometry and how much light that geometry
//! absorbs on average.
//!
//! The ideal WBOIT weight of a fragment is the transmittance in front of it (then the weighted
//! sum is the exact front-to-back composite). `range` approximates that transmittance by
//! assuming the scene's absorbance is spread evenly across its transparent depth interval:
//! a fragment at position t ∈ [0, 1] of the interval sits behind a fraction t of it, so
//! w = α · 256 · 2^(−fall · t), where `fall` is the absorbance (in bits, −log2 T) a covered
//! pixel's fragments put in front of the farthest one. Two α = 0.45 layers give fall ≈ 0.86
//! (the back layer's weight is 0.55 of the front's, as in the exact composite); a 1/512 haze
//! gives fall ≈ 0 (uniform weights); 32 layers of α = 0.99 give a steep fall, capped at
//! [`MAX_FALL`] so that the smallest weight stays inside fp16's normal range.

use oit_scene::Scene;

/// Largest weight: 2^8, so 255 layers of α = 1 and colour 1 still sum below fp16's 65504.
pub const MAX_WEIGHT: f32 = 256.0;
/// Largest fall in bits: the smallest weight 256 · 2^−12 = 1/16 keeps α = 1/512 contributions
/// (1.2e-4) above fp16's smallest normal (6.1e-5).
pub const MAX_FALL: f32 = 12.0;
/// Edge of the coarse screen grid the absorbance is estimated on.
pub const GRID: usize = 64;

/// The scene-dependent inputs of the `range` weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeParams {
    /// View distance of the nearest transparent vertex (clamped to the camera's near plane).
    pub z_near: f32,
    /// View distance of the farthest transparent vertex (clamped to the far plane).
    pub z_far: f32,
    /// Bits of absorbance in front of the farthest fragment of a covered pixel, averaged over
    /// covered pixels, in [0, MAX_FALL].
    pub fall: f32,
}

impl RangeParams {
    pub fn of(scene: &Scene) -> RangeParams {
        let (z_near, z_far) = transparent_depth_interval(scene);
        RangeParams {
            z_near,
            z_far,
            fall: absorbance_fall(scene),
        }
    }

    /// CPU twin of `wboit_weight_range` in shaders/wboit_tail.wgsl.
    pub fn weight(&self, view_z: f32, alpha: f32) -> f32 {
        let span = self.z_far - self.z_near;
        let t = if span > 0.0 {
            ((view_z - self.z_near) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        alpha * MAX_WEIGHT * (-self.fall * t).exp2()
    }
}

/// The view-distance interval `[near, far]` of the scene's transparent vertices, clipped to the
/// camera's near and far planes (the whole frustum when there are none). Vertices rather than
/// the draws' bounding spheres: a screen-filling quad's sphere reaches far in front of and
/// behind the quad, which would spend most of the weight curve on empty depth.
pub fn transparent_depth_interval(scene: &Scene) -> (f32, f32) {
    let cam = &scene.camera;
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    for d in &scene.draws {
        if !scene.material_of(d).mode.is_transparent() {
            continue;
        }
        for v in &scene.vertices[d.vertex_range()] {
            let z = -cam.view.transform_point3(glam::Vec3::from(v.position)).z;
            lo = lo.min(z);
            hi = hi.max(z);
        }
    }
    let near = cam.near.max(f32::MIN_POSITIVE);
    let far = cam.far.max(near);
    if lo > hi || lo.is_nan() || hi.is_nan() {
        return (near, far);
    }
    let lo = lo.clamp(near, far);
    (lo, hi.clamp(lo, far))
}

/// The mean, over grid cells covered by transparent triangles, of the absorbance (bits) in
/// front of the cell's farthest fragment: Σ −log2(1 − α_i) · (n − 1)/n for the n fragments at
/// the cell centre (the farthest fragment's own absorbance is not in front of it; with n
/// equal layers, (n − 1)/n of the total is). Opaque occluders are ignored, α is the triangle's
/// mean vertex α times the material's, and back faces of single-sided materials do not count.
/// Clamped to [0, MAX_FALL].
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
    let (mut sum, mut covered) = (0.0f64, 0u32);
    for (b, &n) in bits.iter().zip(&count) {
        if n > 0 {
            sum += b * f64::from(n - 1) / f64::from(n);
            covered += 1;
        }
    }
    if covered == 0 {
        return 0.0;
    }
    ((sum / f64::from(covered)) as f32).clamp(0.0, MAX_FALL)
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
        let ratio = r.weight(5.5, 0.45) / r.weight(4.5, 0.45);
        assert!((ratio - 0.55).abs() < 1e-4, "{ratio}");
        assert!((r.weight(4.5, 1.0) - MAX_WEIGHT).abs() < 1e-3);
    }

    #[test]
    fn one_layer_is_flat_and_none_is_the_frustum() {
        let s = scene(&quad(0.0, 0.5), CAMERA);
        let r = RangeParams::of(&s);
        assert_eq!(r.fall, 0.0);
        assert_eq!(r.weight(5.0, 0.5), 128.0);
        let empty = scene("", CAMERA);
        let r = RangeParams::of(&empty);
        assert_eq!((r.z_near, r.z_far, r.fall), (0.1, 100.0, 0.0));
    }

    #[test]
    fn deep_opaque_stacks_are_capped() {
        let layers: Vec<String> = (0..8).map(|i| quad(i as f32 * -0.1, 0.99)).collect();
        let r = RangeParams::of(&scene(&layers.join(", "), CAMERA));
        assert_eq!(r.fall, MAX_FALL);
        // The smallest weight of an alpha = 1/512 fragment stays a normal fp16 number.
        assert!(r.weight(r.z_far, 1.0 / 512.0) >= 6.1e-5);
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
