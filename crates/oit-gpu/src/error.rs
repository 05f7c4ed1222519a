//! The one error type of this crate.

/// Why a technique (or target format) cannot run on this adapter. Not a failure of the run:
/// the harness records it as "skipped" with this reason.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unsupported here because {reason}")]
pub struct Unsupported {
    pub reason: String,
}

impl Unsupported {
    pub fn new(reason: impl Into<String>) -> Self {
        Self {
            reason: reason.into(),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter at all for the requested backend.
    #[error(
        "no GPU adapter found for backend {backend}: install a GPU driver, or `apt-get install mesa-vulkan-drivers` for the CPU rasterizer lavapipe"
    )]
    NoAdapter { backend: String },
    /// Adapters exist, but none has `filter` in its name.
    #[error(
        "no GPU adapter for backend {backend} has {filter:?} in its name; available: {available}"
    )]
    AdapterNotMatched {
        backend: String,
        filter: String,
        available: String,
    },
    #[error("cannot create a device on adapter {adapter:?}: {message}")]
    RequestDevice { adapter: String, message: String },
    #[error(transparent)]
    Unsupported(#[from] Unsupported),
    /// A size the device cannot hold (buffer or texture over the adapter's limits), in bytes
    /// (stated in MiB).
    #[error("{what} needs {}, but this adapter allows at most {}", crate::mib(*needed), crate::mib(*limit))]
    TooLarge {
        what: String,
        needed: u64,
        limit: u64,
    },
    /// A count the device cannot hold (peel passes, u32 indices): like [`GpuError::TooLarge`]
    /// for numbers that are not bytes.
    #[error("{what} needs {needed}, but this adapter allows at most {limit}")]
    TooMany {
        what: String,
        needed: u64,
        limit: u64,
    },
    /// Storage sized from the scene (`auto` parameters) over a stated cap: refused, never
    /// clamped.
    #[error("{what} needs {}, more than {}, {cap_name}; nothing is clamped, so the configuration is refused on this scene", crate::mib(*needed), crate::mib(*cap))]
    OverMemoryCap {
        what: String,
        needed: u64,
        cap: u64,
        cap_name: String,
    },
    /// The scene's textures exceed the adapter's texture array (the message gives both sizes
    /// in MiB; see crates/oit-gpu/src/texels.rs).
    #[error("{0}")]
    TexturesTooLarge(String),
    #[error("shader {shader}: {message}")]
    Shader { shader: String, message: String },
    #[error("reading back {what} from the GPU failed: {message}")]
    Readback { what: String, message: String },
    #[error("waiting for the GPU failed: {0}")]
    Poll(String),
    /// A hand-built scene breaks a rule the loader enforces (the message says which).
    #[error("invalid scene: {0}")]
    InvalidScene(String),
    /// The run's time budget ([`crate::GpuTimer::set_budget`]) ran out before a submission.
    #[error("stopped after {}, the time budget of one run (oit compare --run-budget)", seconds_text(*seconds))]
    OverBudget { seconds: f64 },
    /// The device reported an error (validation, out of memory, internal) or the work
    /// panicked, caught by [`crate::Context::contain`].
    #[error("{0}")]
    Device(String),
    /// Caller passed inconsistent arguments (e.g. targets of another size than the scene).
    #[error("{0}")]
    Mismatch(String),
}

/// Whole seconds from 10 s on, milliseconds below.
fn seconds_text(seconds: f64) -> String {
    if seconds >= 10.0 {
        format!("{seconds:.0} s")
    } else {
        format!("{:.0} ms", seconds * 1e3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_sizes_are_stated_in_mib_and_counts_as_numbers() {
        let bytes = GpuError::TooLarge {
            what: "the texel store".into(),
            needed: 138_412_032,
            limit: 134_217_728,
        };
        assert_eq!(
            bytes.to_string(),
            "the texel store needs 132.0 MiB, but this adapter allows at most 128.0 MiB"
        );
        let count = GpuError::TooMany {
            what: "depth-peeling passes".into(),
            needed: 300,
            limit: 256,
        };
        assert_eq!(
            count.to_string(),
            "depth-peeling passes needs 300, but this adapter allows at most 256"
        );
    }
}
