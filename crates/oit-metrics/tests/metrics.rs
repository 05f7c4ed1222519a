//! `compare`, `diff_image` and `heatmap` against numbers worked out by hand.

use oit_metrics::{
    Errors, LinearImage, MetricsError, NONFINITE_SRGB8, PSNR_CAP, compare, diff_image, error_color,
    heatmap,
};

/// A deterministic image with varied LDR and HDR content; every value a multiple of 2⁻¹⁰ so
/// that adding a power-of-two offset is exact in f32.
fn pattern(width: u32, height: u32) -> LinearImage {
    let mut image = LinearImage::new(width, height, [0.0; 4]);
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize;
            let r = ((x * 37 + y * 11) % 1024) as f32 / 1024.0;
            let g = ((x * 5 + y * 91) % 1024) as f32 / 1024.0;
            let b = if (x / 8 + y / 8) % 2 == 0 { 4.0 } else { 0.125 };
            image.pixels[i] = [r, g, b, 0.5];
        }
    }
    image
}

fn offset(image: &LinearImage, d: f32) -> LinearImage {
    let mut out = image.clone();
    for p in &mut out.pixels {
        p[0] += d;
        p[1] += d;
        p[2] += d;
    }
    out
}

#[test]
fn identical_images_have_zero_error() {
    let a = pattern(64, 48);
    let e = compare(&a, &a).unwrap();
    assert_eq!(
        e,
        Errors {
            rmse: 0.0,
            psnr: PSNR_CAP,
            mean_abs: 0.0,
            max_abs: 0.0,
            max_relative: 0.0,
            over_1_255: 0.0,
            over_1_64: 0.0,
            flip_mean: 0.0,
            nonfinite: 0,
            // The pattern's blue channel reaches 4: an HDR reference.
            hdr: true,
            hdr_flip_mean: Some(0.0),
            relmse: 0.0,
            ssim: 1.0,
        }
    );
}

#[test]
fn alpha_is_ignored() {
    let a = pattern(16, 16);
    let mut b = a.clone();
    for p in &mut b.pixels {
        p[3] = f32::NAN;
    }
    let e = compare(&b, &a).unwrap();
    assert_eq!(
        (e.rmse, e.max_abs, e.nonfinite, e.flip_mean),
        (0.0, 0.0, 0, 0.0)
    );
}

#[test]
fn constant_power_of_two_offset_is_exact() {
    let reference = pattern(64, 64);
    let d = 1.0f32 / 128.0; // 0.0078125: between 1/255 and 1/64
    let render = offset(&reference, d);
    let e = compare(&render, &reference).unwrap();
    let d = f64::from(d);
    assert_eq!(e.rmse, d);
    assert_eq!(e.mean_abs, d);
    assert_eq!(e.max_abs, d);
    assert!(
        (e.psnr - 20.0 * 128f64.log10()).abs() < 1e-12,
        "psnr {}",
        e.psnr
    );
    assert!(
        (e.psnr - 42.144_199_392_957_4).abs() < 1e-9,
        "psnr {}",
        e.psnr
    );
    assert_eq!(e.over_1_255, 1.0);
    assert_eq!(e.over_1_64, 0.0);
    assert_eq!(e.nonfinite, 0);
}

#[test]
fn constant_offset_either_sign() {
    // d = 0.05 from a base of 0.5 (f32 rounding of the sum stays below 3e-8).
    let reference = LinearImage::new(32, 32, [0.5, 0.5, 0.5, 1.0]);
    for d in [0.05f32, -0.05] {
        let render = offset(&reference, d);
        let e = compare(&render, &reference).unwrap();
        for (name, v) in [
            ("rmse", e.rmse),
            ("mean_abs", e.mean_abs),
            ("max_abs", e.max_abs),
        ] {
            assert!((v - 0.05).abs() < 3e-8, "{name} = {v} for d = {d}");
        }
        // −20·log10(0.05) = 26.0206 dB
        assert!(
            (e.psnr - 26.020_599_913_279_62).abs() < 1e-5,
            "psnr {}",
            e.psnr
        );
        assert_eq!((e.over_1_255, e.over_1_64), (1.0, 1.0));
    }
}

#[test]
fn psnr_below_one_and_large_errors() {
    let reference = LinearImage::new(8, 8, [0.0, 0.0, 0.0, 1.0]);
    let render = LinearImage::new(8, 8, [10.0, 10.0, 10.0, 1.0]);
    let e = compare(&render, &reference).unwrap();
    assert_eq!(e.rmse, 10.0);
    assert!((e.psnr + 20.0).abs() < 1e-12, "psnr {}", e.psnr);
}

#[test]
fn one_nan_pixel_is_counted_and_excluded() {
    let reference = pattern(16, 16);
    let d = 1.0f32 / 256.0; // over 1/255? 1/256 < 1/255: no
    let mut render = offset(&reference, d);
    render.pixels[3 * 16 + 5][1] = f32::NAN;
    let e = compare(&render, &reference).unwrap();
    assert_eq!(e.nonfinite, 1);
    assert_eq!(e.rmse, f64::from(d));
    assert_eq!(e.mean_abs, f64::from(d));
    assert_eq!(e.max_abs, f64::from(d));
    assert_eq!(e.over_1_255, 1.0 / 256.0);
    assert_eq!(e.over_1_64, 1.0 / 256.0);
    assert!(e.psnr.is_finite() && e.psnr > 40.0, "psnr {}", e.psnr);
    assert!(
        e.flip_mean.is_finite() && e.flip_mean > 0.0,
        "flip {}",
        e.flip_mean
    );
    // And JSON stays plain numbers.
    let json = serde_json::to_string(&e).unwrap();
    assert!(!json.contains("null"), "{json}");
}

#[test]
fn infinities_count_as_nonfinite_too() {
    let reference = LinearImage::new(8, 8, [0.25, 0.25, 0.25, 1.0]);
    let mut render = reference.clone();
    render.pixels[0][0] = f32::INFINITY;
    render.pixels[9][2] = f32::NEG_INFINITY;
    render.pixels[10] = [f32::NAN; 4];
    let e = compare(&render, &reference).unwrap();
    assert_eq!(e.nonfinite, 3);
    assert_eq!((e.rmse, e.max_abs, e.psnr), (0.0, 0.0, PSNR_CAP));
    assert_eq!(e.over_1_255, 3.0 / 64.0);
}

#[test]
fn all_pixels_nonfinite_still_gives_finite_numbers() {
    let reference = LinearImage::new(4, 4, [0.25, 0.25, 0.25, 1.0]);
    let render = LinearImage::new(4, 4, [f32::NAN; 4]);
    let e = compare(&render, &reference).unwrap();
    assert_eq!(e.nonfinite, 16);
    assert_eq!(
        (e.rmse, e.mean_abs, e.max_abs, e.psnr),
        (0.0, 0.0, 0.0, PSNR_CAP)
    );
    assert_eq!((e.over_1_255, e.over_1_64), (1.0, 1.0));
    assert!(e.flip_mean.is_finite());
}

/// Fraction of the 8×8 image over each threshold when one pixel's green channel is `a` in the
/// render and `b` in the reference and everything else is equal.
fn one_pixel(a: f32, b: f32) -> (f64, f64) {
    let mut reference = LinearImage::new(8, 8, [0.2, b, 0.2, 1.0]);
    for (i, p) in reference.pixels.iter_mut().enumerate() {
        p[1] = if i == 27 { b } else { 0.3 };
    }
    let mut render = reference.clone();
    render.pixels[27][1] = a;
    let e = compare(&render, &reference).unwrap();
    (e.over_1_255, e.over_1_64)
}

#[test]
fn threshold_one_step_is_not_over_slightly_more_is() {
    let px = 1.0 / 64.0;
    for base in [0.0f32, 0.25, 0.5, 0.9, 1.0, 3.0, 7.5] {
        // Exactly one 8-bit step, as f32 arithmetic produces it: not over.
        let step = base + 1.0 / 255.0;
        assert_eq!(
            one_pixel(step, base),
            (0.0, 0.0),
            "base {base}: one step up"
        );
        assert_eq!(
            one_pixel(base, step),
            (0.0, 0.0),
            "base {base}: one step down"
        );
        // 1e-5 more: over 1/255 but not 1/64.
        assert_eq!(
            one_pixel(step + 1e-5, base),
            (px, 0.0),
            "base {base}: above 1/255"
        );
        // 1/64 is exact in f32: not over; 1e-5 more is over both.
        let quarter = base + 1.0 / 64.0;
        assert_eq!(
            one_pixel(quarter, base),
            (px, 0.0),
            "base {base}: exactly 1/64"
        );
        assert_eq!(
            one_pixel(quarter + 1e-5, base),
            (px, px),
            "base {base}: above 1/64"
        );
    }
}

#[test]
fn flip_separates_visible_from_invisible_differences() {
    let reference = pattern(128, 128);
    // A bright square over a quarter of the image: plainly visible.
    let mut visible = reference.clone();
    for y in 32..96 {
        for x in 32..96 {
            visible.pixels[y * 128 + x] = [8.0, 0.0, 8.0, 1.0];
        }
    }
    let near = offset(&reference, 1e-4);
    let big = compare(&visible, &reference).unwrap().flip_mean;
    let tiny = compare(&near, &reference).unwrap().flip_mean;
    println!("flip visible {big}, near-identical {tiny}");
    // Measured: 0.260 and 0.0017 (float FLIP: no 8-bit quantisation step).
    assert!(big > 0.2, "visible change scored only {big}");
    assert!(tiny > 0.0 && tiny < 0.005, "invisible change scored {tiny}");
    assert!(big > 50.0 * tiny);
}

#[test]
fn size_mismatch_is_an_error_everywhere() {
    let a = pattern(4, 4);
    let b = pattern(4, 5);
    for err in [
        compare(&a, &b).unwrap_err(),
        diff_image(&a, &b).unwrap_err(),
        heatmap(&a, &b).unwrap_err(),
    ] {
        match err {
            MetricsError::SizeMismatch { render, reference } => {
                assert_eq!((render, reference), ((4, 4), (4, 5)));
            }
            other => panic!("expected SizeMismatch, got {other}"),
        }
    }
    assert!(compare(&a, &b).unwrap_err().to_string().contains("4x4"));
}

#[test]
fn inconsistent_or_empty_images_are_errors() {
    let a = pattern(4, 4);
    let mut broken = a.clone();
    broken.pixels.pop();
    match compare(&a, &broken).unwrap_err() {
        MetricsError::PixelCount {
            image,
            expected,
            len,
            ..
        } => {
            assert_eq!((image, expected, len), ("reference", 16, 15));
        }
        other => panic!("expected PixelCount, got {other}"),
    }
    let empty = LinearImage::new(0, 7, [0.0; 4]);
    assert!(matches!(
        compare(&empty, &empty),
        Err(MetricsError::Empty {
            width: 0,
            height: 7,
            ..
        })
    ));
}

#[test]
fn diff_image_is_per_channel_absolute_difference() {
    let reference = LinearImage::new(2, 1, [0.5, 0.25, 2.0, 0.0]);
    let mut render = reference.clone();
    render.pixels[0] = [0.75, 0.0, 2.0, 0.3];
    render.pixels[1] = [f32::NAN, 0.25, -1.0, 0.0];
    let diff = diff_image(&render, &reference).unwrap();
    assert_eq!((diff.width, diff.height), (2, 1));
    assert_eq!(diff.pixels[0], [0.25, 0.25, 0.0, 1.0]);
    assert!(diff.pixels[1][0].is_nan());
    assert_eq!(&diff.pixels[1][1..], &[0.0, 3.0, 1.0]);
}

#[test]
fn heatmap_colours_follow_max_channel_error() {
    let reference = LinearImage::new(3, 2, [0.5, 0.5, 0.5, 1.0]);
    let mut render = reference.clone();
    render.pixels[1][2] = 0.5 + 0.0078125; // 2^-7 in blue only
    render.pixels[2] = [0.5 + 0.5, 0.5 - 0.0078125, 0.5, 1.0]; // max is 0.5
    render.pixels[4][0] = f32::NAN;
    let map = heatmap(&render, &reference).unwrap();
    assert_eq!((map.width, map.height), (3, 2));
    assert_eq!(map.get(0, 0), error_color(0.0));
    assert_eq!(map.get(1, 0), error_color(0.0078125));
    assert_eq!(map.get(2, 0), error_color(0.5));
    assert_eq!(map.get(1, 1), NONFINITE_SRGB8);
    assert_ne!(map.get(1, 0), map.get(2, 0));
}

#[test]
fn errors_serialize_with_the_results_schema_names() {
    let e = compare(&offset(&pattern(8, 8), 0.125), &pattern(8, 8)).unwrap();
    let value = serde_json::to_value(e).unwrap();
    let mut keys: Vec<&str> = value
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    keys.sort_unstable();
    assert_eq!(
        keys,
        [
            "flip_mean",
            "hdr",
            "hdr_flip_mean",
            "max_abs",
            "max_relative",
            "mean_abs",
            "nonfinite",
            "over_1_255",
            "over_1_64",
            "psnr",
            "relmse",
            "rmse",
            "ssim"
        ]
    );
    assert_eq!(value["nonfinite"], serde_json::json!(0));
    let back: Errors = serde_json::from_value(value).unwrap();
    assert_eq!(back, e);
}

#[test]
fn degenerate_shapes_do_not_trip_flip() {
    for (w, h) in [(1, 1), (1, 9), (9, 1), (2, 3)] {
        let reference = LinearImage::new(w, h, [0.25, 0.5, 1.0, 1.0]);
        let render = offset(&reference, 0.5);
        let e = compare(&render, &reference).unwrap();
        assert!((e.max_abs - 0.5).abs() < 1e-7, "{w}x{h}: {e:?}");
        assert!(e.flip_mean > 0.0 && e.flip_mean <= 1.0, "{w}x{h}: {e:?}");
        assert_eq!(compare(&reference, &reference).unwrap().flip_mean, 0.0);
    }
}

#[test]
fn compare_gives_the_same_answer_on_many_threads() {
    // The harness may compare runs in parallel; FLIP is C++ underneath, so check it has no
    // shared state that leaks between calls.
    let reference = pattern(96, 64);
    let renders: Vec<LinearImage> = (1..=4)
        .map(|k| offset(&reference, k as f32 * 0.03125))
        .collect();
    let sequential: Vec<Errors> = renders
        .iter()
        .map(|r| compare(r, &reference).unwrap())
        .collect();
    let parallel: Vec<Errors> = std::thread::scope(|s| {
        let handles: Vec<_> = renders
            .iter()
            .map(|r| s.spawn(|| compare(r, &reference).unwrap()))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(sequential, parallel);
    // Larger offsets score strictly higher FLIP.
    for pair in sequential.windows(2) {
        assert!(pair[1].flip_mean > pair[0].flip_mean, "{pair:?}");
    }
}

/// `max_relative` divides each channel's error by its reference value above 1 and by 1 below:
/// an error of 0.5 on a reference of 10 counts 0.05, on a reference of 0.25 counts 0.5.
#[test]
fn max_relative_is_relative_above_one_and_absolute_below() {
    let reference = LinearImage::new(2, 1, [0.25, 10.0, 0.25, 1.0]);
    let mut render = reference.clone();
    render.pixels[0][1] = 10.5;
    let e = compare(&render, &reference).unwrap();
    assert_eq!(e.max_abs, 0.5);
    assert!((e.max_relative - 0.05).abs() < 1e-9, "{}", e.max_relative);
    render.pixels[1][0] = 0.75;
    let e = compare(&render, &reference).unwrap();
    assert!((e.max_relative - 0.5).abs() < 1e-9, "{}", e.max_relative);
}

/// SSIM adds its per-row sums in row order, so one pair of images scores the same bits on one
/// thread and on several (a parallel reduction's order depends on how rayon splits the rows).
#[test]
fn ssim_is_the_same_bits_on_any_number_of_threads() {
    let (width, height) = (193, 157);
    let x: Vec<f32> = (0..width * height)
        .map(|i| ((i * 7919) % 1009) as f32 / 1009.0)
        .collect();
    let y: Vec<f32> = (0..width * height)
        .map(|i| ((i * 104_729) % 997) as f32 / 997.0)
        .collect();
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool")
            .install(|| oit_metrics::ssim(&x, &y, width, height))
    };
    let one = on(1);
    assert!(one > -1.0 && one < 0.5, "unrelated images score low: {one}");
    for threads in [2, 3, 8] {
        for _ in 0..4 {
            assert_eq!(on(threads).to_bits(), one.to_bits(), "{threads} threads");
        }
    }
}
