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
//! See README.md for the measurements (lavapipe) and the depth-range encoding table.

mod config;
mod dual;
mod encoding;
mod error;
mod front;
mod gpu;

pub use config::{DepthFormat, DualPeelConfig, FrontPeelConfig, PassCount, Tail};
pub use dual::DualPeel;
pub use encoding::{DepthEncoding, KeyParams, f16_round, half_uniform, peel_key};
pub use error::PeelError;
pub use front::FrontPeel;
pub use gpu::{COUNTER_SLOTS, Options, PeelReport, Termination};

use oit_gpu::{Allowed, ParamInfo, TechniqueInfo};

/// Largest `dual-peel:passes=N` (and the `auto` budget): 128 layers.
pub const MAX_DUAL_PASSES: u32 = 64;
/// Largest `front-peel:layers=N` (and the `auto` budget).
pub const MAX_FRONT_LAYERS: u32 = 128;

/// The registry entries of this crate.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![
        TechniqueInfo {
            name: "front-peel",
            description: "front-to-back depth peeling (Everitt 2001): one layer per geometry pass, exact up to the layer budget; auto stops after the first empty pass",
            params: vec![ParamInfo {
                key: "layers",
                description: "layers to peel (one geometry pass each), or auto: until a pass finds nothing (GPU-gated indirect draws)",
                default: "auto",
                allowed: Allowed::Integer {
                    min: 1,
                    max: MAX_FRONT_LAYERS as u64,
                    words: &["auto"],
                },
            }],
            build: |spec| Box::new(FrontPeel::from_spec(spec)),
        },
        TechniqueInfo {
            name: "dual-peel",
            description: "dual depth peeling (Bavoil & Myers 2008): nearest and farthest layer per pass from a MAX-blended (-min, max) range; range test before shading, coverage-only init pass",
            params: vec![
                ParamInfo {
                    key: "passes",
                    description: "peel passes after the init pass (2 layers each; Babylon's default is 5), or auto: exactly ceil(L/2), GPU-gated",
                    default: "5",
                    allowed: Allowed::Integer {
                        min: 1,
                        max: MAX_DUAL_PASSES as u64,
                        words: &["auto"],
                    },
                },
                ParamInfo {
                    key: "depth",
                    description: "range target format: rg32f needs blendable 32-bit float targets; auto picks rg32f where the adapter can blend it, else rg16f (keys rounded to f16)",
                    default: "auto",
                    allowed: Allowed::Values(DepthFormat::NAMES),
                },
                ParamInfo {
                    key: "reverse-z",
                    description: "stored key grows toward the viewer (independent of the scene's own depth buffer)",
                    default: "on",
                    allowed: Allowed::Values(&["on", "off"]),
                },
                ParamInfo {
                    key: "tail",
                    description: "layers left after the last pass: drop them, or composite them with weighted blended OIT",
                    default: "drop",
                    allowed: Allowed::Values(Tail::NAMES),
                },
                ParamInfo {
                    key: "encoding",
                    description: "stored key: window depth, or linear / logarithmic view distance over the scene's transparent depth interval",
                    default: "window",
                    allowed: Allowed::Values(DepthEncoding::NAMES),
                },
            ],
            build: |spec| Box::new(DualPeel::from_spec(spec)),
        },
    ]
}
