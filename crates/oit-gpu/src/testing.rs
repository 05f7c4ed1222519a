//! Helpers for GPU tests in every crate.

use crate::context::{Context, ContextOptions};

/// Environment variable that turns a missing adapter into a test failure (CI sets it to 1).
pub const REQUIRE_GPU_ENV: &str = "OIT_REQUIRE_GPU";

/// A context on the default adapter, or `None` (with a message) when there is none. With
/// `OIT_REQUIRE_GPU=1` a missing adapter panics instead, so CI cannot pass by skipping.
pub fn context_or_skip(test_name: &str) -> Option<Context> {
    match Context::new(&ContextOptions::default()) {
        Ok(ctx) => Some(ctx),
        Err(e) => {
            if std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1") {
                panic!("{test_name}: {REQUIRE_GPU_ENV}=1 but no usable GPU adapter: {e}");
            }
            eprintln!("skipped {test_name}: no GPU adapter (install mesa-vulkan-drivers): {e}");
            None
        }
    }
}

/// A context on wgpu's GL backend (llvmpipe through EGL in CI), or `None` with a message. With
/// `OIT_REQUIRE_GPU=1` a missing GL adapter panics, like a missing Vulkan one: the GL fallback
/// paths are tested in CI, never skipped there.
pub fn gl_context_or_skip(test_name: &str) -> Option<Context> {
    match Context::new(&ContextOptions {
        backend: crate::Backend::Gl,
        adapter: None,
    }) {
        Ok(ctx) => Some(ctx),
        Err(e) => {
            if std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| v == "1") {
                panic!("{test_name}: {REQUIRE_GPU_ENV}=1 but no GL adapter: {e}");
            }
            eprintln!(
                "skipped {test_name}: no GL adapter (install libegl-mesa0 libgl1-mesa-dri): {e}"
            );
            None
        }
    }
}
