//! The JSON scene format as serde types. These mirror the file one to one (documented in
//! docs/scene-format.md); validation and flattening into [`crate::Scene`] happen in `load.rs`.
//! Every struct denies unknown fields so a typo is an error, not a silently ignored setting.

use serde::Deserialize;

use crate::scene::{AlphaMode, Resolution};

/// Cap on the total triangle count of one scene (after instancing), checked before any geometry
/// is generated, so a typo like `"count": 1e9` cannot exhaust memory. 4 million triangles is
/// 432 MB of vertices, well above the bundled suite and within a CI box.
pub const MAX_TRIANGLES: u64 = 4_000_000;

/// Resolution of a scene that gives none (the bundled suite's size: small enough for CI).
pub const DEFAULT_RESOLUTION: Resolution = Resolution {
    width: 256,
    height: 256,
};

/// Valid `kind` values of a mesh, listed in errors.
pub const MESH_KINDS: &str =
    "`quad`, `box`, `uv-sphere`, `torus`, `cylinder`, `layers`, `soup`, `billboards`, `gltf`";

fn default_resolution() -> [u64; 2] {
    [
        u64::from(DEFAULT_RESOLUTION.width),
        u64::from(DEFAULT_RESOLUTION.height),
    ]
}
fn yes() -> bool {
    true
}
fn one() -> f32 {
    1.0
}
fn ones3() -> [f32; 3] {
    [1.0; 3]
}
fn half() -> f32 {
    0.5
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawScene {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default = "default_resolution")]
    pub resolution: [u64; 2],
    pub camera: RawCamera,
    #[serde(default)]
    pub background: [f32; 3],
    #[serde(default = "yes")]
    pub reverse_z: bool,
    #[serde(default)]
    pub lighting: RawLighting,
    pub objects: Vec<RawObject>,
    /// Present for an animated scene: its frame count and rate (crate::animation).
    #[serde(default)]
    pub animation: Option<RawAnimation>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawAnimation {
    pub frames: u64,
    pub fps: f32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn default_near() -> f32 {
    0.1
}
fn default_far() -> f32 {
    100.0
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawCamera {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees (perspective; 45 when neither this nor
    /// `orthographic` is given).
    #[serde(default)]
    pub fov_y: Option<f32>,
    #[serde(default)]
    pub orthographic: Option<RawOrthographic>,
    #[serde(default = "default_near")]
    pub near: f32,
    #[serde(default = "default_far")]
    pub far: f32,
    /// Animated camera values by frame (crate::animation); empty for a still camera.
    #[serde(default)]
    pub keyframes: Vec<RawCameraKey>,
    /// A generated path: the eye circles `center` (the target) once per `turns`.
    #[serde(default)]
    pub orbit: Option<RawOrbit>,
}

/// One camera keyframe: any subset of the animated camera fields at `frame`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawCameraKey {
    pub frame: u64,
    #[serde(default)]
    pub eye: Option<[f32; 3]>,
    #[serde(default)]
    pub target: Option<[f32; 3]>,
    #[serde(default)]
    pub up: Option<[f32; 3]>,
    #[serde(default)]
    pub fov_y: Option<f32>,
    #[serde(default)]
    pub orthographic: Option<RawOrthographic>,
}

fn default_turns() -> f32 {
    1.0
}

/// PixelSyncOIT's path in its simplest form: the eye on a circle of `radius` around
/// `center`, `height` above it, `turns` revolutions over the animation, looking at `center`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawOrbit {
    pub center: [f32; 3],
    pub radius: f32,
    #[serde(default)]
    pub height: f32,
    #[serde(default = "default_turns")]
    pub turns: f32,
    /// Angle of frame 0 in degrees about +Y, 0 on +Z (the eye at `center + (0, height, radius)`).
    #[serde(default)]
    pub start_degrees: f32,
}

pub(crate) const DEFAULT_FOV_Y: f32 = 45.0;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawOrthographic {
    /// Vertical extent of the view volume in world units.
    pub height: f32,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields, rename_all = "kebab-case")]
pub(crate) enum RawLighting {
    #[default]
    Unlit,
    Directional(RawDirectional),
}

fn default_ambient() -> [f32; 3] {
    [0.0; 3]
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawDirectional {
    /// Direction the light travels (from the light towards the scene).
    pub direction: [f32; 3],
    #[serde(default = "ones3")]
    pub color: [f32; 3],
    #[serde(default = "default_ambient")]
    pub ambient: [f32; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawObject {
    /// Parsed in a second step (by `kind`) so errors inside a mesh keep their full JSON path.
    pub mesh: serde_json::Value,
    #[serde(default)]
    pub transform: RawTransform,
    /// Absent means the default material; must be absent for `"kind": "gltf"` meshes.
    #[serde(default)]
    pub material: Option<RawMaterial>,
    /// Babylon's renderingGroupId.
    #[serde(default)]
    pub render_group: u32,
    /// pygfx's and Unity's render queue (1–4999); absent derives it.
    #[serde(default)]
    pub render_queue: Option<u16>,
    /// Within a queue, lower first; `alpha_index` is Babylon's name for the same key.
    #[serde(default)]
    pub render_order: Option<i32>,
    #[serde(default)]
    pub alpha_index: Option<i32>,
    /// The object's transparency method for the `per-object` renderer.
    #[serde(default)]
    pub method: Option<crate::ObjectMethod>,
    #[serde(default)]
    pub instances: Option<RawInstances>,
    /// Animated transform and alpha by frame (crate::animation); empty for a still object.
    #[serde(default)]
    pub keyframes: Vec<RawObjectKey>,
}

/// One object keyframe: any subset of `transform`'s fields and the material's `alpha`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawObjectKey {
    pub frame: u64,
    #[serde(default)]
    pub translate: Option<[f32; 3]>,
    #[serde(default)]
    pub rotate: Option<[f32; 3]>,
    #[serde(default)]
    pub scale: Option<[f32; 3]>,
    #[serde(default)]
    pub alpha: Option<f32>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawTransform {
    #[serde(default)]
    pub translate: [f32; 3],
    /// Degrees about X, then Y, then Z (world = T · Rz · Ry · Rx · S · local).
    #[serde(default)]
    pub rotate: [f32; 3],
    #[serde(default = "ones3")]
    pub scale: [f32; 3],
}

impl Default for RawTransform {
    fn default() -> Self {
        Self {
            translate: [0.0; 3],
            rotate: [0.0; 3],
            scale: [1.0; 3],
        }
    }
}

fn default_mode() -> AlphaMode {
    AlphaMode::Opaque
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawMaterial {
    #[serde(default = "ones3")]
    pub base_color: [f32; 3],
    #[serde(default = "one")]
    pub alpha: f32,
    #[serde(default = "default_mode")]
    pub mode: AlphaMode,
    #[serde(default = "half")]
    pub cutoff: f32,
    #[serde(default)]
    pub double_sided: bool,
    #[serde(default)]
    pub premultiplied: bool,
    #[serde(default = "one")]
    pub intensity: f32,
    #[serde(default)]
    pub transmission: f32,
    /// Lit per pixel by the scene's lights (docs/scene-format.md "Per-pixel lighting").
    #[serde(default)]
    pub lit: Option<RawLit>,
    /// docs/scene-format.md "Blend operators".
    #[serde(default)]
    pub operator: crate::BlendOperator,
    #[serde(default)]
    pub depth_write: bool,
}

/// A JSON material's per-pixel lighting parameters.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawLit {
    #[serde(default)]
    pub metallic: f32,
    #[serde(default = "half")]
    pub roughness: f32,
    #[serde(default = "faded")]
    pub specular: crate::lighting::Specular,
}

fn faded() -> crate::lighting::Specular {
    crate::lighting::Specular::Faded
}

/// How a `"kind": "gltf"` object's materials are lit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum RawGltfLighting {
    /// Per pixel by the scene's lights (the default).
    PerPixel,
    /// Unlit: the scene's `lighting.directional`, if any, baked into vertex colours.
    Unlit,
}

impl Default for RawMaterial {
    fn default() -> Self {
        Self {
            base_color: [1.0; 3],
            alpha: 1.0,
            mode: AlphaMode::Opaque,
            cutoff: 0.5,
            double_sided: false,
            premultiplied: false,
            intensity: 1.0,
            transmission: 0.0,
            lit: None,
            operator: crate::BlendOperator::Over,
            depth_write: false,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawInstances {
    /// Instances along x, y, z (instance index = ix + nx·(iy + ny·iz)).
    pub counts: [u32; 3],
    /// World-space offset between neighbouring instances, added after the object's transform.
    pub spacing: [f32; 3],
}

/// A `"kind": "gltf"` mesh: a glTF 2.0 asset placed as one object.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct GltfMeshRef {
    /// `.gltf` or `.glb` path, relative to the scene file's directory.
    pub file: String,
    /// Scene index in the asset; the asset's default scene (else 0) when absent.
    #[serde(default)]
    pub scene: Option<usize>,
    /// `"per-pixel"` (default) or `"unlit"`.
    #[serde(default)]
    pub lighting: Option<RawGltfLighting>,
    /// Overrides every lit material's specular rule: `"faded"` or `"kept"`.
    #[serde(default)]
    pub specular: Option<crate::lighting::Specular>,
}

// ---- meshes: one struct per `kind`, parsed from the `mesh` object after reading `kind` ----

fn unit2() -> [f32; 2] {
    [1.0; 2]
}
fn corner_ones() -> [f32; 4] {
    [1.0; 4]
}
fn default_segments() -> u32 {
    32
}
fn default_rings() -> u32 {
    16
}
fn default_tube_segments() -> u32 {
    16
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct QuadMesh {
    #[serde(default = "unit2")]
    pub size: [f32; 2],
    /// Vertex alpha at the corners (-x-y, +x-y, +x+y, -x+y), interpolated across the quad.
    #[serde(default = "corner_ones")]
    pub corner_alpha: [f32; 4],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BoxMesh {
    #[serde(default = "ones3")]
    pub size: [f32; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SphereMesh {
    #[serde(default = "half")]
    pub radius: f32,
    #[serde(default = "default_segments")]
    pub segments: u32,
    #[serde(default = "default_rings")]
    pub rings: u32,
}

fn default_major() -> f32 {
    0.5
}
fn default_minor() -> f32 {
    0.2
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TorusMesh {
    #[serde(default = "default_major")]
    pub major_radius: f32,
    #[serde(default = "default_minor")]
    pub minor_radius: f32,
    /// Around the main ring.
    #[serde(default = "default_segments")]
    pub segments: u32,
    /// Around the tube.
    #[serde(default = "default_tube_segments")]
    pub tube_segments: u32,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct CylinderMesh {
    #[serde(default = "half")]
    pub radius: f32,
    #[serde(default = "one")]
    pub height: f32,
    #[serde(default = "default_segments")]
    pub segments: u32,
    #[serde(default = "yes")]
    pub capped: bool,
}

fn default_layer_spacing() -> f32 {
    0.1
}
fn two2() -> [f32; 2] {
    [2.0, 2.0]
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LayersMesh {
    pub count: u32,
    #[serde(default = "default_layer_spacing")]
    pub spacing: f32,
    #[serde(default = "two2")]
    pub size: [f32; 2],
    #[serde(default = "ones3")]
    pub color_from: [f32; 3],
    #[serde(default = "ones3")]
    pub color_to: [f32; 3],
    #[serde(default = "half")]
    pub alpha_from: f32,
    #[serde(default = "half")]
    pub alpha_to: f32,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBounds {
    pub min: [f32; 3],
    pub max: [f32; 3],
}

fn default_item_size() -> f32 {
    0.1
}
fn zeros3() -> [f32; 3] {
    [0.0; 3]
}
fn zero() -> f32 {
    0.0
}

/// Shared by `soup` and `billboards`: `count` random items in `bounds`, each with a colour and
/// alpha drawn uniformly from the given ranges.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ScatterMesh {
    pub seed: u64,
    pub count: u32,
    pub bounds: RawBounds,
    #[serde(default = "default_item_size")]
    pub size: f32,
    #[serde(default = "zeros3")]
    pub color_min: [f32; 3],
    #[serde(default = "ones3")]
    pub color_max: [f32; 3],
    #[serde(default = "zero")]
    pub alpha_min: f32,
    #[serde(default = "one")]
    pub alpha_max: f32,
}

/// A mesh after its `kind` was read.
#[derive(Debug)]
pub(crate) enum RawMesh {
    Quad(QuadMesh),
    Box(BoxMesh),
    UvSphere(SphereMesh),
    Torus(TorusMesh),
    Cylinder(CylinderMesh),
    Layers(LayersMesh),
    Soup(ScatterMesh),
    Billboards(ScatterMesh),
}
