//! The CPU twin of shaders/wavelet_math.wgsl, function for function and line for line: the
//! Haar projection of one fragment's absorbance step, the reconstruction at a depth, the same
//! with the fragment's own step taken out ("signal-corrected"), and the total.
//!
//! The signal is a pixel's absorbance as a function of normalised depth x ∈ [0, 1]:
//! A(x) = Σᵢ aᵢ·H(x − xᵢ), a step of height aᵢ = −ln(1 − αᵢ) at each fragment's depth xᵢ.
//! Rank r keeps N = 2^(r+1) coefficients: the scaling function φ = 1 on [0, 1) (index 0) and
//! the Haar wavelets ψⱼₖ(x) = 2^(j/2)·ψ(2^j·x − k) for levels j = 0..=r (index 2^j + k),
//! ψ = +1 on [0, ½), −1 on [½, 1). Projecting a step H(x − x₀) gives 1 − x₀ on φ and, on the
//! one wavelet per level whose support holds x₀ (u = 2^j·x₀ − k its place in that support),
//! ∫ψⱼₖ over [x₀, ∞) = −2^(−j/2)·min(u, 1 − u): a tent, zero at the support's ends. So one
//! fragment writes r + 2 coefficients, and the projection of the pixel is the sum of its
//! fragments' (additive blending, any order).
//!
//! The projection onto this basis is exactly A's average over each of the N cells of width
//! 1/N, so the reconstruction is read per cell and interpolated linearly between the cell
//! before and the cell at the depth, as Flywheel's shipped code does; depth is scaled by
//! (N − 1)/N so the farthest fragment's step lies inside the last cell, whose average is then
//! the exact total Σ aᵢ.

/// Coefficients of the largest rank (4): the length of every coefficient array, here and in
/// the shader.
pub const MAX_COEFFICIENTS: usize = 32;

/// Transmittance floor before the logarithm (Flywheel's `max(T, 1e-5)`): an opaque fragment
/// absorbs ln(1e5) ≈ 11.5, enough to hide what is behind it to 1e-5.
pub const MIN_TRANSMITTANCE: f32 = 1e-5;

/// Fragments that transmit more than this add nothing and are discarded (as `mboit`).
pub const MAX_TRANSMITTANCE: f32 = 0.9999999;

/// √½, for the levels' 2^(±j/2) scales: exact powers of two times this constant, the same
/// rounding on the CPU and the GPU.
pub const SQRT_HALF: f32 = 0.70710677;

/// A rank the technique offers: 2, 3 (Flywheel's) or 4.
pub type Rank = oit_gpu::Bounded<2, 4>;

/// N = 2^(rank + 1) coefficients.
pub fn coefficient_count(rank: u32) -> u32 {
    1u32 << (rank + 1)
}

/// The fragment's absorbance −ln(max(1 − α, 1e-5)), or `None` when it is discarded.
pub fn absorbance(alpha: f32) -> Option<f32> {
    let t = 1.0 - alpha;
    if t > MAX_TRANSMITTANCE {
        return None;
    }
    Some(-(t.max(MIN_TRANSMITTANCE)).ln())
}

/// View distance `z` normalised into the pixel's transparent interval [z_min, z_max]; 0 when
/// the interval is empty (one fragment, or all at one depth).
pub fn normalized_depth(z: f32, z_min: f32, z_max: f32) -> f32 {
    if z_max > z_min {
        return ((z - z_min) / (z_max - z_min)).clamp(0.0, 1.0);
    }
    0.0
}

/// 2^(−j/2): a power of two, times √½ on odd levels.
pub fn level_shrink(j: u32) -> f32 {
    let odd = if j % 2 == 1 { SQRT_HALF } else { 1.0 };
    odd * (-((j / 2) as f32)).exp2()
}

/// 2^(j/2): a power of two, times √2 (= 2·√½) on odd levels.
pub fn level_grow(j: u32) -> f32 {
    let odd = if j % 2 == 1 { 2.0 * SQRT_HALF } else { 1.0 };
    odd * ((j / 2) as f32).exp2()
}

/// Depth in the basis's domain: x·(N − 1)/N.
pub fn basis_depth(rank: u32, depth: f32) -> f32 {
    let n = coefficient_count(rank) as f32;
    depth * ((n - 1.0) / n)
}

/// Adds the projection of a step of height `signal` at normalised `depth` to `c`.
pub fn project(c: &mut [f32; MAX_COEFFICIENTS], rank: u32, signal: f32, depth: f32) {
    let x = basis_depth(rank, depth);
    c[0] += signal * (1.0 - x);
    for j in 0..=rank {
        let level = (1u32 << j) as f32;
        let scaled = x * level;
        let k = scaled.floor().min(level - 1.0);
        let u = scaled - k;
        let i = (1u32 << j) as usize + k as usize;
        c[i] += -signal * level_shrink(j) * u.min(1.0 - u);
    }
}

/// The reconstruction on cell `cell` of N: A's average over [cell/N, (cell + 1)/N).
pub fn cell_value(c: &[f32; MAX_COEFFICIENTS], rank: u32, cell: u32) -> f32 {
    let mut v = c[0];
    for j in 0..=rank {
        let k = cell >> (rank + 1 - j);
        let first_half = (cell >> (rank - j)) & 1 == 0;
        let sign = if first_half { 1.0 } else { -1.0 };
        v += sign * level_grow(j) * c[((1u32 << j) + k) as usize];
    }
    v
}

/// The reconstructed absorbance at normalised `depth`: the cell averages before and at it,
/// interpolated by the depth's place in its cell.
pub fn absorbance_at(c: &[f32; MAX_COEFFICIENTS], rank: u32, depth: f32) -> f32 {
    let n = coefficient_count(rank);
    let x = basis_depth(rank, depth) * n as f32;
    let cell = (x.floor().max(0.0) as u32).min(n - 1);
    let f = (x - cell as f32).clamp(0.0, 1.0);
    let b = cell_value(c, rank, cell);
    let mut a = 0.0;
    if cell > 0 {
        a = cell_value(c, rank, cell - 1);
    }
    a + (b - a) * f
}

/// The absorbance in front of a fragment of absorbance `signal` at `depth`: the
/// reconstruction with the fragment's own step taken out of the coefficients first, so a
/// fragment never absorbs its own light.
pub fn absorbance_before(c: &[f32; MAX_COEFFICIENTS], rank: u32, depth: f32, signal: f32) -> f32 {
    let mut without = *c;
    project(&mut without, rank, -signal, depth);
    absorbance_at(&without, rank, depth)
}

/// The pixel's total absorbance: the last cell's average, Σ aᵢ.
pub fn total_absorbance(c: &[f32; MAX_COEFFICIENTS], rank: u32) -> f32 {
    cell_value(c, rank, coefficient_count(rank) - 1)
}

/// exp(−A), clamped to [0, 1] (rounding can leave A slightly negative).
pub fn transmittance(absorbance: f32) -> f32 {
    (-absorbance).exp().clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A's average over cell `cell` of N computed directly from the steps.
    fn cell_average(steps: &[(f32, f32)], rank: u32, cell: u32) -> f64 {
        let n = f64::from(coefficient_count(rank));
        let (lo, hi) = (f64::from(cell) / n, f64::from(cell + 1) / n);
        steps
            .iter()
            .map(|&(a, d)| {
                let x = f64::from(basis_depth(rank, d));
                // The part of the cell at or after the step, as a fraction of the cell.
                let covered = ((hi - x.max(lo)) / (hi - lo)).clamp(0.0, 1.0);
                f64::from(a) * covered
            })
            .sum()
    }

    proptest! {
        /// The Haar projection is the cell-average projection: every cell reconstructs to A's
        /// average over it, for every rank; the last cell to the total.
        #[test]
        fn cells_reconstruct_the_cell_averages(
            steps in prop::collection::vec((0.0f32..12.0, 0.0f32..=1.0), 1..40),
            rank in 2u32..=4,
        ) {
            let mut c = [0.0; MAX_COEFFICIENTS];
            for &(a, d) in &steps {
                project(&mut c, rank, a, d);
            }
            let scale: f64 = steps.iter().map(|s| f64::from(s.0)).sum::<f64>().max(1.0);
            for cell in 0..coefficient_count(rank) {
                let got = f64::from(cell_value(&c, rank, cell));
                let want = cell_average(&steps, rank, cell);
                prop_assert!((got - want).abs() <= 2e-5 * scale, "cell {cell}: {got} vs {want}");
            }
            let total: f64 = steps.iter().map(|s| f64::from(s.0)).sum();
            prop_assert!((f64::from(total_absorbance(&c, rank)) - total).abs() <= 2e-5 * scale);
            // Coefficients beyond N stay zero.
            prop_assert!(c[coefficient_count(rank) as usize..].iter().all(|&v| v == 0.0));
        }

        /// Taking a fragment's own step out leaves what the others alone reconstruct.
        #[test]
        fn signal_correction_removes_exactly_the_fragment(
            steps in prop::collection::vec((0.0f32..12.0, 0.0f32..=1.0), 2..20),
            rank in 2u32..=4,
        ) {
            let mut all = [0.0; MAX_COEFFICIENTS];
            let mut others = [0.0; MAX_COEFFICIENTS];
            for (i, &(a, d)) in steps.iter().enumerate() {
                project(&mut all, rank, a, d);
                if i != 0 {
                    project(&mut others, rank, a, d);
                }
            }
            let (a0, d0) = steps[0];
            let corrected = absorbance_before(&all, rank, d0, a0);
            let direct = absorbance_at(&others, rank, d0);
            let scale: f32 = steps.iter().map(|s| s.0).sum::<f32>().max(1.0);
            prop_assert!((corrected - direct).abs() <= 2e-5 * scale, "{corrected} vs {direct}");
        }
    }

    /// Fragments in depth order: a fragment sees none of the absorbance behind it, and every
    /// step in a cell strictly before its own cell's predecessor in full.
    #[test]
    fn separated_fragments_see_what_is_in_front_of_them() {
        let rank = 3;
        // Depths at the starts of cells 1, 5 and 12 of 16 (after the (N − 1)/N scale).
        let n = coefficient_count(rank) as f32;
        let at = |cell: f32| cell / (n - 1.0);
        let steps = [(0.7f32, at(1.0)), (1.2, at(5.0)), (2.0, at(12.0))];
        let mut c = [0.0; MAX_COEFFICIENTS];
        for &(a, d) in &steps {
            project(&mut c, rank, a, d);
        }
        let before: Vec<f32> = steps
            .iter()
            .map(|&(a, d)| absorbance_before(&c, rank, d, a))
            .collect();
        assert!(before[0].abs() < 1e-6, "{before:?}");
        assert!((before[1] - 0.7).abs() < 1e-5, "{before:?}");
        assert!((before[2] - 1.9).abs() < 1e-5, "{before:?}");
        assert!((total_absorbance(&c, rank) - 3.9).abs() < 1e-5);
        // A fragment at the far end sees everything but itself.
        assert!((absorbance_before(&c, rank, 1.0, 0.5) - 3.9).abs() < 1e-4);
    }

    /// Two fragments in one cell see each other in proportion to their places in it: the
    /// interpolation, not the order, decides (the method's resolution limit).
    #[test]
    fn fragments_in_one_cell_blur_together() {
        let rank = 2;
        let mut c = [0.0; MAX_COEFFICIENTS];
        // Cell 3 of 8 spans basis depths [3/8, 4/8); both fragments inside it.
        let d = |x: f32| x / basis_depth(rank, 1.0);
        project(&mut c, rank, 1.0, d(0.4));
        project(&mut c, rank, 1.0, d(0.45));
        let near = absorbance_before(&c, rank, d(0.4), 1.0);
        let far = absorbance_before(&c, rank, d(0.45), 1.0);
        // The far one sees the near one's cell average (1 − 0.2) interpolated at 0.6 of its
        // cell: 0.48, not 1; the near one sees a share of the far one that it should not.
        assert!((far - 0.48).abs() < 1e-5, "{far}");
        assert!(near > 0.0 && near < far, "{near} {far}");
    }

    #[test]
    fn level_scales_are_inverse_powers_of_root_two() {
        for j in 0..=4u32 {
            let want = 2f64.powf(-f64::from(j) / 2.0);
            assert!((f64::from(level_shrink(j)) - want).abs() < 1e-7, "{j}");
            assert!((f64::from(level_grow(j)) - 1.0 / want).abs() < 1e-6, "{j}");
        }
        assert_eq!(absorbance(0.0), None);
        assert_eq!(absorbance(1.0), Some(-(1e-5f32).ln()));
        assert_eq!(normalized_depth(3.0, 3.0, 3.0), 0.0);
        assert_eq!(normalized_depth(4.0, 2.0, 6.0), 0.5);
        assert_eq!(normalized_depth(7.0, 2.0, 6.0), 1.0);
    }
}
