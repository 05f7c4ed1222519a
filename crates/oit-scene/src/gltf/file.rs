//! A `.gltf` / `.glb` file loaded as a scene of its own: its camera (or one framing its
//! bounds), the default resolution and background, and every file it read.

use super::*;

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

/// Loads a `.gltf` / `.glb` file as a scene of its own: unlit, at [`DEFAULT_RESOLUTION`],
/// background [`GLTF_BACKGROUND`], reverse-Z, with the asset's first camera in node order (or
/// `options.camera`), else [`framing_camera`].
/// With every file it read: the asset first, then its buffers and images.
pub(crate) fn load_file_with_inputs(
    path: &Path,
    options: &LoadOptions,
) -> Result<(Scene, Vec<PathBuf>)> {
    let (scene, mut inputs) = load_bytes_with_inputs(path, &read(path)?, options)?;
    inputs.insert(0, path.to_path_buf());
    Ok((scene, inputs))
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
    Ok(load_bytes_with_inputs(path, bytes, options)?.0)
}

/// [`load_bytes`], and the files it read besides `path` (buffers, images).
fn load_bytes_with_inputs(
    path: &Path,
    bytes: &[u8],
    options: &LoadOptions,
) -> Result<(Scene, Vec<PathBuf>)> {
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
    let resolution = DEFAULT_RESOLUTION;
    let stem = path
        .file_stem()
        .map_or_else(|| asset.name.clone(), |s| s.to_string_lossy().into_owned());
    let mut scene = Scene {
        name: stem,
        description: String::new(),
        resolution,
        camera: framing_camera(Vec3::ZERO, 1.0, resolution.aspect()),
        background: GLTF_BACKGROUND,
        materials: Vec::new(),
        draws: Vec::new(),
        vertices: Vec::with_capacity(triangles as usize * 3),
        textures: Vec::new(),
        ignored: Vec::new(),
        credits: Vec::new(),
        frame: 0,
        animation: None,
    };
    let materials = asset.add_materials(&mut scene)?;
    let placement = Placement {
        transform: Affine3A::IDENTITY,
        transform_path: None,
        light: None,
        render_group: 0,
        alpha_index: 0,
        name_prefix: String::new(),
    };
    asset.add_geometry(&nodes, &materials, &placement, &mut scene)?;
    let (centre, radius) = bounds(&scene.vertices);
    let camera_text;
    scene.camera = match (options.camera, nodes.cameras.is_empty()) {
        (Some(k), _) => {
            camera_text = format!("/cameras/{k}");
            asset.camera(&nodes, Some(k), (centre, radius), resolution.aspect())?
        }
        (None, false) => {
            camera_text = "its first camera in node order".to_string();
            asset.camera(&nodes, None, (centre, radius), resolution.aspect())?
        }
        (None, true) => {
            camera_text = "a camera framing its bounds (it has none)".to_string();
            framing_camera(centre, radius, resolution.aspect())
        }
    };
    if !scene.camera.view_proj.is_finite() {
        return Err(asset.cx.err(
            "/cameras",
            Problem::DerivedNonFinite {
                what: "view-projection matrix".into(),
            },
        ));
    }
    let scene_text = nodes
        .scene
        .map_or("all root nodes".to_string(), |s| format!("/scenes/{s}"));
    scene.description = format!(
        "glTF 2.0 asset {} ({scene_text}), viewed from {camera_text}, unlit",
        asset.name
    );
    let inputs = asset.files_read();
    Ok((scene, inputs))
}
