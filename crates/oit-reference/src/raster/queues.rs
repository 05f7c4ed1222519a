//! Render queues in the stored path (docs/scene-format.md, "Render queues"): in a scene whose
//! transparent draws span several (render group, queue) levels, each pixel's depth-sorted
//! list loses the fragments that a depth-writing transparent fragment of a lower level hides,
//! and the rest are ordered by level, highest first (it is drawn last, so it is in front),
//! nearest first within a level. Scenes with one level never come here (their output is the
//! same bit for bit as before queues were modelled), nor through the in-order path.

use oit_scene::Scene;

use super::*;
use crate::fragments::Ranks;

/// Per draw: its level among the scene's transparent levels (0 is drawn first) and whether it
/// writes depth; built once per render, looked up by triangle rank.
#[derive(Debug)]
pub(crate) struct QueueTable {
    ranks: Ranks,
    /// Per index into `scene.draws`: (level, writes depth). Opaque draws never reach a list.
    levels: Vec<(u32, bool)>,
}

impl QueueTable {
    /// `None` when queues do not change the answer ([`Scene::has_queue_effects`]).
    pub(crate) fn new(scene: &Scene) -> Option<Self> {
        let distinct = scene.transparent_levels();
        if distinct.len() < 2 {
            return None;
        }
        let levels = scene
            .draws
            .iter()
            .map(|d| {
                let level = scene.queue_level(d);
                let index = distinct.partition_point(|&l| l < level) as u32;
                let m = scene.material_of(d);
                (index, m.mode.is_transparent() && m.depth_write)
            })
            .collect();
        Some(QueueTable {
            ranks: Ranks::new(scene),
            levels,
        })
    }

    /// The level and depth write of the triangle of transparent key `key`.
    #[inline]
    fn of(&self, key: u64) -> (u32, bool) {
        let (draw, _) = self.ranks.draw_and_triangle(u32::MAX - key as u32);
        self.levels[draw]
    }
}

/// Reorders pixel `p`'s depth-sorted list (`start[p]..end[p]`) for render queues: drops the
/// hidden fragments (shortening `end[p]`), orders the rest by level descending (stable: depth
/// order within a level) and marks the pixel tied where rounding decides an order or a depth
/// test that matters. Uses the sort scratch (`perm`, `merge_buffer`, `runs`: sized for the
/// tile's longest list), nothing else.
pub(super) fn order_by_queue(table: &QueueTable, s: &mut Scratch, p: usize, planes: &[f64]) {
    let (lo, hi) = (s.start[p] as usize, s.end[p] as usize);
    if hi - lo < 2 {
        return;
    }
    let depth = |key: u64| (key >> 32) as u32;
    // Ties, nearest first: every pair within the tie distance whose order matters (same level,
    // as the depth-only path checks) or whose depth test does (a depth writer of a lower level
    // and a fragment of a higher one).
    let mut tie = false;
    for k in lo + 1..hi {
        let dk = depth(s.keys[k]);
        let mut j = k;
        while j > lo && close(depth(s.keys[j - 1]), dk) {
            j -= 1;
            let ((la, wa), (lb, wb)) = (table.of(s.keys[j]), table.of(s.keys[k]));
            tie |= if la == lb {
                transparent_tie(&s.keys, &s.colors, &s.transmittance, planes, j, k)
            } else if (la < lb && wa) || (lb < la && wb) {
                rounding_tie(
                    depth(s.keys[j]),
                    dk,
                    transparent_plane(s.keys[j], planes),
                    transparent_plane(s.keys[k], planes),
                )
            } else {
                false
            };
        }
    }
    s.tie[p] |= tie;
    // Hidden fragments, nearest first: a fragment is hidden when a depth writer of a lower
    // level lies nearer or at the same depth (every depth test is strict). Kept ones move down
    // in place, in depth order.
    let coloured = !s.transmittance.is_empty();
    let mut lowest_writer = u32::MAX;
    let mut kept = lo;
    let mut i = lo;
    while i < hi {
        let d = depth(s.keys[i]);
        let mut j = i;
        while j < hi && depth(s.keys[j]) == d {
            let (level, writes) = table.of(s.keys[j]);
            if writes {
                lowest_writer = lowest_writer.min(level);
            }
            j += 1;
        }
        for k in i..j {
            if table.of(s.keys[k]).0 <= lowest_writer {
                s.keys[kept] = s.keys[k];
                s.colors[kept] = s.colors[k];
                if coloured {
                    s.transmittance[kept] = s.transmittance[k];
                }
                kept += 1;
            }
        }
        i = j;
    }
    s.end[p] = kept as u32;
    // Level descending, then list position (depth order): unique keys, so the sort is stable.
    let keys = &s.keys[lo..kept];
    s.perm.clear();
    s.perm.extend(0..keys.len() as u32);
    sort_by_key(
        &mut s.perm,
        |i| (u64::from(u32::MAX - table.of(keys[i as usize]).0) << 32) | u64::from(i),
        &mut s.merge_buffer,
        &mut s.runs,
    );
    let transmittance = if coloured {
        &mut s.transmittance[lo..kept]
    } else {
        &mut []
    };
    permute(
        &mut s.perm,
        &mut s.keys[lo..kept],
        &mut s.colors[lo..kept],
        transmittance,
    );
}
