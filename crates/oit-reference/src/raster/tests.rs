//! Tests of the per-tile rasterizer.

use super::*;

#[test]
fn natural_merge_sort_matches_a_plain_sort() {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let (mut buffer, mut runs) = (Vec::new(), Vec::new());
    for case in 0..2000 {
        let n = (next() % 300) as usize;
        // Unique keys: a permutation scaled up, then shaped into runs.
        let mut keys: Vec<u64> = (0..n as u64).map(|k| k * 3 + 1).collect();
        match case % 4 {
            0 => {}
            1 => keys.reverse(),
            2 => {
                // A few ascending and descending runs.
                let cut = (next() as usize) % (n + 1);
                keys[..cut].reverse();
                keys.rotate_left(cut / 2);
            }
            _ => {
                for i in (1..n).rev() {
                    keys.swap(i, (next() % (i as u64 + 1)) as usize);
                }
            }
        }
        let mut list: Vec<u32> = (0..n as u32).collect();
        sort_by_key(&mut list, |i| keys[i as usize], &mut buffer, &mut runs);
        let got: Vec<u64> = list.iter().map(|&i| keys[i as usize]).collect();
        let mut want = keys.clone();
        want.sort_unstable();
        assert_eq!(got, want, "case {case}, n = {n}");
        let mut seen = list.clone();
        seen.sort_unstable();
        assert!(
            seen.iter().copied().eq(0..n as u32),
            "the result is a permutation"
        );
    }
}

#[test]
fn permute_reorders_every_array_by_the_permutation_and_restores_it() {
    let mut state = 0x51_7cc1_b727_220au64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for n in 0..40usize {
        for coloured in [false, true] {
            let mut perm: Vec<u32> = (0..n as u32).collect();
            for i in (1..n).rev() {
                perm.swap(i, (next() % (i as u64 + 1)) as usize);
            }
            let keys: Vec<u64> = (0..n).map(|_| next()).collect();
            let colors: Vec<[f32; 4]> = (0..n).map(|i| [i as f32; 4]).collect();
            let t: Vec<[f64; 3]> = if coloured {
                (0..n).map(|i| [i as f64, -(i as f64), 0.5]).collect()
            } else {
                Vec::new()
            };
            let (mut k, mut c, mut tt, mut p) =
                (keys.clone(), colors.clone(), t.clone(), perm.clone());
            permute(&mut p, &mut k, &mut c, &mut tt);
            assert_eq!(p, perm, "the permutation is left as it was");
            for j in 0..n {
                let from = perm[j] as usize;
                assert_eq!(k[j], keys[from], "n = {n}, slot {j}");
                assert_eq!(c[j], colors[from]);
                if coloured {
                    assert_eq!(tt[j], t[from]);
                }
            }
            assert_eq!(tt.len(), t.len());
        }
    }
}

#[test]
fn reciprocal_quotients_round_like_division() {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let unit = |bits: u64| (bits >> 11) as f64 / (1u64 << 53) as f64;
    let (mut fast, mut checked) = (0, 0);
    for case in 0..1_000_000 {
        let sum: f64 = match case % 5 {
            0 => unit(next()) * 4.0,
            1 => unit(next()) * 1e-30,
            2 => -unit(next()) * 1e30,
            3 => [0.0, -0.0, 1e-310, f64::MIN_POSITIVE, 1e300][case / 5 % 5],
            _ => unit(next()) + 0.5,
        };
        // Quotients on and around f32 rounding midpoints, exact f32 values, zeros and
        // values outside the f32 range.
        let f = f32::from_bits((next() as u32) & 0x3fff_ffff);
        let midpoint = (f64::from(f) + f64::from(f32::from_bits(f.to_bits() + 1))) / 2.0;
        let target = match case % 7 {
            0..=2 => midpoint,
            3 => f64::from(f),
            4 => [0.0, -0.0, 1e-320, 1e40][case % 4],
            _ => unit(next()),
        };
        let nudge = 1.0 + ((next() % 64) as f64 - 32.0) * f64::EPSILON;
        let num = target * sum * nudge;
        let inv = 1.0 / sum;
        let (got, exact) = quotient_via_reciprocal(num, inv);
        // `colours` only uses the result when the reciprocal is a normal f64.
        if exact && inv.is_normal() {
            let want = (num / sum) as f32;
            assert_eq!(got.to_bits(), want.to_bits(), "{num} / {sum}");
            fast += 1;
        }
        checked += 1;
    }
    // Most quotients take the fast path, but not those closest to a midpoint.
    assert!(
        fast > checked / 2 && fast < checked * 9 / 10,
        "{fast} of {checked}"
    );
}

#[test]
fn depth_key_orders_like_camera_nearer() {
    let depths = [
        0.0f32, -0.0, 1e-30, 1e-7, 0.25, 0.5, 0.5000001, 0.99999994, 1.0,
    ];
    for reverse_z in [false, true] {
        for &a in &depths {
            for &b in &depths {
                let nearer = if reverse_z { a > b } else { a < b };
                let by_key = depth_key(a, reverse_z) < depth_key(b, reverse_z);
                // -0.0 and 0.0 compare equal as floats but get different keys: both are
                // clamped to +0.0 before keying in the renderer, so only check a != b.
                if a != b {
                    assert_eq!(by_key, nearer, "{a} vs {b}, reverse_z={reverse_z}");
                }
            }
        }
    }
}

/// Checks [`depth_key_bounds`] against the exact key of every covered pixel of every
/// triangle it bounds; the number of triangles and fragments checked.
fn check_depth_key_bounds(scene: &oit_scene::Scene, what: &str) -> (u64, u64) {
    let pieces = crate::set_up(scene).expect("a valid scene").0.triangles;
    let tile = TileRect {
        x0: 0,
        y0: 0,
        width: scene.resolution.width,
        height: scene.resolution.height,
    };
    let reverse_z = scene.camera.reverse_z;
    let (mut bounded, mut fragments) = (0, 0);
    for tri in pieces.chunks().iter().flatten() {
        if tri.inv_farea2 == 0.0 {
            continue;
        }
        let Some((lo, hi)) = depth_key_bounds(tri, reverse_z) else {
            continue;
        };
        bounded += 1;
        for_each_span(tri, tile, |row, first, end| {
            let weights = RowWeights::new(tri, tile, row);
            for x in first..end {
                let key = depth_key(depths(tri, &weights.at(x))[0], reverse_z);
                assert!(
                    (lo..=hi).contains(&key),
                    "{what}: triangle {} at ({x}, {row}): key {key} outside {lo}..={hi}",
                    tri.key
                );
                fragments += 1;
            }
        });
    }
    (bounded, fragments)
}

#[test]
fn depth_key_bounds_hold_for_every_fragment() {
    let (mut bounded, mut fragments) = (0, 0);
    for seed in 0..200 {
        let (text, about) = oit_scene::random::random_scene_json(seed);
        let scene = oit_scene::parse(&text, "random").expect("random scene");
        let (b, f) = check_depth_key_bounds(&scene, &format!("seed {seed}: {about:?}"));
        (bounded, fragments) = (bounded + b, fragments + f);
    }
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    for (path, scene) in oit_scene::load_dir(&dir).expect("bundled scenes") {
        let scene = scene.with_resolution(oit_scene::Resolution {
            width: 256,
            height: 256,
        });
        let (b, f) = check_depth_key_bounds(&scene, &path.display().to_string());
        (bounded, fragments) = (bounded + b, fragments + f);
    }
    assert!(
        bounded > 10_000 && fragments > 1_000_000,
        "{bounded} triangles, {fragments} fragments"
    );
}

/// A stack of `count` full-screen constant layers of alpha `alpha` (two triangles each),
/// set up, and every triangle as one bin.
fn layer_bin(count: u32, alpha: f32) -> (Triangles, Vec<u32>) {
    let text = format!(
        r#"{{"name": "stack", "resolution": [8, 8],
          "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0],
                      "fov_y": 45, "near": 0.1, "far": 100}},
          "objects": [{{"mesh": {{"kind": "layers", "count": {count}, "spacing": 0.001,
                        "size": [8, 8], "color_from": [1, 0.5, 0.2],
                        "color_to": [0.2, 0.5, 1], "alpha_from": {alpha},
                        "alpha_to": {alpha}}},
                        "material": {{"mode": "blend"}}}}]}}"#
    );
    let scene = oit_scene::parse(&text, "stack").expect("a layer stack");
    let triangles = crate::set_up(&scene).expect("a valid scene").0.triangles;
    let bin = triangles.ids().collect();
    (triangles, bin)
}

#[test]
fn the_underflow_bound_counts_halvings_of_the_transmittance() {
    // α = 0.5: each triangle of the bin may halve it once; 990 halvings are allowed.
    let (triangles, bin) = layer_bin(495, 0.5);
    assert_eq!(bin.len(), 990);
    assert!(!may_underflow(&triangles, &bin));
    let (triangles, bin) = layer_bin(496, 0.5);
    assert!(may_underflow(&triangles, &bin));
    // 1 − 0.3 = 0.7 ≥ 2^-1: one halving each, however many digits it has.
    let (triangles, bin) = layer_bin(495, 0.3);
    assert!(!may_underflow(&triangles, &bin));
    // 1 − 0.99 ≥ 2^-7: seven each, so 71 layers (142 triangles, 994) may reach it and 70
    // (980) may not.
    let (triangles, bin) = layer_bin(71, 0.99);
    assert!(may_underflow(&triangles, &bin));
    assert!(!may_underflow(&triangles, &bin[..140]));
    // Opaque-as-blend layers (α = 1) leave 0, which is no subnormal, however many.
    let (triangles, bin) = layer_bin(2000, 1.0);
    assert!(!may_underflow(&triangles, &bin));
}
