// Exclusive prefix sum of a u32 array in place, one level of a reduce-then-scan: each workgroup
// scans a block of BLOCK values in workgroup memory (Hillis–Steele) and writes the block's total
// to `sums`; the caller scans `sums` the same way (one level per 256× fewer values) and adds
// each block's scanned total back with `cs_add_block_sums`. No inter-workgroup communication,
// so it needs no forward-progress guarantee (lavapipe gives none). CPU twin:
// `oit_abuffer::scan::exclusive_scan`, whose levels mirror these passes.

const BLOCK: u32 = 256u;

struct ScanParams {
    // Values at this level.
    len: u32,
    // Workgroups per row of the dispatch (a grid past 65 535 blocks wraps into rows).
    groups_x: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> params: ScanParams;
@group(0) @binding(1) var<storage, read_write> values: array<u32>;
@group(0) @binding(2) var<storage, read_write> sums: array<u32>;

var<workgroup> block: array<u32, BLOCK>;

fn block_of(group: vec3<u32>) -> u32 {
    return group.y * params.groups_x + group.x;
}

@compute @workgroup_size(256)
fn cs_scan_blocks(
    @builtin(local_invocation_index) lane: u32,
    @builtin(workgroup_id) group: vec3<u32>,
) {
    let b = block_of(group);
    let i = b * BLOCK + lane;
    var x = 0u;
    if i < params.len {
        x = values[i];
    }
    block[lane] = x;
    workgroupBarrier();
    // Inclusive scan: after the step of width d, block[l] sums the 2d values ending at l.
    for (var d = 1u; d < BLOCK; d = d << 1u) {
        var y = 0u;
        if lane >= d {
            y = block[lane - d];
        }
        workgroupBarrier();
        block[lane] += y;
        workgroupBarrier();
    }
    if i < params.len {
        values[i] = block[lane] - x;
    }
    if lane == BLOCK - 1u && b * BLOCK < params.len {
        sums[b] = block[lane];
    }
}

@compute @workgroup_size(256)
fn cs_add_block_sums(
    @builtin(local_invocation_index) lane: u32,
    @builtin(workgroup_id) group: vec3<u32>,
) {
    let b = block_of(group);
    let i = b * BLOCK + lane;
    if i < params.len {
        values[i] += sums[b];
    }
}
