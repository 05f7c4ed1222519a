//! oit-opaque-copy: Babylon.js's transmission technique (seed 002, "Rendering transmissive
//! materials with frame graphs"), measured against the exact reference.
//!
//! `opaque-copy` renders a frame the way Babylon's frame graph does:
//! 1. the shared opaque pass;
//! 2. a copy of its colour (a pass cannot read the texture it writes);
//! 3. transmissive surfaces (`Material::transmission > 0`), depth-tested and depth-writing like
//!    Babylon's OPAQUE-mode glass, each writing `C + t ⊙ copy` at its own pixel (no refraction
//!    offset: the reference models none), so the nearest one wins;
//! 4. the ordinary transparent surfaces, OVER-blended in Babylon's object order.
//!
//! It is exact for one transmissive layer over opaque content and for transparent layers in
//! front of the glass. Anything transparent or transmissive *behind* the nearest transmissive
//! surface is missing from the copy and hidden by its depth: the missing-layer error the
//! bundled `transmission-*` scenes measure.

mod predict;
mod technique;

pub use technique::OpaqueCopy;

/// Every WGSL file of this crate (`shaders/`), by file name: what its passes' `#include`s
/// resolve in first (`oit_gpu::shaders::resolve`), and what the shader test holds against the
/// folder.
pub const SHADERS: oit_gpu::shaders::Library = &[("opaque_copy.wgsl", technique::SHADER)];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "opaque-copy",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS],
};

use oit_gpu::TechniqueInfo;

/// The registry entry of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![TechniqueInfo {
        name: OpaqueCopy::NAME,
        description: "Babylon's transmission: opaque pass, copy of its colour, transmissive surfaces write C + t ⊙ copy (nearest wins), then OVER-blended transparent objects in Babylon's order",
        params: Vec::new(),
        transmission: "approximate: exact for the nearest transmissive surface over opaque content and for transparent surfaces in front of it; anything transparent or transmissive behind the nearest glass is missing",
        build: |spec| Ok(Box::new(OpaqueCopy::from_spec(spec)?)),
    }]
}
