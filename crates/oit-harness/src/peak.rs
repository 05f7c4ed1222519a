//! Peak resident memory of the process per scene of a comparison (Linux): the kernel's
//! high-water mark `VmHWM` is reset to the current resident size by writing `5` to
//! `/proc/self/clear_refs` when a scene starts, and read from `/proc/self/status` when it
//! ends. On lavapipe GPU memory is host memory, so the figure includes the scene's uploads and
//! every technique's buffers. Elsewhere (or where `/proc` refuses the reset) there is no
//! figure, never a guess.

use std::path::Path;

/// Measures one scene's peak; [`ScenePeak::finish`] returns it in bytes.
#[derive(Debug)]
pub(crate) struct ScenePeak {
    /// Whether the high-water mark was reset at the start: without it `VmHWM` would be the
    /// process's peak so far, not the scene's.
    reset: bool,
}

impl ScenePeak {
    /// Resets the high-water mark to the memory resident now.
    pub(crate) fn start() -> ScenePeak {
        ScenePeak {
            reset: std::fs::write("/proc/self/clear_refs", "5").is_ok(),
        }
    }

    /// The most resident memory since [`ScenePeak::start`], in bytes; `None` off Linux or when
    /// the reset or the read failed.
    pub(crate) fn finish(self) -> Option<u64> {
        if !self.reset {
            return None;
        }
        let status = std::fs::read_to_string(Path::new("/proc/self/status")).ok()?;
        vm_hwm_bytes(&status)
    }
}

/// `VmHWM:   123456 kB` of a `/proc/PID/status` text, in bytes.
fn vm_hwm_bytes(status: &str) -> Option<u64> {
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let mut words = line["VmHWM:".len()..].split_whitespace();
    let value: u64 = words.next()?.parse().ok()?;
    match words.next()? {
        "kB" => value.checked_mul(1024),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn high_water_mark_is_read_in_bytes() {
        let status = "Name:\toit\nVmPeak:\t 9000 kB\nVmHWM:\t   123456 kB\nVmRSS:\t  100 kB\n";
        assert_eq!(vm_hwm_bytes(status), Some(123_456 * 1024));
        assert_eq!(vm_hwm_bytes("VmRSS:\t100 kB\n"), None);
        assert_eq!(vm_hwm_bytes("VmHWM:\t100 MB\n"), None);
        assert_eq!(vm_hwm_bytes("VmHWM:\tlots kB\n"), None);
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn a_scene_peak_covers_what_it_allocated_and_not_what_came_before() {
        // Touch 256 MiB and release it, then measure a "scene" that touches 16 MiB: its peak
        // covers the 16 and stays well below the process's earlier high-water mark.
        let before = vec![1u8; 256 << 20];
        std::hint::black_box(&before);
        drop(before);
        let status = std::fs::read_to_string("/proc/self/status").unwrap();
        let process_peak = vm_hwm_bytes(&status).unwrap();
        assert!(process_peak >= 256 << 20, "{process_peak}");
        let peak = ScenePeak::start();
        let during = vec![1u8; 16 << 20];
        std::hint::black_box(&during);
        let bytes = peak.finish().expect("Linux has VmHWM and clear_refs");
        drop(during);
        assert!(bytes >= 16 << 20, "{bytes}");
        assert!(
            bytes + (128 << 20) < process_peak,
            "{bytes} vs {process_peak}"
        );
    }
}
