//! glTF 2.0 assets (`.gltf`, `.glb`) flattened into the same [`Scene`] the JSON format builds:
//! every mesh instance of the chosen scene becomes world-space triangles (one [`Draw`] per
//! primitive instance), glTF materials map onto [`Material`] (base colour, alpha mode, cutoff,
//! double-sidedness, emission, base-colour and emissive textures), and what is read but not
//! modelled is listed in [`Scene::ignored`]. Node animations of a file loaded directly are
//! played ([`animation`]). docs/scene-format.md ("glTF 2.0") is the contract.
//!
//! Errors name the file and a JSON pointer into the asset (`/meshes/2/primitives/0/mode`), or
//! `(glb header)` / `(glb chunk N)` for the binary container.

mod accessor;
mod animation;
mod file;
mod image;
mod lights;
mod notes;
mod source;
mod texture_cache;
use texture_cache::TextureCache;

pub use animation::GLTF_FPS;
use file::read;
pub(crate) use file::{GltfFrames, load_bytes, load_file_frames, load_file_with_inputs};
use notes::MaterialNotes;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::Document;
use gltf::mesh::Mode;

use crate::error::{Problem, SceneError};
use crate::format::{DEFAULT_RESOLUTION, MAX_TRIANGLES};
use crate::lighting::{LightKind, PunctualLight, Reflectance, Specular};
use crate::load::{Light, LoadOptions};
use crate::scene::{AlphaMode, Camera, Draw, Material, Projection, Scene, Vertex};
use crate::texture::{Encoding, MAX_UV, Sampler, Texture, Wrap};

type Result<T> = std::result::Result<T, SceneError>;

/// Cap on level-0 texels per scene: 256 Mi texels are 1 GiB of 8-bit RGBA codes (1.33 GiB
/// with mip chains, 86 of the 256 texel pages every adapter allows), room for a Sponza-class
/// asset; what a comparison may hold beyond that is `--memory-budget`'s to refuse.
pub const MAX_TEXELS: u64 = 256 * 1024 * 1024;

/// Extensions an asset may list in `extensionsRequired`: the ones modelled here.
const SUPPORTED_REQUIRED: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_materials_transmission",
    "KHR_texture_transform",
    "KHR_lights_punctual",
    "KHR_materials_unlit",
];

/// Background of a glTF file loaded directly: linear 0.18, photographic middle grey, so both
/// dark and bright transparent surfaces stay visible.
pub const GLTF_BACKGROUND: [f32; 3] = [0.18, 0.18, 0.18];

/// Vertical field of view of the framing camera (used when the asset has no camera).
const FRAMING_FOV_Y: f32 = 45.0;

/// Error context: the file named in messages, and the files read for it.
pub(crate) struct Cx {
    file: String,
    /// Every file read for the asset other than itself (buffers, images), in reading order:
    /// outputs must never land on them.
    read: std::cell::RefCell<Vec<PathBuf>>,
}

impl Cx {
    /// Records a file read for the asset.
    fn note_read(&self, path: PathBuf) {
        let mut read = self.read.borrow_mut();
        if !read.contains(&path) {
            read.push(path);
        }
    }

    fn err(&self, path: impl Into<String>, problem: Problem) -> SceneError {
        SceneError::Invalid {
            file: self.file.clone(),
            path: path.into(),
            problem,
        }
    }

    fn bad(
        &self,
        path: impl Into<String>,
        what: &str,
        value: impl ToString,
        allowed: &str,
    ) -> SceneError {
        self.err(
            path,
            Problem::BadValue {
                what: what.to_string(),
                value: value.to_string(),
                allowed: allowed.to_string(),
            },
        )
    }
}

/// A parsed, validated asset with its buffers read (images are decoded when materials are
/// added, and only those that materials use).
pub(crate) struct Asset {
    cx: Cx,
    /// File name, used in draw, texture and `ignored` names.
    name: String,
    base: PathBuf,
    doc: Document,
    buffers: Vec<gltf::buffer::Data>,
}

/// The node instances of one glTF scene, in depth-first node order.
pub(crate) struct Nodes {
    /// Scene index used, if the asset has scenes.
    scene: Option<usize>,
    /// (node, mesh, world matrix).
    meshes: Vec<(usize, usize, Mat4)>,
    /// (node, camera, world matrix).
    cameras: Vec<(usize, usize, Mat4)>,
    /// (node, `KHR_lights_punctual` light, world matrix).
    lights: Vec<(usize, usize, Mat4)>,
}

/// How an asset's materials are lit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum GltfLighting {
    /// Per pixel by the scene's lights (the default), with every material's specular rule
    /// overridden when `Some`; `KHR_materials_unlit` materials stay unlit.
    PerPixel(Option<Specular>),
    /// Every material unlit (vertex colours may still carry a JSON scene's baked light).
    Unlit,
}

/// Where and how an asset's geometry goes into a scene.
pub(crate) struct Placement<'a> {
    /// Applied on top of the node hierarchy (the JSON object's transform; identity otherwise).
    pub transform: Affine3A,
    /// Path reported when a value derived from the placement is non-finite (the JSON
    /// object's `transform`/`instances`); `None` reports the node's pointer instead.
    pub transform_path: Option<String>,
    pub light: Option<&'a Light>,
    /// The JSON object's place in engines' draw orders, for every draw of the asset.
    pub ordering: crate::Ordering,
    /// Prepended to draw names (e.g. `objects[2] `).
    pub name_prefix: String,
}

/// The scene materials an asset's materials became.
pub(crate) struct Materials {
    /// Scene index of glTF material 0 (the rest follow in order).
    first: u32,
    /// Scene index of the glTF default material, when some primitive has none.
    default: Option<u32>,
    /// Per glTF material: the KHR_texture_transform applied to TEXCOORD_0 at load time.
    uv_transforms: Vec<Option<UvTransform>>,
}

/// `uv' = T·R·S·uv` of KHR_texture_transform, as the matrix rows of a 2×3 affine map.
#[derive(Debug, Clone, Copy, PartialEq)]
struct UvTransform {
    u: [f32; 3],
    v: [f32; 3],
}

impl UvTransform {
    /// Scale, then rotate, then offset. The rotation follows the extension's worked example
    /// (offset (0, 1), rotation π/2, scale 0.5 selects the lower-left quadrant):
    /// `u' = u·cos r + v·sin r`, `v' = v·cos r − u·sin r`.
    fn new(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> Self {
        let (s, c) = rotation.sin_cos();
        UvTransform {
            u: [c * scale[0], s * scale[1], offset[0]],
            v: [-s * scale[0], c * scale[1], offset[1]],
        }
    }

    fn apply(&self, uv: Vec2) -> Vec2 {
        Vec2::new(
            self.u[0] * uv.x + self.u[1] * uv.y + self.u[2],
            self.v[0] * uv.x + self.v[1] * uv.y + self.v[2],
        )
    }
}

impl Placement<'_> {
    /// Where a non-finite derived value of `node` is reported.
    fn derived_path(&self, node: usize) -> String {
        self.transform_path
            .clone()
            .unwrap_or_else(|| format!("/nodes/{node}"))
    }
}

impl Asset {
    /// The files read for the asset so far besides the asset itself: external buffers, and
    /// the images of materials already added.
    pub(crate) fn files_read(&self) -> Vec<PathBuf> {
        self.cx.read.borrow().clone()
    }

    /// Reads, splits (GLB), parses, validates and loads the buffers of the asset at `path`.
    /// Errors name the file as `path` displays.
    pub(crate) fn open(path: &Path) -> Result<Asset> {
        Asset::from_bytes(path, &read(path)?)
    }

    /// [`Asset::open`] on bytes already read: `path` names the asset in errors, says whether
    /// it is GLB by its extension and is the base of relative URIs.
    fn from_bytes(path: &Path, bytes: &[u8]) -> Result<Asset> {
        let cx = Cx {
            file: path.display().to_string(),
            read: std::cell::RefCell::new(Vec::new()),
        };
        let is_glb = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
        let container = source::container(&cx, bytes, is_glb)?;
        let doc = source::document(&cx, container.json)?;
        let base = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let buffers = source::buffers(&cx, &doc, &base, container.bin)?;
        let name = path
            .file_name()
            .map_or_else(|| cx.file.clone(), |n| n.to_string_lossy().into_owned());
        Ok(Asset {
            cx,
            name,
            base,
            doc,
            buffers,
        })
    }

    /// The node instances of scene `requested` (reported at `path` in `file` if out of range),
    /// else the default scene, else scene 0, else every root node.
    pub(crate) fn nodes(
        &self,
        requested: Option<usize>,
        err: impl Fn(usize) -> SceneError,
    ) -> Result<Nodes> {
        self.nodes_posed(requested, err, None)
    }

    /// [`Asset::nodes`] with the local matrices of the nodes `pose` animates replaced.
    fn nodes_posed(
        &self,
        requested: Option<usize>,
        err: impl Fn(usize) -> SceneError,
        pose: Option<&animation::Pose>,
    ) -> Result<Nodes> {
        let count = self.doc.scenes().len();
        let scene = match requested {
            Some(i) if i >= count => return Err(err(count)),
            Some(i) => Some(i),
            None => self
                .doc
                .default_scene()
                .map(|s| s.index())
                .or((count > 0).then_some(0)),
        };
        let roots: Vec<usize> = match scene.and_then(|i| self.doc.scenes().nth(i)) {
            Some(s) => s.nodes().map(|n| n.index()).collect(),
            None => {
                let mut is_child = vec![false; self.doc.nodes().len()];
                for n in self.doc.nodes() {
                    for c in n.children() {
                        if let Some(slot) = is_child.get_mut(c.index()) {
                            *slot = true;
                        }
                    }
                }
                (0..is_child.len()).filter(|&i| !is_child[i]).collect()
            }
        };
        let nodes: Vec<gltf::Node> = self.doc.nodes().collect();
        let mut visited = vec![false; nodes.len()];
        let mut out = Nodes {
            scene,
            meshes: Vec::new(),
            cameras: Vec::new(),
            lights: Vec::new(),
        };
        // Depth-first, children in order, without recursion (deep chains cannot overflow the
        // stack) and with a visited set (cycles and shared children are errors, not hangs).
        let mut stack: Vec<(usize, Mat4)> =
            roots.iter().rev().map(|&r| (r, Mat4::IDENTITY)).collect();
        while let Some((i, parent)) = stack.pop() {
            let Some(node) = nodes.get(i) else { continue };
            if std::mem::replace(&mut visited[i], true) {
                return Err(self
                    .cx
                    .err(format!("/nodes/{i}"), Problem::NodeNotTree { node: i }));
            }
            let local = pose
                .and_then(|p| p.local(i))
                .unwrap_or_else(|| Mat4::from_cols_array_2d(&node.transform().matrix()));
            let world = parent * local;
            if !world.is_finite() {
                return Err(self.cx.err(
                    format!("/nodes/{i}"),
                    Problem::DerivedNonFinite {
                        what: "world matrix (parent · local)".into(),
                    },
                ));
            }
            if let Some(m) = node.mesh() {
                out.meshes.push((i, m.index(), world));
            }
            if let Some(c) = node.camera() {
                out.cameras.push((i, c.index(), world));
            }
            if let Some(l) = node.light() {
                out.lights.push((i, l.index(), world));
            }
            let children: Vec<usize> = node.children().map(|c| c.index()).collect();
            for c in children.into_iter().rev() {
                stack.push((c, world));
            }
        }
        Ok(out)
    }

    /// Triangles the node instances produce, from accessor counts alone (nothing is read), after
    /// checking every primitive's mode. Lets callers enforce [`MAX_TRIANGLES`] before allocating.
    pub(crate) fn triangle_count(&self, nodes: &Nodes) -> Result<u64> {
        let mut per_mesh = vec![None::<u64>; self.doc.meshes().len()];
        let mut total = 0u64;
        for &(_, m, _) in &nodes.meshes {
            let Some(mesh) = self.doc.meshes().nth(m) else {
                continue;
            };
            let count = match per_mesh.get(m).copied().flatten() {
                Some(c) => c,
                None => {
                    let mut c = 0u64;
                    for p in mesh.primitives() {
                        c = c.saturating_add(self.primitive_triangles(m, &p)?);
                    }
                    if let Some(slot) = per_mesh.get_mut(m) {
                        *slot = Some(c);
                    }
                    c
                }
            };
            total = total.saturating_add(count);
        }
        Ok(total)
    }

    fn primitive_triangles(&self, m: usize, p: &gltf::Primitive) -> Result<u64> {
        let pointer = format!("/meshes/{m}/primitives/{}", p.index());
        let n = match p.indices() {
            Some(a) => a.count(),
            None => match p.get(&gltf::Semantic::Positions) {
                Some(a) => a.count(),
                None => {
                    return Err(self.cx.err(
                        format!("{pointer}/attributes"),
                        Problem::AccessorFormat {
                            found: "no POSITION attribute".into(),
                            expected: "a VEC3 FLOAT POSITION accessor in every primitive".into(),
                        },
                    ));
                }
            },
        } as u64;
        match p.mode() {
            Mode::Triangles => Ok(n / 3),
            Mode::TriangleStrip | Mode::TriangleFan => Ok(n.saturating_sub(2)),
            other => Err(self.cx.err(
                format!("{pointer}/mode"),
                Problem::UnsupportedPrimitiveMode {
                    mode: format!("{other:?} ({})", other.as_gl_enum()),
                },
            )),
        }
    }

    /// Converts every material of the asset (plus the glTF default material when a primitive
    /// has none) and the textures they use, appending to `scene`. Unmodelled extensions are
    /// listed in `scene.ignored`.
    pub(crate) fn add_materials(
        &self,
        scene: &mut Scene,
        lighting: GltfLighting,
    ) -> Result<Materials> {
        // The asset's credit line travels with the scene into every report (CC-BY asks for it).
        if let Some(c) = self.doc.as_json().asset.copyright.as_deref() {
            let credit = format!("{}: {c}", self.name);
            if !scene.credits.contains(&credit) {
                scene.credits.push(credit);
            }
        }
        let modelled = [
            "KHR_materials_emissive_strength",
            "KHR_materials_transmission",
            "KHR_texture_transform",
            "KHR_lights_punctual",
            "KHR_materials_unlit",
        ];
        for e in self.doc.extensions_used() {
            if !modelled.contains(&e) {
                scene.ignored.push(format!(
                    "{}: {e} in /extensionsUsed: not modelled",
                    self.name
                ));
            }
        }
        let first = scene.materials.len() as u32;
        let mut textures = TextureCache::default();
        let mut notes = MaterialNotes::default();
        let mut uv_transforms = Vec::new();
        for m in self.doc.materials() {
            let (material, uv) = self.material(&m, scene, &mut textures, &mut notes, lighting)?;
            scene.materials.push(material);
            uv_transforms.push(uv);
        }
        notes.finish(&self.name, scene);
        let needs_default = self
            .doc
            .meshes()
            .any(|mesh| mesh.primitives().any(|p| p.material().index().is_none()));
        let default = needs_default.then(|| {
            // glTF's default material: white, opaque, single-sided, no emission, metallic and
            // roughness 1.
            let mut m = Material::plain([1.0; 3], 1.0, AlphaMode::Opaque);
            if let GltfLighting::PerPixel(specular) = lighting {
                m.reflectance = Some(Reflectance {
                    specular: specular.unwrap_or(Specular::Faded),
                    ..Reflectance::GLTF_DEFAULT
                });
            }
            scene.materials.push(m);
            scene.materials.len() as u32 - 1
        });
        Ok(Materials {
            first,
            default,
            uv_transforms,
        })
    }

    fn material(
        &self,
        m: &gltf::Material,
        scene: &mut Scene,
        textures: &mut TextureCache,
        notes: &mut MaterialNotes,
        lighting: GltfLighting,
    ) -> Result<(Material, Option<UvTransform>)> {
        let i = m.index().unwrap_or(0);
        let mp = format!("/materials/{i}");
        let label = match m.name() {
            Some(n) => format!("{mp} ({n})"),
            None => mp.clone(),
        };
        let pbr = m.pbr_metallic_roughness();
        let factor = pbr.base_color_factor();
        for (k, c) in factor.iter().enumerate() {
            if !c.is_finite() || !(0.0..=1.0).contains(c) {
                return Err(self.cx.bad(
                    format!("{mp}/pbrMetallicRoughness/baseColorFactor/{k}"),
                    "base colour factor component",
                    c,
                    "finite values in [0, 1]",
                ));
            }
        }
        let mode = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask,
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        };
        // Absent means the spec default 0.5 (the crate returns None then). Above 1 discards
        // everything, as glTF says; kept as given.
        let cutoff = m.alpha_cutoff().unwrap_or(0.5);
        if !cutoff.is_finite() || cutoff < 0.0 {
            return Err(self.cx.bad(
                format!("{mp}/alphaCutoff"),
                "alpha cutoff",
                cutoff,
                "a finite value >= 0",
            ));
        }
        let strength = m.emissive_strength().unwrap_or(1.0);
        if !strength.is_finite() || strength < 0.0 {
            return Err(self.cx.bad(
                format!("{mp}/extensions/KHR_materials_emissive_strength/emissiveStrength"),
                "emissive strength",
                strength,
                "a finite value >= 0",
            ));
        }
        let ef = m.emissive_factor();
        let mut emissive = [0.0f32; 3];
        for k in 0..3 {
            let e = ef[k] * strength;
            if !ef[k].is_finite() || ef[k] < 0.0 || !e.is_finite() {
                return Err(self.cx.bad(
                    format!("{mp}/emissiveFactor/{k}"),
                    "emissive factor × strength",
                    e,
                    "finite values >= 0",
                ));
            }
            emissive[k] = e;
        }
        let mut uv = None;
        let mut slot = |info: Option<gltf::texture::Info>,
                        which: &str,
                        scene: &mut Scene|
         -> Result<Option<u32>> {
            let Some(info) = info else { return Ok(None) };
            let tp = format!("{mp}/{which}");
            let transform = info.texture_transform();
            let set = transform
                .as_ref()
                .and_then(|t| t.tex_coord())
                .unwrap_or(info.tex_coord());
            if set != 0 {
                notes.add(
                    format!("texCoord {set} of {which}"),
                    &label,
                    "ignored (TEXCOORD_0 used)",
                );
            }
            if let Some(t) = transform {
                let parts = [
                    t.offset()[0],
                    t.offset()[1],
                    t.rotation(),
                    t.scale()[0],
                    t.scale()[1],
                ];
                if parts.iter().any(|c| !c.is_finite()) {
                    return Err(self.cx.bad(
                        format!("{tp}/extensions/KHR_texture_transform"),
                        "offset, rotation or scale",
                        format!("{parts:?}"),
                        "finite numbers",
                    ));
                }
                let this = UvTransform::new(t.offset(), t.rotation(), t.scale());
                match uv {
                    None => uv = Some(this),
                    Some(first) if first == this => {}
                    Some(_) => notes.add(
                        format!("KHR_texture_transform of {which}"),
                        &label,
                        "ignored (differs from the base colour texture's; one uv per vertex)",
                    ),
                }
            }
            let tex = info.texture();
            let wrap = |w: gltf::texture::WrappingMode| match w {
                gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
                gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
                gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            };
            let sampler = tex.sampler();
            let filters = Sampler {
                wrap_u: wrap(sampler.wrap_s()),
                wrap_v: wrap(sampler.wrap_t()),
                ..Sampler::default()
            }
            .with_gltf_filters(
                sampler.mag_filter().map(|f| f.as_gl_enum()),
                sampler.min_filter().map(|f| f.as_gl_enum()),
            )
            .map_err(|message| {
                let pointer = match sampler.index() {
                    Some(s) => format!("/samplers/{s}"),
                    None => tp.clone(),
                };
                self.cx
                    .bad(pointer, "sampler filter", message, "glTF filter codes")
            })?;
            // Base colour and emission are colour: sRGB rgb.
            let key = (tex.source().index(), filters, Encoding::Srgb);
            textures.get(self, key, scene).map(Some)
        };
        let base_texture = slot(
            pbr.base_color_texture(),
            "pbrMetallicRoughness/baseColorTexture",
            scene,
        )?;
        let emissive_texture = slot(m.emissive_texture(), "emissiveTexture", scene)?;
        let mode_name = match mode {
            AlphaMode::Opaque => "OPAQUE",
            AlphaMode::Mask => "MASK",
            _ => "BLEND",
        };
        let alpha_mode_note =
            format!("not modelled; the material renders with its alphaMode ({mode_name} here)");
        // KHR_materials_transmission, thin and unlit (docs/scene-format.md): τ = factor ×
        // (1 − metallic) filters by the base colour term (glTF: transmission is the dielectric
        // part's); the alphaMode stays coverage, and OPAQUE becomes BLEND with coverage 1 (α
        // ignored, as OPAQUE ignores it).
        let metallic_factor = pbr.metallic_factor();
        if !metallic_factor.is_finite() || !(0.0..=1.0).contains(&metallic_factor) {
            return Err(self.cx.bad(
                format!("{mp}/pbrMetallicRoughness/metallicFactor"),
                "metallic factor",
                metallic_factor,
                "a finite value in [0, 1]",
            ));
        }
        let mut transmission = 0.0;
        let mut alpha = factor[3];
        let mut mode = mode;
        let mut metallic_texture_read = false;
        if let Some(t) = m.transmission() {
            let tp = format!("{mp}/extensions/KHR_materials_transmission");
            let f = t.transmission_factor();
            if !f.is_finite() || !(0.0..=1.0).contains(&f) {
                return Err(self.cx.bad(
                    format!("{tp}/transmissionFactor"),
                    "transmission factor",
                    f,
                    "a finite value in [0, 1]",
                ));
            }
            let metallic = match pbr.metallic_roughness_texture() {
                Some(info) if f > 0.0 && metallic_factor > 0.0 => {
                    metallic_texture_read = true;
                    let i = info.texture().source().index();
                    let Some((lo, hi, mean)) = notes::blue_channel_stats(textures.image(self, i)?)
                    else {
                        return Err(self.cx.bad(
                            format!("/images/{i}"),
                            "metallic-roughness image (blue channel, metalness)",
                            "pixels out of [0, 1] or not matching the format",
                            "values in [0, 1]",
                        ));
                    };
                    let exact = if lo == hi {
                        "exact: the channel is uniform".to_owned()
                    } else {
                        format!(
                            "approximated: per-texel metalness not modelled, the channel spans {lo:.3}..{hi:.3}"
                        )
                    };
                    notes.add(
                        "metallicRoughnessTexture (metalness) with KHR_materials_transmission",
                        &label,
                        format!("metallic = metallicFactor {metallic_factor} × mean blue of /images/{i} {mean:.4} ({exact})"),
                    );
                    (f64::from(metallic_factor) * mean) as f32
                }
                _ => metallic_factor,
            };
            transmission = f * (1.0 - metallic);
            if f > 0.0 && metallic > 0.0 {
                // glTF: a metal does not transmit; its part reflects the base colour here.
                let given = if metallic_texture_read || metallic_factor < 1.0 {
                    ""
                } else {
                    " (metallicFactor 1, also glTF's default when absent)"
                };
                notes.add(
                    "metallic transmission",
                    &label,
                    format!("transmissionFactor {f} applies to the dielectric part only: τ = {f} × (1 − metallic {metallic}) = {transmission}{given}; the metallic part renders as the base colour, unlit"),
                );
            }
            if t.transmission_texture().is_some() {
                notes.add(
                    "transmissionTexture",
                    &label,
                    "not modelled; transmissionFactor used alone",
                );
            }
            if transmission > 0.0 {
                match mode {
                    AlphaMode::Opaque => {
                        mode = AlphaMode::Blend;
                        alpha = 1.0;
                        if base_texture.is_some() {
                            notes.add(
                                "KHR_materials_transmission (OPAQUE)",
                                &label,
                                "the base colour texture's alpha still scales coverage",
                            );
                        }
                    }
                    AlphaMode::Mask => mode = AlphaMode::MaskBlend,
                    _ => {}
                }
                notes.add(
                    "KHR_materials_transmission",
                    &label,
                    format!("modelled thin and unlit (τ = {transmission}, filter = base colour term); roughness, IOR and refraction ignored"),
                );
            } else {
                notes.add(
                    "KHR_materials_transmission",
                    &label,
                    format!("τ = 0: {alpha_mode_note}"),
                );
            }
        }
        notes::unread_properties(m, &label, metallic_texture_read, notes);
        let reflectance = self.reflectance(m, &mp, lighting)?;
        if m.volume().is_some() {
            notes.add(
                "KHR_materials_volume",
                &label,
                "not modelled (thin: no thickness, absorption or refraction)",
            );
        }
        if m.ior().is_some() {
            notes.add(
                "KHR_materials_ior",
                &label,
                "not modelled (no refraction or Fresnel term)",
            );
        }
        if let Some(others) = m.extensions() {
            for ext in others.keys() {
                notes.add(ext.as_str(), &label, alpha_mode_note.clone());
            }
        }
        Ok((
            Material {
                base_color: [factor[0], factor[1], factor[2]],
                alpha,
                mode,
                cutoff,
                double_sided: m.double_sided(),
                premultiplied: false,
                intensity: 1.0,
                base_texture,
                emissive,
                emissive_texture,
                transmission,
                reflectance,
                operator: crate::BlendOperator::Over,
                depth_write: false,
            },
            uv,
        ))
    }

    /// Appends the triangles of every mesh instance in `nodes` to `scene`: one draw per
    /// primitive instance, vertices in world space, lit when `placement.light` is set.
    pub(crate) fn add_geometry(
        &self,
        nodes: &Nodes,
        materials: &Materials,
        placement: &Placement,
        scene: &mut Scene,
    ) -> Result<()> {
        let outer = Mat4::from(placement.transform);
        for &(node, m, world) in &nodes.meshes {
            let Some(mesh) = self.doc.meshes().nth(m) else {
                continue;
            };
            let w = outer * world;
            if !w.is_finite() {
                return Err(self.cx.err(
                    placement.derived_path(node),
                    Problem::DerivedNonFinite {
                        what: format!("world matrix of /nodes/{node}"),
                    },
                ));
            }
            for p in mesh.primitives() {
                self.primitive(node, m, &p, w, materials, placement, scene)?;
            }
        }
        self.add_lights(nodes, placement, scene)
    }

    #[allow(
        clippy::too_many_arguments,
        reason = "a private helper of `add_geometry`"
    )]
    fn primitive(
        &self,
        node: usize,
        m: usize,
        p: &gltf::Primitive,
        world: Mat4,
        materials: &Materials,
        placement: &Placement,
        scene: &mut Scene,
    ) -> Result<()> {
        let pp = format!("/meshes/{m}/primitives/{}", p.index());
        let cx = &self.cx;
        let read = |sem: &gltf::Semantic,
                    name: &str,
                    spec: &accessor::Spec|
         -> Result<Option<Vec<[f64; 4]>>> {
            match p.get(sem) {
                None => Ok(None),
                Some(a) => accessor::read(
                    cx,
                    &self.buffers,
                    &a,
                    spec,
                    &format!("{pp}/attributes/{name}"),
                )
                .map(Some),
            }
        };
        let Some(positions) = read(&gltf::Semantic::Positions, "POSITION", &accessor::POSITION)?
        else {
            return Err(cx.err(
                format!("{pp}/attributes"),
                Problem::AccessorFormat {
                    found: "no POSITION attribute".into(),
                    expected: "a VEC3 FLOAT POSITION accessor in every primitive".into(),
                },
            ));
        };
        let n = positions.len();
        let same_count = |v: Option<Vec<[f64; 4]>>, name: &str| -> Result<Option<Vec<[f64; 4]>>> {
            match v {
                Some(v) if v.len() != n => Err(cx.err(
                    format!("{pp}/attributes/{name}"),
                    Problem::AccessorFormat {
                        found: format!("{} elements", v.len()),
                        expected: format!("as many elements as POSITION ({n})"),
                    },
                )),
                v => Ok(v),
            }
        };
        let normals = same_count(
            read(&gltf::Semantic::Normals, "NORMAL", &accessor::NORMAL)?,
            "NORMAL",
        )?;
        let uvs = same_count(
            read(
                &gltf::Semantic::TexCoords(0),
                "TEXCOORD_0",
                &accessor::TEXCOORD,
            )?,
            "TEXCOORD_0",
        )?;
        let colors = same_count(
            read(&gltf::Semantic::Colors(0), "COLOR_0", &accessor::COLOR)?,
            "COLOR_0",
        )?;
        let color_is_vec3 = p
            .get(&gltf::Semantic::Colors(0))
            .is_some_and(|a| a.dimensions() == gltf::accessor::Dimensions::Vec3);
        let indices: Vec<u32> = match p.indices() {
            Some(a) => {
                let ip = format!("/accessors/{}", a.index());
                let raw = accessor::read(
                    cx,
                    &self.buffers,
                    &a,
                    &accessor::INDICES,
                    &format!("{pp}/indices"),
                )?;
                let mut out = Vec::with_capacity(raw.len());
                for v in raw {
                    let i = v[0] as u64;
                    if i >= n as u64 {
                        return Err(cx.err(
                            ip,
                            Problem::IndexOutOfRange {
                                index: i,
                                count: n as u64,
                            },
                        ));
                    }
                    out.push(i as u32);
                }
                out
            }
            None => (0..n as u32).collect(),
        };
        let triangles = triangle_list(p.mode(), &indices);
        if triangles.is_empty() {
            return Ok(());
        }
        // Mirroring transforms reverse the winding; swap two corners so front faces stay front.
        let flip = Mat3::from_mat4(world).determinant() < 0.0;
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let uv_transform = p
            .material()
            .index()
            .and_then(|i| materials.uv_transforms.get(i).copied().flatten());
        let material = match p.material().index() {
            Some(i) => materials.first + i as u32,
            None => materials.default.unwrap_or(materials.first),
        };
        let pos_ap = p.get(&gltf::Semantic::Positions).map_or(0, |a| a.index());
        let first = scene.vertices.len();
        for t in &triangles {
            let corners = if flip { [t[0], t[2], t[1]] } else { *t };
            let world_pos = corners.map(|i| {
                let q = positions[i as usize];
                world.transform_point3(Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32))
            });
            for (k, &i) in corners.iter().enumerate() {
                let q = positions[i as usize];
                if q[..3].iter().any(|c| !(*c as f32).is_finite()) {
                    return Err(cx.bad(
                        format!("/accessors/{pos_ap}"),
                        &format!("POSITION element {i} is"),
                        format!("{:?}", &q[..3]),
                        "finite positions",
                    ));
                }
                if !world_pos[k].is_finite() {
                    return Err(cx.err(
                        placement.derived_path(node),
                        Problem::DerivedNonFinite {
                            what: format!("position of /nodes/{node} {pp} vertex {i}"),
                        },
                    ));
                }
            }
            let face = (world_pos[1] - world_pos[0])
                .cross(world_pos[2] - world_pos[0])
                .normalize_or_zero();
            for (k, &i) in corners.iter().enumerate() {
                let i = i as usize;
                let mut uv = uvs
                    .as_ref()
                    .map_or(Vec2::ZERO, |u| Vec2::new(u[i][0] as f32, u[i][1] as f32));
                if let Some(tr) = uv_transform {
                    uv = tr.apply(uv);
                }
                if !uv.is_finite() || uv.abs().max_element() > MAX_UV {
                    return Err(cx.bad(
                        format!("{pp}/attributes/TEXCOORD_0"),
                        &format!("uv of vertex {i} (after any texture transform) is"),
                        format!("[{}, {}]", uv.x, uv.y),
                        &format!("finite coordinates with |u|, |v| <= {MAX_UV}"),
                    ));
                }
                let mut color = colors.as_ref().map_or(Vec4::ONE, |c| {
                    let a = if color_is_vec3 { 1.0 } else { c[i][3] as f32 };
                    Vec4::new(c[i][0] as f32, c[i][1] as f32, c[i][2] as f32, a)
                });
                if !color.is_finite() || color.min_element() < 0.0 {
                    return Err(cx.bad(
                        format!("{pp}/attributes/COLOR_0"),
                        &format!("colour of vertex {i} is"),
                        format!("{:?}", color.to_array()),
                        "finite components >= 0",
                    ));
                }
                // Without NORMAL the face normal lights the triangle (flat shading, as the glTF
                // spec asks); a zero normal (degenerate triangle, zero NORMAL) receives ambient
                // only.
                let normal = match &normals {
                    Some(nv) => {
                        let q = nv[i];
                        let v = Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32);
                        if !v.is_finite() {
                            return Err(cx.bad(
                                format!("{pp}/attributes/NORMAL"),
                                &format!("normal of vertex {i} is"),
                                format!("{:?}", v.to_array()),
                                "finite normals",
                            ));
                        }
                        (normal_matrix * v).normalize_or_zero()
                    }
                    None => face,
                };
                let normal = if normal.is_finite() {
                    normal
                } else {
                    Vec3::ZERO
                };
                if let Some(l) = placement.light {
                    let lit = l.ambient + l.color * normal.dot(l.to_light).max(0.0);
                    color = (color.truncate() * lit).extend(color.w);
                    if !color.is_finite() {
                        return Err(cx.err(
                            placement.derived_path(node),
                            Problem::DerivedNonFinite {
                                what: "lit vertex colour".into(),
                            },
                        ));
                    }
                }
                scene.vertices.push(Vertex {
                    position: world_pos[k].to_array(),
                    color: color.to_array(),
                    uv: uv.to_array(),
                    normal: normal.to_array(),
                });
            }
        }
        let added = &scene.vertices[first..];
        let (lo, hi) = added.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(v.position.into()), hi.max(v.position.into())),
        );
        let centre = (lo + hi) * 0.5;
        let radius = added
            .iter()
            .map(|v| Vec3::from(v.position).distance(centre))
            .fold(0.0f32, f32::max);
        if !centre.is_finite() || !radius.is_finite() {
            return Err(cx.err(
                placement.derived_path(node),
                Problem::DerivedNonFinite {
                    what: format!("bounding sphere of /nodes/{node} {pp}"),
                },
            ));
        }
        scene.draws.push(Draw {
            id: scene.draws.len() as u32,
            name: format!(
                "{}{} /nodes/{node} mesh {m} primitive {}",
                placement.name_prefix,
                self.name,
                p.index()
            ),
            material,
            first_vertex: first as u32,
            vertex_count: (scene.vertices.len() - first) as u32,
            ordering: placement.ordering,
            bounds_center: centre,
            bounds_radius: radius,
        });
        Ok(())
    }

    /// Camera `/cameras/{index}` as placed by the first node (in node order) that uses it, for
    /// `aspect`; `None` takes the first camera any node places.
    fn camera(
        &self,
        nodes: &Nodes,
        index: Option<usize>,
        bounds: (Vec3, f32),
        aspect: f32,
    ) -> Result<Camera> {
        let count = self.doc.cameras().len();
        if let Some(k) = index.filter(|&k| k >= count) {
            return Err(self
                .cx
                .err("/cameras", Problem::NoSuchItem { index: k, count }));
        }
        let placed = nodes
            .cameras
            .iter()
            .find(|(_, c, _)| index.is_none_or(|k| k == *c));
        let Some(&(node, c, world)) = placed else {
            return Err(self.cx.bad(
                "/cameras",
                "camera",
                index.map_or("(any)".to_string(), |k| k.to_string()),
                "a camera that a node of the loaded scene uses",
            ));
        };
        let np = format!("/nodes/{node}");
        let cp = format!("/cameras/{c}");
        let eye = world.transform_point3(Vec3::ZERO);
        // glTF cameras look down their local −Z with +Y up.
        let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
        if forward == Vec3::ZERO || up == Vec3::ZERO || !eye.is_finite() {
            return Err(self.cx.err(
                np,
                Problem::DerivedNonFinite {
                    what: "camera orientation".into(),
                },
            ));
        }
        if forward.cross(up).length() < 1e-5 {
            return Err(self.cx.err(np, Problem::UpParallel));
        }
        let Some(camera) = self.doc.cameras().nth(c) else {
            return Err(self.cx.err(cp, Problem::NoSuchItem { index: c, count }));
        };
        let (projection, near, far) = match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let fov = p.yfov().to_degrees();
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(self.cx.err(
                        format!("{cp}/perspective/yfov"),
                        Problem::FovOutOfRange { value: fov },
                    ));
                }
                let near = p.znear();
                if !(near > 0.0 && near.is_finite()) {
                    return Err(self.cx.err(
                        format!("{cp}/perspective/znear"),
                        Problem::NearNotPositive { near },
                    ));
                }
                // Infinite far (zfar absent): twice the distance to the far side of the
                // scene's bounding sphere, and at least 1000 × near.
                let far = p.zfar().unwrap_or_else(|| {
                    let (centre, radius) = bounds;
                    (2.0 * (eye.distance(centre) + radius)).max(1000.0 * near)
                });
                if !(far > near && far.is_finite()) {
                    return Err(self.cx.err(
                        format!("{cp}/perspective/zfar"),
                        Problem::NearNotBeforeFar { near, far },
                    ));
                }
                (Projection::Perspective { fov_y_degrees: fov }, near, far)
            }
            gltf::camera::Projection::Orthographic(o) => {
                let height = 2.0 * o.ymag();
                if !(height > 0.0 && height.is_finite()) {
                    return Err(self.cx.bad(
                        format!("{cp}/orthographic/ymag"),
                        "ymag",
                        o.ymag(),
                        "a finite value > 0",
                    ));
                }
                let (near, far) = (o.znear(), o.zfar());
                if !(near.is_finite() && far.is_finite() && near < far) {
                    return Err(self.cx.err(
                        format!("{cp}/orthographic/zfar"),
                        Problem::NearNotBeforeFar { near, far },
                    ));
                }
                (Projection::Orthographic { height }, near, far)
            }
        };
        Ok(Camera::new(
            eye,
            eye + forward,
            up,
            projection,
            near,
            far,
            true,
            aspect,
        ))
    }
}

/// Triangles of a primitive as index triples. Strips and fans become lists with the spec's
/// vertex order (glTF 2.0, 3.7.2.1); a list's incomplete last triangle is dropped.
fn triangle_list(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        Mode::TriangleStrip => idx
            .windows(3)
            .enumerate()
            .map(|(i, w)| {
                if i % 2 == 0 {
                    [w[0], w[1], w[2]]
                } else {
                    [w[0], w[2], w[1]]
                }
            })
            .collect(),
        Mode::TriangleFan => match idx.split_first() {
            Some((&hub, rest)) => rest.windows(2).map(|w| [w[0], w[1], hub]).collect(),
            None => Vec::new(),
        },
        _ => Vec::new(),
    }
}
