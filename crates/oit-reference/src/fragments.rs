//! The reference's per-pixel transparent fragment lists, handed to a visitor as they are
//! composited ([`render_visiting`]): the same fragments, in the same order with the same
//! tie-breaks, that make [`crate::Reference::image`].

use oit_scene::Scene;

use crate::{Reference, ReferenceError, ReferenceOptions};

/// What [`render_visiting`] calls with each rectangle of pixels it has composited (a tile, a
/// band or a slice of one), from worker threads, each pixel exactly once.
pub type FragmentVisitor<'v> = dyn Fn(&RectFragments<'_>) + Sync + 'v;

/// One transparent fragment of a pixel's list: one that survived the opaque depth test
/// (strictly nearer than the nearest opaque surface, and nearer than the far plane).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelFragment {
    /// Index of its draw in `scene.draws`.
    pub draw: usize,
    /// Triangle index within the draw.
    pub triangle: u32,
    /// Rank of the triangle, `(draw.id, triangle index)` in ascending order from 0: unique,
    /// and at equal depth the higher rank is in front.
    pub rank: u32,
    /// Window depth as stored (f32, clamped to [0, 1]).
    pub depth: f32,
    /// Coverage α (`1 − mean transmittance` for coloured transmission).
    pub alpha: f32,
    /// Premultiplied linear RGB, as composited.
    pub premultiplied: [f32; 3],
}

/// The sorted transparent lists of one rectangle of pixels, nearest fragment first (in a scene
/// with render queue effects: in compositing order, level descending then nearest first, and
/// without the fragments depth writers of lower levels hide).
pub struct RectFragments<'a> {
    /// Frame coordinates of the top-left pixel.
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
    pub(crate) start: &'a [u32],
    pub(crate) end: &'a [u32],
    pub(crate) keys: &'a [u64],
    pub(crate) colors: &'a [[f32; 4]],
    /// Per slot, only in scenes with coloured transmission (empty otherwise).
    pub(crate) transmittance: &'a [[f64; 3]],
    /// Per pixel: the nearest opaque surface's key and colour; `far` where there is none.
    pub(crate) opaque_key: &'a [u64],
    pub(crate) opaque_color: &'a [[f32; 3]],
    pub(crate) far: u64,
    pub(crate) background: [f64; 3],
    pub(crate) ranks: &'a Ranks,
    pub(crate) reverse_z: bool,
}

impl std::fmt::Debug for RectFragments<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RectFragments")
            .field("x0", &self.x0)
            .field("y0", &self.y0)
            .field("width", &self.width)
            .field("height", &self.height)
            .finish_non_exhaustive()
    }
}

impl RectFragments<'_> {
    /// Pixels of the rectangle (row-major).
    pub fn pixel_count(&self) -> usize {
        self.start.len()
    }

    /// Frame coordinates of pixel `i` of the rectangle.
    pub fn position(&self, i: usize) -> (u32, u32) {
        let w = self.width as usize;
        (self.x0 + (i % w) as u32, self.y0 + (i / w) as u32)
    }

    /// Layers of pixel `i`.
    pub fn layers(&self, i: usize) -> usize {
        (self.end[i] - self.start[i]) as usize
    }

    /// What pixel `i`'s list is composited over: the nearest opaque surface's colour, or the
    /// scene background where there is none (as the reference composites it).
    pub fn behind(&self, i: usize) -> [f64; 3] {
        if self.opaque_key[i] == self.far {
            self.background
        } else {
            self.opaque_color[i].map(f64::from)
        }
    }

    /// Per-channel transmittance of pixel `i`'s fragments, nearest first: `1 − α` in every
    /// channel unless the scene has coloured transmission.
    pub fn transmittances(&self, i: usize) -> impl ExactSizeIterator<Item = [f64; 3]> + '_ {
        let slots = self.start[i] as usize..self.end[i] as usize;
        slots.map(move |slot| match self.transmittance.get(slot) {
            Some(&t) => t,
            None => [1.0 - f64::from(self.colors[slot][3]); 3],
        })
    }

    /// Pixel `i`'s fragments, nearest first (the order they are composited in).
    pub fn fragments(&self, i: usize) -> impl ExactSizeIterator<Item = PixelFragment> + '_ {
        let slots = self.start[i] as usize..self.end[i] as usize;
        slots.map(move |slot| {
            let key = self.keys[slot];
            let rank = u32::MAX - key as u32;
            let (draw, triangle) = self.ranks.draw_and_triangle(rank);
            let [r, g, b, a] = self.colors[slot];
            PixelFragment {
                draw,
                triangle,
                rank,
                depth: depth_of_key((key >> 32) as u32, self.reverse_z),
                alpha: a,
                premultiplied: [r, g, b],
            }
        })
    }
}

/// The inverse of `raster::depth_key`: the f32 window depth a key was made from.
pub(crate) fn depth_of_key(key: u32, reverse_z: bool) -> f32 {
    let ordered = key ^ if reverse_z { u32::MAX } else { 0 };
    let bits = if ordered & 0x8000_0000 != 0 {
        ordered ^ 0x8000_0000
    } else {
        !ordered
    };
    f32::from_bits(bits)
}

/// Ranks back to draws: ranks number the triangles in `(draw.id, triangle index)` order.
#[derive(Debug, Clone)]
pub struct Ranks {
    /// First rank of each draw, in id order, and one past the last.
    first: Vec<u64>,
    /// Indices into `scene.draws`, in id order.
    draws: Vec<usize>,
    /// Per index into `scene.draws`: its position in `draws`.
    position: Vec<usize>,
}

impl Ranks {
    /// The rank table of `scene`, built as `set_up` ranks its triangles.
    pub fn new(scene: &Scene) -> Self {
        let mut draws: Vec<usize> = (0..scene.draws.len()).collect();
        draws.sort_by_key(|&i| scene.draws[i].id);
        let mut first = Vec::with_capacity(draws.len() + 1);
        let mut total = 0u64;
        for &i in &draws {
            first.push(total);
            total += u64::from(scene.draws[i].triangle_count());
        }
        first.push(total);
        let mut position = vec![0; draws.len()];
        for (p, &i) in draws.iter().enumerate() {
            position[i] = p;
        }
        Ranks {
            first,
            draws,
            position,
        }
    }

    /// The draw (index into `scene.draws`) and triangle index of `rank`.
    pub fn draw_and_triangle(&self, rank: u32) -> (usize, u32) {
        let rank = u64::from(rank);
        // The last draw whose first rank is at most `rank` and that has triangles.
        let d = self.first.partition_point(|&f| f <= rank).saturating_sub(1);
        let d = d.min(self.draws.len().saturating_sub(1));
        (self.draws[d], (rank - self.first[d]) as u32)
    }

    /// The first rank of draw `draw` (index into `scene.draws`).
    pub fn first_rank(&self, draw: usize) -> u64 {
        self.first[self.position[draw]]
    }
}

/// Renders the reference of `scene` ([`crate::try_render`]) and hands every pixel's sorted
/// transparent list to `visit`, a rectangle at a time, from the worker threads. Every tile
/// takes the stored path (lists sorted per pixel; [`ReferenceOptions::in_order`] is ignored),
/// so the memory budget covers the lists as it does there; the reference returned is the
/// same bit for bit as without a visitor.
pub fn render_visiting(
    scene: &Scene,
    options: &ReferenceOptions,
    visit: &FragmentVisitor<'_>,
) -> Result<Reference, ReferenceError> {
    let ranks = Ranks::new(scene);
    crate::render_with(scene, options, Some((visit, &ranks)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::depth_key;

    #[test]
    fn depth_of_key_inverts_depth_key() {
        for d in [0.0f32, 1e-30, 0.25, 0.5, 0.999_999, 1.0] {
            for reverse_z in [false, true] {
                assert_eq!(depth_of_key(depth_key(d, reverse_z), reverse_z), d);
            }
        }
    }
}
