//! Front-to-back compositing in f64: the one formula of the rendering model, for scalar alpha
//! and for coloured transmittance (of which scalar alpha is the case `t = 1 − α` in every
//! channel; both give the same bits there).

/// Composites premultiplied fragments, sorted front to back, over an opaque base colour:
/// `C = Σ_i C_i · T_i + T_n · C_o` with `T_i = Π_{j<i} (1 − α_j)`, in f64.
///
/// `fragments` are `(premultiplied RGB, alpha)` pairs, nearest first; `background` is the
/// colour of the nearest opaque surface, or the scene background. The reference uses exactly
/// this function per pixel, so GPU-side tests and closed-form checks can call it directly.
/// A transmittance below 2^-1000 is taken as 0 ([`negligible`]), which leaves the result the
/// same once rounded to f32.
pub fn composite_front_to_back(fragments: &[([f64; 3], f64)], background: [f64; 3]) -> [f64; 3] {
    composite_iter(fragments.iter().copied(), background)
}

/// [`composite_front_to_back`] over an iterator (the renderer feeds its tile storage directly).
#[inline]
pub(crate) fn composite_iter(
    fragments: impl Iterator<Item = ([f64; 3], f64)>,
    background: [f64; 3],
) -> [f64; 3] {
    let mut color = [0.0f64; 3];
    let mut transmittance = 1.0f64;
    for (premultiplied, alpha) in fragments {
        over_step::<true>(&mut color, &mut transmittance, premultiplied, 1.0 - alpha);
    }
    [
        color[0] + transmittance * background[0],
        color[1] + transmittance * background[1],
        color[2] + transmittance * background[2],
    ]
}

/// Composites fragments with coloured transmittance, sorted front to back, over an opaque base
/// colour: `C = Σ_i C_i ⊙ T_i + T_n ⊙ C_o` with `T_i = Π_{j<i} t_j` per channel, in f64.
///
/// `fragments` are `(premultiplied RGB, transmittance RGB)` pairs, nearest first. A fragment
/// with scalar alpha α is `(C, [1 − α; 3])`, and then the result is bit-identical to
/// [`composite_front_to_back`].
pub fn composite_transmittance_front_to_back(
    fragments: &[([f64; 3], [f64; 3])],
    background: [f64; 3],
) -> [f64; 3] {
    composite_coloured_iter(fragments.iter().copied(), background)
}

/// [`composite_transmittance_front_to_back`] over an iterator.
#[inline]
pub(crate) fn composite_coloured_iter(
    fragments: impl Iterator<Item = ([f64; 3], [f64; 3])>,
    background: [f64; 3],
) -> [f64; 3] {
    let mut color = [0.0f64; 3];
    let mut transmittance = [1.0f64; 3];
    for (premultiplied, t) in fragments {
        over_step_coloured(&mut color, &mut transmittance, premultiplied, t);
    }
    [
        color[0] + transmittance[0] * background[0],
        color[1] + transmittance[1] * background[1],
        color[2] + transmittance[2] * background[2],
    ]
}

/// Transmittance below which the rest of a stack cannot change the f32 result, so it is set to
/// 0 ([`negligible`]): 2^-1000.
pub(crate) const NEGLIGIBLE_TRANSMITTANCE: f64 = f64::from_bits((1023 - 1000) << 52);

/// `transmittance`, or 0 once it is below [`NEGLIGIBLE_TRANSMITTANCE`].
///
/// Why the f32 result cannot change: every later term `T·C_i`, and `T·C_o`, is below
/// 2^-1000 · 2^128 = 2^-872 (colours are f32, α ≤ 1), and there are fewer than 2^32 of them
/// (fragment counts are u32), so together below 2^-840. A colour sum of at least 2^-787 absorbs
/// each such term (it is under half its ulp, 2^-840, so rounding returns the sum unchanged),
/// with or without them; a smaller sum stays below 2^-786 either way, which rounds to 0 in f32
/// (whose smallest subnormal is 2^-149). What it saves: without it, a deep stack's
/// transmittance sinks into subnormal f64s, where it sticks at 2^-1074 for α < 0.5 and every
/// multiply costs about 100 cycles on some x86 CPUs.
#[inline(always)]
pub(crate) fn negligible(transmittance: f64) -> f64 {
    if transmittance < NEGLIGIBLE_TRANSMITTANCE {
        0.0
    } else {
        transmittance
    }
}

/// One front-to-back step: `C += T·C_i`, then `T *= 1 − α_i` (`keep` = `1 − α_i`), and
/// [`negligible`] when `MAY_UNDERFLOW`. The one place this arithmetic is written: the stored
/// path ([`composite_iter`]) and the in-order path of the renderer both call it, so they give
/// the same bits. A caller that has shown the transmittance cannot fall below
/// [`NEGLIGIBLE_TRANSMITTANCE`] (the renderer bounds it per tile) leaves the check out: it
/// would never fire, so the bits are the same, and it is a sixth of a cheap step.
#[inline(always)]
pub(crate) fn over_step<const MAY_UNDERFLOW: bool>(
    color: &mut [f64; 3],
    transmittance: &mut f64,
    premultiplied: [f64; 3],
    keep: f64,
) {
    for k in 0..3 {
        color[k] += *transmittance * premultiplied[k];
    }
    *transmittance *= keep;
    if MAY_UNDERFLOW {
        *transmittance = negligible(*transmittance);
    }
}

/// [`over_step`] with a per-channel transmittance `t` (`C += T ⊙ C_i`, `T ⊙= t_i`).
#[inline(always)]
pub(crate) fn over_step_coloured(
    color: &mut [f64; 3],
    transmittance: &mut [f64; 3],
    premultiplied: [f64; 3],
    t: [f64; 3],
) {
    for k in 0..3 {
        color[k] += transmittance[k] * premultiplied[k];
        transmittance[k] = negligible(transmittance[k] * t[k]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The formula without [`negligible`]: what the f32 result must equal.
    fn unflushed(fragments: &[([f64; 3], [f64; 3])], background: [f64; 3]) -> [f32; 3] {
        let mut color = [0.0f64; 3];
        let mut transmittance = [1.0f64; 3];
        for (premultiplied, t) in fragments {
            for k in 0..3 {
                color[k] += transmittance[k] * premultiplied[k];
                transmittance[k] *= t[k];
            }
        }
        std::array::from_fn(|k| (color[k] + transmittance[k] * background[k]) as f32)
    }

    /// An f32 colour from 2^-149 to 2^127: from the smallest subnormal to HDR.
    fn colour() -> impl Strategy<Value = f64> {
        prop_oneof![
            Just(0.0),
            (-149i32..128, 1.0f64..2.0).prop_map(|(e, m)| f64::from((m * 2f64.powi(e)) as f32)),
        ]
    }

    fn fragment() -> impl Strategy<Value = ([f64; 3], f64)> {
        (
            [colour(), colour(), colour()],
            prop_oneof![0.3f32..1.0, Just(1.0 / 512.0), Just(0.99)],
        )
            .prop_map(|(c, a)| (c.map(|c| c * f64::from(a)), f64::from(a)))
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

        /// Stacks deep enough that the transmittance passes 2^-1000 and, unflushed, sinks into
        /// subnormals: the f32 result is the same bits with and without setting it to 0.
        #[test]
        fn a_negligible_transmittance_never_changes_the_f32_result(
            stack in prop::collection::vec(fragment(), 500..3000),
            tint in [0.4f64..1.0, 0.4f64..1.0, 0.4f64..1.0],
            background in [colour(), colour(), colour()],
        ) {
            let scalar: Vec<([f64; 3], [f64; 3])> =
                stack.iter().map(|&(c, a)| (c, [1.0 - a; 3])).collect();
            let bits = |c: [f32; 3]| c.map(f32::to_bits);
            let flushed = composite_front_to_back(&stack, background).map(|c| c as f32);
            prop_assert_eq!(bits(flushed), bits(unflushed(&scalar, background)));
            // Per-channel transmittance, some channels far more opaque than others.
            let tinted: Vec<([f64; 3], [f64; 3])> = scalar
                .iter()
                .map(|&(c, t)| (c, std::array::from_fn(|k| t[k] * tint[k])))
                .collect();
            let flushed =
                composite_transmittance_front_to_back(&tinted, background).map(|c| c as f32);
            prop_assert_eq!(bits(flushed), bits(unflushed(&tinted, background)));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

        /// The step is the textbook `C += T·C_i; T *= keep` bit for bit: no fused
        /// multiply-add, no reassociation (the stored and in-order paths rely on it).
        #[test]
        fn the_step_is_the_plain_arithmetic(
            color in [colour(), colour(), colour()],
            premultiplied in [colour(), colour(), colour()],
            through in prop_oneof![Just(0.0), Just(1.0), 0.0f64..1.0, colour()],
            keep in prop_oneof![Just(0.0), Just(1.0), 0.0f64..1.0, -1e-7f64..0.0],
        ) {
            let (mut c, mut t) = (color, through);
            over_step::<false>(&mut c, &mut t, premultiplied, keep);
            let plain: [f64; 3] = std::array::from_fn(|k| color[k] + through * premultiplied[k]);
            prop_assert_eq!(c.map(f64::to_bits), plain.map(f64::to_bits));
            prop_assert_eq!(t.to_bits(), (through * keep).to_bits());
        }
    }

    #[test]
    fn the_negligible_transmittance_is_2_to_the_minus_1000() {
        assert_eq!(NEGLIGIBLE_TRANSMITTANCE, 2f64.powi(-1000));
        assert_eq!(negligible(2f64.powi(-1000)), 2f64.powi(-1000));
        assert_eq!(negligible(2f64.powi(-1001)), 0.0);
        // A stack of 0.5-alpha layers reaches it after 1001 layers.
        let stack = vec![([0.0; 3], 0.5); 1001];
        let mut c = [0.0; 3];
        let mut t = 1.0;
        for &(p, a) in &stack {
            over_step::<true>(&mut c, &mut t, p, 1.0 - a);
        }
        assert_eq!(t, 0.0);
    }
}
