//! The node encodings of shaders/linked_list_node.wgsl against their CPU twin
//! (`oit_linked_list::node`), on the GPU: `pack_node` in both formats, scalar and rgb-opacity
//! (`TRANSMIT`), both depth directions, and
//! `pack_rgb9e5`, word for word, over colours from 0 through HDR to beyond the rgb9e5 range,
//! coverages at the unorm8 rounding edges and depths across [0, 1]; and the k-buffer's 64-bit
//! slot (`to_slot` of shaders/kbuffer64.wgsl against `kbuffer::to_slot`), as its two words.
//! cargo-mutants does not mutate WGSL: a constant changed on one side only fails here.

use oit_gpu::testing::{context_or_skip, eval_f32, eval_f32_with, eval_u32, uniform_buffer};
use oit_linked_list::kbuffer;
use oit_linked_list::node::{self, NodeFormat};

const NODE_WGSL: &str = oit_linked_list::NODE_WGSL;

/// One 16-bit half of a u32 result, exactly representable as f32 (no NaN bit patterns).
fn halves(expr: &str) -> [String; 2] {
    [
        format!("f32(({expr}) & 0xffffu)"),
        format!("f32(({expr}) >> 16u)"),
    ]
}

fn run_words(
    ctx: &oit_gpu::Context,
    expr: &str,
    inputs: &[[f32; 4]],
    constants: &[(&str, f64)],
) -> Vec<u32> {
    let [lo, hi] = halves(expr);
    let lo = eval_f32(ctx, NODE_WGSL, &lo, inputs, None, constants).expect("kernel runs");
    let hi = eval_f32(ctx, NODE_WGSL, &hi, inputs, None, constants).expect("kernel runs");
    lo.iter()
        .zip(&hi)
        .map(|(l, h)| *l as u32 | ((*h as u32) << 16))
        .collect()
}

fn inputs() -> Vec<[f32; 4]> {
    let channels = [
        0.0, 1e-6, 0.003, 0.25, 0.5, 0.999, 1.0, 3.7, 250.0, 65408.0, 1e6,
    ];
    let depths = [0.0, 1e-7, 0.1, 0.333_333_3, 0.5, 0.9, 0.999_999, 1.0];
    let mut out = Vec::new();
    for (i, &r) in channels.iter().enumerate() {
        for &g in &channels[i % 3..] {
            let b = channels[(i * 7 + 3) % channels.len()];
            for &z in &depths {
                out.push([r, g, b, z]);
            }
        }
    }
    out
}

#[test]
fn pack_node_on_the_gpu_equals_its_cpu_twin_word_for_word() {
    let Some(ctx) = context_or_skip("linked_list_node_twins") else {
        return;
    };
    let inputs = inputs();
    let mut failures = Vec::new();
    for format in [NodeFormat::F32, NodeFormat::Packed] {
        for transmit in [false, true] {
            let constants = [
                ("PACKED", f64::from(u8::from(format == NodeFormat::Packed))),
                ("TRANSMIT", f64::from(u8::from(transmit))),
            ];
            for reverse_z in [false, true] {
                // 0.5/255 and 1.5/255 sit on unorm8 rounding edges, 0.5/1023 on a unorm10 one.
                for alpha in [0.0f32, 0.5 / 255.0, 1.5 / 255.0, 0.37, 0.5, 1.0] {
                    // Per-channel opacity (used by transmit nodes): three different values.
                    let opacity = [alpha, 1.0 - alpha, 0.5 / 1023.0 + alpha * 0.25];
                    let call = format!(
                        "pack_node(x.xyz, {alpha:?}, vec3<f32>({:?}, {:?}, {:?}), x.w, {reverse_z})",
                        opacity[0], opacity[1], opacity[2]
                    );
                    let words = ["key", "c0", "c1", "c2"]
                        .map(|w| run_words(&ctx, &format!("{call}.{w}"), &inputs, &constants));
                    for (i, x) in inputs.iter().enumerate() {
                        let cpu = node::pack_node(
                            format,
                            transmit,
                            [x[0], x[1], x[2]],
                            alpha,
                            opacity,
                            x[3],
                            reverse_z,
                        );
                        let gpu = words.each_ref().map(|w| w[i]);
                        let cpu = [cpu.key, cpu.c0, cpu.c1, cpu.c2];
                        if gpu != cpu {
                            failures.push(format!(
                                "{format:?} transmit {transmit} reverse_z {reverse_z} α {alpha} colour {:?} z {}: GPU {gpu:08x?} CPU {cpu:08x?}",
                                &x[..3],
                                x[3],
                            ));
                        }
                    }
                }
            }
        }
    }
    let count = failures.len();
    failures.truncate(20);
    assert!(
        failures.is_empty(),
        "{count} mismatches:\n{}",
        failures.join("\n")
    );
}

#[test]
fn rgb9e5_on_the_gpu_equals_its_cpu_twin() {
    let Some(ctx) = context_or_skip("rgb9e5_twin") else {
        return;
    };
    let inputs = inputs();
    let gpu = run_words(&ctx, "pack_rgb9e5(x.xyz)", &inputs, &[]);
    for (x, g) in inputs.iter().zip(&gpu) {
        assert_eq!(
            *g,
            node::pack_rgb9e5([x[0], x[1], x[2]]),
            "colour {:?}",
            &x[..3]
        );
    }
    // And back: unpack of the packed words (exact f32 values on both sides).
    for channel in 0..3 {
        let expr = format!("unpack_rgb9e5(pack_rgb9e5(x.xyz))[{channel}]");
        let gpu = eval_f32(&ctx, NODE_WGSL, &expr, &inputs, None, &[]).expect("kernel runs");
        for (x, g) in inputs.iter().zip(&gpu) {
            let cpu = node::unpack_rgb9e5(node::pack_rgb9e5([x[0], x[1], x[2]]))[channel];
            assert_eq!(
                g.to_bits(),
                cpu.to_bits(),
                "colour {:?} channel {channel}",
                &x[..3]
            );
        }
    }
}

/// kbuffer64.wgsl with its includes, as the k-buffer pass composes it.
fn kbuffer_source() -> String {
    oit_gpu::shaders::compose_with(kbuffer::KBUFFER64_WGSL, oit_linked_list::FAMILY.shaders)
        .expect("includes resolve")
}

/// Depths for the slot's nearness key: both ends (z = 0 and 1, the far plane under either
/// convention, where the nearness is 0 or 1), the first values off them, the exactness edge at
/// 0.5 (1 − z is exact for z ≥ 0.5) and its neighbours, and steps that differ only below the
/// 2^-15 truncation.
const SLOT_DEPTHS: [f32; 13] = [
    0.0,
    1e-30,
    1e-7,
    0.1,
    0.1 + 1e-8,
    0.333_333_3,
    0.499_999_97,
    0.5,
    0.500_000_06,
    0.75,
    0.9,
    0.999_999_94,
    1.0,
];

#[test]
fn kbuffer_slots_on_the_gpu_equal_their_cpu_twin_word_for_word() {
    let Some(ctx) = context_or_skip("kbuffer_slot_twin") else {
        return;
    };
    if !ctx.caps.int64_atomics {
        // kbuffer64.wgsl declares its u64 atomics, which need the feature to compile at all.
        assert_ne!(
            ctx.caps.backend,
            oit_gpu::wgpu::Backend::Vulkan,
            "Vulkan adapter without 64-bit atomics"
        );
        eprintln!("skipped kbuffer_slot_twin: no 64-bit atomics on this adapter");
        return;
    }
    let source = kbuffer_source();
    let channels = [0.0, 1e-6, 0.003, 0.25, 0.5, 1.0, 3.7, 250.0, 65408.0, 1e6];
    let mut inputs = Vec::new();
    for (i, &r) in channels.iter().enumerate() {
        let g = channels[(i * 3 + 1) % channels.len()];
        let b = channels[(i * 7 + 5) % channels.len()];
        for &z in &SLOT_DEPTHS {
            inputs.push([r, g, b, z]);
        }
    }
    let mut failures = Vec::new();
    let mut worst_alpha_ulps = 0u32;
    for reverse_z in [false, true] {
        // `KParams`: width, k, reverse_z, tail, then the hybrid's weight inputs (unused at
        // tail 1; colour scale 1).
        let words = [
            64u32,
            8,
            u32::from(reverse_z),
            1,
            0,
            1f32.to_bits(),
            0,
            1f32.to_bits(),
            0,
            0,
            0,
            0,
        ];
        let uniform = uniform_buffer(&ctx, bytemuck::cast_slice(&words));
        let group1 = [oit_gpu::wgpu::BindGroupEntry {
            binding: 0,
            resource: uniform.as_entire_binding(),
        }];
        // 0.5/255 and 1.5/255 sit on unorm8 rounding edges; -0.25 and 1.5 are clamped.
        for alpha in [-0.25f32, 0.0, 0.5 / 255.0, 1.5 / 255.0, 0.37, 1.0, 1.5] {
            let slot = format!("to_slot(x.xyz, {alpha:?}, x.w)");
            let run = |expr: String| {
                eval_u32(&ctx, &source, &expr, &inputs, &group1, &[]).expect("kernel runs")
            };
            let hi = run(format!("u32({slot} >> 32u)"));
            let lo = run(format!("u32({slot} & 0xFFFFFFFFlu)"));
            // And back: the α the resolve reads from the slot.
            let back = eval_f32_with(
                &ctx,
                &source,
                &format!("from_slot({slot}).opacity.x"),
                &inputs,
                &group1,
                &[],
            )
            .expect("kernel runs");
            for (i, x) in inputs.iter().enumerate() {
                let cpu = kbuffer::to_slot([x[0], x[1], x[2]], alpha, x[3], reverse_z);
                let gpu = (u64::from(hi[i]) << 32) | u64::from(lo[i]);
                if gpu != cpu {
                    failures.push(format!(
                        "reverse_z {reverse_z} α {alpha} colour {:?} z {}: GPU {gpu:016x} CPU {cpu:016x}",
                        &x[..3],
                        x[3]
                    ));
                }
                let a = kbuffer::from_slot(cpu).opacity[0];
                worst_alpha_ulps = worst_alpha_ulps.max(a.to_bits().abs_diff(back[i].to_bits()));
            }
        }
    }
    println!("from_slot α: worst {worst_alpha_ulps} ulp from the twin");
    // q/255 on the GPU: division is allowed 2.5 ulp in Vulkan (exact on lavapipe).
    assert!(
        worst_alpha_ulps <= 3,
        "from_slot α off by {worst_alpha_ulps} ulp"
    );
    let count = failures.len();
    failures.truncate(20);
    assert!(
        failures.is_empty(),
        "{count} mismatches:\n{}",
        failures.join("\n")
    );
}
