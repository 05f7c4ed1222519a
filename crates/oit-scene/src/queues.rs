//! Render queues as the exact reference composites them (docs/scene-format.md, "Render
//! queues"): an engine draws (render group, queue) levels in increasing order, each level's
//! fragments in perfect back-to-front order, with one depth buffer for the whole frame (no
//! depth clear between render groups). Transparent fragments therefore composite front to back
//! by level descending, then depth; a transparent fragment behind a depth-writing transparent
//! fragment of a lower level fails that fragment's depth test.

use crate::{Draw, RenderQueue, Scene};

/// Where a draw's fragments sit in the exact compositing order: render group, then queue.
/// Lower levels are drawn first, so their transparent fragments end up underneath.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct QueueLevel {
    pub group: u32,
    pub queue: RenderQueue,
}

impl Scene {
    /// The queue the exact reference composites a draw in: the file's `render_queue`, else the
    /// one pygfx derives from the material alone (mode and `depth_write`). The per-object
    /// method is not read: it says how an engine approximates the object, not what the right
    /// answer is (pygfx derives queue 2400 for a dithered object, which would otherwise move a
    /// blended object under every queue-3000 one).
    pub fn exact_queue_of(&self, draw: &Draw) -> RenderQueue {
        let m = self.material_of(draw);
        draw.ordering
            .queue
            .unwrap_or_else(|| RenderQueue::derived(m.mode, m.depth_write, None))
    }

    /// A draw's [`QueueLevel`] in the exact compositing order.
    pub fn queue_level(&self, draw: &Draw) -> QueueLevel {
        QueueLevel {
            group: draw.ordering.group,
            queue: self.exact_queue_of(draw),
        }
    }

    /// The distinct levels of the transparent draws, ascending.
    pub fn transparent_levels(&self) -> Vec<QueueLevel> {
        let mut levels: Vec<QueueLevel> = self
            .draws
            .iter()
            .filter(|d| self.material_of(d).mode.is_transparent())
            .map(|d| self.queue_level(d))
            .collect();
        levels.sort_unstable();
        levels.dedup();
        levels
    }

    /// Whether render queues (or groups) change the exact answer: transparent draws in more
    /// than one level. With one level the answer is depth order alone, bit for bit as without
    /// queues (a depth-writing transparent draw hides nothing within its own level: everything
    /// behind it was drawn before it).
    pub fn has_queue_effects(&self) -> bool {
        self.transparent_levels().len() > 1
    }

    /// The first opaque or mask draw (index into `draws`) that an engine would draw after some
    /// transparent draw, and that transparent draw: it would replace transparent fragments in
    /// front of it, which no depth-ordered compositing models. `None` when every opaque level
    /// is at most every transparent level (the loader refuses the other case).
    pub fn opaque_after_transparent(&self) -> Option<(usize, usize)> {
        let (first_transparent, _) = self
            .draws
            .iter()
            .enumerate()
            .filter(|(_, d)| self.material_of(d).mode.is_transparent())
            .map(|(i, d)| (i, self.queue_level(d)))
            .min_by_key(|&(_, level)| level)?;
        let lowest = self.queue_level(&self.draws[first_transparent]);
        let opaque = self.draws.iter().position(|d| {
            !self.material_of(d).mode.is_transparent() && self.queue_level(d) > lowest
        })?;
        Some((opaque, first_transparent))
    }
}
