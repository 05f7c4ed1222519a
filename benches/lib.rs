//! Benchmarks live in benches/; see benches/README.md.

pub mod gpu_time;
