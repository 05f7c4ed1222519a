//! CPU ordering: per-object (Babylon's transparent sort) and per-triangle (a radix sort on
//! depth keys).

use glam::{Mat4, Vec3};
use oit_scene::Scene;
use rayon::prelude::*;

/// Transparent draws (indices into `scene.draws`) in the order Babylon renders them: render
/// group ascending, then `alpha_index` ascending, then distance from the eye to the bounding
/// sphere centre descending (far first). The sort is stable: draws that tie on all three keep
/// their draw order, so the later-drawn one lands on top, which is the reference's tie-break for
/// coplanar fragments in natural draw order.
pub fn object_order(scene: &Scene) -> Vec<usize> {
    let eye = scene.camera.eye;
    let mut order: Vec<(usize, u32, i32, f32)> = scene
        .draws
        .iter()
        .enumerate()
        .filter(|(_, d)| scene.material_of(d).mode.is_transparent())
        .map(|(i, d)| {
            (
                i,
                d.render_group,
                d.alpha_index,
                d.bounds_center.distance(eye),
            )
        })
        .collect();
    order.sort_by(|a, b| a.1.cmp(&b.1).then(a.2.cmp(&b.2)).then(b.3.total_cmp(&a.3)));
    order.into_iter().map(|(i, ..)| i).collect()
}

/// Order-preserving map from f32 to u32: `a < b` ⇔ `key(a) < key(b)` for all non-NaN floats
/// (−0 sorts just below +0).
pub fn ordered_bits(x: f32) -> u32 {
    let b = x.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// Sort key that puts the farthest triangle first: view-space depth `d = −z_view` (distance in
/// front of the eye along the view direction), descending.
pub fn back_to_front_key(view_depth: f32) -> u32 {
    !ordered_bits(view_depth)
}

/// Below this many triangles the keys are computed on one thread (spawning costs more).
const PARALLEL_KEYS: usize = 1 << 15;

/// Reusable scratch for sorting triangles back to front (allocations survive between frames).
#[derive(Debug, Default, Clone)]
pub struct DepthSorter {
    keys: Vec<u32>,
    order: Vec<u32>,
    tmp_keys: Vec<u32>,
    tmp_order: Vec<u32>,
}

impl DepthSorter {
    pub fn new() -> Self {
        Self::default()
    }

    /// Sorts triangles (given by their centroids, world space) back to front by the view depth
    /// of the centroid under `view` (a right-handed view matrix, camera looking down −z). Returns
    /// the triangle indices, farthest first. Stable: equal depths keep their input order.
    ///
    /// Method: one pass computes u32 keys ([`back_to_front_key`], in parallel above 32k
    /// triangles), then an LSD radix sort of (key, index) pairs, 8 bits per pass, skipping the
    /// passes where every key has the same byte.
    pub fn sort_back_to_front(&mut self, view: &Mat4, centroids: &[Vec3]) -> &[u32] {
        let n = centroids.len();
        // z_view = row 2 of the view matrix · (p, 1).
        let row = view.row(2);
        let key = |p: &Vec3| back_to_front_key(-(row.x * p.x + row.y * p.y + row.z * p.z + row.w));
        self.keys.clear();
        if n >= PARALLEL_KEYS {
            centroids
                .par_iter()
                .map(key)
                .collect_into_vec(&mut self.keys);
        } else {
            self.keys.extend(centroids.iter().map(key));
        }
        self.order.clear();
        self.order.extend(0..n as u32);
        radix_sort_pairs(
            &mut self.keys,
            &mut self.order,
            &mut self.tmp_keys,
            &mut self.tmp_order,
        );
        &self.order
    }
}

/// Stable LSD radix sort of `values` by `keys` (ascending), 8 bits per pass. `tmp_*` are scratch.
pub fn radix_sort_pairs(
    keys: &mut Vec<u32>,
    values: &mut Vec<u32>,
    tmp_keys: &mut Vec<u32>,
    tmp_values: &mut Vec<u32>,
) {
    let n = keys.len();
    assert_eq!(n, values.len(), "one value per key");
    let mut hist = [[0usize; 256]; 4];
    for &k in keys.iter() {
        for (b, h) in hist.iter_mut().enumerate() {
            h[((k >> (8 * b)) & 0xff) as usize] += 1;
        }
    }
    tmp_keys.resize(n, 0);
    tmp_values.resize(n, 0);
    for (b, h) in hist.iter().enumerate() {
        // Every key has the same byte here: the pass would be the identity permutation.
        if h.contains(&n) {
            continue;
        }
        let mut offset = [0usize; 256];
        let mut sum = 0;
        for (o, &c) in offset.iter_mut().zip(h) {
            *o = sum;
            sum += c;
        }
        let shift = 8 * b;
        for (&k, &v) in keys.iter().zip(values.iter()) {
            let bucket = ((k >> shift) & 0xff) as usize;
            let dst = offset[bucket];
            offset[bucket] += 1;
            tmp_keys[dst] = k;
            tmp_values[dst] = v;
        }
        std::mem::swap(keys, tmp_keys);
        std::mem::swap(values, tmp_values);
    }
}

/// Triangle centroids `(a + b + c) / 3` of a non-indexed triangle list.
pub fn centroid(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Vec3 {
    (Vec3::from(a) + Vec3::from(b) + Vec3::from(c)) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordered_bits_preserves_order() {
        let xs = [
            f32::NEG_INFINITY,
            -1e30,
            -2.0,
            -1.0,
            -1e-40,
            -0.0,
            0.0,
            1e-40,
            0.5,
            1.0,
            3.0,
            1e30,
            f32::INFINITY,
        ];
        for w in xs.windows(2) {
            assert!(ordered_bits(w[0]) < ordered_bits(w[1]), "{} {}", w[0], w[1]);
            assert!(back_to_front_key(w[0]) > back_to_front_key(w[1]));
        }
    }

    #[test]
    fn radix_sort_matches_a_stable_comparison_sort() {
        // Deterministic pseudo-random keys with many duplicates (tests stability) and some
        // keys differing only in high bytes (tests pass skipping).
        let mut x = 0x9e37_79b9_u32;
        let mut keys: Vec<u32> = (0..5000)
            .map(|i| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                if i % 3 == 0 { (x % 7) << 24 } else { x % 1000 }
            })
            .collect();
        let mut expected: Vec<(u32, u32)> = keys.iter().copied().zip(0..).collect();
        expected.sort_by_key(|p| p.0);
        let mut values: Vec<u32> = (0..keys.len() as u32).collect();
        radix_sort_pairs(&mut keys, &mut values, &mut Vec::new(), &mut Vec::new());
        let got: Vec<(u32, u32)> = keys.into_iter().zip(values).collect();
        assert_eq!(got, expected);
    }

    #[test]
    fn sorts_far_to_near_and_keeps_ties_in_order() {
        let view =
            glam::camera::rh::view::look_at_mat4(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
        // Depths in front of the eye: 5, 7, 3, 7 (tie), 5.5 (sideways offsets do not matter).
        let c = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, -2.0),
            Vec3::new(0.0, 3.0, 2.0),
            Vec3::new(-4.0, 0.0, -2.0),
            Vec3::new(0.0, 0.0, -0.5),
        ];
        let mut s = DepthSorter::new();
        assert_eq!(s.sort_back_to_front(&view, &c), &[1, 3, 4, 0, 2]);
        // Large input takes the parallel key path and gives the same order as a comparison sort.
        let many: Vec<Vec3> = (0..70_000)
            .map(|i| Vec3::new(0.0, 0.0, ((i * 7919) % 1000) as f32 * 0.01))
            .collect();
        let got = s.sort_back_to_front(&view, &many).to_vec();
        let mut want: Vec<u32> = (0..many.len() as u32).collect();
        want.sort_by(|&a, &b| many[a as usize].z.total_cmp(&many[b as usize].z));
        assert_eq!(got, want);
    }
}
