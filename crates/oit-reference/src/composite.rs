//! Front-to-back compositing in f64: the one formula of the rendering model.

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
        for k in 0..3 {
            color[k] += transmittance * premultiplied[k];
        }
        transmittance *= 1.0 - alpha;
    }
    [
        color[0] + transmittance * background[0],
        color[1] + transmittance * background[1],
        color[2] + transmittance * background[2],
    ]
}
