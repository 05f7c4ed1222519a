//! The sweep bound is inclusive: a sweep of exactly `MAX_SWEEP_SPECS` specs resolves, one more
//! value is refused (no GPU).

use oit_harness::{MAX_SWEEP_SPECS, resolve_specs};

#[test]
fn a_sweep_of_exactly_the_maximum_resolves_and_one_more_is_refused() {
    // 32 × 128 = 4096 linked-list specs, every one distinct.
    let at_max = "linked-list:nodes-per-pixel=1..32,sort-max=1..128".to_string();
    let specs = resolve_specs(&[at_max]).unwrap();
    assert_eq!(specs.len() as u64, MAX_SWEEP_SPECS);
    assert_eq!(specs.last().unwrap().get("nodes-per-pixel"), Some("32"));
    // 33 × 128 = 4224.
    let err = resolve_specs(&["linked-list:nodes-per-pixel=1..33,sort-max=1..128".to_string()])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("4224") && err.contains("at most 4096"),
        "{err}"
    );
}
