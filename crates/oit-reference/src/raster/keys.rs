//! Depth keys (the order of fragments in a pixel), the ties rounding can decide, and the order in
//! which set-up triangles are binned (nearest first).

use super::*;

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
pub(super) fn opaque_key(dkey: u32, rank: u32) -> u64 {
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
pub(super) fn close(a: u32, b: u32) -> bool {
    a.abs_diff(b) <= PRECISION_TIE_ULPS
}

/// For depth keys within the tie distance: whether rounding decides them, i.e. not an exact tie
/// of two surfaces on one plane. Plane depths are NaN unless flat, and NaN for the far plane
/// (whose depth is rounded too). Out of line: the per-fragment loops only pay for [`close`].
#[cold]
#[inline(never)]
pub(super) fn rounding_tie(a: u32, b: u32, plane_a: f64, plane_b: f64) -> bool {
    a != b || !same_plane(plane_a, plane_b)
}

/// Plane depth of the surface behind a pixel's opaque key (NaN for the far sentinel).
#[inline(always)]
pub(super) fn opaque_plane(key: u64, far: u64, planes: &[f64]) -> f64 {
    if key == far {
        f64::NAN
    } else {
        planes[(key as u32) as usize]
    }
}

/// Plane depth of a transparent key's triangle (low half `u32::MAX − rank`).
#[inline(always)]
pub(super) fn transparent_plane(key: u64, planes: &[f64]) -> f64 {
    planes[(u32::MAX - key as u32) as usize]
}

/// For two neighbouring slots of a sorted list whose depths are within the tie distance:
/// whether rounding decides their order and the order matters (their colours, or their
/// transmittances where the scene has them, differ).
#[cold]
#[inline(never)]
pub(super) fn transparent_tie(
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
pub(super) fn near_far(tri: &SetupTriangle, far: u64, reverse_z: bool) -> bool {
    let far = (far >> 32) as u32;
    tri.z
        .iter()
        .any(|&z| close(depth_key(z.clamp(0.0, 1.0) + 0.0, reverse_z), far))
}

/// Whether a fragment (depth key `dkey` on a triangle of plane depth `plane`) ties with the
/// surface behind a pixel's opaque key `opaque` (the far plane when it is `far`).
#[inline(always)]
pub(super) fn ties_opaque(dkey: u32, plane: f64, opaque: u64, far: u64, planes: &[f64]) -> bool {
    let nearest = (opaque >> 32) as u32;
    close(dkey, nearest) && rounding_tie(dkey, nearest, plane, opaque_plane(opaque, far, planes))
}

/// The opaque key of a pixel no opaque fragment reached: the cleared far depth with the lowest
/// rank, so a fragment exactly at far never beats it (`key < far` fails, as `Less` against a
/// buffer cleared to 1.0 does, or `Greater` against 0.0 under reverse-Z).
pub(super) fn far_key(reverse_z: bool) -> u64 {
    let far = if reverse_z { 0.0 } else { 1.0 };
    opaque_key(depth_key(far, reverse_z), 0)
}

/// Transparent key: nearest first, then at equal depth the HIGHER rank is in front (it would
/// have been blended last in natural draw order).
pub(super) fn transparent_key(dkey: u32, rank: u32) -> u64 {
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
