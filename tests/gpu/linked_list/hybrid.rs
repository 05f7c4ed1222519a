//! `hybrid` (the k-buffer's K slots as the exact core, the tail weighted by WBOIT's `range`
//! weight): its shader weight equals the CPU twin, `weight=equal` is the k-buffer's averaged
//! tail bit for bit, with no tail it is the k-buffer, and on the deep scenes the weighted tail
//! is measured against the average at equal K.

use oit_gpu::testing::{context_or_skip, eval_f32_with, uniform_buffer};
use oit_gpu::{ColorFormat, Context};
use oit_linked_list::kbuffer;
use oit_scene::Resolution;

const RES: Resolution = Resolution {
    width: 128,
    height: 128,
};

fn context() -> Option<Context> {
    let ctx = context_or_skip("hybrid")?;
    if !ctx.caps.int64_atomics {
        assert_ne!(
            ctx.caps.backend,
            oit_gpu::wgpu::Backend::Vulkan,
            "Vulkan adapter without 64-bit atomics"
        );
        eprintln!("skipped hybrid: no 64-bit atomics on this adapter");
        return None;
    }
    Some(ctx)
}

#[test]
fn tail_weight_on_the_gpu_equals_its_cpu_twin() {
    let Some(ctx) = context() else {
        return;
    };
    let source =
        oit_gpu::shaders::compose_with(kbuffer::KBUFFER64_WGSL, oit_linked_list::FAMILY.shaders)
            .expect("includes resolve");
    let mut worst = 0.0f64;
    for name in ["many-layers-64", "particles", "depth-range"] {
        let scene = crate::kit::bundled(name, RES);
        let range = oit_wboit::RangeParams::of(&scene);
        let camera = &scene.camera;
        let (a, b, ortho) = camera.view_depth_terms();
        let words = [
            128u32,
            4,
            u32::from(camera.reverse_z),
            2,
            range.z_near.to_bits(),
            range.z_far.to_bits(),
            range.fall.to_bits(),
            range.color_scale.to_bits(),
            a.to_bits(),
            b.to_bits(),
            u32::from(ortho),
            0,
        ];
        let uniform = uniform_buffer(&ctx, bytemuck::cast_slice(&words));
        let group1 = [oit_gpu::wgpu::BindGroupEntry {
            binding: 0,
            resource: uniform.as_entire_binding(),
        }];
        // Window depths across the scene's transparent interval and beyond it.
        let inputs: Vec<[f32; 4]> = (0..=64)
            .map(|i| [0.5, 0.25, 0.125, 0.5 + 0.5 * (i as f32 / 64.0).powi(3)])
            .collect();
        let gpu = eval_f32_with(
            &ctx,
            &source,
            "tail_weight(to_slot(x.xyz, 0.5, x.w))",
            &inputs,
            &group1,
            &[],
        )
        .expect("kernel runs");
        for (x, g) in inputs.iter().zip(&gpu) {
            let slot = kbuffer::to_slot([x[0], x[1], x[2]], 0.5, x[3], camera.reverse_z);
            let cpu = kbuffer::tail_weight(slot, &range, camera);
            let relative = f64::from((g - cpu).abs() / cpu.abs().max(1e-6));
            worst = worst.max(relative);
            assert!(relative < 1e-4, "{name} z {}: GPU {g} CPU {cpu}", x[3]);
        }
    }
    println!("tail weight: worst relative difference {worst:.1e}");
}

/// `weight=equal` renders exactly what `k-buffer:tail=average` renders, and with K slots for
/// every layer (no tail) the range weight changes nothing either.
#[test]
fn equal_weight_and_no_tail_are_the_kbuffer_bit_for_bit() {
    let Some(ctx) = context() else {
        return;
    };
    for (name, hybrid, kbuffer) in [
        ("many-layers-64", "hybrid:k=4,weight=equal", "k-buffer:k=4"),
        ("particles", "hybrid:k=2,weight=equal", "k-buffer:k=2"),
        ("sorted-quads", "hybrid:k=8", "k-buffer:k=8"),
    ] {
        let scene = crate::kit::bundled(name, RES);
        let (a, frame, memory) =
            crate::kit::render_spec(&ctx, &scene, hybrid, ColorFormat::Rgba16Float);
        let (b, kframe, kmemory) =
            crate::kit::render_spec(&ctx, &scene, kbuffer, ColorFormat::Rgba16Float);
        assert_eq!(
            crate::kit::max_abs_rgb(&a, &b),
            0.0,
            "{name}: {hybrid} vs {kbuffer}"
        );
        assert_eq!(frame.stats, kframe.stats, "{name}");
        assert_eq!(memory, kmemory, "{name}");
    }
}

/// The deep scenes, K = 1, 2, 4, 8: RMSE of the range-weighted tail against the k-buffer's
/// average at equal K. Where the tail is used (the k-buffer averages on some pixels), the
/// weighted tail is closer to the reference on `many-layers-64` (measured 2026-12-07 on
/// lavapipe: 4.3–5.5× lower), `particles` (1.06–1.6×) and `opaque-interleaved` (5.4–46×),
/// and on `faint-haze` (128 faint layers, colour barely changing with depth) 1.05–1.06×
/// *higher*: there the range weight's assumed fall of transmittance with depth is steeper
/// than the haze's, and no weight gains much over the average. Held to: lower on the first
/// three, within 1.1× on `faint-haze`.
#[test]
fn range_weighted_tail_beats_the_average_at_equal_k_on_the_deep_scenes() {
    let Some(ctx) = context() else {
        return;
    };
    let mut table = String::from("scene                 K  k-buffer average   hybrid range\n");
    let mut failures = Vec::new();
    for name in [
        "many-layers-64",
        "faint-haze",
        "particles",
        "opaque-interleaved",
    ] {
        let scene = crate::kit::bundled(name, RES);
        let reference = oit_reference::render(&scene, &Default::default());
        for k in [1, 2, 4, 8] {
            let (average, frame, _) = crate::kit::render_spec(
                &ctx,
                &scene,
                &format!("k-buffer:k={k}"),
                ColorFormat::Rgba16Float,
            );
            let (weighted, hframe, _) = crate::kit::render_spec(
                &ctx,
                &scene,
                &format!("hybrid:k={k}"),
                ColorFormat::Rgba16Float,
            );
            let a = oit_metrics::compare(&average, &reference.image).expect("compare");
            let h = oit_metrics::compare(&weighted, &reference.image).expect("compare");
            assert_eq!(
                frame.stats.pixels_with_approximated_layers,
                hframe.stats.pixels_with_approximated_layers,
                "{name} k {k}: the same pixels have a tail"
            );
            table += &format!(
                "{name:20} {k:2}  {:.4e} / {:.3}   {:.4e} / {:.3}\n",
                a.rmse, a.max_abs, h.rmse, h.max_abs
            );
            let allowed = if name == "faint-haze" {
                1.1 * a.rmse
            } else {
                a.rmse
            };
            if frame.stats.pixels_with_approximated_layers > 0 && h.rmse >= allowed {
                failures.push(format!(
                    "{name} k {k}: hybrid RMSE {:.4e}, the average's {:.4e}",
                    h.rmse, a.rmse
                ));
            }
        }
    }
    println!("RMSE / max error at 128², lavapipe:\n{table}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
