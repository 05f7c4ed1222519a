//! One tile: the opaque pass, the transparent fragments counted, stored, sorted and composited
//! (the stored path), the split of a deep tile into bands, and the tile's outputs.

use super::*;

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
    pub(super) fn reborrow(&mut self) -> TileOutput<'_> {
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
    pub(super) fn split_rows(self, rows: usize) -> (Self, Self) {
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
    /// The lights and eye of lit materials.
    pub lighting: super::Lighting<'a>,
    pub planes: &'a [f64],
    pub reverse_z: bool,
    pub background: [f64; 3],
    /// Some draw has coloured transmission: fragments keep a per-channel transmittance.
    pub coloured: bool,
    /// Try [`render_rect_in_order`] before the stored path ([`crate::ReferenceOptions`]).
    pub in_order: bool,
    /// Called by [`render_rect`] with each rectangle's sorted lists ([`crate::render_visiting`]).
    pub visit: Option<(&'a crate::FragmentVisitor<'a>, &'a crate::fragments::Ranks)>,
    /// Render queue levels of a scene where they change the answer ([`QueueTable::new`]);
    /// such scenes take the stored path only.
    pub queues: Option<&'a QueueTable>,
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
pub(super) const OUTPUT_BYTES: u64 =
    (size_of::<[f32; 4]>() + 3 * size_of::<u32>() + size_of::<bool>()) as u64;

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
pub(super) fn in_order_in_bands(
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
pub(super) fn count_tile(
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
pub(super) struct Slices<'a> {
    pub(super) counts: &'a [u32],
    pub(super) row_spans: &'a [u32],
    pub(super) tile: TileRect,
    pub(super) limit: u64,
    pub(super) coloured: bool,
    pub(super) row: usize,
    pub(super) x: usize,
}

impl<'a> Slices<'a> {
    pub(super) fn new(counter: &'a Scratch, tile: TileRect, limit: u64, coloured: bool) -> Self {
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
    pub(super) fn fits(&self, pixels: u64, slots: u64, spans: u64, longest: u64) -> bool {
        slots <= u64::from(u32::MAX)
            && rect_bytes(pixels, slots, spans, longest, self.coloured) + pixels * OUTPUT_BYTES
                <= self.limit
    }

    pub(super) fn count_at(&self, row: usize, x: usize) -> u64 {
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
pub(super) fn counted_slots(s: &Scratch, n: usize) -> u64 {
    s.start[1..=n].iter().map(|&c| u64::from(c)).sum()
}

/// Makes room for `rows` more spans in the coverage pass of [`render_rect`], unless what the
/// rectangle has counted so far (its state, spans and a slot per covered transparent fragment)
/// already exceeds `limit`: then it is given up early, before recording the rest.
#[cold]
#[inline(never)]
pub(super) fn grow_spans(
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
pub(super) fn render_rect(
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
        lighting,
        planes,
        reverse_z,
        background,
        coloured,
        in_order: _,
        visit,
        queues,
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
        shade_span(
            tri, textures, &lighting, tile, row, first, last, reverse_z, &mut sink,
        );
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
    if let Some(table) = queues {
        for p in 0..n {
            order_by_queue(table, s, p, planes);
        }
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
            // With queues, `order_by_queue` found the ties (neighbours here may differ in level).
            if queues.is_none() && close(previous.0, depth) {
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
    if let Some((visit, ranks)) = visit {
        visit(&crate::RectFragments {
            x0: tile.x0,
            y0: tile.y0,
            width: tile.width,
            height: tile.height,
            start: &s.start[..n],
            end: &s.end[..n],
            keys: &s.keys,
            colors: &s.colors,
            transmittance: if coloured { &s.transmittance } else { &[] },
            opaque_key: &s.opaque_key[..n],
            opaque_color: &s.opaque_color[..n],
            far,
            background,
            ranks,
            reverse_z,
        });
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
pub(super) fn reset_shared_state(s: &mut Scratch, n: usize, far: u64) {
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
pub(super) fn reset_transparent_state(s: &mut Scratch, n: usize) {
    s.undecided.clear();
    s.undecided.resize(n, 0);
    s.tie.clear();
    s.tie.resize(n, false);
}

/// The opaque pass of one opaque (or mask) triangle over `tile`.
#[inline(always)]
pub(super) fn shade_opaque(
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
            &ctx.lighting,
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
pub(super) struct PixelResult {
    pub(super) rgb: [f64; 3],
    pub(super) layers: u32,
    pub(super) fragments: u32,
    pub(super) undecided: u32,
    pub(super) tie: bool,
}

impl PixelResult {
    /// Writes the pixel at index `o` of the outputs and adds it to `stats`.
    #[inline(always)]
    pub(super) fn write(&self, out: &mut TileOutput<'_>, o: usize, stats: &mut TileStats) {
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
