//! oit-peel: depth peeling, the exact GPU transparency techniques of this testbed.
//!
//! - `front-peel` (Everitt 2001): one layer per geometry pass, nearest first, under-blended into
//!   a front accumulator; `layers=auto` stops one pass after the last layer (the detection pass).
//! - `dual-peel` (Bavoil & Myers 2008): each pass peels the nearest and the farthest remaining
//!   layer, using a MAX-blended (−min, max) key range in `Rg32Float` or `Rg16Float`. Beyond
//!   Babylon.js: the range test runs before any shading, the init pass computes only coverage,
//!   `passes=auto` stops exactly after ⌈L/2⌉ passes without a CPU round trip per pass, the
//!   middle layers left after the last pass can be composited with weighted blending
//!   (`tail=wboit`), and the stored key can use another depth encoding than window depth.
//!
//! Termination is GPU-driven: every transparent draw is an indirect draw, and a one-workgroup
//! compute pass after each peel pass copies "this pass left something for the next" (an atomic
//! flag a shader of the pass sets) into the instance count of the next pass's draws. A frame
//! records as many passes as the previous frame needed and reads the counters back once at the
//! end (for the stats); only when that budget was too small does it record more.
//!
//! No pass count is fixed: `auto` peels until nothing is left. The per-pass counters and pass
//! indices grow with the frame; the only bound is the adapter's ([`max_pass_slots`]: buffer
//! size over the dynamic-offset alignment, or the storage binding size), which an explicit
//! `layers=N` / `passes=N` beyond it is reported against by `check`.
//!
//! See README.md for the measurements (lavapipe) and the depth-range encoding table.

mod config;
mod dual;
mod encoding;
mod front;
mod gpu;
mod predict;

pub use config::{
    AccumFormat, DepthFormat, DualPeelConfig, FrontPeelConfig, PassCount, Passes, ReverseZ, Tail,
};
pub use dual::DualPeel;
pub use encoding::{DepthEncoding, KeyParams, f16_round, half_uniform, peel_key};
pub use front::FrontPeel;
pub use gpu::{
    COUNTER_HEADER_WORDS, COUNTER_WORDS_PER_PASS, Options, PeelReport, Termination, max_pass_slots,
};

/// Every WGSL file of this crate (`shaders/`), by file name: what its passes' `#include`s
/// resolve in first (`oit_gpu::shaders::resolve`), and what the shader test holds against the
/// folder.
pub const SHADERS: oit_gpu::shaders::Library = &[
    ("peel_common.wgsl", gpu::PEEL_COMMON),
    ("peel_composite.wgsl", gpu::PEEL_COMPOSITE),
    ("peel_counters.wgsl", gpu::PEEL_COUNTERS),
    ("peel_dual.wgsl", gpu::PEEL_DUAL),
    ("peel_front.wgsl", gpu::PEEL_FRONT),
    ("peel_gate.wgsl", gpu::PEEL_GATE),
    ("peel_tail.wgsl", gpu::PEEL_TAIL),
    ("peel_transmit.wgsl", gpu::PEEL_TRANSMIT),
];

/// This crate's `shaders/` folder.
pub const SHADER_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");

/// This crate as the harness's registry and the shader test see it.
pub const FAMILY: oit_gpu::Family = oit_gpu::Family {
    folder: "peel",
    techniques,
    shader_dir: SHADER_DIR,
    shaders: &[SHADERS, oit_wboit::SHADERS],
};

use oit_gpu::{Caps, TechniqueInfo};

/// Most `front-peel` layers on this adapter (`auto` and `layers=N`): one pass slot per layer.
pub fn max_front_layers(caps: &Caps) -> u32 {
    max_pass_slots(caps).0
}

/// Most `dual-peel` peel passes on this adapter (`auto` and `passes=N`): the init pass takes
/// one pass slot, each peel pass one more.
pub fn max_dual_passes(caps: &Caps) -> u32 {
    max_pass_slots(caps).0.saturating_sub(1)
}

/// The registry entries of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![
        TechniqueInfo {
            name: "front-peel",
            description: "front-to-back depth peeling (Everitt 2001): one layer per geometry pass, exact up to the layer budget; auto stops after the first empty pass",
            params: FrontPeelConfig::params(),
            transmission: "**exact** per channel: one accumulator per colour channel, blended with ordinary factors (dual-source blending allows only one target, and peel passes write several), put over the final colour as `dst *= T`, `dst += F`. Needs 3 colour attachments of 48 bytes per sample, else approximate: the scalar opacity `1 − mean(t)`",
            build: |spec| Ok(Box::new(FrontPeel::from_spec(spec)?)),
        },
        TechniqueInfo {
            name: "dual-peel",
            description: "dual depth peeling (Bavoil & Myers 2008): nearest and farthest layer per pass from a MAX-blended (-min, max) range; range test before shading, coverage-only init pass",
            params: DualPeelConfig::params(),
            transmission: "**exact** per channel as `front-peel` does, with 7 colour attachments of 80 bytes per sample, else approximate: `1 − mean(t)`. With a fixed `passes` and `tail=wboit` approximate: its WBOIT tail stays scalar",
            build: |spec| Ok(Box::new(DualPeel::from_spec(spec)?)),
        },
    ]
}
