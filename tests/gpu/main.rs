//! Every GPU integration test of oit-lab in one test binary (as wgpu keeps its own): one link of
//! wgpu and naga instead of one per test file, and one test kit ([`kit`]). Modules follow the
//! crates they test: `gpu` (oit-gpu), `harness` (oit-harness, the comparison end to end, the
//! goldens and the shaders of every crate), and one per technique family.
//!
//! GPU tests run on whatever adapter is present; with `OIT_REQUIRE_GPU=1` (as `.ci/run` sets)
//! a missing adapter fails instead of skipping. Run one family with
//! `cargo test -p oit-tests --test gpu -- peel::`.

mod kit;

mod abuffer;
mod approximate_operators;
mod gpu;
mod harness;
mod linked_list;
mod mboit;
mod opaque_copy;
mod peel;
mod per_object;
mod sorted;
mod stochastic;
mod wavelet;
mod wboit;
