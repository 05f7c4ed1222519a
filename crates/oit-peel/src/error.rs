//! The error type of this crate.

/// A technique spec this crate cannot turn into a configuration. Specs parsed against
/// [`crate::techniques`] never produce one; hand-built [`oit_gpu::TechniqueSpec`] values can.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PeelError {
    #[error("technique spec {spec:?}: {technique} needs parameter {key}; allowed: {allowed}")]
    Missing {
        spec: String,
        technique: &'static str,
        key: &'static str,
        allowed: String,
    },
    #[error("technique spec {spec:?}: {key}={value:?} is not allowed; allowed: {allowed}")]
    BadValue {
        spec: String,
        key: &'static str,
        value: String,
        allowed: String,
    },
    #[error("technique spec {spec:?}: not a {expected} spec")]
    WrongTechnique {
        spec: String,
        expected: &'static str,
    },
}
