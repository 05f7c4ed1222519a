//! Timing a technique as every run is timed: an untimed first frame, the warm-up, the timed
//! frames (again where the machine was busy, with `--retime`), all within the run's budget, and
//! a technique's own estimate of its passes priced before it starts.

use oit_gpu::{Context, GpuScene, GpuTimer, Targets, Technique, TimingSource, render_frame};

use crate::results::{GpuMs, PassMs};
use crate::{CompareOptions, HarnessError, interference};

/// One untimed first frame (pipelines and shaders are created, caches fill: never timed, at
/// any `--warmup`), the warm-up frames, then the timed frames. Returns total GPU ms
/// (median/min/max), per-pass medians, and the last frame's stats with `cpu_ms` replaced by
/// its median over the timed frames. With `options.retime`, frames timed in a noisy window are
/// timed again ([`quietest`]).
///
/// The whole run stays within `options.run_budget`: every submission after it has passed
/// fails, and a run whose first frame shows that its frames would not fit stops before them.
/// With `held` (what the scene holds besides the technique), the technique's buffers, built in
/// the first frame, must fit `--memory-budget` with it ([`crate::budget`]).
pub(crate) fn time_frames(
    ctx: &Context,
    scene: &GpuScene,
    technique: &mut dyn Technique,
    targets: &Targets,
    options: &CompareOptions,
    held: Option<crate::budget::RunMemory>,
) -> Result<(GpuMs, Vec<PassMs>, oit_gpu::RenderStats), HarnessError> {
    let mut timer = GpuTimer::new(ctx);
    timer.set_budget(Some(options.run_budget));
    let started = std::time::Instant::now();
    render_frame(ctx, scene, technique, targets, &mut timer)?;
    let first = started.elapsed();
    if let Some(held) = held {
        let name = &scene.scene.name;
        crate::budget::check_technique(held, technique, name, options.memory_budget)?;
    }
    time_after_first_frame(
        ctx,
        scene,
        technique,
        targets,
        options,
        &mut timer,
        Some(first),
    )
}

/// [`time_frames`] for the scene's own measurements (the floor, a baseline timed for the
/// ratios): one pass each, so never over a budget that a technique could keep.
pub(crate) fn time_unbudgeted(
    ctx: &Context,
    scene: &GpuScene,
    technique: &mut dyn Technique,
    targets: &Targets,
    options: &CompareOptions,
) -> Result<(GpuMs, Vec<PassMs>, oit_gpu::RenderStats), HarnessError> {
    let mut timer = GpuTimer::new(ctx);
    render_frame(ctx, scene, technique, targets, &mut timer)?;
    time_after_first_frame(ctx, scene, technique, targets, options, &mut timer, None)
}

/// Warm-up and timed frames after the untimed first one; with `first` (its duration), first
/// checks that the rest can fit the run's budget.
fn time_after_first_frame(
    ctx: &Context,
    scene: &GpuScene,
    technique: &mut dyn Technique,
    targets: &Targets,
    options: &CompareOptions,
    timer: &mut GpuTimer,
    first: Option<std::time::Duration>,
) -> Result<(GpuMs, Vec<PassMs>, oit_gpu::RenderStats), HarnessError> {
    if let Some(first) = first {
        check_frames_fit(first, options)?;
    }
    for _ in 0..options.warmup {
        render_frame(ctx, scene, technique, targets, timer)?;
    }
    let ((mut gpu, passes, stats), made) = until_quiet(
        options.retime,
        || time_window(ctx, scene, technique, targets, options.frames, timer),
        |attempt| attempt.0.interference,
    )?;
    gpu.attempts = made;
    Ok((gpu, passes, stats))
}

/// Whether the frames after a first frame that took `first` can fit the run's budget.
fn check_frames_fit(
    first: std::time::Duration,
    options: &CompareOptions,
) -> Result<(), HarnessError> {
    // The first frame includes building; later ones cost at most as much (a bound, so a slow
    // build may refuse a run that would have fit: the message says how to allow it).
    let frames_left =
        u64::from(options.warmup) + u64::from(options.frames) * (1 + u64::from(options.retime)) + 2;
    let estimate = first.as_secs_f64() * frames_left as f64;
    let left = options.run_budget.saturating_sub(first).as_secs_f64();
    if estimate > left {
        return Err(HarnessError::Options(format!(
            "the first frame took {:.1} s, so {frames_left} more frames (warm-up, timed, re-timed, the reversed-order and the counted frame) could take {estimate:.0} s, past --run-budget {} s; raise it or lower --frames",
            first.as_secs_f64(),
            options.run_budget.as_secs()
        )));
    }
    Ok(())
}

/// Times `technique` on `scene` the way `compare` times every run (first frame untimed, then
/// warm-up and timed frames, within `options.run_budget`): median/min/max GPU ms, per-pass
/// medians and the last frame's stats.
pub fn time_technique(
    ctx: &Context,
    scene: &GpuScene,
    technique: &mut dyn Technique,
    targets: &Targets,
    options: &CompareOptions,
) -> Result<(GpuMs, Vec<PassMs>, oit_gpu::RenderStats), HarnessError> {
    time_frames(ctx, scene, technique, targets, options, None)
}

/// A technique's own count of the geometry passes it will make on a scene
/// ([`Technique::planned_passes`]), priced at the floor's pass.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PassEstimate {
    passes: u32,
    depth_complexity: u32,
    floor_ms: f64,
    frames: u64,
}

impl PassEstimate {
    pub(crate) fn of(
        technique: &dyn Technique,
        depth_complexity: u32,
        floor_ms: f64,
        options: &CompareOptions,
    ) -> Option<Self> {
        let passes = technique.planned_passes(depth_complexity)?;
        Some(PassEstimate {
            passes,
            depth_complexity,
            floor_ms,
            // The first, reversed-order and counted frames, and the rest.
            frames: 3
                + u64::from(options.warmup)
                + u64::from(options.frames) * (1 + u64::from(options.retime)),
        })
    }

    /// Seconds the run's frames would take at one floor pass per geometry pass.
    fn seconds(&self) -> f64 {
        f64::from(self.passes) * self.floor_ms * 1e-3 * self.frames as f64
    }

    pub(crate) fn over_budget(&self, budget: std::time::Duration) -> bool {
        self.seconds() > budget.as_secs_f64()
    }

    pub(crate) fn describe(&self, budget: std::time::Duration) -> String {
        format!(
            "estimated {:.0} s: {} geometry passes a frame for depth complexity {} × {} frames, each pass at least the floor's {:.2} ms; over --run-budget {} s (raise it, or bound the passes)",
            self.seconds(),
            self.passes,
            self.depth_complexity,
            self.frames,
            self.floor_ms,
            budget.as_secs()
        )
    }
}

/// Makes `attempt`s until one's window is not noisy or `retime` more were made after the
/// first; returns the [`quietest`] and how many were made.
fn until_quiet<T, E>(
    retime: u32,
    mut attempt: impl FnMut() -> Result<T, E>,
    window: impl Fn(&T) -> Option<crate::interference::Interference>,
) -> Result<(T, u32), E> {
    let mut attempts = Vec::new();
    loop {
        let made = attempt()?;
        let quiet = !window(&made).is_some_and(|i| i.notable());
        attempts.push(made);
        if quiet || attempts.len() > retime as usize {
            break;
        }
    }
    let made = attempts.len() as u32;
    let best = quietest(attempts.iter().map(&window));
    Ok((attempts.swap_remove(best), made))
}

/// Which attempt to keep: the first whose window was not noisy (or could not be judged),
/// else the one that lost the least CPU time to others.
fn quietest(windows: impl Iterator<Item = Option<crate::interference::Interference>>) -> usize {
    let mut best: Option<(usize, f64)> = None;
    for (i, window) in windows.enumerate() {
        let lost = match window {
            Some(w) if w.notable() => w.lost(),
            _ => return i,
        };
        if best.is_none_or(|(_, least)| lost < least) {
            best = Some((i, lost));
        }
    }
    best.map_or(0, |(i, _)| i)
}

/// One window of `frames` timed frames: the [`time_frames`] results of one attempt.
fn time_window(
    ctx: &Context,
    scene: &GpuScene,
    technique: &mut dyn Technique,
    targets: &Targets,
    frames: u32,
    timer: &mut GpuTimer,
) -> Result<(GpuMs, Vec<PassMs>, oit_gpu::RenderStats), HarnessError> {
    let mut totals = Vec::with_capacity(frames as usize);
    let mut cpu = Vec::with_capacity(frames as usize);
    let mut per_pass: Vec<(String, Vec<f64>)> = Vec::new();
    let mut last = None;
    let mut source = TimingSource::WallClock;
    let before = interference::sample();
    for _ in 0..frames {
        let frame = render_frame(ctx, scene, technique, targets, timer)?;
        source = frame.timings.source;
        // Wall-clock mode: total GPU busy time is unknowable, so the whole frame counts.
        totals.push(match source {
            TimingSource::Timestamp => frame.timings.total_ms,
            TimingSource::WallClock => frame.timings.wall_ms,
        });
        cpu.push(frame.stats.cpu_ms);
        for p in &frame.timings.passes {
            match per_pass.iter_mut().find(|(n, _)| *n == p.name) {
                Some((_, v)) => v.push(p.ms),
                None => per_pass.push((p.name.clone(), vec![p.ms])),
            }
        }
        last = Some(frame.stats);
    }
    let after = interference::sample();
    // `compare` refuses zero frames up front; a library caller gets the same error here.
    let Some(mut stats) = last else {
        return Err(HarnessError::Options(
            "zero timed frames: at least one frame must be timed".into(),
        ));
    };
    stats.cpu_ms = median(&mut cpu);
    let gpu = GpuMs {
        median: median(&mut totals.clone()),
        min: totals.iter().copied().fold(f64::INFINITY, f64::min),
        max: totals.iter().copied().fold(0.0, f64::max),
        frames,
        source: source.name().to_owned(),
        interference: before.zip(after).and_then(|(a, b)| {
            interference::Interference::between(a, b, interference::TICKS_PER_SECOND)
        }),
        attempts: 1,
    };
    let passes = per_pass
        .into_iter()
        .map(|(name, mut v)| PassMs {
            name,
            median_ms: median(&mut v),
        })
        .collect();
    Ok((gpu, passes, stats))
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
    }

    /// `--retime` keeps the first attempt whose window was quiet or too short to judge, and
    /// otherwise the one that lost the least CPU time.
    #[test]
    fn the_quietest_attempt_is_kept() {
        use crate::interference::Interference;
        let window = |lost: f64, cpu_seconds: f64| {
            Some(Interference {
                steal: lost,
                other_processes: 0.0,
                cpu_seconds,
            })
        };
        let noisy = |lost: f64| window(lost, 4.0);
        assert_eq!(quietest([noisy(0.3), window(0.05, 4.0)].into_iter()), 1);
        assert_eq!(
            quietest([noisy(0.3), noisy(0.12), noisy(0.2)].into_iter()),
            1
        );
        assert_eq!(quietest([noisy(0.2), noisy(0.4)].into_iter()), 0);
        // Too short to judge, or not measured at all (no /proc/stat): as good as quiet.
        assert_eq!(quietest([noisy(0.3), window(0.9, 0.1)].into_iter()), 1);
        assert_eq!(quietest([noisy(0.3), None, noisy(0.01)].into_iter()), 1);
        assert_eq!(quietest([None].into_iter()), 0);
    }

    /// A noisy window is timed again at most `retime` times, and timing stops at the first
    /// quiet one.
    #[test]
    fn retiming_stops_at_a_quiet_window_or_the_limit() {
        use crate::interference::Interference;
        let lost = [0.3, 0.2, 0.01, 0.5];
        let run = |retime: u32| {
            let mut next = 0;
            until_quiet::<usize, ()>(
                retime,
                || {
                    next += 1;
                    Ok(next - 1)
                },
                |&i| {
                    Some(Interference {
                        steal: lost[i],
                        other_processes: 0.0,
                        cpu_seconds: 4.0,
                    })
                },
            )
            .unwrap()
        };
        assert_eq!(
            run(0),
            (0, 1),
            "no retiming: the first window, noisy or not"
        );
        assert_eq!(run(1), (1, 2), "the quieter of two noisy windows");
        assert_eq!(run(2), (2, 3), "stops at the quiet third window");
        assert_eq!(run(10), (2, 3), "and makes no more after it");
        let failing = until_quiet::<u32, &str>(3, || Err("lost the device"), |_| None);
        assert_eq!(failing, Err("lost the device"));
    }
}
