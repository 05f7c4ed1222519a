//! The tile's reusable storage ([`Scratch`]), what each buffer costs per pixel and slot, and the
//! memory budget a tile is held to; a tile's statistics ([`TileStats`]).

use super::*;

/// One row's run of pixels covered by a transparent triangle, recorded by the coverage pass
/// and replayed by the shading pass.
#[derive(Debug, Clone, Copy)]
pub(super) struct Span {
    /// Index into the set-up triangles.
    pub(super) triangle: u32,
    /// Tile-local row and pixels `first..end` of it.
    pub(super) row: u16,
    pub(super) first: u16,
    pub(super) end: u16,
}

/// Reusable per-thread tile storage.
///
/// Transparent fragments are written straight into per-pixel lists: a coverage pass counts
/// each pixel's covered transparent triangles (an upper bound on what it stores, since the
/// cutoff discard and the opaque depth test only remove fragments), the prefix sum gives each
/// pixel its slots `start[p]..start[p + 1]`, and the shading pass appends at `end[p]`. Keys and
/// colours are separate arrays so that sorting only touches keys and 4-byte indices.
///
/// Every buffer's capacity is set through [`Scratch::ensure`] before it is filled, so that the
/// sum of all capacities ([`Scratch::bytes`]) never exceeds the limit the tile runs under.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    pub(super) opaque_key: Vec<u64>,
    pub(super) opaque_color: Vec<[f32; 3]>,
    pub(super) all_count: Vec<u32>,
    /// Per pixel: fragments in the undecided band of a mask cutoff; whether its composite
    /// depends on a precision tie.
    pub(super) undecided: Vec<u32>,
    pub(super) tie: Vec<bool>,
    pub(super) start: Vec<u32>,
    pub(super) end: Vec<u32>,
    pub(super) spans: Vec<Span>,
    /// Per slot: sort key and (premultiplied RGB, alpha). After the sort, each pixel's slots
    /// are in front-to-back order (permuted in place).
    pub(super) keys: Vec<u64>,
    pub(super) colors: Vec<[f32; 4]>,
    /// The last pixel's sorting permutation, and the merge sort's buffers.
    pub(super) perm: Vec<u32>,
    pub(super) merge_buffer: Vec<u32>,
    pub(super) runs: Vec<usize>,
    /// Only while a tile is rendered in slices: per row `w + 1` covered-transparent counts
    /// (a difference array until summed), and spans per row.
    pub(super) counts: Vec<u32>,
    pub(super) row_spans: Vec<u32>,
    /// Per slot, only in scenes with coloured transmission: the fragment's transmittance
    /// (`1 − α` in every channel for a scalar-alpha fragment), f64 as it is composited.
    pub(super) transmittance: Vec<[f64; 3]>,
    /// Only while a tile is composited in arrival order ([`render_rect_in_order`]): per pixel
    /// its state, and in scenes with coloured transmission its per-channel transmittance;
    /// the rectangles (first row, end row, first column, end column) the stored path renders.
    pub(super) in_order: Vec<InOrderPixel>,
    pub(super) in_order_transmittance: Vec<[f64; 3]>,
    pub(super) stored_rects: Vec<[u32; 4]>,
    /// Most bytes held since the tile started, the transient of a reallocation included.
    pub(super) high_water: u64,
}

/// A scratch buffer as [`Scratch::ensure`] sees it: a `Vec` of any element type.
pub(super) trait Buffer {
    fn len(&self) -> usize;
    fn capacity(&self) -> usize;
    fn element_bytes(&self) -> usize;
    fn shrink_to(&mut self, capacity: usize);
    /// Frees the contents and allocates exactly `capacity` (no copy of the old contents).
    fn replace(&mut self, capacity: usize);
    /// Grows to exactly `capacity`, keeping the contents (a reallocation may copy them).
    fn grow(&mut self, capacity: usize);
}

impl<T> Buffer for Vec<T> {
    fn len(&self) -> usize {
        Vec::len(self)
    }
    fn capacity(&self) -> usize {
        Vec::capacity(self)
    }
    fn element_bytes(&self) -> usize {
        size_of::<T>()
    }
    fn shrink_to(&mut self, capacity: usize) {
        self.truncate(capacity);
        Vec::shrink_to(self, capacity);
    }
    fn replace(&mut self, capacity: usize) {
        *self = Vec::new();
        self.reserve_exact(capacity);
    }
    fn grow(&mut self, capacity: usize) {
        self.reserve_exact(capacity - Vec::len(self));
    }
}

/// What a buffer must hold at an [`Scratch::ensure`] point.
#[derive(Debug, Clone, Copy)]
pub(super) enum Want {
    /// Its contents are needed: keep them and make room for at least this many elements.
    Keep(usize),
    /// Its contents are not needed: room for this many elements.
    Fresh(usize),
}

/// Buffers of [`Scratch::buffers`]: the per-pixel state, the spans, the per-slot arrays, the
/// sort buffers, the slicing counts and the in-order state, in that order.
pub(super) const BUFFERS: usize = 19;
/// The per-pixel state both paths share: opaque key and colour, fragment and undecided
/// counts, tie flag.
pub(super) const SHARED_STATE: usize = 5;
pub(super) const START: usize = 5;
pub(super) const SPANS: usize = 7;
pub(super) const COUNTS: usize = 13;
pub(super) const TRANSMITTANCE: usize = 15;
pub(super) const IN_ORDER: usize = 16;
pub(super) const IN_ORDER_TRANSMITTANCE: usize = 17;
pub(super) const STORED_RECTS: usize = 18;

/// Bytes of per-pixel state a tile keeps besides its fragment lists: opaque key and colour,
/// fragment count, undecided count, list start and end, tie flag.
pub(super) const PER_PIXEL_BYTES: u64 =
    (size_of::<u64>() + size_of::<[f32; 3]>() + 4 * size_of::<u32>() + size_of::<bool>()) as u64;

/// Bytes per transparent fragment slot: key and colour.
pub(super) const PER_SLOT_BYTES: u64 = (size_of::<u64>() + size_of::<[f32; 4]>()) as u64;

/// Bytes per slot a scene with coloured transmission adds: the f64 transmittance.
pub(super) const TRANSMITTANCE_SLOT_BYTES: u64 = size_of::<[f64; 3]>() as u64;

/// Bytes per slot: [`PER_SLOT_BYTES`], plus the transmittance where the scene has one.
pub(super) fn slot_bytes(coloured: bool) -> u64 {
    PER_SLOT_BYTES
        + if coloured {
            TRANSMITTANCE_SLOT_BYTES
        } else {
            0
        }
}

/// Bytes per recorded span.
pub(super) const SPAN_BYTES: u64 = size_of::<Span>() as u64;

/// Entries of the merge sort's run list for a list of `n`: every run but the last holds at
/// least two keys (keys are unique), plus the leading 0. Short lists never use it.
pub(super) fn runs_needed(n: usize) -> usize {
    if n > SHORT_LIST { n / 2 + 2 } else { 0 }
}

/// Exact scratch bytes to render a rectangle of `pixels` pixels holding `slots` covered
/// transparent fragments in `spans` row spans, the longest pixel list `longest`: what
/// [`render_rect`] reserves with the same numbers (`coloured`: the scene has coloured
/// transmission).
pub(super) fn rect_bytes(pixels: u64, slots: u64, spans: u64, longest: u64, coloured: bool) -> u64 {
    // Per slot the sort may need the list's permutation and the merge buffer (4 + 4 bytes).
    pixels * PER_PIXEL_BYTES
        + size_of::<u32>() as u64
        + slots * slot_bytes(coloured)
        + spans * SPAN_BYTES
        + longest * 2 * size_of::<u32>() as u64
        + runs_needed(longest as usize) as u64 * size_of::<usize>() as u64
}

/// Bytes of the counts a sliced `width`×`height` tile keeps while its slices render.
pub(super) fn count_bytes(width: u64, height: u64) -> u64 {
    (height * (width + 1) + height) * size_of::<u32>() as u64
}

/// The least memory a `width`×`height` tile can be rendered in: its per-pixel state, or its
/// slicing counts and one pixel's state and outputs, whichever is more (so any tile without
/// fragments fits, and one with fragments fits when each of its pixels does).
pub(crate) fn tile_minimum_bytes(width: u32, height: u32) -> u64 {
    let (w, h) = (u64::from(width), u64::from(height));
    rect_bytes(w * h, 0, 0, 0, false)
        .max(count_bytes(w, h) + rect_bytes(1, 0, 0, 0, false) + OUTPUT_BYTES)
}

impl Scratch {
    pub(super) fn buffers(&mut self) -> [&mut dyn Buffer; BUFFERS] {
        [
            &mut self.opaque_key,
            &mut self.opaque_color,
            &mut self.all_count,
            &mut self.undecided,
            &mut self.tie,
            &mut self.start,
            &mut self.end,
            &mut self.spans,
            &mut self.keys,
            &mut self.colors,
            &mut self.perm,
            &mut self.merge_buffer,
            &mut self.runs,
            &mut self.counts,
            &mut self.row_spans,
            &mut self.transmittance,
            &mut self.in_order,
            &mut self.in_order_transmittance,
            &mut self.stored_rects,
        ]
    }

    /// Bytes allocated: the sum of all buffer capacities.
    pub(crate) fn bytes(&mut self) -> u64 {
        self.buffers()
            .iter()
            .map(|b| (b.capacity() * b.element_bytes()) as u64)
            .sum()
    }

    /// Frees every buffer.
    pub(super) fn release(&mut self) {
        *self = Scratch {
            high_water: self.high_water,
            ..Scratch::default()
        };
    }

    /// Sets capacities so that every buffer can hold what `want` asks, without the sum of
    /// capacities exceeding `limit`, even while a kept buffer is reallocated (old and new
    /// allocation both count then). Grows by doubling where that fits, else exactly; frees
    /// what is not wanted when even that does not fit. False (capacities possibly reduced)
    /// when `want` cannot fit. Out of line: called a few times per tile, not per fragment.
    #[inline(never)]
    pub(super) fn ensure(&mut self, want: [Want; BUFFERS], limit: u64) -> bool {
        let mut buffers = self.buffers();
        let mut need = [0u64; BUFFERS];
        let mut size = [0u64; BUFFERS];
        let mut cap = [0u64; BUFFERS];
        for (i, b) in buffers.iter().enumerate() {
            size[i] = b.element_bytes() as u64;
            cap[i] = b.capacity() as u64;
            need[i] = match want[i] {
                Want::Keep(n) => n.max(b.len()) as u64,
                Want::Fresh(n) => n as u64,
            };
        }
        if need.iter().zip(&cap).all(|(n, c)| n <= c) {
            return true;
        }
        // Bytes after growing to `target` (keeping larger capacities unless `shrink`), and the
        // peak while the largest kept buffer is reallocated.
        let footprint = |target: &[u64; BUFFERS], shrink: bool| {
            let mut total = 0;
            let mut copy = 0;
            for i in 0..BUFFERS {
                let c = if shrink {
                    target[i]
                } else {
                    target[i].max(cap[i])
                };
                total += c * size[i];
                if matches!(want[i], Want::Keep(_)) && target[i] > cap[i] {
                    copy = copy.max(cap[i] * size[i]);
                }
            }
            total + copy
        };
        let doubled: [u64; BUFFERS] = std::array::from_fn(|i| {
            if need[i] > cap[i] {
                need[i].max(2 * cap[i])
            } else {
                need[i]
            }
        });
        let before: u64 = (0..BUFFERS).map(|i| cap[i] * size[i]).sum();
        let (target, shrink, peak) = if footprint(&doubled, false) <= limit {
            (doubled, false, footprint(&doubled, false))
        } else if footprint(&need, false) <= limit {
            (need, false, footprint(&need, false))
        } else if footprint(&need, true) <= limit {
            (need, true, before.max(footprint(&need, true)))
        } else {
            return false;
        };
        if shrink {
            for (i, b) in buffers.iter_mut().enumerate() {
                if cap[i] > target[i] {
                    if matches!(want[i], Want::Fresh(_)) {
                        b.replace(target[i] as usize);
                    } else {
                        b.shrink_to(target[i] as usize);
                    }
                }
            }
        }
        // Fresh buffers first: they free before they allocate.
        for (i, b) in buffers.iter_mut().enumerate() {
            if matches!(want[i], Want::Fresh(_)) && (b.capacity() as u64) < target[i] {
                b.replace(target[i] as usize);
            }
        }
        for (i, b) in buffers.iter_mut().enumerate() {
            if matches!(want[i], Want::Keep(_)) && (b.capacity() as u64) < target[i] {
                b.grow(target[i] as usize);
            }
        }
        self.high_water = self.high_water.max(peak);
        true
    }
}

/// Statistics of one tile or band, summed.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct TileStats {
    pub fragments: u64,
    pub transparent_fragments: u64,
    pub composited_fragments: u64,
    pub max_layers: u32,
    pub covered_pixels: u64,
    pub undecided_fragments: u64,
    pub undecided_pixels: u64,
    pub precision_tie_pixels: u64,
    pub raster: Duration,
    pub sort: Duration,
    pub composite: Duration,
    pub peak_tile_bytes: u64,
    /// Tiles rendered in slices because their fragments did not fit at once.
    pub sliced_tiles: u64,
    /// Tiles composited in arrival order ([`render_rect_in_order`]).
    pub in_order_tiles: u64,
    /// Tiles composited in order in row bands ([`in_order_in_bands`]).
    pub banded_tiles: u64,
    /// Pixels composited from stored, sorted lists.
    pub stored_pixels: u64,
    /// Tiles that stopped compositing in order because most of their pixels were disordered
    /// ([`mostly_disordered`]) and were rendered with stored lists.
    pub given_up_tiles: u64,
}

/// Why [`render_rect_in_order`] stopped without rendering its rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum InOrderStop {
    /// The per-pixel state or a stored rectangle does not fit the limit.
    OverLimit,
    /// Most of the rectangle is disordered ([`mostly_disordered`]): the stored path is cheaper.
    Disordered,
}

impl TileStats {
    pub(crate) fn merge(mut self, o: TileStats) -> TileStats {
        self.fragments += o.fragments;
        self.transparent_fragments += o.transparent_fragments;
        self.composited_fragments += o.composited_fragments;
        self.max_layers = self.max_layers.max(o.max_layers);
        self.covered_pixels += o.covered_pixels;
        self.undecided_fragments += o.undecided_fragments;
        self.undecided_pixels += o.undecided_pixels;
        self.precision_tie_pixels += o.precision_tie_pixels;
        self.raster += o.raster;
        self.sort += o.sort;
        self.composite += o.composite;
        self.peak_tile_bytes = self.peak_tile_bytes.max(o.peak_tile_bytes);
        self.sliced_tiles += o.sliced_tiles;
        self.in_order_tiles += o.in_order_tiles;
        self.banded_tiles += o.banded_tiles;
        self.stored_pixels += o.stored_pixels;
        self.given_up_tiles += o.given_up_tiles;
        self
    }
}
