//! `GuardCounts`' text form names every counter with its own value (no GPU).

use oit_wboit::{GUARD_SLOTS, GuardCounts};

#[test]
fn display_names_every_counter_with_its_value() {
    // Distinct values per counter, so a counter printed under another's name shows; the lines
    // that `pixels` and `covered` are spread over stay 0 (their sums have a test of their own).
    let slots: Vec<u32> = (0..GUARD_SLOTS)
        .map(|i| if i < 8 { 10 + i } else { 0 })
        .collect();
    let g = GuardCounts::from_slots(&slots);
    assert_eq!(
        g.to_string(),
        "pixels 10 covered 11 accum_overflow 12 zero_weight 13 average_clamped 14 \
         reveal_clamped 15 reveal_lost 16 opaque 17"
    );
    assert_eq!(
        GuardCounts::default().to_string(),
        "pixels 0 covered 0 accum_overflow 0 zero_weight 0 average_clamped 0 reveal_clamped 0 \
         reveal_lost 0 opaque 0"
    );
}
