//! oit-gpu
