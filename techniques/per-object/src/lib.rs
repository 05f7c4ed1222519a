//! oit-per-object: pygfx's renderer (pygfx 0.17, `pygfx/pygfx` at `ed8e491b`), where every
//! object carries its own transparency method (`Draw.ordering.method`, pygfx's
//! `alpha_method`) and the renderer draws the objects in pygfx's order, one render pass per
//! run of consecutive objects that share a method:
//!
//! - `opaque` (pygfx `solid`): the straight colour with α = 1, depth written;
//! - `stochastic` (pygfx `dither`): pygfx's procedural pseudo-blue noise with its per-element
//!   seed decides, per pixel, whether the fragment is kept (then opaque, depth written);
//! - `blended` (pygfx `blend`, `add`, `subtract`, `multiply`): the material's operator in fixed
//!   function, depth written only where the material asks;
//! - `weighted` (pygfx `weighted_blend`): weight α into an rgba16float accumulation and an
//!   r8unorm revealage, resolved over the colour right after each run of weighted objects.
//!
//! The order ([`order::draw_order`]) is the scene's engine order (render group, render queue,
//! render order, distance), with the queue derived from each object's effective method and
//! weighted objects unsorted by distance, as pygfx sorts them.

mod order;
mod predict;
mod technique;

pub use order::{Config, DefaultMethod, ForcedMethod, draw_order, effective_method};
pub use technique::PerObject;

/// Every WGSL file of this crate (`shaders/`), by file name: what its passes' `#include`s
/// resolve in first (`oit_gpu::shaders::resolve`), and what the shader test holds against the
/// folder.
pub const SHADERS: oit_gpu::shaders::Library = &[
    ("per_object.wgsl", technique::METHODS_WGSL),
    ("per_object_dither.wgsl", technique::DITHER_WGSL),
    ("per_object_noise.wgsl", technique::NOISE_WGSL),
    ("per_object_resolve.wgsl", technique::RESOLVE_WGSL),
    ("per_object_transmit.wgsl", technique::TRANSMIT_WGSL),
];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "per-object",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS],
};

use oit_gpu::TechniqueInfo;

/// The registry entry of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![TechniqueInfo {
        name: PerObject::NAME,
        description: "pygfx's renderer: each object drawn with its own method (opaque, stochastic dither, blended with its operator, weighted blended), objects in pygfx's order (group, queue, render order, distance), one pass per run of a method",
        params: Config::params(),
        transmission: "blended objects: **exact** per channel with dual-source blending (`dst = C + t ⊙ dst`) where the adapter has it, else 1 − mean(t) as scalar α; weighted, stochastic and opaque objects: the scalar opacity 1 − mean(t); multiply-operator objects are always drawn blended",
        build: |spec| Ok(Box::new(PerObject::from_spec(spec)?)),
    }]
}
