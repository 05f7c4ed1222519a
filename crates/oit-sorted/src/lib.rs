//! oit-sorted
