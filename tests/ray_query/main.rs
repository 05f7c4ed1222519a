//! `ray-query` on an adapter with ray queries (lavapipe of Mesa 25.0.7, unpacked by
//! `.ci/lavapipe-ray-query` and selected with `VK_ICD_FILENAMES`; `cargo xtask ci` runs this
//! binary so): exact against the reference on the tie-free bundled scenes and on seeded random
//! scenes in both draw orders, non-opaque candidates delivered without confirmation, K and ε
//! doing what they say. A binary of its own because the adapter is chosen per process.
//!
//! Without an adapter that has ray queries every test says so and returns; with
//! `OIT_REQUIRE_RAY_QUERY=1` (the xtask step) that is a failure instead.

#[allow(
    dead_code,
    reason = "the GPU tests' kit, shared whole; this binary uses part of it"
)]
#[path = "../gpu/kit.rs"]
mod kit;

mod exact;
