//! A `.gltf` / `.glb` file loaded as a scene of its own: its camera (or one framing its
//! bounds), the default resolution and background, every file it read, and the frames of its
//! animation 0.

use super::animation::{Clip, Pose};
use super::*;
use crate::animation::{Animation, Frames};

/// World-space bounding sphere of all vertices (unit sphere at the origin when empty).
pub(super) fn bounds(vertices: &[Vertex]) -> (Vec3, f32) {
    if vertices.is_empty() {
        return (Vec3::ZERO, 1.0);
    }
    let (lo, hi) = vertices.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), v| (lo.min(v.position.into()), hi.max(v.position.into())),
    );
    let centre = (lo + hi) * 0.5;
    let radius = vertices
        .iter()
        .map(|v| Vec3::from(v.position).distance(centre))
        .fold(0.0f32, f32::max);
    (centre, radius)
}

/// The camera used when the asset has none: looking down −Z at the bounding sphere's centre
/// from the front (+Z side), far enough that the sphere fits a 45° vertical field of view
/// with a 10% margin; near and far bracket the sphere.
pub(super) fn framing_camera(centre: Vec3, radius: f32, aspect: f32) -> Camera {
    let r = if radius > 0.0 { radius } else { 1.0 };
    let half = (FRAMING_FOV_Y * 0.5).to_radians();
    let d = 1.1 * r / half.sin();
    let eye = centre + Vec3::new(0.0, 0.0, d);
    Camera::new(
        eye,
        centre,
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: FRAMING_FOV_Y,
        },
        0.5 * (d - r),
        1.5 * (d + r),
        true,
        aspect,
    )
}

/// Loads a `.gltf` / `.glb` file as a scene of its own (frame 0 of its animation, if it has
/// one; see [`load_file_frames`]). With every file it read: the asset first, then its buffers
/// and images.
pub(crate) fn load_file_with_inputs(
    path: &Path,
    options: &LoadOptions,
) -> Result<(Scene, Vec<PathBuf>)> {
    let (frames, inputs) = load_file_frames(path, options)?;
    Ok((frames.frame(0)?, inputs))
}

/// Loads a `.gltf` / `.glb` file with every frame of its animation 0 ([`GLTF_FPS`]); an asset
/// without animations (or whose animation 0 plays nothing) is a one-frame still. Each frame is
/// unlit, at [`DEFAULT_RESOLUTION`], background [`GLTF_BACKGROUND`], reverse-Z, viewed from
/// the asset's first camera in node order (or `options.camera`), which follows its node's
/// animated world matrix, else from [`framing_camera`] computed from frame 0's bounds and
/// kept for every frame (moving geometry may leave its view).
/// With every file it read: the asset first, then its buffers and images.
pub(crate) fn load_file_frames(
    path: &Path,
    options: &LoadOptions,
) -> Result<(Frames, Vec<PathBuf>)> {
    let (frames, mut inputs) = frames_from_bytes(path, &read(path)?, options)?;
    inputs.insert(0, path.to_path_buf());
    Ok((frames, inputs))
}

/// The bytes of the file at `path`.
pub(super) fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| SceneError::Io {
        file: path.display().to_string(),
        source,
    })
}

/// [`load_file_with_inputs`] on bytes already read (`path` names the asset and is the base of relative
/// URIs, but is not read).
pub(crate) fn load_bytes(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<Scene> {
    frames_from_bytes(path, bytes, options)?.0.frame(0)
}

/// [`load_file_frames`] on bytes already read, and the files it read besides `path`
/// (buffers, images).
fn frames_from_bytes(
    path: &Path,
    bytes: &[u8],
    options: &LoadOptions,
) -> Result<(Frames, Vec<PathBuf>)> {
    let (frames, first) = GltfFrames::prepare(path, bytes, options)?;
    let inputs = frames.asset.files_read();
    if frames.clip.is_none() {
        return Ok((Frames::still(first, frames.asset.cx.file.clone()), inputs));
    }
    Ok((Frames::gltf(Box::new(frames)), inputs))
}

/// Which camera views the frames.
#[derive(Debug)]
enum View {
    /// `/cameras/N` (`None`: the first camera in node order), following its node.
    Asset(Option<usize>),
    /// The framing camera of frame 0's bounds, kept for every frame.
    Fixed(Box<Camera>),
}

/// A glTF file prepared for flattening: read and validated once (the asset, animation 0,
/// materials and textures, and the node matrices and camera of every frame); a frame rebuilds
/// only the node matrices, the geometry and the camera.
pub(crate) struct GltfFrames {
    asset: Asset,
    clip: Option<Clip>,
    view: View,
    /// Every frame without its geometry and camera: name, description, resolution, materials,
    /// textures, ignored lines and credits.
    template: Scene,
    materials: Materials,
    triangles: u64,
}

impl std::fmt::Debug for GltfFrames {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GltfFrames")
            .field("file", &self.asset.cx.file)
            .field("animation", &self.animation())
            .field("triangles", &self.triangles)
            .finish_non_exhaustive()
    }
}

/// Marks an error of frame `t` as such.
fn at_frame(t: u32, e: SceneError) -> SceneError {
    e.at_frame(t, "/animations/0")
}

/// Where a file's geometry goes: as it is, unlit.
const PLACEMENT: Placement<'static> = Placement {
    transform: Affine3A::IDENTITY,
    transform_path: None,
    light: None,
    ordering: crate::Ordering {
        group: 0,
        queue: None,
        order: 0,
        method: None,
    },
    name_prefix: String::new(),
};

impl GltfFrames {
    /// Reads and validates the asset, its animation 0, materials and textures, and the node
    /// matrices and camera of every frame. With frame 0, built on the way.
    fn prepare(path: &Path, bytes: &[u8], options: &LoadOptions) -> Result<(GltfFrames, Scene)> {
        let asset = Asset::from_bytes(path, bytes)?;
        let nodes = asset.nodes(None, |count| {
            asset
                .cx
                .err("/scenes", Problem::NoSuchItem { index: 0, count })
        })?;
        let triangles = asset.triangle_count(&nodes)?;
        if triangles > MAX_TRIANGLES {
            return Err(asset
                .cx
                .err("/meshes", Problem::TooManyTriangles { count: triangles }));
        }
        let (clip, ignored) = asset.clip()?;
        let resolution = DEFAULT_RESOLUTION;
        let stem = path
            .file_stem()
            .map_or_else(|| asset.name.clone(), |s| s.to_string_lossy().into_owned());
        let mut template = Scene {
            name: stem,
            description: String::new(),
            resolution,
            camera: framing_camera(Vec3::ZERO, 1.0, resolution.aspect()),
            background: GLTF_BACKGROUND,
            materials: Vec::new(),
            draws: Vec::new(),
            vertices: Vec::new(),
            textures: Vec::new(),
            ignored: Vec::new(),
            credits: Vec::new(),
            frame: 0,
            animation: None,
            lights: crate::LightRig::none(),
        };
        let materials = asset.add_materials(&mut template, options.gltf_lighting())?;
        template.ignored.extend(ignored);
        let animated = clip.is_some();
        let (view, camera_text) = match (options.camera, nodes.cameras.is_empty()) {
            (Some(k), _) => (View::Asset(Some(k)), format!("/cameras/{k}")),
            (None, false) => (
                View::Asset(None),
                "its first camera in node order".to_string(),
            ),
            (None, true) if animated => (
                View::Fixed(Box::new(template.camera.clone())),
                "a camera framing frame 0's bounds, kept for every frame (it has none)".to_string(),
            ),
            (None, true) => (
                View::Fixed(Box::new(template.camera.clone())),
                "a camera framing its bounds (it has none)".to_string(),
            ),
        };
        let scene_text = nodes
            .scene
            .map_or("all root nodes".to_string(), |s| format!("/scenes/{s}"));
        template.description = format!(
            "glTF 2.0 asset {} ({scene_text}), viewed from {camera_text}, {}",
            asset.name,
            match options.gltf_lighting() {
                GltfLighting::Unlit => "unlit",
                GltfLighting::PerPixel(_) => "lit per pixel",
            }
        );
        if let Some(c) = &clip {
            template.description.push_str(&format!(
                ", /animations/0 played at {GLTF_FPS} fps ({} frames)",
                c.frames
            ));
        }
        let mut frames = GltfFrames {
            asset,
            clip,
            view,
            template,
            materials,
            triangles,
        };
        // Frame 0's geometry gives the bounds: of the framing camera, and of the far plane of
        // an asset camera without zfar (validated here; each frame recomputes its own).
        let pose = frames.clip.as_ref().map(|c| c.pose(0));
        let nodes = frames.nodes(pose.as_ref()).map_err(|e| frames.mark(0, e))?;
        let mut scene = frames.template.clone();
        frames
            .asset
            .add_geometry(&nodes, &frames.materials, &PLACEMENT, &mut scene)
            .map_err(|e| frames.mark(0, e))?;
        crate::lighting::complete_rig(&mut scene);
        let (centre, radius) = bounds(&scene.vertices);
        if let View::Fixed(c) = &mut frames.view {
            **c = framing_camera(centre, radius, resolution.aspect());
        }
        scene.camera = frames
            .camera(&nodes, (centre, radius))
            .map_err(|e| frames.mark(0, e))?;
        scene.animation = frames.animation();
        let count = frames.clip.as_ref().map_or(1, |c| c.frames);
        for t in 1..count {
            let pose = frames.clip.as_ref().map(|c| c.pose(t));
            let nodes = frames.nodes(pose.as_ref()).map_err(|e| frames.mark(t, e))?;
            frames
                .camera(&nodes, (centre, radius))
                .map_err(|e| frames.mark(t, e))?;
        }
        Ok((frames, scene))
    }

    /// `e` marked as an error of frame `t` when the asset is animated.
    fn mark(&self, t: u32, e: SceneError) -> SceneError {
        if self.clip.is_some() {
            at_frame(t, e)
        } else {
            e
        }
    }

    /// The file, as named in errors.
    pub(crate) fn file(&self) -> &str {
        &self.asset.cx.file
    }

    /// Frame count and rate of animation 0 (`None` for a still asset).
    pub(crate) fn animation(&self) -> Option<Animation> {
        self.clip.as_ref().map(|c| Animation {
            frames: c.frames,
            fps: GLTF_FPS,
        })
    }

    /// The node instances of the scene used, with the animated nodes of `pose`.
    fn nodes(&self, pose: Option<&Pose>) -> Result<Nodes> {
        self.asset.nodes_posed(
            None,
            |count| {
                self.asset
                    .cx
                    .err("/scenes", Problem::NoSuchItem { index: 0, count })
            },
            pose,
        )
    }

    /// The camera of a frame whose nodes are `nodes` and whose bounding sphere is `bounds`.
    fn camera(&self, nodes: &Nodes, bounds: (Vec3, f32)) -> Result<Camera> {
        let aspect = self.template.resolution.aspect();
        let camera = match &self.view {
            View::Asset(k) => self.asset.camera(nodes, *k, bounds, aspect)?,
            View::Fixed(c) => (**c).clone(),
        };
        if !camera.view_proj.is_finite() {
            return Err(self.asset.cx.err(
                "/cameras",
                Problem::DerivedNonFinite {
                    what: "view-projection matrix".into(),
                },
            ));
        }
        Ok(camera)
    }

    /// Frame `t` (0 for a still asset) as a scene: `Scene::frame` = `t`, `Scene::animation`
    /// set when the asset is animated. Errors of an animated asset name the frame.
    pub(crate) fn frame(&self, t: u32) -> Result<Scene> {
        let build = || -> Result<Scene> {
            let pose = self.clip.as_ref().map(|c| c.pose(t));
            let nodes = self.nodes(pose.as_ref())?;
            let mut scene = self.template.clone();
            scene.vertices.reserve(self.triangles as usize * 3);
            self.asset
                .add_geometry(&nodes, &self.materials, &PLACEMENT, &mut scene)?;
            crate::lighting::complete_rig(&mut scene);
            scene.camera = self.camera(&nodes, bounds(&scene.vertices))?;
            scene.frame = t;
            scene.animation = self.animation();
            Ok(scene)
        };
        build().map_err(|e| self.mark(t, e))
    }
}
