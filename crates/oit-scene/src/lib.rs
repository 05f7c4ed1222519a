//! oit-scene: the scene format and the one immutable [`Scene`] every oit-lab crate consumes.

mod scene;

pub use scene::*;
