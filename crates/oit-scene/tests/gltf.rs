//! glTF 2.0 loading: the two bundled Khronos sample models (real facts read back from the
//! files) and small hand-built assets for each geometry rule and each error class.

use std::path::{Path, PathBuf};

use glam::Vec3;
use oit_scene::{
    AlphaMode, Filter, LoadOptions, MipFilter, Problem, Scene, SceneError, Wrap, srgb_to_linear,
};
use serde_json::json;

mod common;
use common::build::{Data, TRI, glb, png, single_mesh};

fn asset(rel: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets")).join(rel)
}

const ALPHA_BLEND: &str = "AlphaBlendModeTest/AlphaBlendModeTest.glb";
const GLASS_VASE: &str = "GlassVaseFlowers/GlassVaseFlowers.glb";

/// A scratch directory unique to this test process and `tag`, removed on drop.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("oit-gltf-{}-{tag}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }
    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn load_text(tag: &str, text: &str) -> Result<Scene, SceneError> {
    let dir = Scratch::new(tag);
    let path = dir.write("asset.gltf", text.as_bytes());
    oit_scene::load(&path)
}

/// Asserts `r` is an `Invalid` error at `path` and returns its problem.
fn problem_at(r: Result<Scene, SceneError>, path: &str) -> Problem {
    match r {
        Err(SceneError::Invalid {
            path: p, problem, ..
        }) => {
            assert_eq!(p, path, "wrong path for {problem}");
            problem
        }
        Err(e) => panic!("expected an Invalid error at {path}, got {e}"),
        Ok(_) => panic!("expected an error at {path}, loaded fine"),
    }
}

fn material_names(path: &Path) -> Vec<String> {
    let g = gltf::Gltf::open(path).unwrap();
    g.materials()
        .map(|m| m.name().unwrap_or("").to_string())
        .collect()
}

/// Triangles each mesh's primitives declare, from the accessor counts (all TRIANGLES here).
fn declared_triangles(path: &Path) -> Vec<Vec<usize>> {
    let g = gltf::Gltf::open(path).unwrap();
    g.meshes()
        .map(|m| {
            m.primitives()
                .map(|p| {
                    p.indices().map_or_else(
                        || p.get(&gltf::Semantic::Positions).unwrap().count(),
                        |a| a.count(),
                    ) / 3
                })
                .collect()
        })
        .collect()
}

fn check_common(s: &Scene, path: &Path) {
    // Draw triangle counts equal the accessors' (per draw name `/nodes/N mesh M primitive P`).
    let declared = declared_triangles(path);
    for d in &s.draws {
        let words: Vec<&str> = d.name.split_whitespace().collect();
        let m: usize = words[3].parse().unwrap();
        let p: usize = words[5].parse().unwrap();
        assert_eq!(d.triangle_count() as usize, declared[m][p], "{}", d.name);
        assert!(d.bounds_center.is_finite() && d.bounds_radius.is_finite());
    }
    assert_eq!(s.vertices.len(), 3 * s.triangle_count());
    // The framing camera sees every vertex.
    for v in &s.vertices {
        let c = s.camera.clip(Vec3::from(v.position));
        assert!(
            c.w > 0.0 && c.x.abs() <= c.w && c.y.abs() <= c.w && c.z >= 0.0 && c.z <= c.w,
            "{v:?} outside: {c:?}"
        );
    }
    // Texel decode: each texture is its image's 8-bit codes, sRGB-decoded rgb, linear alpha.
    let (_, _, images) = gltf::import(path).unwrap();
    for t in &s.textures {
        let i: usize = t.name.rsplit('/').next().unwrap().parse().unwrap();
        let img = &images[i];
        assert_eq!((t.width(), t.height()), (img.width, img.height));
        let count = (t.width() * t.height()) as usize;
        let n = match img.format {
            gltf::image::Format::R8G8B8A8 => 4,
            gltf::image::Format::R8G8B8 => 3,
            other => panic!("test expects RGB8 or RGBA8, got {other:?}"),
        };
        for k in [0usize, 1, (count / 2) + 7, count - 1] {
            let px = &img.pixels[n * k..n * k + n];
            let alpha = if n == 4 {
                (f64::from(px[3]) / 255.0) as f32
            } else {
                1.0
            };
            let want = [
                srgb_to_linear(f64::from(px[0]) / 255.0),
                srgb_to_linear(f64::from(px[1]) / 255.0),
                srgb_to_linear(f64::from(px[2]) / 255.0),
                alpha,
            ];
            assert_eq!(t.texel(k), want, "{} texel {k}", t.name);
        }
    }
}

#[test]
fn alpha_blend_mode_test_loads_its_modes_and_textures() {
    let path = asset(ALPHA_BLEND);
    let s = oit_scene::load(&path).unwrap();
    assert_eq!(s.name, "AlphaBlendModeTest");
    assert!(s.description.contains("AlphaBlendModeTest.glb"));
    assert_eq!(s.resolution, oit_scene::DEFAULT_RESOLUTION);
    assert_eq!(s.background, oit_scene::GLTF_BACKGROUND);
    assert!(s.camera.reverse_z);
    let names = material_names(&path);
    assert_eq!(s.materials.len(), names.len());
    let by_name = |n: &str| s.materials[names.iter().position(|x| x == n).unwrap()];
    assert_eq!(by_name("MatBlend").mode, AlphaMode::Blend);
    assert_eq!(by_name("MatCutoff25").mode, AlphaMode::Mask);
    assert_eq!(by_name("MatCutoff25").cutoff, 0.25);
    assert_eq!(by_name("MatCutoff75").cutoff, 0.75);
    // alphaCutoff absent: the spec default.
    assert_eq!(by_name("MatCutoffDefault").mode, AlphaMode::Mask);
    assert_eq!(by_name("MatCutoffDefault").cutoff, 0.5);
    assert_eq!(by_name("MatOpaque").mode, AlphaMode::Opaque);
    let count = |mode| s.materials.iter().filter(|m| m.mode == mode).count();
    assert_eq!(
        (
            count(AlphaMode::Blend),
            count(AlphaMode::Mask),
            count(AlphaMode::Opaque)
        ),
        (1, 3, 2)
    );
    assert_eq!(s.materials.iter().filter(|m| m.double_sided).count(), 5);
    // MatOpaque samples a texture with alpha, which the Opaque mode ignores.
    let opaque_tex = by_name("MatOpaque").base_texture.unwrap() as usize;
    let t = &s.textures[opaque_tex];
    assert!((0..(t.width() * t.height()) as usize).any(|k| t.texel(k)[3] < 1.0));
    assert!(
        s.materials
            .iter()
            .all(|m| m.base_texture.is_some() && !m.premultiplied)
    );
    assert!(
        s.textures
            .iter()
            .all(|t| t.sampler().wrap_u == Wrap::Repeat && t.is_consistent())
    );
    // MatBed's textures that are not sampled, one line each.
    assert_eq!(
        s.ignored,
        [
            "AlphaBlendModeTest.glb: metallicRoughnessTexture on /materials/0 (MatBed): not modelled (metallicFactor and roughnessFactor light the material alone)",
            "AlphaBlendModeTest.glb: normalTexture on /materials/0 (MatBed): not modelled (geometric or vertex normals only)",
            "AlphaBlendModeTest.glb: occlusionTexture on /materials/0 (MatBed): not modelled",
        ]
    );
    assert!(s.materials.iter().all(|m| m.is_lit()));
    assert_eq!(s.lights, oit_scene::LightRig::default_rig());
    check_common(&s, &path);
}

#[test]
fn glass_vase_flowers_maps_transmission_to_clear_glass() {
    let path = asset(GLASS_VASE);
    let s = oit_scene::load(&path).unwrap();
    let names = material_names(&path);
    assert_eq!(s.materials.len(), 3);
    let modes: Vec<_> = s.materials.iter().map(|m| m.mode).collect();
    assert_eq!(
        modes,
        [AlphaMode::Mask, AlphaMode::Blend, AlphaMode::Blend],
        "{names:?}"
    );
    let blend = s.materials[1];
    assert_eq!(blend.alpha, 0.3);
    assert!(s.materials[0].base_texture.is_some());
    let transmission = names.iter().position(|n| n == "GlassTransmission").unwrap();
    // KHR_materials_transmission, thin and unlit: OPAQUE glass becomes a clear (white filter,
    // τ = 1) transmissive surface of coverage 1.
    let glass = s.materials[transmission];
    assert_eq!(glass.mode, AlphaMode::Blend);
    assert_eq!((glass.alpha, glass.transmission), (1.0, 1.0));
    assert!(glass.is_transmissive());
    assert!(
        s.ignored.iter().any(|l| l
            .contains("KHR_materials_transmission on /materials/2 (GlassTransmission)")
            && l.contains("refraction ignored")),
        "{:?}",
        s.ignored
    );
    assert!(s.ignored.iter().any(|l| l.contains("KHR_materials_volume")));
    assert!(s.triangle_count() > 10_000);
    check_common(&s, &path);
}

#[test]
fn node_hierarchy_composes_trs_and_matrix() {
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let mut doc = single_mesh(pos, json!({}));
    // Parent: translate (10, 0, 0) by matrix; child: scale 2 then rotate 90° about Z.
    let s2 = std::f32::consts::FRAC_1_SQRT_2;
    doc["nodes"] = json!([
        {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 10,0,0,1], "children": [1]},
        {"mesh": 0, "rotation": [0, 0, s2, s2], "scale": [2, 2, 2], "translation": [0, 0, 5]}
    ]);
    let s = load_text("hier", &d.gltf(doc)).unwrap();
    let p: Vec<[f32; 3]> = s.vertices.iter().map(|v| v.position).collect();
    let close = |a: [f32; 3], b: [f32; 3]| (Vec3::from(a) - Vec3::from(b)).length() < 1e-5;
    assert!(close(p[0], [10.0, 0.0, 5.0]), "{p:?}");
    assert!(close(p[1], [10.0, 2.0, 5.0]), "{p:?}");
    assert!(close(p[2], [8.0, 0.0, 5.0]), "{p:?}");
    assert_eq!(s.draws[0].name, "asset.gltf /nodes/1 mesh 0 primitive 0");
    // No COLOR_0: white; no TEXCOORD_0: (0, 0); no material: the glTF default.
    assert!(
        s.vertices
            .iter()
            .all(|v| v.color == [1.0; 4] && v.uv == [0.0; 2])
    );
    assert_eq!(s.materials.len(), 1);
    assert_eq!(s.materials[0].mode, AlphaMode::Opaque);
    assert!(!s.materials[0].double_sided);
}

fn signed_area_z(s: &Scene) -> Vec<f32> {
    s.vertices
        .chunks(3)
        .map(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|v| Vec3::from(v.position));
            (b - a).cross(c - a).z
        })
        .collect()
}

#[test]
fn mirroring_keeps_front_faces_front() {
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let mut doc = single_mesh(pos, json!({}));
    // Mirrored in x, the triangle keeps its local +Z front side. Kept in order its corners
    // would turn clockwise seen from +Z (a back face); the loader swaps two of them.
    doc["nodes"] = json!([{"mesh": 0, "scale": [-1, 1, 1]}]);
    let s = load_text("mirror", &d.gltf(doc)).unwrap();
    assert!(signed_area_z(&s)[0] > 0.0, "{:?}", s.vertices);
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let s = load_text("plain", &d.gltf(single_mesh(pos, json!({})))).unwrap();
    assert!(signed_area_z(&s)[0] > 0.0);
}

#[test]
fn strips_and_fans_become_lists() {
    // A quad as a 4-vertex strip and as a 4-vertex fan: 2 triangles each, both front-facing.
    let strip = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0];
    let fan = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
    for (mode, v) in [(5, strip), (6, fan)] {
        let mut d = Data::default();
        let pos = d.f32s(&v, "VEC3");
        let s = load_text(
            &format!("mode{mode}"),
            &d.gltf(single_mesh(pos, json!({"mode": mode}))),
        )
        .unwrap();
        assert_eq!(s.triangle_count(), 2, "mode {mode}");
        let areas = signed_area_z(&s);
        assert!(areas.iter().all(|a| *a > 0.0), "mode {mode}: {areas:?}");
        // Together they cover the unit square.
        assert!((areas.iter().sum::<f32>() - 2.0).abs() < 1e-6);
    }
}

#[test]
fn normalized_colours_and_texcoords() {
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    // COLOR_0 as VEC3 normalized UNSIGNED_BYTE (alpha becomes 1), padded to 4-byte elements
    // by the stride.
    let color_bytes = [255u8, 0, 51, 0, 0, 255, 0, 0, 102, 102, 102, 0];
    let color = d.add(&color_bytes, 5121, "VEC3", 3, true);
    d.views[1]["byteStride"] = json!(4);
    let uv = d.u16s(&[0, 65535, 65535, 0, 32768, 16384], "VEC2", 3, true);
    let doc = single_mesh(
        pos,
        json!({"attributes": {"POSITION": pos, "COLOR_0": color, "TEXCOORD_0": uv}}),
    );
    let s = load_text("norm", &d.gltf(doc)).unwrap();
    let v = &s.vertices;
    assert_eq!(v[0].color, [1.0, 0.0, 0.2, 1.0]);
    assert_eq!(v[1].color, [0.0, 1.0, 0.0, 1.0]);
    assert_eq!(v[2].color, [0.4, 0.4, 0.4, 1.0]);
    assert_eq!(v[0].uv, [0.0, 1.0]);
    assert_eq!(v[1].uv, [1.0, 0.0]);
    assert_eq!(
        v[2].uv,
        [(32768.0f64 / 65535.0) as f32, (16384.0f64 / 65535.0) as f32]
    );
}

/// A triangle with uvs (0,0), (1,0), (0,1), material 0 and the given materials, textures,
/// samplers and images (images as bufferViews holding `pngs`).
fn textured(
    pngs: &[Vec<u8>],
    materials: serde_json::Value,
    textures: serde_json::Value,
    samplers: serde_json::Value,
) -> String {
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let uv = d.f32s(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0], "VEC2");
    let images: Vec<_> = pngs
        .iter()
        .map(|p| json!({"bufferView": d.view(p), "mimeType": "image/png"}))
        .collect();
    let mut doc = single_mesh(
        pos,
        json!({"attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "material": 0}),
    );
    doc["materials"] = materials;
    doc["textures"] = textures;
    doc["samplers"] = samplers;
    doc["images"] = json!(images);
    d.gltf(doc)
}

#[test]
fn image_formats_decode_to_8_bit_codes() {
    let srgb = |c: f64, max: f64| srgb_to_linear(c / max);
    let cases: Vec<(Vec<u8>, [f32; 4])> = vec![
        // RGBA8: sRGB colour, linear alpha.
        (
            png(1, 1, 6, 8, &[128, 64, 255, 51]),
            [
                srgb(128.0, 255.0),
                srgb(64.0, 255.0),
                1.0,
                (51.0f64 / 255.0) as f32,
            ],
        ),
        // RGB8: alpha 1.
        (
            png(1, 1, 2, 8, &[10, 20, 30]),
            [srgb(10.0, 255.0), srgb(20.0, 255.0), srgb(30.0, 255.0), 1.0],
        ),
        // Grey+alpha: alpha is the second channel.
        (
            png(1, 1, 4, 8, &[200, 100]),
            [
                srgb(200.0, 255.0),
                srgb(200.0, 255.0),
                srgb(200.0, 255.0),
                (100.0f64 / 255.0) as f32,
            ],
        ),
        // 16-bit grey: rounded to the nearest 8-bit code (32768 → 127.502 → 128), as engines
        // store it; the scene says so.
        (
            png(1, 1, 0, 16, &[0x80, 0x00]),
            [
                srgb(128.0, 255.0),
                srgb(128.0, 255.0),
                srgb(128.0, 255.0),
                1.0,
            ],
        ),
        // 16-bit grey+alpha: alpha 16384 → 63.75 → 64.
        (
            png(1, 1, 4, 16, &[0xff, 0xff, 0x40, 0x00]),
            [1.0, 1.0, 1.0, (64.0f64 / 255.0) as f32],
        ),
    ];
    for (k, (image, want)) in cases.into_iter().enumerate() {
        let text = textured(
            &[image],
            json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]),
            json!([{"source": 0}]),
            json!([]),
        );
        let s = load_text(&format!("img{k}"), &text).unwrap();
        assert_eq!(s.textures.len(), 1);
        assert_eq!((s.textures[0].width(), s.textures[0].height()), (1, 1));
        assert_eq!(s.textures[0].texel(0), want, "case {k}");
        assert_eq!(s.textures[0].name, "asset.gltf /images/0");
        let quantised = s.ignored.iter().any(|i| {
            i.contains(
                "asset.gltf /images/0: 16-bit image stored as 8-bit codes (rounded to nearest",
            )
        });
        assert_eq!(quantised, k >= 3, "case {k}: {:?}", s.ignored);
    }
}

#[test]
fn textures_follow_samplers_and_are_shared() {
    let image = png(2, 1, 6, 8, &[255, 0, 0, 255, 0, 255, 0, 128]);
    let materials = json!([
        {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": [1, 0.5, 0.25, 0.8]},
         "emissiveTexture": {"index": 0}, "emissiveFactor": [1, 0.5, 0],
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}},
         "alphaMode": "MASK", "alphaCutoff": 1.5, "doubleSided": true},
        {"pbrMetallicRoughness": {"baseColorTexture": {"index": 1, "texCoord": 1}}, "alphaMode": "BLEND"}
    ]);
    let textures = json!([{"source": 0, "sampler": 0}, {"source": 0}]);
    let samplers = json!([{"wrapS": 33071, "wrapT": 33648, "magFilter": 9728, "minFilter": 9985}]);
    let mut doc: serde_json::Value =
        serde_json::from_str(&textured(&[image], materials, textures, samplers)).unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    let s = load_text("samplers", &doc.to_string()).unwrap();
    // Same image, two wrap pairs: two textures; base and emissive of material 0 share one.
    assert_eq!(s.textures.len(), 2);
    assert_eq!(
        (
            s.textures[0].sampler().wrap_u,
            s.textures[0].sampler().wrap_v
        ),
        (Wrap::ClampToEdge, Wrap::MirroredRepeat)
    );
    assert_eq!(
        (
            s.textures[1].sampler().wrap_u,
            s.textures[1].sampler().wrap_v
        ),
        (Wrap::Repeat, Wrap::Repeat)
    );
    // The filters: NEAREST magnification, LINEAR_MIPMAP_NEAREST; no sampler is what engines
    // use, LINEAR and LINEAR_MIPMAP_LINEAR. Both build the 2×1 image's chain (2 levels).
    let (nearest, default) = (s.textures[0].sampler(), s.textures[1].sampler());
    assert_eq!(
        (nearest.mag, nearest.min, nearest.mip),
        (Filter::Nearest, Filter::Linear, MipFilter::Nearest)
    );
    assert_eq!(
        (default.mag, default.min, default.mip),
        (Filter::Linear, Filter::Linear, MipFilter::Linear)
    );
    assert_eq!((s.textures[0].levels(), s.textures[1].levels()), (2, 2));
    let m = s.materials[0];
    assert_eq!((m.base_texture, m.emissive_texture), (Some(0), Some(0)));
    assert_eq!(m.base_color, [1.0, 0.5, 0.25]);
    assert_eq!(m.alpha, 0.8);
    assert_eq!(m.emissive, [4.0, 2.0, 0.0]);
    assert_eq!(
        (m.mode, m.cutoff, m.double_sided),
        (AlphaMode::Mask, 1.5, true)
    );
    assert_eq!(s.materials[1].mode, AlphaMode::Blend);
    assert_eq!(s.materials[1].base_texture, Some(1));
    assert!(
        s.ignored.contains(
            &"asset.gltf: texCoord 1 of pbrMetallicRoughness/baseColorTexture on /materials/1: ignored (TEXCOORD_0 used)".to_owned()
        ),
        "{:?}",
        s.ignored
    );
}

#[test]
fn texture_transform_follows_the_extension_example() {
    // offset (0, 1), rotation π/2, scale 0.5 maps the unit square onto the lower-left quadrant.
    let image = png(1, 1, 6, 8, &[255, 255, 255, 255]);
    let tt =
        json!({"offset": [0, 1], "rotation": std::f32::consts::FRAC_PI_2, "scale": [0.5, 0.5]});
    let materials = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": tt}}}}]);
    let mut doc: serde_json::Value = serde_json::from_str(&textured(
        &[image],
        materials,
        json!([{"source": 0}]),
        json!([]),
    ))
    .unwrap();
    doc["extensionsUsed"] = json!(["KHR_texture_transform"]);
    doc["extensionsRequired"] = json!(["KHR_texture_transform"]);
    let s = load_text("tt", &doc.to_string()).unwrap();
    let uv: Vec<[f32; 2]> = s.vertices.iter().map(|v| v.uv).collect();
    let want = [[0.0, 1.0], [0.0, 0.5], [0.5, 1.0]];
    for (got, want) in uv.iter().zip(want) {
        assert!(
            (got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6,
            "{uv:?}"
        );
    }
    assert!(s.ignored.is_empty(), "{:?}", s.ignored);
}

#[test]
fn oversized_textures_are_errors() {
    let wide = png(8193, 1, 0, 8, &[7u8; 8193]);
    let text = textured(
        &[wide],
        json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]),
        json!([{"source": 0}]),
        json!([]),
    );
    let p = problem_at(load_text("wide", &text), "/images/0");
    assert_eq!(
        p,
        Problem::TextureTooLarge {
            width: 8193,
            height: 1
        }
    );
}

#[test]
fn a_placed_asset_without_triangles_ignores_its_instance_count() {
    // Found by the fuzzer: with no triangles the triangle cap never bounds the instances, and
    // 2·4294967295 instances of a primitive with two vertices looped for hours.
    let dir = Scratch::new("no-triangles");
    let mut d = Data::default();
    let pos = d.f32s(&TRI[..6], "VEC3");
    dir.write("two.gltf", d.gltf(single_mesh(pos, json!({}))).as_bytes());
    let scene = json!({
        "name": "none",
        "camera": {"eye": [0, 0, 10], "target": [0, 0, 0]},
        "objects": [
            {"mesh": {"kind": "gltf", "file": "two.gltf"},
             "instances": {"counts": [2, 1, 4_294_967_295u32], "spacing": [1, 0, 0]}},
            {"mesh": {"kind": "quad"}}
        ]
    });
    let path = dir.write("scene.json", scene.to_string().as_bytes());
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || send.send(oit_scene::load(&path).map(|s| s.draws.len())));
    let loaded = receive
        .recv_timeout(std::time::Duration::from_secs(20))
        .expect("still loading after 20 s");
    assert_eq!(loaded.unwrap(), 1, "only the quad draws");
}

#[test]
fn json_object_kind_gltf_places_the_asset() {
    let dir = Scratch::new("json-object");
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    std::fs::create_dir_all(dir.0.join("models")).unwrap();
    dir.write(
        "models/tri.gltf",
        d.gltf(single_mesh(pos, json!({}))).as_bytes(),
    );
    let scene = json!({
        "name": "placed",
        "camera": {"eye": [0, 0, 10], "target": [0, 0, 0]},
        "lighting": {"directional": {"direction": [0, 0, -1], "color": [0.5, 0.5, 0.5], "ambient": [0.25, 0.25, 0.25]}},
        "objects": [
            {"mesh": {"kind": "quad"}},
            {"mesh": {"kind": "gltf", "file": "models/tri.gltf", "lighting": "unlit"}, "transform": {"translate": [5, 0, 0], "scale": [2, 2, 2]},
             "render_group": 3, "alpha_index": -2, "instances": {"counts": [1, 1, 2], "spacing": [0, 0, 1]}}
        ]
    });
    let path = dir.write("scene.json", scene.to_string().as_bytes());
    let s = oit_scene::load(&path).unwrap();
    assert_eq!(s.draws.len(), 3);
    let g = &s.draws[1];
    assert_eq!(
        g.name,
        "objects[1].instances[0] tri.gltf /nodes/0 mesh 0 primitive 0"
    );
    assert_eq!((g.ordering.group, g.ordering.order), (3, -2));
    let v = &s.vertices[g.vertex_range()];
    assert_eq!(v[1].position, [7.0, 0.0, 0.0]);
    assert_eq!(
        s.vertices[s.draws[2].vertex_range()][1].position,
        [7.0, 0.0, 1.0]
    );
    // Flat face normal +Z faces the light: 0.25 + 0.5.
    assert_eq!(v[0].color, [0.75, 0.75, 0.75, 1.0]);
    // The asset's default material follows the quad's.
    assert_eq!(g.material, 1);

    // With NORMAL, the vertex normal is lit (transformed by the inverse transpose): a normal
    // facing away from the light gets the ambient term only.
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let normals = d.f32s(&[0.0, 0.0, -1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0], "VEC3");
    let doc = single_mesh(
        pos,
        json!({"attributes": {"POSITION": pos, "NORMAL": normals}}),
    );
    dir.write("models/normals.gltf", d.gltf(doc).as_bytes());
    let mut lit = scene.clone();
    lit["objects"][1]["mesh"]["file"] = json!("models/normals.gltf");
    let path = dir.write("normals.json", lit.to_string().as_bytes());
    let s = oit_scene::load(&path).unwrap();
    let v = &s.vertices[s.draws[1].vertex_range()];
    assert_eq!(v[0].color, [0.25, 0.25, 0.25, 1.0]);
    assert_eq!(v[2].color, [0.75, 0.75, 0.75, 1.0]);

    // `material` on a gltf object is an error; so is a missing file, named by its path.
    let bad = json!({"name": "x", "camera": {"eye": [0, 0, 1], "target": [0, 0, 0]},
        "objects": [{"mesh": {"kind": "gltf", "file": "models/tri.gltf"}, "material": {"alpha": 0.5}}]});
    let p = dir.write("bad.json", bad.to_string().as_bytes());
    let e = problem_at(oit_scene::load(&p), "objects[0].material");
    assert!(matches!(e, Problem::GltfObjectField { .. }), "{e}");
    let missing = json!({"name": "x", "camera": {"eye": [0, 0, 1], "target": [0, 0, 0]},
        "objects": [{"mesh": {"kind": "gltf", "file": "models/none.glb"}}]});
    let p = dir.write("missing.json", missing.to_string().as_bytes());
    assert!(
        matches!(oit_scene::load(&p), Err(SceneError::Io { file, .. }) if file.ends_with("none.glb"))
    );
    let scene_oob = json!({"name": "x", "camera": {"eye": [0, 0, 1], "target": [0, 0, 0]},
        "objects": [{"mesh": {"kind": "gltf", "file": "models/tri.gltf", "scene": 4}}]});
    let p = dir.write("oob.json", scene_oob.to_string().as_bytes());
    let e = problem_at(oit_scene::load(&p), "objects[0].mesh.scene");
    assert_eq!(e, Problem::NoSuchItem { index: 4, count: 1 });
}

#[test]
fn load_dir_picks_up_gltf_files() {
    let dir = Scratch::new("dir");
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let text = d.gltf(single_mesh(pos, json!({})));
    dir.write("b.gltf", text.as_bytes());
    dir.write("c.GLB", &glb(&text, None));
    dir.write(
        "a.json",
        json!({"name": "a", "camera": {"eye": [0, 0, 1], "target": [0, 0, 0]}, "objects": []})
            .to_string()
            .as_bytes(),
    );
    dir.write("notes.txt", b"ignored");
    let scenes = oit_scene::load_dir(&dir.0).unwrap();
    let names: Vec<_> = scenes.iter().map(|(_, s)| s.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "c"]);
}

#[test]
fn cameras_from_the_asset() {
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let mut doc = single_mesh(pos, json!({}));
    doc["cameras"] = json!([
        {"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}},
        {"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 3, "znear": 0, "zfar": 50}}
    ]);
    doc["nodes"] = json!([{"mesh": 0}, {"camera": 1, "translation": [0, 0, 20]}, {"camera": 0, "translation": [0, 0, 5]}]);
    doc["scenes"] = json!([{"nodes": [0, 1, 2]}]);
    let text = d.gltf(doc);
    let dir = Scratch::new("cams");
    let path = dir.write("cams.gltf", text.as_bytes());
    // First camera in node order: node 1's orthographic camera.
    let s = oit_scene::load(&path).unwrap();
    assert_eq!(
        s.camera.projection,
        oit_scene::Projection::Orthographic { height: 6.0 }
    );
    assert_eq!(s.camera.eye, Vec3::new(0.0, 0.0, 20.0));
    assert_eq!((s.camera.near, s.camera.far), (0.0, 50.0));
    let s = oit_scene::load_with(
        &path,
        &LoadOptions {
            camera: Some(0),
            ..Default::default()
        },
    )
    .unwrap();
    let oit_scene::Projection::Perspective { fov_y_degrees } = s.camera.projection else {
        panic!()
    };
    assert!((fov_y_degrees - 0.5f32.to_degrees()).abs() < 1e-4);
    // Infinite far: a finite far beyond the scene.
    assert!(s.camera.far.is_finite() && s.camera.far > 5.0);
    let s2 = s.with_resolution(oit_scene::Resolution {
        width: 512,
        height: 256,
    });
    assert_eq!(s2.camera.eye, s.camera.eye);
    let e = problem_at(
        oit_scene::load_with(
            &path,
            &LoadOptions {
                camera: Some(2),
                ..Default::default()
            },
        ),
        "/cameras",
    );
    assert_eq!(e, Problem::NoSuchItem { index: 2, count: 2 });
}

// ---- errors: each names its pointer and problem class ----

#[test]
fn glb_container_errors() {
    let dir = Scratch::new("glb");
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let good = glb(&d.gltf(single_mesh(pos, json!({}))), None);
    let load = |name: &str, bytes: &[u8]| oit_scene::load(&dir.write(name, bytes));
    assert!(load("ok.glb", &good).is_ok());
    let p = problem_at(load("magic.glb", b"GLTF\x02\0\0\0"), "(glb header)");
    assert!(matches!(p, Problem::GlbStructure { .. }), "{p}");
    let p = problem_at(load("short.glb", &good[..10]), "(glb header)");
    assert!(
        p.to_string().contains("shorter than the 12-byte header"),
        "{p}"
    );
    let p = problem_at(load("trunc.glb", &good[..good.len() - 4]), "(glb header)");
    assert!(p.to_string().contains("differs from the file size"), "{p}");
    let mut long_chunk = good.clone();
    long_chunk[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    let p = problem_at(load("chunk.glb", &long_chunk), "(glb chunk 0)");
    assert!(p.to_string().contains("runs past the end"), "{p}");
    let mut version = good.clone();
    version[4] = 1;
    assert!(matches!(
        problem_at(load("v1.glb", &version), "(glb header)"),
        Problem::GlbStructure { .. }
    ));
}

#[test]
fn json_and_schema_errors() {
    let p = load_text("syntax", "{\"asset\": {\"version\": \"2.0\"},,}");
    let p = problem_at(p, "(json)");
    assert!(matches!(p, Problem::Syntax { line: 1, .. }), "{p}");
    // An index out of range is the crate's validation error, as a pointer.
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let mut doc = single_mesh(pos, json!({}));
    doc["nodes"][0]["mesh"] = json!(7);
    let p = problem_at(load_text("schema", &d.gltf(doc)), "/nodes/0/mesh");
    assert!(matches!(p, Problem::GltfInvalid { .. }), "{p}");
    // Required extensions that are not modelled.
    let mut doc = single_mesh(pos, json!({}));
    doc["extensionsRequired"] = json!([
        "KHR_texture_transform",
        "KHR_materials_transmission",
        "KHR_materials_volume",
        "EXT_meshopt_compression"
    ]);
    let p = problem_at(load_text("required", &d.gltf(doc)), "/extensionsRequired");
    match p {
        Problem::UnsupportedExtension { names, .. } => {
            assert_eq!(names, "KHR_materials_volume, EXT_meshopt_compression")
        }
        other => panic!("{other}"),
    }
}

#[test]
fn data_errors() {
    // Missing external buffer file.
    let doc =
        json!({"asset": {"version": "2.0"}, "buffers": [{"uri": "nowhere.bin", "byteLength": 4}]});
    let p = problem_at(load_text("nofile", &doc.to_string()), "/buffers/0/uri");
    assert!(
        matches!(&p, Problem::ExternalData { uri, .. } if uri == "nowhere.bin"),
        "{p}"
    );
    // Buffer shorter than byteLength.
    let doc = json!({"asset": {"version": "2.0"}, "buffers": [{"uri": "data:application/octet-stream;base64,AAAA", "byteLength": 8}]});
    let p = problem_at(
        load_text("shortbuf", &doc.to_string()),
        "/buffers/0/byteLength",
    );
    assert_eq!(
        p,
        Problem::BufferTooShort {
            expected: 8,
            actual: 3
        }
    );
    // Accessor reaching past its bufferView.
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    d.accessors[pos]["count"] = json!(4);
    let p = problem_at(
        load_text("oob", &d.gltf(single_mesh(pos, json!({})))),
        "/accessors/0",
    );
    assert!(matches!(p, Problem::AccessorOutOfBounds { .. }), "{p}");
    // Wrong component type for POSITION.
    let mut d = Data::default();
    let pos = d.u16s(&[0; 9], "VEC3", 3, false);
    d.accessors[pos]["min"] = json!([0, 0, 0]);
    d.accessors[pos]["max"] = json!([0, 0, 0]);
    let p = problem_at(
        load_text("type", &d.gltf(single_mesh(pos, json!({})))),
        "/meshes/0/primitives/0/attributes/POSITION",
    );
    assert!(matches!(p, Problem::AccessorFormat { .. }), "{p}");
    // NaN position.
    let mut d = Data::default();
    let mut v = TRI;
    v[4] = f32::NAN;
    let pos = d.f32s(&v, "VEC3");
    let p = problem_at(
        load_text("nan", &d.gltf(single_mesh(pos, json!({})))),
        "/accessors/0",
    );
    assert!(matches!(p, Problem::BadValue { .. }), "{p}");
    // Index out of range.
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let idx = d.u16s(&[0, 1, 3], "SCALAR", 3, false);
    let p = problem_at(
        load_text("index", &d.gltf(single_mesh(pos, json!({"indices": idx})))),
        "/accessors/1",
    );
    assert_eq!(p, Problem::IndexOutOfRange { index: 3, count: 3 });
    // Points are not triangles.
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let p = problem_at(
        load_text("points", &d.gltf(single_mesh(pos, json!({"mode": 0})))),
        "/meshes/0/primitives/0/mode",
    );
    assert!(matches!(p, Problem::UnsupportedPrimitiveMode { .. }), "{p}");
    // Absurd counts are refused before anything is read or allocated: 3e9 indices over a
    // 36-byte bufferView are 1e9 triangles, checked against the cap first.
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let mut doc = single_mesh(pos, json!({}));
    d.accessors.push(json!({"bufferView": 0, "componentType": 5125, "type": "SCALAR", "count": 3_000_000_000u64}));
    doc["meshes"][0]["primitives"][0]["indices"] = json!(1);
    let p = problem_at(load_text("cap", &d.gltf(doc)), "/meshes");
    assert_eq!(
        p,
        Problem::TooManyTriangles {
            count: 1_000_000_000
        }
    );
    // Unsupported image format.
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let mut doc = single_mesh(pos, json!({"material": 0}));
    doc["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["textures"] = json!([{"source": 0}]);
    doc["images"] = json!([{"uri": "picture.webp"}]);
    let p = problem_at(load_text("webp", &d.gltf(doc.clone())), "/images/0/uri");
    assert!(matches!(p, Problem::UnsupportedImage { .. }), "{p}");
    doc["images"] = json!([{"bufferView": 0, "mimeType": "image/ktx2"}]);
    let p = problem_at(load_text("ktx", &d.gltf(doc.clone())), "/images/0/mimeType");
    assert!(matches!(p, Problem::UnsupportedImage { .. }), "{p}");
    // Bytes that claim to be PNG but are not.
    doc["images"] = json!([{"bufferView": 0, "mimeType": "image/png"}]);
    let p = problem_at(load_text("notpng", &d.gltf(doc)), "/images/0");
    assert!(matches!(p, Problem::ImageDecode { .. }), "{p}");
}

#[test]
fn node_cycles_are_errors_not_hangs() {
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let mut doc = single_mesh(pos, json!({}));
    doc["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}]);
    let p = problem_at(load_text("cycle", &d.gltf(doc)), "/nodes/0");
    assert_eq!(p, Problem::NodeNotTree { node: 0 });
    let mut doc = single_mesh(pos, json!({}));
    doc["nodes"] = json!([{"children": [1]}, {"children": [2]}, {"mesh": 0, "children": [1]}]);
    let p = problem_at(load_text("cycle2", &d.gltf(doc)), "/nodes/1");
    assert_eq!(p, Problem::NodeNotTree { node: 1 });
}

#[test]
fn inputs_that_panic_inside_gltf_json_are_errors() {
    // gltf-json 1.4.1 indexes, or unwraps, these before or without validating them.
    let mut d = Data::default();
    let pos = d.f32s(&TRI, "VEC3");
    let doc = single_mesh(9, json!({}));
    let p = problem_at(
        load_text("posidx", &d.gltf(doc)),
        "/meshes/0/primitives/0/attributes",
    );
    assert!(matches!(p, Problem::GltfInvalid { .. }), "{p}");
    let mut doc = single_mesh(pos, json!({}));
    doc["images"] = json!([{}]);
    let p = problem_at(load_text("noimg", &d.gltf(doc.clone())), "/images/0");
    assert!(matches!(p, Problem::GltfInvalid { .. }), "{p}");
    doc["images"] = json!([{"bufferView": 0}]);
    let p = problem_at(
        load_text("nomime", &d.gltf(doc.clone())),
        "/images/0/mimeType",
    );
    assert!(matches!(p, Problem::GltfInvalid { .. }), "{p}");
    doc["images"] = json!([]);
    doc["cameras"] = json!([{"type": "orthographic", "perspective": {"yfov": 1, "znear": 1}}]);
    let p = problem_at(load_text("camtype", &d.gltf(doc)), "/cameras/0");
    assert!(matches!(p, Problem::GltfInvalid { .. }), "{p}");
}

/// A glass dome as real assets write it: transmissionFactor 1, no metallicFactor (so 1) and a
/// metallic-roughness texture whose blue channel (metalness) is 0 over the glass. glTF's
/// transmission is the dielectric part's, so τ = 1 × (1 − 1 × 0) = 1: clear glass, not an
/// opaque white dome. Without the texture the factor alone makes it metal (τ = 0), and a
/// texture of mixed metalness is approximated by its mean; each is said in `ignored`, one line
/// per property, naming every material it applies to.
#[test]
fn transmission_takes_metalness_from_the_metallic_roughness_texture_and_says_so() {
    // 2x1 RGB: green = roughness, blue = metalness.
    let dielectric = png(2, 1, 2, 8, &[0, 200, 0, 0, 90, 0]);
    let mixed = png(2, 1, 2, 8, &[0, 200, 0, 0, 90, 255]);
    let glass = |name: &str, texture: Option<u32>| {
        let mut pbr = json!({"baseColorFactor": [1, 1, 1, 1]});
        if let Some(t) = texture {
            pbr["metallicRoughnessTexture"] = json!({"index": t});
        }
        json!({
            "name": name,
            "pbrMetallicRoughness": pbr,
            "normalTexture": {"index": 0},
            "extensions": {
                "KHR_materials_transmission": {"transmissionFactor": 1},
                "KHR_materials_volume": {"thicknessFactor": 0.1}
            }
        })
    };
    let materials = json!([
        glass("Dome", Some(0)),
        glass("Shade", Some(1)),
        glass("NoTexture", None)
    ]);
    let mut doc: serde_json::Value = serde_json::from_str(&textured(
        &[dielectric, mixed],
        materials,
        json!([{"source": 0}, {"source": 1}]),
        json!([]),
    ))
    .unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_transmission", "KHR_materials_volume"]);
    let s = load_text("glass-dome", &doc.to_string()).unwrap();
    let [dome, shade, metal] = [s.materials[0], s.materials[1], s.materials[2]];
    assert_eq!(
        (dome.transmission, dome.mode, dome.alpha),
        (1.0, AlphaMode::Blend, 1.0)
    );
    assert!(dome.is_transmissive());
    assert_eq!((shade.transmission, shade.mode), (0.5, AlphaMode::Blend));
    assert_eq!((metal.transmission, metal.mode), (0.0, AlphaMode::Opaque));
    let line = |l: &str| {
        assert!(
            s.ignored.iter().any(|i| i == l),
            "missing {l:?} in {:#?}",
            s.ignored
        );
    };
    line(
        "asset.gltf: metallicRoughnessTexture (metalness) with KHR_materials_transmission on /materials/0 (Dome): metallic = metallicFactor 1 × mean blue of /images/0 0.0000 (exact: the channel is uniform)",
    );
    line(
        "asset.gltf: metallicRoughnessTexture (metalness) with KHR_materials_transmission on /materials/1 (Shade): metallic = metallicFactor 1 × mean blue of /images/1 0.5000 (approximated: per-texel metalness not modelled, the channel spans 0.000..1.000)",
    );
    line(
        "asset.gltf: metallic transmission on /materials/1 (Shade): transmissionFactor 1 applies to the dielectric part only: τ = 1 × (1 − metallic 0.5) = 0.5; the metallic part renders as the base colour, unlit",
    );
    line(
        "asset.gltf: metallic transmission on /materials/2 (NoTexture): transmissionFactor 1 applies to the dielectric part only: τ = 1 × (1 − metallic 1) = 0 (metallicFactor 1, also glTF's default when absent); the metallic part renders as the base colour, unlit",
    );
    line(
        "asset.gltf: KHR_materials_transmission on /materials/2 (NoTexture): τ = 0: not modelled; the material renders with its alphaMode (OPAQUE here)",
    );
    line(
        "asset.gltf: metallicRoughnessTexture on /materials/0 (Dome), /materials/1 (Shade): roughness and per-texel metalness not modelled (its mean metalness sets τ)",
    );
    // One line per property and explanation, naming every material it applies to.
    line(
        "asset.gltf: normalTexture on /materials/0 (Dome), /materials/1 (Shade), /materials/2 (NoTexture): not modelled (geometric or vertex normals only)",
    );
    line(
        "asset.gltf: KHR_materials_volume on /materials/0 (Dome), /materials/1 (Shade), /materials/2 (NoTexture): not modelled (thin: no thickness, absorption or refraction)",
    );
    assert!(
        s.ignored.iter().any(|l| l.starts_with(
            "asset.gltf: KHR_materials_transmission on /materials/0 (Dome): modelled thin and unlit (τ = 1,"
        )),
        "{:#?}",
        s.ignored
    );
    let volume = s
        .ignored
        .iter()
        .filter(|l| l.contains("KHR_materials_volume on"))
        .count();
    assert_eq!(volume, 1, "{:#?}", s.ignored);
    // Every material is named by every line about it: nothing is lost without a line.
    for m in ["(Dome)", "(Shade)", "(NoTexture)"] {
        assert!(
            s.ignored.iter().filter(|l| l.contains(m)).count() >= 3,
            "{m}: {:#?}",
            s.ignored
        );
    }
}

/// GlassVaseFlowers: the flowers' normal map and metallic-roughness texture, which are not
/// sampled, and the vase's volume each get a line.
#[test]
fn glass_vase_flowers_lists_its_unsampled_textures() {
    let s = oit_scene::load(&asset(GLASS_VASE)).unwrap();
    for want in [
        "GlassVaseFlowers.glb: normalTexture on /materials/0 (Flowers): not modelled (geometric or vertex normals only)",
        "GlassVaseFlowers.glb: metallicRoughnessTexture on /materials/0 (Flowers): not modelled (metallicFactor and roughnessFactor light the material alone)",
        "GlassVaseFlowers.glb: KHR_materials_volume on /materials/2 (GlassTransmission): not modelled (thin: no thickness, absorption or refraction)",
    ] {
        assert!(
            s.ignored.iter().any(|l| l == want),
            "missing {want:?} in {:#?}",
            s.ignored
        );
    }
}
