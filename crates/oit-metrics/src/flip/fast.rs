//! Branch-free single-precision cube root, log2, exp2 and power for ꟻLIP's per-pixel step.
//!
//! The library functions are opaque calls, so a loop that uses them runs one pixel at a time;
//! these are plain arithmetic and bit operations that the compiler vectorises. Accuracy (checked
//! in the tests below against the library over the ranges ꟻLIP uses): `cbrt` is `x^(1.0f/3.0f)` correctly rounded,
//! `pow` within 4·(1 + |a·log₂x|)·2⁻²⁴ relative (2.4e-7 for `x^a` near 1, 6e-6 at 1e-30) — far below the 1e-6 level at which the
//! float ꟻLIP already differs from the C++ one through summation order.

use std::f32::consts::{LN_2, LOG2_E, SQRT_2};

/// `x^(1/3)` for positive normal `x`, as the reference implementation computes it: with the
/// exponent `1.0f/3.0f` = 1/3 + 9.9e-9 (`powf(x, 1.0f / 3.0f)`), correctly rounded (but for
/// rare near-ties). First `exp2(log2(x)/3)` (within ~1e-6), then one Newton step in f64 for the
/// true cube root (error ~1e-12) and the factor `x^9.9e-9 = 1 + 9.9e-9·ln x`, then one rounding.
/// The rounding matters: ꟻLIP subtracts the Lab values of nearly equal colours and raises the
/// difference to the power 0.7, so a cube root that differs by an ulp shows in near-zero errors.
#[inline(always)]
pub(super) fn cbrt(x: f32) -> f32 {
    // The f32 exponent 1/3 rounds up by this much.
    const EXCESS: f64 = (1.0f32 / 3.0) as f64 - 1.0 / 3.0;
    let l2 = log2(x);
    let y = f64::from(exp2(l2 * (1.0 / 3.0)));
    let x = f64::from(x);
    let y = (2.0 * y + x / (y * y)) * (1.0 / 3.0);
    (y * (1.0 + EXCESS * std::f64::consts::LN_2 * f64::from(l2))) as f32
}

/// log₂ of a positive normal `x`: exponent plus the atanh series of the mantissa taken in
/// [√½, √2) (|z| ≤ 0.172, so the first omitted term is below 1e-9).
#[inline(always)]
fn log2(x: f32) -> f32 {
    let bits = x.to_bits() as i32;
    let mut e = ((bits >> 23) & 0xFF) - 127;
    let mut m = f32::from_bits(((bits & 0x007F_FFFF) | 0x3F80_0000) as u32);
    let big = m > SQRT_2;
    m = if big { 0.5 * m } else { m };
    e += i32::from(big);
    let z = (m - 1.0) / (m + 1.0);
    let z2 = z * z;
    let ln_m =
        z * (2.0 + z2 * (2.0 / 3.0 + z2 * (2.0 / 5.0 + z2 * (2.0 / 7.0 + z2 * (2.0 / 9.0)))));
    e as f32 + ln_m * LOG2_E
}

/// 2^t for t ≤ 127: 0 below −126. Round to the nearest integer n, then e^(f·ln 2) for the
/// remainder |f| ≤ ½ by its Taylor series to degree 7 (error below 6e-9), scaled by 2^n.
#[inline(always)]
fn exp2(t: f32) -> f32 {
    // Adding and removing 1.5·2²³ rounds to the nearest integer (|t| < 2²²).
    const ROUND: f32 = 12_582_912.0;
    let t = t.max(-127.0);
    let shifted = t + ROUND;
    let n = shifted - ROUND;
    let g = (t - n) * LN_2;
    let p = 1.0
        + g * (1.0
            + g * (1.0 / 2.0)
                * (1.0
                    + g * (1.0 / 3.0)
                        * (1.0
                            + g * (1.0 / 4.0)
                                * (1.0
                                    + g * (1.0 / 5.0)
                                        * (1.0 + g * (1.0 / 6.0) * (1.0 + g * (1.0 / 7.0)))))));
    // The integer n sits in the low mantissa bits of `shifted` (no float → int conversion,
    // which would not vectorise as cheaply).
    let n = (shifted.to_bits() as i32).wrapping_sub(0x4B40_0000);
    let scale = f32::from_bits((n.wrapping_add(127) << 23) as u32);
    if t < -126.0 { 0.0 } else { p * scale }
}

/// `x^a` for `x ≥ 0` and `a` such that the result stays below 2¹²⁷. `0^0 = 1`, `0^a = 0`.
#[inline(always)]
pub(super) fn pow(x: f32, a: f32) -> f32 {
    // Subnormal x would mislead log2's exponent; raised to a ≥ 0.5 they are below 1e-19 anyway.
    let r = exp2(a * log2(x.max(f32::MIN_POSITIVE)));
    if x > 0.0 {
        r
    } else if a == 0.0 {
        1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `x` from `lo` to `hi` in steps of about 1e-4 relative.
    fn sweep(lo: f32, hi: f32) -> impl Iterator<Item = f32> {
        std::iter::successors(Some(lo), move |&x| Some(x * 1.000_1 + 1e-12))
            .take_while(move |&x| x <= hi)
    }

    #[test]
    fn cbrt_is_correctly_rounded_over_labs_range() {
        // lab_f takes cube roots above (6/29)³ ≈ 0.0089 of clamped colours (≤ ~1.1).
        let (mut off, mut n) = (0usize, 0usize);
        for x in sweep(0.008, 4.0) {
            let exact = f64::from(x).powf(f64::from(1.0f32 / 3.0));
            let err = (f64::from(cbrt(x)) - exact).abs();
            // Within half an ulp of the exact value (with room for the f64 reference's error).
            let half_ulp = f64::from(f32::EPSILON) * exact / 2.0;
            off += usize::from(err > half_ulp * (1.0 + 1e-6));
            n += 1;
        }
        assert_eq!(off, 0, "{off} of {n} cube roots not correctly rounded");
        // And so they almost always equal the library's powf(x, 1.0 / 3.0) (measured with
        // glibc: 36 of 62139 differ, by one ulp, at near-ties).
        let same = sweep(0.008, 4.0)
            .filter(|&x| cbrt(x) == x.powf(1.0 / 3.0))
            .count();
        assert!(
            same * 1000 >= n * 999,
            "{same} of {n} equal to powf(x, 1/3)"
        );
    }

    #[test]
    fn pow_matches_the_library() {
        // The exponent t = a·log2(x) carries f32 rounding of |t|·2⁻²⁴, which 2^t turns into a
        // relative error of ln2·|t|·2⁻²⁴; measure against that scale (1 + |t|)·2⁻²⁴.
        let mut worst = 0.0f64;
        for a in [0.7f32, 1.0, 0.999, 0.5, 0.25, 0.01, 0.0] {
            for x in sweep(1e-30, 400.0) {
                let (ours, lib) = (f64::from(pow(x, a)), f64::from(x.powf(a)));
                let t = f64::from(a) * f64::from(x).log2();
                let scale = (1.0 + t.abs()) * f64::from(f32::EPSILON) / 2.0;
                worst = worst.max((ours - lib).abs() / lib / scale);
            }
        }
        println!("worst error: {worst:.2} × (1 + |t|)·2⁻²⁴");
        assert!(worst < 4.0, "worst relative error {worst} × (1 + |t|)·2⁻²⁴");
        assert_eq!(
            (pow(0.0, 0.7), pow(0.0, 0.0), pow(1.0, 0.3)),
            (0.0, 1.0, 1.0)
        );
        // Subnormal input is read as the smallest normal.
        let tiny = f32::MIN_POSITIVE.powf(0.7);
        assert!((pow(1e-39, 0.7) - tiny).abs() < 1e-5 * tiny);
    }

    #[test]
    fn exp2_integers_are_exact_and_underflow_is_zero() {
        for n in -126..=127 {
            assert_eq!(exp2(n as f32), 2f32.powi(n), "2^{n}");
        }
        assert_eq!(exp2(-200.0), 0.0);
    }
}
