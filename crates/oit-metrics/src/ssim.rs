//! SSIM (Wang, Bovik, Sheikh and Simoncelli 2004) on one channel, with the paper's constants:
//! an 11×11 Gaussian window of σ = 1.5 (normalised to sum 1), `K1 = 0.01`, `K2 = 0.03`,
//! dynamic range `L = 1`, and the weighted (population) variances of the paper's reference code.

use rayon::prelude::*;

/// Window radius: 11 taps.
const RADIUS: usize = 5;
const SIGMA: f64 = 1.5;
const C1: f64 = (0.01 * 1.0) * (0.01 * 1.0);
const C2: f64 = (0.03 * 1.0) * (0.03 * 1.0);

fn window() -> [f64; 2 * RADIUS + 1] {
    let mut w = [0.0; 2 * RADIUS + 1];
    for (i, v) in w.iter_mut().enumerate() {
        let x = i as f64 - RADIUS as f64;
        *v = (-(x * x) / (2.0 * SIGMA * SIGMA)).exp();
    }
    let sum: f64 = w.iter().sum();
    w.map(|v| v / sum)
}

/// Mean SSIM of `x` against `y` (row-major, `width·height` values each, nominally in [0, 1]).
///
/// The mean is over the pixels whose whole 11×11 window lies inside the image (the "valid"
/// region of the paper's reference code), so borders need no rule. An image narrower or shorter
/// than 11 pixels has no such pixel: then every pixel counts and the window reads outside the
/// image as the nearest edge pixel. Identical images score exactly 1. Empty images score 1.
/// The result is the same, bit for bit, however many threads compute it.
///
/// Panics if a slice does not hold `width·height` values.
pub fn ssim(x: &[f32], y: &[f32], width: usize, height: usize) -> f64 {
    assert_eq!(x.len(), width * height, "x size");
    assert_eq!(y.len(), width * height, "y size");
    if width == 0 || height == 0 {
        return 1.0;
    }
    let w = window();
    let taps = w.len();
    let valid = width >= taps && height >= taps;
    let (rows, cols) = if valid {
        (RADIUS..height - RADIUS, RADIUS..width - RADIUS)
    } else {
        (0..height, 0..width)
    };
    let count = (rows.len() * cols.len()) as f64;

    let (c0, c1) = (cols.start, cols.end);
    // Rows in parallel, their sums added in row order: a parallel `sum()` adds in an order that
    // depends on how the work was split, which moved the last digit between runs of one image.
    let row_sums: Vec<f64> = rows
        .into_par_iter()
        .map_init(
            || vec![0.0f64; 5 * (width + 2 * RADIUS) + 5 * width],
            |scratch, row| {
                let pw = width + 2 * RADIUS;
                let (padded, filtered) = scratch.split_at_mut(5 * pw);
                // Vertical pass first, straight from the images, into five padded rows:
                // x, y, x², y², xy.
                padded.fill(0.0);
                let (px, rest) = padded.split_at_mut(pw);
                let (py, rest) = rest.split_at_mut(pw);
                let (pxx, rest) = rest.split_at_mut(pw);
                let (pyy, pxy) = rest.split_at_mut(pw);
                for (k, &wk) in w.iter().enumerate() {
                    let yy = (row + k).saturating_sub(RADIUS).min(height - 1);
                    let (xs, ys) = (&x[yy * width..][..width], &y[yy * width..][..width]);
                    let lanes = px[RADIUS..RADIUS + width]
                        .iter_mut()
                        .zip(&mut py[RADIUS..RADIUS + width])
                        .zip(&mut pxx[RADIUS..RADIUS + width])
                        .zip(&mut pyy[RADIUS..RADIUS + width])
                        .zip(&mut pxy[RADIUS..RADIUS + width])
                        .zip(xs.iter().zip(ys));
                    for (((((mx, my), mxx), myy), mxy), (&a, &b)) in lanes {
                        let (a, b) = (f64::from(a), f64::from(b));
                        *mx += wk * a;
                        *my += wk * b;
                        *mxx += wk * a * a;
                        *myy += wk * b * b;
                        *mxy += wk * a * b;
                    }
                }
                // Clamp to the edge horizontally, then the horizontal pass per plane.
                for (plane, out) in padded.chunks_mut(pw).zip(filtered.chunks_mut(width)) {
                    let (first, last) = (plane[RADIUS], plane[RADIUS + width - 1]);
                    plane[..RADIUS].fill(first);
                    plane[RADIUS + width..].fill(last);
                    out.fill(0.0);
                    for (k, &wk) in w.iter().enumerate() {
                        for (o, &s) in out.iter_mut().zip(&plane[k..k + width]) {
                            *o += wk * s;
                        }
                    }
                }
                let f = |i: usize| &filtered[i * width..][c0..c1];
                let (mx, my, xx2, yy2, xy) = (f(0), f(1), f(2), f(3), f(4));
                let mut sum = 0.0;
                for i in 0..c1 - c0 {
                    let (mx, my) = (mx[i], my[i]);
                    let vx = xx2[i] - mx * mx;
                    let vy = yy2[i] - my * my;
                    let cov = xy[i] - mx * my;
                    sum += ((2.0 * mx * my + C1) * (2.0 * cov + C2))
                        / ((mx * mx + my * my + C1) * (vx + vy + C2));
                }
                sum
            },
        )
        .collect();
    row_sums.iter().sum::<f64>() / count
}
