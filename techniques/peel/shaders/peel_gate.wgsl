// Compute passes of depth peeling: the GPU-side termination gate and the final dropped-layer
// counts. The gate turns the counter "pass i found something left" into the instance count of
// every indirect draw of pass i + 1, so a pass with nothing to peel costs no rasterization and
// the CPU never waits for the answer.

#include "peel_counters.wgsl"

// Read by the dual-peel count: keys are in [0, 1], EMPTY is -2.
const EMPTY_BELOW: f32 = -1.5;

struct Grid {
    width: u32,
    height: u32,
    draws: u32,
    pad0: u32,
}

// wgpu::util::DrawIndexedIndirectArgs per draw: index_count, instance_count, first_index,
// base_vertex, first_instance (oit_gpu::GpuScene::indirect_args).
@group(0) @binding(1) var<storage, read_write> args: array<u32>;
@group(0) @binding(2) var<uniform> grid: Grid;
// Dual: the last range target. Front: the detection pass's layer texture.
@group(0) @binding(3) var last_range: texture_2d<f32>;
// The pass group (oit-peel's Control).
@group(1) @binding(0) var<uniform> pass_info: PassInfo;
@group(1) @binding(1) var<storage, read_write> counters: array<atomic<u32>>;

@compute @workgroup_size(64)
fn cs_gate(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x < grid.draws {
        args[id.x * 5u + 1u] = atomicLoad(&counters[left_word(pass_info.index)]);
    }
}

// The scans after a pass: whether it left anything for the next pass (`left_word`) and how many
// fragments it composited (`peeled_word`), read from the textures the pass wrote, so that the
// pass's fragment stages make no atomic access (on lavapipe those took 40 % of a dual peel
// pass). Each invocation reads a SCAN_BLOCK² block of pixels; each workgroup adds once to the
// counters.
const SCAN_BLOCK: u32 = 4u;
var<workgroup> group_left: atomic<u32>;
var<workgroup> group_peeled: atomic<u32>;

fn scan_begin(local: u32) {
    if local == 0u {
        atomicStore(&group_left, 0u);
        atomicStore(&group_peeled, 0u);
    }
    workgroupBarrier();
}

// Pixel `k` (0 ≤ k < SCAN_BLOCK²) of invocation `id`'s block.
fn block_pixel(id: vec3<u32>, k: u32) -> vec2<u32> {
    return id.xy * SCAN_BLOCK + vec2<u32>(k % SCAN_BLOCK, k / SCAN_BLOCK);
}

fn scan_end(local: u32, left: bool, peeled: u32) {
    if left {
        atomicStore(&group_left, 1u);
    }
    if peeled != 0u {
        atomicAdd(&group_peeled, peeled);
    }
    workgroupBarrier();
    if local == 0u {
        if atomicLoad(&group_left) != 0u {
            atomicStore(&counters[left_word(pass_info.index)], 1u);
        }
        let n = atomicLoad(&group_peeled);
        if n != 0u {
            atomicAdd(&counters[peeled_word(pass_info.index)], n);
        }
    }
}

// Dual peeling, after pass `pass_info.index` (the init pass is 0): the range it wrote (anything
// inside is left for the next pass) and its per-pixel peeled count (0 where the fragments
// counted themselves).
@group(0) @binding(4) var peeled_count: texture_2d<f32>;

@compute @workgroup_size(8, 8)
fn cs_scan_range(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    scan_begin(local);
    let size = textureDimensions(last_range);
    var left = false;
    var peeled = 0u;
    for (var k = 0u; k < SCAN_BLOCK * SCAN_BLOCK; k++) {
        let p = block_pixel(id, k);
        if all(p < size) {
            let at = vec2<i32>(p);
            left = left || textureLoad(last_range, at, 0).x > EMPTY_BELOW;
            // A per-pixel count of one pass: an exact integer in f32.
            peeled += u32(textureLoad(peeled_count, at, 0).x);
        }
    }
    scan_end(local, left, peeled);
}

// Front peeling, after layer pass `pass_info.index`: its layer texture (alpha −1 where it found
// none). A pixel with a layer composited one fragment and may have another behind it.
@compute @workgroup_size(8, 8)
fn cs_scan_layer(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    scan_begin(local);
    let size = textureDimensions(last_range);
    var peeled = 0u;
    for (var k = 0u; k < SCAN_BLOCK * SCAN_BLOCK; k++) {
        let p = block_pixel(id, k);
        if all(p < size) && textureLoad(last_range, vec2<i32>(p), 0).a >= 0.0 {
            peeled += 1u;
        }
    }
    scan_end(local, peeled != 0u, peeled);
}

// Dual peeling: pixels whose range after the last pass still holds fragments.
@compute @workgroup_size(8, 8)
fn cs_count_range(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x < grid.width && id.y < grid.height {
        let r = textureLoad(last_range, vec2<i32>(id.xy), 0).x;
        if r > EMPTY_BELOW {
            atomicAdd(&counters[DROPPED_WORD], 1u);
        }
    }
}

// Front peeling: pixels where the detection pass after the last layer found another layer
// (the layer texture's alpha is -1 where it found none).
@compute @workgroup_size(8, 8)
fn cs_count_layer(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x < grid.width && id.y < grid.height {
        if textureLoad(last_range, vec2<i32>(id.xy), 0).a >= 0.0 {
            atomicAdd(&counters[DROPPED_WORD], 1u);
        }
    }
}
