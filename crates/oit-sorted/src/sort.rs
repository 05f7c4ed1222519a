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
    packed: Vec<u64>,
    tmp: Vec<u64>,
    order: Vec<u32>,
}

impl DepthSorter {
    pub fn new() -> Self {
        Self::default()
    }

    /// Sorts triangles (given by their centroids, world space) back to front by the view depth
    /// of the centroid under `view` (a right-handed view matrix, camera looking down −z). Returns
    /// the triangle indices, farthest first. Stable: equal depths keep their input order.
    ///
    /// Method: one pass packs `(key << 32) | index` into u64s ([`back_to_front_key`], in
    /// parallel above 32k triangles), then an LSD radix sort on the 32 key bits in three passes of
    /// 11, 11 and 10 bits (one scatter stream per pass; passes where every key has the same digit
    /// are skipped).
    pub fn sort_back_to_front(&mut self, view: &Mat4, centroids: &[Vec3]) -> &[u32] {
        let n = centroids.len();
        assert!(n <= u32::MAX as usize, "at most 2^32 triangles");
        // z_view = row 2 of the view matrix · (p, 1).
        let row = view.row(2);
        let pack = |(i, p): (usize, &Vec3)| {
            let key = back_to_front_key(-(row.x * p.x + row.y * p.y + row.z * p.z + row.w));
            (u64::from(key) << 32) | i as u64
        };
        self.packed.clear();
        if n >= PARALLEL_KEYS {
            centroids
                .par_iter()
                .enumerate()
                .map(pack)
                .collect_into_vec(&mut self.packed);
        } else {
            self.packed.extend(centroids.iter().enumerate().map(pack));
        }
        radix_sort_high32(&mut self.packed, &mut self.tmp);
        self.order.clear();
        self.order.extend(self.packed.iter().map(|&p| p as u32));
        &self.order
    }
}

/// Stable LSD radix sort of `values` by `keys` (ascending): the same sort
/// [`DepthSorter::sort_back_to_front`] runs, for arbitrary key/value pairs.
pub fn radix_sort_pairs(keys: &mut [u32], values: &mut [u32]) {
    assert_eq!(keys.len(), values.len(), "one value per key");
    let mut packed: Vec<u64> = keys
        .iter()
        .zip(values.iter())
        .map(|(&k, &v)| (u64::from(k) << 32) | u64::from(v))
        .collect();
    radix_sort_high32(&mut packed, &mut Vec::new());
    for ((k, v), p) in keys.iter_mut().zip(values.iter_mut()).zip(&packed) {
        *k = (p >> 32) as u32;
        *v = *p as u32;
    }
}

/// Digit widths of the three passes over the key (bits 32..64 of each element).
const DIGITS: [(u32, u32); 3] = [(32, 11), (43, 11), (54, 10)];

/// Stable LSD radix sort of u64s by their high 32 bits.
fn radix_sort_high32(data: &mut Vec<u64>, tmp: &mut Vec<u64>) {
    let n = data.len();
    let mut hist = vec![[0usize; 2048]; 3];
    for &x in data.iter() {
        for (h, &(shift, bits)) in hist.iter_mut().zip(&DIGITS) {
            h[((x >> shift) & ((1 << bits) - 1)) as usize] += 1;
        }
    }
    tmp.resize(n, 0);
    for (h, &(shift, bits)) in hist.iter().zip(&DIGITS) {
        // Every key has the same digit here: the pass would be the identity permutation.
        if h.contains(&n) {
            continue;
        }
        let mut offset = [0usize; 2048];
        let mut sum = 0;
        for (o, &c) in offset.iter_mut().zip(h) {
            *o = sum;
            sum += c;
        }
        let mask = (1u64 << bits) - 1;
        for &x in data.iter() {
            let d = ((x >> shift) & mask) as usize;
            tmp[offset[d]] = x;
            offset[d] += 1;
        }
        std::mem::swap(data, tmp);
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
        radix_sort_pairs(&mut keys, &mut values);
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
