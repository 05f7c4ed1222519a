//! Per-tile rasterization, sorting and compositing. All storage lives in a reusable [`Scratch`]
//! sized by the tile, never by the frame.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use rayon::iter::{
    IndexedParallelIterator, IntoParallelIterator, ParallelBridge, ParallelIterator,
};
use rayon::slice::ParallelSliceMut;

use oit_scene::{Material, Shaded, Texels, Texture};

use crate::composite::{composite_coloured_iter, composite_iter, over_step, over_step_coloured};
use crate::setup::{
    HALF, ONE, PixelBox, SetupTriangle, Triangles, same_plane, undecided, undecided_textured,
};

/// One row's run of pixels covered by a transparent triangle, recorded by the coverage pass
/// and replayed by the shading pass.
#[derive(Debug, Clone, Copy)]
struct Span {
    /// Index into the set-up triangles.
    triangle: u32,
    /// Tile-local row and pixels `first..end` of it.
    row: u16,
    first: u16,
    end: u16,
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
    opaque_key: Vec<u64>,
    opaque_color: Vec<[f32; 3]>,
    all_count: Vec<u32>,
    /// Per pixel: fragments in the undecided band of a mask cutoff; whether its composite
    /// depends on a precision tie.
    undecided: Vec<u32>,
    tie: Vec<bool>,
    start: Vec<u32>,
    end: Vec<u32>,
    spans: Vec<Span>,
    /// Per slot: sort key and (premultiplied RGB, alpha). After the sort, each pixel's slots
    /// are in front-to-back order (permuted in place).
    keys: Vec<u64>,
    colors: Vec<[f32; 4]>,
    /// The last pixel's sorting permutation, and the merge sort's buffers.
    perm: Vec<u32>,
    merge_buffer: Vec<u32>,
    runs: Vec<usize>,
    /// Only while a tile is rendered in slices: per row `w + 1` covered-transparent counts
    /// (a difference array until summed), and spans per row.
    counts: Vec<u32>,
    row_spans: Vec<u32>,
    /// Per slot, only in scenes with coloured transmission: the fragment's transmittance
    /// (`1 − α` in every channel for a scalar-alpha fragment), f64 as it is composited.
    transmittance: Vec<[f64; 3]>,
    /// Only while a tile is composited in arrival order ([`render_rect_in_order`]): per pixel
    /// its state, and in scenes with coloured transmission its per-channel transmittance;
    /// the rectangles (first row, end row, first column, end column) the stored path renders.
    in_order: Vec<InOrderPixel>,
    in_order_transmittance: Vec<[f64; 3]>,
    stored_rects: Vec<[u32; 4]>,
    /// Most bytes held since the tile started, the transient of a reallocation included.
    high_water: u64,
}

/// A scratch buffer as [`Scratch::ensure`] sees it: a `Vec` of any element type.
trait Buffer {
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
enum Want {
    /// Its contents are needed: keep them and make room for at least this many elements.
    Keep(usize),
    /// Its contents are not needed: room for this many elements.
    Fresh(usize),
}

/// Buffers of [`Scratch::buffers`]: the per-pixel state, the spans, the per-slot arrays, the
/// sort buffers, the slicing counts and the in-order state, in that order.
const BUFFERS: usize = 19;
/// The per-pixel state both paths share: opaque key and colour, fragment and undecided
/// counts, tie flag.
const SHARED_STATE: usize = 5;
const START: usize = 5;
const SPANS: usize = 7;
const COUNTS: usize = 13;
const TRANSMITTANCE: usize = 15;
const IN_ORDER: usize = 16;
const IN_ORDER_TRANSMITTANCE: usize = 17;
const STORED_RECTS: usize = 18;

/// Bytes of per-pixel state a tile keeps besides its fragment lists: opaque key and colour,
/// fragment count, undecided count, list start and end, tie flag.
const PER_PIXEL_BYTES: u64 =
    (size_of::<u64>() + size_of::<[f32; 3]>() + 4 * size_of::<u32>() + size_of::<bool>()) as u64;

/// Bytes per transparent fragment slot: key and colour.
const PER_SLOT_BYTES: u64 = (size_of::<u64>() + size_of::<[f32; 4]>()) as u64;

/// Bytes per slot a scene with coloured transmission adds: the f64 transmittance.
const TRANSMITTANCE_SLOT_BYTES: u64 = size_of::<[f64; 3]>() as u64;

/// Bytes per slot: [`PER_SLOT_BYTES`], plus the transmittance where the scene has one.
fn slot_bytes(coloured: bool) -> u64 {
    PER_SLOT_BYTES
        + if coloured {
            TRANSMITTANCE_SLOT_BYTES
        } else {
            0
        }
}

/// Bytes per recorded span.
const SPAN_BYTES: u64 = size_of::<Span>() as u64;

/// Entries of the merge sort's run list for a list of `n`: every run but the last holds at
/// least two keys (keys are unique), plus the leading 0. Short lists never use it.
fn runs_needed(n: usize) -> usize {
    if n > SHORT_LIST { n / 2 + 2 } else { 0 }
}

/// Exact scratch bytes to render a rectangle of `pixels` pixels holding `slots` covered
/// transparent fragments in `spans` row spans, the longest pixel list `longest`: what
/// [`render_rect`] reserves with the same numbers (`coloured`: the scene has coloured
/// transmission).
fn rect_bytes(pixels: u64, slots: u64, spans: u64, longest: u64, coloured: bool) -> u64 {
    // Per slot the sort may need the list's permutation and the merge buffer (4 + 4 bytes).
    pixels * PER_PIXEL_BYTES
        + size_of::<u32>() as u64
        + slots * slot_bytes(coloured)
        + spans * SPAN_BYTES
        + longest * 2 * size_of::<u32>() as u64
        + runs_needed(longest as usize) as u64 * size_of::<usize>() as u64
}

/// Bytes of the counts a sliced `width`×`height` tile keeps while its slices render.
fn count_bytes(width: u64, height: u64) -> u64 {
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
    fn buffers(&mut self) -> [&mut dyn Buffer; BUFFERS] {
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
    fn release(&mut self) {
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
    fn ensure(&mut self, want: [Want; BUFFERS], limit: u64) -> bool {
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
enum InOrderStop {
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

/// Maps an f32 window depth to a u32 whose ascending unsigned order is nearest first, i.e. the
/// order [`oit_scene::Camera::nearer`] defines: `nearer(a, b)` ⇔ `depth_key(a) < depth_key(b)`.
/// Written without branches so that a batch of pixels is keyed with SIMD integer operations.
#[inline(always)]
pub(crate) const fn depth_key(depth: f32, reverse_z: bool) -> u32 {
    let bits = depth.to_bits();
    // Order-preserving map from f32 to u32: negative values are flipped entirely (all ones
    // from the arithmetic shift), others get the sign bit set.
    let negative = ((bits as i32) >> 31) as u32;
    let ordered = bits ^ (negative | 0x8000_0000);
    // Reverse-Z: larger depth is nearer, so invert to put it first.
    ordered ^ if reverse_z { u32::MAX } else { 0 }
}

/// Opaque key: nearest first, then the lower (draw.id, triangle index) rank wins a tie.
fn opaque_key(dkey: u32, rank: u32) -> u64 {
    (u64::from(dkey) << 32) | u64::from(rank)
}

/// Window depths (as [`depth_key`]s) closer than this many f32 ulps are a *precision tie*:
/// which one is nearer is decided by rounding (vertex transform, divide, interpolation: a few
/// ulps each on the GPU), not by the geometry. The exception is an exact tie of two
/// constant-depth triangles on one plane (`SetupTriangle::plane_depth`): every rasterizer
/// computes the same depth for both, so draw order decides them, as documented.
pub const PRECISION_TIE_ULPS: u32 = 4;

/// Whether two depth keys are within the tie distance ([`PRECISION_TIE_ULPS`]); the rare
/// true case then asks [`rounding_tie`]. Kept tiny: it sits in the per-fragment loops.
#[inline(always)]
fn close(a: u32, b: u32) -> bool {
    a.abs_diff(b) <= PRECISION_TIE_ULPS
}

/// For depth keys within the tie distance: whether rounding decides them, i.e. not an exact tie
/// of two surfaces on one plane. Plane depths are NaN unless flat, and NaN for the far plane
/// (whose depth is rounded too). Out of line: the per-fragment loops only pay for [`close`].
#[cold]
#[inline(never)]
fn rounding_tie(a: u32, b: u32, plane_a: f64, plane_b: f64) -> bool {
    a != b || !same_plane(plane_a, plane_b)
}

/// Plane depth of the surface behind a pixel's opaque key (NaN for the far sentinel).
#[inline(always)]
fn opaque_plane(key: u64, far: u64, planes: &[f64]) -> f64 {
    if key == far {
        f64::NAN
    } else {
        planes[(key as u32) as usize]
    }
}

/// Plane depth of a transparent key's triangle (low half `u32::MAX − rank`).
#[inline(always)]
fn transparent_plane(key: u64, planes: &[f64]) -> f64 {
    planes[(u32::MAX - key as u32) as usize]
}

/// For two neighbouring slots of a sorted list whose depths are within the tie distance:
/// whether rounding decides their order and the order matters (their colours, or their
/// transmittances where the scene has them, differ).
#[cold]
#[inline(never)]
fn transparent_tie(
    keys: &[u64],
    colors: &[[f32; 4]],
    transmittance: &[[f64; 3]],
    planes: &[f64],
    a: usize,
    b: usize,
) -> bool {
    let (ka, kb) = (keys[a], keys[b]);
    let differ = colors[a] != colors[b]
        || (!transmittance.is_empty() && transmittance[a] != transmittance[b]);
    differ
        && rounding_tie(
            (ka >> 32) as u32,
            (kb >> 32) as u32,
            transparent_plane(ka, planes),
            transparent_plane(kb, planes),
        )
}

/// Whether some vertex depth of `tri` is within the tie distance of the far plane.
/// `far` is [`far_key`].
fn near_far(tri: &SetupTriangle, far: u64, reverse_z: bool) -> bool {
    let far = (far >> 32) as u32;
    tri.z
        .iter()
        .any(|&z| close(depth_key(z.clamp(0.0, 1.0) + 0.0, reverse_z), far))
}

/// Whether a fragment (depth key `dkey` on a triangle of plane depth `plane`) ties with the
/// surface behind a pixel's opaque key `opaque` (the far plane when it is `far`).
#[inline(always)]
fn ties_opaque(dkey: u32, plane: f64, opaque: u64, far: u64, planes: &[f64]) -> bool {
    let nearest = (opaque >> 32) as u32;
    close(dkey, nearest) && rounding_tie(dkey, nearest, plane, opaque_plane(opaque, far, planes))
}

/// The opaque key of a pixel no opaque fragment reached: the cleared far depth with the lowest
/// rank, so a fragment exactly at far never beats it (`key < far` fails, as `Less` against a
/// buffer cleared to 1.0 does, or `Greater` against 0.0 under reverse-Z).
fn far_key(reverse_z: bool) -> u64 {
    let far = if reverse_z { 0.0 } else { 1.0 };
    opaque_key(depth_key(far, reverse_z), 0)
}

/// Transparent key: nearest first, then at equal depth the HIGHER rank is in front (it would
/// have been blended last in natural draw order).
fn transparent_key(dkey: u32, rank: u32) -> u64 {
    (u64::from(dkey) << 32) | u64::from(u32::MAX - rank)
}

/// What setup hands the ordering ([`in_bin_order`]): the set-up triangles and, written by the
/// setup tasks while their pieces were still in cache, each piece's sort key and bounding box
/// and each rank's plane depth. Ordering then never reads the set-up triangles (three passes
/// over them, one of them serial and one in random order, cost `particles` about 1.5 ms of a
/// 45 ms render at 1024²).
#[derive(Debug)]
pub(crate) struct SetUp {
    pub triangles: Triangles,
    /// Per piece, in id order ([`Triangles::id`]): [`bin_key`].
    pub keys: Vec<u128>,
    /// Per chunk of [`Triangles`], per piece: its `SetupTriangle::bbox`.
    pub bboxes: Vec<Vec<PixelBox>>,
    /// Per rank: the plane depth of its last piece ([`Ordered::plane_depths`]).
    pub plane_depths: Vec<f64>,
}

/// The set-up triangles in the order they are binned and what binning reads of them, in
/// compact lists: binning never walks the set-up triangles (only the tiles read them, each
/// its own bin).
#[derive(Debug)]
pub(crate) struct Ordered {
    /// The pieces, where setup wrote them.
    pub triangles: Triangles,
    /// The order they are binned in: ids in `triangles`, each with its triangle's pixel
    /// bounding box (`SetupTriangle::bbox`), so that the binning passes read 20 sequential
    /// bytes per triangle instead of a cache line of a scattered struct.
    pub order: Vec<(u32, PixelBox)>,
    /// Per rank: the plane depth of a flat triangle, NaN otherwise (fan pieces share both)
    /// ([`TileContext::planes`]).
    pub plane_depths: Vec<f64>,
}

/// The key piece `id` is binned by ([`in_bin_order`]): opaque triangles first, in id (that is
/// rank) order, then transparent ones by [`transparent_key`] of their nearest vertex, the id
/// in the low 32 bits.
#[inline]
pub(crate) fn bin_key(t: &SetupTriangle, id: u32, reverse_z: bool) -> u128 {
    let key = if t.transparent {
        let nearest =
            t.z.iter()
                .map(|&z| depth_key(z.clamp(0.0, 1.0) + 0.0, reverse_z))
                .min()
                .unwrap_or(u32::MAX);
        transparent_key(nearest, t.key)
    } else {
        0
    };
    (u128::from(t.transparent) << 96) | (u128::from(key) << 32) | u128::from(id)
}

/// The order the set-up triangles are binned in, which every tile then sees: opaque
/// triangles in rank order, then transparent ones nearest first by their nearest vertex's key
/// (at equal depth the higher rank first, as [`transparent_key`] orders fragments). A
/// fragment's depth lies between its triangle's vertex depths, so where triangles' depth
/// ranges do not overlap (layers, billboards) each pixel's list is appended in key order and
/// its sort is one check. No result depends on the order: lists are sorted by their unique
/// keys, and the opaque pass keeps the nearest key whatever the order. The triangles
/// themselves stay where setup wrote them ([`Triangles`]).
pub(crate) fn in_bin_order(set_up: SetUp) -> Ordered {
    let SetUp {
        triangles,
        mut keys,
        bboxes,
        plane_depths,
    } = set_up;
    // Bare 16-byte keys, the bounding boxes gathered afterwards: moving 48-byte records
    // through the sort cost more than the sort.
    keys.par_sort_unstable();
    let order = keys
        .into_par_iter()
        .with_min_len(1024)
        .map(|k| {
            let id = k as u32;
            let (chunk, position) = Triangles::chunk_and_position(id);
            (id, bboxes[chunk][position])
        })
        .collect();
    Ordered {
        triangles,
        order,
        plane_depths,
    }
}

/// Bytes per triangle [`in_bin_order`] sorts, for the memory docs' test.
#[cfg(test)]
pub(crate) const SORT_KEY_BYTES: usize = size_of::<u128>();

/// Rectangle of a tile in pixels.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TileRect {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

/// Calls `f(row, first, end)` for every row of `tri`'s bounding box inside `tile` that has
/// covered pixel centres, with the covered pixels `first..end` of that row (tile-local
/// coordinates). Coverage is the exact top-left-rule test of the GPU, solved per row instead of
/// tested per pixel.
///
/// Edge i goes from vertex i+1 to vertex i+2 (opposite vertex i), with
/// `E(p) = (xb − xa)(py − ya) − (yb − ya)(px − xa)`, positive inside because the triangle was
/// normalised to positive area in y-down window coordinates. The top-left rule in that frame:
/// a *top* edge is horizontal with the interior below it, which is `dy == 0 && dx > 0`; a
/// *left* edge has the interior to its right, which is `dy < 0`. Pixel centres exactly on a
/// top or left edge are covered (`E >= 0`), on any other edge they are not (`E >= 1`, exact
/// because E is an integer). Along a row E is linear in the pixel index, so each edge admits a
/// half-line of pixels and a triangle covers one contiguous run per row ([`row_span`]).
#[inline(always)]
fn for_each_span(tri: &SetupTriangle, tile: TileRect, mut f: impl FnMut(u32, u32, u32)) {
    let x0 = tri.bbox[0].max(tile.x0);
    let y0 = tri.bbox[1].max(tile.y0);
    let x1 = tri.bbox[2].min(tile.x0 + tile.width - 1);
    let y1 = tri.bbox[3].min(tile.y0 + tile.height - 1);
    if x0 > x1 || y0 > y1 {
        return;
    }
    let px0 = i64::from(x0) * ONE + HALF;
    let py0 = i64::from(y0) * ONE + HALF;
    let px1 = i64::from(x1) * ONE + HALF;
    let py1 = i64::from(y1) * ONE + HALF;
    let mut row = [0i64; 3];
    let mut step_x = [0i64; 3];
    let mut step_y = [0i64; 3];
    let mut bias = [0i64; 3];
    let mut inside_everywhere = true;
    let (xs, ys) = tri.snapped();
    for i in 0..3 {
        let (a, b) = ((i + 1) % 3, (i + 2) % 3);
        let dx = xs[b] - xs[a];
        let dy = ys[b] - ys[a];
        let edge = |px: i64, py: i64| dx * (py - ys[a]) - dy * (px - xs[a]);
        let corners = [
            edge(px0, py0),
            edge(px1, py0),
            edge(px0, py1),
            edge(px1, py1),
        ];
        let top_left = (dy == 0 && dx > 0) || dy < 0;
        bias[i] = if top_left { 0 } else { 1 };
        // E is linear, so its extremes over the rectangle are at the corners: the rectangle is
        // entirely outside this edge when its best corner is, entirely inside when its worst is.
        if corners.iter().all(|&e| e < bias[i]) {
            return;
        }
        inside_everywhere &= corners.iter().all(|&e| e >= bias[i]);
        row[i] = corners[0];
        step_x[i] = -dy * ONE;
        step_y[i] = dx * ONE;
    }
    let (first, end) = (x0 - tile.x0, x1 + 1 - tile.x0);
    if inside_everywhere {
        for y in y0..=y1 {
            f(y - tile.y0, first, end);
        }
        return;
    }
    let width = i64::from(x1 - x0) + 1;
    for y in y0..=y1 {
        let (lo, hi) = row_span(row, step_x, bias, width);
        if lo < hi {
            f(y - tile.y0, first + lo as u32, first + hi as u32);
        }
        row[0] += step_y[0];
        row[1] += step_y[1];
        row[2] += step_y[2];
    }
}

/// The pixels `k` in `lo..hi` (`0 <= k < width`) of a row whose edge values
/// `e[i] + k·step[i]` are all `>= bias[i]`: exact integer solutions of the three half-lines.
#[inline(always)]
fn row_span(e: [i64; 3], step: [i64; 3], bias: [i64; 3], width: i64) -> (i64, i64) {
    let (mut lo, mut hi) = (0i64, width);
    for i in 0..3 {
        // Need k·step >= deficit.
        let deficit = bias[i] - e[i];
        let s = step[i];
        if s > 0 {
            if deficit > 0 {
                // k >= ceil(deficit / s); both positive.
                lo = lo.max((deficit + s - 1) / s);
            }
        } else if s < 0 {
            if deficit > 0 {
                return (0, 0);
            }
            // The row's last pixel is inside too: no bound from this edge.
            if e[i] + (width - 1) * s < bias[i] {
                // k <= floor(deficit / s) = floor(-deficit / -s); both non-negative.
                hi = hi.min(deficit / s + 1);
            }
        } else if deficit > 0 {
            return (0, 0);
        }
    }
    (lo, hi)
}

/// Pixels per batch of the shading kernel: the float arithmetic of neighbouring pixels is
/// independent, so it is written over small arrays that the compiler turns into SIMD.
const LANES: usize = 4;

/// Receives the fragments of [`shade_span`]. A trait with `#[inline(always)]` implementations
/// rather than a closure: LLVM left the transparent pass's closure out of line once it grew
/// (a call per fragment halved the reference's throughput).
trait Fragments {
    /// Pixel in the tile, [`depth_key`], shaded colour, whether α is in the cutoff's
    /// undecided band.
    fn fragment(&mut self, p: usize, dkey: u32, shaded: Shaded, undecided: bool);
}

/// The opaque pass of one triangle: nearest opaque fragment per pixel, fragment and
/// undecided counts, opaque precision ties.
struct OpaqueFragments<'a> {
    rank: u32,
    plane: f64,
    far: u64,
    planes: &'a [f64],
    opaque_key: &'a mut [u64],
    opaque_color: &'a mut [[f32; 3]],
    all_count: &'a mut [u32],
    undecided: &'a mut [u32],
    tie: &'a mut [bool],
}

impl Fragments for OpaqueFragments<'_> {
    #[inline(always)]
    fn fragment(&mut self, p: usize, dkey: u32, shaded: Shaded, undecided: bool) {
        if undecided {
            self.undecided[p] += 1;
        }
        let Shaded::Opaque(color) = shaded else {
            return;
        };
        self.all_count[p] += 1;
        let key = opaque_key(dkey, self.rank);
        let current = self.opaque_key[p];
        let tie = ties_opaque(dkey, self.plane, current, self.far, self.planes);
        if key < current {
            // The old nearest is the runner-up: if it is not within the tie distance, nothing
            // farther is.
            self.tie[p] = tie;
            self.opaque_key[p] = key;
            self.opaque_color[p] = color;
        } else {
            self.tie[p] |= tie;
        }
    }
}

/// What a transparent pass composites of a fragment: its premultiplied colour, its scalar α
/// (the opacity of a transmissive one) and, if transmissive, its per-channel transmittance.
/// None for what is not composited (discarded, or opaque).
#[inline(always)]
fn transparent_parts(shaded: Shaded) -> Option<([f32; 3], f32, Option<[f32; 3]>)> {
    match shaded {
        Shaded::Transparent {
            premultiplied,
            alpha,
        } => Some((premultiplied, alpha, None)),
        Shaded::Transmissive {
            premultiplied,
            opacity,
            transmittance,
        } => Some((premultiplied, opacity, Some(transmittance))),
        Shaded::Opaque(_) | Shaded::Discarded => None,
    }
}

/// The transparent pass: fragments strictly nearer than the opaque depth (or far) appended to
/// their pixel's list; cutoff discards, undecided counts, ties with the opaque surface.
struct TransparentFragments<'a> {
    /// Of the triangle being shaded.
    rank: u32,
    behind: Behind<'a>,
    keys: &'a mut [u64],
    colors: &'a mut [[f32; 4]],
    /// Per slot, empty unless the scene has coloured transmission.
    transmittance: &'a mut [[f64; 3]],
    end: &'a mut [u32],
    all_count: &'a mut [u32],
    undecided: &'a mut [u32],
    tie: &'a mut [bool],
    discarded: u64,
}

/// What a transparent fragment must lie strictly in front of to be composited: its pixel's
/// opaque surface, or the far plane where none is; shared by the transparent passes.
#[derive(Clone, Copy)]
struct Behind<'a> {
    far: u64,
    planes: &'a [f64],
    opaque_key: &'a [u64],
    /// False when no opaque fragment reached the tile: every opaque key is `far`, no load.
    any_opaque: bool,
    /// Of the triangle being shaded: its plane depth, and whether its fragments can tie with
    /// the opaque depth or the far plane.
    plane: f64,
    check_ties: bool,
}

impl Behind<'_> {
    /// The depth key fragment `dkey` at pixel `p` must be below, after flagging in `tie` a
    /// precision tie with what it is (kept or hidden by rounding when this close).
    #[inline(always)]
    fn nearest(&self, p: usize, dkey: u32, tie: &mut [bool]) -> u32 {
        let opaque = if self.any_opaque {
            self.opaque_key[p]
        } else {
            self.far
        };
        if self.check_ties && ties_opaque(dkey, self.plane, opaque, self.far, self.planes) {
            tie[p] = true;
        }
        (opaque >> 32) as u32
    }
}

/// The transmittance a transparent fragment gives what is behind it, per channel in f64: its
/// own for a transmissive one, `1 − α` in every channel otherwise.
#[inline(always)]
fn transmittance_of(alpha: f32, transmittance: Option<[f32; 3]>) -> [f64; 3] {
    match transmittance {
        Some(t) => t.map(f64::from),
        None => [1.0 - f64::from(alpha); 3],
    }
}

impl Fragments for TransparentFragments<'_> {
    #[inline(always)]
    fn fragment(&mut self, p: usize, dkey: u32, shaded: Shaded, undecided: bool) {
        if undecided {
            self.undecided[p] += 1;
        }
        let Some((premultiplied, alpha, transmittance)) = transparent_parts(shaded) else {
            self.all_count[p] -= 1;
            self.discarded += 1;
            return;
        };
        if dkey < self.behind.nearest(p, dkey, self.tie) {
            let slot = self.end[p] as usize;
            self.keys[slot] = transparent_key(dkey, self.rank);
            let [r, g, b] = premultiplied;
            self.colors[slot] = [r, g, b, alpha];
            if !self.transmittance.is_empty() {
                self.transmittance[slot] = transmittance_of(alpha, transmittance);
            }
            self.end[p] += 1;
        }
    }
}

/// Screen-linear window depth and perspective-correct shaded colour of the pixels
/// `first..end` of tile row `row`, handing each to `sink` in order ([`depth_key`] of the f32 depth; `undecided`: α is in the cutoff's undecided
/// band, [`crate::CUTOFF_UNDECIDED_BOUND`]).
///
/// Coverage comes from the snapped integer edge functions; the attribute weights come from
/// the *unsnapped* f32 window positions, as lavapipe interpolates (measured: a mask cutoff
/// decided on snapped weights differed from the GPU on one `foliage-cards` pixel). The f64
/// error is far below half an f32 ulp, so a constant-depth triangle gets exactly its depth
/// back and coplanar ties stay ties. Degenerate float triangles fall back to snapped weights.
/// Every value is computed by the same f64 operations in the same order per pixel (only the
/// row-constant product is hoisted), so batching changes no bit of the result.
// Indexed lane loops: the iterator form (`enumerate().take(n)`) compiled to markedly slower
// code here (callgrind: +20 % instructions, 3× the mispredicted branches).
#[allow(clippy::needless_range_loop)]
#[allow(
    clippy::too_many_arguments,
    reason = "the hot per-span entry: plain arguments stay in registers"
)]
#[inline(always)]
fn shade_span(
    tri: &SetupTriangle,
    textures: &[Texture],
    tile: TileRect,
    row: u32,
    first: u32,
    end: u32,
    reverse_z: bool,
    sink: &mut impl Fragments,
) {
    let y = tile.y0 + row;
    let base = (row * tile.width) as usize;
    if tri.inv_farea2 == 0.0 {
        let (xs, ys) = tri.snapped();
        for x in first..end {
            let px = i64::from(tile.x0 + x) * ONE + HALF;
            let pys = i64::from(y) * ONE + HALF;
            let l: [[f64; 1]; 3] = std::array::from_fn(|i| {
                let (a, b) = ((i + 1) % 3, (i + 2) % 3);
                let e = (xs[b] - xs[a]) * (pys - ys[a]) - (ys[b] - ys[a]) * (px - xs[a]);
                [e as f64 * tri.inv_area2]
            });
            let (depth, rgba) = attributes(tri, &l);
            let (shaded, open) = match tri.constant {
                Some(shaded) => (shaded, tri.constant_undecided),
                None if tri.textured => {
                    shade_textured(tri, &tri.material, textures, rgba[0], texcoords(tri, &l)[0])
                }
                None => (
                    tri.material.shade(rgba[0], Texels::UNTEXTURED),
                    tri.cutoff_rounds && undecided(&tri.material, rgba[0][3]),
                ),
            };
            sink.fragment(
                base + x as usize,
                depth_key(depth[0], reverse_z),
                shaded,
                open,
            );
        }
        return;
    }
    let row_weights = RowWeights::new(tri, tile, row);
    let weights = |x: u32| row_weights.at(x);
    if let Some(shaded) = tri.constant {
        let open = tri.constant_undecided;
        if let Some(dkey) = flat_depth_key(tri, reverse_z) {
            for x in first..end {
                sink.fragment(base + x as usize, dkey, shaded, open);
            }
            return;
        }
        for x in (first..end).step_by(LANES) {
            let dkey = depth_keys(depths(tri, &weights(x)), reverse_z);
            let p = base + x as usize;
            for j in 0..((end - x) as usize).min(LANES) {
                sink.fragment(p + j, dkey[j], shaded, open);
            }
        }
    } else if tri.textured {
        let material = tri.material;
        for x in (first..end).step_by(LANES) {
            let l = weights(x);
            let (depth, rgba) = attributes(tri, &l);
            let uv = texcoords(tri, &l);
            let dkey = depth_keys(depth, reverse_z);
            let p = base + x as usize;
            for j in 0..((end - x) as usize).min(LANES) {
                let (shaded, open) = shade_textured(tri, &material, textures, rgba[j], uv[j]);
                sink.fragment(p + j, dkey[j], shaded, open);
            }
        }
    } else {
        // A local copy, not loads through `tri` per fragment (the caller's stores could alias
        // it as far as the compiler knows).
        let material = tri.material;
        let cutoff_rounds = tri.cutoff_rounds;
        for x in (first..end).step_by(LANES) {
            let (depth, rgba) = attributes(tri, &weights(x));
            let dkey = depth_keys(depth, reverse_z);
            let p = base + x as usize;
            for j in 0..((end - x) as usize).min(LANES) {
                let open = cutoff_rounds && undecided(&material, rgba[j][3]);
                sink.fragment(
                    p + j,
                    dkey[j],
                    material.shade(rgba[j], Texels::UNTEXTURED),
                    open,
                );
            }
        }
    }
}

/// The depth key every fragment of `tri` has when its window depth is constant (bit-identical
/// at the vertices) and its float area is not zero, else None.
///
/// A constant depth interpolates to itself: Σ l_i·z in f64 is z·(1 ± 2^-50) (the weights sum
/// to 1 up to f64 rounding), which rounds back to the f32 z. So every fragment of a flat
/// triangle (layers, camera-facing billboards) has this key, bit-identical to what the
/// per-pixel path of [`shade_span`] computes.
#[inline(always)]
fn flat_depth_key(tri: &SetupTriangle, reverse_z: bool) -> Option<u32> {
    (tri.inv_farea2 != 0.0 && tri.z[0] == tri.z[1] && tri.z[1] == tri.z[2])
        .then(|| depth_key(tri.z[0].clamp(0.0, 1.0) + 0.0, reverse_z))
}

/// Barycentric weights along one tile row of a triangle with non-zero float area, from its
/// unsnapped f32 window positions ([`shade_span`]), a batch of [`LANES`] pixels at a time.
struct RowWeights {
    /// `E_i(px, py) = dx_i·(py − ya) − dy_i·(px − xa)`: the first product is constant along
    /// a row.
    along_row: [f64; 3],
    dy: [f64; 3],
    xa: [f64; 3],
    inv_farea2: f64,
    /// The tile's first pixel column.
    x0: u32,
}

impl RowWeights {
    #[inline(always)]
    fn new(tri: &SetupTriangle, tile: TileRect, row: u32) -> Self {
        let py = (tile.y0 + row) as f64 + 0.5;
        let (fx, fy) = tri.window();
        let mut w = RowWeights {
            along_row: [0.0; 3],
            dy: [0.0; 3],
            xa: [0.0; 3],
            inv_farea2: tri.inv_farea2,
            x0: tile.x0,
        };
        for i in 0..3 {
            let (a, b) = ((i + 1) % 3, (i + 2) % 3);
            w.along_row[i] = (fx[b] - fx[a]) * (py - fy[a]);
            w.dy[i] = fy[b] - fy[a];
            w.xa[i] = fx[a];
        }
        w
    }

    /// The weights of the pixels `x..x + LANES` of the row (tile-local).
    #[inline(always)]
    fn at(&self, x: u32) -> [[f64; LANES]; 3] {
        // Pixel centres; small integers plus 0.5, so the sum is exact.
        let px0 = (self.x0 + x) as f64 + 0.5;
        let px: [f64; LANES] = std::array::from_fn(|j| px0 + j as f64);
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                (self.along_row[i] - self.dy[i] * (px[j] - self.xa[i])) * self.inv_farea2
            })
        })
    }
}

/// Bounds (inclusive) on the depth key of every fragment of `tri` (non-zero float area), or
/// None for a sliver, whose weights round too loosely to bound this simply.
///
/// A covered pixel centre lies in the snapped triangle, whose vertices are within 1/512 px of
/// the float ones the interpolated depth plane passes through, so the plane's depth there is
/// a convex combination of its depths at the snapped vertices, each within |∇z|₁/512 of a
/// vertex depth. The f64 rounding of the weights and their sum adds a few units of 2^-53 of
/// (1 + 2·stretch)·Σ|z_i|, with `stretch` = (W + 1)(H + 1)/|2A| (W, H the float triangle's
/// extent in pixels, A its area): the magnitude of the edge-function terms over the area.
/// Both are taken with wide margins (1/256, 2^-48). The f32 rounding, the clamp and
/// [`depth_key`] are monotone, so the keys of the widened depth range bound the fragments'.
fn depth_key_bounds(tri: &SetupTriangle, reverse_z: bool) -> Option<(u32, u32)> {
    let (x, y) = tri.window();
    let z = tri.z.map(f64::from);
    let extent = |v: [f64; 3]| v[0].max(v[1]).max(v[2]) - v[0].min(v[1]).min(v[2]);
    let stretch = (extent(x) + 1.0) * (extent(y) + 1.0) * tri.inv_farea2.abs();
    if stretch.is_nan() || stretch > 64.0 {
        return None;
    }
    let zx = ((z[1] - z[0]) * (y[2] - y[0]) - (z[2] - z[0]) * (y[1] - y[0])) * tri.inv_farea2;
    let zy = ((z[2] - z[0]) * (x[1] - x[0]) - (z[1] - z[0]) * (x[2] - x[0])) * tri.inv_farea2;
    let rounding = (1.0 + 2.0 * stretch) * (z[0].abs() + z[1].abs() + z[2].abs());
    let margin = (zx.abs() + zy.abs()) / 256.0 + rounding * (2.0f64).powi(-48);
    let key = |v: f64| depth_key((v as f32).clamp(0.0, 1.0) + 0.0, reverse_z);
    let a = key(z[0].min(z[1]).min(z[2]) - margin);
    let b = key(z[0].max(z[1]).max(z[2]) + margin);
    margin.is_finite().then_some((a.min(b), a.max(b)))
}

/// One fragment of a textured triangle: the material's texture samples at `uv`, the material
/// rule, and whether α is in the cutoff's undecided band (widened by the texture's reach).
#[inline(always)]
fn shade_textured(
    tri: &SetupTriangle,
    material: &Material,
    textures: &[Texture],
    rgba: [f32; 4],
    uv: [f32; 2],
) -> (Shaded, bool) {
    let texels = material.texels(textures, uv);
    let open = tri.cutoff_rounds
        && match material.base_texture {
            Some(t) => {
                undecided_textured(material, &textures[t as usize], rgba[3], texels.base[3], uv)
            }
            None => undecided(material, rgba[3]),
        };
    (material.shade(rgba, texels), open)
}

/// Perspective-correct texture coordinates (weights / w, f32 as the shader receives them), by
/// the same steps as the colours in [`attributes`] with a plain division.
#[inline(always)]
fn texcoords<const N: usize>(tri: &SetupTriangle, l: &[[f64; N]; 3]) -> [[f32; 2]; N] {
    let uv = &tri.uv;
    std::array::from_fn(|j| {
        let pw: [f64; 3] = std::array::from_fn(|i| l[i][j] * tri.inv_w[i]);
        let sum = pw[0] + pw[1] + pw[2];
        std::array::from_fn(|k| {
            let weighted = pw[0] * f64::from(uv[0][k])
                + pw[1] * f64::from(uv[1][k])
                + pw[2] * f64::from(uv[2][k]);
            (weighted / sum) as f32
        })
    })
}

/// [`depth_key`] of a batch (`array::map` is not reliably inlined in this hot loop).
#[inline(always)]
fn depth_keys<const N: usize>(depth: [f32; N], reverse_z: bool) -> [u32; N] {
    std::array::from_fn(|j| depth_key(depth[j], reverse_z))
}

/// Window depth from the barycentric weights `l`: linear in screen space, stored as f32 and
/// clamped to the viewport depth range [0, 1] like the GPU does. `+ 0.0` turns −0.0 into +0.0
/// so both get one sort key.
#[inline(always)]
fn depths<const N: usize>(tri: &SetupTriangle, l: &[[f64; N]; 3]) -> [f32; N] {
    let z: [f64; 3] = std::array::from_fn(|i| f64::from(tri.z[i]));
    std::array::from_fn(|j| {
        let z = l[0][j] * z[0] + l[1][j] * z[1] + l[2][j] * z[2];
        (z as f32).clamp(0.0, 1.0) + 0.0
    })
}

/// Depth and perspective-correct vertex colour (weights / w, converted to f32 as the fragment
/// shader receives it) from the barycentric weights `l`.
// `&` of both comparisons, not `RangeInclusive::contains` (which short-circuits into a branch).
#[allow(clippy::manual_range_contains)]
#[inline(always)]
fn attributes<const N: usize>(tri: &SetupTriangle, l: &[[f64; N]; 3]) -> ([f32; N], [[f32; 4]; N]) {
    let depth = depths(tri, l);
    let pw: [[f64; N]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|j| l[i][j] * tri.inv_w[i]));
    let sum: [f64; N] = std::array::from_fn(|j| pw[0][j] + pw[1][j] + pw[2][j]);
    let c = &tri.color;
    let weighted: [[f64; 4]; N] = std::array::from_fn(|j| {
        std::array::from_fn(|k| {
            pw[0][j] * f64::from(c[0][k])
                + pw[1][j] * f64::from(c[1][k])
                + pw[2][j] * f64::from(c[2][k])
        })
    });
    // One division per pixel instead of four: see `quotient_via_reciprocal`.
    let inv: [f64; N] = std::array::from_fn(|j| 1.0 / sum[j]);
    let mut exact = true;
    let mut rgba = [[0.0f32; 4]; N];
    for j in 0..N {
        // The error bound needs a normal reciprocal (false for NaN too).
        let magnitude = inv[j].abs();
        exact &= (magnitude >= f64::MIN_POSITIVE) & (magnitude <= f64::MAX);
        for k in 0..4 {
            let (value, ok) = quotient_via_reciprocal(weighted[j][k], inv[j]);
            rgba[j][k] = value;
            exact &= ok;
        }
    }
    if !exact {
        rgba = divide(&weighted, &sum);
    }
    (depth, rgba)
}

/// `(weighted / sum) as f32`, the plain way: the rare batches where the reciprocal is not
/// known to give the same result.
#[cold]
#[inline(never)]
fn divide<const N: usize>(weighted: &[[f64; 4]; N], sum: &[f64; N]) -> [[f32; 4]; N] {
    std::array::from_fn(|j| std::array::from_fn(|k| (weighted[j][k] / sum[j]) as f32))
}

/// `(num / sum) as f32` computed as `num · inv` with `inv = RN(1 / sum)` a normal f64, and
/// whether that is known to be bit-identical to the division.
///
/// `q = num · inv` is two roundings away from the exact quotient and `RN(num / sum)` one, so
/// they are within 4 f64 ulps of each other. Converting f64 to f32 is monotone, so if
/// `q·(1 − 2^-48)` and `q·(1 + 2^-48)` (each at least 14 ulps away from q, even after
/// rounding) convert to the same f32, every value between them does, the correctly rounded
/// quotient included. That only fails within a few ulps of an f32 rounding midpoint (about
/// one value in 2^24). A q that underflows converts to a zero of the quotient's sign either
/// way.
#[inline(always)]
fn quotient_via_reciprocal(num: f64, inv: f64) -> (f32, bool) {
    const BELOW: f64 = 1.0 - 1.0 / (1u64 << 48) as f64;
    const ABOVE: f64 = 1.0 + 1.0 / (1u64 << 48) as f64;
    let q = num * inv;
    let below = (q * BELOW) as f32;
    (below, below == (q * ABOVE) as f32)
}

/// Output slices for one tile, rows of the full-width band.
pub(crate) struct TileOutput<'a> {
    pub image: &'a mut [[f32; 4]],
    pub layers: &'a mut [u32],
    pub fragments: &'a mut [u32],
    pub undecided: &'a mut [u32],
    pub precision_ties: &'a mut [bool],
    /// Row stride of the slices (the frame width).
    pub stride: usize,
    /// Index of the tile's top-left pixel inside the slices.
    pub x_offset: usize,
}

impl TileOutput<'_> {
    /// The same outputs, borrowed for a shorter time (an attempt that may give up).
    fn reborrow(&mut self) -> TileOutput<'_> {
        TileOutput {
            image: &mut *self.image,
            layers: &mut *self.layers,
            fragments: &mut *self.fragments,
            undecided: &mut *self.undecided,
            precision_ties: &mut *self.precision_ties,
            stride: self.stride,
            x_offset: self.x_offset,
        }
    }

    /// The first `rows` rows of the tile, and the rest.
    fn split_rows(self, rows: usize) -> (Self, Self) {
        let at = (rows * self.stride).min(self.image.len());
        let (image, image_rest) = self.image.split_at_mut(at);
        let (layers, layers_rest) = self.layers.split_at_mut(at);
        let (fragments, fragments_rest) = self.fragments.split_at_mut(at);
        let (undecided, undecided_rest) = self.undecided.split_at_mut(at);
        let (precision_ties, ties_rest) = self.precision_ties.split_at_mut(at);
        let (stride, x_offset) = (self.stride, self.x_offset);
        (
            TileOutput {
                image,
                layers,
                fragments,
                undecided,
                precision_ties,
                stride,
                x_offset,
            },
            TileOutput {
                image: image_rest,
                layers: layers_rest,
                fragments: fragments_rest,
                undecided: undecided_rest,
                precision_ties: ties_rest,
                stride,
                x_offset,
            },
        )
    }
}

/// What the tiles share: the set-up triangles, textures, plane depths, depth convention and
/// background.
pub(crate) struct TileContext<'a> {
    pub triangles: &'a Triangles,
    pub textures: &'a [Texture],
    pub planes: &'a [f64],
    pub reverse_z: bool,
    pub background: [f64; 3],
    /// Some draw has coloured transmission: fragments keep a per-channel transmittance.
    pub coloured: bool,
    /// Try [`render_rect_in_order`] before the stored path ([`crate::ReferenceOptions`]).
    pub in_order: bool,
}

/// Why [`render_tile`] did not render a tile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TileFailure {
    /// It does not fit `limit` at once: render it alone, in slices.
    Defer,
    /// The pixel (frame coordinates) alone needs more than `hard_limit`: its covered
    /// transparent fragments and the bytes it needs beside the tile's counts (`reserved`).
    Pixel {
        x: u32,
        y: u32,
        fragments: u32,
        bytes: u64,
        reserved: u64,
    },
}

/// Renders one tile at once with its scratch storage bounded by `limit` bytes
/// ([`Scratch::bytes`]): in arrival order where [`TileContext::in_order`] allows
/// ([`render_rect_in_order`], the stored path for the pixels that need it), else with
/// stored, sorted lists ([`render_rect`]). `bin` lists the tile's triangles in binning order
/// ([`in_bin_order`]), its opaque ones first.
///
/// When it does not fit, [`TileFailure::Defer`]: the tile is for [`render_tile_sliced`], and
/// its outputs, which an in-order attempt may have partly written, are all written again
/// there. Without the in-order path the transparent coverage is counted per pixel first
/// (nothing stored, the outputs untouched): [`TileFailure::Pixel`] when one pixel needs more
/// than `hard_limit` (the first in row-major order).
pub(crate) fn render_tile(
    ctx: &TileContext<'_>,
    bin: &[u32],
    tile: TileRect,
    scratch: &mut Scratch,
    mut out: TileOutput<'_>,
    limit: u64,
    hard_limit: u64,
) -> Result<TileStats, TileFailure> {
    scratch.high_water = scratch.bytes();
    let mut attempt = Duration::ZERO;
    let mut given_up = false;
    if ctx.in_order {
        let started = Instant::now();
        match render_rect_in_order(ctx, bin, tile, scratch, out.reborrow(), limit, true) {
            Ok(stats) => return Ok(stats),
            Err(stop) => given_up = stop == InOrderStop::Disordered,
        }
        attempt = started.elapsed();
    }
    if let Some(stats) = render_rect(ctx, bin, tile, scratch, out, limit, None) {
        // A failed in-order attempt counts as rasterization time of the tile.
        return Ok(TileStats {
            raster: stats.raster + attempt,
            given_up_tiles: u64::from(given_up),
            ..stats
        });
    }
    scratch.release();
    if ctx.in_order {
        // Alone with the whole budget the tile may still be composited in order, whatever
        // its pixels would need stored: [`render_tile_sliced`] decides.
        return Err(TileFailure::Defer);
    }
    let checked = count_tile(ctx, bin, tile, scratch, limit, hard_limit);
    scratch.release();
    checked.and(Err(TileFailure::Defer))
}

/// Output bytes per pixel of a slice, rendered into its own buffers: image, layers, fragment
/// and undecided counts, tie flag.
const OUTPUT_BYTES: u64 = (size_of::<[f32; 4]>() + 3 * size_of::<u32>() + size_of::<bool>()) as u64;

/// Renders a tile alone: in arrival order where [`TileContext::in_order`] allows and that
/// fits `budget` ([`render_rect_in_order`]; in bands on all threads when each fits its
/// share, [`in_order_in_bands`]), else in slices, bands of rows, runs of a row or
/// single pixels, each re-rasterizing the tile's triangles; the transparent coverage is
/// counted per pixel first (nothing stored) to plan them. Every pixel's result depends only on its own fragments, so
/// the output is the same bit for bit as at once.
///
/// The counts and the slices in flight stay within `budget`: the slices run in parallel, each
/// worker within an equal share of what the counts leave, when every pixel fits such a share,
/// else one at a time with all of it. [`TileFailure::Pixel`] when a pixel needs more than
/// `budget`.
pub(crate) fn render_tile_sliced(
    ctx: &TileContext<'_>,
    bin: &[u32],
    tile: TileRect,
    mut out: TileOutput<'_>,
    budget: u64,
) -> Result<TileStats, TileFailure> {
    let t_start = Instant::now();
    if ctx.in_order {
        if let Some(stats) = in_order_in_bands(ctx, bin, tile, out.reborrow(), budget) {
            return Ok(stats);
        }
        // With the whole budget the per-pixel state may fit where a thread's share did not.
        let mut scratch = Scratch::default();
        if let Ok(stats) =
            render_rect_in_order(ctx, bin, tile, &mut scratch, out.reborrow(), budget, false)
        {
            return Ok(stats);
        }
    }
    let mut counter = Scratch::default();
    let largest = count_tile(ctx, bin, tile, &mut counter, budget, budget)?;
    let reserved = counter.bytes();
    let counted = Instant::now();
    let threads = rayon::current_num_threads() as u64;
    let share = (budget - reserved) / threads;
    let (limit, parallel) = if largest <= share {
        (share, threads > 1)
    } else {
        (budget - reserved, false)
    };
    let out_tile = tile;
    let out = Mutex::new(&mut out);
    let render = |s: &mut Scratch, (rect, spans): (TileRect, u64)| -> TileStats {
        let n = (rect.width * rect.height) as usize;
        let mut image = vec![[0.0; 4]; n];
        let mut layers = vec![0; n];
        let mut fragments = vec![0; n];
        let mut undecided = vec![0; n];
        let mut precision_ties = vec![false; n];
        let local = TileOutput {
            image: &mut image,
            layers: &mut layers,
            fragments: &mut fragments,
            undecided: &mut undecided,
            precision_ties: &mut precision_ties,
            stride: rect.width as usize,
            x_offset: 0,
        };
        // The slice's own outputs are part of its share.
        let limit = limit - n as u64 * OUTPUT_BYTES;
        let stats = render_rect(ctx, bin, rect, s, local, limit, Some(spans as usize))
            .expect("a slice planned within the limit fits it");
        let mut out = out.lock().unwrap_or_else(|e| e.into_inner());
        let w = rect.width as usize;
        for row in 0..rect.height as usize {
            let o = out.x_offset
                + (rect.y0 - out_tile.y0) as usize * out.stride
                + row * out.stride
                + (rect.x0 - out_tile.x0) as usize;
            let l = row * w..(row + 1) * w;
            out.image[o..o + w].copy_from_slice(&image[l.clone()]);
            out.layers[o..o + w].copy_from_slice(&layers[l.clone()]);
            out.fragments[o..o + w].copy_from_slice(&fragments[l.clone()]);
            out.undecided[o..o + w].copy_from_slice(&undecided[l.clone()]);
            out.precision_ties[o..o + w].copy_from_slice(&precision_ties[l]);
        }
        TileStats {
            peak_tile_bytes: stats.peak_tile_bytes + n as u64 * OUTPUT_BYTES,
            ..stats
        }
    };
    let slices = Slices::new(&counter, tile, limit, ctx.coloured);
    let mut stats = if parallel {
        slices
            .par_bridge()
            .map_init(Scratch::default, render)
            .reduce(TileStats::default, TileStats::merge)
    } else {
        let mut scratch = Scratch::default();
        slices
            .map(|slice| render(&mut scratch, slice))
            .fold(TileStats::default(), TileStats::merge)
    };
    // The counting pass is rasterization too; the counts are held beside every slice.
    stats.raster += counted - t_start;
    stats.peak_tile_bytes += reserved;
    stats.sliced_tiles = 1;
    Ok(stats)
}

/// A tile rendered alone, composited in arrival order in bands of rows, one per thread, each
/// within an equal share of `budget`: a tile deferred for its depth (a deep stack covering
/// one tile) would otherwise run on one thread. Every pixel's result depends only on its own
/// fragments, so the output is the same bit for bit. `None` when there are not two threads
/// and two rows, or a band does not fit its share; the caller then writes every output again.
fn in_order_in_bands(
    ctx: &TileContext<'_>,
    bin: &[u32],
    tile: TileRect,
    out: TileOutput<'_>,
    budget: u64,
) -> Option<TileStats> {
    let bands = (rayon::current_num_threads() as u32).min(tile.height);
    if bands < 2 {
        return None;
    }
    let rows = tile.height.div_ceil(bands);
    let share = budget / u64::from(bands);
    let mut parts = Vec::new();
    let mut rest = out;
    for y0 in (tile.y0..tile.y0 + tile.height).step_by(rows as usize) {
        let height = rows.min(tile.y0 + tile.height - y0);
        let (band, tail) = rest.split_rows(height as usize);
        parts.push((TileRect { y0, height, ..tile }, band));
        rest = tail;
    }
    let bands: Vec<Option<TileStats>> = parts
        .into_par_iter()
        .map(|(rect, band)| {
            render_rect_in_order(ctx, bin, rect, &mut Scratch::default(), band, share, false).ok()
        })
        .collect();
    // The bands ran at once: their peaks add up.
    let mut peak = 0;
    let mut stats = TileStats::default();
    for band in bands {
        let band = band?;
        peak += band.peak_tile_bytes;
        stats = stats.merge(band);
    }
    Some(TileStats {
        peak_tile_bytes: peak,
        in_order_tiles: 1,
        banded_tiles: 1,
        ..stats
    })
}

/// Counts the covered transparent fragments per pixel of `tile` and its spans per row into
/// `s.counts` and `s.row_spans`, within `limit`, and checks that every pixel fits alone beside
/// them: the bytes the largest one needs, [`TileFailure::Pixel`] for the first over
/// `hard_limit`, [`TileFailure::Defer`] when the counts do not fit `limit`.
fn count_tile(
    ctx: &TileContext<'_>,
    bin: &[u32],
    tile: TileRect,
    s: &mut Scratch,
    limit: u64,
    hard_limit: u64,
) -> Result<u64, TileFailure> {
    let (w, h) = (tile.width as usize, tile.height as usize);
    let mut want = [Want::Fresh(0); BUFFERS];
    want[COUNTS] = Want::Fresh(h * (w + 1));
    want[COUNTS + 1] = Want::Fresh(h);
    if !s.ensure(want, limit) {
        return Err(TileFailure::Defer);
    }
    // The same coverage as the rendering pass; per row a difference array (+1 at a span's
    // first pixel, −1 after its end) summed afterwards, so each span costs O(1). Wrapping: the
    // sums are < 2^32 (at most one fragment per triangle and pixel).
    s.counts.clear();
    s.counts.resize(h * (w + 1), 0);
    s.row_spans.clear();
    s.row_spans.resize(h, 0);
    for &t in bin {
        let tri = &ctx.triangles[t];
        if tri.transparent {
            for_each_span(tri, tile, |row, first, end| {
                let b = row as usize * (w + 1);
                s.counts[b + first as usize] = s.counts[b + first as usize].wrapping_add(1);
                s.counts[b + end as usize] = s.counts[b + end as usize].wrapping_sub(1);
                s.row_spans[row as usize] += 1;
            });
        }
    }
    for row in s.counts.chunks_exact_mut(w + 1) {
        let mut sum = 0u32;
        for c in row {
            sum = sum.wrapping_add(*c);
            *c = sum;
        }
    }
    let reserved = s.bytes();
    let mut largest = 0;
    for row in 0..h {
        for x in 0..w {
            let c = u64::from(s.counts[row * (w + 1) + x]);
            let bytes = rect_bytes(1, c, c, c, ctx.coloured) + OUTPUT_BYTES;
            if reserved + bytes > hard_limit {
                return Err(TileFailure::Pixel {
                    x: tile.x0 + x as u32,
                    y: tile.y0 + row as u32,
                    fragments: c as u32,
                    bytes,
                    reserved,
                });
            }
            largest = largest.max(bytes);
        }
    }
    Ok(largest)
}

/// The slices of a counted tile ([`count_tile`]), greedily: as many whole rows as fit `limit`,
/// and a row that does not fit alone cut into runs of pixels (each pixel fits, checked by the
/// caller). Yields each slice with a bound on its spans: a rectangle's spans are at most its
/// rows' spans, and a run's at most its fragments too (each span covers one of them).
struct Slices<'a> {
    counts: &'a [u32],
    row_spans: &'a [u32],
    tile: TileRect,
    limit: u64,
    coloured: bool,
    row: usize,
    x: usize,
}

impl<'a> Slices<'a> {
    fn new(counter: &'a Scratch, tile: TileRect, limit: u64, coloured: bool) -> Self {
        Slices {
            counts: &counter.counts,
            row_spans: &counter.row_spans,
            tile,
            limit,
            coloured,
            row: 0,
            x: 0,
        }
    }

    /// Whether a slice of these numbers and its outputs fit; slot indices are u32.
    fn fits(&self, pixels: u64, slots: u64, spans: u64, longest: u64) -> bool {
        slots <= u64::from(u32::MAX)
            && rect_bytes(pixels, slots, spans, longest, self.coloured) + pixels * OUTPUT_BYTES
                <= self.limit
    }

    fn count_at(&self, row: usize, x: usize) -> u64 {
        u64::from(self.counts[row * (self.tile.width as usize + 1) + x])
    }
}

impl Iterator for Slices<'_> {
    type Item = (TileRect, u64);

    fn next(&mut self) -> Option<(TileRect, u64)> {
        let (w, h) = (self.tile.width as usize, self.tile.height as usize);
        if self.row == h {
            return None;
        }
        let (row, x) = (self.row, self.x);
        if x == 0 {
            let (mut rows, mut slots, mut spans, mut longest) = (0, 0, 0, 0);
            while row + rows < h {
                let r = row + rows;
                let row_slots: u64 = (0..w).map(|x| self.count_at(r, x)).sum();
                let row_longest = (0..w).map(|x| self.count_at(r, x)).max().unwrap_or(0);
                let (sl, sp, lo) = (
                    slots + row_slots,
                    spans + u64::from(self.row_spans[r]),
                    longest.max(row_longest),
                );
                if !self.fits(((rows + 1) * w) as u64, sl, sp, lo) {
                    break;
                }
                (rows, slots, spans, longest) = (rows + 1, sl, sp, lo);
            }
            if rows > 0 {
                self.row += rows;
                let rect = TileRect {
                    x0: self.tile.x0,
                    y0: self.tile.y0 + row as u32,
                    width: self.tile.width,
                    height: rows as u32,
                };
                return Some((rect, spans));
            }
        }
        let row_spans = u64::from(self.row_spans[row]);
        let (mut len, mut slots, mut longest) = (0, 0, 0);
        while x + len < w {
            let c = self.count_at(row, x + len);
            let (sl, lo) = (slots + c, longest.max(c));
            if !self.fits(len as u64 + 1, sl, sl.min(row_spans), lo) {
                break;
            }
            (len, slots, longest) = (len + 1, sl, lo);
        }
        assert!(len > 0, "every pixel fits alone");
        self.x += len;
        if self.x == w {
            (self.row, self.x) = (row + 1, 0);
        }
        let rect = TileRect {
            x0: self.tile.x0 + x as u32,
            y0: self.tile.y0 + row as u32,
            width: len as u32,
            height: 1,
        };
        Some((rect, slots.min(row_spans)))
    }
}

/// Covered transparent fragments of the first `n` pixels, before the prefix sum.
fn counted_slots(s: &Scratch, n: usize) -> u64 {
    s.start[1..=n].iter().map(|&c| u64::from(c)).sum()
}

/// Makes room for `rows` more spans in the coverage pass of [`render_rect`], unless what the
/// rectangle has counted so far (its state, spans and a slot per covered transparent fragment)
/// already exceeds `limit`: then it is given up early, before recording the rest.
#[cold]
#[inline(never)]
fn grow_spans(
    s: &mut Scratch,
    want: &mut [Want; BUFFERS],
    rows: usize,
    n: usize,
    limit: u64,
    coloured: bool,
) -> bool {
    let spans = s.spans.len() + rows;
    if rect_bytes(n as u64, counted_slots(s, n), spans as u64, 0, coloured) > limit {
        return false;
    }
    want[SPANS] = Want::Keep(spans);
    s.ensure(*want, limit)
}

/// Renders a rectangle of a tile: opaque pass into a depth/colour buffer; transparent coverage
/// pass (row spans, per-pixel slot counts); transparent shading pass keeping only fragments
/// strictly in front of the opaque depth, appended to their pixel's list; per-pixel sort by
/// key; f64 front-to-back compositing.
///
/// None, with the outputs untouched, when its storage would exceed `limit`. With `spans`, the
/// span buffer is reserved for that many at once (a slice's count, so that it never grows
/// while in use); otherwise it grows as coverage is recorded.
fn render_rect(
    ctx: &TileContext<'_>,
    bin: &[u32],
    tile: TileRect,
    scratch: &mut Scratch,
    mut out: TileOutput<'_>,
    limit: u64,
    spans: Option<usize>,
) -> Option<TileStats> {
    let TileContext {
        triangles,
        textures,
        planes,
        reverse_z,
        background,
        coloured,
        in_order: _,
    } = *ctx;
    let t_start = Instant::now();
    let n = (tile.width * tile.height) as usize;
    let tile_w = tile.width as usize;
    let s = scratch;
    // The far plane is what the depth buffer is cleared to, and every depth test is strict: a
    // fragment exactly at far is covered (counted) but never visible, opaque or transparent.
    let far = far_key(reverse_z);
    // Room for the per-pixel state (and the spans of a slice); nothing else is needed yet.
    let mut want = [Want::Fresh(0); BUFFERS];
    want[..SPANS].fill(Want::Fresh(n));
    want[START] = Want::Fresh(n + 1);
    want[SPANS] = Want::Fresh(spans.unwrap_or(0));
    want[COUNTS] = Want::Keep(0);
    want[COUNTS + 1] = Want::Keep(0);
    // The in-order path renders its stored rectangles one by one with this function.
    want[STORED_RECTS] = Want::Keep(0);
    if !s.ensure(want, limit) {
        return None;
    }
    reset_shared_state(s, n, far);
    s.start.clear();
    s.start.resize(n + 1, 0);
    // Filled after the coverage pass; empty until then, as `ensure` counts what it holds.
    s.end.clear();
    s.spans.clear();
    let mut stats = TileStats::default();
    // From here on the per-pixel state and the counts are in use.
    want[..SPANS].fill(Want::Keep(0));
    want[SPANS] = Want::Keep(0);
    // Each transparent triangle adds at most a span per row. `room` counts the triangles the
    // span buffer surely holds, so that neither a triangle nor a span needs a capacity check;
    // a slice's buffer was reserved for all of its spans.
    let rows = tile.height as usize;
    let mut room = if spans.is_some() {
        usize::MAX
    } else {
        s.spans.capacity() / rows
    };

    // Opaque (and mask) triangles first: they define the depth transparent fragments must beat.
    // Transparent triangles only record their spans and count the slots they may need.
    for &t in bin {
        let tri = &triangles[t];
        if tri.transparent {
            if room == 0 {
                room = (s.spans.capacity() - s.spans.len()) / rows;
                if room == 0 {
                    if !grow_spans(s, &mut want, rows, n, limit, coloured) {
                        return None;
                    }
                    room = (s.spans.capacity() - s.spans.len()) / rows;
                }
            }
            room -= 1;
            for_each_span(tri, tile, |row, first, end| {
                s.spans.push(Span {
                    triangle: t,
                    row: row as u16,
                    first: first as u16,
                    end: end as u16,
                });
                let p = row as usize * tile_w;
                for c in &mut s.start[p + first as usize + 1..p + end as usize + 1] {
                    *c += 1;
                }
            });
            continue;
        }
        shade_opaque(ctx, tri, tile, s, far);
    }
    // Slot indices are u32; only a tile with millions of spans can have more slots.
    if s.spans.len() as u64 * u64::from(tile.width) > u64::from(u32::MAX)
        && counted_slots(s, n) > u64::from(u32::MAX)
    {
        return None;
    }
    // Each covered pixel counts as a fragment unless the cutoff discards it (counted below).
    let mut longest = 0;
    for p in 0..n {
        let count = s.start[p + 1];
        longest = longest.max(count);
        s.all_count[p] += count;
        s.start[p + 1] += s.start[p];
    }
    let (slots, longest) = (s.start[n] as usize, longest as usize);
    want[SPANS] = Want::Keep(0);
    want[SPANS + 1..COUNTS].copy_from_slice(&[
        Want::Fresh(slots),
        Want::Fresh(slots),
        Want::Fresh(longest),
        Want::Fresh(longest),
        Want::Fresh(runs_needed(longest)),
    ]);
    want[TRANSMITTANCE] = Want::Fresh(if coloured { slots } else { 0 });
    if !s.ensure(want, limit) {
        return None;
    }
    s.end.extend_from_slice(&s.start[..n]);
    // Every slot below `end[p]` is written before it is read; the fill only sizes the arrays.
    s.keys.resize(slots, 0);
    s.colors.resize(slots, [0.0; 4]);
    s.transmittance.clear();
    if coloured {
        s.transmittance.resize(slots, [1.0; 3]);
    }
    let any_opaque = s.opaque_key.iter().any(|&k| k != far);
    let mut discarded = 0;
    for span in &s.spans {
        let tri = &triangles[span.triangle];
        // A sink per span: a short-lived local whose fields the optimiser keeps in registers.
        let mut sink = TransparentFragments {
            rank: tri.key,
            behind: Behind {
                far,
                planes,
                opaque_key: &s.opaque_key,
                any_opaque,
                plane: tri.plane_depth,
                // Without opaque fragments in the tile, only a triangle reaching the far
                // plane's tie distance can tie with it (its depths lie within its vertices').
                check_ties: any_opaque || near_far(tri, far, reverse_z),
            },
            keys: &mut s.keys,
            colors: &mut s.colors,
            transmittance: &mut s.transmittance,
            end: &mut s.end,
            all_count: &mut s.all_count,
            undecided: &mut s.undecided,
            tie: &mut s.tie,
            discarded: 0,
        };
        let (row, first, last) = (span.row.into(), span.first.into(), span.end.into());
        shade_span(tri, textures, tile, row, first, last, reverse_z, &mut sink);
        discarded += sink.discarded;
    }
    stats.transparent_fragments = slots as u64 - discarded;
    let t_raster = Instant::now();

    // Sort each pixel's list, in place. With `bin_order` most lists arrive sorted: one check.
    // Otherwise neighbouring pixels are usually covered by the same triangles in the same
    // depth order, so the previous pixel's permutation is tried first: if it puts the keys in
    // strictly ascending order it is the (unique) sorted order, found with n − 1 comparisons.
    s.perm.clear();
    for p in 0..n {
        let (lo, hi) = (s.start[p] as usize, s.end[p] as usize);
        let keys = &s.keys[lo..hi];
        if keys.is_sorted_by(|a, b| a < b) {
            continue;
        }
        let reuse = s.perm.len() == keys.len() && strictly_ascending(&s.perm, keys);
        if !reuse {
            s.perm.clear();
            s.perm.extend(0..keys.len() as u32);
            sort_by_key(
                &mut s.perm,
                |i| keys[i as usize],
                &mut s.merge_buffer,
                &mut s.runs,
            );
        }
        let transmittance = if coloured {
            &mut s.transmittance[lo..hi]
        } else {
            &mut []
        };
        permute(
            &mut s.perm,
            &mut s.keys[lo..hi],
            &mut s.colors[lo..hi],
            transmittance,
        );
    }
    let t_sort = Instant::now();

    let (mut out_row, mut column) = (out.x_offset, 0);
    for p in 0..n {
        let list = s.start[p] as usize..s.end[p] as usize;
        let base = if s.opaque_key[p] == far {
            background
        } else {
            s.opaque_color[p].map(f64::from)
        };
        // Neighbours in the sorted list that rounding could swap, found while compositing (one
        // pass over the list); only close ones are looked at further.
        let mut tie = s.tie[p];
        let mut previous = (u32::MAX - PRECISION_TIE_ULPS * 2, 0usize);
        let mut visit = |slot: usize| {
            let depth = (s.keys[slot] >> 32) as u32;
            if close(previous.0, depth) {
                tie |= transparent_tie(
                    &s.keys,
                    &s.colors,
                    &s.transmittance,
                    planes,
                    previous.1,
                    slot,
                );
            }
            previous = (depth, slot);
            let [r, g, b, a] = s.colors[slot];
            ([f64::from(r), f64::from(g), f64::from(b)], a)
        };
        let rgb = if coloured {
            composite_coloured_iter(
                list.clone().map(|slot| {
                    let (premultiplied, _) = visit(slot);
                    (premultiplied, s.transmittance[slot])
                }),
                base,
            )
        } else {
            composite_iter(
                list.clone().map(|slot| {
                    let (premultiplied, alpha) = visit(slot);
                    (premultiplied, f64::from(alpha))
                }),
                base,
            )
        };
        let pixel = PixelResult {
            rgb,
            layers: list.len() as u32,
            fragments: s.all_count[p],
            undecided: s.undecided[p],
            tie,
        };
        pixel.write(&mut out, out_row + column, &mut stats);
        // Next pixel: the output index follows the tile's rows through the frame's.
        column += 1;
        if column == tile_w {
            column = 0;
            out_row += out.stride;
        }
    }
    let t_end = Instant::now();
    stats.raster = t_raster - t_start;
    stats.sort = t_sort - t_raster;
    stats.composite = t_end - t_sort;
    stats.peak_tile_bytes = s.high_water;
    stats.stored_pixels = n as u64;
    Some(stats)
}

/// Clears the per-pixel state both paths share for a rectangle of `n` pixels: no opaque
/// surface yet (`far`), no fragments, nothing undecided, no tie.
fn reset_shared_state(s: &mut Scratch, n: usize, far: u64) {
    s.opaque_key.clear();
    s.opaque_key.resize(n, far);
    s.opaque_color.clear();
    s.opaque_color.resize(n, [0.0; 3]);
    s.all_count.clear();
    s.all_count.resize(n, 0);
    reset_transparent_state(s, n);
}

/// The part of [`reset_shared_state`] a rectangle without opaque triangles uses: nothing
/// undecided, no tie.
fn reset_transparent_state(s: &mut Scratch, n: usize) {
    s.undecided.clear();
    s.undecided.resize(n, 0);
    s.tie.clear();
    s.tie.resize(n, false);
}

/// The opaque pass of one opaque (or mask) triangle over `tile`.
#[inline(always)]
fn shade_opaque(
    ctx: &TileContext<'_>,
    tri: &SetupTriangle,
    tile: TileRect,
    s: &mut Scratch,
    far: u64,
) {
    let mut sink = OpaqueFragments {
        rank: tri.key,
        plane: tri.plane_depth,
        far,
        planes: ctx.planes,
        opaque_key: &mut s.opaque_key,
        opaque_color: &mut s.opaque_color,
        all_count: &mut s.all_count,
        undecided: &mut s.undecided,
        tie: &mut s.tie,
    };
    for_each_span(tri, tile, |row, first, end| {
        shade_span(
            tri,
            ctx.textures,
            tile,
            row,
            first,
            end,
            ctx.reverse_z,
            &mut sink,
        );
    });
}

/// One pixel's outputs, as both paths produce them.
struct PixelResult {
    rgb: [f64; 3],
    layers: u32,
    fragments: u32,
    undecided: u32,
    tie: bool,
}

impl PixelResult {
    /// Writes the pixel at index `o` of the outputs and adds it to `stats`.
    #[inline(always)]
    fn write(&self, out: &mut TileOutput<'_>, o: usize, stats: &mut TileStats) {
        let rgb = self.rgb;
        out.image[o] = [rgb[0] as f32, rgb[1] as f32, rgb[2] as f32, 1.0];
        out.layers[o] = self.layers;
        out.fragments[o] = self.fragments;
        // The outputs start zeroed: writing only what is set leaves untouched pages unmapped.
        if self.undecided > 0 {
            out.undecided[o] = self.undecided;
        }
        if self.tie {
            out.precision_ties[o] = true;
        }
        stats.undecided_fragments += u64::from(self.undecided);
        stats.undecided_pixels += u64::from(self.undecided > 0);
        stats.precision_tie_pixels += u64::from(self.tie);
        stats.fragments += u64::from(self.fragments);
        stats.composited_fragments += u64::from(self.layers);
        stats.max_layers = stats.max_layers.max(self.layers);
        stats.covered_pixels += u64::from(self.layers > 0);
    }
}

/// One pixel's state while its tile is composited in arrival order ([`render_rect_in_order`]),
/// together in one struct: a fragment touches one cache line and one bounds check.
#[derive(Debug, Clone, Copy)]
pub(crate) struct InOrderPixel {
    /// Premultiplied colour sum so far, f64.
    color: [f64; 3],
    /// Transmittance so far in scalar scenes (scenes with coloured transmission keep it per
    /// channel beside the pixel).
    through: f64,
    /// Depth key of the last composited fragment, or an upper bound of it where that was
    /// enough to know it in order ([`ConstantSpan`]); 0 before the first (every depth key of
    /// a depth in [0, 1] is far above the tie distance from it); [`DISORDERED`] for good once
    /// a fragment did not follow the last one ([`InOrderPixel::follows`]): the stored path
    /// decides this pixel. No fragment follows that value, so the pixel stays disordered, and
    /// the state needs no flag of its own: 48 bytes instead of 56, so fewer pixels straddle
    /// two cache lines and a tile's state is 49 kB instead of 57.
    last_depth: u32,
    /// The triangle whose fragment `last_depth` is only an upper bound of, or [`EXACT`].
    bound_of: u32,
    /// Fragments composited.
    layers: u32,
    /// Transparent fragments the cutoff kept that were not composited (hidden by the opaque
    /// depth or the far plane): with `layers`, every fragment it kept. Counted apart so that
    /// a composited fragment, nearly all of them, costs no second counter.
    hidden: u32,
}

/// [`InOrderPixel::last_depth`] of a disordered pixel: above every depth key of a depth in
/// [0, 1] (at most `0xBF80_0000`, the key of 1.0, or `0x7FFF_FFFF` under reverse-Z), so no key
/// follows it.
const DISORDERED: u32 = u32::MAX;
const _: () = assert!(
    depth_key(1.0, false) < DISORDERED - PRECISION_TIE_ULPS
        && depth_key(0.0, true) < DISORDERED - PRECISION_TIE_ULPS
);

impl InOrderPixel {
    /// Nothing composited yet.
    const EMPTY: InOrderPixel = InOrderPixel {
        color: [0.0; 3],
        through: 1.0,
        last_depth: 0,
        bound_of: EXACT,
        layers: 0,
        hidden: 0,
    };

    /// Whether some fragment did not follow the last one.
    #[inline(always)]
    fn disordered(&self) -> bool {
        self.last_depth == DISORDERED
    }

    /// `dkey` becomes the last key if it follows the last one; otherwise the pixel is
    /// [`DISORDERED`].
    #[inline(always)]
    fn step_to(&mut self, dkey: u32) {
        self.last_depth = if self.follows(dkey) { dkey } else { DISORDERED };
    }

    /// Whether `dkey` may follow the last composited depth key: farther by more than the tie
    /// distance. Then it is the next fragment of the sorted list and no neighbour pair of it
    /// is a precision tie.
    #[inline(always)]
    fn follows(&self, dkey: u32) -> bool {
        u64::from(self.last_depth) + u64::from(PRECISION_TIE_ULPS) < u64::from(dkey)
    }

    /// Composites a visible fragment of a scalar scene ([`over_step`]).
    #[inline(always)]
    fn add<const MAY_UNDERFLOW: bool>(&mut self, dkey: u32, premultiplied: [f64; 3], keep: f64) {
        self.step_to(dkey);
        self.bound_of = EXACT;
        self.composite::<MAY_UNDERFLOW>(premultiplied, keep);
    }

    /// [`over_step`] for a fragment known to follow the last one.
    #[inline(always)]
    fn composite<const MAY_UNDERFLOW: bool>(&mut self, premultiplied: [f64; 3], keep: f64) {
        self.layers += 1;
        over_step::<MAY_UNDERFLOW>(&mut self.color, &mut self.through, premultiplied, keep);
    }

    /// Composites a visible fragment of a scene with coloured transmission, `through` being
    /// the pixel's per-channel transmittance ([`over_step_coloured`]).
    #[inline(always)]
    fn add_coloured(
        &mut self,
        through: &mut [f64; 3],
        dkey: u32,
        premultiplied: [f64; 3],
        t: [f64; 3],
    ) {
        self.step_to(dkey);
        self.bound_of = EXACT;
        self.layers += 1;
        over_step_coloured(&mut self.color, through, premultiplied, t);
    }
}

/// [`InOrderPixel::bound_of`] when `last_depth` is exact.
const EXACT: u32 = u32::MAX;

/// The transparent pass of [`render_rect_in_order`]: each fragment strictly nearer than the
/// opaque depth (or far) is composited into its pixel as it arrives, by the operations of
/// [`composite_iter`] (scalar) or [`composite_coloured_iter`] (`COLOURED`) in the same order,
/// so that the sums are bit for bit those of the stored path wherever the arrival order is
/// the sorted order; pixels where it is not are marked ([`InOrderPixel::disordered`]).
/// Bookkeeping as [`TransparentFragments`]. The pass's own fragments are counted in
/// [`InOrderPixel::layers`] and [`InOrderPixel::hidden`], apart from the opaque pass's
/// `all_count`.
struct InOrderFragments<'a, const COLOURED: bool, const MAY_UNDERFLOW: bool> {
    behind: Behind<'a>,
    undecided: &'a mut [u32],
    tie: &'a mut [bool],
    pixels: &'a mut [InOrderPixel],
    /// Per pixel, only when `COLOURED`: the per-channel transmittance.
    transmittance: &'a mut [[f64; 3]],
}

impl<const COLOURED: bool, const MAY_UNDERFLOW: bool> Fragments
    for InOrderFragments<'_, COLOURED, MAY_UNDERFLOW>
{
    #[inline(always)]
    fn fragment(&mut self, p: usize, dkey: u32, shaded: Shaded, undecided: bool) {
        if undecided {
            self.undecided[p] += 1;
        }
        let Some((premultiplied, alpha, transmittance)) = transparent_parts(shaded) else {
            return;
        };
        let pixel = &mut self.pixels[p];
        if dkey < self.behind.nearest(p, dkey, self.tie) {
            let c = premultiplied.map(f64::from);
            if COLOURED {
                let t = transmittance_of(alpha, transmittance);
                pixel.add_coloured(&mut self.transmittance[p], dkey, c, t);
            } else {
                pixel.add::<MAY_UNDERFLOW>(dkey, c, 1.0 - f64::from(alpha));
            }
        } else {
            pixel.hidden += 1;
        }
    }
}

/// [`InOrderFragments`] for whole spans of a triangle of constant colour in a scalar scene's
/// tile without opaque fragments (layers, billboards, particles): the colour, the far plane
/// and what is counted are the same for every fragment, and no fragment can tie with the far
/// plane unless the whole triangle does, so per pixel only the depth key and the composite
/// step are left (for a flat triangle only the composite step). The same operations in the
/// same order, so the same bits.
struct ConstantSpan {
    premultiplied: [f64; 3],
    /// `1 − α`.
    keep: f64,
    /// α is in the cutoff's undecided band.
    undecided: bool,
    /// The far plane's depth key: fragments must be strictly nearer to be composited.
    far: u32,
    /// For a flat triangle: its one depth key, and whether it ties with the far plane
    /// ([`ties_opaque`]). Otherwise no vertex is within the tie distance of it
    /// ([`near_far`]), and keys are interpolated per pixel.
    flat: Option<(u32, bool)>,
    /// Otherwise, where the triangle is no sliver and lies in front of the far plane: bounds
    /// on its fragments' depth keys ([`depth_key_bounds`]). A pixel whose last key is below
    /// the lower one by more than the tie distance needs no key of its own.
    bounds: Option<(u32, u32)>,
}

impl ConstantSpan {
    #[inline(always)]
    fn of<const COLOURED: bool>(
        tri: &SetupTriangle,
        any_opaque: bool,
        far: u64,
        ctx: &TileContext<'_>,
    ) -> Option<ConstantSpan> {
        if COLOURED || any_opaque || tri.inv_farea2 == 0.0 {
            return None;
        }
        let Some(Shaded::Transparent {
            premultiplied,
            alpha,
        }) = tri.constant
        else {
            return None;
        };
        let flat = match flat_depth_key(tri, ctx.reverse_z) {
            Some(dkey) => Some((
                dkey,
                ties_opaque(dkey, tri.plane_depth, far, far, ctx.planes),
            )),
            None if near_far(tri, far, ctx.reverse_z) => return None,
            None => None,
        };
        let far = (far >> 32) as u32;
        let bounds = flat
            .is_none()
            .then(|| depth_key_bounds(tri, ctx.reverse_z))
            .flatten()
            .filter(|&(_, hi)| hi < far);
        Some(ConstantSpan {
            premultiplied: premultiplied.map(f64::from),
            keep: 1.0 - f64::from(alpha),
            undecided: tri.constant_undecided,
            far,
            flat,
            bounds,
        })
    }

    /// Composites the span's fragments at the pixels `first..end` of tile row `row`.
    #[allow(
        clippy::too_many_arguments,
        reason = "the per-span entry, as shade_span"
    )]
    #[inline(always)]
    fn composite<const MAY_UNDERFLOW: bool>(
        &self,
        triangles: &Triangles,
        t: u32,
        tile: TileRect,
        reverse_z: bool,
        s: &mut Scratch,
        row: u32,
        first: u32,
        end: u32,
    ) {
        let tri = &triangles[t];
        let base = (row * tile.width) as usize;
        let range = base + first as usize..base + end as usize;
        if self.undecided {
            for u in &mut s.undecided[range.clone()] {
                *u += 1;
            }
        }
        let pixels = &mut s.in_order[range.clone()];
        if let Some((lo, hi)) = self.bounds {
            // Only pixels whose last key is not clearly nearer need their own key: the row's
            // weights are set up at the first of them.
            let mut weights = None;
            let mut key_at = |x: u32| {
                let w = weights.get_or_insert_with(|| RowWeights::new(tri, tile, row));
                depth_key(depths(tri, &w.at(x))[0], reverse_z)
            };
            // `last + tie < lo`, as in `follows` (never when `lo <= tie`).
            let clearly_nearer = lo.saturating_sub(PRECISION_TIE_ULPS);
            let (premultiplied, keep) = (self.premultiplied, self.keep);
            for (i, pixel) in pixels.iter_mut().enumerate() {
                if pixel.last_depth < clearly_nearer {
                    debug_assert!(
                        (lo..=hi).contains(&key_at(first + i as u32)),
                        "depth key out of bounds"
                    );
                    pixel.last_depth = hi;
                    pixel.bound_of = t;
                    pixel.composite::<MAY_UNDERFLOW>(premultiplied, keep);
                    continue;
                }
                if pixel.disordered() {
                    // Decided by the stored path: nothing here is read again.
                    continue;
                }
                let x = first + i as u32;
                let dkey = key_at(x);
                debug_assert!((lo..=hi).contains(&dkey), "depth key out of bounds");
                if !pixel.follows(dkey) && pixel.bound_of != EXACT {
                    // Only a bound of the last fragment's key is known: its own key decides.
                    let last = &triangles[pixel.bound_of];
                    let weights = RowWeights::new(last, tile, row);
                    pixel.last_depth = depth_key(depths(last, &weights.at(x))[0], reverse_z);
                }
                pixel.add::<MAY_UNDERFLOW>(dkey, premultiplied, keep);
            }
            return;
        }
        let Some((dkey, ties_far)) = self.flat else {
            let weights = RowWeights::new(tri, tile, row);
            for (batch, x) in pixels.chunks_mut(LANES).zip((first..end).step_by(LANES)) {
                let dkeys = depth_keys(depths(tri, &weights.at(x)), reverse_z);
                for (pixel, &dkey) in batch.iter_mut().zip(&dkeys) {
                    if dkey < self.far {
                        pixel.add::<MAY_UNDERFLOW>(dkey, self.premultiplied, self.keep);
                    } else {
                        pixel.hidden += 1;
                    }
                }
            }
            return;
        };
        if ties_far {
            s.tie[range].fill(true);
        }
        if dkey >= self.far {
            for pixel in pixels {
                pixel.hidden += 1;
            }
            return;
        }
        for pixel in pixels {
            pixel.add::<MAY_UNDERFLOW>(dkey, self.premultiplied, self.keep);
        }
    }
}

/// Most pixels a stored rectangle of [`render_rect_in_order`] may hold beyond its rows' runs
/// when runs of neighbouring rows are merged into one rectangle: each rectangle costs a pass
/// over the tile's triangles, about what this many pixels cost the stored path.
const STORED_MERGE_SLACK: u32 = 64;

/// Renders a rectangle without storing its transparent fragments where they arrive in depth
/// order: opaque pass as [`render_rect`], then each transparent fragment in front of the
/// opaque depth composited into its pixel on arrival ([`InOrderFragments`]). Transparent
/// triangles are binned nearest first ([`in_bin_order`]), so on layered content and
/// billboards nearly every pixel's fragments do arrive in order, and for those the sort, the
/// slot storage and the second shading pass disappear. Each row's run from its first to its
/// last disordered pixel (intersecting or depth-overlapping geometry, a precision tie) is
/// then rendered by [`render_rect`], runs of neighbouring rows merged into rectangles where
/// that adds few pixels; every pixel is written once, bit-identical to what [`render_rect`]
/// alone gives.
///
/// Stops when the per-pixel state or a stored rectangle does not fit `limit`, or, when
/// `give_up`, when most of the tile turns out disordered early ([`mostly_disordered`]); the
/// outputs may then be partly written, and the caller renders the whole tile again.
fn render_rect_in_order(
    ctx: &TileContext<'_>,
    bin: &[u32],
    tile: TileRect,
    s: &mut Scratch,
    mut out: TileOutput<'_>,
    limit: u64,
    give_up: bool,
) -> Result<TileStats, InOrderStop> {
    let t_start = Instant::now();
    if bin.is_empty() {
        return Ok(write_background(ctx, tile, out, t_start, s.high_water));
    }
    let n = (tile.width * tile.height) as usize;
    let far = far_key(ctx.reverse_z);
    let mut want = [Want::Fresh(0); BUFFERS];
    want[..SHARED_STATE].fill(Want::Fresh(n));
    want[IN_ORDER] = Want::Fresh(n);
    want[IN_ORDER_TRANSMITTANCE] = Want::Fresh(if ctx.coloured { n } else { 0 });
    want[STORED_RECTS] = Want::Fresh(tile.height as usize);
    if !s.ensure(want, limit) {
        return Err(InOrderStop::OverLimit);
    }
    // Bins list their opaque triangles first ([`in_bin_order`]), so the first transparent one
    // ends them; on transparent content that is the first triangle, and no scan of the bin
    // loads every triangle once more. Without opaque triangles (layers, particles) no pixel
    // can hold an opaque fragment or count one: the opaque state is left empty, neither
    // cleared nor read.
    debug_assert!(
        bin.is_sorted_by_key(|&t| ctx.triangles[t].transparent),
        "a bin lists its opaque triangles first"
    );
    let opaque_count = bin
        .iter()
        .position(|&t| ctx.triangles[t].transparent)
        .unwrap_or(bin.len());
    let opaque_triangles = opaque_count > 0;
    if opaque_triangles {
        reset_shared_state(s, n, far);
    } else {
        // Emptied, so that reading it would fail loudly.
        s.opaque_key.clear();
        s.opaque_color.clear();
        s.all_count.clear();
        reset_transparent_state(s, n);
    }
    s.in_order.clear();
    s.in_order.resize(n, InOrderPixel::EMPTY);
    s.in_order_transmittance.clear();
    if ctx.coloured {
        s.in_order_transmittance.resize(n, [1.0; 3]);
    }
    for &t in &bin[..opaque_count] {
        shade_opaque(ctx, &ctx.triangles[t], tile, s, far);
    }
    let any_opaque = opaque_triangles && s.opaque_key.iter().any(|&k| k != far);
    let finished = if ctx.coloured {
        // Coloured steps always check ([`over_step_coloured`]).
        transparent_in_order::<true, true>(ctx, bin, tile, s, far, any_opaque, give_up)
    } else if may_underflow(ctx.triangles, &bin[opaque_count..]) {
        transparent_in_order::<false, true>(ctx, bin, tile, s, far, any_opaque, give_up)
    } else {
        transparent_in_order::<false, false>(ctx, bin, tile, s, far, any_opaque, give_up)
    };
    if !finished {
        return Err(InOrderStop::Disordered);
    }
    let t_raster = Instant::now();

    // The rectangles the stored path renders: per row the run from its first to its last
    // disordered pixel, merged with the next row's while that adds few pixels.
    let tile_w = tile.width as usize;
    s.stored_rects.clear();
    let mut covered = 0;
    for (row, pixels) in s.in_order.chunks_exact(tile_w).enumerate() {
        // First and last disordered pixel, in one pass (most rows have none).
        let mut run: Option<(usize, usize)> = None;
        for (x, pixel) in pixels.iter().enumerate() {
            if pixel.disordered() {
                run = Some(run.map_or((x, x), |(lo, _)| (lo, x)));
            }
        }
        let Some((lo, hi)) = run else {
            continue;
        };
        let (row, lo, hi) = (row as u32, lo as u32, hi as u32 + 1);
        if let Some(last) = s.stored_rects.last_mut() {
            let [r0, r1, l, h] = *last;
            let (ml, mh) = (l.min(lo), h.max(hi));
            if r1 == row && (r1 + 1 - r0) * (mh - ml) <= covered + (hi - lo) + STORED_MERGE_SLACK {
                *last = [r0, row + 1, ml, mh];
                covered += hi - lo;
                continue;
            }
        }
        s.stored_rects.push([row, row + 1, lo, hi]);
        covered = hi - lo;
    }
    let mut stats = TileStats {
        in_order_tiles: u64::from(s.stored_rects.is_empty()),
        ..TileStats::default()
    };
    let mut rects = s.stored_rects.iter().peekable();
    for row in 0..tile.height {
        while rects.peek().is_some_and(|r| r[1] <= row) {
            rects.next();
        }
        let (lo, hi) = match rects.peek() {
            Some(&&[r0, _, lo, hi]) if r0 <= row => (lo as usize, hi as usize),
            _ => (tile_w, tile_w),
        };
        let row = row as usize;
        for xs in [0..lo, hi..tile_w] {
            if opaque_triangles {
                write_in_order::<true>(ctx, s, far, &mut out, row * tile_w, xs, row, &mut stats);
            } else {
                write_in_order::<false>(ctx, s, far, &mut out, row * tile_w, xs, row, &mut stats);
            }
        }
    }
    let t_end = Instant::now();
    stats.raster = t_raster - t_start;
    stats.composite = t_end - t_raster;
    stats.peak_tile_bytes = s.high_water;

    // The stored rectangles (`stored_rects` is kept through `render_rect`).
    for i in 0..s.stored_rects.len() {
        let [r0, r1, lo, hi] = s.stored_rects[i];
        let rect = TileRect {
            x0: tile.x0 + lo,
            y0: tile.y0 + r0,
            width: hi - lo,
            height: r1 - r0,
        };
        let rect_out = TileOutput {
            x_offset: out.x_offset + r0 as usize * out.stride + lo as usize,
            ..out.reborrow()
        };
        let stored =
            render_rect(ctx, bin, rect, s, rect_out, limit, None).ok_or(InOrderStop::OverLimit)?;
        stats = stats.merge(TileStats {
            peak_tile_bytes: s.high_water,
            ..stored
        });
    }
    Ok(stats)
}

/// [`render_rect_in_order`] of a tile no triangle touches: every pixel is the background,
/// computed by the write pass's expression (`color + through · base` with nothing
/// composited, so −0 becomes +0 as there), with no fragment, layer, undecided count or tie.
/// Only the image is written: the frame's counts start zeroed, and such a tile is never
/// attempted before (it cannot fail), so its count pages need not be touched at all.
/// Sparse content (a model in the middle of the frame, the seeded conformance scenes) has
/// many such tiles, and the per-pixel state of the general path cost them as much as
/// covered ones.
fn write_background(
    ctx: &TileContext<'_>,
    tile: TileRect,
    out: TileOutput<'_>,
    t_start: Instant,
    high_water: u64,
) -> TileStats {
    let empty = InOrderPixel::EMPTY;
    let rgb: [f64; 3] = std::array::from_fn(|k| empty.color[k] + empty.through * ctx.background[k]);
    let colour = [rgb[0] as f32, rgb[1] as f32, rgb[2] as f32, 1.0];
    let width = tile.width as usize;
    for row in 0..tile.height as usize {
        let o = out.x_offset + row * out.stride;
        out.image[o..o + width].fill(colour);
    }
    TileStats {
        in_order_tiles: 1,
        composite: t_start.elapsed(),
        peak_tile_bytes: high_water,
        ..TileStats::default()
    }
}

/// Writes the in-order results of the pixels `xs` of tile row `row` (tile pixel index
/// `p0 + x`) and adds them to `stats`, as [`PixelResult::write`] does pixel by pixel. Without
/// `OPAQUE` triangles in the bin the opaque state was never set up: every pixel's base is
/// the background and the transparent pass's counts are all its fragments.
#[allow(clippy::too_many_arguments, reason = "one row range of one tile")]
fn write_in_order<const OPAQUE: bool>(
    ctx: &TileContext<'_>,
    s: &Scratch,
    far: u64,
    out: &mut TileOutput<'_>,
    p0: usize,
    xs: std::ops::Range<usize>,
    row: usize,
    stats: &mut TileStats,
) {
    if xs.is_empty() {
        return;
    }
    // One pass over the run, every slice cut to its length `n` (so no index is checked).
    let n = xs.len();
    let ps = p0 + xs.start..p0 + xs.end;
    let o0 = out.x_offset + row * out.stride;
    let os = o0 + xs.start..o0 + xs.end;
    let pixels = &s.in_order[ps.clone()][..n];
    let (keys, colours, all_counts) = if OPAQUE {
        (
            &s.opaque_key[ps.clone()][..n],
            &s.opaque_color[ps.clone()][..n],
            &s.all_count[ps.clone()][..n],
        )
    } else {
        (&[][..], &[][..], &[][..])
    };
    let undecided_counts = &s.undecided[ps.clone()][..n];
    let tie_flags = &s.tie[ps.clone()][..n];
    let coloured = if ctx.coloured {
        &s.in_order_transmittance[ps][..n]
    } else {
        &[]
    };
    let image = &mut out.image[os.clone()][..n];
    let layers = &mut out.layers[os.clone()][..n];
    let counts = &mut out.fragments[os.clone()][..n];
    let undecided_out = &mut out.undecided[os.clone()][..n];
    let ties_out = &mut out.precision_ties[os][..n];
    let (mut fragments, mut kept, mut composited, mut covered, mut most) = (0, 0, 0, 0, 0);
    let (mut undecided, mut undecided_pixels, mut ties) = (0u64, 0u64, 0u64);
    for j in 0..n {
        let pixel = &pixels[j];
        let base = if !OPAQUE || keys[j] == far {
            ctx.background
        } else {
            colours[j].map(f64::from)
        };
        let through = if ctx.coloured {
            coloured[j]
        } else {
            [pixel.through; 3]
        };
        let rgb: [f64; 3] = std::array::from_fn(|k| pixel.color[k] + through[k] * base[k]);
        image[j] = [rgb[0] as f32, rgb[1] as f32, rgb[2] as f32, 1.0];
        // The transparent pass counted its kept fragments apart from the opaque pass's.
        let pixel_kept = pixel.layers + pixel.hidden;
        let count = if OPAQUE {
            all_counts[j] + pixel_kept
        } else {
            pixel_kept
        };
        layers[j] = pixel.layers;
        counts[j] = count;
        fragments += u64::from(count);
        kept += u64::from(pixel_kept);
        composited += u64::from(pixel.layers);
        covered += u64::from(pixel.layers > 0);
        most = most.max(pixel.layers);
        // The outputs start zeroed: writing only what is set leaves untouched pages unmapped.
        let u = undecided_counts[j];
        if u > 0 {
            undecided_out[j] = u;
        }
        undecided += u64::from(u);
        undecided_pixels += u64::from(u > 0);
        if tie_flags[j] {
            ties_out[j] = true;
        }
        ties += u64::from(tie_flags[j]);
    }
    stats.fragments += fragments;
    stats.transparent_fragments += kept;
    stats.undecided_fragments += undecided;
    stats.undecided_pixels += undecided_pixels;
    stats.precision_tie_pixels += ties;
    stats.composited_fragments += composited;
    stats.max_layers = stats.max_layers.max(most);
    stats.covered_pixels += covered;
}

/// Whether a pixel of a tile with this bin may see its transmittance fall below
/// [`crate::composite::NEGLIGIBLE_TRANSMITTANCE`], so that every step must check for it ([`over_step`]). No
/// when every transparent triangle is of constant colour and the sum over them of
/// −⌊log2(1 − α)⌋ is at most 990: a pixel takes at most one fragment of each, its
/// transmittance is a product of some of their `1 − α` (one that is 0 leaves 0 for good), and
/// with f64 rounding that product stays above 2^-990 · (1 − n·2^-53) > 2^-1000.
fn may_underflow(triangles: &Triangles, bin: &[u32]) -> bool {
    let mut halvings = 0i64;
    for &t in bin {
        let tri = &triangles[t];
        if !tri.transparent {
            continue;
        }
        let Some(Shaded::Transparent { alpha, .. }) = tri.constant else {
            return true;
        };
        let keep = 1.0 - f64::from(alpha);
        if keep > 0.0 {
            // keep ≥ 2^e, e its binary exponent (keep ≥ 2^-24: alpha is an f32).
            let e = ((keep.to_bits() >> 52) & 0x7ff) as i64 - 1023;
            halvings -= e;
            if halvings > 990 {
                return true;
            }
        }
    }
    false
}

/// A tile of at least this many triangles may give up compositing in order
/// ([`mostly_disordered`]); smaller ones cost little either way.
const GIVE_UP_TRIANGLES: usize = 8;

/// Whether at least three quarters of every fourth pixel of every fourth row of `tile` are
/// already disordered. Then the tile's stored rectangles will cover about all of it, and finishing the
/// in-order pass only to render the tile again with stored lists would cost it both paths
/// (measured on seeded random scenes of interpenetrating layer stacks: 1.2–1.4× the stored
/// path alone). A sixteenth of the pixels keeps the check cheap beside the pass.
fn mostly_disordered(s: &Scratch, tile: TileRect) -> bool {
    let (mut sampled, mut disordered) = (0, 0);
    for row in s.in_order.chunks_exact(tile.width as usize).step_by(4) {
        for pixel in row.iter().step_by(4) {
            sampled += 1;
            disordered += usize::from(pixel.disordered());
        }
    }
    disordered * 4 >= sampled * 3
}

/// The transparent pass of [`render_rect_in_order`]. False when `give_up` and the tile was
/// [`mostly_disordered`] after an eighth, a quarter or half of its triangles: the pass stops
/// there, and the tile is for the stored path.
fn transparent_in_order<const COLOURED: bool, const MAY_UNDERFLOW: bool>(
    ctx: &TileContext<'_>,
    bin: &[u32],
    tile: TileRect,
    s: &mut Scratch,
    far: u64,
    any_opaque: bool,
    give_up: bool,
) -> bool {
    let checks = if give_up && bin.len() >= GIVE_UP_TRIANGLES {
        [bin.len() / 8, bin.len() / 4, bin.len() / 2]
    } else {
        [usize::MAX; 3]
    };
    for (i, &t) in bin.iter().enumerate() {
        if checks.contains(&i) && mostly_disordered(s, tile) {
            return false;
        }
        let tri = &ctx.triangles[t];
        if !tri.transparent {
            continue;
        }
        if let Some(span) = ConstantSpan::of::<COLOURED>(tri, any_opaque, far, ctx) {
            for_each_span(tri, tile, |row, first, end| {
                span.composite::<MAY_UNDERFLOW>(
                    ctx.triangles,
                    t,
                    tile,
                    ctx.reverse_z,
                    s,
                    row,
                    first,
                    end,
                );
            });
            continue;
        }
        let check_ties = any_opaque || near_far(tri, far, ctx.reverse_z);
        for_each_span(tri, tile, |row, first, end| {
            // A sink per span: a short-lived local whose fields the optimiser keeps in
            // registers (one that lives across spans is reloaded from memory per fragment).
            let mut sink = InOrderFragments::<COLOURED, MAY_UNDERFLOW> {
                behind: Behind {
                    far,
                    planes: ctx.planes,
                    opaque_key: &s.opaque_key,
                    any_opaque,
                    plane: tri.plane_depth,
                    check_ties,
                },
                undecided: &mut s.undecided,
                tie: &mut s.tie,
                pixels: &mut s.in_order,
                transmittance: &mut s.in_order_transmittance,
            };
            shade_span(
                tri,
                ctx.textures,
                tile,
                row,
                first,
                end,
                ctx.reverse_z,
                &mut sink,
            );
        });
    }
    true
}

/// Marks an entry of a permutation as moved while [`permute`] follows its cycles.
const MOVED: u32 = 1 << 31;

/// Reorders one pixel's slots in place so that slot `k` holds what slot `perm[k]` held (keys,
/// colours and, where the scene has them, transmittances together), following the
/// permutation's cycles: no buffer beyond `perm`, which is left as it was. Lists are shorter
/// than 2^31 (slot indices are u32 and a slice's slots fit it).
fn permute(
    perm: &mut [u32],
    keys: &mut [u64],
    colors: &mut [[f32; 4]],
    transmittance: &mut [[f64; 3]],
) {
    for start in 0..perm.len() {
        if perm[start] & MOVED != 0 || perm[start] as usize == start {
            continue;
        }
        let (key, color) = (keys[start], colors[start]);
        let t = transmittance.get(start).copied();
        let mut j = start;
        loop {
            let k = perm[j] as usize;
            perm[j] |= MOVED;
            if k == start {
                keys[j] = key;
                colors[j] = color;
                if let Some(t) = t {
                    transmittance[j] = t;
                }
                break;
            }
            keys[j] = keys[k];
            colors[j] = colors[k];
            if t.is_some() {
                transmittance[j] = transmittance[k];
            }
            j = k;
        }
    }
    for i in perm.iter_mut() {
        *i &= !MOVED;
    }
}

/// Whether `keys[perm[0]] < keys[perm[1]] < …` (`perm` indexes `keys`). Branch-free over the
/// list: the answer is almost always yes, so an early exit would not pay.
fn strictly_ascending(perm: &[u32], keys: &[u64]) -> bool {
    let Some((&first, rest)) = perm.split_first() else {
        return true;
    };
    let mut previous = keys[first as usize];
    let mut ascending = true;
    for &i in rest {
        let key = keys[i as usize];
        ascending &= previous < key;
        previous = key;
    }
    ascending
}

/// Lists up to this long are sorted by insertion, longer ones by merging runs.
const SHORT_LIST: usize = 12;

/// Sorts one pixel's list (indices of its fragments) by key; keys are unique: they contain the
/// triangle rank.
///
/// Fragments arrive in triangle-rank order, one per triangle, so a pixel's list is usually a
/// few monotone runs (each object's layers in order, one way or the other). This is a natural
/// merge sort: find the runs (reversing descending ones), then merge neighbours pairwise
/// through `buffer` until one run is left: O(n) for one or two runs, O(n log n) at worst, and
/// no allocation once the tile's scratch has grown. Short lists use insertion sort.
fn sort_by_key(
    list: &mut [u32],
    key: impl Fn(u32) -> u64,
    buffer: &mut Vec<u32>,
    runs: &mut Vec<usize>,
) {
    let n = list.len();
    if n <= SHORT_LIST {
        // Insertion sort on a local copy of the keys (no indirect loads while shifting).
        let mut keys = [0u64; SHORT_LIST];
        for (k, &i) in keys.iter_mut().zip(list.iter()) {
            *k = key(i);
        }
        for i in 1..n {
            let (f, fk) = (list[i], keys[i]);
            let mut j = i;
            while j > 0 && keys[j - 1] > fk {
                list[j] = list[j - 1];
                keys[j] = keys[j - 1];
                j -= 1;
            }
            list[j] = f;
            keys[j] = fk;
        }
        return;
    }
    runs.clear();
    runs.push(0);
    let mut i = 0;
    while i < n {
        let mut j = i + 1;
        if j < n && key(list[j]) < key(list[j - 1]) {
            while j < n && key(list[j]) < key(list[j - 1]) {
                j += 1;
            }
            list[i..j].reverse();
        } else {
            while j < n && key(list[j]) > key(list[j - 1]) {
                j += 1;
            }
        }
        runs.push(j);
        i = j;
    }
    if runs.len() == 2 {
        return;
    }
    buffer.clear();
    buffer.extend_from_slice(list);
    // Ping-pong between `list` and `buffer`; `in_list` says where the current runs live.
    let mut in_list = true;
    while runs.len() > 2 {
        let (src, dst): (&[u32], &mut [u32]) = if in_list {
            (&*list, &mut buffer[..])
        } else {
            (&buffer[..], &mut *list)
        };
        let mut merged = 1;
        let mut r = 0;
        while r + 1 < runs.len() {
            let lo = runs[r];
            if r + 2 < runs.len() {
                let (mid, hi) = (runs[r + 1], runs[r + 2]);
                merge(&src[lo..mid], &src[mid..hi], &mut dst[lo..hi], &key);
                runs[merged] = hi;
                r += 2;
            } else {
                let hi = runs[r + 1];
                dst[lo..hi].copy_from_slice(&src[lo..hi]);
                runs[merged] = hi;
                r += 1;
            }
            merged += 1;
        }
        runs.truncate(merged);
        in_list = !in_list;
    }
    if !in_list {
        list.copy_from_slice(buffer);
    }
}

/// Merges two runs ascending by key into `out` (`out.len() == a.len() + b.len()`).
fn merge(a: &[u32], b: &[u32], out: &mut [u32], key: &impl Fn(u32) -> u64) {
    let (mut i, mut j) = (0, 0);
    for slot in out.iter_mut() {
        let take_a = j >= b.len() || (i < a.len() && key(a[i]) < key(b[j]));
        if take_a {
            *slot = a[i];
            i += 1;
        } else {
            *slot = b[j];
            j += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_merge_sort_matches_a_plain_sort() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let (mut buffer, mut runs) = (Vec::new(), Vec::new());
        for case in 0..2000 {
            let n = (next() % 300) as usize;
            // Unique keys: a permutation scaled up, then shaped into runs.
            let mut keys: Vec<u64> = (0..n as u64).map(|k| k * 3 + 1).collect();
            match case % 4 {
                0 => {}
                1 => keys.reverse(),
                2 => {
                    // A few ascending and descending runs.
                    let cut = (next() as usize) % (n + 1);
                    keys[..cut].reverse();
                    keys.rotate_left(cut / 2);
                }
                _ => {
                    for i in (1..n).rev() {
                        keys.swap(i, (next() % (i as u64 + 1)) as usize);
                    }
                }
            }
            let mut list: Vec<u32> = (0..n as u32).collect();
            sort_by_key(&mut list, |i| keys[i as usize], &mut buffer, &mut runs);
            let got: Vec<u64> = list.iter().map(|&i| keys[i as usize]).collect();
            let mut want = keys.clone();
            want.sort_unstable();
            assert_eq!(got, want, "case {case}, n = {n}");
            let mut seen = list.clone();
            seen.sort_unstable();
            assert!(
                seen.iter().copied().eq(0..n as u32),
                "the result is a permutation"
            );
        }
    }

    #[test]
    fn permute_reorders_every_array_by_the_permutation_and_restores_it() {
        let mut state = 0x51_7cc1_b727_220au64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for n in 0..40usize {
            for coloured in [false, true] {
                let mut perm: Vec<u32> = (0..n as u32).collect();
                for i in (1..n).rev() {
                    perm.swap(i, (next() % (i as u64 + 1)) as usize);
                }
                let keys: Vec<u64> = (0..n).map(|_| next()).collect();
                let colors: Vec<[f32; 4]> = (0..n).map(|i| [i as f32; 4]).collect();
                let t: Vec<[f64; 3]> = if coloured {
                    (0..n).map(|i| [i as f64, -(i as f64), 0.5]).collect()
                } else {
                    Vec::new()
                };
                let (mut k, mut c, mut tt, mut p) =
                    (keys.clone(), colors.clone(), t.clone(), perm.clone());
                permute(&mut p, &mut k, &mut c, &mut tt);
                assert_eq!(p, perm, "the permutation is left as it was");
                for j in 0..n {
                    let from = perm[j] as usize;
                    assert_eq!(k[j], keys[from], "n = {n}, slot {j}");
                    assert_eq!(c[j], colors[from]);
                    if coloured {
                        assert_eq!(tt[j], t[from]);
                    }
                }
                assert_eq!(tt.len(), t.len());
            }
        }
    }

    #[test]
    fn reciprocal_quotients_round_like_division() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let unit = |bits: u64| (bits >> 11) as f64 / (1u64 << 53) as f64;
        let (mut fast, mut checked) = (0, 0);
        for case in 0..1_000_000 {
            let sum: f64 = match case % 5 {
                0 => unit(next()) * 4.0,
                1 => unit(next()) * 1e-30,
                2 => -unit(next()) * 1e30,
                3 => [0.0, -0.0, 1e-310, f64::MIN_POSITIVE, 1e300][case / 5 % 5],
                _ => unit(next()) + 0.5,
            };
            // Quotients on and around f32 rounding midpoints, exact f32 values, zeros and
            // values outside the f32 range.
            let f = f32::from_bits((next() as u32) & 0x3fff_ffff);
            let midpoint = (f64::from(f) + f64::from(f32::from_bits(f.to_bits() + 1))) / 2.0;
            let target = match case % 7 {
                0..=2 => midpoint,
                3 => f64::from(f),
                4 => [0.0, -0.0, 1e-320, 1e40][case % 4],
                _ => unit(next()),
            };
            let nudge = 1.0 + ((next() % 64) as f64 - 32.0) * f64::EPSILON;
            let num = target * sum * nudge;
            let inv = 1.0 / sum;
            let (got, exact) = quotient_via_reciprocal(num, inv);
            // `colours` only uses the result when the reciprocal is a normal f64.
            if exact && inv.is_normal() {
                let want = (num / sum) as f32;
                assert_eq!(got.to_bits(), want.to_bits(), "{num} / {sum}");
                fast += 1;
            }
            checked += 1;
        }
        // Most quotients take the fast path, but not those closest to a midpoint.
        assert!(
            fast > checked / 2 && fast < checked * 9 / 10,
            "{fast} of {checked}"
        );
    }

    #[test]
    fn depth_key_orders_like_camera_nearer() {
        let depths = [
            0.0f32, -0.0, 1e-30, 1e-7, 0.25, 0.5, 0.5000001, 0.99999994, 1.0,
        ];
        for reverse_z in [false, true] {
            for &a in &depths {
                for &b in &depths {
                    let nearer = if reverse_z { a > b } else { a < b };
                    let by_key = depth_key(a, reverse_z) < depth_key(b, reverse_z);
                    // -0.0 and 0.0 compare equal as floats but get different keys: both are
                    // clamped to +0.0 before keying in the renderer, so only check a != b.
                    if a != b {
                        assert_eq!(by_key, nearer, "{a} vs {b}, reverse_z={reverse_z}");
                    }
                }
            }
        }
    }

    /// Checks [`depth_key_bounds`] against the exact key of every covered pixel of every
    /// triangle it bounds; the number of triangles and fragments checked.
    fn check_depth_key_bounds(scene: &oit_scene::Scene, what: &str) -> (u64, u64) {
        let pieces = crate::set_up(scene).expect("a valid scene").0.triangles;
        let tile = TileRect {
            x0: 0,
            y0: 0,
            width: scene.resolution.width,
            height: scene.resolution.height,
        };
        let reverse_z = scene.camera.reverse_z;
        let (mut bounded, mut fragments) = (0, 0);
        for tri in pieces.chunks().iter().flatten() {
            if tri.inv_farea2 == 0.0 {
                continue;
            }
            let Some((lo, hi)) = depth_key_bounds(tri, reverse_z) else {
                continue;
            };
            bounded += 1;
            for_each_span(tri, tile, |row, first, end| {
                let weights = RowWeights::new(tri, tile, row);
                for x in first..end {
                    let key = depth_key(depths(tri, &weights.at(x))[0], reverse_z);
                    assert!(
                        (lo..=hi).contains(&key),
                        "{what}: triangle {} at ({x}, {row}): key {key} outside {lo}..={hi}",
                        tri.key
                    );
                    fragments += 1;
                }
            });
        }
        (bounded, fragments)
    }

    #[test]
    fn depth_key_bounds_hold_for_every_fragment() {
        let (mut bounded, mut fragments) = (0, 0);
        for seed in 0..200 {
            let (text, about) = oit_scene::random::random_scene_json(seed);
            let scene = oit_scene::parse(&text, "random").expect("random scene");
            let (b, f) = check_depth_key_bounds(&scene, &format!("seed {seed}: {about:?}"));
            (bounded, fragments) = (bounded + b, fragments + f);
        }
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
        for (path, scene) in oit_scene::load_dir(&dir).expect("bundled scenes") {
            let scene = scene.with_resolution(oit_scene::Resolution {
                width: 256,
                height: 256,
            });
            let (b, f) = check_depth_key_bounds(&scene, &path.display().to_string());
            (bounded, fragments) = (bounded + b, fragments + f);
        }
        assert!(
            bounded > 10_000 && fragments > 1_000_000,
            "{bounded} triangles, {fragments} fragments"
        );
    }

    /// A stack of `count` full-screen constant layers of alpha `alpha` (two triangles each),
    /// set up, and every triangle as one bin.
    fn layer_bin(count: u32, alpha: f32) -> (Triangles, Vec<u32>) {
        let text = format!(
            r#"{{"name": "stack", "resolution": [8, 8],
              "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0],
                          "fov_y": 45, "near": 0.1, "far": 100}},
              "objects": [{{"mesh": {{"kind": "layers", "count": {count}, "spacing": 0.001,
                            "size": [8, 8], "color_from": [1, 0.5, 0.2],
                            "color_to": [0.2, 0.5, 1], "alpha_from": {alpha},
                            "alpha_to": {alpha}}},
                            "material": {{"mode": "blend"}}}}]}}"#
        );
        let scene = oit_scene::parse(&text, "stack").expect("a layer stack");
        let triangles = crate::set_up(&scene).expect("a valid scene").0.triangles;
        let bin = triangles.ids().collect();
        (triangles, bin)
    }

    #[test]
    fn the_underflow_bound_counts_halvings_of_the_transmittance() {
        // α = 0.5: each triangle of the bin may halve it once; 990 halvings are allowed.
        let (triangles, bin) = layer_bin(495, 0.5);
        assert_eq!(bin.len(), 990);
        assert!(!may_underflow(&triangles, &bin));
        let (triangles, bin) = layer_bin(496, 0.5);
        assert!(may_underflow(&triangles, &bin));
        // 1 − 0.3 = 0.7 ≥ 2^-1: one halving each, however many digits it has.
        let (triangles, bin) = layer_bin(495, 0.3);
        assert!(!may_underflow(&triangles, &bin));
        // 1 − 0.99 ≥ 2^-7: seven each, so 71 layers (142 triangles, 994) may reach it and 70
        // (980) may not.
        let (triangles, bin) = layer_bin(71, 0.99);
        assert!(may_underflow(&triangles, &bin));
        assert!(!may_underflow(&triangles, &bin[..140]));
        // Opaque-as-blend layers (α = 1) leave 0, which is no subnormal, however many.
        let (triangles, bin) = layer_bin(2000, 1.0);
        assert!(!may_underflow(&triangles, &bin));
    }
}
