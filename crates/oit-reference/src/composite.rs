//! Front-to-back compositing in f64: the one formula of the rendering model, for scalar alpha
//! and for coloured transmittance (of which scalar alpha is the case `t = 1 − α` in every
//! channel; both give the same bits there).

/// Composites premultiplied fragments, sorted front to back, over an opaque base colour:
/// `C = Σ_i C_i · T_i + T_n · C_o` with `T_i = Π_{j<i} (1 − α_j)`, in f64.
///
/// `fragments` are `(premultiplied RGB, alpha)` pairs, nearest first; `background` is the
/// colour of the nearest opaque surface, or the scene background. The reference uses exactly
/// this function per pixel, so GPU-side tests and closed-form checks can call it directly.
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
        over_step(&mut color, &mut transmittance, premultiplied, 1.0 - alpha);
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

/// One front-to-back step: `C += T·C_i`, then `T *= 1 − α_i` (`keep` = `1 − α_i`). The one
/// place this arithmetic is written: the stored path ([`composite_iter`]) and the in-order
/// path of the renderer both call it, so they give the same bits.
#[inline(always)]
pub(crate) fn over_step(
    color: &mut [f64; 3],
    transmittance: &mut f64,
    premultiplied: [f64; 3],
    keep: f64,
) {
    for k in 0..3 {
        color[k] += *transmittance * premultiplied[k];
    }
    *transmittance *= keep;
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
        transmittance[k] *= t[k];
    }
}
