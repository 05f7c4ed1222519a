//! The counter layout this crate's WGSL and Rust both write down agrees. (Every WGSL file of
//! every crate is validated by `harness::shaders`.)

/// The counter layout is written twice (WGSL in peel_counters.wgsl, which every peel shader
/// includes, and Rust); they must agree. No shader holds a pass count: the counters are a
/// runtime-sized array the crate grows.
#[test]
fn counter_layout_matches_the_shaders() {
    let read = |file: &str| {
        oit_gpu::shaders::resolve(file, &[oit_peel::SHADERS])
            .unwrap_or_else(|| panic!("{file} in the crate's shaders"))
            .to_owned()
    };
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
