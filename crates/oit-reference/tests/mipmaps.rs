//! The reference's level of detail: texture coordinates of each pixel's 2×2-quad neighbours,
//! fine differences, Vulkan's isotropic rule. A screen-filling orthographic quad whose uv
//! covers 4 texels per pixel samples level 2 of its texture everywhere; with half a texel per
//! pixel it magnifies level 0.

use oit_scene::{Encoding, Filter, Sampler, Scene, Texture};

/// A 64×64 view of an orthographic, screen-filling opaque quad with uv 0..`uv_extent` (ρ =
/// `uv_extent` texels per pixel), whose
/// material samples a 64×64 texture of hashed codes (REPEAT, trilinear).
fn quad_scene(uv_extent: f32) -> Scene {
    let text = r#"{"name": "lod", "resolution": [64, 64],
        "camera": {"eye": [0, 0, 2], "target": [0, 0, 0], "orthographic": {"height": 2},
                   "near": 0.1, "far": 10},
        "objects": [{"mesh": {"kind": "quad", "size": [2, 2]},
                     "material": {"base_color": [1, 1, 1]}}]}"#;
    let mut scene = oit_scene::parse(text, "lod").expect("scene");
    let codes = (0..64u32 * 64)
        .map(|k| k.wrapping_mul(0x9e37_79b9).rotate_left(7) | 0xff00_0000)
        .collect();
    let texture =
        Texture::new("hash", 64, 64, codes, Encoding::Srgb, Sampler::default()).expect("texture");
    scene.textures = vec![texture];
    scene.materials[0].base_texture = Some(0);
    for v in &mut scene.vertices {
        v.uv = [v.uv[0] * uv_extent, v.uv[1] * uv_extent];
        v.color = [1.0; 4];
    }
    scene
}

/// The pixel's texture coordinate on the quad (pixel centres; the quad's uv runs 0..extent
/// across the 64 pixels, v downwards like the image).
fn uv_at(x: usize, y: usize, extent: f32, flip: (bool, bool)) -> [f32; 2] {
    let u = (x as f32 + 0.5) / 64.0 * extent;
    let v = (y as f32 + 0.5) / 64.0 * extent;
    [
        if flip.0 { extent - u } else { u },
        if flip.1 { extent - v } else { v },
    ]
}

#[test]
fn minified_quads_sample_the_level_their_footprint_selects() {
    for (extent, level, filter) in [(4.0, 2, Filter::Linear), (0.5, 0, Filter::Linear)] {
        let scene = quad_scene(extent);
        let texture = &scene.textures[0];
        let reference = oit_reference::render(&scene, &Default::default());
        // The quad's uv orientation: whichever of the two fits level-`level` samples.
        let mut best = (f32::INFINITY, f32::INFINITY);
        for flip in [(false, false), (false, true), (true, false), (true, true)] {
            let mut worst = (0.0f32, 0.0f32);
            for y in 8..56 {
                for x in 8..56 {
                    let want = texture.filter_level(level, filter, uv_at(x, y, extent, flip));
                    let other = texture.filter_level(level ^ 1, filter, uv_at(x, y, extent, flip));
                    let got = reference.image.pixels[y * 64 + x];
                    let e = (0..3).map(|c| (got[c] - want[c]).abs()).fold(0.0, f32::max);
                    let o = (0..3)
                        .map(|c| (got[c] - other[c]).abs())
                        .fold(0.0, f32::max);
                    worst = (worst.0.max(e), worst.1.max(o));
                }
            }
            if worst.0 < best.0 {
                best = worst;
            }
        }
        // Level `level` to rounding of the interpolated uv; the neighbouring level is far off.
        assert!(
            best.0 < 2e-3,
            "extent {extent}: {best:?} from level {level}"
        );
        assert!(
            best.1 > 0.05,
            "extent {extent}: level {} fits too: {best:?}",
            level ^ 1
        );
    }
}
