//! The tile rectangle and the spans of pixels a triangle covers in it: exact integer edge
//! functions, the top-left fill rule.

use super::*;

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
pub(super) fn for_each_span(tri: &SetupTriangle, tile: TileRect, mut f: impl FnMut(u32, u32, u32)) {
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
pub(super) fn row_span(e: [i64; 3], step: [i64; 3], bias: [i64; 3], width: i64) -> (i64, i64) {
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
