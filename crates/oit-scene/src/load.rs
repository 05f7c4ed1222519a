//! Loading: JSON → serde types (with JSON paths on every error) → validation → flattening into
//! the immutable [`Scene`]: instancing expanded, transforms applied, billboards turned to the
//! camera and lighting baked into vertex colours.

use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat3, Vec3};
use serde::de::DeserializeOwned;

use crate::animation::Frames;
use crate::error::{Problem, SceneError};
use crate::format::{
    DEFAULT_FOV_Y, GltfMeshRef, MAX_TRIANGLES, MESH_KINDS, RawCamera, RawGltfLighting, RawLighting,
    RawMaterial, RawMesh, RawObject, RawScene, RawTransform, ScatterMesh,
};
use crate::gltf::{Asset, GltfLighting, Nodes, Placement};
use crate::mesh::{self, Facing, Geometry};
use crate::scene::{Camera, Draw, Material, Projection, Resolution, Scene, Vertex};
use crate::serde_errors::{json_kind, json_path};
use crate::strict::Strict;

type Result<T> = std::result::Result<T, SceneError>;

/// How to load a file beyond what the file says.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// glTF only: view from `/cameras/N` (as placed by the first node that uses it) instead of
    /// the asset's first camera in node order. Ignored for the JSON format, whose camera is
    /// part of the file.
    pub camera: Option<usize>,
    /// glTF only: render every material unlit (base colour × texture + emission, as before
    /// per-pixel lighting), instead of lit by the asset's `KHR_lights_punctual` lights or the
    /// default rig ([`crate::LightRig::default_rig`]).
    pub unlit: bool,
}

impl LoadOptions {
    /// How a glTF file loaded on its own is lit.
    pub(crate) fn gltf_lighting(&self) -> crate::gltf::GltfLighting {
        if self.unlit {
            crate::gltf::GltfLighting::Unlit
        } else {
            crate::gltf::GltfLighting::PerPixel(None)
        }
    }
}

/// Whether `path` names a glTF asset (`.gltf` or `.glb`, any case) rather than a JSON scene.
pub fn is_gltf_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// Reads and loads one scene file: a glTF 2.0 asset (`.gltf`, `.glb`) or the JSON format
/// otherwise. Errors name the file as given in `path`.
pub fn load(path: &Path) -> Result<Scene> {
    load_with(path, &LoadOptions::default())
}

/// [`load`] with options.
pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Scene> {
    Ok(load_with_inputs(path, options)?.0)
}

/// [`load_with`], and every file the loader read, `path` first: the glTF assets a JSON scene
/// names, and every buffer and image of a glTF asset. Commands that write files refuse
/// outputs that would land on any of them (an input is never overwritten).
pub fn load_with_inputs(path: &Path, options: &LoadOptions) -> Result<(Scene, Vec<PathBuf>)> {
    if is_gltf_path(path) {
        return crate::gltf::load_file_with_inputs(path, options);
    }
    let file = path.display().to_string();
    let json = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        file: file.clone(),
        source,
    })?;
    let (scene, mut inputs) = parse_with_inputs(&json, &file)?;
    inputs.insert(0, path.to_path_buf());
    Ok((scene, inputs))
}

/// Parses a scene from JSON text. `origin` is the file name used in error messages; files an
/// object references (`"kind": "gltf"`) are resolved relative to its parent directory if that
/// exists, else the current directory.
///
/// A UTF-8 byte order mark at the start is skipped (editors on Windows write one).
pub fn parse(json: &str, origin: &str) -> Result<Scene> {
    Ok(parse_with_inputs(json, origin)?.0)
}

/// [`parse`], and the files it read (glTF assets that objects name, their buffers and images).
fn parse_with_inputs(json: &str, origin: &str) -> Result<(Scene, Vec<PathBuf>)> {
    let (frames, inputs) = parse_frames_with_inputs(json, origin)?;
    Ok((frames.frame(0)?, inputs))
}

/// [`parse`] for every frame: the scene's [`Frames`] (one for a still scene), and the files
/// read to prepare them and to flatten frame 0.
fn parse_frames_with_inputs(json: &str, origin: &str) -> Result<(Frames, Vec<PathBuf>)> {
    let json = json.strip_prefix('\u{feff}').unwrap_or(json);
    let cx = Ctx::new(origin, json);
    let mut de = serde_json::Deserializer::from_str(json);
    let raw: RawScene = serde_path_to_error::deserialize(Strict(&mut de))
        .map_err(|e| cx.serde_error(&json_path("", e.path()), e.inner()))?;
    de.end().map_err(|e| cx.serde_error("(root)", &e))?;
    let prepared = cx.prepare_scene(&raw)?;
    if prepared.timeline.is_none() {
        let scene = cx.flatten(&raw, &prepared, 0)?;
        let inputs = cx.inputs.into_inner();
        return Ok((Frames::still(scene, origin), inputs));
    }
    // Frame 0 is flattened once here so that every file the frames read is known up front.
    cx.flatten(&raw, &prepared, 0)?;
    let inputs = cx.inputs.into_inner();
    let frames = Frames::animated(origin.to_string(), json.to_string(), raw, prepared);
    Ok((frames, inputs))
}

/// Reads a scene file with all its frames: an animated JSON scene's [`Frames`], a glTF
/// file's animation 0 (docs/scene-format.md, "glTF animations"), or a still scene (JSON
/// without `animation`, glTF without animations) as one frame. Also returns every file read,
/// `path` first, as [`load_with_inputs`] does.
pub fn load_frames(path: &Path, options: &LoadOptions) -> Result<(Frames, Vec<PathBuf>)> {
    if is_gltf_path(path) {
        return crate::gltf::load_file_frames(path, options);
    }
    let file = path.display().to_string();
    let json = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        file: file.clone(),
        source,
    })?;
    let (frames, mut inputs) = parse_frames_with_inputs(&json, &file)?;
    inputs.insert(0, path.to_path_buf());
    Ok((frames, inputs))
}

/// [`parse`] returning every frame of an animated scene ([`Frames`]).
pub fn parse_frames(json: &str, origin: &str) -> Result<Frames> {
    Ok(parse_frames_with_inputs(json, origin)?.0)
}

/// Loads a glTF 2.0 asset (glTF JSON or GLB) from memory, as [`load`] loads a `.gltf` or
/// `.glb` file. `origin` names it in errors and draw names; a `.glb` extension makes a file
/// without the `glTF` magic an error rather than JSON, and relative URIs resolve against its
/// parent directory.
pub fn parse_gltf(bytes: &[u8], origin: &str, options: &LoadOptions) -> Result<Scene> {
    crate::gltf::load_bytes(Path::new(origin), bytes, options)
}

/// Loads every `*.json`, `*.gltf` and `*.glb` file in `dir` (not recursive), sorted by file name. Stops at the first
/// invalid scene: a broken bundled scene is a bug to fix, not one to skip.
pub fn load_dir(dir: &Path) -> Result<Vec<(PathBuf, Scene)>> {
    load_dir_with(dir, &LoadOptions::default())
}

/// [`load_dir`] with `options` applied to every glTF file in it.
pub fn load_dir_with(dir: &Path, options: &LoadOptions) -> Result<Vec<(PathBuf, Scene)>> {
    scene_files(dir)?
        .into_iter()
        .map(|p| {
            let scene = load_with(&p, options)?;
            Ok((p, scene))
        })
        .collect()
}

/// The scene files of `dir` that [`load_dir`] loads: every `*.json`, `*.gltf` and `*.glb`
/// file (not recursive), sorted by file name.
pub fn scene_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let io = |source| SceneError::Io {
        file: dir.display().to_string(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        if path.is_file() && (path.extension().is_some_and(|e| e == "json") || is_gltf_path(&path))
        {
            files.push(path);
        }
    }
    files.sort_by(|a, b| a.file_name().cmp(&b.file_name()));
    Ok(files)
}

pub(crate) struct Ctx<'a> {
    pub(crate) file: &'a str,
    pub(crate) json: &'a str,
    /// Files read besides the scene file (glTF assets, their buffers and images).
    inputs: std::cell::RefCell<Vec<PathBuf>>,
}

impl<'a> Ctx<'a> {
    pub(crate) fn new(file: &'a str, json: &'a str) -> Self {
        Ctx {
            file,
            json,
            inputs: std::cell::RefCell::new(Vec::new()),
        }
    }
}

impl Ctx<'_> {
    /// Records files read for the scene, each once.
    fn note_inputs(&self, paths: impl IntoIterator<Item = PathBuf>) {
        let mut inputs = self.inputs.borrow_mut();
        for path in paths {
            if !inputs.contains(&path) {
                inputs.push(path);
            }
        }
    }

    pub(crate) fn err(&self, path: impl Into<String>, problem: Problem) -> SceneError {
        SceneError::Invalid {
            file: self.file.to_string(),
            path: path.into(),
            problem,
        }
    }

    // ---- value checks: each returns the value or the specific error at `path` ----

    pub(crate) fn finite(&self, v: f32, path: &str) -> Result<f32> {
        if v.is_finite() {
            return Ok(v);
        }
        // Only overflow can get here (JSON has no NaN): say so, the source text is gone.
        let value = format!("{v} (the number overflows f32)");
        Err(self.err(path, Problem::NonFinite { value }))
    }

    pub(crate) fn vec3(&self, v: [f32; 3], path: &str) -> Result<Vec3> {
        for (k, x) in v.iter().enumerate() {
            self.finite(*x, &format!("{path}[{k}]"))?;
        }
        Ok(Vec3::from(v))
    }

    fn color(&self, v: [f32; 3], path: &str) -> Result<Vec3> {
        let c = self.vec3(v, path)?;
        for (k, x) in v.iter().enumerate() {
            if *x < 0.0 {
                return Err(self.err(format!("{path}[{k}]"), Problem::NegativeColor { value: *x }));
            }
        }
        Ok(c)
    }

    pub(crate) fn alpha(&self, v: f32, path: &str) -> Result<f32> {
        self.finite(v, path)?;
        if (0.0..=1.0).contains(&v) {
            Ok(v)
        } else {
            Err(self.err(path, Problem::AlphaOutOfRange { value: v }))
        }
    }

    pub(crate) fn positive(&self, v: f32, path: &str) -> Result<f32> {
        self.finite(v, path)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(path, Problem::NotPositive { value: v }))
        }
    }

    fn segments(&self, v: u32, min: u32, path: &str) -> Result<()> {
        if v >= min {
            Ok(())
        } else {
            Err(self.err(path, Problem::TooFewSegments { value: v, min }))
        }
    }

    fn nonempty(&self, count: u32, what: &'static str, path: &str) -> Result<()> {
        if count > 0 {
            Ok(())
        } else {
            Err(self.err(path, Problem::EmptyMesh { what }))
        }
    }

    fn range(&self, min: f32, max: f32, path: &str) -> Result<()> {
        if min <= max {
            Ok(())
        } else {
            Err(self.err(path, Problem::EmptyRange { min, max }))
        }
    }

    // ---- building ----

    /// Validates everything about the scene once (and, for an animated scene, every frame's
    /// camera and keyed transforms) and counts its triangles before generating any geometry,
    /// so an absurd scene is rejected without allocating anything.
    pub(crate) fn prepare_scene(&self, raw: &RawScene) -> Result<PreparedScene> {
        let mut res = [0u32; 2];
        for (k, v) in raw.resolution.iter().enumerate() {
            if *v == 0 || *v > u64::from(Resolution::MAX_DIMENSION) {
                let problem = Problem::ResolutionOutOfRange { value: *v };
                return Err(self.err(format!("resolution[{k}]"), problem));
            }
            res[k] = *v as u32;
        }
        let resolution = Resolution {
            width: res[0],
            height: res[1],
        };
        let background = self.color(raw.background, "background")?.to_array();
        self.camera(&raw.camera, raw.reverse_z, resolution)?;
        let light = self.lighting(&raw.lighting)?;
        let mut total_triangles: u64 = 0;
        let mut objects = Vec::with_capacity(raw.objects.len());
        for (i, obj) in raw.objects.iter().enumerate() {
            objects.push(self.prepare(i, obj, &mut total_triangles)?);
        }
        let timeline = self.timeline(raw)?;
        if let Some(t) = &timeline {
            self.check_frames(raw, t)?;
        }
        Ok(PreparedScene {
            resolution,
            background,
            light,
            objects,
            total_triangles,
            timeline,
        })
    }

    /// Flattens frame `t` of a prepared scene: the frame's camera, transforms and alphas,
    /// geometry generated and transformed, billboards turned to this frame's camera.
    pub(crate) fn flatten(&self, raw: &RawScene, prep: &PreparedScene, t: u32) -> Result<Scene> {
        let camera = match &prep.timeline {
            Some(tl) => {
                let c = tl.camera.camera_at(&raw.camera, t, tl.animation.frames);
                self.camera(&c, raw.reverse_z, prep.resolution)?
            }
            None => self.camera(&raw.camera, raw.reverse_z, prep.resolution)?,
        };
        let mut scene = Scene {
            name: raw.name.clone(),
            description: raw.description.clone(),
            resolution: prep.resolution,
            camera,
            background: prep.background,
            materials: Vec::with_capacity(raw.objects.len()),
            draws: Vec::new(),
            vertices: Vec::new(),
            textures: Vec::new(),
            ignored: Vec::new(),
            credits: Vec::new(),
            frame: t,
            animation: prep.timeline.as_ref().map(|tl| tl.animation),
            lights: match &prep.light {
                // The directional light lights lit materials per pixel, with the same colour
                // a Lambert bake gives: E = π·color against the BRDF's 1/π.
                Some(l) => crate::LightRig {
                    ambient: l.ambient.to_array(),
                    lights: vec![crate::PunctualLight::directional(
                        -l.to_light,
                        (l.color * std::f32::consts::PI).to_array(),
                    )],
                    origin: "lighting.directional".into(),
                },
                None => crate::LightRig::none(),
            },
        };
        scene.vertices.reserve(prep.total_triangles as usize * 3);
        for (i, (obj, p)) in raw.objects.iter().zip(&prep.objects).enumerate() {
            let keyed = prep
                .timeline
                .as_ref()
                .map(|tl| &tl.objects[i])
                .filter(|tracks| !tracks.is_empty());
            let (world, material) = match keyed {
                None => (p.world, p.material),
                Some(tracks) => {
                    let transform = tracks.transform_at(&obj.transform, t);
                    let world = self.transform(&transform, &format!("objects[{i}].transform"))?;
                    let mut material = p.material;
                    if let Some([alpha]) = tracks.alpha.at(t) {
                        material.alpha = alpha;
                    }
                    (world, material)
                }
            };
            let at = Placed { world, material };
            self.object(i, obj, p, &at, prep.light.as_ref(), &mut scene)?;
        }
        if scene.materials.iter().any(Material::is_lit) {
            crate::lighting::complete_rig(&mut scene);
        } else {
            scene.lights = crate::LightRig::none();
        }
        self.check_queue_order(&scene)?;
        Ok(scene)
    }

    pub(crate) fn camera(&self, c: &RawCamera, reverse_z: bool, res: Resolution) -> Result<Camera> {
        let eye = self.vec3(c.eye, "camera.eye")?;
        let target = self.vec3(c.target, "camera.target")?;
        let up = self.vec3(c.up, "camera.up")?;
        let near = self.finite(c.near, "camera.near")?;
        let far = self.finite(c.far, "camera.far")?;
        if eye == target {
            return Err(self.err("camera.target", Problem::EyeAtTarget));
        }
        let dir = target - eye;
        if !dir.is_finite() || !dir.length().is_finite() {
            let what = "view direction (target - eye)".to_string();
            return Err(self.err("camera.target", Problem::DerivedNonFinite { what }));
        }
        if up == Vec3::ZERO || !up.length().is_finite() || up.length() == 0.0 {
            return Err(self.err("camera.up", Problem::ZeroUp));
        }
        // Parallel within ~0.0006°: the view matrix would be numerically meaningless.
        if dir.normalize().cross(up.normalize()).length() < 1e-5 {
            return Err(self.err("camera.up", Problem::UpParallel));
        }
        let projection = match (&c.fov_y, &c.orthographic) {
            (Some(_), Some(_)) => {
                return Err(self.err("camera.orthographic", Problem::ProjectionConflict));
            }
            (_, Some(o)) => Projection::Orthographic {
                height: self.positive(o.height, "camera.orthographic.height")?,
            },
            (fov, None) => {
                let fov = self.finite(fov.unwrap_or(DEFAULT_FOV_Y), "camera.fov_y")?;
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(self.err("camera.fov_y", Problem::FovOutOfRange { value: fov }));
                }
                if near <= 0.0 {
                    return Err(self.err("camera.near", Problem::NearNotPositive { near }));
                }
                Projection::Perspective { fov_y_degrees: fov }
            }
        };
        if near >= far {
            return Err(self.err("camera.far", Problem::NearNotBeforeFar { near, far }));
        }
        let cam = Camera::new(
            eye,
            target,
            up,
            projection,
            near,
            far,
            reverse_z,
            res.aspect(),
        );
        if !cam.view_proj.is_finite() || !cam.view.is_finite() || !cam.proj.is_finite() {
            let what = "view-projection matrix".to_string();
            return Err(self.err("camera", Problem::DerivedNonFinite { what }));
        }
        Ok(cam)
    }

    fn lighting(&self, l: &RawLighting) -> Result<Option<Light>> {
        match l {
            RawLighting::Unlit => Ok(None),
            RawLighting::Directional(d) => {
                let p = "lighting.directional";
                let direction = self.vec3(d.direction, &format!("{p}.direction"))?;
                let to_light = -direction.normalize_or_zero();
                if to_light == Vec3::ZERO || !to_light.is_finite() {
                    return Err(self.err(format!("{p}.direction"), Problem::ZeroVector));
                }
                let color = self.color(d.color, &format!("{p}.color"))?;
                let ambient = self.color(d.ambient, &format!("{p}.ambient"))?;
                Ok(Some(Light {
                    to_light,
                    color,
                    ambient,
                }))
            }
        }
    }

    fn material(&self, m: &RawMaterial, p: &str) -> Result<Material> {
        let base = self.color(m.base_color, &format!("{p}.base_color"))?;
        let alpha = self.alpha(m.alpha, &format!("{p}.alpha"))?;
        let cutoff = self.finite(m.cutoff, &format!("{p}.cutoff"))?;
        if !(0.0..=1.0).contains(&cutoff) {
            return Err(self.err(
                format!("{p}.cutoff"),
                Problem::CutoffOutOfRange { value: cutoff },
            ));
        }
        let intensity = self.finite(m.intensity, &format!("{p}.intensity"))?;
        if intensity < 0.0 {
            return Err(self.err(
                format!("{p}.intensity"),
                Problem::NegativeIntensity { value: intensity },
            ));
        }
        if !(base * intensity).is_finite() {
            let what = "base_color × intensity".to_string();
            return Err(self.err(format!("{p}.intensity"), Problem::DerivedNonFinite { what }));
        }
        let transmission = self.transmission(m, base, p)?;
        self.check_blending(m, p)?;
        let reflectance = match &m.lit {
            None => None,
            Some(l) => {
                for (name, v) in [("metallic", l.metallic), ("roughness", l.roughness)] {
                    let path = format!("{p}.lit.{name}");
                    let v = self.finite(v, &path)?;
                    if !(0.0..=1.0).contains(&v) {
                        return Err(self.err(
                            path,
                            Problem::BadValue {
                                what: name.into(),
                                value: v.to_string(),
                                allowed: "a factor in [0, 1]".into(),
                            },
                        ));
                    }
                }
                Some(crate::Reflectance {
                    metallic: l.metallic,
                    roughness: l.roughness,
                    specular: l.specular,
                })
            }
        };
        Ok(Material {
            base_color: base.to_array(),
            alpha,
            mode: m.mode,
            cutoff,
            double_sided: m.double_sided,
            premultiplied: m.premultiplied,
            intensity,
            base_texture: None,
            emissive: [0.0; 3],
            emissive_texture: None,
            transmission,
            reflectance,
            operator: m.operator,
            depth_write: m.depth_write,
        })
    }

    /// `transmission` in [0, 1]; above 0 only where it means something: a transparent mode,
    /// straight alpha, and a base colour in [0, 1] (the filter; above 1 it would amplify).
    fn transmission(&self, m: &RawMaterial, base: Vec3, p: &str) -> Result<f32> {
        let path = format!("{p}.transmission");
        let tau = self.finite(m.transmission, &path)?;
        let bad = |value: String, allowed: &str| {
            self.err(
                path.clone(),
                Problem::BadValue {
                    what: "transmission".into(),
                    value,
                    allowed: allowed.into(),
                },
            )
        };
        if !(0.0..=1.0).contains(&tau) {
            return Err(bad(tau.to_string(), "a factor in [0, 1]"));
        }
        if tau > 0.0 {
            if !m.mode.is_transparent() {
                return Err(bad(
                    format!("{tau} with mode {:?}", m.mode),
                    "transmission > 0 only with mode \"blend\" or \"mask-blend\"",
                ));
            }
            if m.premultiplied {
                return Err(bad(
                    format!("{tau} with premultiplied true"),
                    "transmission > 0 only with straight alpha (premultiplied false)",
                ));
            }
            if base.max_element() > 1.0 {
                return Err(bad(
                    format!("{tau} with base_color {:?}", base.to_array()),
                    "transmission > 0 only with base_color components in [0, 1] (the base colour is the filter)",
                ));
            }
        }
        Ok(tau)
    }

    pub(crate) fn transform(&self, t: &RawTransform, p: &str) -> Result<Affine3A> {
        let translate = self.vec3(t.translate, &format!("{p}.translate"))?;
        let rotate = self.vec3(t.rotate, &format!("{p}.rotate"))?;
        let scale = self.vec3(t.scale, &format!("{p}.scale"))?;
        for k in 0..3 {
            self.positive(scale[k], &format!("{p}.scale[{k}]"))?;
        }
        // XYZ Euler: rotate about X first, then Y, then Z (column vectors: Rz · Ry · Rx).
        let r = Mat3::from_rotation_z(rotate.z.to_radians())
            * Mat3::from_rotation_y(rotate.y.to_radians())
            * Mat3::from_rotation_x(rotate.x.to_radians());
        let m = Affine3A::from_mat3_translation(r * Mat3::from_diagonal(scale), translate);
        if !m.is_finite() {
            return Err(self.err(
                p,
                Problem::DerivedNonFinite {
                    what: "transform matrix".into(),
                },
            ));
        }
        Ok(m)
    }

    /// Reads `kind` and parses the rest of the mesh object into that kind's struct, so every
    /// error inside the mesh keeps its full JSON path.
    fn mesh(&self, value: &serde_json::Value, p: &str) -> Result<RawMesh> {
        let Some(map) = value.as_object() else {
            let found = format!("invalid type: {}", json_kind(value));
            let expected = format!("a mesh object with a `kind` ({MESH_KINDS})");
            return Err(self.err(p, Problem::WrongType { found, expected }));
        };
        let kind = match map.get("kind") {
            None => {
                return Err(self.err(
                    format!("{p}.kind"),
                    Problem::MissingField {
                        field: "kind".into(),
                    },
                ));
            }
            Some(serde_json::Value::String(s)) => s.as_str(),
            Some(other) => {
                let found = format!("invalid type: {}", json_kind(other));
                let expected = format!("a string, one of {MESH_KINDS}");
                return Err(self.err(format!("{p}.kind"), Problem::WrongType { found, expected }));
            }
        };
        let mut rest = map.clone();
        rest.remove("kind");
        let rest = serde_json::Value::Object(rest);
        Ok(match kind {
            "quad" => RawMesh::Quad(self.sub(rest, p)?),
            "box" => RawMesh::Box(self.sub(rest, p)?),
            "uv-sphere" => RawMesh::UvSphere(self.sub(rest, p)?),
            "torus" => RawMesh::Torus(self.sub(rest, p)?),
            "cylinder" => RawMesh::Cylinder(self.sub(rest, p)?),
            "layers" => RawMesh::Layers(self.sub(rest, p)?),
            "soup" => RawMesh::Soup(self.sub(rest, p)?),
            "billboards" => RawMesh::Billboards(self.sub(rest, p)?),
            other => {
                let problem = Problem::UnknownVariant {
                    value: other.into(),
                    expected: MESH_KINDS.into(),
                };
                return Err(self.err(format!("{p}.kind"), problem));
            }
        })
    }

    fn sub<T: DeserializeOwned>(&self, v: serde_json::Value, p: &str) -> Result<T> {
        serde_path_to_error::deserialize(Strict(v))
            .map_err(|e| self.serde_error(&json_path(p, e.path()), e.inner()))
    }

    /// Range checks of a mesh's own parameters.
    fn check_mesh(&self, m: &RawMesh, p: &str) -> Result<()> {
        match m {
            RawMesh::Quad(q) => {
                for k in 0..2 {
                    self.positive(q.size[k], &format!("{p}.size[{k}]"))?;
                }
                for k in 0..4 {
                    self.alpha(q.corner_alpha[k], &format!("{p}.corner_alpha[{k}]"))?;
                }
            }
            RawMesh::Box(b) => {
                for k in 0..3 {
                    self.positive(b.size[k], &format!("{p}.size[{k}]"))?;
                }
            }
            RawMesh::UvSphere(s) => {
                self.positive(s.radius, &format!("{p}.radius"))?;
                self.segments(s.segments, 3, &format!("{p}.segments"))?;
                self.segments(s.rings, 2, &format!("{p}.rings"))?;
            }
            RawMesh::Torus(t) => {
                let major = self.positive(t.major_radius, &format!("{p}.major_radius"))?;
                let minor = self.positive(t.minor_radius, &format!("{p}.minor_radius"))?;
                if minor >= major {
                    return Err(self.err(
                        format!("{p}.minor_radius"),
                        Problem::TorusRadii { minor, major },
                    ));
                }
                self.segments(t.segments, 3, &format!("{p}.segments"))?;
                self.segments(t.tube_segments, 3, &format!("{p}.tube_segments"))?;
            }
            RawMesh::Cylinder(c) => {
                self.positive(c.radius, &format!("{p}.radius"))?;
                self.positive(c.height, &format!("{p}.height"))?;
                self.segments(c.segments, 3, &format!("{p}.segments"))?;
            }
            RawMesh::Layers(l) => {
                self.nonempty(l.count, "layer count", &format!("{p}.count"))?;
                let spacing = self.finite(l.spacing, &format!("{p}.spacing"))?;
                if spacing < 0.0 {
                    return Err(self.err(
                        format!("{p}.spacing"),
                        Problem::NegativeSpacing { value: spacing },
                    ));
                }
                for k in 0..2 {
                    self.positive(l.size[k], &format!("{p}.size[{k}]"))?;
                }
                self.color(l.color_from, &format!("{p}.color_from"))?;
                self.color(l.color_to, &format!("{p}.color_to"))?;
                self.alpha(l.alpha_from, &format!("{p}.alpha_from"))?;
                self.alpha(l.alpha_to, &format!("{p}.alpha_to"))?;
                // The farthest layer must stay finite.
                if !(spacing * (l.count - 1) as f32).is_finite() {
                    let what = "spacing × (count - 1)".to_string();
                    return Err(
                        self.err(format!("{p}.spacing"), Problem::DerivedNonFinite { what })
                    );
                }
            }
            RawMesh::Soup(s) => self.check_scatter(s, "triangle count", p)?,
            RawMesh::Billboards(s) => self.check_scatter(s, "billboard count", p)?,
        }
        Ok(())
    }

    fn check_scatter(&self, s: &ScatterMesh, what: &'static str, p: &str) -> Result<()> {
        self.nonempty(s.count, what, &format!("{p}.count"))?;
        let min = self.vec3(s.bounds.min, &format!("{p}.bounds.min"))?;
        let max = self.vec3(s.bounds.max, &format!("{p}.bounds.max"))?;
        for k in 0..3 {
            self.range(min[k], max[k], &format!("{p}.bounds.max[{k}]"))?;
        }
        if !(max - min).is_finite() {
            let what = "bounds extent (max - min)".to_string();
            return Err(self.err(format!("{p}.bounds"), Problem::DerivedNonFinite { what }));
        }
        self.positive(s.size, &format!("{p}.size"))?;
        let cmin = self.color(s.color_min, &format!("{p}.color_min"))?;
        let cmax = self.color(s.color_max, &format!("{p}.color_max"))?;
        for k in 0..3 {
            self.range(cmin[k], cmax[k], &format!("{p}.color_max[{k}]"))?;
        }
        let amin = self.alpha(s.alpha_min, &format!("{p}.alpha_min"))?;
        let amax = self.alpha(s.alpha_max, &format!("{p}.alpha_max"))?;
        self.range(amin, amax, &format!("{p}.alpha_max"))
    }

    /// Parses and validates one object and adds its triangles to the running total.
    fn prepare(&self, i: usize, obj: &RawObject, total_triangles: &mut u64) -> Result<Prepared> {
        let p = format!("objects[{i}]");
        let mp = format!("{p}.mesh");
        let is_gltf = obj.mesh.get("kind").and_then(serde_json::Value::as_str) == Some("gltf");
        let source = if is_gltf {
            if obj.material.is_some() {
                return Err(self.err(
                    format!("{p}.material"),
                    Problem::GltfObjectField {
                        field: "material".into(),
                        allowed: "no `material` on a gltf object (materials come from the asset)"
                            .into(),
                    },
                ));
            }
            MeshSource::Gltf(Box::new(self.gltf_object(&obj.mesh, &mp)?))
        } else {
            let mesh = self.mesh(&obj.mesh, &mp)?;
            self.check_mesh(&mesh, &mp)?;
            MeshSource::Procedural(mesh)
        };
        let world = self.transform(&obj.transform, &format!("{p}.transform"))?;
        let material = match &obj.material {
            Some(m) => self.material(m, &format!("{p}.material"))?,
            None => self.material(&RawMaterial::default(), &format!("{p}.material"))?,
        };
        let (counts, spacing) = match &obj.instances {
            None => ([1u32; 3], Vec3::ZERO),
            Some(inst) => {
                for k in 0..3 {
                    let path = format!("{p}.instances.counts[{k}]");
                    self.nonempty(inst.counts[k], "instance count", &path)?;
                }
                (
                    inst.counts,
                    self.vec3(inst.spacing, &format!("{p}.instances.spacing"))?,
                )
            }
        };
        let instances = counts
            .iter()
            .fold(1u64, |a, &c| a.saturating_mul(u64::from(c)));
        let per_instance = match &source {
            MeshSource::Procedural(mesh) => mesh::triangle_count(mesh),
            MeshSource::Gltf(g) => g.triangles,
        };
        let triangles = per_instance.saturating_mul(instances);
        *total_triangles = total_triangles.saturating_add(triangles);
        if *total_triangles > MAX_TRIANGLES {
            return Err(self.err(
                p,
                Problem::TooManyTriangles {
                    count: *total_triangles,
                },
            ));
        }
        let ordering = self.ordering(obj, &p)?;
        Ok(Prepared {
            source,
            world,
            material,
            ordering,
            counts,
            spacing,
        })
    }

    /// Generates one validated object's draws, placed and coloured as `at` says (the frame's
    /// transform and material).
    fn object(
        &self,
        i: usize,
        obj: &RawObject,
        prep: &Prepared,
        at: &Placed,
        light: Option<&Light>,
        scene: &mut Scene,
    ) -> Result<()> {
        let p = format!("objects[{i}]");
        let Prepared {
            source,
            counts,
            spacing,
            ..
        } = prep;
        let (world, material) = (&at.world, &at.material);
        let mesh = match source {
            MeshSource::Procedural(mesh) => mesh,
            MeshSource::Gltf(g) => return self.place_gltf(&p, obj, g, prep, world, light, scene),
        };
        // A material lit per pixel gets the scene's light from the rig, not baked.
        let light = if material.is_lit() { None } else { light };
        let material_index = scene.materials.len() as u32;
        scene.materials.push(*material);
        let facing = match scene.camera.projection {
            Projection::Perspective { .. } => Facing::Eye(scene.camera.eye),
            Projection::Orthographic { .. } => {
                Facing::Direction((scene.camera.eye - scene.camera.target).normalize())
            }
        };
        // Generated once and transformed per instance (empty for billboards, which are built
        // per instance in world space).
        let local = mesh::local(mesh);
        let derived_path = if obj.instances.is_some() {
            format!("{p}.instances")
        } else {
            format!("{p}.transform")
        };
        let mut instance = 0usize;
        for iz in 0..counts[2] {
            for iy in 0..counts[1] {
                for ix in 0..counts[0] {
                    let offset = *spacing * Vec3::new(ix as f32, iy as f32, iz as f32);
                    let w = Affine3A::from_translation(offset) * *world;
                    let built;
                    let (geometry, in_world) = if let RawMesh::Billboards(b) = mesh {
                        built = mesh::billboards(b, &w, facing, scene.camera.up);
                        (&built, true)
                    } else {
                        (&local, false)
                    };
                    let base = if obj.instances.is_some() {
                        format!("{p}.instances[{instance}]")
                    } else {
                        p.clone()
                    };
                    let named_parts = matches!(mesh, RawMesh::Layers(_));
                    self.emit(
                        geometry,
                        in_world,
                        &w,
                        light,
                        &derived_path,
                        &base,
                        named_parts,
                        prep.ordering,
                        material_index,
                        scene,
                    )?;
                    instance += 1;
                }
            }
        }
        Ok(())
    }

    /// Opens the asset a `"kind": "gltf"` mesh names (relative to the scene file's directory)
    /// and collects the node instances of its scene.
    fn gltf_object(&self, mesh: &serde_json::Value, p: &str) -> Result<GltfObject> {
        let mut rest = mesh.as_object().cloned().unwrap_or_default();
        rest.remove("kind");
        let r: GltfMeshRef = self.sub(serde_json::Value::Object(rest), p)?;
        let base = match Path::new(self.file).parent() {
            Some(d) if !d.as_os_str().is_empty() && d.is_dir() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let asset_path = base.join(&r.file);
        self.note_inputs([asset_path.clone()]);
        let asset = Asset::open(&asset_path)?;
        let nodes = asset.nodes(r.scene, |count| {
            let index = r.scene.unwrap_or(0);
            self.err(format!("{p}.scene"), Problem::NoSuchItem { index, count })
        })?;
        let triangles = asset.triangle_count(&nodes)?;
        let lighting = match r.lighting {
            None | Some(RawGltfLighting::PerPixel) => GltfLighting::PerPixel(r.specular),
            Some(RawGltfLighting::Unlit) => {
                if let Some(specular) = r.specular {
                    return Err(self.err(
                        format!("{p}.specular"),
                        Problem::BadValue {
                            what: "specular".into(),
                            value: format!("{specular:?} with lighting \"unlit\"").to_lowercase(),
                            allowed: "specular only with lighting \"per-pixel\" (the default)"
                                .into(),
                        },
                    ));
                }
                GltfLighting::Unlit
            }
        };
        Ok(GltfObject {
            asset,
            nodes,
            triangles,
            lighting,
        })
    }

    /// Adds a glTF object's materials (once) and its geometry (per instance).
    #[allow(
        clippy::too_many_arguments,
        reason = "a private helper of `object`, called once"
    )]
    fn place_gltf(
        &self,
        p: &str,
        obj: &RawObject,
        g: &GltfObject,
        prep: &Prepared,
        world: &Affine3A,
        light: Option<&Light>,
        scene: &mut Scene,
    ) -> Result<()> {
        let materials = g.asset.add_materials(scene, g.lighting)?;
        // Per-pixel lit assets take the scene's directional light as a light, not baked.
        let light = match g.lighting {
            GltfLighting::PerPixel(_) => None,
            GltfLighting::Unlit => light,
        };
        scene.ignored.extend(g.asset.unplayed_animations());
        self.note_inputs(g.asset.files_read());
        let derived_path = if obj.instances.is_some() {
            format!("{p}.instances")
        } else {
            format!("{p}.transform")
        };
        // An asset without triangles adds no draws, and MAX_TRIANGLES does not bound its
        // instance count: one pass checks its geometry, however many instances are asked for.
        let counts = if g.triangles == 0 {
            [1; 3]
        } else {
            prep.counts
        };
        let mut instance = 0usize;
        for iz in 0..counts[2] {
            for iy in 0..counts[1] {
                for ix in 0..counts[0] {
                    let offset = prep.spacing * Vec3::new(ix as f32, iy as f32, iz as f32);
                    let name_prefix = if obj.instances.is_some() {
                        format!("{p}.instances[{instance}] ")
                    } else {
                        format!("{p} ")
                    };
                    let placement = Placement {
                        transform: Affine3A::from_translation(offset) * *world,
                        transform_path: Some(derived_path.clone()),
                        light,
                        ordering: prep.ordering,
                        name_prefix,
                    };
                    g.asset
                        .add_geometry(&g.nodes, &materials, &placement, scene)?;
                    instance += 1;
                }
            }
        }
        Ok(())
    }

    /// Transforms, lights and appends one instance's geometry as draws (one per part).
    #[allow(
        clippy::too_many_arguments,
        reason = "a private helper of `object`, called once"
    )]
    fn emit(
        &self,
        g: &Geometry,
        in_world: bool,
        w: &Affine3A,
        light: Option<&Light>,
        derived_path: &str,
        base_name: &str,
        named_parts: bool,
        ordering: crate::Ordering,
        material: u32,
        scene: &mut Scene,
    ) -> Result<()> {
        // Normals transform by the inverse transpose (non-uniform scale keeps them orthogonal).
        let normal_matrix = Mat3::from(w.matrix3).inverse().transpose();
        for (pi, part) in g.parts.iter().enumerate() {
            let first = scene.vertices.len();
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for v in part.clone() {
                let (pos, normal) = if in_world {
                    (g.positions[v], g.normals[v])
                } else {
                    (
                        w.transform_point3(g.positions[v]),
                        (normal_matrix * g.normals[v]).normalize_or_zero(),
                    )
                };
                if !pos.is_finite() {
                    return Err(self.err(
                        derived_path,
                        Problem::DerivedNonFinite {
                            what: "vertex position".into(),
                        },
                    ));
                }
                let mut color = g.colors[v];
                if let Some(l) = light {
                    if !normal.is_finite() || normal == Vec3::ZERO {
                        return Err(self.err(
                            derived_path,
                            Problem::DerivedNonFinite {
                                what: "vertex normal".into(),
                            },
                        ));
                    }
                    let k = l.ambient + l.color * normal.dot(l.to_light).max(0.0);
                    color = (color.truncate() * k).extend(color.w);
                    if !color.is_finite() {
                        return Err(self.err(
                            derived_path,
                            Problem::DerivedNonFinite {
                                what: "lit vertex colour".into(),
                            },
                        ));
                    }
                }
                lo = lo.min(pos);
                hi = hi.max(pos);
                scene.vertices.push(Vertex {
                    position: pos.to_array(),
                    color: color.to_array(),
                    uv: g.uvs[v].to_array(),
                    normal: if normal.is_finite() {
                        normal.to_array()
                    } else {
                        [0.0; 3]
                    },
                });
            }
            let centre = (lo + hi) * 0.5;
            let radius = scene.vertices[first..]
                .iter()
                .map(|v| Vec3::from(v.position).distance(centre))
                .fold(0.0f32, f32::max);
            if !centre.is_finite() || !radius.is_finite() {
                return Err(self.err(
                    derived_path,
                    Problem::DerivedNonFinite {
                        what: "bounding sphere".into(),
                    },
                ));
            }
            let name = if named_parts {
                format!("{base_name}.layers[{pi}]")
            } else {
                base_name.to_string()
            };
            scene.draws.push(Draw {
                id: scene.draws.len() as u32,
                name,
                material,
                first_vertex: first as u32,
                vertex_count: (scene.vertices.len() - first) as u32,
                ordering,
                bounds_center: centre,
                bounds_radius: radius,
            });
        }
        Ok(())
    }
}

/// An object after validation, before its geometry is generated.
#[derive(Debug)]
struct Prepared {
    source: MeshSource,
    world: Affine3A,
    material: Material,
    /// Where engines draw it (render group, queue, order, method).
    ordering: crate::Ordering,
    counts: [u32; 3],
    spacing: Vec3,
}

/// An object's transform and material in one frame.
struct Placed {
    world: Affine3A,
    material: Material,
}

/// A scene file after validation, before any frame's geometry is generated.
#[derive(Debug)]
pub(crate) struct PreparedScene {
    resolution: Resolution,
    background: [f32; 3],
    light: Option<Light>,
    objects: Vec<Prepared>,
    total_triangles: u64,
    pub(crate) timeline: Option<crate::animation::Timeline>,
}

/// Where an object's triangles come from.
#[derive(Debug)]
enum MeshSource {
    Procedural(RawMesh),
    Gltf(Box<GltfObject>),
}

/// A `"kind": "gltf"` mesh: the opened asset and the node instances of the chosen scene.
struct GltfObject {
    asset: Asset,
    nodes: Nodes,
    /// Per instance of the object.
    triangles: u64,
    lighting: GltfLighting,
}

impl std::fmt::Debug for GltfObject {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GltfObject")
            .field("triangles", &self.triangles)
            .finish_non_exhaustive()
    }
}

/// A directional light, ready to bake: `rgb *= ambient + color · max(0, n · to_light)`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Light {
    pub(crate) to_light: Vec3,
    pub(crate) color: Vec3,
    pub(crate) ambient: Vec3,
}
