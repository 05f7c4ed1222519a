//! Threshold patterns computed on the CPU: Bayer ordered dither, void-and-cluster blue noise,
//! and the per-frame shifts that `spp=N` and animation frames use (spatiotemporal blue noise is
//! generated in [`crate::stbn`]).
//!
//! Sub-frames: sample `k` of animation frame `t` (`Scene::frame`) with `spp` samples per frame
//! is sub-frame `t·spp + k` (wrapping in u32), so frame 0 is what a still image always was and
//! every later frame continues the same sequence with fresh thresholds.
//!
//! A threshold array holds `side²` values in `(0, 1)`; a fragment with coverage α survives at a
//! pixel when `α > threshold`. Ranks `r` in `0..side²` become thresholds `(r + ½) / side²`, so
//! exactly `⌈α·side² − ½⌉` of every tile's pixels pass: the pattern is unbiased per tile.

use crate::config::{Pattern, Seed};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Side of the generated blue-noise tile. 64² = 4096 threshold levels, far finer than the
/// alpha steps of any bundled scene, and small enough to generate in milliseconds.
pub const BLUE_NOISE_SIDE: usize = 64;
/// Gaussian σ of the void-and-cluster energy filter (Ulichney 1993 recommends 1.5).
pub const BLUE_NOISE_SIGMA: f64 = 1.5;
/// Seed of the initial random binary pattern; fixed so the tile is the same on every machine.
pub const BLUE_NOISE_SEED: u64 = 0x006f_6974_2d6c_6162; // "oit-lab"

/// `1/φ` (golden ratio conjugate): the per-frame Cranley–Patterson value rotation.
pub const GOLDEN: f64 = 0.618_033_988_749_894_9;
/// The R2 sequence's generators (`1/g`, `1/g²` with g the plastic number): per-frame 2D tile
/// shifts that cover the tile evenly for any number of frames (Roberts 2018).
pub const R2: [f64; 2] = [0.754_877_666_246_692_8, 0.569_840_290_998_053_3];

/// The Bayer ordered-dither matrix of side `n` (a power of two, ≥ 1), row-major ranks
/// `0..n²`, built by the recursion `B_2n = [[4B, 4B+2], [4B+3, 4B+1]]`. The `bayerN`
/// patterns use n = 4 to 256 (65 536 levels, a 256 KiB table of f32 thresholds).
pub fn bayer(n: usize) -> Vec<u32> {
    assert!(
        n.is_power_of_two(),
        "Bayer side must be a power of two, got {n}"
    );
    let mut side = 1;
    let mut m = vec![0u32];
    while side < n {
        let next = side * 2;
        let mut out = vec![0u32; next * next];
        for y in 0..side {
            for x in 0..side {
                let b = 4 * m[y * side + x];
                out[y * next + x] = b;
                out[y * next + x + side] = b + 2;
                out[(y + side) * next + x] = b + 3;
                out[(y + side) * next + x + side] = b + 1;
            }
        }
        m = out;
        side = next;
    }
    m
}

/// Thresholds `(rank + ½)/count` of a rank array.
pub fn thresholds(ranks: &[u32]) -> Vec<f32> {
    let n = ranks.len() as f64;
    ranks
        .iter()
        .map(|&r| ((f64::from(r) + 0.5) / n) as f32)
        .collect()
}

/// SplitMix64: the deterministic generator for the initial void-and-cluster pattern.
fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Toroidal Gaussian energy field of a binary pattern, updated incrementally.
struct Energy {
    side: usize,
    /// `kernel[dy·side + dx]` = exp(−(dx² + dy²)/(2σ²)) with toroidal (shortest) offsets.
    kernel: Vec<f64>,
    field: Vec<f64>,
}

impl Energy {
    fn new(side: usize, sigma: f64) -> Self {
        let wrap = |d: usize| {
            let d = d.min(side - d) as f64;
            d * d
        };
        let mut kernel = vec![0.0; side * side];
        for dy in 0..side {
            for dx in 0..side {
                kernel[dy * side + dx] = (-(wrap(dx) + wrap(dy)) / (2.0 * sigma * sigma)).exp();
            }
        }
        Energy {
            side,
            kernel,
            field: vec![0.0; side * side],
        }
    }

    /// Adds (`sign` = 1) or removes (`sign` = −1) the splat of a one at `p`.
    fn splat(&mut self, p: usize, sign: f64) {
        let s = self.side;
        let (px, py) = (p % s, p / s);
        for y in 0..s {
            let dy = (y + s - py) % s;
            let krow = &self.kernel[dy * s..(dy + 1) * s];
            let frow = &mut self.field[y * s..(y + 1) * s];
            // dx runs (s − px) … s−1, 0 … (s − px − 1) across the row.
            let (a, b) = frow.split_at_mut(px);
            for (f, k) in b.iter_mut().zip(krow) {
                *f += sign * k;
            }
            for (f, k) in a.iter_mut().zip(&krow[s - px..]) {
                *f += sign * k;
            }
        }
    }

    /// The one with the highest energy (tightest cluster); first in scan order on ties.
    fn tightest_cluster(&self, pattern: &[bool]) -> usize {
        let mut best = (f64::NEG_INFINITY, 0);
        for (i, (&e, &on)) in self.field.iter().zip(pattern).enumerate() {
            if on && e > best.0 {
                best = (e, i);
            }
        }
        best.1
    }

    /// The zero with the lowest energy (largest void); first in scan order on ties.
    fn largest_void(&self, pattern: &[bool]) -> usize {
        let mut best = (f64::INFINITY, 0);
        for (i, (&e, &on)) in self.field.iter().zip(pattern).enumerate() {
            if !on && e < best.0 {
                best = (e, i);
            }
        }
        best.1
    }
}

/// Ulichney's void-and-cluster method (1993): a tileable `side × side` rank array (a
/// permutation of `0..side²`) whose every threshold level is a blue-noise point set.
///
/// 1. A random binary pattern with `side²/10` ones is relaxed by repeatedly moving the one in
///    the tightest cluster into the largest void until the move would undo itself.
/// 2. Ones are ranked downwards by removing tightest clusters from a copy of that prototype.
/// 3. Zeros are ranked upwards by filling largest voids (for the second half this is the same
///    as Ulichney's "tightest cluster of zeros": the toroidal Gaussian sum is constant, so the
///    zero with the least energy from ones has the most energy from zeros).
///
/// Energies are exact f64 sums of the full toroidal kernel, updated incrementally, and ties go
/// to the first pixel in scan order, so the result is identical on every machine.
pub fn void_and_cluster(side: usize, sigma: f64, seed: u64) -> Vec<u32> {
    let n = side * side;
    assert!(n >= 4, "void-and-cluster needs at least a 2x2 tile");
    let ones = (n / 10).max(1);
    let mut pattern = vec![false; n];
    let mut energy = Energy::new(side, sigma);
    let mut state = seed;
    let mut placed = 0;
    while placed < ones {
        let p = (splitmix(&mut state) % n as u64) as usize;
        if !pattern[p] {
            pattern[p] = true;
            energy.splat(p, 1.0);
            placed += 1;
        }
    }
    // 1. Relax into the initial binary pattern.
    loop {
        let cluster = energy.tightest_cluster(&pattern);
        pattern[cluster] = false;
        energy.splat(cluster, -1.0);
        let void = energy.largest_void(&pattern);
        pattern[void] = true;
        energy.splat(void, 1.0);
        if void == cluster {
            break;
        }
    }
    let prototype = pattern.clone();
    let prototype_energy = energy.field.clone();
    let mut rank = vec![0u32; n];
    // 2. Rank the prototype's ones, tightest cluster last removed = lowest rank.
    let mut count = ones;
    while count > 0 {
        let cluster = energy.tightest_cluster(&pattern);
        pattern[cluster] = false;
        energy.splat(cluster, -1.0);
        count -= 1;
        rank[cluster] = count as u32;
    }
    // 3. Rank the zeros, largest void first.
    pattern = prototype;
    energy.field = prototype_energy;
    for r in ones..n {
        let void = energy.largest_void(&pattern);
        pattern[void] = true;
        energy.splat(void, 1.0);
        rank[void] = r as u32;
    }
    rank
}

/// The project's blue-noise tile ([`BLUE_NOISE_SIDE`]², σ = 1.5), generated on first use and
/// cached for the process, with how long the generation took.
pub fn blue_noise() -> &'static (Vec<u32>, Duration) {
    static TILE: OnceLock<(Vec<u32>, Duration)> = OnceLock::new();
    TILE.get_or_init(|| {
        let t0 = Instant::now();
        let ranks = void_and_cluster(BLUE_NOISE_SIDE, BLUE_NOISE_SIGMA, BLUE_NOISE_SEED);
        (ranks, t0.elapsed())
    })
}

/// Per-frame shifts of frame `k`: the R2 tile shift in whole pixels (for a tile of `side`) and
/// the golden-ratio value rotation in `[0, 1)`. Frame 0 is unshifted.
pub fn frame_shift(k: u32, side: u32) -> ([u32; 2], f32) {
    let k = f64::from(k);
    let off = R2.map(|g| ((k * g).fract() * f64::from(side)).floor() as u32 % side.max(1));
    (off, (k * GOLDEN).fract() as f32)
}

/// Sub-frame `k` of animation frame `frame` with `spp` samples per frame: `frame·spp + k`,
/// wrapping (the sequences are periodic or hashed, so a wrap after 2^32 sub-frames is harmless).
pub fn sub_frame(frame: u32, spp: u32, k: u32) -> u32 {
    frame.wrapping_mul(spp).wrapping_add(k)
}

/// Where sub-frame `s` of the `stbn` pattern reads: slice `s mod slices`, and the R2 tile shift
/// of period `⌊s / slices⌋` (none in the first period), so that later periods do not repeat
/// the first exactly.
pub fn stbn_frame(s: u32) -> (u32, [u32; 2]) {
    let slices = crate::stbn::STBN_SLICES as u32;
    let (offset, _) = frame_shift(s / slices, crate::stbn::STBN_SIDE as u32);
    (s % slices, offset)
}

/// The `stbn` lookup of stochastic_dither.wgsl (`tiled_threshold` with the slice's first row and
/// no value rotation), the twin the GPU lookup is tested against: the threshold at `pixel` of
/// `volume` (slices of `tile²` stacked) in the slice sub-frame `s` reads, shifted toroidally by
/// the seed (low 16 bits in x, high in y) and by the period's R2 offset.
pub fn stbn_threshold(volume: &[f32], tile: u32, pixel: [u32; 2], seed: u32, s: u32) -> f32 {
    let (slice, offset) = stbn_frame(s);
    let mask = tile - 1;
    let x = (pixel[0] + (seed & 0xffff) + offset[0]) & mask;
    let y = (pixel[1] + (seed >> 16) + offset[1]) & mask;
    let v = volume[((slice * tile + y) * tile + x) as usize];
    v - v.floor()
}

/// The threshold table a pattern uploads, row-major (`side²` values, or `side²·slices` with the
/// slices stacked vertically for `stbn`): the blue-noise tile, the STBN volume or the Bayer
/// matrix as thresholds; one placeholder texel for the procedural patterns, which read none but
/// still bind a texture.
pub fn table(pattern: Pattern) -> Vec<f32> {
    match (pattern, pattern.bayer_side()) {
        (Pattern::Blue, _) => thresholds(&blue_noise().0),
        (Pattern::Stbn, _) => crate::stbn::stbn_thresholds(),
        (_, Some(side)) => thresholds(&bayer(side as usize)),
        _ => vec![0.0; 1],
    }
}

/// PCG hash (Jarzynski & Olano 2020), `pcg` of stochastic_dither.wgsl: the twin that seeded
/// tiled patterns' per-frame rotation needs.
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// `unit` of the shader: the hash's top 24 bits as a uniform in `[0, 1)`, exact in f32.
pub fn unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// `tiled_threshold` of stochastic_dither.wgsl, the twin the GPU lookup is tested against: the
/// threshold at `pixel` of `table` (side `tile`, a power of two) shifted toroidally by the
/// seed (low 16 bits in x, high in y) and by sub-frame `frame`'s R2 offset, its value rotated by
/// the sub-frame's golden-ratio step, or for seeded layers from sub-frame 1 on by a hash of
/// (seed, sub-frame).
pub fn tiled_threshold(
    table: &[f32],
    tile: u32,
    pixel: [u32; 2],
    seed: u32,
    seed_mode: Seed,
    frame: u32,
) -> f32 {
    let (offset, golden) = frame_shift(frame, tile);
    let mask = tile - 1;
    let x = (pixel[0] + (seed & 0xffff) + offset[0]) & mask;
    let y = (pixel[1] + (seed >> 16) + offset[1]) & mask;
    let rotation = if seed_mode != Seed::None && frame > 0 {
        unit(pcg(seed ^ pcg(frame.wrapping_add(0x632b_e5ab))))
    } else {
        golden
    };
    let v = table[(y * tile + x) as usize] + rotation;
    v - v.floor()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bayer_matches_the_literature() {
        assert_eq!(bayer(2), vec![0, 2, 3, 1]);
        // The classic 4x4 matrix (e.g. Bayer 1973; Ulichney, Digital Halftoning, 1987).
        assert_eq!(
            bayer(4),
            vec![0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5]
        );
        let b8 = bayer(8);
        let mut sorted = b8.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..64).collect::<Vec<u32>>());
        // Level 1/2 of any Bayer matrix is a checkerboard.
        for (i, &r) in b8.iter().enumerate() {
            assert_eq!(r < 32, (i % 8 + i / 8) % 2 == 0, "pixel {i}");
        }
    }

    /// `B₂ = [[0, 2], [3, 1]]` at `(x, y)`, coordinates 0 or 1.
    fn b2(x: usize, y: usize) -> u32 {
        [[0, 2], [3, 1]][y][x]
    }

    #[test]
    fn every_bayer_size_is_a_recursively_interleaved_permutation() {
        for n in [2usize, 4, 8, 16, 32, 64, 128, 256] {
            let b = bayer(n);
            assert_eq!(b.len(), n * n);
            // Every rank exactly once.
            let mut seen = vec![false; n * n];
            for &r in &b {
                assert!(!seen[r as usize], "bayer{n}: rank {r} twice");
                seen[r as usize] = true;
            }
            let k = n.trailing_zeros();
            let h = n / 2;
            let half = bayer(h);
            for y in 0..n {
                for x in 0..n {
                    let r = b[y * n + x];
                    // Closed form: bit i of (x, y) picks the B₂ entry of rank digit k−1−i
                    // (base 4), so the finest pixel bits decide the coarsest levels.
                    let closed: u32 = (0..k)
                        .map(|i| b2(x >> i & 1, y >> i & 1) << (2 * (k - 1 - i)))
                        .sum();
                    assert_eq!(r, closed, "bayer{n} at ({x}, {y})");
                    // With h = n/2, interleaving: Bₙ(x, y) = h²·B₂(x mod 2, y mod 2) +
                    // B_h(⌊x/2⌋, ⌊y/2⌋), and quadrants: Bₙ(x, y) = 4·B_h(x mod h, y mod h) +
                    // B₂(⌊x/h⌋, ⌊y/h⌋).
                    let hh = (h * h) as u32;
                    assert_eq!(r, hh * b2(x % 2, y % 2) + half[(y / 2) * h + x / 2]);
                    assert_eq!(r, 4 * half[(y % h) * h + x % h] + b2(x / h, y / h));
                }
            }
            // Every level 4^j of the ranks is a regular lattice: the pixels of rank < n²/4^j
            // are spaced 2^j apart in x and y (the first quarter is every other pixel of every
            // other row, and so on), which is what makes each level evenly spread.
            for j in 1..=k {
                let step = 1usize << j;
                let count = (n * n) >> (2 * j);
                let (x0, y0) = (0..n * n)
                    .find(|&i| b[i] == 0)
                    .map(|i| (i % n, i / n))
                    .expect("rank 0");
                for (i, &r) in b.iter().enumerate() {
                    let on_lattice = (i % n) % step == x0 % step && (i / n) % step == y0 % step;
                    assert_eq!(
                        (r as usize) < count,
                        on_lattice,
                        "bayer{n} level 1/{}: pixel {i}",
                        1usize << (2 * j)
                    );
                }
            }
            // The thresholds are distinct, centred and inside (0, 1).
            let t = thresholds(&b);
            for (&r, &v) in b.iter().zip(&t) {
                assert_eq!(f64::from(v), (f64::from(r) + 0.5) / (n * n) as f64);
                assert!(v > 0.0 && v < 1.0);
            }
        }
    }

    #[test]
    fn thresholds_are_centred() {
        assert_eq!(thresholds(&[0, 1, 2, 3]), vec![0.125, 0.375, 0.625, 0.875]);
    }

    /// Power of the pattern `rank < level` at the lowest nonzero frequencies, relative to what
    /// white noise of the same density has in expectation (n·p·(1−p) per frequency).
    fn low_frequency_ratio(ranks: &[u32], side: usize, level: u32) -> f64 {
        let n = (side * side) as f64;
        let p = f64::from(level) / n;
        let mut power = 0.0;
        let mut freqs = 0;
        for ky in -4i32..=4 {
            for kx in -4i32..=4 {
                let k2 = kx * kx + ky * ky;
                if k2 == 0 || k2 > 16 {
                    continue;
                }
                let (mut re, mut im) = (0.0f64, 0.0f64);
                for (i, &r) in ranks.iter().enumerate() {
                    if r < level {
                        let (x, y) = ((i % side) as f64, (i / side) as f64);
                        let ph =
                            2.0 * std::f64::consts::PI * (f64::from(kx) * x + f64::from(ky) * y)
                                / side as f64;
                        re += ph.cos();
                        im += ph.sin();
                    }
                }
                power += re * re + im * im;
                freqs += 1;
            }
        }
        power / f64::from(freqs) / (n * p * (1.0 - p))
    }

    #[test]
    fn void_and_cluster_is_a_blue_noise_permutation() {
        let (ranks, took) = blue_noise();
        println!("void-and-cluster 64x64 sigma 1.5 took {took:?}");
        let mut sorted = ranks.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..4096).collect::<Vec<u32>>());
        // Deterministic: a second generation is identical.
        assert_eq!(
            &void_and_cluster(BLUE_NOISE_SIDE, BLUE_NOISE_SIGMA, BLUE_NOISE_SEED),
            ranks
        );
        // Blue: almost no power at low frequencies at every level, where white noise has
        // ratio 1 in expectation.
        for level in [256, 1024, 2048, 3072] {
            let ratio = low_frequency_ratio(ranks, 64, level);
            println!("level {level}/4096: low-frequency power ratio {ratio:.4}");
            assert!(ratio < 0.05, "level {level}: ratio {ratio}");
        }
        // A white-noise permutation for contrast (the test can tell the difference).
        let mut state = 7u64;
        let mut white: Vec<u32> = (0..4096).collect();
        for i in (1..white.len()).rev() {
            let j = (splitmix(&mut state) % (i as u64 + 1)) as usize;
            white.swap(i, j);
        }
        let ratio = low_frequency_ratio(&white, 64, 2048);
        assert!(ratio > 0.3, "white ratio {ratio}");
        // Minority pixels at 1/16 density are well spread: no two are 8-neighbours.
        let side = 64usize;
        for (i, &r) in ranks.iter().enumerate() {
            if r >= 256 {
                continue;
            }
            let (x, y) = (i % side, i / side);
            for (dx, dy) in [(1, 0), (0, 1), (1, 1), (side - 1, 1)] {
                let j = (y + dy) % side * side + (x + dx) % side;
                assert!(ranks[j] >= 256, "neighbours {i} and {j} both below 1/16");
            }
        }
    }

    #[test]
    fn frame_shifts() {
        assert_eq!(frame_shift(0, 64), ([0, 0], 0.0));
        let (o, r) = frame_shift(1, 64);
        assert_eq!(o, [48, 36]);
        assert!((r - 0.618_034).abs() < 1e-6);
        // R2 shifts of 64 frames on a 64 tile hit 64 distinct x and y offsets? Not necessarily,
        // but they are spread: no shift repeats.
        let mut seen: Vec<[u32; 2]> = (0..64).map(|k| frame_shift(k, 64).0).collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), 64);
    }
}
