//! This crate's WGSL (shaders/peel_*.wgsl) parses and validates with naga after include
//! expansion, with no GPU; includes resolve from the files on disk.

use std::path::{Path, PathBuf};

#[test]
fn peel_shaders_validate() {
    let dir: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
    let resolve = |name: &str| std::fs::read_to_string(dir.join(name)).ok();
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("shaders/ exists")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with("peel_") && n.ends_with(".wgsl"))
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "peel_common.wgsl",
            "peel_composite.wgsl",
            "peel_dual.wgsl",
            "peel_front.wgsl",
            "peel_gate.wgsl",
            "peel_tail.wgsl"
        ]
    );
    for name in &names {
        let source = resolve(name).expect("readable");
        let code =
            oit_gpu::shaders::compose(&source, &resolve).unwrap_or_else(|e| panic!("{name}: {e}"));
        let module = naga::front::wgsl::parse_str(&code)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&code)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&code)));
    }
}

/// The counter layout is written twice (WGSL constants and Rust); they must agree.
#[test]
fn counter_layout_matches_the_shaders() {
    let slots = oit_peel::COUNTER_SLOTS;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
    for (file, needles) in [
        (
            "peel_common.wgsl",
            vec![
                format!("COUNTER_SLOTS: u32 = {slots}u"),
                format!("PEELED_BASE: u32 = {slots}u"),
                format!("DROPPED_SLOT: u32 = {}u", 2 * slots),
            ],
        ),
        (
            "peel_composite.wgsl",
            vec![format!("PEELED_BASE: u32 = {slots}u")],
        ),
        (
            "peel_gate.wgsl",
            vec![
                format!("COUNTER_SLOTS: u32 = {slots}u"),
                format!("DROPPED_SLOT: u32 = {}u", 2 * slots),
            ],
        ),
    ] {
        let text = std::fs::read_to_string(dir.join(file)).expect("readable");
        for n in needles {
            assert!(text.contains(&n), "{file} lacks {n:?}");
        }
    }
}
