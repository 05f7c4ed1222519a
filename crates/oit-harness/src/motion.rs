//! Animated scenes: every selected frame of the path, for every technique, against the exact
//! reference of that frame; then frame 0 again and again at its static camera for bias and
//! noise. The numbers are `oit_metrics::temporal`'s; they land in each run's `temporal` block.
//!
//! Cost: the path is streamed frame by frame (frames outer, techniques inner), so each frame's
//! scene is flattened, its reference computed (or read from the cache) and uploaded once for
//! all techniques, and each technique is built once for the whole path: its pipelines and
//! buffers are reused by every frame. Host memory is bounded whatever the frame count: per
//! technique, the previous frame's error image ([`TRACKER_BYTES_PER_PIXEL`]); its clip
//! (`crate::clip`, an animated PNG) is encoded frame by frame.

use std::path::Path;

use oit_gpu::{Context, GpuScene, GpuTimer, Targets, TechniqueSpec, read_color};
use oit_metrics::temporal::{
    HISTORY_BLEND, POP_FLOOR, POP_MULTIPLE, PathTracker, StaticTracker, error_image,
};
use oit_scene::{Frames, LinearImage, Scene};

use crate::results::{StaticCamera, Temporal};
use crate::run::{CompareOptions, Event, build, max_rgb_difference, reference_of};
use crate::{HarnessError, at_resolution};

/// Host bytes per pixel each technique keeps while a path streams (its previous error image).
pub const TRACKER_BYTES_PER_PIXEL: u64 = 12;
/// Default of [`CompareOptions::static_frames`].
pub const DEFAULT_STATIC_FRAMES: u32 = 16;

/// Which frames of an animated scene are rendered: `start..end` every `step`th (`end`
/// exclusive; `None` is the last frame of the animation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FrameSelection {
    pub start: u32,
    pub end: Option<u32>,
    pub step: u32,
}

impl Default for FrameSelection {
    fn default() -> Self {
        FrameSelection::ALL
    }
}

impl FrameSelection {
    /// Every frame.
    pub const ALL: FrameSelection = FrameSelection {
        start: 0,
        end: None,
        step: 1,
    };

    /// Reads `all`, `N`, `A..B` or `A..B:S` (B exclusive, S ≥ 1).
    pub fn parse(text: &str) -> Result<FrameSelection, String> {
        let bad = || {
            format!(
                "animation frames `{text}`: allowed `all`, a frame `N`, a range `A..B` (B exclusive) or `A..B:STEP`"
            )
        };
        let number = |s: &str| s.trim().parse::<u32>().map_err(|_| bad());
        if text.trim() == "all" {
            return Ok(FrameSelection::ALL);
        }
        let Some((start, rest)) = text.split_once("..") else {
            let n = number(text)?;
            return Ok(FrameSelection {
                start: n,
                end: Some(n.checked_add(1).ok_or_else(bad)?),
                step: 1,
            });
        };
        let (end, step) = match rest.split_once(':') {
            Some((end, step)) => (end, number(step)?),
            None => (rest, 1),
        };
        let selection = FrameSelection {
            start: number(start)?,
            end: Some(number(end)?),
            step,
        };
        if step == 0 || selection.end <= Some(selection.start) {
            return Err(bad());
        }
        Ok(selection)
    }

    /// The frames of an animation of `count` frames, or why the selection does not fit it.
    pub fn frames(&self, count: u32) -> Result<Vec<u32>, String> {
        let end = self.end.unwrap_or(count);
        if self.start >= count || end > count {
            return Err(format!(
                "animation frames {}..{end}: the scene has frames 0..{count}",
                self.start
            ));
        }
        Ok((self.start..end)
            .step_by(self.step.max(1) as usize)
            .collect())
    }
}

/// What a run's motion measurement was made from ([`crate::results::RunInputs::motion`]): the
/// frame selection, the static-camera renders and an FNV-1a hash of the content hashes of the
/// selected frames (at the comparison's resolution). A frame that does not flatten or a
/// selection past the end hashes as such: the measurement will fail and say why.
pub fn inputs(frames: &Frames, options: &CompareOptions) -> String {
    let selection = options.animation_frames;
    let end = selection
        .end
        .map_or_else(|| "end".to_string(), |e| e.to_string());
    let mut bytes = Vec::new();
    match selection.frames(frames.count()) {
        Ok(selected) => {
            for t in selected {
                let hash = frames
                    .frame(t)
                    .map(|s| at_resolution(&s, options.resolution).content_hash())
                    .unwrap_or(0);
                bytes.extend_from_slice(&hash.to_le_bytes());
            }
        }
        Err(_) => bytes.extend_from_slice(b"out of range"),
    }
    format!(
        "frames {}..{end}:{}, static {}, path {:016x}",
        selection.start,
        selection.step,
        options.static_frames,
        crate::fnv1a64(&bytes)
    )
}

/// Per canonical spec, its `temporal` block or why it has none.
pub type MotionRuns = Vec<(String, Result<Temporal, String>)>;

/// One technique's state along the path.
struct Track {
    canonical: String,
    technique: Box<dyn oit_gpu::Technique>,
    /// Set when the technique cannot render the scene or failed: the run gets no `temporal`.
    stopped: Option<String>,
    path: PathTracker,
    frames: Vec<u32>,
    rmse: Vec<f64>,
    flip: Vec<f64>,
    flip_name: &'static str,
    max_abs: Vec<f64>,
    order: f64,
    inexact_frames: Vec<u32>,
    /// The animated PNG of the path (every `clip::step`th frame).
    clip: Option<crate::clip::Clip>,
}

/// Measures `specs` over the selected frames of `frames` and returns, per canonical spec, its
/// `temporal` block or why there is none. Errors end the scene (a frame that does not
/// flatten, a reference over the memory budget); a technique's own failure only ends its track.
#[allow(clippy::too_many_arguments)] // the comparison's state for one scene and format
pub fn measure(
    ctx: &Context,
    frames: &Frames,
    specs: &[TechniqueSpec],
    options: &CompareOptions,
    format: oit_results::TargetFormat,
    cache_dir: Option<&Path>,
    scene_dir: &Path,
    on_event: &dyn Fn(Event<'_>),
) -> Result<MotionRuns, HarnessError> {
    let selected = options
        .animation_frames
        .frames(frames.count())
        .map_err(HarnessError::Options)?;
    let first = at_resolution(&frames.frame(selected[0])?, options.resolution);
    let pixels = first.resolution.pixel_count() as u64;
    let tracker_bytes = pixels * TRACKER_BYTES_PER_PIXEL * specs.len() as u64;
    if tracker_bytes > options.memory_budget / 2 {
        return Err(HarnessError::Options(format!(
            "{}: following {} techniques over its frames at {} keeps {} MiB of error images, more than half of --memory-budget {} MiB",
            first.name,
            specs.len(),
            first.resolution,
            tracker_bytes >> 20,
            options.memory_budget >> 20
        )));
    }
    let targets = Targets::new(ctx, first.resolution, crate::run::color_format(format))?;
    let clip_step = crate::clip::step(selected.len());
    let clip_frames = selected.len().div_ceil(clip_step);
    let seconds = clip_step as f64 / f64::from(frames.animation().map_or(24.0, |a| a.fps));
    let size = (first.resolution.width, first.resolution.height);
    let mut tracks = Vec::with_capacity(specs.len());
    for spec in specs {
        let canonical = spec.canonical();
        let clip =
            crate::clip::Clip::create(scene_dir, &canonical, format, size, clip_frames, seconds)?;
        tracks.push(Track {
            canonical,
            technique: build(spec)?,
            stopped: None,
            path: PathTracker::new(),
            frames: Vec::new(),
            rmse: Vec::new(),
            flip: Vec::new(),
            flip_name: "LDR-FLIP",
            max_abs: Vec::new(),
            order: 0.0,
            inexact_frames: Vec::new(),
            clip: Some(clip),
        });
    }
    for (i, &t) in selected.iter().enumerate() {
        let scene = at_resolution(&frames.frame(t)?, options.resolution);
        let reference = reference_of(&scene, options, cache_dir, on_event)?;
        let forward = GpuScene::upload(ctx, &scene)?;
        let reversed = GpuScene::upload(ctx, &scene.with_reversed_order())?;
        for track in tracks.iter_mut().filter(|t| t.stopped.is_none()) {
            let step = frame_of(
                ctx,
                &scene,
                &forward,
                &reversed,
                &targets,
                track,
                &reference.image,
            );
            match step {
                Err(why) => {
                    on_event(Event::Warning(&format!(
                        "{} on {}: no motion measurement: {why}",
                        track.canonical, scene.name
                    )));
                    track.stopped = Some(why);
                    track.clip = None;
                }
                Ok(image) if i % clip_step == 0 => {
                    if let Some(clip) = &mut track.clip {
                        clip.push(&image, &reference.image)?;
                    }
                }
                Ok(_) => {}
            }
        }
        on_event(Event::FrameDone {
            scene: &scene.name,
            done: i + 1,
            of: selected.len(),
        });
    }
    let statics = if options.static_frames > 0 {
        static_camera(
            ctx,
            frames,
            &mut tracks,
            options,
            cache_dir,
            &targets,
            on_event,
        )?
    } else {
        vec![None; tracks.len()]
    };
    let mut out = Vec::with_capacity(tracks.len());
    for (track, static_camera) in tracks.into_iter().zip(statics) {
        if let Some(why) = track.stopped {
            // Its clip is dropped unfinished: no file.
            out.push((track.canonical, Err(why)));
            continue;
        }
        let mut track = track;
        if let Some(clip) = track.clip.take() {
            clip.finish()?;
        }
        out.push((track.canonical.clone(), Ok(summarise(track, static_camera))));
    }
    Ok(out)
}

/// Renders one frame of one technique reversed and forward, adds its errors to the track and
/// returns the forward image.
fn frame_of(
    ctx: &Context,
    scene: &Scene,
    forward: &GpuScene,
    reversed: &GpuScene,
    targets: &Targets,
    track: &mut Track,
    reference: &LinearImage,
) -> Result<LinearImage, String> {
    oit_gpu::check_scene(track.technique.as_ref(), &ctx.caps, scene)
        .and_then(|()| (track.technique).check_target(targets.color_format, &ctx.caps))
        .map_err(|u| u.reason)?;
    let mut timer = GpuTimer::wall_clock();
    oit_gpu::render_frame(ctx, reversed, track.technique.as_mut(), targets, &mut timer)
        .map_err(|e| e.to_string())?;
    let backwards = read_color(ctx, targets).map_err(|e| e.to_string())?;
    let frame = oit_gpu::render_frame(ctx, forward, track.technique.as_mut(), targets, &mut timer)
        .map_err(|e| e.to_string())?;
    let image = read_color(ctx, targets).map_err(|e| e.to_string())?;
    let errors = oit_metrics::compare(&image, reference).map_err(|e| e.to_string())?;
    let (flip, name) = errors.headline_flip();
    let t = scene.frame;
    track.frames.push(t);
    track.rmse.push(errors.rmse);
    track.flip.push(flip);
    track.flip_name = name;
    track.max_abs.push(errors.max_abs);
    track.order = track.order.max(max_rgb_difference(&image, &backwards));
    if frame.stats.pixels_with_dropped_layers + frame.stats.pixels_with_approximated_layers > 0 {
        track.inexact_frames.push(t);
    }
    track.path.push(t, error_image(&image, reference));
    Ok(image)
}

/// Frame 0 rendered [`CompareOptions::static_frames`] times at its static camera, with
/// `Scene::frame` counting up so that techniques with per-frame noise draw fresh noise.
fn static_camera(
    ctx: &Context,
    frames: &Frames,
    tracks: &mut [Track],
    options: &CompareOptions,
    cache_dir: Option<&Path>,
    targets: &Targets,
    on_event: &dyn Fn(Event<'_>),
) -> Result<Vec<Option<StaticCamera>>, HarnessError> {
    let scene = at_resolution(&frames.frame(0)?, options.resolution);
    let reference = reference_of(&scene, options, cache_dir, on_event)?;
    let mut gpu = GpuScene::upload(ctx, &scene)?;
    let mut out = Vec::with_capacity(tracks.len());
    for track in tracks.iter_mut() {
        if track.stopped.is_some() {
            out.push(None);
            continue;
        }
        let mut tracker = StaticTracker::new(&reference.image);
        let mut failed = None;
        for k in 0..options.static_frames {
            // The upload is reused: only the frame index changes (techniques key their
            // per-frame sequence on it, and their caches on the upload's id).
            gpu.scene.frame = k;
            let mut timer = GpuTimer::wall_clock();
            let rendered =
                oit_gpu::render_frame(ctx, &gpu, track.technique.as_mut(), targets, &mut timer)
                    .map_err(HarnessError::from)
                    .and_then(|_| read_color(ctx, targets).map_err(HarnessError::from));
            match rendered {
                Ok(image) => tracker.push(&image),
                Err(e) => {
                    failed = Some(e.to_string());
                    break;
                }
            }
        }
        if let Some(why) = failed {
            on_event(Event::Warning(&format!(
                "{} on {}: no static-camera measurement: {why}",
                track.canonical, scene.name
            )));
            out.push(None);
            continue;
        }
        let s = tracker.finish();
        out.push(Some(StaticCamera {
            frames: s.frames,
            bias_rmse: s.bias_rmse,
            noise_rms: s.noise_rms,
            mse: s.mse,
            history_rmse: s.history_rmse,
            history_blend: HISTORY_BLEND,
            mean_rmse: s.mean_rmse,
        }));
    }
    Ok(out)
}

fn summarise(track: Track, static_camera: Option<StaticCamera>) -> Temporal {
    let n = track.flip.len().max(1) as f64;
    let (worst, worst_flip) =
        track
            .flip
            .iter()
            .enumerate()
            .fold((0, f64::NEG_INFINITY), |best, (i, &f)| {
                if f > best.1 { (i, f) } else { best }
            });
    Temporal {
        worst_frame: track.frames.get(worst).copied().unwrap_or(0),
        worst_flip: worst_flip.max(0.0),
        mean_flip: track.flip.iter().sum::<f64>() / n,
        mean_rmse: track.rmse.iter().sum::<f64>() / n,
        change: track.path.changes().iter().map(|c| c.1).collect(),
        flicker: track.path.flicker(),
        pop_events: track.path.pop_events(),
        pop_multiple: POP_MULTIPLE,
        pop_floor: POP_FLOOR,
        frames: track.frames,
        rmse: track.rmse,
        flip: track.flip,
        flip_name: track.flip_name.to_string(),
        max_abs: track.max_abs,
        max_order_dependence: track.order,
        inexact_frames: track.inexact_frames,
        static_camera,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_selections_parse_and_are_checked_against_the_animation() {
        assert_eq!(FrameSelection::parse("all"), Ok(FrameSelection::ALL));
        let one = FrameSelection::parse("7").expect("one frame");
        assert_eq!(one.frames(10), Ok(vec![7]));
        let range = FrameSelection::parse("2..9:3").expect("range");
        assert_eq!(range.frames(10), Ok(vec![2, 5, 8]));
        assert_eq!(FrameSelection::ALL.frames(3), Ok(vec![0, 1, 2]));
        for bad in ["", "x", "3..3", "5..2", "1..4:0", "-1", "1..", "..4"] {
            let e = FrameSelection::parse(bad).expect_err(bad);
            assert!(e.contains("allowed"), "{e}");
        }
        let e = FrameSelection::parse("4..12")
            .expect("parses")
            .frames(10)
            .expect_err("past the end");
        assert!(e.contains("0..10"), "{e}");
        assert!(one.frames(5).is_err());
    }

    /// `--resume` reuses a motion measurement only for the same path: another frame
    /// selection, static-camera count or keyframe changes the run's inputs.
    #[test]
    fn a_runs_motion_inputs_name_the_path_it_measured() {
        let scene = |end: u32| {
            format!(
                r#"{{"name": "m", "resolution": [8, 8], "animation": {{"frames": 4, "fps": 24}},
                "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0],
                           "keyframes": [{{"frame": 0, "eye": [0, 0, 5]}}, {{"frame": 3, "eye": [{end}, 0, 5]}}]}},
                "objects": [{{"mesh": {{"kind": "quad"}}, "material": {{"mode": "blend", "alpha": 0.5}}}}]}}"#
            )
        };
        let frames = oit_scene::parse_frames(&scene(1), "m.json").expect("scene");
        let options = CompareOptions::default();
        let all = inputs(&frames, &options);
        assert_eq!(all, inputs(&frames, &options), "deterministic");
        let fewer = CompareOptions {
            animation_frames: FrameSelection::parse("0..2").expect("selection"),
            ..CompareOptions::default()
        };
        let less_static = CompareOptions {
            static_frames: 4,
            ..CompareOptions::default()
        };
        let moved = oit_scene::parse_frames(&scene(2), "m.json").expect("scene");
        for other in [
            inputs(&frames, &fewer),
            inputs(&frames, &less_static),
            inputs(&moved, &options),
        ] {
            assert_ne!(all, other);
        }
    }
}
