//! The float ꟻLIP port: against nv-flip (the C++ ꟻLIP v1.2 on sRGB8, wrapped by the `nv-flip`
//! crate) on 8-bit input, and on the properties issue 10 asks for (no quantisation floor, HDR
//! error seen by HDR-ꟻLIP). The cross-check against NVIDIA's Python `flip-evaluator` (v1.6+) on
//! float input is `xtask/flip-check/check.py`.

use oit_metrics::{
    DEFAULT_PPD, LinearImage, aces, compare, encode_srgb8, flip_hdr, flip_ldr, flip_map_mean,
    hdr_exposures, pixels_per_degree, preview_srgb8, tone_map,
};

/// Deterministic pseudo-random numbers in [0, 1) (64-bit LCG, top 24 bits).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// sRGB8 code → linear, the decoding ꟻLIP v1.2 applies to its 8-bit input (single precision).
fn srgb8_to_linear(v: u8) -> f32 {
    let s = f32::from(v) / 255.0;
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

fn nv_flip_map(reference: &[[u8; 3]], test: &[[u8; 3]], w: u32, h: u32, ppd: f32) -> Vec<f32> {
    let image = |p: &[[u8; 3]]| {
        nv_flip::FlipImageRgb8::with_data(w, h, &p.iter().flatten().copied().collect::<Vec<_>>())
    };
    nv_flip::flip(image(reference), image(test), ppd).to_vec()
}

/// Smooth gradients, a hard-edged square and 8-bit noise: exercises colour, edges and points.
fn srgb8_scene(rng: &mut Lcg, w: usize, h: usize, noise: f32) -> Vec<[u8; 3]> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            let inside =
                (w / 4..3 * w / 4).contains(&(i % w)) && (h / 3..2 * h / 3).contains(&(i / w));
            let base = if inside {
                [0.9, 0.2, 0.1]
            } else {
                [x / w as f32, y / h as f32, 0.5 + 0.4 * (x * 0.3).sin()]
            };
            base.map(|c| ((c + noise * (rng.next() - 0.5)).clamp(0.0, 1.0) * 255.0).round() as u8)
        })
        .collect()
}

#[test]
fn default_ppd_is_the_flip_tools() {
    assert_eq!(pixels_per_degree(0.7, 3840.0, 0.7), DEFAULT_PPD);
    assert!((f64::from(DEFAULT_PPD) - 3840.0 * std::f64::consts::PI / 180.0).abs() < 1e-4);
}

#[test]
fn matches_nv_flip_on_8bit_input() {
    let mut rng = Lcg(7);
    let mut worst_pixel = 0.0f32;
    let mut worst_mean = 0.0f64;
    for (w, h) in [(64usize, 48usize), (37, 23), (5, 3), (1, 1)] {
        let reference = srgb8_scene(&mut rng, w, h, 0.1);
        let test = srgb8_scene(&mut rng, w, h, 0.3);
        let lin =
            |p: &[[u8; 3]]| -> Vec<[f32; 3]> { p.iter().map(|c| c.map(srgb8_to_linear)).collect() };
        let ours = flip_ldr(&lin(&reference), &lin(&test), w, h, 67.0);
        let theirs = nv_flip_map(&reference, &test, w as u32, h as u32, 67.0);
        let max_pixel = ours
            .iter()
            .zip(&theirs)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        let mean_diff = (flip_map_mean(&ours) - flip_map_mean(&theirs)).abs();
        println!(
            "{w}x{h}: mean ours {:.6} nv-flip {:.6}, |mean diff| {mean_diff:.2e}, max pixel diff {max_pixel:.2e}",
            flip_map_mean(&ours),
            flip_map_mean(&theirs)
        );
        worst_pixel = worst_pixel.max(max_pixel);
        worst_mean = worst_mean.max(mean_diff);
    }
    assert!(worst_mean < 1e-5, "mean differs by {worst_mean}");
    assert!(worst_pixel < 1e-3, "a pixel differs by {worst_pixel}");
}

fn flat(w: u32, h: u32, v: f32) -> LinearImage {
    LinearImage::new(w, h, [v, v, v, 1.0])
}

/// The mean ꟻLIP the crate reported before issue 10: nv-flip on the tone-mapped sRGB8 previews.
fn quantised_flip(render: &LinearImage, reference: &LinearImage) -> f64 {
    let (a, b) = (
        preview_srgb8(reference).unwrap(),
        preview_srgb8(render).unwrap(),
    );
    let map = nv_flip_map(&a.pixels, &b.pixels, a.width, a.height, 67.0);
    flip_map_mean(&map)
}

#[test]
fn flat_field_offset_has_no_quantisation_floor() {
    for base in [0.02f32, 0.1, 0.18, 0.5, 0.9, 2.0] {
        let reference = flat(64, 64, base);
        let mut row = format!("flat {base}:");
        let mut previous: Option<f64> = None;
        for d in [1e-3f32, 1e-4, 1e-5] {
            let render = flat(64, 64, base + d);
            let e = compare(&render, &reference).unwrap();
            let before = quantised_flip(&render, &reference);
            row += &format!(" +{d:e}: {:.2e} (sRGB8 {before:.2e})", e.flip_mean);
            assert!(
                e.flip_mean > 0.0,
                "base {base} + {d}: a real difference scores above 0"
            );
            // ꟻLIP grows like (colour distance)^0.7: a tenth of the offset, about a fifth of the
            // score. With the 8-bit floor it stayed at one code's worth or dropped to 0.
            if let Some(p) = previous {
                let ratio = e.flip_mean / p;
                // (0.1^0.7 = 0.1995; f32 rounding of a 1e-5 step on 2.0 moves it by a few %.)
                assert!(
                    (0.17..0.27).contains(&ratio),
                    "base {base} + {d}: ratio {ratio}"
                );
            }
            previous = Some(e.flip_mean);
        }
        println!("{row}");
    }
}

#[test]
fn one_code_step_no_longer_reads_as_a_visible_error() {
    // A mid-grey flat field whose 1e-4 offset crosses an sRGB8 code boundary: the 8-bit
    // pipeline saw a whole code step there (issue 10: ≈ 0.035), the float one sees 1e-4.
    let mut base = 0.4f32;
    while encode_srgb8(tone_map(base)) == encode_srgb8(tone_map(base + 1e-4)) {
        base += 1e-5;
    }
    let (reference, render) = (flat(64, 64, base), flat(64, 64, base + 1e-4));
    let before = quantised_flip(&render, &reference);
    let after = compare(&render, &reference).unwrap().flip_mean;
    println!("flat {base} + 1e-4 across a code boundary: sRGB8 {before:.4}, float {after:.2e}");
    assert!(before > 0.02, "before {before}");
    assert!(after < 1.5e-3, "after {after}");
}

#[test]
fn identical_images_score_zero_everywhere() {
    let mut rng = Lcg(3);
    let mut image = LinearImage::new(40, 30, [0.0; 4]);
    for p in &mut image.pixels {
        *p = [rng.next() * 4.0, rng.next(), rng.next() * 100.0, 1.0];
    }
    let e = compare(&image, &image).unwrap();
    assert_eq!(e.flip_mean, 0.0);
    assert_eq!(e.hdr_flip_mean, Some(0.0));
    assert_eq!((e.relmse, e.ssim), (0.0, 1.0));
}

#[test]
fn a_large_difference_scores_large() {
    // Black against white: the largest colour difference there is.
    let e = compare(&flat(32, 32, 1.0), &flat(32, 32, 0.0)).unwrap();
    println!("black vs white: flip {}", e.flip_mean);
    assert!(e.flip_mean > 0.7, "{e:?}");
    let map = flip_ldr(
        &[[0.0, 1.0, 0.0]; 64],
        &[[0.0, 0.0, 1.0]; 64],
        8,
        8,
        DEFAULT_PPD,
    );
    // Green vs blue is the distance ꟻLIP normalises by: exactly 1 on a flat field.
    assert!(map.iter().all(|&v| (v - 1.0).abs() < 1e-5), "{map:?}");
}

#[test]
fn hdr_flip_sees_what_reinhard_hides() {
    // An emissive-like scene: dim background, highlights of 10..1000, and a render whose
    // highlights are 40 % too dark. Reinhard squeezes 10..1000 into [0.91, 1), so LDR-ꟻLIP
    // barely moves; HDR-ꟻLIP exposes the highlights down into the tone curve's range.
    let (w, h) = (64u32, 64u32);
    let mut reference = flat(w, h, 0.05);
    let mut render = reference.clone();
    for y in 0..h as usize {
        for x in 0..w as usize {
            if (x / 8 + y / 8) % 3 == 0 {
                let v = 10.0 * 100f32.powf(x as f32 / w as f32);
                reference.pixels[y * w as usize + x] = [v, v * 0.8, v * 0.5, 1.0];
                render.pixels[y * w as usize + x] = [v * 0.6, v * 0.48, v * 0.3, 1.0];
            }
        }
    }
    let e = compare(&render, &reference).unwrap();
    println!("{e:?}");
    assert!(e.hdr);
    let hdr = e.hdr_flip_mean.unwrap();
    assert!(hdr > 5.0 * e.flip_mean, "hdr {hdr} vs ldr {}", e.flip_mean);
    assert_eq!(e.headline_flip(), (hdr, "HDR-FLIP"));
    assert!(e.relmse > 0.05, "relmse {}", e.relmse);
}

#[test]
fn exposure_range_follows_the_reference() {
    // ACES maps its x85 to 0.85.
    let e = hdr_exposures(&[[1.0, 1.0, 1.0]; 3]);
    let x85 = 2f32.powf(e.start);
    assert!((aces(x85) - 0.85).abs() < 1e-6, "{e:?}");
    assert!((x85 - 2.118_87).abs() < 1e-4, "{e:?}");
    assert_eq!((e.start, e.stop, e.count), (e.start, e.start, 2));

    // Max 1000, upper median 1 (element 3 of 0.5, 0.5, 0.5, 1, 1, 1000): start
    // log2(x85/1000), stop log2(x85), 10 exposures.
    let mut px = vec![[0.5f32; 3]; 3];
    px.extend([[1.0; 3], [1.0; 3], [1000.0; 3]]);
    let e = hdr_exposures(&px);
    assert!((e.stop - x85.log2()).abs() < 1e-5, "{e:?}");
    assert!((e.stop - e.start - 1000f32.log2()).abs() < 1e-4, "{e:?}");
    assert_eq!(e.count, 10);

    // Mostly black: the median of the positive luminances stands in for 0.
    let mut px = vec![[0.0f32; 3]; 10];
    px.extend([[2.0; 3], [4.0; 3], [8.0; 3]]);
    let e = hdr_exposures(&px);
    assert!((e.stop - (x85 / 4.0).log2()).abs() < 1e-5, "{e:?}");
    assert_eq!(e.count, 2);

    // All black, NaN and negative are ignored: one exposure, 0.
    let e = hdr_exposures(&[[0.0; 3], [-1.0; 3], [f32::NAN, 1.0, 1.0]]);
    assert_eq!((e.start, e.stop, e.count), (0.0, 0.0, 2));
}

#[test]
fn hdr_flip_of_identical_images_with_nonfinite_pixels_is_zero() {
    let mut image = vec![[3.0f32, 0.5, -2.0]; 100];
    image[17] = [f32::NAN, 0.0, 0.0];
    image[42] = [f32::INFINITY, 1.0, 1.0];
    let r = flip_hdr(&image, &image, 10, 10, DEFAULT_PPD);
    assert!(r.map.iter().all(|&v| v == 0.0));
}
