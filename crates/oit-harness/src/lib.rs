//! oit-harness
