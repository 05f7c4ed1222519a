//! The pass shaders as this crate builds them (common.wgsl and the math resolved from the
//! embedded sources) parse and validate with naga, without a GPU.

fn validate(name: &str, code: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(code)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(code)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(code)));
    module
}

#[test]
fn passes_and_composite_validate() {
    let code = oit_gpu::shaders::compose_with(oit_mboit::ACCUM_WGSL, &[oit_mboit::SHADERS])
        .expect("includes resolve");
    let m = validate("mboit_accum.wgsl", &code);
    let entries: Vec<&str> = m.entry_points.iter().map(|e| e.name.as_str()).collect();
    assert!(
        entries.contains(&"fs_moments") && entries.contains(&"fs_resolve"),
        "{entries:?}"
    );
    let m = validate("mboit_composite.wgsl", oit_mboit::COMPOSITE_WGSL);
    assert_eq!(m.entry_points.len(), 2);
    // The math stands alone (no bindings, no includes) and shares its constants with the CPU.
    assert!(!oit_mboit::MATH_WGSL.contains("@group") && !oit_mboit::MATH_WGSL.contains("#include"));
    validate("mboit_math.wgsl", oit_mboit::MATH_WGSL);
    for (name, value) in [
        ("MBOIT_MAX_ABSORBANCE", oit_mboit::math::MAX_ABSORBANCE),
        (
            "MBOIT_MAX_TRANSMITTANCE",
            oit_mboit::math::MAX_TRANSMITTANCE,
        ),
        ("MBOIT_MIN_B0", oit_mboit::math::MIN_B0),
    ] {
        let line = oit_mboit::MATH_WGSL
            .lines()
            .find(|l| l.starts_with(&format!("const {name}: f32 = ")))
            .unwrap_or_else(|| panic!("{name} missing"));
        let v: f32 = line
            .rsplit(' ')
            .next()
            .unwrap()
            .trim_end_matches(';')
            .parse()
            .unwrap();
        assert_eq!(v, value, "{name}");
    }
}
