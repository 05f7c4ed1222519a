//! ꟻLIP on floating-point input: LDR-ꟻLIP (Andersson et al. 2020) on linear RGB in [0, 1] and
//! HDR-ꟻLIP (Andersson et al. 2021) on linear HDR radiance, written from the two papers with the
//! constants and border rule of NVIDIA's reference implementation v1.6 (`FLIP.h`), so that the
//! two agree to float rounding (the crate docs give the measured agreement).
//!
//! The steps are listed on [`flip_ldr`].

use rayon::prelude::*;

mod fast;

/// π as the reference implementation rounds it (single precision).
const PI: f32 = std::f32::consts::PI;

/// Colour-error parameters of the ꟻLIP paper: `qc`, `pc`, `pt`.
const QC: f32 = 0.7;
const PC: f32 = 0.4;
const PT: f32 = 0.95;
/// Feature detector width in degrees and its exponent `qf`.
const FEATURE_WIDTH_DEG: f32 = 0.082;
const QF: f32 = 0.5;

/// Contrast sensitivity: the achromatic and red-green channels use one Gaussian `a1, b1`; the
/// blue-yellow channel a sum of two (`a1, b1` and `a2, b2`). Order: Y, Cx, Cz.
const CSF_A1: [f32; 3] = [1.0, 1.0, 34.1];
const CSF_B1: [f32; 3] = [0.0047, 0.0053, 0.04];
const CSF_A2: f32 = 13.5;
const CSF_B2: f32 = 0.025;
/// Largest scale parameter over all the CSF Gaussians: it sets the filter radius.
const CSF_B_MAX: f32 = 0.04;

/// D65 white in XYZ and its reciprocal, as the reference writes them.
const WHITE: [f32; 3] = [0.950_428_55, 1.0, 1.088_900_4];
const INV_WHITE: [f32; 3] = [1.052_156_9, 1.0, 0.918_357_7];

/// Linear sRGB → XYZ (D65), the exact rational matrix of the reference.
const RGB_TO_XYZ: [[f32; 3]; 3] = [
    [
        10_135_552.0 / 24_577_794.0,
        8_788_810.0 / 24_577_794.0,
        4_435_075.0 / 24_577_794.0,
    ],
    [
        2_613_072.0 / 12_288_897.0,
        8_788_810.0 / 12_288_897.0,
        887_015.0 / 12_288_897.0,
    ],
    [
        1_425_312.0 / 73_733_382.0,
        8_788_810.0 / 73_733_382.0,
        70_074_185.0 / 73_733_382.0,
    ],
];

/// XYZ (D65) → linear sRGB.
const XYZ_TO_RGB: [[f32; 3]; 3] = [
    [3.241_003_3, -1.537_398_9, -0.498_615_87],
    [-0.969_224_3, 1.875_930_1, 0.041_554_224],
    [0.055_639_423, -0.204_011_2, 1.057_148_9],
];

/// The ꟻLIP tool's default pixels per degree: a 0.7 m wide, 3840-pixel monitor seen from 0.7 m
/// (`pixels_per_degree(0.7, 3840.0, 0.7)` ≈ 67.0206). nv-flip's default is the rounded 67.0.
pub const DEFAULT_PPD: f32 = 0.7 * (3840.0 / 0.7) * (PI / 180.0);

/// Pixels per degree of visual angle for a monitor `monitor_width_m` wide with `width_px` columns
/// seen from `distance_m` (small-angle form, as the ꟻLIP tool computes it).
pub fn pixels_per_degree(distance_m: f32, width_px: f32, monitor_width_m: f32) -> f32 {
    distance_m * (width_px / monitor_width_m) * (PI / 180.0)
}

/// Luminance of linear sRGB (Rec. 709 weights), the one HDR-ꟻLIP uses for its exposure range.
pub fn luminance(rgb: [f32; 3]) -> f32 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// Coefficients `k` of the ACES fit `(k0x² + k1x + k2)/(k3x² + k4x + k5)` (Narkowicz) with the
/// 0.6 pre-exposure folded in, the HDR-ꟻLIP default tone mapper.
const ACES: [f32; 6] = [
    0.6 * 0.6 * 2.51,
    0.6 * 0.03,
    0.0,
    0.6 * 0.6 * 2.43,
    0.6 * 0.59,
    0.14,
];

/// HDR-ꟻLIP's tone mapper for one channel (not clamped: it exceeds 1 for large `x`).
pub fn aces(x: f32) -> f32 {
    let k = ACES;
    (x * x * k[0] + x * k[1] + k[2]) / (x * x * k[3] + x * k[4] + k[5])
}

/// The input the tone mapper maps to 0.85: the larger root of `T(x) = 0.85` (≈ 2.11887).
fn aces_x_at_085() -> f32 {
    let t = 0.85f32;
    let k = ACES;
    let (a, b, c) = (k[0] - t * k[3], k[1] - t * k[4], k[2] - t * k[5]);
    let mid = -0.5 * (b / a);
    mid + (mid * mid - c / a).sqrt()
}

/// The exposures HDR-ꟻLIP evaluates: `count` values evenly spaced from `start` to `stop`
/// (both included), as powers of two applied before the tone map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposures {
    pub start: f32,
    pub stop: f32,
    pub count: usize,
}

impl Exposures {
    /// The `i`-th exposure (in stops), `i < count`.
    pub fn get(&self, i: usize) -> f32 {
        let step = (self.stop - self.start) / (self.count - 1) as f32;
        self.start + i as f32 * step
    }
}

/// HDR-ꟻLIP's automatic exposure range, from the **reference** only.
///
/// With `x85` the radiance the ACES curve maps to 0.85, `Y_max` the largest luminance and
/// `Y_med` the upper median (element `n/2` of the sorted luminances, zeros included):
/// `start = log2(x85 / Y_max)`, `stop = log2(x85 / Y_med)`, `count = max(2, ceil(stop − start))`.
///
/// Pixels with a non-finite channel are left out and negative channels count as 0. Two cases the
/// reference implementation leaves undefined get a stated answer here:
/// - `Y_med = 0` (over half the reference is black; the reference's stop exposure is +∞): the
///   upper median of the **positive** luminances replaces it;
/// - no positive luminance at all (a black reference): one exposure, 0, evaluated twice
///   (`start = stop = 0`, `count = 2`).
pub fn hdr_exposures(reference: &[[f32; 3]]) -> Exposures {
    let mut lum: Vec<f32> = reference
        .iter()
        .filter(|p| p.iter().all(|c| c.is_finite()))
        .map(|p| luminance([p[0].max(0.0), p[1].max(0.0), p[2].max(0.0)]))
        .collect();
    let y_max = lum.iter().copied().fold(0.0f32, f32::max);
    if y_max <= 0.0 {
        return Exposures {
            start: 0.0,
            stop: 0.0,
            count: 2,
        };
    }
    let upper_median = |v: &mut Vec<f32>| {
        let mid = v.len() / 2;
        *v.select_nth_unstable_by(mid, f32::total_cmp).1
    };
    let mut y_med = upper_median(&mut lum);
    if y_med <= 0.0 {
        lum.retain(|&y| y > 0.0);
        y_med = upper_median(&mut lum);
    }
    let x85 = aces_x_at_085();
    let start = (x85 / y_max).log2();
    let stop = (x85 / y_med).log2();
    let count = (stop - start).ceil().max(2.0) as usize;
    Exposures { start, stop, count }
}

/// The separated filters at one pixels-per-degree, each a list of taps centred on its middle.
struct Filters {
    /// Contrast sensitivity, achromatic (Y) and red-green (Cx) channels.
    csf_y: Vec<f32>,
    csf_cx: Vec<f32>,
    /// Blue-yellow (Cz): the two separated halves of its sum of two Gaussians.
    csf_cz1: Vec<f32>,
    csf_cz2: Vec<f32>,
    /// Feature detectors: Gaussian, first and second derivative.
    gauss: Vec<f32>,
    d1: Vec<f32>,
    d2: Vec<f32>,
}

impl Filters {
    fn new(ppd: f32) -> Self {
        let pi2 = PI * PI;
        // Contrast sensitivity filters, sampled at 1/ppd degree per pixel.
        let rs = (3.0 * (CSF_B_MAX / (2.0 * pi2)).sqrt() * ppd).ceil() as usize;
        let gauss = |x2: f32, a: f32, b: f32| a * (PI / b).sqrt() * (-pi2 * x2 / b).exp();
        // The 2-D sum of two Gaussians separates into two products of "square-root" Gaussians.
        let gauss_half =
            |x2: f32, a: f32, b: f32| (a * (PI / b).sqrt()).sqrt() * (-pi2 * x2 / b).exp();
        let dx = 1.0 / ppd;
        let x2 = |i: usize| {
            let x = (i as f32 - rs as f32) * dx;
            x * x
        };
        let taps = 2 * rs + 1;
        let mut csf_y: Vec<f32> = (0..taps)
            .map(|i| gauss(x2(i), CSF_A1[0], CSF_B1[0]))
            .collect();
        let mut csf_cx: Vec<f32> = (0..taps)
            .map(|i| gauss(x2(i), CSF_A1[1], CSF_B1[1]))
            .collect();
        let mut csf_cz1: Vec<f32> = (0..taps)
            .map(|i| gauss_half(x2(i), CSF_A1[2], CSF_B1[2]))
            .collect();
        let mut csf_cz2: Vec<f32> = (0..taps)
            .map(|i| gauss_half(x2(i), CSF_A2, CSF_B2))
            .collect();
        let sum = |v: &[f32]| v.iter().sum::<f32>();
        let (sy, scx) = (sum(&csf_y), sum(&csf_cx));
        let scz = (sum(&csf_cz1).powi(2) + sum(&csf_cz2).powi(2)).sqrt();
        csf_y.iter_mut().for_each(|w| *w /= sy);
        csf_cx.iter_mut().for_each(|w| *w /= scx);
        csf_cz1.iter_mut().for_each(|w| *w /= scz);
        csf_cz2.iter_mut().for_each(|w| *w /= scz);

        // Feature detectors: Gaussian and its first two derivatives, in pixels.
        let sigma = 0.5 * FEATURE_WIDTH_DEG * ppd;
        let rf = (3.0 * sigma).ceil() as usize;
        let xs: Vec<f32> = (0..=2 * rf).map(|i| i as f32 - rf as f32).collect();
        let mut g: Vec<f32> = xs
            .iter()
            .map(|&x| (-(x * x) / (2.0 * sigma * sigma)).exp())
            .collect();
        let mut d1: Vec<f32> = xs.iter().zip(&g).map(|(&x, &g)| -x * g).collect();
        let mut d2: Vec<f32> = xs
            .iter()
            .zip(&g)
            .map(|(&x, &g)| (x * x / (sigma * sigma) - 1.0) * g)
            .collect();
        // Normalise: the Gaussian sums to 1; the positive and the negative lobes of each
        // derivative sum to +1 and −1.
        let g_sum = sum(&g);
        g.iter_mut().for_each(|w| *w /= g_sum);
        for d in [&mut d1, &mut d2] {
            let pos: f32 = d.iter().filter(|&&v| v > 0.0).sum();
            let neg: f32 = -d.iter().filter(|&&v| v <= 0.0).sum::<f32>();
            d.iter_mut()
                .for_each(|w| *w /= if *w > 0.0 { pos } else { neg });
        }
        Self {
            csf_y,
            csf_cx,
            csf_cz1,
            csf_cz2,
            gauss: g,
            d1,
            d2,
        }
    }

    /// The larger of the two radii: how far outside a row or strip the filters reach.
    fn radius(&self) -> usize {
        self.csf_y.len().max(self.gauss.len()) / 2
    }
}

#[inline(always)]
fn mat3(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// Linear RGB → `[Y, Cx, Cz, y]`: YCxCz and the achromatic channel scaled to [0, 1].
fn to_opponent(rgb: [f32; 3]) -> [f32; 4] {
    let xyz = mat3(&RGB_TO_XYZ, rgb);
    let (x, y, z) = (xyz[0] * INV_WHITE[0], xyz[1], xyz[2] * INV_WHITE[2]);
    let big_y = 116.0 * y - 16.0;
    let cx = 500.0 * (x - y);
    let cz = 200.0 * (y - z);
    // The feature detectors see the achromatic channel back in [0, 1] (= y, up to rounding).
    let gray = big_y * (1.0 / 116.0) + 16.0 / 116.0;
    [big_y, cx, cz, gray]
}

/// CIELab's companding function.
#[inline(always)]
fn lab_f(t: f32) -> f32 {
    const D: f32 = 6.0 / 29.0;
    if t > D * D * D {
        fast::cbrt(t)
    } else {
        t * (1.0 / (3.0 * D * D)) + 4.0 / 29.0
    }
}

/// Filtered YCxCz → clamped linear RGB → CIELab with the Hunt adjustment applied to a and b.
#[inline(always)]
fn filtered_to_hunt_lab(y: f32, cx: f32, cz: f32) -> [f32; 3] {
    let yy = (y + 16.0) / 116.0;
    let xyz = [
        (yy + cx / 500.0) * WHITE[0],
        yy,
        (yy - cz / 200.0) * WHITE[2],
    ];
    let rgb = mat3(&XYZ_TO_RGB, xyz).map(clamp01);
    let xyz = mat3(&RGB_TO_XYZ, rgb);
    let fx = lab_f(xyz[0] * INV_WHITE[0]);
    let fy = lab_f(xyz[1]);
    let fz = lab_f(xyz[2] * INV_WHITE[2]);
    let l = 116.0 * fy - 16.0;
    let a = 500.0 * (fx - fy);
    let b = 200.0 * (fy - fz);
    [l, 0.01 * l * a, 0.01 * l * b]
}

#[inline(always)]
fn hyab(p: [f32; 3], q: [f32; 3]) -> f32 {
    let (da, db) = (p[1] - q[1], p[2] - q[2]);
    (p[0] - q[0]).abs() + (da * da + db * db).sqrt()
}

/// Clamp to [0, 1]; NaN becomes 0 (as the reference's clamp does).
#[inline(always)]
fn clamp01(v: f32) -> f32 {
    if v > 0.0 { v.min(1.0) } else { 0.0 }
}

/// Constants of the colour-error remapping.
#[derive(Clone, Copy)]
struct ColorScale {
    cmax: f32,
    pccmax: f32,
}

impl ColorScale {
    fn new() -> Self {
        // The largest HyAB distance between colours of the gamut: pure green vs pure blue.
        let hunt = |rgb: [f32; 3]| {
            let xyz = mat3(&RGB_TO_XYZ, rgb);
            let fx = lab_f(xyz[0] * INV_WHITE[0]);
            let fy = lab_f(xyz[1]);
            let fz = lab_f(xyz[2] * INV_WHITE[2]);
            let l = 116.0 * fy - 16.0;
            [
                l,
                0.01 * l * 500.0 * (fx - fy),
                0.01 * l * 200.0 * (fy - fz),
            ]
        };
        let cmax = hyab(hunt([0.0, 1.0, 0.0]), hunt([0.0, 0.0, 1.0])).powf(QC);
        Self {
            cmax,
            pccmax: PC * cmax,
        }
    }

    /// HyAB^qc remapped to [0, 1]: [0, pc·cmax) → [0, pt), the rest → [pt, 1].
    #[inline(always)]
    fn remap(self, d: f32) -> f32 {
        let d = fast::pow(d, QC);
        if d < self.pccmax {
            d * (PT / self.pccmax)
        } else {
            PT + ((d - self.pccmax) / (self.cmax - self.pccmax)) * (1.0 - PT)
        }
    }
}

/// The filtered values ꟻLIP needs at one pixel of one image: YCxCz (Cz as its two separated
/// halves) and the first and second derivatives of the achromatic channel in x and y.
#[derive(Clone, Copy)]
struct Filtered {
    y: f32,
    cx: f32,
    cz1: f32,
    cz2: f32,
    dx: f32,
    ddx: f32,
    dy: f32,
    ddy: f32,
}

/// The ꟻLIP error of one pixel.
#[inline(always)]
fn pixel_error(r: Filtered, t: Filtered, scale: ColorScale) -> f32 {
    let lab_r = filtered_to_hunt_lab(r.y, r.cx, r.cz1 + r.cz2);
    let lab_t = filtered_to_hunt_lab(t.y, t.cx, t.cz1 + t.cz2);
    let color = scale.remap(hyab(lab_r, lab_t));

    let edge = |v: Filtered| (v.dx * v.dx + v.dy * v.dy).sqrt();
    let point = |v: Filtered| (v.ddx * v.ddx + v.ddy * v.ddy).sqrt();
    let de = (edge(r) - edge(t)).abs();
    let dp = (point(r) - point(t)).abs();
    // qf = 0.5: the power is a square root.
    const _: () = assert!(QF == 0.5);
    let feature = (std::f32::consts::FRAC_1_SQRT_2 * de.max(dp)).sqrt();
    fast::pow(color, 1.0 - feature)
}

/// `out = Σₖ taps[k] · src[k..k + out.len()]`: one filter along a padded row. `src` must hold
/// `out.len() + taps.len() − 1` values.
fn convolve_row(out: &mut [f32], src: &[f32], taps: &[f32]) {
    let n = out.len();
    out.fill(0.0);
    for (k, &w) in taps.iter().enumerate() {
        for (o, &s) in out.iter_mut().zip(&src[k..k + n]) {
            *o += w * s;
        }
    }
}

/// Rows processed per strip: bounds the intermediate memory on large images (the vertical pass
/// of a strip needs its rows plus `radius` rows of context on each side).
const STRIP_ROWS: usize = 256;

/// Planes the horizontal pass leaves per image row: Y, Cx, Cz¹, Cz² after their contrast
/// filters, and the achromatic channel after g′, g″ and g.
const H_PLANES: usize = 7;
/// Planes the vertical pass accumulates per image row: Y, Cx, Cz¹, Cz², dx, ddx, dy, ddy.
const V_PLANES: usize = 8;

/// The LDR-ꟻLIP error map of two images given as linear RGB pixels (row-major, `width·height`
/// each). `prepare` turns each input pixel into the linear RGB in [0, 1] that ꟻLIP evaluates.
fn flip_map_with<F>(
    reference: &[[f32; 3]],
    test: &[[f32; 3]],
    width: usize,
    height: usize,
    ppd: f32,
    prepare: F,
) -> Vec<f32>
where
    F: Fn([f32; 3]) -> [f32; 3] + Sync,
{
    assert_eq!(reference.len(), width * height, "reference size");
    assert_eq!(test.len(), width * height, "test size");
    let mut out = vec![0.0f32; width * height];
    if width == 0 || height == 0 {
        return out;
    }
    let f = Filters::new(ppd);
    let scale = ColorScale::new();
    let r = f.radius();
    let w = width;

    for strip_start in (0..height).step_by(STRIP_ROWS) {
        let strip_end = (strip_start + STRIP_ROWS).min(height);
        // Rows the vertical taps of this strip can reach, after clamping to the image.
        let lo = strip_start.saturating_sub(r);
        let hi = (strip_end + r).min(height);

        // Horizontal pass over rows lo..hi. Each row holds H_PLANES planes of `w` values for
        // the reference, then as many for the test image.
        let row_len = 2 * H_PLANES * w;
        let mut horiz = vec![0.0f32; (hi - lo) * row_len];
        horiz.par_chunks_mut(row_len).enumerate().for_each_init(
            || vec![0.0f32; 4 * (w + 2 * r)],
            |padded, (i, row_out)| {
                let y = lo + i;
                let pw = w + 2 * r;
                for (image, dst) in [reference, test]
                    .into_iter()
                    .zip(row_out.chunks_mut(H_PLANES * w))
                {
                    let src = &image[y * w..(y + 1) * w];
                    // Opponent values of the row, extended by clamping to the edge.
                    for j in 0..pw {
                        let v = to_opponent(prepare(src[j.saturating_sub(r).min(w - 1)]));
                        for (c, &v) in v.iter().enumerate() {
                            padded[c * pw + j] = v;
                        }
                    }
                    let plane = |c: usize| &padded[c * pw..(c + 1) * pw];
                    let mut dst = dst.chunks_mut(w);
                    let mut conv = |src: &[f32], taps: &[f32]| {
                        // Filters shorter than the common radius start further in.
                        let off = r - taps.len() / 2;
                        convolve_row(
                            dst.next().expect("one destination row per filter"),
                            &src[off..],
                            taps,
                        );
                    };
                    conv(plane(0), &f.csf_y);
                    conv(plane(1), &f.csf_cx);
                    conv(plane(2), &f.csf_cz1);
                    conv(plane(2), &f.csf_cz2);
                    conv(plane(3), &f.d1);
                    conv(plane(3), &f.d2);
                    conv(plane(3), &f.gauss);
                }
            },
        );

        // Vertical pass and the per-pixel error, one output row at a time.
        out[strip_start * w..strip_end * w]
            .par_chunks_mut(w)
            .enumerate()
            .for_each_init(
                || vec![0.0f32; 2 * V_PLANES * w],
                |acc, (i, row_out)| {
                    let y = strip_start + i;
                    acc.fill(0.0);
                    for (side, acc) in acc.chunks_mut(V_PLANES * w).enumerate() {
                        let mut acc = acc.chunks_mut(w);
                        // Accumulate horizontal plane `plane` with `taps` into the next output.
                        let mut vert = |plane: usize, taps: &[f32]| {
                            let a = acc.next().expect("one accumulator row per vertical filter");
                            let half = taps.len() / 2;
                            for (k, &wk) in taps.iter().enumerate() {
                                let yy = (y + k).saturating_sub(half).min(height - 1) - lo;
                                let start = yy * row_len + (side * H_PLANES + plane) * w;
                                for (o, &s) in a.iter_mut().zip(&horiz[start..start + w]) {
                                    *o += wk * s;
                                }
                            }
                        };
                        vert(0, &f.csf_y);
                        vert(1, &f.csf_cx);
                        vert(2, &f.csf_cz1);
                        vert(3, &f.csf_cz2);
                        vert(4, &f.gauss);
                        vert(5, &f.gauss);
                        vert(6, &f.d1);
                        vert(6, &f.d2);
                    }
                    let (r_acc, t_acc) = acc.split_at(V_PLANES * w);
                    let rp: [&[f32]; V_PLANES] = std::array::from_fn(|c| &r_acc[c * w..][..w]);
                    let tp: [&[f32]; V_PLANES] = std::array::from_fn(|c| &t_acc[c * w..][..w]);
                    // Blocks of LANES pixels copied into fixed-size arrays: with no bounds to
                    // check and only arithmetic inside, the per-pixel loop vectorises.
                    const LANES: usize = 8;
                    for (b, out_block) in row_out[..w].chunks_mut(LANES).enumerate() {
                        let (x0, n) = (b * LANES, out_block.len());
                        let mut rv = [[0.0f32; LANES]; V_PLANES];
                        let mut tv = [[0.0f32; LANES]; V_PLANES];
                        for c in 0..V_PLANES {
                            rv[c][..n].copy_from_slice(&rp[c][x0..x0 + n]);
                            tv[c][..n].copy_from_slice(&tp[c][x0..x0 + n]);
                        }
                        let at = |v: &[[f32; LANES]; V_PLANES], j: usize| Filtered {
                            y: v[0][j],
                            cx: v[1][j],
                            cz1: v[2][j],
                            cz2: v[3][j],
                            dx: v[4][j],
                            ddx: v[5][j],
                            dy: v[6][j],
                            ddy: v[7][j],
                        };
                        let mut ov = [0.0f32; LANES];
                        for (j, o) in ov.iter_mut().enumerate() {
                            *o = pixel_error(at(&rv, j), at(&tv, j), scale);
                        }
                        out_block.copy_from_slice(&ov[..n]);
                    }
                },
            );
    }
    out
}

/// LDR-ꟻLIP error map (one value in [0, 1] per pixel, row-major) of `test` against `reference`,
/// both linear RGB, `width·height` pixels each. Channels are clamped to [0, 1] first (NaN → 0),
/// as the reference implementation does in LDR mode. `ppd`: see [`DEFAULT_PPD`].
///
/// Pipeline of one LDR evaluation, both images at once:
///
/// 1. linear RGB (clamped to [0, 1]) → CIE XYZ (D65) → YCxCz (opponent space, linear in XYZ);
/// 2. the contrast-sensitivity filters, one Gaussian per achromatic / red-green channel and a sum of
///    two for blue-yellow, applied separably (the sum as two separated halves) at the viewing
///    distance's pixels per degree;
/// 3. back to linear RGB, clamp to [0, 1], → CIELab, Hunt adjustment (`a, b ← 0.01·L·a, b`),
///    HyAB distance, raised to `qc = 0.7` and remapped so that `pc = 0.4` of the largest possible
///    distance (green vs blue) lands at `pt = 0.95`: the colour error `ec` in [0, 1];
/// 4. on the achromatic channel scaled to [0, 1], first and second derivatives of a Gaussian of
///    standard deviation `0.5·0.082·ppd` pixels give edge and point strength; the feature error is
///    `ef = (max(|Δedge|, |Δpoint|)/√2)^qf`, `qf = 0.5`;
/// 5. the ꟻLIP error is `ec^(1 − ef)`.
///
/// Every filter reads outside the image as the nearest edge pixel (clamp to edge), as the
/// reference implementation does.
///
/// Panics if a slice does not hold `width·height` pixels.
pub fn flip_ldr(
    reference: &[[f32; 3]],
    test: &[[f32; 3]],
    width: usize,
    height: usize,
    ppd: f32,
) -> Vec<f32> {
    flip_map_with(reference, test, width, height, ppd, |p| p.map(clamp01))
}

/// An HDR-ꟻLIP result: the per-pixel error map and the exposures it took the maximum over.
#[derive(Debug, Clone, PartialEq)]
pub struct HdrFlip {
    pub map: Vec<f32>,
    pub exposures: Exposures,
}

/// The colour a pixel with a non-finite channel takes in every HDR-ꟻLIP exposure (cyan, as in
/// previews: see [`crate::NONFINITE_SRGB8`]).
const NONFINITE_LINEAR: [f32; 3] = [0.0, 1.0, 1.0];

/// HDR-ꟻLIP error map of `test` against `reference`, both linear HDR RGB.
///
/// For each exposure `c` of [`hdr_exposures`]`(reference)`: both images are scaled by `2^c`,
/// tone mapped per channel with [`aces`], clamped to [0, 1] and compared with LDR-ꟻLIP; each
/// pixel keeps its largest error over the exposures. Negative channels are taken as 0 before the
/// exposure (ACES maps negative input to positive output); a pixel with a NaN or infinite channel
/// is cyan in every exposure.
///
/// Panics if a slice does not hold `width·height` pixels.
pub fn flip_hdr(
    reference: &[[f32; 3]],
    test: &[[f32; 3]],
    width: usize,
    height: usize,
    ppd: f32,
) -> HdrFlip {
    let exposures = hdr_exposures(reference);
    let mut map = vec![0.0f32; width * height];
    for i in 0..exposures.count {
        let gain = 2f32.powf(exposures.get(i));
        let ldr = flip_map_with(reference, test, width, height, ppd, |p| {
            if p.iter().all(|c| c.is_finite()) {
                p.map(|c| clamp01(aces(c.max(0.0) * gain)))
            } else {
                NONFINITE_LINEAR
            }
        });
        for (m, e) in map.iter_mut().zip(ldr) {
            if e > *m {
                *m = e;
            }
        }
    }
    HdrFlip { map, exposures }
}

/// Arithmetic mean of an error map in f64 (0 for an empty map).
pub fn mean(map: &[f32]) -> f64 {
    if map.is_empty() {
        return 0.0;
    }
    map.iter().map(|&v| f64::from(v)).sum::<f64>() / map.len() as f64
}
