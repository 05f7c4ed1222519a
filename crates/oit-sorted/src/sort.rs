//! CPU ordering: per-object (Babylon's transparent sort) and per-triangle (a radix sort on
//! depth keys).

use glam::{Mat4, Vec3};
use oit_scene::Scene;
use rayon::prelude::*;

/// Transparent draws (indices into `scene.draws`) in the order Babylon renders them
/// ([`Scene::babylon_object_order`]: render group, alpha index, far first, stable).
pub fn object_order(scene: &Scene) -> Vec<usize> {
    scene.babylon_object_order()
}

/// Order-preserving map from f32 to u32: `a < b` ⇔ `key(a) < key(b)` for all non-NaN floats
/// (−0 sorts just below +0).
pub fn ordered_bits(x: f32) -> u32 {
    let b = x.to_bits();
    // Negative: flip every bit; positive: set the sign bit (branch-free).
    b ^ (((b as i32) >> 31) as u32 | 0x8000_0000)
}

/// Sort key that puts the farthest triangle first: view-space depth `d = −z_view` (distance in
/// front of the eye along the view direction), descending.
pub fn back_to_front_key(view_depth: f32) -> u32 {
    !ordered_bits(view_depth)
}

/// Below this many keys they are computed on one thread (spawning costs more).
const PARALLEL: usize = 1 << 15;
/// Below this many keys a comparison sort of the packed `(key, index)` pairs is faster.
const SMALL: usize = 1 << 8;
/// Radix digits of the 32-bit key for large inputs, least significant first, as
/// `(shift, bits)`: two bytes, then the top 16 bits in one pass. Depth keys are float bits,
/// whose top 16 bits (sign, exponent, 7 leading mantissa bits) take few distinct values in a
/// scene, so that pass writes to few buckets, as the byte passes do. 11-bit digits (2048
/// buckets: 16 KiB of scattered write heads instead of 2 KiB) were 1.5–2× slower per pass on
/// 1M keys.
const LARGE_DIGITS: [(u32, u32); 3] = [(0, 8), (8, 8), (16, 16)];
/// Digits below [`LARGE`] keys, where the pairs fit in L2 and clearing and scanning a
/// 2^16-entry histogram would cost more than the wide digits do.
const SMALL_DIGITS: [(u32, u32); 3] = [(0, 11), (11, 11), (22, 10)];
/// From this many keys on, [`LARGE_DIGITS`] (the two sets were equally fast at 40k–70k).
const LARGE: usize = 1 << 16;
/// Keys computed per block before their digits are counted: the key loop vectorizes only
/// without the counting in it (fused, it was 1.5× slower), and the block is still in L1.
const BLOCK: usize = 1024;

fn digits(n: usize) -> [(u32, u32); 3] {
    if n >= LARGE {
        LARGE_DIGITS
    } else {
        SMALL_DIGITS
    }
}

/// Reusable scratch for sorting triangles back to front (allocations survive between frames).
#[derive(Debug, Default, Clone)]
pub struct DepthSorter {
    /// Two buffers of `n` u64s, ping-ponged by the passes. The keys (as u32s) start in the
    /// second; `(key << 32) | index` pairs go between passes; the last pass writes the
    /// indices (as u32s) into whichever buffer it does not read. Sharing them keeps the
    /// working set at 16 bytes per triangle.
    bufs: [Vec<u64>; 2],
    /// One set of digit histograms per chunk of keys ([`hist_len`] each); the first becomes
    /// the total, then the running bucket offsets.
    hists: Vec<u32>,
}

impl DepthSorter {
    pub fn new() -> Self {
        Self::default()
    }

    /// Sorts triangles (given by their centroids, world space) back to front by the view depth
    /// of the centroid under `view` (a right-handed view matrix, camera looking down −z). Returns
    /// the triangle indices, farthest first. Stable: equal depths keep their input order.
    ///
    /// Method: one pass computes the keys ([`back_to_front_key`]) and the histograms of all
    /// three radix digits (in parallel chunks above 32k triangles), then an LSD radix sort in
    /// up to three scatter passes (8, 8 and 16-bit digits from 65 536 triangles, 11, 11 and
    /// 10 below). The first pass reads the keys and makes `(key << 32) | index` pairs, the last
    /// writes the indices out, and passes whose digit is the same for every key are skipped.
    /// Below 256 triangles, a comparison sort of the pairs.
    pub fn sort_back_to_front(&mut self, view: &Mat4, centroids: &[Vec3]) -> &[u32] {
        let n = centroids.len();
        assert!(n <= u32::MAX as usize, "at most 2^32 triangles");
        // z_view = row 2 of the view matrix · (p, 1).
        let row = view.row(2);
        let key =
            move |p: &Vec3| back_to_front_key(-(row.x * p.x + row.y * p.y + row.z * p.z + row.w));
        self.resize(n);
        let keys = &mut bytemuck::cast_slice_mut::<u64, u32>(&mut self.bufs[1])[..n];
        if n < SMALL {
            for (k, p) in keys.iter_mut().zip(centroids) {
                *k = key(p);
            }
            return self.small_sort(n);
        }
        let chunks = if n >= PARALLEL {
            rayon::current_num_threads().clamp(1, 16)
        } else {
            1
        };
        let chunk = n.div_ceil(chunks);
        let chunks = n.div_ceil(chunk);
        let digits = digits(n);
        let len = hist_len(digits);
        self.hists.clear();
        self.hists.resize(chunks * len, 0);
        let fill = |((keys, points), hist): ((&mut [u32], &[Vec3]), &mut [u32])| {
            let mut counts = Counts::new(hist, digits);
            for (keys, points) in keys.chunks_mut(BLOCK).zip(points.chunks(BLOCK)) {
                for (k, p) in keys.iter_mut().zip(points) {
                    *k = key(p);
                }
                counts.add(keys);
            }
        };
        if chunks > 1 {
            keys.par_chunks_mut(chunk)
                .zip(centroids.par_chunks(chunk))
                .zip(self.hists.par_chunks_mut(len))
                .for_each(fill);
            let (total, rest) = self.hists.split_at_mut(len);
            for h in rest.chunks(len) {
                total.iter_mut().zip(h).for_each(|(t, c)| *t += c);
            }
        } else {
            fill(((keys, centroids), &mut self.hists[..]));
        }
        self.radix_sort(n, digits)
    }

    /// Stable ascending argsort of `keys`: the indices `i` ordered by `keys[i]`, equal keys in
    /// index order. The sort [`DepthSorter::sort_back_to_front`] runs on its depth keys.
    pub fn sort_keys(&mut self, keys: &[u32]) -> &[u32] {
        let n = keys.len();
        assert!(n <= u32::MAX as usize, "at most 2^32 keys");
        self.resize(n);
        bytemuck::cast_slice_mut::<u64, u32>(&mut self.bufs[1])[..n].copy_from_slice(keys);
        if n < SMALL {
            return self.small_sort(n);
        }
        let digits = digits(n);
        self.hists.clear();
        self.hists.resize(hist_len(digits), 0);
        Counts::new(&mut self.hists, digits).add(keys);
        self.radix_sort(n, digits)
    }

    /// Sizes both buffers for `n` keys (they only grow).
    fn resize(&mut self, n: usize) {
        for b in &mut self.bufs {
            b.resize(n, 0);
        }
    }

    /// Argsort of a few keys: the `(key << 32) | index` values are distinct and order exactly
    /// as (key, index), so an unstable sort of them is a stable sort of the keys.
    fn small_sort(&mut self, n: usize) -> &[u32] {
        let [pairs, keys] = &mut self.bufs;
        let keys = &mut bytemuck::cast_slice_mut::<u64, u32>(keys)[..n];
        for ((i, p), &k) in pairs.iter_mut().enumerate().zip(keys.iter()) {
            *p = (u64::from(k) << 32) | i as u64;
        }
        pairs.sort_unstable();
        for (o, &p) in keys.iter_mut().zip(pairs.iter()) {
            *o = p as u32;
        }
        keys
    }

    /// LSD radix argsort of the `n` keys in the second buffer, given the histograms of their
    /// `digits` at the start of `hists`.
    fn radix_sort(&mut self, n: usize, digits: [(u32, u32); 3]) -> &[u32] {
        // Turn the histograms into bucket starts. A digit that every key shares would make
        // its pass the identity permutation, so that pass is left out.
        let mut passes = Vec::with_capacity(3);
        let mut rest = &mut self.hists[..];
        for (shift, bits) in digits {
            let (hist, tail) = rest.split_at_mut(1 << bits);
            rest = tail;
            if hist.contains(&(n as u32)) {
                continue;
            }
            let mut sum = 0;
            for h in hist.iter_mut() {
                let c = *h;
                *h = sum;
                sum += c;
            }
            passes.push((shift, ((1u64 << bits) - 1) as u32, hist));
        }
        // The buffer the next pass reads: the keys are in buffer 1.
        let mut from = 1;
        let count = passes.len();
        for (p, (shift, mask, next)) in passes.into_iter().enumerate() {
            let digit = |k: u32| ((k >> shift) & mask) as usize;
            let [a, b] = &mut self.bufs;
            let (src, dst) = if from == 1 {
                (&b[..n], &mut a[..n])
            } else {
                (&a[..n], &mut b[..n])
            };
            match (p == 0, p + 1 == count) {
                (true, true) => {
                    let order = &mut bytemuck::cast_slice_mut::<u64, u32>(dst)[..n];
                    for (i, &k) in bytemuck::cast_slice::<u64, u32>(src)[..n]
                        .iter()
                        .enumerate()
                    {
                        let slot = &mut next[digit(k)];
                        order[*slot as usize] = i as u32;
                        *slot += 1;
                    }
                }
                (true, false) => {
                    for (i, &k) in bytemuck::cast_slice::<u64, u32>(src)[..n]
                        .iter()
                        .enumerate()
                    {
                        let slot = &mut next[digit(k)];
                        dst[*slot as usize] = (u64::from(k) << 32) | i as u64;
                        *slot += 1;
                    }
                }
                (false, true) => {
                    let order = &mut bytemuck::cast_slice_mut::<u64, u32>(dst)[..n];
                    for &x in src {
                        let slot = &mut next[digit((x >> 32) as u32)];
                        order[*slot as usize] = x as u32;
                        *slot += 1;
                    }
                }
                (false, false) => {
                    for &x in src {
                        let slot = &mut next[digit((x >> 32) as u32)];
                        dst[*slot as usize] = x;
                        *slot += 1;
                    }
                }
            }
            from = 1 - from;
        }
        let out = &mut bytemuck::cast_slice_mut::<u64, u32>(&mut self.bufs[from])[..n];
        if count == 0 {
            // Every key is equal: index order.
            for (i, o) in out.iter_mut().enumerate() {
                *o = i as u32;
            }
        }
        out
    }
}

/// Entries of the three histograms of `digits`.
fn hist_len(digits: [(u32, u32); 3]) -> usize {
    digits.iter().map(|&(_, bits)| 1usize << bits).sum()
}

/// The three digit histograms of a chunk of keys, in one [`hist_len`] slice.
struct Counts<'h> {
    hists: [&'h mut [u32]; 3],
    shifts: [u32; 3],
    masks: [u32; 3],
}

impl<'h> Counts<'h> {
    fn new(hist: &'h mut [u32], digits: [(u32, u32); 3]) -> Self {
        let (low, rest) = hist.split_at_mut(1 << digits[0].1);
        let (mid, rest) = rest.split_at_mut(1 << digits[1].1);
        let high = &mut rest[..1 << digits[2].1];
        Counts {
            hists: [low, mid, high],
            shifts: digits.map(|d| d.0),
            masks: digits.map(|d| ((1u64 << d.1) - 1) as u32),
        }
    }

    fn add(&mut self, keys: &[u32]) {
        let [low, mid, high] = &mut self.hists;
        let [s0, s1, s2] = self.shifts;
        let [m0, m1, m2] = self.masks;
        for &k in keys {
            low[((k >> s0) & m0) as usize] += 1;
            mid[((k >> s1) & m1) as usize] += 1;
            high[((k >> s2) & m2) as usize] += 1;
        }
    }
}

/// Stable radix sort of `values` by `keys` (ascending; equal keys keep their order): the sort
/// [`DepthSorter::sort_back_to_front`] runs, for arbitrary key/value pairs.
pub fn radix_sort_pairs(keys: &mut [u32], values: &mut [u32]) {
    assert_eq!(keys.len(), values.len(), "one value per key");
    let mut sorter = DepthSorter::new();
    let order = sorter.sort_keys(keys);
    let sorted: Vec<(u32, u32)> = order
        .iter()
        .map(|&i| (keys[i as usize], values[i as usize]))
        .collect();
    for ((k, v), (sk, sv)) in keys.iter_mut().zip(values.iter_mut()).zip(sorted) {
        *k = sk;
        *v = sv;
    }
}

/// Triangle centroids `(a + b + c) / 3` of a non-indexed triangle list.
pub fn centroid(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Vec3 {
    (Vec3::from(a) + Vec3::from(b) + Vec3::from(c)) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Stable comparison argsort (`sort_by_key` is stable): what the radix sort must match.
    fn stable_argsort(keys: &[u32]) -> Vec<u32> {
        let mut order: Vec<u32> = (0..keys.len() as u32).collect();
        order.sort_by_key(|&i| keys[i as usize]);
        order
    }

    /// SplitMix64 from `seed`.
    fn random(seed: u64) -> impl FnMut() -> u64 {
        let mut state = seed;
        move || {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        }
    }

    /// Masks that make digits constant (their passes are skipped) and, when narrow, give
    /// many equal keys (stability).
    fn masks() -> impl Strategy<Value = u32> {
        prop_oneof![
            Just(u32::MAX),
            Just(0xffff_0000),
            Just(0x0000_ffff),
            Just(0x0000_ff00),
            Just(0xff00_00ff),
            Just(0x8000_0007),
            Just(0),
        ]
    }

    /// Sizes on both sides of every threshold: comparison sort, 11-bit digits, parallel
    /// keys, 8/8/16-bit digits.
    fn sizes() -> impl Strategy<Value = usize> {
        prop_oneof![
            0..SMALL + 50,
            SMALL..4000,
            PARALLEL - 20..PARALLEL + 500,
            LARGE - 20..LARGE + 500,
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

        #[test]
        fn sort_keys_is_a_stable_sort(
            n in sizes(),
            seed in any::<u64>(),
            mask in masks(),
            base in any::<u32>(),
        ) {
            let mut next = random(seed);
            let keys: Vec<u32> = (0..n).map(|_| (next() as u32 & mask) | (base & !mask)).collect();
            let want = stable_argsort(&keys);
            let mut sorter = DepthSorter::new();
            prop_assert_eq!(sorter.sort_keys(&keys), &want[..]);
            // The scratch is reused: a smaller and then the same input again.
            let few = &keys[..n / 3];
            prop_assert_eq!(sorter.sort_keys(few), &stable_argsort(few)[..]);
            prop_assert_eq!(sorter.sort_keys(&keys), &want[..]);
            // radix_sort_pairs is the same sort.
            let (mut k, mut v) = (keys.clone(), (0..n as u32).map(|i| i ^ 0x5555).collect::<Vec<_>>());
            radix_sort_pairs(&mut k, &mut v);
            let want_pairs: Vec<(u32, u32)> =
                want.iter().map(|&i| (keys[i as usize], i ^ 0x5555)).collect();
            prop_assert_eq!(k.into_iter().zip(v).collect::<Vec<_>>(), want_pairs);
        }

        #[test]
        fn back_to_front_is_a_stable_sort_by_view_depth(
            n in sizes(),
            seed in any::<u64>(),
            levels in prop_oneof![Just(3u64), Just(1000), Just(1 << 24)],
            specials in any::<bool>(),
        ) {
            let view = glam::camera::rh::view::look_at_mat4(
                Vec3::new(3.0, 2.0, 10.0),
                Vec3::ZERO,
                Vec3::Y,
            );
            // Coordinates on `levels` steps in [-50, 50] (few levels: many equal depths),
            // points behind the eye included, and optionally a sprinkle of NaN and ±∞.
            let mut next = random(seed);
            let mut coord = || {
                let r = next();
                if specials && r.is_multiple_of(97) {
                    [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -0.0][(r >> 8) as usize % 4]
                } else {
                    ((r >> 16) % levels) as f32 / levels as f32 * 100.0 - 50.0
                }
            };
            let points: Vec<Vec3> = (0..n).map(|_| Vec3::new(coord(), coord(), coord())).collect();
            let row = view.row(2);
            let keys: Vec<u32> = points
                .iter()
                .map(|p| back_to_front_key(-(row.x * p.x + row.y * p.y + row.z * p.z + row.w)))
                .collect();
            let want = stable_argsort(&keys);
            let mut sorter = DepthSorter::new();
            prop_assert_eq!(sorter.sort_back_to_front(&view, &points), &want[..]);
            let few = &points[..n / 3];
            prop_assert_eq!(sorter.sort_back_to_front(&view, few), &stable_argsort(&keys[..n / 3])[..]);
            prop_assert_eq!(sorter.sort_back_to_front(&view, &points), &want[..]);
        }
    }

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
