//! A run's `counts` (docs/results-schema.md, "counts"): one more frame, after the timed ones,
//! with an occlusion query around every render pass, priced by what the technique states per
//! pass ([`oit_gpu::Technique::work`]).
//!
//! Counted in a frame of its own, not in the timed frames: the timed frames stay as they were
//! before counting existed (their numbers comparable with older results), and an occlusion
//! query costs something on some adapters (lavapipe counts per lane of every depth-tested
//! quad). It follows the timed frames directly (before the reversed-order frame), so a
//! technique that sizes its passes from the previous frame (front-peel's remembered pass count)
//! records the timed frames' passes; every technique renders the same work in every frame of a
//! still scene, so the counted frame's work is the timed frames'. A pass the GPU skips (a
//! gated peel pass past the last layer) is recorded and counts its triangles, with 0 samples.

use oit_gpu::work::{PassDraws, PassWork, Work};
use oit_gpu::{Context, GpuScene, GpuTimer, PassFragments, Targets, Technique, render_frame};
use oit_results::{PassCounts, RunCounts};

use crate::HarnessError;

/// Renders one counted frame of `technique` (within what is left of the run's budget until
/// `deadline`) and prices it; `None` on a backend whose occlusion queries do not count
/// ([`oit_gpu::occlusion_counts_samples`]: wgpu's GL, DX12 and Metal answer 0 or 1). The
/// counts of the same scene, technique and resolution from a Vulkan adapter apply there too.
pub(crate) fn frame(
    ctx: &Context,
    scene: &GpuScene,
    technique: &mut dyn Technique,
    targets: &Targets,
    deadline: std::time::Instant,
) -> Result<Option<RunCounts>, HarnessError> {
    if !oit_gpu::occlusion_counts_samples(&ctx.caps) {
        return Ok(None);
    }
    let mut timer = GpuTimer::wall_clock().counting_fragments(ctx);
    timer.set_budget(Some(
        deadline.saturating_duration_since(std::time::Instant::now()),
    ));
    render_frame(ctx, scene, technique, targets, &mut timer)?;
    let passes = timer.pass_fragments().unwrap_or_default();
    let mut work = technique.work(&ctx.caps, targets.color_format);
    work.passes
        .push(oit_gpu::work::opaque_pass(targets.color_format));
    Ok(Some(price(passes, &work, &Triangles::of(scene))))
}

/// Triangles each kind of pass submits on a scene.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Triangles {
    pub transparent: u64,
    pub transparent_double_sided: u64,
    pub transmissive: u64,
    pub additive: u64,
    pub opaque: u64,
    pub pixels: u64,
}

impl Triangles {
    pub(crate) fn of(scene: &GpuScene) -> Self {
        let s = &scene.scene;
        let mut t = Triangles {
            pixels: s.resolution.pixel_count() as u64,
            ..Default::default()
        };
        for d in &s.draws {
            let m = s.material_of(d);
            let n = u64::from(d.vertex_count / 3);
            if m.mode.is_transparent() {
                t.transparent += n;
                if m.double_sided {
                    t.transparent_double_sided += n;
                }
                if m.is_transmissive() {
                    t.transmissive += n;
                }
                if m.operator.is_additive() {
                    t.additive += n;
                }
            } else {
                t.opaque += n;
            }
        }
        t
    }

    fn submitted(&self, draws: PassDraws) -> u64 {
        match draws {
            PassDraws::Transparent => self.transparent,
            PassDraws::TransparentDoubleSidedTwice => {
                self.transparent + self.transparent_double_sided
            }
            PassDraws::Transmissive => self.transmissive,
            PassDraws::NotTransmissive => self.transparent - self.transmissive,
            PassDraws::Additive => self.additive,
            PassDraws::NotAdditive => self.transparent - self.additive,
            PassDraws::Opaque => self.opaque,
            PassDraws::FullScreen | PassDraws::Compute => 0,
        }
    }
}

fn draws_name(draws: PassDraws) -> String {
    match draws {
        PassDraws::Transparent => "transparent",
        PassDraws::TransparentDoubleSidedTwice => "transparent-double-sided-twice",
        PassDraws::Transmissive => "transmissive",
        PassDraws::NotTransmissive => "not-transmissive",
        PassDraws::Additive => "additive",
        PassDraws::NotAdditive => "not-additive",
        PassDraws::Opaque => "opaque",
        PassDraws::FullScreen => "full-screen",
        PassDraws::Compute => "compute",
    }
    .to_owned()
}

/// Prices the counted frame's passes by the technique's declarations.
pub(crate) fn price(passes: &[PassFragments], work: &Work, triangles: &Triangles) -> RunCounts {
    let mut counts = RunCounts::default();
    // Samples per declaration, for passes that read another pass's fragments.
    let samples_of = |declared: &str| -> u64 {
        passes
            .iter()
            .filter(|p| work.of_pass(&p.name).is_some_and(|w| w.name == declared))
            .filter_map(|p| p.samples)
            .sum()
    };
    for pass in passes {
        let Some(declared) = work.of_pass(&pass.name) else {
            counts.undeclared_passes.push(pass.name.clone());
            counts.passes.push(PassCounts {
                name: pass.name.clone(),
                draws: None,
                samples: pass.samples,
                bytes: None,
                atomics: None,
                triangles: 0,
            });
            continue;
        };
        let PassWork {
            draws,
            bytes_read,
            bytes_written,
            atomics,
            ..
        } = declared;
        let tri = triangles.submitted(*draws);
        let (bytes, pass_atomics) = match pass.samples {
            Some(samples) => {
                let mut bytes = samples * u64::from(bytes_read + bytes_written);
                if let Some((other, per)) = &declared.reads_fragments_of {
                    bytes += samples_of(other) * u64::from(*per);
                }
                (Some(bytes), Some(samples as f64 * atomics))
            }
            None => (None, None),
        };
        match draws {
            PassDraws::FullScreen => {
                counts.fullscreen_passes += 1;
                counts.fullscreen_pixels += triangles.pixels;
            }
            PassDraws::Compute => {}
            _ => {
                counts.geometry_passes += 1;
                counts.triangle_passes += tri;
                counts.fragments += pass.samples.unwrap_or(0);
            }
        }
        counts.bytes += bytes.unwrap_or(0);
        counts.atomics += pass_atomics.unwrap_or(0.0);
        counts.passes.push(PassCounts {
            name: pass.name.clone(),
            draws: Some(draws_name(*draws)),
            samples: pass.samples,
            bytes,
            atomics: pass_atomics,
            triangles: tri,
        });
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn counted(name: &str, samples: Option<u64>) -> PassFragments {
        PassFragments {
            name: name.to_owned(),
            samples,
        }
    }

    fn triangles() -> Triangles {
        Triangles {
            transparent: 100,
            transparent_double_sided: 40,
            transmissive: 10,
            additive: 30,
            opaque: 7,
            pixels: 64,
        }
    }

    #[test]
    fn passes_are_priced_by_their_declarations() {
        let work = Work::new(vec![
            PassWork::new("opaque", PassDraws::Opaque).bytes(4, 12),
            PassWork::new("insert", PassDraws::Transparent)
                .bytes(4, 16)
                .atomics(2.0),
            PassWork::new("resolve", PassDraws::FullScreen)
                .bytes(16, 8)
                .reads_fragments_of("insert", 16),
            PassWork::numbered("layer ", PassDraws::TransparentDoubleSidedTwice).bytes(1, 1),
        ]);
        let passes = [
            counted("opaque", Some(64)),
            counted("insert", Some(300)),
            counted("layer 1", Some(50)),
            counted("layer 2", Some(20)),
            counted("resolve", Some(64)),
            counted("a compute pass", None),
        ];
        let c = price(&passes, &work, &triangles());
        assert_eq!(c.fragments, 64 + 300 + 50 + 20);
        assert_eq!(
            c.bytes,
            64 * 16 + 300 * 20 + 70 * 2 + 64 * 24 + 300 * 16,
            "{c:?}"
        );
        assert_eq!(c.atomics, 600.0);
        assert_eq!(c.triangle_passes, 7 + 100 + 2 * 140);
        assert_eq!(c.geometry_passes, 4);
        assert_eq!(c.fullscreen_passes, 1);
        assert_eq!(c.fullscreen_pixels, 64);
        assert_eq!(c.undeclared_passes, vec!["a compute pass".to_owned()]);
        assert_eq!(c.passes.len(), 6);
        assert_eq!(c.passes[4].bytes, Some(64 * 24 + 300 * 16));
    }

    #[test]
    fn transmissive_passes_split_the_transparent_triangles() {
        let work = Work::new(vec![
            PassWork::new("a", PassDraws::Transmissive),
            PassWork::new("b", PassDraws::NotTransmissive),
        ]);
        let c = price(
            &[counted("a", Some(1)), counted("b", Some(2))],
            &work,
            &triangles(),
        );
        assert_eq!(c.triangle_passes, 100);
        assert_eq!(c.fragments, 3);
        assert!(c.undeclared_passes.is_empty());
    }

    #[test]
    fn additive_passes_price_the_additive_triangles_only() {
        let work = Work::new(vec![
            PassWork::new("over", PassDraws::NotAdditive),
            PassWork::new("add", PassDraws::Additive),
        ]);
        let c = price(
            &[counted("over", Some(1)), counted("add", Some(2))],
            &work,
            &triangles(),
        );
        assert_eq!(c.triangle_passes, 70 + 30);
        assert_eq!(c.passes[1].triangles, 30);
        assert_eq!(c.passes[1].draws.as_deref(), Some("additive"));
    }
}
