//! The pass shaders as this crate builds them (common.wgsl and the tail resolved from the
//! embedded sources) parse and validate with naga, without a GPU; the tail also validates
//! appended to a foreign shader, as dual depth peeling uses it.

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
fn accumulation_and_composite_validate() {
    let code = oit_gpu::shaders::compose_with(oit_wboit::ACCUM_WGSL, &[oit_wboit::SHADERS])
        .expect("includes resolve");
    let m = validate("wboit_accum.wgsl", &code);
    let entries: Vec<&str> = m.entry_points.iter().map(|e| e.name.as_str()).collect();
    assert!(
        entries.contains(&"fs_wboit") && entries.contains(&"fs_average"),
        "{entries:?}"
    );
    let m = validate("wboit_composite.wgsl", oit_wboit::tail::COMPOSITE_WGSL);
    let entries: Vec<&str> = m.entry_points.iter().map(|e| e.name.as_str()).collect();
    assert_eq!(
        entries,
        ["vs_fullscreen", "fs_composite", "cs_count_guards"],
        "the composite's stages and the guard count"
    );
}

#[test]
fn tail_appends_to_a_foreign_pass() {
    let pass = format!(
        "{}\n@fragment\nfn fs(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {{\n    let z = wboit_view_distance_default(p.z);\n    let a = wboit_accumulate(vec3<f32>(0.5), 0.5, wboit_weight_default(z, p.z, 0.5), wboit_color_scale);\n    return a.accum + a.reveal;\n}}\n",
        oit_wboit::tail::WGSL
    );
    validate("peel pass with the tail", &pass);
}
