//! oit-reference: the exact many-layer CPU reference (an A-buffer) every GPU technique is
//! measured against.
//!
//! It rasterizes with the GPU's coverage rules (the README of this crate, "What exact means here"):
//! positions from [`Camera::clip`](oit_scene::Camera::clip) in f32; clipping in homogeneous clip
//! space against the whole clip volume, the viewport (`|x|, |y| <= w`: no guard band, as
//! lavapipe with a depth buffer), near (`z >= 0`) and far (`z <= w`), never dividing by
//! `w <= 0`; perspective divide and viewport transform in f32 with a top-left origin, with
//! lavapipe's operations (see the README); x, y snapped to 1/256 pixel; exact i64 edge
//! functions sampled at pixel centres with the top-left fill rule; back faces culled by the sign
//! of the snapped area (counter-clockwise with y up is front, wgpu's `FrontFace::Ccw`);
//! zero-area triangles produce nothing. Window depth is interpolated linearly in screen space
//! (f64 barycentrics from the integer edge functions, stored as f32 like a `Depth32Float`
//! buffer, clamped to [0, 1]); colour is interpolated perspective-correctly and converted to f32
//! before [`Material::shade`](oit_scene::Material::shade), as the fragment shader sees it.
//!
//! Per pixel the nearest opaque fragment wins (equal depth: lower `(draw.id, triangle index)`),
//! else the background. Transparent fragments strictly nearer than that are sorted front to
//! back (equal depth: the higher `(draw.id, triangle index)` is in front, which is what
//! blending in natural draw order gives) and composited in f64 with
//! [`composite_front_to_back`]. Because the tie-break uses the stable draw ids, the result is
//! bit-identical for any permutation of the draw list (given unique ids, which the loader
//! guarantees; draws sharing an id are ranked by their position in the list).
//!
//! **Render queues** (docs/scene-format.md "Render queues"): where transparent draws span
//! several (render group, queue) levels, a pixel's fragments are ordered by level, highest
//! first, then as above, and a fragment behind a depth-writing transparent fragment of a lower
//! level is dropped (`raster::queues`); such scenes take the stored path only. Scenes in one
//! level render as without queues, bit for bit.
//!
//! **Overflow bound.** Clipping to the viewport keeps every window coordinate inside it (up to
//! rounding); snapped coordinates are clamped to `±2^29` sub-pixel units regardless, so edge
//! functions stay below 2^61 and i64 never overflows.
//!
//! **Memory.** Triangles are set up once and their indices binned to square screen tiles; tiles
//! are rendered in parallel (rayon), each with per-thread scratch arrays sized by the tile's
//! fragments, so the peak fragment storage depends on the tile, not on the frame
//! ([`ReferenceStats::peak_tile_bytes`]). The binning and the tiles in flight stay within
//! [`ReferenceOptions::memory_budget`]: a tile whose fragments do not fit is rendered in
//! slices, and a pixel that cannot fit alone is an error, not an abort.

pub mod analyze;
mod composite;
mod fragments;
pub mod lists;
mod raster;
mod setup;

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use oit_scene::{LinearImage, Scene};
use rayon::prelude::*;

pub use composite::{composite_front_to_back, composite_transmittance_front_to_back};
pub use fragments::{FragmentVisitor, PixelFragment, RectFragments, render_visiting};
pub use raster::PRECISION_TIE_ULPS;
pub use setup::CUTOFF_UNDECIDED_BOUND;

/// Changes whenever any output bit of [`render`] changes for some scene (rules, arithmetic),
/// so that caches of references made by an older build are never reused. 2: vertex
/// arithmetic and viewport clipping as lavapipe does them. 3: fragments exactly on the far
/// plane are never visible; undecided-cutoff and precision-tie outputs. 4: textures as 8-bit
/// codes with mip chains, sampled at the level of detail of fine derivatives. 5: render queues
/// (transparent draws in several (group, queue) levels composite by level, then depth; depth
/// writers hide later levels; scenes in one level are unchanged).
pub const OUTPUT_VERSION: u32 = 5;

/// Fewest triangles in a tile's bin for it to be rendered alone on every thread when it holds
/// a thread's part of all binned triangles (below this it is quick anyway).
const HEAVY_BIN: usize = 1024;

/// Most input triangles a scene may have: 2^28 (268 M, 67 times the loader's cap). Set-up
/// triangles are named by u32 ids of their setup task's list and position in it.
pub const MAX_TRIANGLES: u32 = 1 << 28;
const _: () = assert!(MAX_TRIANGLES as u64 <= setup::Triangles::MAX_RANKS);

use raster::{Scratch, TileFailure, TileOutput, TileRect, TileStats};

/// Progress callback: `(tiles done, tiles total)`. Called from worker threads after each tile.
pub type Progress = Arc<dyn Fn(usize, usize) + Send + Sync>;

/// How to run the reference. `Default` gives 32-pixel tiles, the default memory budget and no
/// progress reporting.
#[derive(Clone)]
pub struct ReferenceOptions {
    /// Edge of the square screen tiles in pixels (1..=1024). Smaller tiles keep a tile's
    /// fragments in cache; 32 is fastest on the scenes measured (see the crate README numbers).
    pub tile_size: u32,
    /// Called after every tile with (done, total); the CLI drives a progress bar with it.
    pub progress: Option<Progress>,
    /// Bytes the render may use for its binning and for the working storage of the tiles in
    /// flight, all worker threads together ([`Self::DEFAULT_MEMORY_BUDGET`] says what that
    /// covers and what not). Each thread's tiles get an equal share; a tile whose fragments
    /// exceed it is rendered after the others, alone with the whole budget, in slices that
    /// run in parallel (same output, bit for bit). A pixel whose fragments alone exceed the
    /// budget is [`ReferenceError::PixelOverBudget`], found before any slice is rendered.
    pub memory_budget: u64,
    /// Composite a tile's transparent fragments as they arrive, without storing or sorting
    /// them, when every pixel receives them in depth order (true by default; transparent
    /// triangles are binned nearest first, so layered content and billboards mostly do); a
    /// tile where some pixel does not is rendered again with stored, sorted lists. The output
    /// is the same bit for bit either way: false forces the stored path, for tests and
    /// measurements.
    pub in_order: bool,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        Self {
            tile_size: Self::DEFAULT_TILE_SIZE,
            progress: None,
            memory_budget: Self::DEFAULT_MEMORY_BUDGET,
            in_order: true,
        }
    }
}

impl ReferenceOptions {
    pub const DEFAULT_TILE_SIZE: u32 = 32;
    pub const MAX_TILE_SIZE: u32 = 1024;
    /// 2 GiB.
    ///
    /// **Counted** (allocated capacity, a reallocation's old and new block both): the bins,
    /// 4 bytes per triangle–tile overlap and 8 per tile; and the scratch of every tile or
    /// slice in flight: 37 bytes per pixel of state, 24 per covered transparent fragment (key,
    /// colour; lists are sorted in place), 12 per covered row of a transparent triangle, 12 per
    /// fragment of the longest pixel list (sort buffers), and for a tile rendered in slices 4
    /// bytes per pixel of counts and 29 per pixel of each slice's outputs. A pixel alone thus
    /// needs about 90 bytes plus 48 per covered transparent fragment, beside its tile's counts.
    /// A tile composited in arrival order ([`ReferenceOptions::in_order`]) holds 77 bytes per
    /// pixel of state (101 with coloured transmission) and 16 per row instead, and nothing
    /// per fragment but for the rectangles of pixels it hands to the stored path, one at a
    /// time.
    ///
    /// **Not counted** (proportional to the input or the resolution, bounded by the loader's
    /// caps): the scene (48 bytes per vertex: 576 MB for 4 M triangles); the set-up triangles,
    /// 392 bytes per triangle reaching the screen (clipping can make up to 7 of one) and 20
    /// for the binning order (id and bounding box), plus 8 per input triangle, and a 16-byte
    /// sort key and a 16-byte copy of the bounding box while they are ordered: 1.6 GB, 1.8 GB
    /// during setup, for 4 M unclipped triangles; the outputs, 29 bytes per pixel: 1.9 GB at
    /// 8192².
    ///
    /// Why 2 GiB: the deepest bundled tiles take under 4 MB at once (faint-haze; particles
    /// near 1 MB), so nothing realistic is sliced even with 64 threads sharing it; one pixel
    /// can hold 41 M fragments, ten times the loader's triangle cap, so no loadable scene
    /// fails for its depth alone; and the worst loadable scene (2 M full-screen layers, 4 M
    /// triangles) peaks at 1.9 GB resident (3.7 GB before its tile was composited in
    /// arrival order; crate README), within a 4 GB limit.
    pub const DEFAULT_MEMORY_BUDGET: u64 = 2 << 30;
}

impl std::fmt::Debug for ReferenceOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReferenceOptions")
            .field("tile_size", &self.tile_size)
            .field("progress", &self.progress.as_ref().map(|_| "callback"))
            .field("memory_budget", &self.memory_budget)
            .field("in_order", &self.in_order)
            .finish()
    }
}

/// The reference image and what it took to make it.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Linear RGBA f32, A = 1, row-major from the top-left.
    pub image: LinearImage,
    /// Per pixel: transparent fragments composited (strictly in front of the nearest opaque).
    pub layers: Vec<u32>,
    /// Per pixel: all fragments rasterization produced after face culling and mask / mask-blend
    /// cutoff discard, opaque and transparent, before any depth test (what a GPU counting
    /// fragment-shader invocations with the same coverage rules would count).
    pub fragments: Vec<u32>,
    /// Per pixel: fragments (opaque or transparent, kept or discarded) whose α lies within
    /// [`CUTOFF_UNDECIDED_BOUND`] of their material's cutoff (widened where α is textured): a
    /// GPU's interpolation rounding may decide them the other way, so `fragments` may differ
    /// from a GPU's count by up to this. Also fragments whose texture sample rounding could
    /// make jump (a NEAREST texel, a *_MIPMAP_NEAREST level, or a switch between differing
    /// magnification and minification filters): their colour is rounding's to decide.
    pub undecided: Vec<u32>,
    /// Per pixel: whether the composite depends on two surfaces whose window depths are within
    /// [`PRECISION_TIE_ULPS`] of each other (or of the far plane), so that rounding, not
    /// geometry, decides their order or visibility.
    pub precision_ties: Vec<bool>,
    pub stats: ReferenceStats,
}

/// A GPU's per-pixel fragment counts against [`Reference::fragments`]
/// ([`Reference::compare_fragment_counts`]).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CountComparison {
    /// Pixels whose counts differ by more than their undecided fragments: a bug on one side.
    pub unexplained: Vec<usize>,
    /// Pixels whose counts differ by no more than their undecided fragments (the GPU's
    /// rounding decided a knife-edge cutoff the other way).
    pub undecided: usize,
}

impl Reference {
    /// Compares a GPU's per-pixel fragment counts (same resolution) with this reference: a
    /// difference is tolerated exactly where, and as far as, the pixel holds fragments in a
    /// cutoff's undecided band.
    pub fn compare_fragment_counts(&self, gpu: &[u32]) -> CountComparison {
        assert_eq!(
            gpu.len(),
            self.fragments.len(),
            "counts for another resolution"
        );
        let mut out = CountComparison::default();
        for (p, (&g, &r)) in gpu.iter().zip(&self.fragments).enumerate() {
            if g == r {
                continue;
            }
            if g.abs_diff(r) <= self.undecided[p] {
                out.undecided += 1;
            } else {
                out.unexplained.push(p);
            }
        }
        out
    }
}

/// Statistics of one reference render. Phase times marked "thread time" are summed over the
/// worker threads (so with 2 threads they can add up to about twice the wall time).
/// Serializable so the harness can cache references on disk with their statistics.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct ReferenceStats {
    /// Input triangles.
    pub triangles: u64,
    /// Triangles (fan pieces after clipping) that survived culling and reach the screen.
    pub raster_triangles: u64,
    /// All fragments produced (sum of [`Reference::fragments`]).
    pub fragments: u64,
    /// Transparent fragments produced (after cutoff discard, before the opaque depth test).
    pub transparent_fragments: u64,
    /// Transparent fragments composited (sum of [`Reference::layers`]).
    pub composited_fragments: u64,
    /// Largest per-pixel layer count (transparent fragments composited).
    pub max_depth_complexity: u32,
    /// Mean layer count over pixels with at least one layer (0 when there are none): the depth
    /// complexity of the transparent content where it exists.
    pub mean_depth_complexity: f64,
    /// Mean layer count over all pixels.
    pub mean_depth_complexity_all: f64,
    /// Pixels with at least one layer.
    pub covered_pixels: u64,
    /// Fragments in the undecided band of a mask cutoff (sum of [`Reference::undecided`]).
    #[serde(default)]
    pub undecided_fragments: u64,
    /// Pixels holding at least one undecided fragment.
    #[serde(default)]
    pub undecided_pixels: u64,
    /// Pixels whose composite depends on a precision tie ([`Reference::precision_ties`]).
    #[serde(default)]
    pub precision_tie_pixels: u64,
    /// Wall time of the whole render.
    pub seconds: f64,
    /// `fragments / seconds`.
    pub fragments_per_second: f64,
    /// Wall time of triangle setup (clip, snap, cull, edge setup).
    pub setup_seconds: f64,
    /// Wall time of binning triangles to tiles.
    pub binning_seconds: f64,
    /// Thread time rasterizing and shading (opaque and transparent passes).
    pub raster_seconds: f64,
    /// Thread time grouping fragments by pixel and sorting each pixel's list.
    pub sort_seconds: f64,
    /// Thread time compositing and writing pixels.
    pub composite_seconds: f64,
    /// Most storage one tile held on one worker (bytes, allocated capacity): its per-pixel
    /// state, stored fragments, spans and sort buffers, or for a tile rendered in slices its
    /// counts plus one slice's scratch and outputs. At most a thread's share of
    /// [`ReferenceOptions::memory_budget`] for a tile at once; for a sliced tile the counts
    /// plus a share of the rest, or all of it when its slices run one at a time.
    pub peak_tile_bytes: u64,
    /// Tiles rendered in slices because their fragments did not fit the budget at once.
    #[serde(default)]
    pub sliced_tiles: u64,
    /// Tiles whose fragments arrived in depth order at every pixel and were composited
    /// without being stored ([`ReferenceOptions::in_order`]).
    #[serde(default)]
    pub in_order_tiles: u64,
    /// Of those, tiles over a thread's share that were rendered alone afterwards, in bands of
    /// rows on all threads (a deep stack over few tiles).
    #[serde(default)]
    pub banded_tiles: u64,
    /// Pixels composited from stored, sorted lists (all of them without
    /// [`ReferenceOptions::in_order`]; with it, those whose fragments did not arrive in depth
    /// order and the rest of their row's run).
    #[serde(default)]
    pub stored_pixels: u64,
    /// Tiles that stopped compositing in order once most of their pixels had received a
    /// fragment out of depth order, and were rendered with stored lists instead (cheaper than
    /// finishing and then storing nearly every pixel; the output is the same).
    #[serde(default)]
    pub given_up_tiles: u64,
    pub tile_size: u32,
    pub tiles: u64,
    pub threads: usize,
}

/// Why a scene cannot be rendered. The loader never produces the input errors; hand-built
/// scenes can. The last three are about [`ReferenceOptions::memory_budget`]: any scene can
/// exceed a small enough budget.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ReferenceError {
    #[error("resolution {width}x{height}: width and height must be in 1..={max}")]
    Resolution { width: u32, height: u32, max: u32 },
    #[error("tile_size {0}: must be in 1..={max}", max = ReferenceOptions::MAX_TILE_SIZE)]
    TileSize(u32),
    #[error("draw `{draw}`: material {material} does not exist (the scene has {count})")]
    Material {
        draw: String,
        material: u32,
        count: usize,
    },
    #[error(
        "draw `{draw}`: vertices {first}..{first}+{count} must be a multiple of 3 within the {total} scene vertices"
    )]
    VertexRange {
        draw: String,
        first: u32,
        count: u32,
        total: usize,
    },
    #[error(
        "material {material}: texture {texture} does not exist or is malformed (the scene has {count}; each needs 1..={max} texels per side and width·height texels)",
        max = oit_scene::MAX_TEXTURE_DIMENSION
    )]
    Texture {
        material: usize,
        texture: u32,
        count: usize,
    },
    #[error(
        "keeping every pixel's transparent list needs {} MiB, over the {} MiB it may take (a quarter of the memory budget)",
        need.div_ceil(1 << 20),
        budget >> 20
    )]
    ListsOverBudget { need: u64, budget: u64 },
    #[error("{0} triangles: at most {max} are supported", max = MAX_TRIANGLES)]
    TooManyTriangles(u64),
    #[error(
        "memory budget of {budget} bytes: the per-pixel state of one {width}x{height} tile needs at least {minimum}; raise it with --memory-budget"
    )]
    MemoryBudget {
        budget: u64,
        minimum: u64,
        width: u32,
        height: u32,
    },
    #[error(
        "binning needs {bytes} bytes for {overlaps} triangle-tile overlaps and one tile's state, more than the memory budget of {budget} bytes (and at most 4294967295 overlaps are supported); raise it with --memory-budget or use larger tiles"
    )]
    BinningOverBudget {
        overlaps: u64,
        bytes: u64,
        budget: u64,
    },
    #[error(
        "pixel ({x}, {y}) holds {fragments} transparent fragments, which need {bytes} bytes to sort and composite, more than the {available} bytes the memory budget of {budget} bytes leaves after binning and the tile's counts; raise it with --memory-budget"
    )]
    PixelOverBudget {
        x: u32,
        y: u32,
        fragments: u32,
        bytes: u64,
        available: u64,
        budget: u64,
    },
}

/// Renders the exact reference.
///
/// # Panics
/// When the scene breaks the invariants [`oit_scene`]'s loader guarantees (see
/// [`ReferenceError`]), the options are out of range or the scene does not fit the memory
/// budget; use [`try_render`] for hand-built input or a budget it may exceed.
pub fn render(scene: &Scene, options: &ReferenceOptions) -> Reference {
    match try_render(scene, options) {
        Ok(r) => r,
        Err(e) => panic!("oit-reference: invalid input: {e}"),
    }
}

/// [`render`] that reports invalid input, or a scene beyond the memory budget, as an error
/// instead of panicking.
pub fn try_render(scene: &Scene, options: &ReferenceOptions) -> Result<Reference, ReferenceError> {
    render_with(scene, options, None)
}

/// [`try_render`], handing every rectangle's sorted transparent lists to `visit` when given
/// ([`render_visiting`]): then every tile takes the stored path (the output is the same bit
/// for bit; [`ReferenceOptions::in_order`] is ignored).
pub(crate) fn render_with(
    scene: &Scene,
    options: &ReferenceOptions,
    visit: Option<(&FragmentVisitor<'_>, &fragments::Ranks)>,
) -> Result<Reference, ReferenceError> {
    let start = Instant::now();
    validate(scene, options)?;
    let queues = raster::QueueTable::new(scene);
    let in_order = options.in_order && visit.is_none() && queues.is_none();
    let (width, height) = (scene.resolution.width, scene.resolution.height);
    let tile = options.tile_size;

    let (set_up, total) = set_up(scene)?;
    // The order tiles read them in: front to back.
    let raster::Ordered {
        triangles,
        order: bin_order,
        plane_depths,
    } = raster::in_bin_order(set_up);
    let setup_done = Instant::now();

    // Binning: counting pass, prefix sum, fill. Each bin lists triangle indices in
    // `bin_order` (transparent triangles nearest first: most pixels' fragments arrive sorted).
    let tiles_x = width.div_ceil(tile) as usize;
    let tiles_y = height.div_ceil(tile) as usize;
    let tile_count = tiles_x * tiles_y;
    let tile_range = |&[x0, y0, x1, y1]: &[u32; 4]| {
        (
            (x0 / tile) as usize..=(x1 / tile) as usize,
            (y0 / tile) as usize..=(y1 / tile) as usize,
        )
    };
    // Checked before anything is allocated: the overlaps are a product of triangles and tiles
    // (4 M full-screen triangles at 1024² would take 16 GiB), and bin offsets are u32.
    let overlaps: u64 = bin_order
        .iter()
        .map(|(_, bbox)| {
            let (xs, ys) = tile_range(bbox);
            (xs.count() * ys.count()) as u64
        })
        .sum();
    let tile_minimum = raster::tile_minimum_bytes(tile.min(width), tile.min(height));
    let reserved = overlaps * 4 + (tile_count as u64 + 1) * 8;
    if overlaps > u64::from(u32::MAX) || reserved + tile_minimum > options.memory_budget {
        return Err(ReferenceError::BinningOverBudget {
            overlaps,
            bytes: reserved + tile_minimum,
            budget: options.memory_budget,
        });
    }
    let mut bin_start = vec![0u32; tile_count + 1];
    for (_, bbox) in &bin_order {
        let (xs, ys) = tile_range(bbox);
        for ty in ys {
            for tx in xs.clone() {
                bin_start[ty * tiles_x + tx + 1] += 1;
            }
        }
    }
    for i in 0..tile_count {
        bin_start[i + 1] += bin_start[i];
    }
    let mut cursor = bin_start.clone();
    let mut bins = vec![0u32; bin_start[tile_count] as usize];
    for &(i, ref bbox) in &bin_order {
        let (xs, ys) = tile_range(bbox);
        for ty in ys {
            for tx in xs.clone() {
                let c = &mut cursor[ty * tiles_x + tx];
                bins[*c as usize] = i;
                *c += 1;
            }
        }
    }
    drop(cursor);
    let binning_done = Instant::now();

    // What the tiles may hold: an equal share per thread while they run in parallel. A tile
    // that does not fit its share at once is deferred and rendered alone afterwards, in
    // slices, with all of it (only a pixel beyond the whole budget fails), so whether a scene
    // renders does not depend on the number of threads.
    let tile_budget = options.memory_budget - reserved;
    let threads = rayon::current_num_threads();
    let share = tile_budget / threads as u64;
    // A tile holding a thread's part of all the binned triangles would be the critical path
    // (a deep stack over few tiles): it waits until the others are done and then runs alone,
    // in order in bands of rows on every thread. Only a scheduling choice: the output is the
    // same.
    let heavy = |t: usize| {
        let len = (bin_start[t + 1] - bin_start[t]) as usize;
        in_order
            && threads > 1
            && len >= HEAVY_BIN
            && len * threads >= bin_start[tile_count] as usize
    };

    let w = width as usize;
    // Every pixel is written by its tile. Zeroed allocations get their pages lazily, so the
    // first touch of the output (page faults, 24 bytes a pixel) happens in the parallel tile
    // workers instead of serially here.
    let mut image = LinearImage {
        width,
        height,
        pixels: vec![[0.0; 4]; scene.resolution.pixel_count()],
    };
    let mut layers = vec![0u32; scene.resolution.pixel_count()];
    let mut fragments = vec![0u32; scene.resolution.pixel_count()];
    let mut undecided = vec![0u32; scene.resolution.pixel_count()];
    let mut precision_ties = vec![false; scene.resolution.pixel_count()];
    let ctx = raster::TileContext {
        triangles: &triangles,
        textures: &scene.textures,
        lighting: raster::Lighting {
            rig: &scene.lights,
            eye: scene.camera.eye.to_array(),
        },
        planes: &plane_depths,
        reverse_z: scene.camera.reverse_z,
        background: scene.background.map(f64::from),
        coloured: scene.has_transmission(),
        in_order,
        visit,
        queues: queues.as_ref(),
    };
    let done = AtomicUsize::new(0);
    let tile_rect = |t: usize, band_height: u32| TileRect {
        x0: (t % tiles_x) as u32 * tile,
        y0: (t / tiles_x) as u32 * tile,
        width: tile.min(width - (t % tiles_x) as u32 * tile),
        height: band_height,
    };
    let bin_of = |t: usize| &bins[bin_start[t] as usize..bin_start[t + 1] as usize];
    let report = || {
        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
        if let Some(progress) = &options.progress {
            progress(d, tile_count);
        }
    };
    // The first tile (in index order) with a pixel beyond the budget: tiles after it are
    // skipped, tiles before it still run, so the error names the same pixel on every run.
    let first_failure = AtomicUsize::new(usize::MAX);
    let failure = Mutex::new(None);
    let deferred = Mutex::new(Vec::new());
    let pixel_error = |f: TileFailure| match f {
        TileFailure::Pixel {
            x,
            y,
            fragments,
            bytes,
            reserved: counts,
        } => ReferenceError::PixelOverBudget {
            x,
            y,
            fragments,
            bytes,
            available: tile_budget - counts,
            budget: options.memory_budget,
        },
        // Not returned by a tile rendered alone: the binning check leaves it room for its
        // counts and a pixel's state.
        TileFailure::Defer => ReferenceError::MemoryBudget {
            budget: options.memory_budget,
            minimum: reserved + tile_minimum,
            width: tile.min(width),
            height: tile.min(height),
        },
    };
    let band = tile as usize * w;
    let stats = image
        .pixels
        .par_chunks_mut(band)
        .zip(layers.par_chunks_mut(band))
        .zip(fragments.par_chunks_mut(band))
        .zip(undecided.par_chunks_mut(band))
        .zip(precision_ties.par_chunks_mut(band))
        .enumerate()
        .map_init(
            Scratch::default,
            |scratch, (ty, ((((img, lay), frag), und), ties))| {
                let mut stats = TileStats::default();
                let band_height = (img.len() / w) as u32;
                for tx in 0..tiles_x {
                    let t = ty * tiles_x + tx;
                    if t > first_failure.load(Ordering::Relaxed) {
                        break;
                    }
                    if heavy(t) {
                        deferred.lock().unwrap().push(t);
                        continue;
                    }
                    let rect = tile_rect(t, band_height);
                    let out = TileOutput {
                        image: &mut *img,
                        layers: &mut *lay,
                        fragments: &mut *frag,
                        undecided: &mut *und,
                        precision_ties: &mut *ties,
                        stride: w,
                        x_offset: rect.x0 as usize,
                    };
                    match raster::render_tile(
                        &ctx,
                        bin_of(t),
                        rect,
                        scratch,
                        out,
                        share,
                        tile_budget,
                    ) {
                        Ok(s) => {
                            stats = stats.merge(s);
                            report();
                        }
                        Err(TileFailure::Defer) => deferred.lock().unwrap().push(t),
                        Err(f) => {
                            first_failure.fetch_min(t, Ordering::Relaxed);
                            let mut slot = failure.lock().unwrap();
                            if slot.as_ref().is_none_or(|(u, _)| t < *u) {
                                *slot = Some((t, pixel_error(f)));
                            }
                        }
                    }
                }
                stats
            },
        )
        .reduce(TileStats::default, TileStats::merge);
    if let Some((_, e)) = failure.into_inner().unwrap() {
        return Err(e);
    }
    // Deferred tiles (over a thread's share, or heavy) one at a time, each with the whole tile
    // budget (the scratches of the parallel pass are gone by now), in bands or slices that run
    // in parallel.
    let mut stats = stats;
    let mut deferred = deferred.into_inner().unwrap();
    deferred.sort_unstable();
    for t in deferred {
        let ty = t / tiles_x;
        let rows = ty * band..((ty + 1) * band).min(w * height as usize);
        let rect = tile_rect(t, (rows.len() / w) as u32);
        let out = TileOutput {
            image: &mut image.pixels[rows.clone()],
            layers: &mut layers[rows.clone()],
            fragments: &mut fragments[rows.clone()],
            undecided: &mut undecided[rows.clone()],
            precision_ties: &mut precision_ties[rows],
            stride: w,
            x_offset: rect.x0 as usize,
        };
        let s = raster::render_tile_sliced(&ctx, bin_of(t), rect, out, tile_budget)
            .map_err(pixel_error)?;
        stats = stats.merge(s);
        report();
    }

    let seconds = start.elapsed().as_secs_f64();
    let pixels = scene.resolution.pixel_count() as f64;
    let stats = ReferenceStats {
        triangles: total,
        raster_triangles: triangles.len() as u64,
        fragments: stats.fragments,
        transparent_fragments: stats.transparent_fragments,
        composited_fragments: stats.composited_fragments,
        max_depth_complexity: stats.max_layers,
        mean_depth_complexity: if stats.covered_pixels > 0 {
            stats.composited_fragments as f64 / stats.covered_pixels as f64
        } else {
            0.0
        },
        mean_depth_complexity_all: stats.composited_fragments as f64 / pixels,
        covered_pixels: stats.covered_pixels,
        undecided_fragments: stats.undecided_fragments,
        undecided_pixels: stats.undecided_pixels,
        precision_tie_pixels: stats.precision_tie_pixels,
        seconds,
        fragments_per_second: if seconds > 0.0 {
            stats.fragments as f64 / seconds
        } else {
            0.0
        },
        setup_seconds: (setup_done - start).as_secs_f64(),
        binning_seconds: (binning_done - setup_done).as_secs_f64(),
        raster_seconds: stats.raster.as_secs_f64(),
        sort_seconds: stats.sort.as_secs_f64(),
        composite_seconds: stats.composite.as_secs_f64(),
        peak_tile_bytes: stats.peak_tile_bytes,
        sliced_tiles: stats.sliced_tiles,
        in_order_tiles: stats.in_order_tiles,
        banded_tiles: stats.banded_tiles,
        stored_pixels: stats.stored_pixels,
        given_up_tiles: stats.given_up_tiles,
        tile_size: tile,
        tiles: tile_count as u64,
        threads: rayon::current_num_threads(),
    };
    Ok(Reference {
        image,
        layers,
        fragments,
        undecided,
        precision_ties,
        stats,
    })
}

/// Every triangle of `scene` set up (clipped, snapped, culled), in pieces of consecutive
/// ranks, with what ordering needs of them ([`raster::SetUp`]), and the number of input
/// triangles. Ranks follow (draw.id, triangle index): the tie-break order, independent of the
/// draw list's order.
pub(crate) fn set_up(scene: &Scene) -> Result<(raster::SetUp, u64), ReferenceError> {
    let mut by_id: Vec<usize> = (0..scene.draws.len()).collect();
    by_id.sort_by_key(|&i| scene.draws[i].id);
    let mut first_rank = Vec::with_capacity(by_id.len() + 1);
    let mut total: u64 = 0;
    for &i in &by_id {
        first_rank.push(total);
        total += u64::from(scene.draws[i].triangle_count());
    }
    first_rank.push(total);
    if total > u64::from(MAX_TRIANGLES) {
        return Err(ReferenceError::TooManyTriangles(total));
    }
    const CHUNK: usize = setup::CHUNK_RANKS;
    let reverse_z = scene.camera.reverse_z;
    // Only for telling coplanar flat triangles from ones rounding merged (`plane_depth`).
    let view_proj64 = scene.camera.view_proj.as_dmat4();
    let mut plane_depths = vec![f64::NAN; total as usize];
    let pieces: Vec<_> = plane_depths
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(c, planes)| {
            let lo = (c * CHUNK) as u64;
            // One piece per triangle unless clipping cuts it: sized once, never regrown.
            let mut out = Vec::with_capacity(planes.len());
            let mut keys = Vec::with_capacity(planes.len());
            let mut d = first_rank.partition_point(|&f| f <= lo) - 1;
            for (rank, plane_out) in (lo..).zip(planes.iter_mut()) {
                while first_rank[d + 1] <= rank {
                    d += 1;
                }
                let draw = &scene.draws[by_id[d]];
                let material = scene.material_of(draw);
                let t = (rank - first_rank[d]) as usize;
                let v0 = draw.first_vertex as usize + 3 * t;
                let clip = std::array::from_fn(|k| {
                    let v = &scene.vertices[v0 + k];
                    (
                        scene.camera.clip(glam::Vec3::from(v.position)),
                        v.color,
                        v.uv,
                        v.position,
                        v.normal,
                    )
                });
                let p = glam::Vec3::from(scene.vertices[v0].position).as_dvec3();
                let plane = view_proj64 * p.extend(1.0);
                let plane_depth = plane.z / plane.w;
                let first = out.len();
                setup::setup_triangle(scene, material, clip, rank as u32, plane_depth, &mut out);
                for (j, piece) in out.iter().enumerate().skip(first) {
                    keys.push(raster::bin_key(
                        piece,
                        setup::Triangles::id(c, j),
                        reverse_z,
                    ));
                }
                if let Some(last) = out[first..].last() {
                    *plane_out = last.plane_depth;
                }
            }
            let bboxes = out.iter().map(|t| t.bbox).collect::<Vec<_>>();
            (out, keys, bboxes)
        })
        .collect();
    // One list of keys for the sort; each chunk's are freed as they are copied.
    let mut keys = Vec::with_capacity(pieces.iter().map(|(_, k, _)| k.len()).sum());
    let mut chunks = Vec::with_capacity(pieces.len());
    let mut bboxes = Vec::with_capacity(pieces.len());
    for (chunk, chunk_keys, chunk_bboxes) in pieces {
        keys.extend_from_slice(&chunk_keys);
        chunks.push(chunk);
        bboxes.push(chunk_bboxes);
    }
    let set_up = raster::SetUp {
        triangles: setup::Triangles::new(chunks),
        keys,
        bboxes,
        plane_depths,
    };
    Ok((set_up, total))
}

fn validate(scene: &Scene, options: &ReferenceOptions) -> Result<(), ReferenceError> {
    let r = scene.resolution;
    let max = oit_scene::Resolution::MAX_DIMENSION;
    if r.width == 0 || r.height == 0 || r.width > max || r.height > max {
        return Err(ReferenceError::Resolution {
            width: r.width,
            height: r.height,
            max,
        });
    }
    if options.tile_size == 0 || options.tile_size > ReferenceOptions::MAX_TILE_SIZE {
        return Err(ReferenceError::TileSize(options.tile_size));
    }
    let (width, height) = (
        options.tile_size.min(r.width),
        options.tile_size.min(r.height),
    );
    let minimum = raster::tile_minimum_bytes(width, height);
    if options.memory_budget < minimum {
        return Err(ReferenceError::MemoryBudget {
            budget: options.memory_budget,
            minimum,
            width,
            height,
        });
    }
    for (i, m) in scene.materials.iter().enumerate() {
        for t in [m.base_texture, m.emissive_texture].into_iter().flatten() {
            if !scene
                .textures
                .get(t as usize)
                .is_some_and(oit_scene::Texture::is_consistent)
            {
                return Err(ReferenceError::Texture {
                    material: i,
                    texture: t,
                    count: scene.textures.len(),
                });
            }
        }
    }
    for d in &scene.draws {
        if d.material as usize >= scene.materials.len() {
            return Err(ReferenceError::Material {
                draw: d.name.clone(),
                material: d.material,
                count: scene.materials.len(),
            });
        }
        let end = u64::from(d.first_vertex) + u64::from(d.vertex_count);
        if d.vertex_count % 3 != 0 || end > scene.vertices.len() as u64 {
            return Err(ReferenceError::VertexRange {
                draw: d.name.clone(),
                first: d.first_vertex,
                count: d.vertex_count,
                total: scene.vertices.len(),
            });
        }
    }
    Ok(())
}
