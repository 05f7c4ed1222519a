//! oit-scene: the scene format and the one immutable [`Scene`] every oit-lab crate consumes.
//!
//! [`load`] / [`parse`] / [`parse_gltf`] / [`load_dir`] read the JSON format described in docs/scene-format.md
//! and glTF 2.0 assets (`.gltf`, `.glb`, also placeable as JSON objects of kind `gltf`),
//! validate every value (errors name file, JSON path and what is allowed) and flatten the file
//! into a [`Scene`]: procedural meshes generated, instancing expanded, transforms applied,
//! billboards turned to the camera and lighting baked into vertex colours. The oit-fuzz package
//! (fuzz/) fuzzes both loaders against their documented invariants.

mod animation;
mod blending;
mod error;
mod format;
pub(crate) mod gltf;
mod lighting;
mod load;
mod load_blending;
mod mesh;
mod queues;
pub mod random;
mod rng;
mod scene;
mod serde_errors;
mod strict;
mod texture;

pub use animation::{Animation, Frames, MAX_FRAMES};
pub use blending::{BlendOperator, ObjectMethod, Ordering, RenderQueue};
pub use error::{Problem, SceneError};
pub use format::{DEFAULT_RESOLUTION, MAX_TRIANGLES};
pub use gltf::{GLTF_BACKGROUND, GLTF_FPS, MAX_TEXELS};
pub use lighting::{
    LightKind, LightRig, MAX_LIGHTS, MIN_GGX_ALPHA, PunctualLight, Reflectance, Reflected,
    Specular, SurfacePoint, reflect_lights,
};
pub use load::{
    LoadOptions, is_gltf_path, load, load_dir, load_dir_with, load_frames, load_with,
    load_with_inputs, parse, parse_frames, parse_gltf, scene_files,
};
pub use queues::QueueLevel;
pub use rng::SplitMix64;
pub use scene::*;
pub use texture::{
    Encoding, Filter, MAX_TEXTURE_DIMENSION, MAX_UV, MipFilter, Sampler, Texture, UNORM_TABLE,
    Wrap, decode_tables, level_size, linear_to_srgb_code, pack_rgba8, srgb_to_linear,
};
