//! The one place oit-lab writes `unsafe`.
//!
//! wgpu 30 puts ray queries (`Features::EXPERIMENTAL_RAY_QUERY`) behind a token whose
//! constructor is `unsafe`: by calling it a program acknowledges that experimental features may
//! have bugs that reach undefined behaviour through safe calls. Every other crate of the
//! workspace forbids `unsafe_code`; this one denies it and allows it on [`experimental_features`]
//! alone, so `grep -rn unsafe` finds this file.

/// wgpu's token for requesting experimental features; `oit_gpu::Context` passes it to
/// `request_device` only where the adapter has `EXPERIMENTAL_RAY_QUERY` and only asks for that
/// experimental feature.
///
/// Why this is sound here: the token's contract (wgpu-types 30 `tokens.rs`) is an
/// acknowledgement, not a precondition on the caller's data. The ray-query technique uses the
/// feature as wgpu validates it — acceleration structures built from buffers it created with
/// `BLAS_INPUT`, instance data it wrote, one query per invocation — and every image it renders
/// is compared with the exact CPU reference by the tests, so a driver or wgpu defect shows up
/// as a failed comparison rather than passing unseen.
#[allow(unsafe_code)]
pub fn experimental_features() -> wgpu::ExperimentalFeatures {
    // SAFETY: an acknowledgement token with no memory-safety precondition of its own; see above.
    unsafe { wgpu::ExperimentalFeatures::enabled() }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_token_is_enabled() {
        assert!(super::experimental_features().is_enabled());
        assert!(!wgpu::ExperimentalFeatures::disabled().is_enabled());
    }
}
