//! One `a2c` instance reused across frames whose targets change size rebuilds its
//! multisampled targets, and renders each frame as a fresh instance does.

use oit_gpu::testing::context_or_skip;
use oit_gpu::{ColorFormat, Context, Technique, TechniqueSpec};
use oit_scene::{LinearImage, Resolution};

fn render(
    ctx: &Context,
    technique: &mut dyn Technique,
    res: Resolution,
    format: ColorFormat,
) -> LinearImage {
    let scene = crate::kit::bundled("sorted-quads", res);
    crate::kit::render(ctx, &scene, technique, format).0
}

fn a2c() -> Box<dyn Technique> {
    TechniqueSpec::build("a2c:samples=4", &oit_stochastic::techniques()).expect("valid spec")
}

#[test]
fn a_reused_a2c_instance_follows_its_targets() {
    let Some(ctx) = context_or_skip("a2c_reuse") else {
        return;
    };
    let small = Resolution {
        width: 32,
        height: 32,
    };
    let large = Resolution {
        width: 48,
        height: 40,
    };
    let format = ColorFormat::Rgba16Float;
    let frames = [
        (small, format),
        (large, format),
        (large, format),
        (small, format),
    ];
    let mut reused = a2c();
    for (res, format) in frames {
        let image = render(&ctx, reused.as_mut(), res, format);
        let fresh = render(&ctx, a2c().as_mut(), res, format);
        assert_eq!((image.width, image.height), (res.width, res.height));
        assert!(
            image.pixels == fresh.pixels,
            "{res:?} {format:?}: the reused instance renders differently"
        );
    }
}
