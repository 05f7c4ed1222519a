//! Triangle setup: clip-space clipping, viewport transform, sub-pixel snapping, face culling and
//! edge-function setup. Everything after this module works on integer window coordinates.
//!
//! The steps follow the Vulkan pipeline that wgpu drives, in the same number formats where that
//! matters for coverage: positions come from [`oit_scene::Camera::clip`] in f32, the perspective
//! divide and the viewport transform are done in f32 with lavapipe's operations, and window x/y
//! are snapped to 1/256 pixel.

use glam::Vec4;
use oit_scene::{Material, Scene, Shaded, Texels, Texture};

/// Sub-pixel precision: window coordinates are snapped to 1/256 pixel (8 bits), as the Vulkan
/// implementations in use do (`subPixelPrecisionBits = 8`).
pub(crate) const SUBPIXEL_BITS: u32 = 8;
/// One pixel in sub-pixel units.
pub(crate) const ONE: i64 = 1 << SUBPIXEL_BITS;
/// Half a pixel: pixel centres are at `ONE * x + HALF`.
pub(crate) const HALF: i64 = ONE / 2;

/// Largest coordinate (sub-pixel units) a snapped vertex may have. Clipping to the view volume
/// keeps window coordinates inside the viewport (up to rounding), so this clamp never fires for
/// viewports below 2^21 pixels; it bounds the edge functions (differences of two products of
/// differences of such values, < 2^61) so that i64 arithmetic cannot overflow whatever the input.
const COORD_LIMIT: i64 = 1 << 29;

/// A snapped coordinate, clamped to ±[`COORD_LIMIT`] by [`to_window`], as stored.
fn snapped_i32(v: i64) -> i32 {
    i32::try_from(v).expect("snapped coordinates are clamped to ±2^29")
}

/// Input triangles (consecutive ranks) set up by one parallel task into one list of
/// [`Triangles`].
pub(crate) const CHUNK_RANKS: usize = 2048;

/// Bits of a [`Triangles`] id that give the position in its chunk's list.
const ID_SHIFT: u32 = 15;

/// Most pieces one input triangle becomes: a fan of the clipped polygon, whose vertices fit
/// [`MAX_POLY`].
const MAX_PIECES: usize = MAX_POLY - 2;

const _: () = assert!(
    CHUNK_RANKS * MAX_PIECES < (1 << ID_SHIFT),
    "a chunk's pieces must fit the position bits of an id"
);

/// The set-up triangles, kept in the lists the setup tasks wrote them to (one per
/// [`CHUNK_RANKS`] ranks, in rank order) and named by u32 ids, `chunk << 15 | position`.
/// Concatenating them into one list cost a copy and the first touch of as many fresh pages:
/// 2.5–5 ms of a 60 ms `particles` render at 1024² on the 2-core VM.
#[derive(Debug)]
pub(crate) struct Triangles {
    chunks: Vec<Vec<SetupTriangle>>,
}

impl Triangles {
    /// Most input triangles whose pieces ids can name: 2^17 chunks. No id is `u32::MAX`
    /// (a position is below 2^15 − 1), which the raster uses as a sentinel.
    pub(crate) const MAX_RANKS: u64 = (1 << (32 - ID_SHIFT)) * CHUNK_RANKS as u64;

    /// The lists of chunks of [`CHUNK_RANKS`] ranks each, in rank order.
    pub(crate) fn new(chunks: Vec<Vec<SetupTriangle>>) -> Self {
        assert!(
            chunks.len() <= 1 << (32 - ID_SHIFT)
                && chunks.iter().all(|c| c.len() <= CHUNK_RANKS * MAX_PIECES),
            "set-up chunks beyond what ids can name"
        );
        Triangles { chunks }
    }

    /// The lists, in rank order: chunk `c`'s piece `j` has id [`Triangles::id`]`(c, j)`.
    #[cfg(test)]
    pub(crate) fn chunks(&self) -> &[Vec<SetupTriangle>] {
        &self.chunks
    }

    /// How many pieces there are.
    pub(crate) fn len(&self) -> usize {
        self.chunks.iter().map(Vec::len).sum()
    }

    /// The id of piece `position` of chunk `chunk`; ids increase in rank order.
    pub(crate) fn id(chunk: usize, position: usize) -> u32 {
        ((chunk as u32) << ID_SHIFT) | position as u32
    }

    /// The chunk and position an id names ([`Triangles::id`]'s inverse).
    #[inline(always)]
    pub(crate) fn chunk_and_position(id: u32) -> (usize, usize) {
        (
            (id >> ID_SHIFT) as usize,
            (id & ((1 << ID_SHIFT) - 1)) as usize,
        )
    }

    /// Every id, in rank order.
    #[cfg(test)]
    pub(crate) fn ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.chunks
            .iter()
            .enumerate()
            .flat_map(|(c, chunk)| (0..chunk.len()).map(move |j| Triangles::id(c, j)))
    }
}

impl std::ops::Index<u32> for Triangles {
    type Output = SetupTriangle;

    #[inline(always)]
    fn index(&self, id: u32) -> &SetupTriangle {
        let (chunk, position) = Triangles::chunk_and_position(id);
        &self.chunks[chunk][position]
    }
}

/// A set-up triangle ready for rasterization: integer window vertices with positive signed area
/// (vertices swapped if necessary), its pixel bounding box and the per-vertex values that are
/// interpolated.
#[derive(Debug, Clone)]
pub(crate) struct SetupTriangle {
    /// Snapped window x, y in 1/256 pixel, y down; within ±[`COORD_LIMIT`], so i32 holds them
    /// (the edge functions widen them to i64). Half the bytes of i64, as `fx` and `fy` in f32:
    /// a set-up triangle is 296 bytes instead of 344, and fewer fresh pages and cache lines.
    pub x: [i32; 3],
    pub y: [i32; 3],
    /// 1 / (twice the signed area in sub-pixel units², > 0 after normalisation): barycentrics
    /// then cost a multiply per fragment.
    pub inv_area2: f64,
    /// Unsnapped f32 window positions that attributes are interpolated from (in f64).
    pub fx: [f32; 3],
    pub fy: [f32; 3],
    /// 1 / (twice the signed float area in pixels²), or 0 when that area is 0.
    pub inv_farea2: f64,
    /// Inclusive pixel bounding box (min x, min y, max x, max y), clamped to the viewport.
    pub bbox: PixelBox,
    /// Window depth per vertex (z_clip · (1 / w_clip), f32 as the GPU computes it).
    pub z: [f32; 3],
    /// 1 / w_clip per vertex, for perspective-correct attributes.
    pub inv_w: [f64; 3],
    /// Linear RGBA per vertex.
    pub color: [[f32; 4]; 3],
    /// Texture coordinates per vertex (only read when the material is textured).
    pub uv: [[f32; 2]; 3],
    /// World position and normal per vertex (only read when the material is lit).
    pub world: [[f32; 3]; 3],
    pub normal: [[f32; 3]; 3],
    /// The material is lit: fragments are shaded with their interpolated world position and
    /// normal (negated on back faces, as the shader does for `front_facing` false).
    pub lit: bool,
    /// The triangle faces the camera (counter-clockwise on screen).
    pub front: bool,
    /// The material reads a texture: fragments sample it at their interpolated uv.
    pub textured: bool,
    /// When all three vertex colours are equal the fragment colour is constant: shade it once.
    /// (The exact interpolation of a constant is that constant, so this is the value the full
    /// path would give; the GPU may land an ulp off, which `constant_undecided` covers.)
    pub constant: Option<Shaded>,
    /// The material has a cutoff and α is interpolated with rounding (not a constant over
    /// constant w, not a material α of 0): fragments near the cutoff may be undecided.
    pub cutoff_rounds: bool,
    /// For a constant colour: whether its α is inside the undecided band of the cutoff.
    pub constant_undecided: bool,
    pub material: Material,
    /// Rank of (draw.id, triangle index) over the whole scene: the deterministic tie-break key.
    pub key: u32,
    /// When the window depth is constant over the triangle (bit-identical at the vertices):
    /// the f64 window depth of its plane, else NaN. Two such triangles with equal f32 depths
    /// are geometrically coplanar when these agree ([`same_plane`]), and only then is their
    /// tie exact on every rasterizer (draw order decides it); otherwise rounding made it.
    pub plane_depth: f64,
    pub transparent: bool,
}

/// A vertex in homogeneous clip space with its colour, as it travels through clipping.
#[derive(Debug, Clone, Copy)]
struct ClipVertex {
    p: Vec4,
    color: [f32; 4],
    uv: [f32; 2],
    world: [f32; 3],
    normal: [f32; 3],
    /// Made by clipping: lavapipe maps such a vertex to the window in its clipper, with other
    /// operations than its vertex stage (see [`to_window`]).
    new: bool,
}

/// Up to 3 + 6 vertices after clipping a triangle against six planes.
const MAX_POLY: usize = 12;

#[derive(Debug, Clone, Copy)]
struct Polygon {
    v: [ClipVertex; MAX_POLY],
    n: usize,
}

/// Signed distance (inside when >= 0) to plane `plane` of the Vulkan clip volume
/// `-w <= x, y <= w`, `0 <= z <= w`, in f32 and in the order of lavapipe's clipper (its f32
/// dot products with the plane vectors reduce to exactly these single roundings). x and y are
/// clipped to the viewport itself, as lavapipe does (no guard band when a depth buffer is
/// bound): with a guard band an edge whose ends lie off-screen is snapped at those ends instead
/// of at new vertices on the viewport border, which decided single pixels (see the README).
/// Near and far are `z >= 0` and `z <= w` for standard and reverse-Z alike.
fn plane_distance(plane: usize, p: Vec4) -> f32 {
    match plane {
        0 => p.w - p.x,
        1 => p.x + p.w,
        2 => p.w - p.y,
        3 => p.y + p.w,
        4 => p.z,
        _ => p.w - p.z,
    }
}

/// The new vertex where edge `prev → cur` (opposite sides of a plane) crosses it, in f32 as
/// lavapipe's clipper computes it: interpolated from the endpoint nearer the plane (the inside
/// one on a tie) with `t = |d_near| / |d_cur − d_prev|`. Symmetric in the two endpoints, so
/// triangles sharing an edge get bit-identical vertices (no cracks).
fn intersect(prev: ClipVertex, cur: ClipVertex, d_prev: f32, d_cur: f32) -> ClipVertex {
    let denom = d_cur - d_prev;
    let (t, near, far) = if d_cur < 0.0 {
        if -d_cur < d_prev {
            (d_cur / denom, cur, prev)
        } else {
            (-d_prev / denom, prev, cur)
        }
    } else if -d_prev < d_cur {
        (-d_prev / denom, prev, cur)
    } else {
        (d_cur / denom, cur, prev)
    };
    let lerp = |a: f32, b: f32| a + t * (b - a);
    ClipVertex {
        p: Vec4::new(
            lerp(near.p.x, far.p.x),
            lerp(near.p.y, far.p.y),
            lerp(near.p.z, far.p.z),
            lerp(near.p.w, far.p.w),
        ),
        color: std::array::from_fn(|k| lerp(near.color[k], far.color[k])),
        uv: std::array::from_fn(|k| lerp(near.uv[k], far.uv[k])),
        world: std::array::from_fn(|k| lerp(near.world[k], far.world[k])),
        normal: std::array::from_fn(|k| lerp(near.normal[k], far.normal[k])),
        new: true,
    }
}

/// Sutherland–Hodgman against the planes in `mask` (those some input vertex is outside of, in
/// plane order, as lavapipe); only called when the mask is not empty.
fn clip_polygon(tri: [ClipVertex; 3], mask: u32) -> Polygon {
    let mut poly = Polygon {
        v: [tri[0]; MAX_POLY],
        n: 3,
    };
    poly.v[1] = tri[1];
    poly.v[2] = tri[2];
    for plane in (0..6).filter(|p| mask & (1 << p) != 0) {
        let mut d = [0.0f32; MAX_POLY];
        for (di, v) in d.iter_mut().zip(&poly.v[..poly.n]) {
            *di = plane_distance(plane, v.p);
        }
        let mut out = Polygon { v: poly.v, n: 0 };
        for i in 0..poly.n {
            let j = (i + 1) % poly.n;
            let (a, b) = (poly.v[i], poly.v[j]);
            let (da, db) = (d[i], d[j]);
            if da >= 0.0 {
                out.v[out.n] = a;
                out.n += 1;
            }
            if (da >= 0.0) != (db >= 0.0) {
                out.v[out.n] = intersect(a, b, da, db);
                out.n += 1;
            }
        }
        poly = out;
        if poly.n < 3 {
            poly.n = 0;
            return poly;
        }
    }
    poly
}

/// Window-space vertex: snapped integer x, y and f32 depth.
#[derive(Debug, Clone, Copy)]
struct WindowVertex {
    x: i64,
    y: i64,
    xf: f32,
    yf: f32,
    z: f32,
    inv_w: f64,
    color: [f32; 4],
    uv: [f32; 2],
    world: [f32; 3],
    normal: [f32; 3],
}

/// Perspective divide and viewport transform in f32 (`x_f = (p_x/2)·x_d + o_x`; wgpu's y flip is
/// a negative viewport height) with lavapipe's operations, which Vulkan leaves to the
/// implementation: the divide is a multiply by `1/w`; the viewport transform is one fused
/// multiply-add for a vertex from the vertex stage, a multiply and an add for a vertex made by
/// clipping. Then snapping to 1/256 pixel, rounding to nearest (ties to even). Returns None
/// when w <= 0 (never divided).
fn to_window(v: ClipVertex, width: u32, height: u32) -> Option<WindowVertex> {
    let p = v.p;
    // Written so that NaN is rejected too (it never gets here: setup drops non-finite input).
    if p.w.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let inv_w = 1.0 / p.w;
    let (xd, yd, zd) = (p.x * inv_w, p.y * inv_w, p.z * inv_w);
    let half_w = width as f32 * 0.5;
    let half_h = height as f32 * 0.5;
    let (xf, yf) = if v.new {
        (xd * half_w + half_w, yd * -half_h + half_h)
    } else {
        (xd.mul_add(half_w, half_w), yd.mul_add(-half_h, half_h))
    };
    let snap =
        |f: f32| ((f * ONE as f32).round_ties_even() as i64).clamp(-COORD_LIMIT, COORD_LIMIT);
    Some(WindowVertex {
        x: snap(xf),
        y: snap(yf),
        xf,
        yf,
        z: zd,
        inv_w: 1.0 / f64::from(p.w),
        color: v.color,
        uv: v.uv,
        world: v.world,
        normal: v.normal,
    })
}

/// Twice the signed area of (a, b, c) in window coordinates (y down): negative for triangles
/// that are counter-clockwise with y up, i.e. front faces under wgpu's `FrontFace::Ccw`.
fn signed_area2(a: &WindowVertex, b: &WindowVertex, c: &WindowVertex) -> i64 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

/// Inclusive range of pixels whose centres `ONE·p + HALF` lie in [lo, hi] (sub-pixel units),
/// clamped to [0, size).
fn pixel_span(lo: i64, hi: i64, size: u32) -> Option<(u32, u32)> {
    let first = (lo - HALF + ONE - 1).div_euclid(ONE).max(0);
    let last = (hi - HALF).div_euclid(ONE).min(i64::from(size) - 1);
    (first <= last).then_some((first as u32, last as u32))
}

/// Sets up one scene triangle (three clip-space vertices); pushes 0..=7 raster triangles (a
/// clipped polygon becomes a fan).
pub(crate) fn setup_triangle(
    scene: &Scene,
    material: &Material,
    clip: [ClipInput; 3],
    rank: u32,
    plane_depth: f64,
    out: &mut Vec<SetupTriangle>,
) {
    let (width, height) = (scene.resolution.width, scene.resolution.height);
    let tri: [ClipVertex; 3] = std::array::from_fn(|i| ClipVertex {
        p: clip[i].0,
        color: clip[i].1,
        uv: clip[i].2,
        world: clip[i].3,
        normal: clip[i].4,
        new: false,
    });
    // A non-finite position cannot be rasterized meaningfully; the loader rejects them, a
    // hand-built scene simply loses the triangle.
    if tri
        .iter()
        .any(|v| !v.p.is_finite() || v.color.iter().any(|c| !c.is_finite()))
    {
        return;
    }
    let mask = (0..6)
        .filter(|&plane| tri.iter().any(|v| plane_distance(plane, v.p) < 0.0))
        .fold(0, |m, plane| m | 1 << plane);
    let poly = if mask == 0 {
        let mut p = Polygon {
            v: [tri[0]; MAX_POLY],
            n: 3,
        };
        p.v[1] = tri[1];
        p.v[2] = tri[2];
        p
    } else {
        clip_polygon(tri, mask)
    };
    if poly.n < 3 {
        return;
    }
    let mut win = [WindowVertex {
        x: 0,
        y: 0,
        xf: 0.0,
        yf: 0.0,
        z: 0.0,
        inv_w: 0.0,
        color: [0.0; 4],
        uv: [0.0; 2],
        world: [0.0; 3],
        normal: [0.0; 3],
    }; MAX_POLY];
    for (w, v) in win.iter_mut().zip(&poly.v[..poly.n]) {
        match to_window(*v, width, height) {
            Some(wv) => *w = wv,
            None => return,
        }
    }
    // Facing is a property of the whole (clipped) polygon; fan pieces whose snapped area has
    // the other sign are snapping slivers and are dropped.
    let total: i128 = (1..poly.n - 1)
        .map(|i| i128::from(signed_area2(&win[0], &win[i], &win[i + 1])))
        .sum();
    if total == 0 {
        return;
    }
    let front = total < 0;
    if !front && !material.double_sided {
        return;
    }
    let transparent = material.mode.is_transparent();
    let textured = material.is_textured();
    let lit = material.is_lit();
    for i in 1..poly.n - 1 {
        let (a, mut b, mut c) = (win[0], win[i], win[i + 1]);
        let mut area = signed_area2(&a, &b, &c);
        if area == 0 || (area < 0) != front {
            continue;
        }
        if area < 0 {
            std::mem::swap(&mut b, &mut c);
            area = -area;
        }
        let v = [a, b, c];
        let min_x = v.iter().map(|v| v.x).min().unwrap_or(0);
        let max_x = v.iter().map(|v| v.x).max().unwrap_or(0);
        let min_y = v.iter().map(|v| v.y).min().unwrap_or(0);
        let max_y = v.iter().map(|v| v.y).max().unwrap_or(0);
        let (Some((x0, x1)), Some((y0, y1))) = (
            pixel_span(min_x, max_x, width),
            pixel_span(min_y, max_y, height),
        ) else {
            continue;
        };
        let color = [a.color, b.color, c.color];
        // Textured colour varies with uv even where the vertex colours agree, lit colour with
        // the position and normal.
        let constant = (!textured && !lit && color[0] == color[1] && color[0] == color[2])
            .then(|| material.shade(color[0], Texels::UNTEXTURED));
        // A constant α over a triangle of constant w has zero gradients: every rasterizer gets
        // it back exactly. With varying w, perspective correction rounds (lavapipe returns
        // 1.0 as 0.99999994 on scattered pixels of a turned card), as does any gradient.
        let constant_w = a.inv_w == b.inv_w && b.inv_w == c.inv_w;
        let constant_alpha = color[0][3] == color[1][3] && color[0][3] == color[2][3];
        let cutoff_rounds = material.mode.uses_cutoff()
            && material.alpha != 0.0
            && (material.base_texture.is_some() || !(constant_alpha && constant_w));
        let constant_undecided =
            constant.is_some() && cutoff_rounds && undecided(material, color[0][3]);
        // Every fragment is discarded by the cutoff, and no GPU could keep one: nothing to
        // rasterize or count.
        if constant == Some(Shaded::Discarded) && !constant_undecided {
            continue;
        }
        let flat_depth = a.z == b.z && b.z == c.z;
        out.push(SetupTriangle {
            x: [a.x, b.x, c.x].map(snapped_i32),
            y: [a.y, b.y, c.y].map(snapped_i32),
            inv_area2: 1.0 / area as f64,
            fx: [a.xf, b.xf, c.xf],
            fy: [a.yf, b.yf, c.yf],
            inv_farea2: {
                let fa = (b.xf as f64 - a.xf as f64) * (c.yf as f64 - a.yf as f64)
                    - (b.yf as f64 - a.yf as f64) * (c.xf as f64 - a.xf as f64);
                if fa != 0.0 { 1.0 / fa } else { 0.0 }
            },
            bbox: [x0, y0, x1, y1],
            z: [a.z, b.z, c.z],
            inv_w: [a.inv_w, b.inv_w, c.inv_w],
            color,
            uv: [a.uv, b.uv, c.uv],
            world: [a.world, b.world, c.world],
            normal: [a.normal, b.normal, c.normal],
            lit,
            front,
            textured,
            constant,
            cutoff_rounds,
            constant_undecided,
            material: *material,
            key: rank,
            plane_depth: if flat_depth { plane_depth } else { f64::NAN },
            transparent,
        });
    }
}

/// Half-width of the band around a mask cutoff inside which a fragment's fate is decided by
/// interpolation rounding: *undecided* when `|α − cutoff| <= CUTOFF_UNDECIDED_BOUND`. The
/// reference interpolates in f64 and rounds once; a GPU interpolates in f32 (lavapipe: up to
/// 4.1e-6 from the exact value on attributes in [0, 1], worst of 532 614 values on 300 random
/// scenes, `cargo run -p oit-tools --bin interpolation_error`), so it may discard what the
/// reference keeps, or the reverse. 2^-16 ≈ 1.5e-5 is 3.7 times that worst case.
pub const CUTOFF_UNDECIDED_BOUND: f32 = 1.0 / 65536.0;

/// Whether interpolated vertex α `vertex_alpha` is in the undecided band of `material`'s
/// cutoff, α as `Material::shade` computes it. Only asked where `cutoff_rounds` holds.
#[inline(always)]
pub(crate) fn undecided(material: &Material, vertex_alpha: f32) -> bool {
    (vertex_alpha * material.alpha - material.cutoff).abs() <= CUTOFF_UNDECIDED_BOUND
}

/// Relative error bound of an interpolated texture coordinate on the GPU: the same measured
/// interpolation error as for colours (the same f32 plane equations), 2^-16 of max(1, |uv|).
pub const UV_UNDECIDED_BOUND: f32 = CUTOFF_UNDECIDED_BOUND;

/// Slack on a level of detail for the GPU's `log2` (WGSL allows 3 ulp, 2^-21 absolute near 1)
/// and the order of the footprint's f32 products: far above both.
pub const LOD_UNDECIDED_SLACK: f32 = 1.0 / 4096.0;

/// [`undecided`] for a material whose α is also multiplied by a texture sample (`texel_alpha`
/// at `uv`, screen derivatives `grad`). The GPU's uv may be off by [`UV_UNDECIDED_BOUND`] and
/// its derivatives (differences of two such coordinates) by twice that, so:
/// - within a level, a bilinear sample moves by at most twice that many texels times the alpha
///   range of the texels it can reach; a nearest sample may become any of them when the
///   coordinate is that close to a texel edge;
/// - the level of detail lies between those of the smallest and largest footprints the
///   derivatives allow (plus [`LOD_UNDECIDED_SLACK`]); trilinear α changes by at most that
///   interval times the alpha range of every level it touches; a nearest level, or a switch
///   between different magnification and minification filters, may give any of them.
#[inline]
pub(crate) fn undecided_textured(
    material: &Material,
    texture: &Texture,
    vertex_alpha: f32,
    texel_alpha: f32,
    uv: [f32; 2],
    grad: [f32; 4],
) -> bool {
    let scale = f64::from(vertex_alpha) * f64::from(material.alpha);
    let alpha = vertex_alpha * material.alpha * texel_alpha;
    let distance = f64::from((alpha - material.cutoff).abs());
    let bound = f64::from(CUTOFF_UNDECIDED_BOUND);
    if distance <= bound {
        return true;
    }
    let motion = texture_motion(texture, uv, grad);
    // A texture's alpha range is at most 1: decided without looking at texels.
    if distance > bound + scale * motion.at_most(1.0, 1.0) {
        return false;
    }
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for level in motion.levels.clone() {
        let (l, h) = texture.alpha_range_near(level, uv);
        lo = lo.min(l);
        hi = hi.max(h);
    }
    let range = f64::from(hi - lo);
    distance <= bound + scale * motion.at_most(range, range)
}

/// Whether the GPU's rounding of `uv` and its derivatives could make `texture`'s sample jump
/// (another texel of a NEAREST filter, another level of a *_MIPMAP_NEAREST filter, or the
/// other of differing magnification and minification filters): then rounding, not the scene,
/// decides the fragment's colour, and the reference flags it undecided. Filters that are
/// linear throughout are continuous and never jump.
#[inline]
pub(crate) fn sample_may_jump(texture: &Texture, uv: [f32; 2], grad: [f32; 4]) -> bool {
    use oit_scene::{Filter, MipFilter};
    let s = texture.sampler();
    if s.mag == Filter::Linear && s.min == Filter::Linear && s.mip != MipFilter::Nearest {
        return false;
    }
    let motion = texture_motion(texture, uv, grad);
    motion.nearest_jump || motion.level_jump
}

/// How far the GPU's sample of `texture` can be from the reference's, in units of the alpha
/// range of the texels involved ([`undecided_textured`]).
struct TextureMotion {
    /// Texels of level 0 the coordinate may move (coarser levels move less).
    reach: f64,
    /// Whether a nearest filter in play may pick another texel.
    nearest_jump: bool,
    /// Level-of-detail interval the GPU may land in (clamped to the stored levels).
    lod_span: f64,
    /// Whether the level choice may jump (nearest level, or the magnification switch).
    level_jump: bool,
    /// The levels the sample may read.
    levels: std::ops::RangeInclusive<u32>,
}

impl TextureMotion {
    fn at_most(&self, level_range: f64, jump_range: f64) -> f64 {
        let within = if self.nearest_jump {
            jump_range
        } else {
            2.0 * self.reach * level_range
        };
        let across = if self.level_jump {
            jump_range
        } else {
            self.lod_span * level_range
        };
        within + across
    }
}

fn texture_motion(texture: &Texture, uv: [f32; 2], grad: [f32; 4]) -> TextureMotion {
    use oit_scene::{Filter, MipFilter};
    let sampler = texture.sampler();
    let (w, h) = (f64::from(texture.width()), f64::from(texture.height()));
    let err = |c: f32| f64::from(UV_UNDECIDED_BOUND) * f64::from(c.abs().max(1.0));
    let (eu, ev) = (err(uv[0]), err(uv[1]));
    let reach = (eu * w).max(ev * h);
    // Footprint bounds from derivatives each off by up to twice the coordinate's error.
    let axis = |du: f32, dv: f32| {
        let (du, dv) = (f64::from(du).abs() * w, f64::from(dv).abs() * h);
        let (mu, mv) = (2.0 * eu * w, 2.0 * ev * h);
        let lo = (du - mu).max(0.0).powi(2) + (dv - mv).max(0.0).powi(2);
        let hi = (du + mu).powi(2) + (dv + mv).powi(2);
        (lo, hi)
    };
    let (x, y) = (axis(grad[0], grad[1]), axis(grad[2], grad[3]));
    let (rho2_lo, rho2_hi) = (x.0.max(y.0), x.1.max(y.1));
    let last = f64::from(texture.levels() - 1);
    let slack = f64::from(LOD_UNDECIDED_SLACK);
    let lod = |rho2: f64| (0.5 * rho2.log2()).clamp(0.0, last);
    let magnified = rho2_lo <= 1.0 + 1e-6;
    let minified = rho2_hi > 1.0 - 1e-6;
    let (lod_lo, lod_hi) = (
        if magnified {
            0.0
        } else {
            (lod(rho2_lo) - slack).max(0.0)
        },
        if minified {
            (lod(rho2_hi) + slack).min(last)
        } else {
            0.0
        },
    );
    let mut level_jump = magnified && minified && sampler.mag != sampler.min;
    let mut nearest = (magnified && sampler.mag == Filter::Nearest)
        || (minified && sampler.min == Filter::Nearest);
    let levels = match sampler.mip {
        MipFilter::None => 0..=0,
        MipFilter::Nearest => {
            let (a, b) = ((lod_lo + 0.5).floor(), (lod_hi + 0.5).floor());
            level_jump |= a != b;
            a as u32..=b as u32
        }
        MipFilter::Linear => lod_lo.floor() as u32..=lod_hi.ceil() as u32,
    };
    let lod_span = match sampler.mip {
        MipFilter::Linear => lod_hi - lod_lo,
        _ => 0.0,
    };
    // A nearest filter moves only when the coordinate is within its reach of a texel edge of
    // some level it reads.
    if nearest {
        nearest = levels.clone().chain(std::iter::once(0)).any(|k| {
            let (lw, lh) = oit_scene::level_size(texture.width(), texture.height(), k);
            let near_edge = |c: f32, size: u32, e: f64| {
                let t = f64::from(c) * f64::from(size);
                let f = t - t.floor();
                let r = e * f64::from(size) + 1e-6;
                f <= r || f >= 1.0 - r
            };
            near_edge(uv[0], lw, eu) || near_edge(uv[1], lh, ev)
        });
    }
    TextureMotion {
        reach,
        nearest_jump: nearest,
        lod_span,
        level_jump,
        // Level 0 too where the magnification filter may apply.
        levels: if magnified { 0 } else { *levels.start() }..=*levels.end(),
    }
}

/// Whether two [`SetupTriangle::plane_depth`]s are the same plane: equal to 1e-12 relative
/// (f64 rounding of the same plane through different vertices); never for NaN.
#[inline(always)]
pub(crate) fn same_plane(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs())
}

/// An inclusive pixel bounding box: min x, min y, max x, max y.
pub(crate) type PixelBox = [u32; 4];

impl SetupTriangle {
    /// The snapped window x and y, widened to the i64 the edge functions are computed in.
    #[inline(always)]
    pub(crate) fn snapped(&self) -> ([i64; 3], [i64; 3]) {
        (self.x.map(i64::from), self.y.map(i64::from))
    }

    /// The unsnapped window x and y, widened to the f64 attributes are interpolated in.
    #[inline(always)]
    pub(crate) fn window(&self) -> ([f64; 3], [f64; 3]) {
        (self.fx.map(f64::from), self.fy.map(f64::from))
    }
}

/// Clip-space position, colour, uv, world position and normal of one input vertex.
pub(crate) type ClipInput = (Vec4, [f32; 4], [f32; 2], [f32; 3], [f32; 3]);

#[cfg(test)]
mod tests {
    /// The memory the crate documents for set-up triangles (`ReferenceOptions::memory_budget`,
    /// README) is this size: a new field must update those figures.
    #[test]
    fn a_set_up_triangle_is_the_size_the_memory_docs_state() {
        assert_eq!(std::mem::size_of::<super::SetupTriangle>(), 392);
        // The binning order keeps an id and a bounding box per triangle, and ordering holds
        // one sort key and a copy of the bounding box per triangle beside them.
        assert_eq!(std::mem::size_of::<(u32, super::PixelBox)>(), 20);
        assert_eq!(crate::raster::SORT_KEY_BYTES, 16);
        assert_eq!(std::mem::size_of::<super::PixelBox>(), 16);
    }
}
