//! CPU ordering: per-object (Babylon's transparent sort) and per-triangle (a radix sort on
//! depth keys: split into L2-sized buckets by the leading bits of the key range, then an LSD
//! radix sort of each bucket in cache).

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

/// Below this many pairs the key pass and a split run on one thread (spawning costs more).
const PARALLEL: usize = 1 << 15;
/// Runs of at most this many pairs are sorted where they lie by an LSD radix sort: with their
/// scratch they take 256 KiB, which stays in L2. Larger runs are split first. (8k was slower
/// on 1M random keys, as fewer and smaller buckets per split; 32k and 64k were no faster.)
const LOCAL: usize = 1 << 14;
/// A split aims at about 2^8 buckets (of n / 2^8 pairs, at least `LOCAL / 4`): few enough
/// write heads that a scatter through all of memory stays fast. (An earlier split on the raw
/// key range with 2^10 buckets won on uniform keys but lost 1.2–1.8× on narrow and clustered
/// ones.)
const SPLIT_BITS: u32 = 8;
/// Up to this many pairs a comparison sort is faster than counting digits.
const SMALL: usize = 1 << 6;
/// Widest digit of the in-cache LSD sort (two 2^11-entry histograms, 16 KiB on the stack).
const MAX_DIGIT: u32 = 11;
/// Buckets are handed to threads in groups of about this many pairs.
const GROUP: usize = 1 << 15;

/// Reusable scratch for sorting triangles back to front (allocations survive between frames):
/// 20 bytes a triangle, and 128 KiB per sorting thread for the in-cache passes
/// (a thread-local buffer).
#[derive(Debug, Default, Clone)]
pub struct DepthSorter {
    /// `(key << 32) | index` pairs: ordered as u64s they order by key, then by index, which
    /// is what makes every step of the sort stable.
    pairs: Vec<u64>,
    /// Where a split scatters its buckets to; the pairs and the scratch swap roles each level.
    scratch: Vec<u64>,
    /// The keys, until the sorted indices replace them.
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
    /// Method ([`DepthSorter::sort_keys`] on [`back_to_front_key`]s): one parallel pass writes
    /// the keys and finds their range; runs larger than 16k keys are split by their leading key
    /// bits into up to 256 buckets of `(key << 32) | index` pairs (chunks scattered in
    /// parallel), recursively, and the buckets, sized for L2, are radix-sorted in parallel
    /// where they lie.
    /// Splitting on the key *range* keeps buckets even for any depth range, so a narrow one
    /// costs no more than a wide one; a far outlier costs one more split.
    pub fn sort_back_to_front(&mut self, view: &Mat4, centroids: &[Vec3]) -> &[u32] {
        // z_view = row 2 of the view matrix · (p, 1).
        let row = view.row(2);
        self.sort_by(centroids, move |p: &Vec3| {
            back_to_front_key(-(row.x * p.x + row.y * p.y + row.z * p.z + row.w))
        })
    }

    /// Stable ascending argsort of `keys`: the indices `i` ordered by `keys[i]`, equal keys in
    /// index order. The sort [`DepthSorter::sort_back_to_front`] runs on its depth keys.
    pub fn sort_keys(&mut self, keys: &[u32]) -> &[u32] {
        self.sort_by(keys, |&k| k)
    }

    /// Stable argsort of `items` by `key`.
    fn sort_by<T: Sync>(&mut self, items: &[T], key: impl Fn(&T) -> u32 + Sync) -> &[u32] {
        let n = items.len();
        assert!(n <= u32::MAX as usize, "at most 2^32 keys");
        self.pairs.resize(n, 0);
        self.scratch.resize(n, 0);
        self.order.resize(n, 0);
        // The keys alone (4 bytes each, in `order` until the indices replace them): the first
        // split reads them and writes the pairs, so the largest pass over all of memory moves
        // half the bytes that pairs would.
        let chunk = chunk_len(n);
        let (mut lo, mut hi) = self
            .order
            .par_chunks_mut(chunk)
            .zip(items.par_chunks(chunk))
            .map(|(keys, items)| {
                let mut range = (u32::MAX, 0);
                for (slot, item) in keys.iter_mut().zip(items) {
                    let k = key(item);
                    *slot = k;
                    range = (range.0.min(k), range.1.max(k));
                }
                range
            })
            .reduce(|| (u32::MAX, 0), |a, b| (a.0.min(b.0), a.1.max(b.1)));
        if n == 0 {
            return &self.order;
        }
        loop {
            if n <= LOCAL || lo == hi {
                for (i, (pair, &k)) in self.pairs.iter_mut().zip(&self.order).enumerate() {
                    *pair = k.pair(i);
                }
                local_sort(&mut self.pairs, &mut self.order, lo, hi);
                break;
            }
            match split(&self.order, &mut self.scratch, lo, hi) {
                Split::Narrow(first, last) => (lo, hi) = (first, last),
                Split::Buckets(buckets) => {
                    sort_buckets(
                        &mut self.scratch,
                        &mut self.pairs,
                        &mut self.order,
                        &buckets,
                    );
                    break;
                }
            }
        }
        &self.order
    }
}

/// Pairs per parallel chunk: one chunk per thread from [`PARALLEL`] pairs on.
fn chunk_len(n: usize) -> usize {
    let chunks = if n >= PARALLEL {
        rayon::current_num_threads().clamp(1, 16)
    } else {
        1
    };
    n.div_ceil(chunks).max(1)
}

/// Key of a pair.
fn key_of(pair: u64) -> u32 {
    (pair >> 32) as u32
}

/// What a split reads: a bare key (whose index is its position) or a `(key << 32) | index`
/// pair.
trait Sortable: Copy + Sync {
    fn key(self) -> u32;
    /// The pair of this item at `index` in its input.
    fn pair(self, index: usize) -> u64;
}

impl Sortable for u32 {
    fn key(self) -> u32 {
        self
    }
    fn pair(self, index: usize) -> u64 {
        (u64::from(self) << 32) | index as u64
    }
}

impl Sortable for u64 {
    fn key(self) -> u32 {
        key_of(self)
    }
    fn pair(self, _index: usize) -> u64 {
        self
    }
}

/// The outcome of a split.
enum Split {
    /// Every key lies in this narrower range: nothing was written; split again.
    Narrow(u32, u32),
    /// The pairs were scattered into buckets, in key order.
    Buckets(Buckets),
}

/// Consecutive buckets of a split: their sizes and key ranges.
struct Buckets {
    sizes: Vec<usize>,
    ranges: Vec<(u32, u32)>,
}

/// Stable sort of the pairs in `src`, whose keys lie in `lo..=hi`; the indices go to `out`,
/// and `tmp` (as long as `src`) is scratch. A run that fits in L2 is sorted in place; a larger
/// one is split into buckets, which are sorted in turn.
fn sort_run(src: &mut [u64], tmp: &mut [u64], out: &mut [u32], lo: u32, hi: u32) {
    if src.len() <= LOCAL || lo == hi {
        return local_sort(src, out, lo, hi);
    }
    match split(src, tmp, lo, hi) {
        Split::Narrow(first, last) => sort_run(src, tmp, out, first, last),
        Split::Buckets(buckets) => sort_buckets(tmp, src, out, &buckets),
    }
}

/// Scatters `src` (keys in `lo..=hi`) as pairs into `dst` by the leading bits of their keys
/// (chunks in parallel), in up to about 2^[`SPLIT_BITS`] buckets, stably.
fn split<T: Sortable>(src: &[T], dst: &mut [u64], lo: u32, hi: u32) -> Split {
    // Fine buckets by the leading bits of `key - lo` (see `fine_range`): a quarter as many as
    // keys, from 2^8 to 2^16. Their tables have a fixed size (so indexing them needs no
    // check), the smaller one for runs of fewer than 2^17 keys, which would spend more time
    // clearing the larger one than it saves them.
    let fine_bits = (src.len().ilog2() - 2).clamp(8, 16);
    if fine_bits <= 14 {
        split_fine::<T, { 1 << 14 }>(src, dst, lo, hi, fine_bits)
    } else {
        split_fine::<T, { 1 << 16 }>(src, dst, lo, hi, fine_bits)
    }
}

/// [`split`] with `fine_bits` ≤ log2(`FINES`).
fn split_fine<T: Sortable, const FINES: usize>(
    src: &[T],
    dst: &mut [u64],
    lo: u32,
    hi: u32,
    fine_bits: u32,
) -> Split {
    let n = src.len();
    let shift = bit_len(hi - lo).saturating_sub(fine_bits);
    // At most `FINES` fine buckets; the mask (a no-op) lets indexing by them go unchecked.
    let fine = move |key: u32| ((key - lo) >> shift) as usize & (FINES - 1);
    let fines = fine(hi) + 1;
    let chunk = chunk_len(n);
    let fine_counts: Vec<Box<[u32; FINES]>> = src
        .par_chunks(chunk)
        .map(|items| {
            let mut count = zeroed::<u32, FINES>();
            for &item in items {
                count[fine(item.key())] += 1;
            }
            count
        })
        .collect();
    // Buckets of consecutive fine buckets, closed before they would exceed `target` pairs: a
    // bucket is either small enough or one fine bucket (empty ones around it are left in
    // buckets of their own), whose range is 2^fine_bits times narrower. So the buckets are
    // even whatever the key distribution (few of them, so the scatter has few write heads),
    // there are fewer than 2^16, and the recursion ends.
    let target = n.div_ceil(1 << SPLIT_BITS).max(LOCAL / 4);
    let totals: Vec<usize> = (0..fines)
        .map(|f| fine_counts.iter().map(|c| c[f] as usize).sum())
        .collect();
    if let Some(f) = totals.iter().position(|&count| count == n) {
        // Every key is in one fine bucket: narrow the range instead of copying the run.
        let (first, last) = fine_range(lo, hi, shift, f, f + 1);
        return Split::Narrow(first, last);
    }
    let mut bucket_of = zeroed::<u16, FINES>();
    let mut starts = vec![0usize];
    let mut filling = 0;
    for (f, (slot, &count)) in bucket_of[..fines].iter_mut().zip(&totals).enumerate() {
        if f > starts[starts.len() - 1] && filling + count > target {
            starts.push(f);
            filling = 0;
        }
        filling += count;
        *slot = (starts.len() - 1) as u16;
    }
    let buckets = starts.len();
    starts.push(fines);
    let counts: Vec<Vec<u32>> = fine_counts
        .iter()
        .map(|c| {
            starts
                .windows(2)
                .map(|w| c[w[0]..w[1]].iter().sum())
                .collect()
        })
        .collect();
    let bucket = |key: u32| usize::from(bucket_of[fine(key)]);
    // Each chunk's share of each bucket, bucket by bucket and, within one, chunks in input
    // order (which keeps the split stable), cut from `dst` so that chunks write in parallel.
    let mut shares: Vec<Vec<&mut [u64]>> =
        counts.iter().map(|_| Vec::with_capacity(buckets)).collect();
    let mut sizes = Vec::with_capacity(buckets);
    let mut rest = &mut dst[..];
    for b in 0..buckets {
        let mut size = 0;
        for (count, chunk_shares) in counts.iter().zip(&mut shares) {
            let (share, tail) = std::mem::take(&mut rest).split_at_mut(count[b] as usize);
            chunk_shares.push(share);
            rest = tail;
            size += count[b] as usize;
        }
        sizes.push(size);
    }
    src.par_chunks(chunk)
        .zip(shares.par_iter_mut())
        .enumerate()
        .for_each(|(c, (items, shares))| {
            // Write heads: one iterator per bucket (one check per write, not two).
            let mut heads: Vec<_> = shares.iter_mut().map(|share| share.iter_mut()).collect();
            for (i, &item) in items.iter().enumerate() {
                let head = heads[bucket(item.key())].next();
                *head.expect("a bucket's share holds its count") = item.pair(c * chunk + i);
            }
        });
    let ranges = starts
        .windows(2)
        .map(|w| fine_range(lo, hi, shift, w[0], w[1]))
        .collect();
    Split::Buckets(Buckets { sizes, ranges })
}

/// Sorts the buckets a split wrote to `pairs` (`scratch` as long), their indices to `out`,
/// in parallel groups of about [`GROUP`] pairs.
fn sort_buckets(pairs: &mut [u64], scratch: &mut [u64], out: &mut [u32], buckets: &Buckets) {
    let Buckets { sizes, ranges } = buckets;
    let mut groups = Vec::new();
    let (mut pairs, mut scratch, mut order) = (pairs, scratch, out);
    let mut b = 0;
    while b < sizes.len() {
        let first = b;
        let mut len = 0;
        while b < sizes.len() && (len == 0 || len + sizes[b] <= GROUP) {
            len += sizes[b];
            b += 1;
        }
        let (p, s, o) = (
            take_front(&mut pairs, len),
            take_front(&mut scratch, len),
            take_front(&mut order, len),
        );
        groups.push((p, s, o, first..b));
    }
    groups
        .into_par_iter()
        .for_each(|(mut pairs, mut scratch, mut order, range)| {
            for b in range {
                let size = sizes[b];
                let (p, s, o) = (
                    take_front(&mut pairs, size),
                    take_front(&mut scratch, size),
                    take_front(&mut order, size),
                );
                if size > 0 {
                    let (first, last) = ranges[b];
                    sort_run(p, s, o, first, last);
                }
            }
        });
}

/// Key bounds of the fine buckets `start..end` of a run with keys in `lo..=hi`: fine bucket f
/// holds the keys lo + [f << shift, (f + 1) << shift).
fn fine_range(lo: u32, hi: u32, shift: u32, start: usize, end: usize) -> (u32, u32) {
    let first = lo + ((start as u32) << shift);
    let last = (u64::from(lo) + ((end as u64) << shift) - 1).min(u64::from(hi));
    (first, last as u32)
}

/// A zeroed array on the heap (never on the stack, where a debug build would first make it).
fn zeroed<T: Copy + Default, const N: usize>() -> Box<[T; N]> {
    let all: Box<[T]> = vec![T::default(); N].into_boxed_slice();
    match all.try_into() {
        Ok(array) => array,
        Err(_) => unreachable!("a vector of N elements"),
    }
}

/// Splits the first `len` elements off `slice`.
fn take_front<'a, T>(slice: &mut &'a mut [T], len: usize) -> &'a mut [T] {
    let (front, back) = std::mem::take(slice).split_at_mut(len);
    *slice = back;
    front
}

/// Bits needed to write `x`.
fn bit_len(x: u32) -> u32 {
    u32::BITS - x.leading_zeros()
}

/// Stable sort of a run that fits in cache (keys in `lo..=hi`), indices to `out`: tiny runs
/// take a comparison sort of the pairs, runs of one key a copy, the rest [`radix_sort_run`] in
/// this thread's [`RADIX_SCRATCH`].
fn local_sort(pairs: &mut [u64], out: &mut [u32], lo: u32, hi: u32) {
    let n = pairs.len();
    if n <= SMALL || lo == hi {
        if lo != hi {
            // The pairs are distinct, so an unstable sort of them is a stable sort of the keys.
            pairs.sort_unstable();
        }
        for (o, &p) in out.iter_mut().zip(pairs.iter()) {
            *o = p as u32;
        }
        return;
    }
    debug_assert!(n <= LOCAL, "larger runs are split first");
    RADIX_SCRATCH.with_borrow_mut(|scratch| {
        if scratch.len() < n {
            scratch.resize(n, 0);
        }
        radix_sort_run(pairs, &mut scratch[..n], out, lo, hi);
    });
}

std::thread_local! {
    /// Each thread's second buffer for the in-cache radix passes (at most [`LOCAL`] pairs,
    /// 128 KiB). Reused by every run the thread sorts, it stays in L2; the run's share of the
    /// sorter's scratch it replaces was cold, so the first scatter into it missed on every
    /// line (0.81–0.85x the sort time on one thread without those misses, measured 2026-11-29).
    static RADIX_SCRATCH: std::cell::RefCell<Vec<u64>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Stable LSD radix sort of `pairs` (keys in `lo..=hi`, `lo < hi`), indices to `out`, with
/// `scratch` as long as `pairs`. It sorts `key − lo`, in as few equal digits of at most
/// [`MAX_DIGIT`] bits (and at most log2 of the run's length, so the histogram never outweighs
/// the run) as cover the range, and skips a digit that every key shares. Each scatter also
/// counts the next pass's digit, so only the first pass reads the run just to count.
fn radix_sort_run(pairs: &mut [u64], scratch: &mut [u64], out: &mut [u32], lo: u32, hi: u32) {
    let n = pairs.len();
    let bits = bit_len(hi - lo);
    let widest = n.ilog2().clamp(4, MAX_DIGIT);
    let passes = bits.div_ceil(widest);
    // At most MAX_DIGIT: `passes` digits of `width` bits cover `bits`.
    let width = bits.div_ceil(passes.max(1));
    let mask = (1u32 << width) - 1;
    // The last mask is `mask` again, spelled so that indexing the histograms needs no check.
    let digit = move |pair: u64, pass: u32| {
        (((key_of(pair) - lo) >> (pass * width)) & mask) as usize & ((1 << MAX_DIGIT) - 1)
    };
    let mut counts = [[0u32; 1 << MAX_DIGIT]; 2];
    let [next, following] = &mut counts;
    let (mut next, mut following) = (next, following);
    // Whether `next` already holds this pass's counts (made while the last pass scattered).
    let mut counted = false;
    let (mut src, mut dst) = (pairs, scratch);
    for pass in 0..passes {
        if !counted {
            next[..1 << width].fill(0);
            for &p in src.iter() {
                next[digit(p, pass)] += 1;
            }
        }
        counted = false;
        if next[..1 << width].contains(&(n as u32)) {
            // Every key has this digit: the pass would not move anything.
            continue;
        }
        let mut sum = 0;
        for slot in &mut next[..1 << width] {
            let count = *slot;
            *slot = sum;
            sum += count;
        }
        if pass + 1 == passes {
            // Touch the output in order first, so the hardware prefetcher brings its lines in
            // and the scattered writes below hit cache (0.80–0.97x the sort time on one thread:
            // written in random order, every cold line stalled the scatter).
            out.fill(0);
            for &p in src.iter() {
                let slot = &mut next[digit(p, pass)];
                out[*slot as usize] = p as u32;
                *slot += 1;
            }
            return;
        }
        following[..1 << width].fill(0);
        for &p in src.iter() {
            let slot = &mut next[digit(p, pass)];
            dst[*slot as usize] = p;
            *slot += 1;
            following[digit(p, pass + 1)] += 1;
        }
        std::mem::swap(&mut next, &mut following);
        counted = true;
        std::mem::swap(&mut src, &mut dst);
    }
    for (o, &p) in out.iter_mut().zip(src.iter()) {
        *o = p as u32;
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

    /// Sizes on both sides of every threshold: comparison sort, in-cache radix sort, split,
    /// parallel chunks, and runs large enough that buckets are split again.
    fn sizes() -> impl Strategy<Value = usize> {
        prop_oneof![
            0..SMALL + 50,
            SMALL..4000,
            LOCAL - 20..LOCAL + 500,
            PARALLEL - 20..PARALLEL + 500,
            GROUP * 3..GROUP * 4,
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

    /// Content whose key range a few outliers stretch: the bulk lands in one bucket of the
    /// first split and must be split again (twice for the tightest cluster), in parallel
    /// chunks, with ties and a bucket at the top of the range.
    #[test]
    fn clustered_keys_with_outliers_are_split_again_and_stay_stable() {
        let mut next = random(11);
        for (spread, outliers) in [(1u64 << 20, 3), (1 << 12, 1), (5, 2), (1 << 30, 0)] {
            let keys: Vec<u32> = (0..200_000)
                .map(|i| {
                    if i % 50_000 < outliers {
                        [0, u32::MAX, 1 << 31][i % 3]
                    } else {
                        0x3c00_0000 + (next() % spread) as u32
                    }
                })
                .collect();
            let mut sorter = DepthSorter::new();
            assert_eq!(
                sorter.sort_keys(&keys),
                &stable_argsort(&keys)[..],
                "spread {spread}, {outliers} outliers"
            );
        }
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
