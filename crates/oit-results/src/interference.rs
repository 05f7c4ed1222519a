//! How much of the machine's CPU time went elsewhere while frames were timed.
//!
//! On a software adapter (lavapipe) the "GPU" is this process's threads, and a virtual machine
//! may lose its cores to the hypervisor (steal) or share them with a build: a frame timed then
//! is slower for reasons that are not the technique's. Runs are timed one after the other, so
//! such a spell distorts their ratios too. The harness therefore samples the kernel's CPU
//! accounting (Linux `/proc/stat` and `/proc/self/stat`) around the timed frames and records
//! the share of the machine's CPU time that was stolen or spent by other processes; reports
//! mark timings taken while it was high. Elsewhere nothing is recorded (and nothing claimed).

use serde::{Deserialize, Serialize};

/// Above this share of the machine's CPU time lost to steal and other processes, a timing is
/// marked in reports: its absolute value and its ratios to runs timed at other moments may be
/// off by about that much.
pub const NOTABLE: f64 = 0.10;

/// Windows shorter than this (CPU time over all CPUs: 20 ticks of the kernel's 10 ms clock)
/// are too coarse to judge alone; several are judged together ([`Interference::combine`]).
pub const MIN_CPU_SECONDS: f64 = 0.2;

/// The kernel's CPU accounting at one moment, in clock ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CpuSample {
    /// Every state of every CPU (the first line of `/proc/stat`, guest time excluded as it is
    /// already in user time).
    total: u64,
    /// Time the CPUs ran anything: user, nice, system, irq and softirq.
    busy: u64,
    /// Time the hypervisor ran something else on this machine's CPUs.
    steal: u64,
    /// This process's user and system time, all threads.
    own: u64,
}

/// The share of the machine's CPU time, over a timed window, that went elsewhere.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interference {
    /// Taken by the hypervisor (steal), 0 to 1.
    pub steal: f64,
    /// Spent by other processes (busy time minus this process's own), 0 to 1.
    pub other_processes: f64,
    /// Length of the window, seconds of CPU time over all CPUs.
    pub cpu_seconds: f64,
}

impl Interference {
    /// The shares between two samples, or None when no tick passed or a counter went back.
    pub fn between(start: CpuSample, end: CpuSample, ticks_per_second: u64) -> Option<Self> {
        let total = end.total.checked_sub(start.total)?;
        if total == 0 || ticks_per_second == 0 {
            return None;
        }
        let steal = end.steal.checked_sub(start.steal)?;
        let busy = end.busy.checked_sub(start.busy)?;
        let own = end.own.checked_sub(start.own)?;
        // The two counters tick separately, so this process can appear to have used a tick
        // more than the machine did: that is rounding, not negative work.
        let others = busy.saturating_sub(own);
        Some(Interference {
            steal: steal as f64 / total as f64,
            other_processes: others as f64 / total as f64,
            cpu_seconds: total as f64 / ticks_per_second as f64,
        })
    }

    /// The share lost in all.
    pub fn lost(&self) -> f64 {
        self.steal + self.other_processes
    }

    /// Whether the window is long enough to judge ([`MIN_CPU_SECONDS`]).
    pub fn conclusive(&self) -> bool {
        self.cpu_seconds >= MIN_CPU_SECONDS
    }

    /// Whether reports mark the timing: conclusive and over [`NOTABLE`].
    pub fn notable(&self) -> bool {
        self.conclusive() && self.lost() > NOTABLE
    }

    /// Several windows as one, each weighted by its length; None for none.
    pub fn combine(windows: impl IntoIterator<Item = Interference>) -> Option<Interference> {
        let (mut seconds, mut steal, mut others) = (0.0, 0.0, 0.0);
        for w in windows {
            seconds += w.cpu_seconds;
            steal += w.steal * w.cpu_seconds;
            others += w.other_processes * w.cpu_seconds;
        }
        (seconds > 0.0).then(|| Interference {
            steal: steal / seconds,
            other_processes: others / seconds,
            cpu_seconds: seconds,
        })
    }

    /// "steal 35 %, other processes 4 %".
    pub fn describe(&self) -> String {
        format!(
            "steal {:.0} %, other processes {:.0} %",
            100.0 * self.steal,
            100.0 * self.other_processes
        )
    }
}

/// Samples the CPU accounting now; None where it cannot be read (not Linux, no procfs).
pub fn sample() -> Option<CpuSample> {
    let stat = std::fs::read_to_string("/proc/stat").ok()?;
    let own = std::fs::read_to_string("/proc/self/stat").ok()?;
    parse(&stat, &own)
}

/// Clock ticks per second of `/proc` ([`sample`]): USER_HZ, 100 on every Linux architecture
/// the harness builds for (the kernel fixes it for user space whatever its internal HZ).
pub const TICKS_PER_SECOND: u64 = 100;

/// [`CpuSample`] from the text of `/proc/stat` and `/proc/self/stat`.
fn parse(stat: &str, own: &str) -> Option<CpuSample> {
    let line = stat.lines().find(|l| l.starts_with("cpu "))?;
    let fields: Vec<u64> = line
        .split_whitespace()
        .skip(1)
        .map(|f| f.parse().ok())
        .collect::<Option<_>>()?;
    // user nice system idle iowait irq softirq steal [guest guest_nice]
    if fields.len() < 8 {
        return None;
    }
    let (user, nice, system, idle, iowait, irq, softirq, steal) = (
        fields[0], fields[1], fields[2], fields[3], fields[4], fields[5], fields[6], fields[7],
    );
    // The command name (field 2) is in parentheses and may hold spaces: count from the last
    // ')'. utime and stime are fields 14 and 15, the 12th and 13th after it.
    let after = &own[own.rfind(')')? + 1..];
    let mut rest = after.split_whitespace().skip(11);
    let utime: u64 = rest.next()?.parse().ok()?;
    let stime: u64 = rest.next()?.parse().ok()?;
    Some(CpuSample {
        total: user + nice + system + idle + iowait + irq + softirq + steal,
        busy: user + nice + system + irq + softirq,
        steal,
        own: utime + stime,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const OWN: &str = "4242 (oit (bench) x) R 1 4242 4242 0 -1 4194560 2000 0 0 0 \
                       150 30 0 0 20 0 3 0 100 0 0";

    #[test]
    fn parses_the_machine_line_and_this_process_past_a_name_with_spaces() {
        let stat = "cpu  1000 10 200 5000 40 5 6 300 0 0\ncpu0 500 5 100 2500 20 2 3 150 0 0\n";
        let s = parse(stat, OWN).expect("well-formed");
        assert_eq!(s.total, 1000 + 10 + 200 + 5000 + 40 + 5 + 6 + 300);
        assert_eq!(s.busy, 1000 + 10 + 200 + 5 + 6);
        assert_eq!(s.steal, 300);
        assert_eq!(s.own, 180);
    }

    #[test]
    fn malformed_accounting_is_none() {
        assert_eq!(parse("cpu  1 2 3\n", OWN), None);
        assert_eq!(parse("intr 5\n", OWN), None);
        assert_eq!(parse("cpu  1 2 3 4 5 6 7 x\n", OWN), None);
        assert_eq!(parse("cpu  1 2 3 4 5 6 7 8\n", "12 (name) R 1"), None);
    }

    fn sample(total: u64, busy: u64, steal: u64, own: u64) -> CpuSample {
        CpuSample {
            total,
            busy,
            steal,
            own,
        }
    }

    #[test]
    fn shares_are_of_the_whole_machine_over_the_window() {
        // 2 CPUs for 1 s = 200 ticks: this process used 100, another 20, the hypervisor 60.
        let a = sample(1000, 400, 50, 300);
        let b = sample(1200, 520, 110, 400);
        let i = Interference::between(a, b, 100).expect("long enough");
        assert_eq!(i.steal, 0.3);
        assert_eq!(i.other_processes, 0.1);
        assert_eq!(i.cpu_seconds, 2.0);
        assert!((i.lost() - 0.4).abs() < 1e-12);
        assert!(i.notable());
        assert_eq!(i.describe(), "steal 30 %, other processes 10 %");
    }

    #[test]
    fn a_quiet_window_is_not_marked_and_own_time_over_busy_is_rounding() {
        let a = sample(0, 0, 0, 0);
        // The process's counter ran a tick ahead of the machine's.
        let b = sample(200, 100, 2, 101);
        let i = Interference::between(a, b, 100).expect("long enough");
        assert_eq!(i.other_processes, 0.0);
        assert_eq!(i.steal, 0.01);
        assert!(!i.notable());
    }

    #[test]
    fn short_windows_are_inconclusive_alone_and_backwards_ones_say_nothing() {
        let a = sample(1000, 400, 50, 300);
        // 19 ticks, all stolen: not enough to mark a run.
        let short = Interference::between(a, sample(1019, 400, 69, 300), 100).expect("a tick");
        assert_eq!(short.steal, 1.0);
        assert!(!short.conclusive());
        assert!(!short.notable());
        assert_eq!(Interference::between(a, a, 100), None);
        assert_eq!(
            Interference::between(a, sample(900, 400, 50, 300), 100),
            None
        );
        assert_eq!(
            Interference::between(a, sample(2000, 300, 50, 300), 100),
            None
        );
    }

    #[test]
    fn combined_windows_weigh_each_by_its_length() {
        let w = |steal, other_processes, cpu_seconds| Interference {
            steal,
            other_processes,
            cpu_seconds,
        };
        // Three short windows: none conclusive, together 0.25 s with 36 % stolen.
        let all = Interference::combine([w(0.5, 0.0, 0.1), w(0.0, 0.0, 0.05), w(0.4, 0.2, 0.1)])
            .expect("windows");
        assert!((all.cpu_seconds - 0.25).abs() < 1e-12);
        assert!((all.steal - 0.36).abs() < 1e-12);
        assert!((all.other_processes - 0.08).abs() < 1e-12);
        assert!(all.notable());
        assert_eq!(Interference::combine([]), None);
    }

    #[test]
    fn this_machine_can_be_sampled_where_procfs_exists() {
        if !std::path::Path::new("/proc/stat").exists() {
            eprintln!("skipped: no /proc/stat on this system (interference is not recorded)");
            return;
        }
        let a = super::sample().expect("procfs readable");
        // Burn some CPU so that this process's own time moves.
        let mut x = 0u64;
        let start = std::time::Instant::now();
        while start.elapsed().as_millis() < 300 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let b = super::sample().expect("procfs readable");
        assert!(
            b.own > a.own,
            "300 ms of spinning shows in this process's CPU time"
        );
        assert!(b.total > a.total);
    }
}
