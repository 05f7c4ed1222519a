//! oit-reference
