//! An adapter whose storage binding leaves room for a single pass slot: front peeling can
//! still peel one layer, dual peeling (whose init pass takes that slot) none, and says so for
//! every pass count, `auto` included.

use super::common::*;

#[test]
fn an_adapter_with_one_pass_slot_allows_one_front_layer_and_no_dual_pass() {
    let Some(ctx) = oit_gpu::testing::context_or_skip("one_pass_slot") else {
        return;
    };
    // 12 storage bytes: 1 header word and (3 − 1) / 2 = 1 pass record.
    let mut tiny = ctx.caps.clone();
    tiny.max_storage_buffer_binding_size = 12;
    tiny.max_buffer_size = 1 << 30;
    tiny.min_uniform_buffer_offset_alignment = 256;
    assert_eq!(oit_peel::max_pass_slots(&tiny).0, 1);
    assert_eq!(oit_peel::max_front_layers(&tiny), 1);
    assert_eq!(oit_peel::max_dual_passes(&tiny), 0);

    for ok in ["front-peel:layers=1", "front-peel:layers=auto"] {
        build(ok)
            .check(&tiny)
            .unwrap_or_else(|e| panic!("{ok}: {e}"));
    }
    let e = build("front-peel:layers=2")
        .check(&tiny)
        .expect_err("2 layers");
    assert!(
        e.reason.contains("layers=2") && e.reason.contains("at most 1"),
        "{e}"
    );

    for spec in [
        "dual-peel:passes=1,depth=rg32f",
        "dual-peel:passes=auto,depth=rg32f",
    ] {
        let e = build(spec).check(&tiny).expect_err(spec);
        assert!(
            e.reason.contains("allows no peel pass")
                && e.reason.contains("max_storage_buffer_binding_size"),
            "{spec}: {e}"
        );
    }
}
