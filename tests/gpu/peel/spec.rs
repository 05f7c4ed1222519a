//! Registry entries, canonical specs and errors (no GPU).

use oit_gpu::{SpecError, TechniqueSpec};
use oit_peel::{
    AccumFormat, DepthFormat, DualPeel, DualPeelConfig, FrontPeel, FrontPeelConfig, PassCount, Tail,
};

#[test]
fn registry_entries_are_valid_and_canonical() {
    let registry = oit_peel::techniques();
    for info in &registry {
        info.validate().unwrap();
    }
    let dual = TechniqueSpec::parse("dual-peel", &registry).unwrap();
    assert_eq!(
        dual.to_string(),
        "dual-peel:accum=auto,depth=auto,encoding=window,passes=5,reverse-z=on,tail=drop"
    );
    assert_eq!(
        DualPeelConfig::from_spec(&dual).unwrap(),
        DualPeelConfig::default()
    );
    let t = TechniqueSpec::build(
        "dual-peel:passes=auto,tail=wboit,depth=rg16f,encoding=log,reverse-z=off",
        &registry,
    )
    .unwrap();
    assert_eq!(
        t.spec().to_string(),
        "dual-peel:accum=auto,depth=rg16f,encoding=log,passes=auto,reverse-z=off,tail=wboit"
    );
    let c = DualPeelConfig::from_spec(&t.spec()).unwrap();
    assert_eq!(
        (c.passes, c.depth, c.tail, c.reverse_z),
        (PassCount::Auto, DepthFormat::Rg16f, Tail::Wboit, false)
    );
    let rgba8 = TechniqueSpec::build("dual-peel:accum=rgba8", &registry).unwrap();
    assert_eq!(
        DualPeelConfig::from_spec(&rgba8.spec()).unwrap().accum,
        AccumFormat::Rgba8
    );
    // Only the float accumulators at least as precise as f32 are exact; the others say why.
    assert_eq!(AccumFormat::Auto.rounding(), None);
    assert_eq!(AccumFormat::Rgba32f.rounding(), None);
    assert!(
        AccumFormat::Rgba16f
            .rounding()
            .unwrap()
            .contains("binary16")
    );
    assert!(AccumFormat::Rgba8.rounding().unwrap().contains("1/255"));
    let front = TechniqueSpec::build("front-peel:layers=12", &registry).unwrap();
    assert_eq!(front.spec().to_string(), "front-peel:layers=12");
    assert_eq!(
        FrontPeelConfig::from_spec(&front.spec()).unwrap().layers,
        PassCount::Fixed(oit_peel::Passes::of(12))
    );
    // No fixed cap below the adapter's bound: counts past the old 64 / 128 parse.
    for big in [
        "dual-peel:passes=65",
        "front-peel:layers=129",
        "front-peel:layers=100000",
    ] {
        TechniqueSpec::parse(big, &registry).unwrap_or_else(|e| panic!("{big}: {e}"));
    }
    for bad in [
        "dual-peel:passes=0",
        "dual-peel:passes=4294967296",
        "dual-peel:depth=r32f",
        "front-peel:layers=0",
        "front-peel:layers=-1",
        "dual-peel:tail=sort",
        "dual-peel:accum=rgba4",
    ] {
        let e = TechniqueSpec::parse(bad, &registry).unwrap_err();
        assert!(e.to_string().contains("allowed"), "{bad}: {e}");
    }
}

#[test]
fn hand_built_bad_specs_are_refused_at_construction() {
    // A parameter missing from a spec built by hand: named with what is allowed. (A value
    // out of range cannot be written into a spec: its parameters are typed.)
    let spec = TechniqueSpec::of("dual-peel")
        .with(
            &DualPeelConfig::PASSES,
            PassCount::Fixed(oit_peel::Passes::of(3)),
        )
        .with(&DualPeelConfig::REVERSE_Z, oit_peel::ReverseZ::On)
        .with(&DualPeelConfig::TAIL, Tail::Drop)
        .with(&DualPeelConfig::ENCODING, oit_peel::DepthEncoding::Window);
    let e = DualPeelConfig::from_spec(&spec).unwrap_err();
    assert!(
        matches!(&e, SpecError::Missing { key, .. } if key == "depth"),
        "{e}"
    );
    assert!(e.to_string().contains("auto, rg32f, rg16f"), "{e}");
    let e = DualPeel::from_spec(&spec).unwrap_err();
    assert!(
        matches!(&e, SpecError::Missing { key, .. } if key == "depth"),
        "{e}"
    );
    let e = FrontPeelConfig::from_spec(&spec).unwrap_err();
    assert!(matches!(e, SpecError::WrongTechnique { .. }), "{e}");
    // The registry's build refuses the same spec instead of building a broken technique.
    let info = &oit_peel::techniques()[1];
    assert_eq!(info.name, "dual-peel");
    assert!((info.build)(&spec).is_err());
    let front = TechniqueSpec::parse("front-peel:layers=4", &oit_peel::techniques()).unwrap();
    assert_eq!(
        FrontPeel::from_spec(&front).unwrap().config().layers,
        PassCount::Fixed(oit_peel::Passes::of(4))
    );
}
