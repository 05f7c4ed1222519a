//! Compositing in arrival order: where fragments arrive sorted, each goes straight into its
//! pixel's sums; only pixels found out of order take the stored path.

use super::*;

/// One pixel's state while its tile is composited in arrival order ([`render_rect_in_order`]),
/// together in one struct: a fragment touches one cache line and one bounds check.
#[derive(Debug, Clone, Copy)]
pub(crate) struct InOrderPixel {
    /// Premultiplied colour sum so far, f64.
    pub(super) color: [f64; 3],
    /// Transmittance so far in scalar scenes (scenes with coloured transmission keep it per
    /// channel beside the pixel).
    pub(super) through: f64,
    /// Depth key of the last composited fragment, or an upper bound of it where that was
    /// enough to know it in order ([`ConstantSpan`]); 0 before the first (every depth key of
    /// a depth in [0, 1] is far above the tie distance from it); [`DISORDERED`] for good once
    /// a fragment did not follow the last one ([`InOrderPixel::follows`]): the stored path
    /// decides this pixel. No fragment follows that value, so the pixel stays disordered, and
    /// the state needs no flag of its own: 48 bytes instead of 56, so fewer pixels straddle
    /// two cache lines and a tile's state is 49 kB instead of 57.
    pub(super) last_depth: u32,
    /// The triangle whose fragment `last_depth` is only an upper bound of, or [`EXACT`].
    pub(super) bound_of: u32,
    /// Fragments composited.
    pub(super) layers: u32,
    /// Transparent fragments the cutoff kept that were not composited (hidden by the opaque
    /// depth or the far plane): with `layers`, every fragment it kept. Counted apart so that
    /// a composited fragment, nearly all of them, costs no second counter.
    pub(super) hidden: u32,
}

/// [`InOrderPixel::last_depth`] of a disordered pixel: above every depth key of a depth in
/// [0, 1] (at most `0xBF80_0000`, the key of 1.0, or `0x7FFF_FFFF` under reverse-Z), so no key
/// follows it.
pub(super) const DISORDERED: u32 = u32::MAX;
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
    pub(super) fn disordered(&self) -> bool {
        self.last_depth == DISORDERED
    }

    /// `dkey` becomes the last key if it follows the last one; otherwise the pixel is
    /// [`DISORDERED`].
    #[inline(always)]
    pub(super) fn step_to(&mut self, dkey: u32) {
        self.last_depth = if self.follows(dkey) { dkey } else { DISORDERED };
    }

    /// Whether `dkey` may follow the last composited depth key: farther by more than the tie
    /// distance. Then it is the next fragment of the sorted list and no neighbour pair of it
    /// is a precision tie.
    #[inline(always)]
    pub(super) fn follows(&self, dkey: u32) -> bool {
        u64::from(self.last_depth) + u64::from(PRECISION_TIE_ULPS) < u64::from(dkey)
    }

    /// Composites a visible fragment of a scalar scene ([`over_step`]).
    #[inline(always)]
    pub(super) fn add<const MAY_UNDERFLOW: bool>(
        &mut self,
        dkey: u32,
        premultiplied: [f64; 3],
        keep: f64,
    ) {
        self.step_to(dkey);
        self.bound_of = EXACT;
        self.composite::<MAY_UNDERFLOW>(premultiplied, keep);
    }

    /// [`over_step`] for a fragment known to follow the last one.
    #[inline(always)]
    pub(super) fn composite<const MAY_UNDERFLOW: bool>(
        &mut self,
        premultiplied: [f64; 3],
        keep: f64,
    ) {
        self.layers += 1;
        over_step::<MAY_UNDERFLOW>(&mut self.color, &mut self.through, premultiplied, keep);
    }

    /// Composites a visible fragment of a scene with coloured transmission, `through` being
    /// the pixel's per-channel transmittance ([`over_step_coloured`]).
    #[inline(always)]
    pub(super) fn add_coloured(
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
pub(super) const EXACT: u32 = u32::MAX;

/// The transparent pass of [`render_rect_in_order`]: each fragment strictly nearer than the
/// opaque depth (or far) is composited into its pixel as it arrives, by the operations of
/// [`composite_iter`] (scalar) or [`composite_coloured_iter`] (`COLOURED`) in the same order,
/// so that the sums are bit for bit those of the stored path wherever the arrival order is
/// the sorted order; pixels where it is not are marked ([`InOrderPixel::disordered`]).
/// Bookkeeping as [`TransparentFragments`]. The pass's own fragments are counted in
/// [`InOrderPixel::layers`] and [`InOrderPixel::hidden`], apart from the opaque pass's
/// `all_count`.
pub(super) struct InOrderFragments<'a, const COLOURED: bool, const MAY_UNDERFLOW: bool> {
    pub(super) behind: Behind<'a>,
    pub(super) undecided: &'a mut [u32],
    pub(super) tie: &'a mut [bool],
    pub(super) pixels: &'a mut [InOrderPixel],
    /// Per pixel, only when `COLOURED`: the per-channel transmittance.
    pub(super) transmittance: &'a mut [[f64; 3]],
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
pub(super) struct ConstantSpan {
    pub(super) premultiplied: [f64; 3],
    /// `1 − α`.
    pub(super) keep: f64,
    /// α is in the cutoff's undecided band.
    pub(super) undecided: bool,
    /// The far plane's depth key: fragments must be strictly nearer to be composited.
    pub(super) far: u32,
    /// For a flat triangle: its one depth key, and whether it ties with the far plane
    /// ([`ties_opaque`]). Otherwise no vertex is within the tie distance of it
    /// ([`near_far`]), and keys are interpolated per pixel.
    pub(super) flat: Option<(u32, bool)>,
    /// Otherwise, where the triangle is no sliver and lies in front of the far plane: bounds
    /// on its fragments' depth keys ([`depth_key_bounds`]). A pixel whose last key is below
    /// the lower one by more than the tie distance needs no key of its own.
    pub(super) bounds: Option<(u32, u32)>,
}

impl ConstantSpan {
    #[inline(always)]
    pub(super) fn of<const COLOURED: bool>(
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
    pub(super) fn composite<const MAY_UNDERFLOW: bool>(
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
pub(super) const STORED_MERGE_SLACK: u32 = 64;

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
pub(super) fn render_rect_in_order(
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
pub(super) fn write_background(
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
pub(super) fn write_in_order<const OPAQUE: bool>(
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
pub(super) fn may_underflow(triangles: &Triangles, bin: &[u32]) -> bool {
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
pub(super) const GIVE_UP_TRIANGLES: usize = 8;

/// Whether at least three quarters of every fourth pixel of every fourth row of `tile` are
/// already disordered. Then the tile's stored rectangles will cover about all of it, and finishing the
/// in-order pass only to render the tile again with stored lists would cost it both paths
/// (measured on seeded random scenes of interpenetrating layer stacks: 1.2–1.4× the stored
/// path alone). A sixteenth of the pixels keeps the check cheap beside the pass.
pub(super) fn mostly_disordered(s: &Scratch, tile: TileRect) -> bool {
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
pub(super) fn transparent_in_order<const COLOURED: bool, const MAY_UNDERFLOW: bool>(
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
    true
}
