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
            "peel_counters.wgsl",
            "peel_dual.wgsl",
            "peel_front.wgsl",
            "peel_gate.wgsl",
            "peel_tail.wgsl",
            "peel_transmit.wgsl"
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

/// The counter layout is written twice (WGSL in peel_counters.wgsl, which every peel shader
/// includes, and Rust); they must agree. No shader holds a pass count: the counters are a
/// runtime-sized array the crate grows.
#[test]
fn counter_layout_matches_the_shaders() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
    let read = |file: &str| std::fs::read_to_string(dir.join(file)).expect("readable");
    let layout = read("peel_counters.wgsl");
    for needle in [
        format!(
            "COUNTER_HEADER_WORDS: u32 = {}u",
            oit_peel::COUNTER_HEADER_WORDS
        ),
        format!(
            "COUNTER_WORDS_PER_PASS: u32 = {}u",
            oit_peel::COUNTER_WORDS_PER_PASS
        ),
        "DROPPED_WORD: u32 = 0u".to_owned(),
        "return COUNTER_HEADER_WORDS + COUNTER_WORDS_PER_PASS * pass_index;".to_owned(),
        "return left_word(pass_index) + 1u;".to_owned(),
    ] {
        assert!(
            layout.contains(&needle),
            "peel_counters.wgsl lacks {needle:?}"
        );
    }
    for file in [
        "peel_common.wgsl",
        "peel_composite.wgsl",
        "peel_dual.wgsl",
        "peel_front.wgsl",
        "peel_gate.wgsl",
        "peel_tail.wgsl",
    ] {
        let text = read(file);
        // Counters are indexed only through the layout's functions, never by a literal slot.
        assert!(!text.contains("SLOT"), "{file} has a fixed counter slot");
        for (i, _) in text.match_indices("&counters[") {
            let index = &text[i + "&counters[".len()..];
            assert!(
                [
                    "left_word(",
                    "peeled_word(",
                    "DROPPED_WORD]",
                    "word]",
                    "left]"
                ]
                .iter()
                .any(|f| index.starts_with(f)),
                "{file}: counters indexed by {:?}",
                &index[..index.find(']').unwrap_or(index.len())]
            );
        }
    }
}
