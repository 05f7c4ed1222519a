//! The fixed tone map and the sRGB OETF, against values computed by hand from IEC 61966-2-1.

use oit_metrics::{LinearImage, NONFINITE_SRGB8, encode_srgb8, preview_srgb8, srgb_oetf, tone_map};

#[test]
fn tone_map_spot_values() {
    assert_eq!(tone_map(0.0), 0.0);
    assert_eq!(tone_map(1.0), 0.5);
    assert_eq!(tone_map(3.0), 0.75);
    assert_eq!(tone_map(-2.0), 0.0);
    assert_eq!(tone_map(f32::NAN), 0.0);
    assert_eq!(tone_map(f32::INFINITY), 1.0);
    assert!(tone_map(f32::MAX) <= 1.0);
}

#[test]
fn tone_map_is_strictly_monotonic_over_the_hdr_range() {
    // 1e-6 to 1e4 in steps of 1 % (log spaced): every step strictly increases the output.
    let mut previous = tone_map(0.0);
    let mut x = 1e-6f64;
    while x < 1e4 {
        let y = tone_map(x as f32);
        assert!(y > previous, "tone_map({x}) = {y} is not above {previous}");
        assert!(y < 1.0);
        previous = y;
        x *= 1.01;
    }
    // Beyond that, f32 runs out of steps below 1 but it must never decrease.
    let mut previous = tone_map(1e4);
    for e in 4..38 {
        let y = tone_map(10f32.powi(e));
        assert!(y >= previous);
        previous = y;
    }
}

#[test]
fn srgb_oetf_spot_values() {
    assert_eq!(encode_srgb8(0.0), 0);
    assert_eq!(encode_srgb8(1.0), 255);
    // 1.055·0.5^(1/2.4) − 0.055 = 0.735357 → 187.52
    assert_eq!(encode_srgb8(0.5), 188);
    // 18 % grey: 0.461356 → 117.65
    assert_eq!(encode_srgb8(0.18), 118);
    // The linear toe (gamma 2.2 would give 0.0433 here).
    assert!((srgb_oetf(0.001) - 0.012_92).abs() < 1e-7);
    assert_eq!(encode_srgb8(0.001), 3);
}

#[test]
fn srgb_oetf_is_continuous_at_the_boundary() {
    // At 0.0031308 the linear branch gives 0.040449936 and the power branch 0.040449907:
    // f32(0.0031308) lies just above the threshold, so either is acceptable within 5e-8.
    let at = f64::from(srgb_oetf(0.003_130_8));
    assert!((at - 0.040_449_92).abs() < 5e-8, "{at}");
    // Just below is the linear branch, exactly 12.92·x (up to f32 rounding).
    let below = f64::from(srgb_oetf(0.003_13));
    assert!(
        (below - 12.92 * f64::from(0.003_13f32)).abs() < 1e-8,
        "{below}"
    );
    // Just above is the power branch: 1.055·0.003132^(1/2.4) − 0.055 = 0.0404651.
    let above = f64::from(srgb_oetf(0.003_132));
    assert!((above - 0.040_465_15).abs() < 1e-7, "{above}");
    assert!(below < at && at < above);
    assert_eq!(encode_srgb8(0.003_130_8), 10);
}

#[test]
fn srgb_encode_clamps_and_is_monotonic() {
    assert_eq!(encode_srgb8(2.0), 255);
    assert_eq!(encode_srgb8(-1.0), 0);
    assert_eq!(encode_srgb8(f32::NAN), 0);
    let mut previous = 0u8;
    for i in 0..=10_000 {
        let v = encode_srgb8(i as f32 / 10_000.0);
        assert!(v >= previous);
        previous = v;
    }
    assert_eq!(previous, 255);
}

#[test]
fn preview_applies_tone_map_then_oetf() {
    let mut image = LinearImage::new(5, 1, [0.0; 4]);
    image.pixels[1] = [1.0, 3.0, 0.0, 0.0]; // tone 0.5, 0.75 → 188, 225
    image.pixels[2] = [10.0, 100.0, -5.0, 1.0]; // tone 0.909, 0.990 → 245, 254
    image.pixels[3] = [0.5, f32::NAN, 0.5, 1.0];
    image.pixels[4] = [0.5, 0.5, 0.5, f32::NAN]; // alpha does not matter
    let preview = preview_srgb8(&image).unwrap();
    assert_eq!(preview.pixels[0], [0, 0, 0]);
    assert_eq!(preview.pixels[1], [188, 225, 0]);
    assert_eq!(preview.pixels[2], [245, 254, 0]);
    assert_eq!(preview.pixels[3], NONFINITE_SRGB8);
    // 0.5 → tone 1/3 → 0.612501 → 156.19
    assert_eq!(preview.pixels[4], [156, 156, 156]);
}
