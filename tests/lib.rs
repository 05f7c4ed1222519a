//! oit-tests has no library code: its one test binary is `gpu/main.rs`.
