//! The context's table of made objects (`oit_gpu::made`): a technique built again finds its
//! pipelines there and draws the same bits, and what the device refused is never kept.

use crate::kit;
use oit_gpu::testing::context_or_skip;
use oit_gpu::{ColorFormat, wgpu};
use oit_scene::Resolution;

const RES: Resolution = Resolution {
    width: 32,
    height: 32,
};

#[test]
fn a_technique_built_again_makes_nothing_new_and_draws_the_same_bits() {
    let Some(ctx) = context_or_skip("a_technique_built_again_makes_nothing_new") else {
        return;
    };
    let scene = kit::bundled("ops-sparks-smoke-glass", RES);
    let other = kit::bundled("sorted-quads", RES);
    for spec in [
        "dual-peel",
        "wboit",
        "linked-list",
        "mboit",
        "abuffer",
        "stochastic",
    ] {
        let (first, _, _) = kit::render_spec(&ctx, &scene, spec, ColorFormat::Rgba16Float);
        let made = ctx.made_objects();
        assert!(made > 0, "{spec}");
        // Another scene between the two builds, as a comparison has.
        kit::render_spec(&ctx, &other, spec, ColorFormat::Rgba16Float);
        let before = ctx.made_objects();
        let (again, _, _) = kit::render_spec(&ctx, &scene, spec, ColorFormat::Rgba16Float);
        assert_eq!(
            ctx.made_objects(),
            before,
            "{spec}: built again, it made new objects"
        );
        assert_eq!(
            first.pixels, again.pixels,
            "{spec}: built again, it drew other bits"
        );
    }
}

#[test]
fn a_pipeline_the_device_refused_is_never_kept() {
    let Some(ctx) = context_or_skip("a_pipeline_the_device_refused_is_never_kept") else {
        return;
    };
    let module = ctx.wgsl_module(
        "refused",
        "@vertex fn vs() -> @builtin(position) vec4<f32> { return vec4<f32>(0.0); }",
    );
    let layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[],
        immediate_size: 0,
    });
    let refused = || {
        ctx.contain("the pipeline", || {
            // No fragment entry point of that name: a validation error.
            let _ = ctx.render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("refused"),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: Default::default(),
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_missing"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::TextureFormat::Rgba8Unorm.into())],
                }),
                multiview_mask: None,
                cache: None,
            });
            Ok::<(), oit_gpu::GpuError>(())
        })
    };
    let made = ctx.made_objects();
    for attempt in 0..2 {
        let error = refused().expect_err("a refused pipeline must report its error every time");
        assert!(
            format!("{error:?}").contains("fs_missing"),
            "attempt {attempt}: {error:?}"
        );
        assert_eq!(
            ctx.made_objects(),
            made,
            "attempt {attempt}: the refused pipeline was kept"
        );
    }
}
