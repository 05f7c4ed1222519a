//! Shading a span: depth, perspective-correct attributes and textures per pixel, handed to the
//! opaque or transparent pass as fragments.

use super::*;

/// What lit materials are shaded with: the scene's lights and the camera eye.
#[derive(Clone, Copy)]
pub(crate) struct Lighting<'a> {
    pub(crate) rig: &'a oit_scene::LightRig,
    pub(crate) eye: [f32; 3],
}

/// Pixels per batch of the shading kernel: the float arithmetic of neighbouring pixels is
/// independent, so it is written over small arrays that the compiler turns into SIMD.
pub(super) const LANES: usize = 4;

/// Receives the fragments of [`shade_span`]. A trait with `#[inline(always)]` implementations
/// rather than a closure: LLVM left the transparent pass's closure out of line once it grew
/// (a call per fragment halved the reference's throughput).
pub(super) trait Fragments {
    /// Pixel in the tile, [`depth_key`], shaded colour, whether α is in the cutoff's
    /// undecided band.
    fn fragment(&mut self, p: usize, dkey: u32, shaded: Shaded, undecided: bool);
}

/// The opaque pass of one triangle: nearest opaque fragment per pixel, fragment and
/// undecided counts, opaque precision ties.
pub(super) struct OpaqueFragments<'a> {
    pub(super) rank: u32,
    pub(super) plane: f64,
    pub(super) far: u64,
    pub(super) planes: &'a [f64],
    pub(super) opaque_key: &'a mut [u64],
    pub(super) opaque_color: &'a mut [[f32; 3]],
    pub(super) all_count: &'a mut [u32],
    pub(super) undecided: &'a mut [u32],
    pub(super) tie: &'a mut [bool],
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
pub(super) fn transparent_parts(shaded: Shaded) -> Option<([f32; 3], f32, Option<[f32; 3]>)> {
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
pub(super) struct TransparentFragments<'a> {
    /// Of the triangle being shaded.
    pub(super) rank: u32,
    pub(super) behind: Behind<'a>,
    pub(super) keys: &'a mut [u64],
    pub(super) colors: &'a mut [[f32; 4]],
    /// Per slot, empty unless the scene has coloured transmission.
    pub(super) transmittance: &'a mut [[f64; 3]],
    pub(super) end: &'a mut [u32],
    pub(super) all_count: &'a mut [u32],
    pub(super) undecided: &'a mut [u32],
    pub(super) tie: &'a mut [bool],
    pub(super) discarded: u64,
}

/// What a transparent fragment must lie strictly in front of to be composited: its pixel's
/// opaque surface, or the far plane where none is; shared by the transparent passes.
#[derive(Clone, Copy)]
pub(super) struct Behind<'a> {
    pub(super) far: u64,
    pub(super) planes: &'a [f64],
    pub(super) opaque_key: &'a [u64],
    /// False when no opaque fragment reached the tile: every opaque key is `far`, no load.
    pub(super) any_opaque: bool,
    /// Of the triangle being shaded: its plane depth, and whether its fragments can tie with
    /// the opaque depth or the far plane.
    pub(super) plane: f64,
    pub(super) check_ties: bool,
}

impl Behind<'_> {
    /// The depth key fragment `dkey` at pixel `p` must be below, after flagging in `tie` a
    /// precision tie with what it is (kept or hidden by rounding when this close).
    #[inline(always)]
    pub(super) fn nearest(&self, p: usize, dkey: u32, tie: &mut [bool]) -> u32 {
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
pub(super) fn transmittance_of(alpha: f32, transmittance: Option<[f32; 3]>) -> [f64; 3] {
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
pub(super) fn shade_span(
    tri: &SetupTriangle,
    textures: &[Texture],
    lighting: &Lighting<'_>,
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
                None if tri.lit || tri.textured => {
                    // The quad neighbours in the row and in the column, as helper lanes
                    // extrapolate them (see `quad_gradient`).
                    let at = |qx: u32, qy: u32| {
                        let px = i64::from(qx) * ONE + HALF;
                        let pys = i64::from(qy) * ONE + HALF;
                        let l: [[f64; 1]; 3] = std::array::from_fn(|i| {
                            let (a, b) = ((i + 1) % 3, (i + 2) % 3);
                            let e =
                                (xs[b] - xs[a]) * (pys - ys[a]) - (ys[b] - ys[a]) * (px - xs[a]);
                            [e as f64 * tri.inv_area2]
                        });
                        texcoords(tri, &l)[0]
                    };
                    let sample = tri.textured.then(|| {
                        let uv = texcoords(tri, &l)[0];
                        let gx = tile.x0 + x;
                        (uv, quad_gradient(uv, at(gx ^ 1, y), at(gx, y ^ 1)))
                    });
                    // Not lit means textured here, so `sample` is there.
                    match sample {
                        Some((uv, grad)) if !tri.lit => {
                            shade_textured(tri, &tri.material, textures, rgba[0], uv, grad)
                        }
                        _ => shade_lit(tri, textures, lighting, rgba[0], &l, 0, sample),
                    }
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
    } else if tri.lit {
        // The other row of each pixel's 2×2 quad, for the fine derivatives along y.
        let other_row = RowWeights::at_row(tri, tile, y ^ 1);
        for x in (first..end).step_by(LANES) {
            let l = weights(x);
            let (depth, rgba) = attributes(tri, &l);
            let samples = tri.textured.then(|| {
                let uv = texcoords(tri, &l);
                let uv_x = texcoords(tri, &row_weights.at_quad_neighbours(x));
                let uv_y = texcoords(tri, &other_row.at(x));
                let grads: [[f32; 4]; LANES] =
                    std::array::from_fn(|j| quad_gradient(uv[j], uv_x[j], uv_y[j]));
                (uv, grads)
            });
            let dkey = depth_keys(depth, reverse_z);
            let p = base + x as usize;
            for j in 0..((end - x) as usize).min(LANES) {
                let sample = samples.map(|(uv, grads)| (uv[j], grads[j]));
                let (shaded, open) = shade_lit(tri, textures, lighting, rgba[j], &l, j, sample);
                sink.fragment(p + j, dkey[j], shaded, open);
            }
        }
    } else if tri.textured {
        let material = tri.material;
        // The other row of each pixel's 2×2 quad, for the fine derivatives along y.
        let other_row = RowWeights::at_row(tri, tile, y ^ 1);
        for x in (first..end).step_by(LANES) {
            let l = weights(x);
            let (depth, rgba) = attributes(tri, &l);
            let uv = texcoords(tri, &l);
            let uv_x = texcoords(tri, &row_weights.at_quad_neighbours(x));
            let uv_y = texcoords(tri, &other_row.at(x));
            let dkey = depth_keys(depth, reverse_z);
            let p = base + x as usize;
            for j in 0..((end - x) as usize).min(LANES) {
                let grad = quad_gradient(uv[j], uv_x[j], uv_y[j]);
                let (shaded, open) = shade_textured(tri, &material, textures, rgba[j], uv[j], grad);
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
pub(super) fn flat_depth_key(tri: &SetupTriangle, reverse_z: bool) -> Option<u32> {
    (tri.inv_farea2 != 0.0 && tri.z[0] == tri.z[1] && tri.z[1] == tri.z[2])
        .then(|| depth_key(tri.z[0].clamp(0.0, 1.0) + 0.0, reverse_z))
}

/// Barycentric weights along one tile row of a triangle with non-zero float area, from its
/// unsnapped f32 window positions ([`shade_span`]), a batch of [`LANES`] pixels at a time.
pub(super) struct RowWeights {
    /// `E_i(px, py) = dx_i·(py − ya) − dy_i·(px − xa)`: the first product is constant along
    /// a row.
    pub(super) along_row: [f64; 3],
    pub(super) dy: [f64; 3],
    pub(super) xa: [f64; 3],
    pub(super) inv_farea2: f64,
    /// The tile's first pixel column.
    pub(super) x0: u32,
}

impl RowWeights {
    #[inline(always)]
    pub(super) fn new(tri: &SetupTriangle, tile: TileRect, row: u32) -> Self {
        Self::at_row(tri, tile, tile.y0 + row)
    }

    /// The weights along pixel row `y` (absolute), over the columns of `tile`.
    #[inline(always)]
    pub(super) fn at_row(tri: &SetupTriangle, tile: TileRect, y: u32) -> Self {
        let py = y as f64 + 0.5;
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
    pub(super) fn at(&self, x: u32) -> [[f64; LANES]; 3] {
        // Pixel centres; small integers plus 0.5, so the sum is exact.
        let px0 = (self.x0 + x) as f64 + 0.5;
        self.at_centres(std::array::from_fn(|j| px0 + j as f64))
    }

    /// The weights of the other pixel of each one's 2×2 quad in this row: columns
    /// `(x0 + x + j) ^ 1` for `j` in `0..LANES`.
    #[inline(always)]
    pub(super) fn at_quad_neighbours(&self, x: u32) -> [[f64; LANES]; 3] {
        let first = self.x0 + x;
        self.at_centres(std::array::from_fn(|j| {
            ((first + j as u32) ^ 1) as f64 + 0.5
        }))
    }

    #[inline(always)]
    fn at_centres(&self, px: [f64; LANES]) -> [[f64; LANES]; 3] {
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
pub(super) fn depth_key_bounds(tri: &SetupTriangle, reverse_z: bool) -> Option<(u32, u32)> {
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

/// The fine screen derivatives of the texture coordinate, (du/dx, dv/dx, du/dy, dv/dy), from
/// the pixel's own `uv` and the texture coordinates of its 2×2 quad's other pixel in the row
/// (`row`) and in the column (`column`), each evaluated like the pixel's own (helper lanes
/// extrapolate the same plane equations). The GPU's `dpdxFine`/`dpdyFine` subtract the quad's
/// left from its right pixel; here the sign may be the opposite, which no footprint sees (the
/// f32 difference negates exactly and is squared).
#[inline(always)]
pub(super) fn quad_gradient(uv: [f32; 2], row: [f32; 2], column: [f32; 2]) -> [f32; 4] {
    [
        row[0] - uv[0],
        row[1] - uv[1],
        column[0] - uv[0],
        column[1] - uv[1],
    ]
}

/// One fragment of a textured triangle: the material's texture samples at `uv` with screen
/// derivatives `grad`, the material rule, and whether it is undecided: α in the cutoff's
/// undecided band (widened by the texture's reach and the level of detail's), or a sample that
/// rounding could make jump (`sample_may_jump`).
#[inline(always)]
pub(super) fn shade_textured(
    tri: &SetupTriangle,
    material: &Material,
    textures: &[Texture],
    rgba: [f32; 4],
    uv: [f32; 2],
    grad: [f32; 4],
) -> (Shaded, bool) {
    let (texels, open) = sample_textured(tri, material, textures, rgba[3], uv, grad);
    (material.shade(rgba, texels), open)
}

/// The texture samples of a textured fragment at `uv` with screen derivatives `grad`, and
/// whether it is undecided (see [`shade_textured`]); shared by the unlit and lit rules.
#[inline(always)]
fn sample_textured(
    tri: &SetupTriangle,
    material: &Material,
    textures: &[Texture],
    alpha: f32,
    uv: [f32; 2],
    grad: [f32; 4],
) -> (Texels, bool) {
    let texels = material.texels(textures, uv, grad);
    let jumps =
        |t: Option<u32>| t.is_some_and(|t| sample_may_jump(&textures[t as usize], uv, grad));
    let open = jumps(material.base_texture)
        || jumps(material.emissive_texture)
        || tri.cutoff_rounds
            && match material.base_texture {
                Some(t) => undecided_textured(
                    material,
                    &textures[t as usize],
                    alpha,
                    texels.base[3],
                    uv,
                    grad,
                ),
                None => undecided(material, alpha),
            };
    (texels, open)
}

/// One fragment of a lit triangle (pixel `j` of the batch of weights `l`): its texture samples
/// (`sample`: uv and quad derivatives, if textured), its perspective-correct world position and normal (negated on a back face),
/// the material rule with the scene's lights, and whether α is in the cutoff's undecided band.
#[inline(never)]
pub(super) fn shade_lit<const N: usize>(
    tri: &SetupTriangle,
    textures: &[Texture],
    lighting: &Lighting<'_>,
    rgba: [f32; 4],
    l: &[[f64; N]; 3],
    j: usize,
    sample: Option<([f32; 2], [f32; 4])>,
) -> (Shaded, bool) {
    let material = &tri.material;
    let (texels, open) = match sample {
        Some((uv, grad)) => sample_textured(tri, material, textures, rgba[3], uv, grad),
        None => (
            Texels::UNTEXTURED,
            tri.cutoff_rounds && undecided(material, rgba[3]),
        ),
    };
    let position = interpolate3(tri, &tri.world, l, j);
    let mut normal = interpolate3(tri, &tri.normal, l, j);
    if !tri.front {
        normal = normal.map(|c| -c);
    }
    let point = oit_scene::SurfacePoint {
        position,
        normal,
        eye: lighting.eye,
    };
    (
        material.shade_lit(rgba, texels, Some((lighting.rig, &point))),
        open,
    )
}

/// A perspective-correct per-vertex vector of pixel `j` (weights / w, f32 as the shader
/// receives it), by the same steps as [`texcoords`].
#[inline(always)]
fn interpolate3<const N: usize>(
    tri: &SetupTriangle,
    values: &[[f32; 3]; 3],
    l: &[[f64; N]; 3],
    j: usize,
) -> [f32; 3] {
    let pw: [f64; 3] = std::array::from_fn(|i| l[i][j] * tri.inv_w[i]);
    let sum = pw[0] + pw[1] + pw[2];
    std::array::from_fn(|k| {
        let weighted = pw[0] * f64::from(values[0][k])
            + pw[1] * f64::from(values[1][k])
            + pw[2] * f64::from(values[2][k]);
        (weighted / sum) as f32
    })
}

/// Perspective-correct texture coordinates (weights / w, f32 as the shader receives them), by
/// the same steps as the colours in [`attributes`] with a plain division.
#[inline(always)]
pub(super) fn texcoords<const N: usize>(tri: &SetupTriangle, l: &[[f64; N]; 3]) -> [[f32; 2]; N] {
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
pub(super) fn depth_keys<const N: usize>(depth: [f32; N], reverse_z: bool) -> [u32; N] {
    std::array::from_fn(|j| depth_key(depth[j], reverse_z))
}

/// Window depth from the barycentric weights `l`: linear in screen space, stored as f32 and
/// clamped to the viewport depth range [0, 1] like the GPU does. `+ 0.0` turns −0.0 into +0.0
/// so both get one sort key.
#[inline(always)]
pub(super) fn depths<const N: usize>(tri: &SetupTriangle, l: &[[f64; N]; 3]) -> [f32; N] {
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
pub(super) fn attributes<const N: usize>(
    tri: &SetupTriangle,
    l: &[[f64; N]; 3],
) -> ([f32; N], [[f32; 4]; N]) {
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
pub(super) fn divide<const N: usize>(weighted: &[[f64; 4]; N], sum: &[f64; N]) -> [[f32; 4]; N] {
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
pub(super) fn quotient_via_reciprocal(num: f64, inv: f64) -> (f32, bool) {
    const BELOW: f64 = 1.0 - 1.0 / (1u64 << 48) as f64;
    const ABOVE: f64 = 1.0 + 1.0 / (1u64 << 48) as f64;
    let q = num * inv;
    let below = (q * BELOW) as f32;
    (below, below == (q * ABOVE) as f32)
}
