//! The include syntax cannot be mistaken for WGSL. (Every WGSL file of every crate is
//! validated by `harness::shaders`, which sees all the crates.)

#[test]
fn unprocessed_includes_do_not_parse() {
    // The include syntax must be invalid WGSL, so a forgotten `compose` cannot go unnoticed.
    let raw = oit_gpu::shaders::OPAQUE;
    assert!(raw.contains("#include"));
    assert!(naga::front::wgsl::parse_str(raw).is_err());
}
