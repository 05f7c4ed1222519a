//! Errors over time: what a person sees change between frames that the truth does not.
//!
//! With an exact reference for every frame, the error image of frame t is
//! `E_t = display(render_t) − display(reference_t)` per pixel and channel, in the display space
//! LDR-ꟻLIP compares (Reinhard tone map, then the sRGB transfer function, unquantised). From the
//! stream of `E_t` ([`PathTracker`]):
//!
//! | quantity | definition |
//! |----------|------------|
//! | flicker  | `sqrt(mean over t ≥ 1, pixels, channels of (E_t − E_{t−1})²)`: zero for a constant bias |
//! | change_t | `mean over pixels, channels of |E_t − E_{t−1}|` (t ≥ 1) |
//! | pop event | a frame whose change exceeds [`POP_MULTIPLE`] × the run's median change and [`POP_FLOOR`] |
//!
//! At a static camera, the frames of one scene rendered N times with fresh per-frame noise
//! ([`StaticTracker`]): the mean image's error (bias), the per-pixel standard deviation over
//! frames (noise) and their sum of squares, which equals the mean frame MSE (MSE = bias² +
//! variance, checked in the tests), plus the error of an exponential history `h_t = (1 − b)·h_{t−1}
//! + b·frame_t` (b = [`HISTORY_BLEND`], `h_0 = frame_0`) against the number of frames.

use oit_scene::LinearImage;

use crate::tonemap::{srgb_oetf, tone_map};

/// A frame's change must exceed this multiple of the run's median change to be a pop event.
pub const POP_MULTIPLE: f64 = 4.0;
/// ... and this absolute mean display-space change (a quarter of an 8-bit code step averaged
/// over the whole image), so that an exact technique's rounding never pops.
pub const POP_FLOOR: f64 = 1.0 / 1020.0;
/// The exponential history's blend weight, what engines and the spatiotemporal blue-noise
/// paper's figures use.
pub const HISTORY_BLEND: f64 = 0.1;

/// The display value of a linear channel: Reinhard, then sRGB, unquantised (LDR-ꟻLIP's input).
pub fn display(linear: f32) -> f32 {
    srgb_oetf(tone_map(linear))
}

/// `display` of every RGB channel, row-major.
pub fn display_image(image: &LinearImage) -> Vec<[f32; 3]> {
    image
        .pixels
        .iter()
        .map(|p| [display(p[0]), display(p[1]), display(p[2])])
        .collect()
}

/// `E = display(render) − display(reference)`; a non-finite channel counts as error 1.
pub fn error_image(render: &LinearImage, reference: &LinearImage) -> Vec<[f32; 3]> {
    render
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(r, x)| {
            std::array::from_fn(|c| {
                let e = display(r[c]) - display(x[c]);
                if e.is_finite() { e } else { 1.0 }
            })
        })
        .collect()
}

/// Streams the error images of a path, one frame at a time: memory is two images whatever the
/// length.
#[derive(Debug, Default)]
pub struct PathTracker {
    previous: Option<Vec<[f32; 3]>>,
    squared_change: f64,
    changed_samples: u64,
    /// `(frame, mean |E_t − E_{t−1}|)` for every frame after the first.
    changes: Vec<(u32, f64)>,
}

impl PathTracker {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds frame `frame`'s error image (frames in increasing order, the same size each).
    pub fn push(&mut self, frame: u32, error: Vec<[f32; 3]>) {
        if let Some(prev) = &self.previous {
            let mut abs = 0.0f64;
            for (a, b) in error.iter().zip(prev) {
                for c in 0..3 {
                    let d = f64::from(a[c]) - f64::from(b[c]);
                    self.squared_change += d * d;
                    abs += d.abs();
                }
            }
            let samples = error.len() as u64 * 3;
            self.changed_samples += samples;
            self.changes.push((frame, abs / samples.max(1) as f64));
        }
        self.previous = Some(error);
    }

    /// RMS of `E_t − E_{t−1}` over every pixel, channel and consecutive pair (0 with one frame).
    pub fn flicker(&self) -> f64 {
        if self.changed_samples == 0 {
            return 0.0;
        }
        (self.squared_change / self.changed_samples as f64).sqrt()
    }

    /// `(frame, mean |E_t − E_{t−1}|)` per frame after the first.
    pub fn changes(&self) -> &[(u32, f64)] {
        &self.changes
    }

    /// Frames whose change exceeds [`POP_MULTIPLE`] × the median change and [`POP_FLOOR`].
    pub fn pop_events(&self) -> Vec<u32> {
        pop_events(&self.changes)
    }
}

/// [`PathTracker::pop_events`] of a change series.
pub fn pop_events(changes: &[(u32, f64)]) -> Vec<u32> {
    let mut sorted: Vec<f64> = changes.iter().map(|c| c.1).collect();
    sorted.sort_by(f64::total_cmp);
    let Some(median) = median(&sorted) else {
        return Vec::new();
    };
    let threshold = (POP_MULTIPLE * median).max(POP_FLOOR);
    changes
        .iter()
        .filter(|c| c.1 > threshold)
        .map(|c| c.0)
        .collect()
}

fn median(sorted: &[f64]) -> Option<f64> {
    let n = sorted.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(sorted[n / 2]),
        _ => Some(0.5 * (sorted[n / 2 - 1] + sorted[n / 2])),
    }
}

/// Bias, noise and history convergence of one scene rendered repeatedly at a static camera,
/// in the display space of [`display`], against the one reference.
#[derive(Debug)]
pub struct StaticTracker {
    reference: Vec<[f32; 3]>,
    /// The first frame: sums are kept of the difference to it, so that a deterministic
    /// technique's variance is exactly 0 and no cancellation hides a small one.
    first: Vec<[f64; 3]>,
    sum: Vec<[f64; 3]>,
    sum_sq: Vec<[f64; 3]>,
    history: Option<Vec<[f64; 3]>>,
    frames: u32,
    frame_mse_sum: f64,
    /// RMSE of the history after 1, 2, … frames.
    history_rmse: Vec<f64>,
    /// RMSE of the plain mean of the first 1, 2, … frames.
    mean_rmse: Vec<f64>,
}

/// What [`StaticTracker::finish`] measured.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticStats {
    pub frames: u32,
    /// RMSE of the mean of all frames against the reference.
    pub bias_rmse: f64,
    /// RMS over pixels and channels of the per-pixel standard deviation over frames (the
    /// population one, so that `bias_rmse² + noise_rms² = mse` exactly).
    pub noise_rms: f64,
    /// Mean over frames of each frame's MSE.
    pub mse: f64,
    /// RMSE of the exponential history after 1, 2, … frames.
    pub history_rmse: Vec<f64>,
    /// RMSE of the plain mean of the first 1, 2, … frames.
    pub mean_rmse: Vec<f64>,
}

/// A display value as the static statistics count it: a non-finite one as 2, farther than any
/// finite display value (in [0, 1]) can be from the truth.
fn shown_value(v: f32) -> f64 {
    if v.is_finite() { f64::from(v) } else { 2.0 }
}

impl StaticTracker {
    pub fn new(reference: &LinearImage) -> Self {
        let n = reference.pixels.len();
        StaticTracker {
            reference: display_image(reference),
            first: Vec::new(),
            sum: vec![[0.0; 3]; n],
            sum_sq: vec![[0.0; 3]; n],
            history: None,
            frames: 0,
            frame_mse_sum: 0.0,
            history_rmse: Vec::new(),
            mean_rmse: Vec::new(),
        }
    }

    /// Adds the next frame's render.
    pub fn push(&mut self, render: &LinearImage) {
        let shown = display_image(render);
        let b = HISTORY_BLEND;
        let history = self
            .history
            .get_or_insert_with(|| shown.iter().map(|p| p.map(shown_value)).collect());
        let first = self.frames == 0;
        if first {
            self.first = history.clone();
        }
        let (mut frame_se, mut history_se, mut mean_se) = (0.0, 0.0, 0.0);
        let count = f64::from(self.frames + 1);
        for (i, p) in shown.iter().enumerate() {
            for c in 0..3 {
                let x = if p[c].is_finite() {
                    f64::from(p[c])
                } else {
                    2.0
                };
                let truth = f64::from(self.reference[i][c]);
                let d = x - self.first[i][c];
                self.sum[i][c] += d;
                self.sum_sq[i][c] += d * d;
                if !first {
                    history[i][c] = (1.0 - b) * history[i][c] + b * x;
                }
                frame_se += (x - truth).powi(2);
                history_se += (history[i][c] - truth).powi(2);
                mean_se += (self.first[i][c] + self.sum[i][c] / count - truth).powi(2);
            }
        }
        let samples = (shown.len() * 3).max(1) as f64;
        self.frames += 1;
        self.frame_mse_sum += frame_se / samples;
        self.history_rmse.push((history_se / samples).sqrt());
        self.mean_rmse.push((mean_se / samples).sqrt());
    }

    pub fn finish(self) -> StaticStats {
        let n = f64::from(self.frames.max(1));
        let samples = (self.reference.len() * 3).max(1) as f64;
        let (mut bias_se, mut variance) = (0.0, 0.0);
        for (i, truth) in self.reference.iter().enumerate() {
            for (c, truth) in truth.iter().enumerate() {
                let mean = self.sum[i][c] / n;
                bias_se += (self.first[i][c] + mean - f64::from(*truth)).powi(2);
                variance += (self.sum_sq[i][c] / n - mean * mean).max(0.0);
            }
        }
        StaticStats {
            frames: self.frames,
            bias_rmse: (bias_se / samples).sqrt(),
            noise_rms: (variance / samples).sqrt(),
            mse: self.frame_mse_sum / n,
            history_rmse: self.history_rmse,
            mean_rmse: self.mean_rmse,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(values: &[f32]) -> LinearImage {
        LinearImage {
            width: values.len() as u32,
            height: 1,
            pixels: values.iter().map(|&v| [v, v, v, 1.0]).collect(),
        }
    }

    #[test]
    fn a_constant_bias_has_no_flicker_and_a_jump_is_one_pop() {
        let reference = image(&[0.2, 0.4, 0.6, 0.8]);
        let mut steady = PathTracker::new();
        let mut jumpy = PathTracker::new();
        for t in 0..10u32 {
            steady.push(t, error_image(&image(&[0.3, 0.5, 0.7, 0.9]), &reference));
            // Exact until frame 6, then wrong on one pixel from there on.
            let wrong = if t >= 6 { 0.9 } else { 0.2 };
            jumpy.push(t, error_image(&image(&[wrong, 0.4, 0.6, 0.8]), &reference));
        }
        assert_eq!(steady.flicker(), 0.0);
        assert!(steady.pop_events().is_empty());
        assert!(jumpy.flicker() > 0.0);
        assert_eq!(jumpy.pop_events(), vec![6]);
        assert_eq!(jumpy.changes().len(), 9);
        assert_eq!(jumpy.changes()[0].0, 1);
    }

    #[test]
    fn changes_below_the_floor_never_pop() {
        let reference = image(&[0.5; 8]);
        let mut tiny = PathTracker::new();
        for t in 0..6u32 {
            let x = if t == 3 { 0.5 + 1e-4 } else { 0.5 };
            tiny.push(t, error_image(&image(&[x; 8]), &reference));
        }
        assert!(tiny.flicker() > 0.0);
        assert!(tiny.pop_events().is_empty(), "{:?}", tiny.changes());
    }

    #[test]
    fn mse_is_bias_squared_plus_variance_and_the_mean_of_noise_converges() {
        let reference = image(&[0.5; 64]);
        let mut noisy = StaticTracker::new(&reference);
        let mut biased = StaticTracker::new(&reference);
        let mut state = 7u64;
        for _ in 0..256 {
            let values: Vec<f32> = (0..64)
                .map(|_| {
                    state = state
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1);
                    0.5 + ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.2
                })
                .collect();
            noisy.push(&image(&values));
            biased.push(&image(&[0.6; 64]));
        }
        let noisy = noisy.finish();
        let biased = biased.finish();
        for s in [&noisy, &biased] {
            let sum = s.bias_rmse.powi(2) + s.noise_rms.powi(2);
            assert!((sum - s.mse).abs() <= 1e-9 * s.mse.max(1e-12), "{s:?}");
        }
        assert_eq!(biased.noise_rms, 0.0);
        assert!(biased.bias_rmse > 0.01, "{biased:?}");
        assert!(noisy.noise_rms > 10.0 * noisy.bias_rmse);
        // The plain mean of independent noise: RMSE ∝ 1/√N, a slope of −1/2 in log-log.
        let (a, b) = (noisy.mean_rmse[3], noisy.mean_rmse[255]);
        let slope = (b / a).ln() / (256.0f64 / 4.0).ln();
        assert!((-0.6..-0.4).contains(&slope), "slope {slope}");
        // The 0.1 history stops improving near its floor: worse than the 256-frame mean.
        assert!(noisy.history_rmse[255] > 2.0 * noisy.mean_rmse[255]);
    }
}
