//! Writes a seeded .glb of a Sponza-class load, for measuring oit-lab at the size real content
//! has: about 300 000 triangles in 60 primitives, 60 PNG textures of 1024² and 2048² (most
//! opaque architecture, 16 alpha-tested foliage atlases on MASK cards, 4 BLEND glass materials of
//! which 2 use KHR_materials_transmission). An opaque courtyard (a ground grid, two rows of
//! columns) with foliage cards hanging in front of the columns and glass panes down its middle.
//!
//! `cargo run -p oit-tools --bin scale_scene -- OUT.glb [--seed N] [--texture-scale S]`
//! (`--texture-scale 64` divides every texture side by 64, for quick runs). The same seed and
//! scale give the same bytes on one platform (f32 `sin`/`cos` of the platform's libm place the
//! columns). Made for oit-lab, CC0 1.0.

use std::io::Cursor;

use anyhow::{Context, Result, bail};
use serde_json::{Value, json};

/// Textures (= materials = primitives) of each kind.
const OPAQUE: usize = 40;
const FOLIAGE: usize = 16;
const GLASS: usize = 4;

/// SplitMix64: the whole scene follows from the seed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((self.next() >> 40) as f32 / (1u64 << 24) as f32)
    }
}

/// One primitive's triangles (non-indexed, 3 positions and uvs each).
#[derive(Default)]
struct Mesh {
    positions: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
}

impl Mesh {
    fn quad(&mut self, corners: [[f32; 3]; 4], uv_scale: f32) {
        let uv = [
            [0.0, uv_scale],
            [uv_scale, uv_scale],
            [uv_scale, 0.0],
            [0.0, 0.0],
        ];
        for k in [0, 1, 2, 0, 2, 3] {
            self.positions.push(corners[k]);
            self.uvs.push(uv[k]);
        }
    }
    fn triangles(&self) -> usize {
        self.positions.len() / 3
    }
}

/// The scene's geometry, one mesh per material, in material order.
fn geometry(rng: &mut Rng) -> Vec<Mesh> {
    let mut meshes: Vec<Mesh> = (0..OPAQUE + FOLIAGE + GLASS)
        .map(|_| Mesh::default())
        .collect();
    // Ground: a 160×160 grid of quads (51 200 triangles), materials in 8 bands.
    let n = 160;
    for i in 0..n {
        for j in 0..n {
            let (x, z) = (i as f32 * 0.25 - 20.0, j as f32 * 0.25 - 20.0);
            let m = &mut meshes[(i * 8 / n) % 8];
            m.quad(
                [
                    [x, 0.0, z + 0.25],
                    [x + 0.25, 0.0, z + 0.25],
                    [x + 0.25, 0.0, z],
                    [x, 0.0, z],
                ],
                1.0,
            );
        }
    }
    // Columns: 64 cylinders of 48 segments × 24 rings (2 304 triangles each, 147 456 in all),
    // two rows of 32, on materials 8..40.
    for c in 0..64 {
        let side = if c < 32 { -6.0 } else { 6.0 };
        let (cx, cz) = (side, (c % 32) as f32 * 1.2 - 19.0);
        let radius = rng.range(0.25, 0.4);
        let m = &mut meshes[8 + c % 32];
        let (segments, rings, height) = (48, 24, 8.0);
        for s in 0..segments {
            let a0 = s as f32 / segments as f32 * std::f32::consts::TAU;
            let a1 = (s + 1) as f32 / segments as f32 * std::f32::consts::TAU;
            for r in 0..rings {
                let (y0, y1) = (
                    r as f32 * height / rings as f32,
                    (r + 1) as f32 * height / rings as f32,
                );
                let p = |a: f32, y: f32| [cx + radius * a.cos(), y, cz + radius * a.sin()];
                m.quad([p(a0, y0), p(a1, y0), p(a1, y1), p(a0, y1)], 1.0);
            }
        }
    }
    // Foliage: 50 000 alpha-tested cards (100 000 triangles) in clusters in front of the
    // columns, 16 atlases.
    for k in 0..50_000 {
        let cluster = k / 500;
        let side = if cluster % 2 == 0 { -4.5 } else { 4.5 };
        let (x, y, z) = (
            side + rng.range(-1.0, 1.0),
            rng.range(0.5, 6.0),
            (cluster / 2) as f32 * 0.8 - 19.5 + rng.range(-0.4, 0.4),
        );
        let (size, angle) = (rng.range(0.15, 0.35), rng.range(0.0, std::f32::consts::PI));
        let (dx, dz) = (size * angle.cos(), size * angle.sin());
        meshes[OPAQUE + k % FOLIAGE].quad(
            [
                [x - dx, y - size, z - dz],
                [x + dx, y - size, z + dz],
                [x + dx, y + size, z + dz],
                [x - dx, y + size, z - dz],
            ],
            1.0,
        );
    }
    // Glass: 4 materials, each 256 panes facing the camera down the courtyard's middle, in
    // depth behind one another (2 048 triangles in all).
    for g in 0..GLASS {
        for _ in 0..256 {
            let (x, y, z) = (
                rng.range(-3.5, 3.5),
                rng.range(0.3, 3.0),
                rng.range(-18.0, 18.0),
            );
            meshes[OPAQUE + FOLIAGE + g].quad(
                [
                    [x - 0.5, y, z],
                    [x + 0.5, y, z],
                    [x + 0.5, y + 1.2, z],
                    [x - 0.5, y + 1.2, z],
                ],
                1.0,
            );
        }
    }
    meshes
}

/// PNG bytes of texture `t` (side `size`): smooth stone for architecture, leaf atlases with
/// α 0 between leaves for foliage, tinted translucent texels for glass.
fn texture(t: usize, size: u32, rng: &mut Rng) -> Result<Vec<u8>> {
    let base = [rng.next() as u8, rng.next() as u8, rng.next() as u8];
    let freq = rng.range(2.0, 9.0);
    let mut pixels = Vec::with_capacity(size as usize * size as usize * 4);
    for y in 0..size {
        for x in 0..size {
            let (u, v) = (x as f32 / size as f32, y as f32 / size as f32);
            let wave = ((u * freq * 6.3).sin() * (v * freq * 5.1).cos() * 0.5 + 0.5) * 0.6 + 0.4;
            let rgb = base.map(|c| (f32::from(c) * wave) as u8);
            let alpha = if t < OPAQUE {
                255
            } else if t < OPAQUE + FOLIAGE {
                // 4×4 leaves per atlas: an ellipse per cell, transparent around it.
                let (cu, cv) = ((u * 4.0).fract() - 0.5, (v * 4.0).fract() - 0.5);
                if cu * cu * 4.0 + cv * cv * 1.5 < 0.4 * wave {
                    255
                } else {
                    0
                }
            } else {
                (60.0 + 80.0 * wave) as u8
            };
            pixels.extend_from_slice(&[rgb[0], rgb[1], rgb[2], alpha]);
        }
    }
    let image = image::RgbaImage::from_raw(size, size, pixels).context("texture buffer size")?;
    let mut out = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new_with_quality(
        Cursor::new(&mut out),
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Sub,
    );
    image.write_with_encoder(encoder)?;
    Ok(out)
}

/// What [`scale_scene`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ScaleSceneInfo {
    pub triangles: usize,
    pub textures: usize,
    /// Texture sides, in texture order.
    pub sides: Vec<u32>,
    /// Bytes of the textures as 8-bit RGBA (4 B a texel, level 0 only).
    pub rgba8_bytes: u64,
}

/// The .glb bytes of scene `seed`, each texture side divided by `texture_scale`.
pub fn scale_scene(seed: u64, texture_scale: u32) -> Result<(Vec<u8>, ScaleSceneInfo)> {
    if texture_scale == 0 || !texture_scale.is_power_of_two() || texture_scale > 1024 {
        bail!("--texture-scale {texture_scale}: allowed: a power of two from 1 to 1024");
    }
    let mut rng = Rng(seed ^ 0x5ca1_e5ce_7e00);
    let meshes = geometry(&mut rng);
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut view = |bin: &mut Vec<u8>, bytes: &[u8]| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
        bin.extend_from_slice(bytes);
        views.len() - 1
    };
    let mut primitives = Vec::new();
    for (material, mesh) in meshes.iter().enumerate() {
        let pos: Vec<u8> = mesh
            .positions
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        let fold = |f: fn(f32, f32) -> f32, init: f32| -> Vec<f32> {
            (0..3)
                .map(|k| mesh.positions.iter().map(|p| p[k]).fold(init, f))
                .collect()
        };
        let pv = view(&mut bin, &pos);
        accessors.push(json!({"bufferView": pv, "componentType": 5126, "count": mesh.positions.len(),
            "type": "VEC3", "min": fold(f32::min, f32::INFINITY), "max": fold(f32::max, f32::NEG_INFINITY)}));
        let uv: Vec<u8> = mesh
            .uvs
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes())
            .collect();
        let uvv = view(&mut bin, &uv);
        accessors.push(json!({"bufferView": uvv, "componentType": 5126, "count": mesh.uvs.len(), "type": "VEC2"}));
        primitives.push(json!({"attributes": {"POSITION": accessors.len() - 2, "TEXCOORD_0": accessors.len() - 1}, "material": material}));
    }
    let mut images = Vec::new();
    let mut materials = Vec::new();
    let mut sides = Vec::new();
    for t in 0..meshes.len() {
        let side = (if rng.next().is_multiple_of(2) {
            1024
        } else {
            2048
        }) / texture_scale;
        sides.push(side);
        let png = texture(t, side, &mut rng)?;
        images.push(json!({"bufferView": view(&mut bin, &png), "mimeType": "image/png"}));
        let mut m = json!({"name": format!("material-{t}"),
            "pbrMetallicRoughness": {"baseColorTexture": {"index": t}, "metallicFactor": 0, "roughnessFactor": 0.7}});
        if (OPAQUE..OPAQUE + FOLIAGE).contains(&t) {
            m["alphaMode"] = json!("MASK");
            m["doubleSided"] = json!(true);
        } else if t >= OPAQUE + FOLIAGE {
            m["alphaMode"] = json!("BLEND");
            m["doubleSided"] = json!(true);
            if t >= OPAQUE + FOLIAGE + 2 {
                m["extensions"] =
                    json!({"KHR_materials_transmission": {"transmissionFactor": 0.8}});
            }
        }
        materials.push(m);
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let textures: Vec<Value> = (0..meshes.len()).map(|t| json!({"source": t})).collect();
    let doc = json!({
        "asset": {"version": "2.0", "generator": "oit-lab tools/src/bin/scale_scene.rs",
            "copyright": "oit-lab generated scene, CC0 1.0"},
        "extensionsUsed": ["KHR_materials_transmission"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0},
            {"camera": 0, "translation": [0.0, 2.0, 22.0]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.1, "zfar": 100.0, "aspectRatio": 1.0}}],
        "meshes": [{"primitives": primitives}],
        "materials": materials,
        "textures": textures,
        "images": images,
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors,
    });
    let mut text = serde_json::to_vec(&doc)?;
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut glb = Vec::with_capacity(total);
    glb.extend_from_slice(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend(u32::try_from(total)?.to_le_bytes());
    glb.extend(u32::try_from(text.len())?.to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&text);
    glb.extend(u32::try_from(bin.len())?.to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    let info = ScaleSceneInfo {
        triangles: meshes.iter().map(Mesh::triangles).sum(),
        textures: sides.len(),
        rgba8_bytes: sides.iter().map(|&s| 4 * u64::from(s) * u64::from(s)).sum(),
        sides,
    };
    Ok((glb, info))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(out) = args.first().filter(|a| !a.starts_with("--")) else {
        bail!("usage: scale_scene OUT.glb [--seed N] [--texture-scale S]");
    };
    let mut seed = 1u64;
    let mut scale = 1u32;
    let mut rest = args[1..].iter();
    while let Some(flag) = rest.next() {
        let value = rest
            .next()
            .with_context(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--seed" => seed = value.parse().with_context(|| format!("--seed {value}"))?,
            "--texture-scale" => {
                scale = value
                    .parse()
                    .with_context(|| format!("--texture-scale {value}"))?
            }
            other => bail!("unknown option {other}; allowed: --seed, --texture-scale"),
        }
    }
    let (glb, info) = scale_scene(seed, scale)?;
    oit_metrics::write_atomic_bytes(std::path::Path::new(out), &glb)?;
    println!(
        "{out}: {} triangles, {} textures ({} of 2048², {} of 1024² before scaling), {:.1} MiB as 8-bit RGBA, {:.1} MiB file",
        info.triangles,
        info.textures,
        info.sides.iter().filter(|&&s| s == 2048 / scale).count(),
        info.sides.iter().filter(|&&s| s == 1024 / scale).count(),
        info.rgba8_bytes as f64 / (1024.0 * 1024.0),
        glb.len() as f64 / (1024.0 * 1024.0)
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Same seed, same bytes; another seed, other bytes; the stated counts, read back by the
    /// loader (textures at 1/64 of their side so the test is quick).
    #[test]
    fn deterministic_with_the_stated_counts() {
        let (a, info) = scale_scene(7, 64).unwrap();
        let (b, again) = scale_scene(7, 64).unwrap();
        assert!(
            a == b && info == again,
            "the same seed must give the same bytes"
        );
        assert_ne!(scale_scene(8, 64).unwrap().0, a);
        assert_eq!(info.triangles, 51_200 + 147_456 + 100_000 + 2_048);
        assert_eq!(info.textures, 60);
        assert!(
            info.sides.iter().all(|&s| s == 16 || s == 32),
            "{:?}",
            info.sides
        );
        let dir = std::env::temp_dir().join(format!("oit-scale-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("scale.glb");
        std::fs::write(&path, &a).unwrap();
        let scene = oit_scene::load(&path).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(scene.triangle_count(), info.triangles);
        assert!(scene.triangle_count() >= 250_000);
        assert_eq!(scene.textures.len(), 60);
        let count = |mode| scene.materials.iter().filter(|m| m.mode == mode).count();
        assert_eq!(count(oit_scene::AlphaMode::Opaque), OPAQUE);
        assert_eq!(count(oit_scene::AlphaMode::Mask), FOLIAGE);
        assert_eq!(count(oit_scene::AlphaMode::Blend), GLASS);
        assert_eq!(
            scene
                .materials
                .iter()
                .filter(|m| m.transmission > 0.0)
                .count(),
            2
        );
        // Foliage atlases are alpha-tested: texels fully transparent and fully opaque.
        let foliage = scene.materials[OPAQUE].base_texture.unwrap() as usize;
        let alpha: Vec<u32> = (scene.textures[foliage].level_codes(0).iter())
            .map(|c| c >> 24)
            .collect();
        assert!(alpha.contains(&0) && alpha.contains(&255));
        // Full size: 60 textures of 1024² or 2048².
        let full: Vec<u32> = info.sides.iter().map(|s| s * 64).collect();
        assert!(full.iter().all(|&s| s == 1024 || s == 2048));
    }
}
