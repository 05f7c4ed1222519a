//! A criterion [`Measurement`] in GPU milliseconds, so `cargo bench` reports what the GPU spent
//! rather than what the CPU waited.
//!
//! Criterion calls `start` and `end` around a batch of iterations but cannot see inside the
//! GPU, so the benchmark routine reports each frame's time to a shared [`GpuClock`]
//! (`clock.record(&frame.timings)`) and the measurement is the GPU time recorded between
//! `start` and `end`. Criterion still plans iteration counts from wall-clock time (its warm-up
//! and `--quick` limits), which is what keeps a run's duration bounded.
//!
//! The time of a frame is the one the harness puts in results.json's `gpu_ms`: the sum of the
//! per-pass timestamp intervals where the adapter has timestamp queries, otherwise the
//! wall-clock time from the first submit to completion (CPU work included). The units printed
//! say which: `ms (GPU)` or `ms (wall clock)`.

use std::sync::{Arc, Mutex, PoisonError};

use criterion::Throughput;
use criterion::measurement::{Measurement, ValueFormatter};
use oit_gpu::{FrameTimings, TimingSource};

/// The sum of recorded frame times, shared between the measurement and the benchmark routine.
#[derive(Debug, Clone)]
pub struct GpuClock {
    source: TimingSource,
    total_ms: Arc<Mutex<f64>>,
}

impl GpuClock {
    /// Adds one frame; returns the milliseconds added. A frame timed by another source than
    /// the clock's is an error, because the units printed would be wrong.
    pub fn record(&self, timings: &FrameTimings) -> Result<f64, String> {
        if timings.source != self.source {
            return Err(format!(
                "frame timed by {} but this measurement reports {}",
                timings.source.name(),
                self.source.name()
            ));
        }
        let ms = frame_ms(timings);
        *self.total_ms.lock().unwrap_or_else(PoisonError::into_inner) += ms;
        Ok(ms)
    }

    /// Everything recorded so far.
    pub fn total_ms(&self) -> f64 {
        *self.total_ms.lock().unwrap_or_else(PoisonError::into_inner)
    }

    pub fn source(&self) -> TimingSource {
        self.source
    }
}

/// A frame's time as results.json's `gpu_ms` counts it.
pub fn frame_ms(timings: &FrameTimings) -> f64 {
    match timings.source {
        TimingSource::Timestamp => timings.total_ms,
        TimingSource::WallClock => timings.wall_ms,
    }
}

/// The measurement: values are milliseconds of recorded frame time.
#[derive(Debug, Clone)]
pub struct GpuTime {
    clock: GpuClock,
    formatter: GpuMsFormatter,
}

impl GpuTime {
    /// A measurement and the clock the benchmark routine records frames into. `source` is the
    /// adapter's (`GpuTimer::new(&ctx).source()`).
    pub fn new(source: TimingSource) -> (GpuTime, GpuClock) {
        let clock = GpuClock {
            source,
            total_ms: Arc::new(Mutex::new(0.0)),
        };
        (
            GpuTime {
                clock: clock.clone(),
                formatter: GpuMsFormatter { source },
            },
            clock,
        )
    }
}

impl Measurement for GpuTime {
    type Intermediate = f64;
    type Value = f64;

    fn start(&self) -> f64 {
        self.clock.total_ms()
    }

    fn end(&self, start: f64) -> f64 {
        self.clock.total_ms() - start
    }

    fn add(&self, a: &f64, b: &f64) -> f64 {
        a + b
    }

    fn zero(&self) -> f64 {
        0.0
    }

    fn to_f64(&self, value: &f64) -> f64 {
        *value
    }

    fn formatter(&self) -> &dyn ValueFormatter {
        &self.formatter
    }
}

/// Prints milliseconds (scaled to s, µs or ns when more readable) labelled with the source.
#[derive(Debug, Clone, Copy)]
pub struct GpuMsFormatter {
    source: TimingSource,
}

/// (factor from ms, unit) for a typical value in ms.
fn time_scale(typical_ms: f64, source: TimingSource) -> (f64, &'static str) {
    let gpu = source == TimingSource::Timestamp;
    let a = typical_ms.abs();
    if a >= 1e3 {
        (1e-3, if gpu { "s (GPU)" } else { "s (wall clock)" })
    } else if a >= 1.0 || a == 0.0 {
        (1.0, if gpu { "ms (GPU)" } else { "ms (wall clock)" })
    } else if a >= 1e-3 {
        (1e3, if gpu { "µs (GPU)" } else { "µs (wall clock)" })
    } else {
        (1e6, if gpu { "ns (GPU)" } else { "ns (wall clock)" })
    }
}

/// (factor from per-second, unit) for a typical rate.
fn rate_scale(typical_per_s: f64, what: &str, source: TimingSource) -> (f64, &'static str) {
    let gpu = source == TimingSource::Timestamp;
    let prefix = if typical_per_s >= 1e9 {
        (1e-9, 3)
    } else if typical_per_s >= 1e6 {
        (1e-6, 2)
    } else if typical_per_s >= 1e3 {
        (1e-3, 1)
    } else {
        (1.0, 0)
    };
    const ELEMENTS: [[&str; 4]; 2] = [
        [
            "elem/s (wall clock)",
            "Kelem/s (wall clock)",
            "Melem/s (wall clock)",
            "Gelem/s (wall clock)",
        ],
        [
            "elem/s (GPU)",
            "Kelem/s (GPU)",
            "Melem/s (GPU)",
            "Gelem/s (GPU)",
        ],
    ];
    const BYTES: [[&str; 4]; 2] = [
        [
            "B/s (wall clock)",
            "KB/s (wall clock)",
            "MB/s (wall clock)",
            "GB/s (wall clock)",
        ],
        ["B/s (GPU)", "KB/s (GPU)", "MB/s (GPU)", "GB/s (GPU)"],
    ];
    let table = if what == "bytes" { &BYTES } else { &ELEMENTS };
    (prefix.0, table[usize::from(gpu)][prefix.1])
}

/// Amount per iteration and whether it is bytes (decimal prefixes throughout).
fn amount(throughput: &Throughput) -> (f64, &'static str) {
    match *throughput {
        Throughput::Bits(b) => (b as f64 / 8.0, "bytes"),
        Throughput::Bytes(b) | Throughput::BytesDecimal(b) => (b as f64, "bytes"),
        Throughput::Elements(e) | Throughput::ElementsAndBytes { elements: e, .. } => {
            (e as f64, "elements")
        }
    }
}

impl ValueFormatter for GpuMsFormatter {
    fn scale_values(&self, typical_ms: f64, values: &mut [f64]) -> &'static str {
        let (factor, unit) = time_scale(typical_ms, self.source);
        values.iter_mut().for_each(|v| *v *= factor);
        unit
    }

    fn scale_throughputs(
        &self,
        typical_ms: f64,
        throughput: &Throughput,
        values: &mut [f64],
    ) -> &'static str {
        let (per_iter, what) = amount(throughput);
        let per_s = |ms: f64| if ms > 0.0 { per_iter * 1e3 / ms } else { 0.0 };
        let (factor, unit) = rate_scale(per_s(typical_ms), what, self.source);
        values.iter_mut().for_each(|v| *v = per_s(*v) * factor);
        unit
    }

    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        // Values are kept in milliseconds.
        "ms"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn timings(source: TimingSource, total_ms: f64, wall_ms: f64) -> FrameTimings {
        FrameTimings {
            source,
            total_ms,
            passes: Vec::new(),
            wall_ms,
        }
    }

    #[test]
    fn measurement_is_the_time_recorded_between_start_and_end() {
        let (m, clock) = GpuTime::new(TimingSource::Timestamp);
        clock
            .record(&timings(TimingSource::Timestamp, 1.5, 9.0))
            .unwrap();
        let start = m.start();
        clock
            .record(&timings(TimingSource::Timestamp, 0.25, 9.0))
            .unwrap();
        clock
            .record(&timings(TimingSource::Timestamp, 0.5, 9.0))
            .unwrap();
        assert_eq!(m.end(start), 0.75);
        assert_eq!(m.add(&0.75, &0.25), 1.0);
        assert_eq!(m.to_f64(&m.zero()), 0.0);
    }

    #[test]
    fn wall_clock_frames_count_their_wall_time_and_sources_cannot_mix() {
        let (m, clock) = GpuTime::new(TimingSource::WallClock);
        let start = m.start();
        assert_eq!(
            clock.record(&timings(TimingSource::WallClock, 0.0, 4.0)),
            Ok(4.0)
        );
        assert!(
            clock
                .record(&timings(TimingSource::Timestamp, 1.0, 4.0))
                .unwrap_err()
                .contains("timestamp")
        );
        assert_eq!(m.end(start), 4.0);
    }

    #[test]
    fn units_name_the_source_and_scale() {
        let (m, _) = GpuTime::new(TimingSource::Timestamp);
        let mut v = [0.5, 0.25];
        assert_eq!(m.formatter().scale_values(0.5, &mut v), "µs (GPU)");
        assert_eq!(v, [500.0, 250.0]);
        let mut v = [2.0];
        assert_eq!(m.formatter().scale_values(2.0, &mut v), "ms (GPU)");
        assert_eq!(v, [2.0]);
        let (w, _) = GpuTime::new(TimingSource::WallClock);
        let mut v = [2500.0];
        assert_eq!(w.formatter().scale_values(2500.0, &mut v), "s (wall clock)");
        assert_eq!(v, [2.5]);
    }

    #[test]
    fn throughput_is_per_second_of_recorded_time() {
        let (m, _) = GpuTime::new(TimingSource::Timestamp);
        // 2 million fragments in 4 ms = 500 million per second.
        let mut v = [4.0];
        let unit = m
            .formatter()
            .scale_throughputs(4.0, &Throughput::Elements(2_000_000), &mut v);
        assert_eq!(unit, "Melem/s (GPU)");
        assert_eq!(v, [500.0]);
    }
}
