//! `--memory-budget` over what a scene's runs hold at once. The reference's fragments are
//! bounded by [`crate::MemoryPlan`] while the reference is computed; once it is done the runs
//! hold one run's images, the predictions' per-pixel lists, the scene uploaded twice (in draw
//! order and reversed, [`oit_gpu::SceneBytes`]), the shared targets and the technique's own
//! buffers ([`oit_gpu::Technique::memory_bytes`]). On lavapipe GPU memory is host memory; on a
//! discrete GPU the same sum bounds host and device memory together.
//!
//! A scene whose upload alone does not fit fails before it is uploaded. A technique's buffers
//! are known once it has built them, in its first (untimed) frame: a run over the budget then
//! fails before any timed frame, with what it needs in MiB, and the next run goes on.

use oit_scene::Scene;

use crate::HarnessError;

/// How a scene's memory budget is shared: the images of one run (render, reference, reversed
/// render, differences, FLIP's working images) first, the reference's fragments get the rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryPlan {
    /// Host bytes of one run's images at the scene's resolution.
    pub image_bytes: u64,
    /// What the reference may hold for fragments.
    pub reference_bytes: u64,
}

/// Host bytes per pixel that one run holds besides the reference's fragments: reference
/// (RGBA f32 and four counts), render and reversed render read back (RGBA f32), the difference
/// and its heat map, and FLIP's working images. Measured as the peak resident memory of
/// `oit compare -t unsorted` at 2048² minus that at 256², per pixel, and rounded up.
pub const RUN_BYTES_PER_PIXEL: u64 = 160;

/// The least the reference keeps for fragments whatever the images take (a scene whose
/// fragments arrive in depth order needs almost nothing).
const MIN_REFERENCE_BYTES: u64 = 1 << 20;

impl MemoryPlan {
    /// The plan for `scene` under `budget` bytes, or an error naming what it would need.
    pub fn of(scene: &Scene, budget: u64) -> Result<MemoryPlan, HarnessError> {
        let pixels = scene.resolution.pixel_count() as u64;
        let image_bytes = pixels.saturating_mul(RUN_BYTES_PER_PIXEL);
        let needed = image_bytes.saturating_add(MIN_REFERENCE_BYTES);
        if needed > budget {
            let mib = |b: u64| b.div_ceil(1 << 20);
            return Err(HarnessError::Options(format!(
                "{} at {} needs about {} MiB for the images of one run ({RUN_BYTES_PER_PIXEL} bytes a pixel) and {} MiB for the reference's fragments, more than --memory-budget {} MiB; raise it or lower --resolution",
                scene.name,
                scene.resolution,
                mib(image_bytes),
                mib(MIN_REFERENCE_BYTES),
                mib(budget)
            )));
        }
        Ok(MemoryPlan {
            image_bytes,
            reference_bytes: budget - image_bytes,
        })
    }
}

/// Bytes held at once while a run renders.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RunMemory {
    /// One run's host images ([`crate::MemoryPlan::image_bytes`]).
    pub images: u64,
    /// The reference's per-pixel lists kept for predictions (0 without predictions).
    pub lists: u64,
    /// The scene's GPU upload, both copies (vertices, materials, textures).
    pub scene_upload: u64,
    /// Of `scene_upload`, the textures.
    pub textures: u64,
    /// The shared colour and depth targets (0 before they exist).
    pub targets: u64,
    /// The technique's own textures and buffers (0 before it is built).
    pub technique: u64,
}

/// Copies of the scene a comparison keeps on the GPU while it runs techniques: in draw order
/// and reversed (the order-dependence render).
pub const SCENE_COPIES: u64 = 2;

impl RunMemory {
    /// What a scene holds before any technique: one run's images, the lists and the upload.
    pub fn of_scene(scene: &oit_scene::Scene, images: u64, lists: u64) -> RunMemory {
        let bytes = oit_gpu::SceneBytes::of(scene);
        RunMemory {
            images,
            lists,
            scene_upload: bytes.total().saturating_mul(SCENE_COPIES),
            textures: bytes.textures.saturating_mul(SCENE_COPIES),
            targets: 0,
            technique: 0,
        }
    }

    pub fn total(&self) -> u64 {
        [
            self.images,
            self.lists,
            self.scene_upload,
            self.targets,
            self.technique,
        ]
        .into_iter()
        .fold(0u64, u64::saturating_add)
    }

    /// `Ok` when the total fits `budget`; otherwise an error that says what `who` needs,
    /// part by part, in MiB, and the option to raise.
    pub fn check(&self, who: &str, budget: u64) -> Result<(), HarnessError> {
        let total = self.total();
        if total <= budget {
            return Ok(());
        }
        let mut parts = Vec::new();
        if self.technique > 0 {
            parts.push(format!(
                "{} of the technique's buffers",
                mib(self.technique)
            ));
        }
        parts.push(format!(
            "{} of the scene's GPU upload ({SCENE_COPIES} copies, in draw order and reversed; {} of it textures)",
            mib(self.scene_upload),
            mib(self.textures)
        ));
        if self.targets > 0 {
            parts.push(format!("{} of colour and depth targets", mib(self.targets)));
        }
        parts.push(format!("{} of one run's images", mib(self.images)));
        if self.lists > 0 {
            parts.push(format!(
                "{} of the reference's per-pixel lists (--no-predict drops them)",
                mib(self.lists)
            ));
        }
        Err(HarnessError::OverMemoryBudget(format!(
            "{who} needs {} at once ({}), more than --memory-budget {}; raise --memory-budget to at least {} MiB",
            mib(total),
            parts.join(", "),
            mib(budget),
            total.div_ceil(1 << 20)
        )))
    }
}

/// What `scene` holds before any technique under `options` (its images priced by
/// [`crate::MemoryPlan`], `lists` when predictions are kept), refused when over
/// `--memory-budget` before anything is uploaded.
pub(crate) fn scene_memory(
    scene: &oit_scene::Scene,
    options: &crate::CompareOptions,
    lists: Option<&oit_gpu::predict::PixelLists>,
) -> Result<RunMemory, HarnessError> {
    let plan = crate::MemoryPlan::of(scene, options.memory_budget)?;
    let lists = lists.map_or(0, oit_gpu::predict::PixelLists::heap_bytes);
    let memory = RunMemory::of_scene(scene, plan.image_bytes, lists);
    memory.check(&format!("scene {}", scene.name), options.memory_budget)?;
    Ok(memory)
}

/// After a technique's first frame: `held` plus its buffers within `budget`.
pub(crate) fn check_technique(
    held: RunMemory,
    technique: &dyn oit_gpu::Technique,
    scene: &str,
    budget: u64,
) -> Result<(), HarnessError> {
    let memory = RunMemory {
        technique: technique.memory_bytes(),
        ..held
    };
    memory.check(
        &format!("{} on {scene}", technique.spec().canonical()),
        budget,
    )
}

/// Bytes in MiB with one decimal, as every size in an error is stated.
pub fn mib(bytes: u64) -> String {
    oit_gpu::mib(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_parts_add_up_and_the_refusal_names_them_in_mib() {
        let memory = RunMemory {
            images: 10 << 20,
            lists: 1 << 20,
            scene_upload: 6 << 20,
            textures: 4 << 20,
            targets: 3 << 20,
            technique: 100 << 20,
        };
        assert_eq!(memory.total(), 120 << 20);
        assert!(memory.check("t", 120 << 20).is_ok());
        let message = memory
            .check("k-buffer on glass", (120 << 20) - 1)
            .unwrap_err();
        let text = message.to_string();
        assert!(
            text.starts_with("k-buffer on glass needs 120.0 MiB at once (100.0 MiB of the technique's buffers, 6.0 MiB of the scene's GPU upload"),
            "{text}"
        );
        assert!(text.contains("4.0 MiB of it textures"), "{text}");
        assert!(
            text.contains("3.0 MiB of colour and depth targets"),
            "{text}"
        );
        assert!(text.contains("10.0 MiB of one run's images"), "{text}");
        assert!(
            text.contains("1.0 MiB of the reference's per-pixel lists"),
            "{text}"
        );
        assert!(
            text.ends_with(
                "more than --memory-budget 120.0 MiB; raise --memory-budget to at least 120 MiB"
            ),
            "{text}"
        );
        assert!(!text.contains("125829"), "no raw byte counts: {text}");
    }

    #[test]
    fn a_scene_is_priced_at_its_upload_twice() {
        for seed in 0..4 {
            let (text, _) = oit_scene::random::random_scene_json(seed);
            let scene = oit_scene::parse(&text, "random").unwrap();
            let bytes = oit_gpu::SceneBytes::of(&scene);
            let memory = RunMemory::of_scene(&scene, 7, 5);
            assert_eq!(memory.scene_upload, 2 * bytes.total(), "seed {seed}");
            assert_eq!(memory.textures, 2 * bytes.textures, "seed {seed}");
            assert_eq!(memory.total(), 2 * bytes.total() + 12, "seed {seed}");
            // One byte short of the upload refuses it, naming the budget.
            let short = memory.total() - 1;
            let e = memory.check("scene", short).unwrap_err().to_string();
            assert!(e.contains("--memory-budget"), "{e}");
            assert!(memory.check("scene", short + 1).is_ok());
        }
    }
}
