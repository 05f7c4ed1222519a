//! How often each composite guard fired in one frame: counted by an untimed compute pass over
//! the accumulation targets right after the timed composite, with the composite's own function
//! (slot order matches shaders/wboit_composite.wgsl).

/// Number of u32 counters the counting pass writes, in [`GuardCounts`] order.
pub const GUARD_SLOTS: u32 = 8;

/// Per-frame guard counts, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GuardCounts {
    /// Pixels the composite ran on (the whole target): the denominator of the rest.
    pub pixels: u32,
    /// Pixels with transparent coverage (revealage below 1).
    pub covered: u32,
    /// An accumulation channel overflowed (Σ C·w or Σ α·w beyond the format): Inf or NaN, or
    /// exactly the format's largest finite value (lavapipe saturates fp16 blends at 65504
    /// instead of producing Inf). Inf became the largest finite value, NaN and −Inf 0.
    pub accum_overflow: u32,
    /// Covered, but Σ α·w was zero (every weight underflowed, or α = 0 with coverage from
    /// rounding): the average colour was set to black instead of dividing by zero.
    pub zero_weight: u32,
    /// The average colour Σ C·w / Σ α·w was non-finite, negative or above the final target's
    /// safe maximum, and was clamped.
    pub average_clamped: u32,
    /// The revealage (or the weighted average's (1 − Σα/n)^n) was NaN or outside [0, 1] and was
    /// clamped.
    pub reveal_clamped: u32,
    /// Weighted sums were non-zero but the revealage stayed exactly 1: the layers' coverage was
    /// lost (R8 revealage rounds α < 1/510 away) and they do not show.
    pub reveal_lost: u32,
    /// Revealage exactly 0 (α = 1 layers, or underflow): the background is fully hidden.
    pub opaque: u32,
}

impl GuardCounts {
    /// Builds from the counter slots (missing slots read as 0).
    pub fn from_slots(words: &[u32]) -> Self {
        let w = |i: usize| words.get(i).copied().unwrap_or(0);
        GuardCounts {
            pixels: w(0),
            covered: w(1),
            accum_overflow: w(2),
            zero_weight: w(3),
            average_clamped: w(4),
            reveal_clamped: w(5),
            reveal_lost: w(6),
            opaque: w(7),
        }
    }

    /// Pixels where a guard changed the output (the informational `covered`, `pixels` and
    /// `opaque` excluded).
    pub fn fired(&self) -> u32 {
        self.accum_overflow + self.zero_weight + self.average_clamped + self.reveal_clamped
    }
}

impl std::fmt::Display for GuardCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "pixels {} covered {} accum_overflow {} zero_weight {} average_clamped {} reveal_clamped {} reveal_lost {} opaque {}",
            self.pixels,
            self.covered,
            self.accum_overflow,
            self.zero_weight,
            self.average_clamped,
            self.reveal_clamped,
            self.reveal_lost,
            self.opaque
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_in_shader_order() {
        let g = GuardCounts::from_slots(&[1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(
            (g.pixels, g.covered, g.accum_overflow, g.zero_weight),
            (1, 2, 3, 4)
        );
        assert_eq!(
            (g.average_clamped, g.reveal_clamped, g.reveal_lost, g.opaque),
            (5, 6, 7, 8)
        );
        assert_eq!(g.fired(), 3 + 4 + 5 + 6);
        assert_eq!(GuardCounts::from_slots(&[9]).covered, 0);
    }

    /// The shader's counter array and count are these.
    #[test]
    fn the_composite_shader_has_these_slots() {
        let wgsl = include_str!("../shaders/wboit_composite.wgsl");
        for line in [
            format!("array<atomic<u32>, {GUARD_SLOTS}>"),
            format!("const GUARD_COUNT: u32 = {GUARD_SLOTS}u;"),
        ] {
            assert!(
                wgsl.contains(&line),
                "shaders/wboit_composite.wgsl lacks `{line}`"
            );
        }
    }
}
