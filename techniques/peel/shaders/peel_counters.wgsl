// Layout of the depth-peeling counters and the per-pass index (oit-peel). The counters are one
// runtime-sized array<atomic<u32>> whose length is the pass capacity the CPU side allocates and
// grows on demand, so no pass count is fixed in any shader.
//
// counters[DROPPED_WORD]: pixels that still had layers after the last pass (the final count).
// Then one record of COUNTER_WORDS_PER_PASS words per pass i:
//   counters[left_word(i)]: pass i found something left for pass i + 1 (0 or 1);
//   counters[peeled_word(i)]: fragments pass i composited.
// Must equal oit_peel's COUNTER_HEADER_WORDS and COUNTER_WORDS_PER_PASS (a test compares them).
const COUNTER_HEADER_WORDS: u32 = 1u;
const COUNTER_WORDS_PER_PASS: u32 = 2u;
const DROPPED_WORD: u32 = 0u;

fn left_word(pass_index: u32) -> u32 {
    return COUNTER_HEADER_WORDS + COUNTER_WORDS_PER_PASS * pass_index;
}

fn peeled_word(pass_index: u32) -> u32 {
    return left_word(pass_index) + 1u;
}

// The pass index, one 16-byte record per pass selected by a dynamic uniform offset.
struct PassInfo {
    index: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}
