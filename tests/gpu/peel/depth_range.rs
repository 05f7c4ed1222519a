//! `depth-range`: five pairs of quads 0.1 % of their distance apart at 0.1 … 50 000 units.
//! RG32F separates every pair; in RG16F the stored key's encoding decides which pairs stay
//! separate. A pair whose two keys round to the same f16 value is peeled as one tie on the
//! near shell, where it composites in draw order (under-blending, first drawn in front): the
//! image is then right in one draw order and wrong in the other. So a pair counts as separated
//! when both the natural and the reversed draw order match the reference. The table is
//! printed (`--nocapture`) and the README quotes it.

use super::common::*;
use oit_peel::{DepthEncoding, DepthFormat, DualPeel, DualPeelConfig, PassCount, Tail};

/// Column ranges of the five vertical strips (one pair each), from the reference's layers.
fn strips(reference: &oit_reference::Reference) -> Vec<(u32, u32)> {
    let (w, h) = (RES.width, RES.height);
    let covered: Vec<bool> = (0..w)
        .map(|x| (0..h).any(|y| reference.layers[(y * w + x) as usize] > 0))
        .collect();
    let mut out = Vec::new();
    let mut x = 0;
    while x < w {
        if covered[x as usize] {
            let start = x;
            while x < w && covered[x as usize] {
                x += 1;
            }
            out.push((start, x));
        } else {
            x += 1;
        }
    }
    out
}

/// Largest RGB error inside each strip.
fn strip_errors(
    image: &oit_scene::LinearImage,
    reference: &oit_reference::Reference,
    strips: &[(u32, u32)],
) -> Vec<f64> {
    strips
        .iter()
        .map(|&(x0, x1)| {
            let mut worst = 0f64;
            for y in 0..RES.height {
                for x in x0..x1 {
                    let i = (y * RES.width + x) as usize;
                    for c in 0..3 {
                        worst = worst.max(f64::from(
                            (image.pixels[i][c] - reference.image.pixels[i][c]).abs(),
                        ));
                    }
                }
            }
            worst
        })
        .collect()
}

fn config(depth: DepthFormat, encoding: DepthEncoding, reverse_z: bool) -> DualPeelConfig {
    DualPeelConfig {
        passes: PassCount::Auto,
        depth,
        accum: oit_peel::AccumFormat::Auto,
        reverse_z,
        tail: Tail::Drop,
        encoding,
    }
}

#[test]
fn depth_range_encodings() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("depth_range_encodings") else {
        return;
    };
    let scene = scene("depth-range");
    let reference = reference(&scene);
    let strips = strips(&reference);
    assert_eq!(
        strips.len(),
        5,
        "depth-range has five pairs in five strips: {strips:?}"
    );
    const SEPARATED: f64 = 4e-3;

    // RG32F: exact for every encoding and direction.
    for &encoding in DepthEncoding::ALL {
        for reverse in [true, false] {
            let mut t = DualPeel::new(config(DepthFormat::Rg32f, encoding, reverse));
            let (image, _) = render(&ctx, &scene, &mut t);
            let e = errors(&image, &reference.image);
            assert!(
                e.rmse <= 1e-3 && e.max_abs <= SEPARATED,
                "rg32f {} reverse-z {reverse}: rmse {:.2e} max {:.2e}",
                encoding.name(),
                e.rmse,
                e.max_abs
            );
        }
    }

    println!(
        "depth-range, rg16f, worse of natural and reversed draw order; max error per pair (distance 0.1, 1, 10, 1000, 50000); * = separated (max <= {SEPARATED:e})"
    );
    let mut rmse = std::collections::BTreeMap::new();
    let mut separated = std::collections::BTreeMap::new();
    for &encoding in DepthEncoding::ALL {
        for reverse in [true, false] {
            let mut t = DualPeel::new(config(DepthFormat::Rg16f, encoding, reverse));
            let (image, _) = render(&ctx, &scene, &mut t);
            let mut t = DualPeel::new(config(DepthFormat::Rg16f, encoding, reverse));
            let (reversed, _) = render(&ctx, &scene.with_reversed_draw_order(), &mut t);
            let per: Vec<f64> = strip_errors(&image, &reference, &strips)
                .into_iter()
                .zip(strip_errors(&reversed, &reference, &strips))
                .map(|(a, b)| a.max(b))
                .collect();
            let e = errors(&image, &reference.image);
            let er = errors(&reversed, &reference.image);
            let e_rmse = e.rmse.max(er.rmse);
            let sep: Vec<bool> = per.iter().map(|&m| m <= SEPARATED).collect();
            println!(
                "{:7} reverse-z={:3}  rmse {:.3e}  {}",
                encoding.name(),
                if reverse { "on" } else { "off" },
                e_rmse,
                per.iter()
                    .zip(&sep)
                    .map(|(m, s)| format!("{m:.2e}{}", if *s { "*" } else { " " }))
                    .collect::<Vec<_>>()
                    .join(" ")
            );
            rmse.insert((encoding.name(), reverse), e_rmse);
            separated.insert((encoding.name(), reverse), sep);
        }
    }
    let worst = rmse[&("window", false)];
    for (&(name, reverse), &r) in &rmse {
        assert!(
            r <= worst,
            "rg16f window depth without reverse-Z must be the worst: {name} reverse-z {reverse} has {r:.3e} > {worst:.3e}"
        );
    }
    let count = |k: (&str, bool)| separated[&k].iter().filter(|&&s| s).count();
    assert!(
        count(("window", true)) > count(("window", false)),
        "reverse-Z must separate more pairs than standard depth in rg16f: {separated:?}"
    );
    assert!(rmse[&("window", true)] < worst, "{rmse:?}");
    // The fixed-point log key separates all five pairs in either direction, beating reverse-Z.
    for reverse in [true, false] {
        assert_eq!(count(("log", reverse)), 5, "{separated:?}");
        assert!(
            rmse[&("log", reverse)] < rmse[&("window", true)],
            "{rmse:?}"
        );
    }
    assert!(
        count(("window", true)) >= 3,
        "reverse-Z keeps the pairs nearer than ~166 units: {separated:?}"
    );
}
