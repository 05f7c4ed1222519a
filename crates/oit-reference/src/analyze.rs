//! What a scene asks of an order-independent technique, measured on the reference's own
//! per-pixel fragment lists ([`crate::render_visiting`]): layers per pixel, where no single
//! order of objects or of triangles is exact, self-overlap, α near 0 and 1, the radiance
//! range and whether 16-bit depth keys keep the layers apart. Definitions: docs/analyze.md.
//!
//! Two passes over the lists (the scene is rendered twice): the first gathers the per-pixel
//! measures and the precedence edges (who is directly in front of whom at some pixel), whose
//! strongly connected components are the cycles; the second counts, per pixel and per pair,
//! what those cycles touch. The pair and edge maps are not counted in the memory budget: they
//! hold at most one entry per composited fragment (distinct adjacent pairs).

use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::Mutex;
use std::time::Instant;

use oit_scene::Scene;

use crate::{PixelFragment, RectFragments, ReferenceError, ReferenceOptions, render_visiting};

/// Schema name of [`Analysis`] as JSON.
pub const SCHEMA: &str = "oit-lab/analyze/v1";

/// Pairs listed per granularity (the counts cover all of them).
pub const LISTED_PAIRS: usize = 100;

/// A scene's analysis. Serialized as the `oit-lab/analyze/v1` schema (docs/analyze.md).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Analysis {
    pub schema: &'static str,
    pub scene: String,
    pub resolution: [u32; 2],
    pub pixels: u64,
    pub layers: Layers,
    pub fragments: Fragments,
    pub objects: OrderConflicts<DrawRef>,
    pub triangles: OrderConflicts<TriangleRef>,
    pub self_overlap: SelfOverlap,
    pub alpha: Alpha,
    pub radiance: Radiance,
    pub depth: Depth,
    /// Wall time of the analysis (both passes).
    pub seconds: f64,
}

/// Transparent fragments composited per pixel (over all pixels, empty ones included).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Layers {
    pub max: u32,
    pub p50: u32,
    pub p95: u32,
    pub p99: u32,
    /// Pixels with at least one layer.
    pub covered_pixels: u64,
    /// `[layers, pixels]` for every layer count some pixel has, ascending.
    pub histogram: Vec<[u64; 2]>,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Fragments {
    /// All fragments rasterized, opaque and transparent, before any depth test.
    pub produced: u64,
    /// Transparent fragments after cutoff discard, before the opaque depth test.
    pub transparent: u64,
    /// Transparent fragments in front of the opaque surface: the lists analysed.
    pub composited: u64,
}

/// A draw, by index into `scene.draws` and name.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
pub struct DrawRef {
    pub draw: usize,
    pub name: String,
}

/// A triangle: its draw and its index within the draw.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
pub struct TriangleRef {
    pub draw: usize,
    pub name: String,
    pub triangle: u32,
}

/// Two items on one precedence cycle, with the pixels that show their order.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PairCount<T> {
    pub a: T,
    pub b: T,
    /// Pixels where every fragment of `a` is in front of every fragment of `b`.
    pub a_in_front: u64,
    pub b_in_front: u64,
    /// Pixels where their fragments interleave (`a … b … a`; objects only).
    pub interleaved: u64,
}

/// Where no single order of the items (draws, or triangles) is exact.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OrderConflicts<T> {
    /// Pixels holding two items of one precedence cycle: every single order of the items is
    /// wrong at some of these pixels, and only at these.
    pub conflict_pixels: u64,
    /// Cycles (strongly connected components of two or more items).
    pub cycles: u64,
    /// Items in the largest cycle (0 without cycles).
    pub largest_cycle: u64,
    /// Pairs of items on a common cycle that meet at some pixel.
    pub conflict_pairs: u64,
    /// Up to [`LISTED_PAIRS`] of them, most pixels first.
    pub pairs: Vec<PairCount<T>>,
    /// Pixels where the order the sorting technique uses is wrong: for objects `sorted-object`'s
    /// ([`Scene::babylon_object_order`], whole draws), for triangles `sorted-triangle`'s
    /// (centroid view depth, stable).
    pub technique_order_wrong_pixels: u64,
    /// Objects: pixels where `sorted-object` is wrong counting also the order within each
    /// object (its triangles blended in index order); equal to the above for triangles.
    pub technique_draw_order_wrong_pixels: u64,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SelfOverlap {
    /// Pixels where some draw contributes two or more fragments.
    pub pixels: u64,
    /// Per draw with self-overlap: its pixels, most first.
    pub draws: Vec<DrawPixels>,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DrawPixels {
    pub draw: usize,
    pub name: String,
    pub pixels: u64,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Alpha {
    /// Composited fragments with α < 1/255.
    pub near_zero: u64,
    /// Composited fragments with α > 254/255.
    pub near_one: u64,
}

/// Minimum and maximum over channels (R, G, B); null where there is nothing.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Radiance {
    /// Of the composited fragments' premultiplied colours.
    pub premultiplied: Option<[f32; 2]>,
    /// Of the reference image (every pixel).
    pub composite: Option<[f32; 2]>,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Depth {
    /// Window depth interval of the composited fragments.
    pub window: Option<[f32; 2]>,
    /// The same as view distance ([`oit_scene::Camera::view_distance`]), nearest first.
    pub view: Option<[f32; 2]>,
    /// Pixels where two neighbouring layers share a 16-bit key (`round(depth · 65535)`).
    pub depth16_shared_pixels: u64,
    /// Whether 16-bit keys keep every pixel's layers apart.
    pub depth16_separates: bool,
    /// Pixels where two neighbouring layers have the same f32 window depth.
    pub equal_depth_pixels: u64,
}

/// The order each sorting technique blends transparent fragments in, as positions (blended
/// later = larger = in front): per draw for `sorted-object`, per rank for `sorted-triangle`.
struct TechniqueOrders {
    /// Per draw: position in [`Scene::babylon_object_order`], `None` for opaque draws.
    object: Vec<Option<u32>>,
    /// Per rank: position in `sorted-triangle`'s stream (0 for opaque triangles).
    triangle: Vec<u32>,
}

impl TechniqueOrders {
    fn new(scene: &Scene) -> Self {
        let mut object = vec![None; scene.draws.len()];
        for (pos, d) in scene.babylon_object_order().into_iter().enumerate() {
            object[d] = Some(pos as u32);
        }
        // `sorted-triangle` (techniques/sorted): render groups ascending; in each, the
        // transparent draws in list order, their triangles sorted back to front by the view
        // depth of the f32 centroid, stable.
        let ranks = crate::fragments::Ranks::new(scene);
        let total: usize = scene
            .draws
            .iter()
            .map(|d| d.triangle_count() as usize)
            .sum();
        let mut triangle = vec![0u32; total];
        let mut groups: BTreeMap<u32, Vec<(u32, u32)>> = BTreeMap::new();
        let row = scene.camera.view.row(2);
        for (i, d) in scene.draws.iter().enumerate() {
            if !scene.material_of(d).mode.is_transparent() {
                continue;
            }
            let g = groups.entry(d.ordering.group).or_default();
            let first = ranks.first_rank(i);
            for t in 0..d.triangle_count() {
                let v = (d.first_vertex + 3 * t) as usize;
                let p = |k: usize| glam::Vec3::from(scene.vertices[v + k].position);
                let c = (p(0) + p(1) + p(2)) / 3.0;
                let depth = -(row.x * c.x + row.y * c.y + row.z * c.z + row.w);
                let key = !ordered_bits(depth);
                let rank = (first + u64::from(t)) as u32;
                g.push((key, rank));
            }
        }
        let mut pos = 0u32;
        for list in groups.values_mut() {
            list.sort_by_key(|&(key, _)| key);
            for &(_, rank) in list.iter() {
                if let Some(slot) = triangle.get_mut(rank as usize) {
                    *slot = pos;
                }
                pos += 1;
            }
        }
        TechniqueOrders { object, triangle }
    }
}

/// Order-preserving map from f32 to u32 (techniques/sorted's `ordered_bits`).
fn ordered_bits(x: f32) -> u32 {
    let b = x.to_bits();
    b ^ (((b as i32) >> 31) as u32 | 0x8000_0000)
}

/// Measures of the first pass, per rectangle and merged.
#[derive(Default)]
struct First {
    histogram: Vec<u64>,
    near_zero: u64,
    near_one: u64,
    premultiplied: Option<[f32; 2]>,
    window: Option<[f32; 2]>,
    depth16_shared: u64,
    equal_depth: u64,
    self_overlap_pixels: u64,
    self_overlap: HashMap<usize, u64>,
    object_edges: HashSet<(u32, u32)>,
    triangle_edges: HashSet<(u32, u32)>,
    object_wrong: u64,
    object_draw_wrong: u64,
    triangle_wrong: u64,
}

fn widen(range: &mut Option<[f32; 2]>, lo: f32, hi: f32) {
    *range = Some(match *range {
        None => [lo, hi],
        Some([a, b]) => [a.min(lo), b.max(hi)],
    });
}

impl First {
    fn merge(&mut self, o: First) {
        if self.histogram.len() < o.histogram.len() {
            self.histogram.resize(o.histogram.len(), 0);
        }
        for (a, b) in self.histogram.iter_mut().zip(&o.histogram) {
            *a += b;
        }
        self.near_zero += o.near_zero;
        self.near_one += o.near_one;
        for (mine, theirs) in [
            (&mut self.premultiplied, o.premultiplied),
            (&mut self.window, o.window),
        ] {
            if let Some([lo, hi]) = theirs {
                widen(mine, lo, hi);
            }
        }
        self.depth16_shared += o.depth16_shared;
        self.equal_depth += o.equal_depth;
        self.self_overlap_pixels += o.self_overlap_pixels;
        for (d, n) in o.self_overlap {
            *self.self_overlap.entry(d).or_default() += n;
        }
        self.object_edges.extend(o.object_edges);
        self.triangle_edges.extend(o.triangle_edges);
        self.object_wrong += o.object_wrong;
        self.object_draw_wrong += o.object_draw_wrong;
        self.triangle_wrong += o.triangle_wrong;
    }

    fn pixel(
        &mut self,
        list: &[PixelFragment],
        runs: &mut Vec<(usize, usize)>,
        previous: &mut Vec<u32>,
        orders: &TechniqueOrders,
    ) {
        let n = list.len();
        if self.histogram.len() <= n {
            self.histogram.resize(n + 1, 0);
        }
        self.histogram[n] += 1;
        if n == 0 {
            return;
        }
        let (mut shared16, mut equal) = (false, false);
        for (i, f) in list.iter().enumerate() {
            self.near_zero += u64::from(f.alpha < 1.0 / 255.0);
            self.near_one += u64::from(f.alpha > 254.0 / 255.0);
            let [r, g, b] = f.premultiplied;
            widen(&mut self.premultiplied, r.min(g).min(b), r.max(g).max(b));
            widen(&mut self.window, f.depth, f.depth);
            if let Some(next) = list.get(i + 1) {
                equal |= f.depth == next.depth;
                shared16 |= depth16(f.depth) == depth16(next.depth);
            }
        }
        // Neighbouring pixels mostly hold the same triangles in the same order: their edges
        // are in the sets already (hashing every fragment's edge was 30 times the render).
        let same = previous.len() == n && previous.iter().zip(list).all(|(&r, f)| r == f.rank);
        if !same {
            previous.clear();
            previous.extend(list.iter().map(|f| f.rank));
            for w in list.windows(2) {
                self.triangle_edges.insert((w[0].rank, w[1].rank));
            }
        }
        self.depth16_shared += u64::from(shared16);
        self.equal_depth += u64::from(equal);
        // Runs of one draw: (draw, fragments).
        runs.clear();
        for f in list {
            match runs.last_mut() {
                Some((d, count)) if *d == f.draw => *count += 1,
                _ => runs.push((f.draw, 1)),
            }
        }
        if !same {
            for w in runs.windows(2) {
                self.object_edges.insert((w[0].0 as u32, w[1].0 as u32));
            }
        }
        // Front to back, each fragment must have been blended after the next one.
        let object = |d: usize| orders.object[d].unwrap_or(0);
        let object_wrong = runs.windows(2).any(|w| object(w[0].0) <= object(w[1].0));
        self.object_wrong += u64::from(object_wrong);
        let draw_wrong = list
            .windows(2)
            .any(|w| (object(w[0].draw), w[0].triangle) <= (object(w[1].draw), w[1].triangle));
        self.object_draw_wrong += u64::from(draw_wrong);
        let triangle = |f: &PixelFragment| orders.triangle[f.rank as usize];
        let triangle_wrong = list.windows(2).any(|w| triangle(&w[0]) <= triangle(&w[1]));
        self.triangle_wrong += u64::from(triangle_wrong);
        // Self-overlap: a draw with two fragments, in one run or several (the runs sorted by
        // draw, so O(r log r) for r runs; they are not needed after this).
        runs.sort_unstable_by_key(|&(d, _)| d);
        let mut overlapping = false;
        for group in runs.chunk_by(|a, b| a.0 == b.0) {
            if group.len() > 1 || group[0].1 > 1 {
                overlapping = true;
                *self.self_overlap.entry(group[0].0).or_default() += 1;
            }
        }
        self.self_overlap_pixels += u64::from(overlapping);
    }
}

/// The 16-bit key of a window depth, as a `Depth16Unorm` buffer stores it.
fn depth16(depth: f32) -> u16 {
    (f64::from(depth.clamp(0.0, 1.0)) * 65535.0).round() as u16
}

/// Strongly connected components of two or more nodes (Tarjan, iterative): node → component.
fn cycles(edges: &HashSet<(u32, u32)>) -> (HashMap<u32, u32>, Vec<u64>) {
    let mut index_of: HashMap<u32, usize> = HashMap::new();
    let mut nodes = Vec::new();
    for &(a, b) in edges {
        for v in [a, b] {
            index_of.entry(v).or_insert_with(|| {
                nodes.push(v);
                nodes.len() - 1
            });
        }
    }
    let n = nodes.len();
    let mut adjacency = vec![Vec::new(); n];
    for &(a, b) in edges {
        adjacency[index_of[&a]].push(index_of[&b]);
    }
    const NONE: usize = usize::MAX;
    let (mut index, mut low, mut on_stack) = (vec![NONE; n], vec![0; n], vec![false; n]);
    let (mut stack, mut next, mut comp_of) = (Vec::new(), 0, HashMap::new());
    let mut sizes = Vec::new();
    for root in 0..n {
        if index[root] != NONE {
            continue;
        }
        let mut call = vec![(root, 0usize)];
        index[root] = next;
        low[root] = next;
        next += 1;
        stack.push(root);
        on_stack[root] = true;
        while let Some(&mut (v, ref mut child)) = call.last_mut() {
            if let Some(&w) = adjacency[v].get(*child) {
                *child += 1;
                if index[w] == NONE {
                    index[w] = next;
                    low[w] = next;
                    next += 1;
                    stack.push(w);
                    on_stack[w] = true;
                    call.push((w, 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            call.pop();
            if let Some(&(parent, _)) = call.last() {
                low[parent] = low[parent].min(low[v]);
            }
            if low[v] == index[v] {
                let mut members = Vec::new();
                while let Some(w) = stack.pop() {
                    on_stack[w] = false;
                    members.push(w);
                    if w == v {
                        break;
                    }
                }
                if members.len() > 1 {
                    let c = sizes.len() as u32;
                    sizes.push(members.len() as u64);
                    for w in members {
                        comp_of.insert(nodes[w], c);
                    }
                }
            }
        }
    }
    (comp_of, sizes)
}

/// Measures of the second pass: pixels and pairs on cycles.
#[derive(Default)]
struct Second {
    object_pixels: u64,
    triangle_pixels: u64,
    /// (a, b) with a < b → [a in front, b in front, interleaved].
    object_pairs: HashMap<(u32, u32), [u64; 3]>,
    triangle_pairs: HashMap<(u32, u32), [u64; 3]>,
}

impl Second {
    fn merge(&mut self, o: Second) {
        self.object_pixels += o.object_pixels;
        self.triangle_pixels += o.triangle_pixels;
        for (mine, theirs) in [
            (&mut self.object_pairs, o.object_pairs),
            (&mut self.triangle_pairs, o.triangle_pairs),
        ] {
            for (k, v) in theirs {
                let e = mine.entry(k).or_default();
                for i in 0..3 {
                    e[i] += v[i];
                }
            }
        }
    }

    /// `items`: per fragment front to back, the item and its component (only fragments on a
    /// cycle). Counts the pixel once and every pair of one component once.
    fn pairs(items: &[(u32, u32)], pairs: &mut HashMap<(u32, u32), [u64; 3]>) -> bool {
        // First and last position of each item on a cycle.
        let mut span: Vec<(u32, u32, usize, usize)> = Vec::new();
        for (pos, &(item, comp)) in items.iter().enumerate() {
            match span.iter_mut().find(|s| s.0 == item) {
                Some(s) => s.3 = pos,
                None => span.push((item, comp, pos, pos)),
            }
        }
        let mut conflict = false;
        for i in 0..span.len() {
            for j in i + 1..span.len() {
                let (x, y) = (span[i], span[j]);
                if x.1 != y.1 {
                    continue;
                }
                conflict = true;
                let ((a, a_first, a_last), (b, b_first, b_last)) = if x.0 < y.0 {
                    ((x.0, x.2, x.3), (y.0, y.2, y.3))
                } else {
                    ((y.0, y.2, y.3), (x.0, x.2, x.3))
                };
                let k = if a_last < b_first {
                    0
                } else if b_last < a_first {
                    1
                } else {
                    2
                };
                pairs.entry((a, b)).or_default()[k] += 1;
            }
        }
        conflict
    }
}

/// Analyses `scene` on its reference's fragment lists (two renders with `options`: its
/// memory budget bounds them as it bounds [`crate::try_render`]; progress is reported for
/// each).
pub fn analyze(scene: &Scene, options: &ReferenceOptions) -> Result<Analysis, ReferenceError> {
    let start = Instant::now();
    let orders = TechniqueOrders::new(scene);
    let first = Mutex::new(First::default());
    let visit_first = |rect: &RectFragments<'_>| {
        let mut local = First::default();
        let (mut list, mut runs, mut previous) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..rect.pixel_count() {
            list.clear();
            list.extend(rect.fragments(i));
            local.pixel(&list, &mut runs, &mut previous, &orders);
        }
        lock(&first).merge(local);
    };
    let reference = render_visiting(scene, options, &visit_first)?;
    let first = first.into_inner().unwrap_or_else(|e| e.into_inner());
    let (object_cycle, object_sizes) = cycles(&first.object_edges);
    let (triangle_cycle, triangle_sizes) = cycles(&first.triangle_edges);

    let mut second = Second::default();
    if !object_cycle.is_empty() || !triangle_cycle.is_empty() {
        let merged = Mutex::new(Second::default());
        let visit_second = |rect: &RectFragments<'_>| {
            let mut local = Second::default();
            let mut items = Vec::new();
            for i in 0..rect.pixel_count() {
                items.clear();
                items.extend(rect.fragments(i).filter_map(|f| {
                    let d = f.draw as u32;
                    object_cycle.get(&d).map(|&c| (d, c))
                }));
                local.object_pixels += u64::from(Second::pairs(&items, &mut local.object_pairs));
                items.clear();
                items.extend(
                    rect.fragments(i)
                        .filter_map(|f| triangle_cycle.get(&f.rank).map(|&c| (f.rank, c))),
                );
                local.triangle_pixels +=
                    u64::from(Second::pairs(&items, &mut local.triangle_pairs));
            }
            lock(&merged).merge(local);
        };
        render_visiting(scene, options, &visit_second)?;
        second = merged.into_inner().unwrap_or_else(|e| e.into_inner());
    }

    let name = |d: usize| {
        scene
            .draws
            .get(d)
            .map(|d| d.name.clone())
            .unwrap_or_default()
    };
    let ranks = crate::fragments::Ranks::new(scene);
    let st = &reference.stats;
    let pixels = scene.resolution.pixel_count() as u64;
    let mut self_overlap: Vec<DrawPixels> = first
        .self_overlap
        .iter()
        .map(|(&draw, &pixels)| DrawPixels {
            draw,
            name: name(draw),
            pixels,
        })
        .collect();
    self_overlap.sort_by(|a, b| b.pixels.cmp(&a.pixels).then(a.draw.cmp(&b.draw)));
    let composite = reference
        .image
        .pixels
        .iter()
        .flat_map(|p| p[..3].iter().copied())
        .fold(None, |acc: Option<[f32; 2]>, v| {
            Some(acc.map_or([v, v], |[lo, hi]| [lo.min(v), hi.max(v)]))
        });
    let view = first.window.map(|[lo, hi]| {
        let (a, b) = (
            scene.camera.view_distance(lo),
            scene.camera.view_distance(hi),
        );
        [a.min(b), a.max(b)]
    });
    Ok(Analysis {
        schema: SCHEMA,
        scene: scene.name.clone(),
        resolution: [scene.resolution.width, scene.resolution.height],
        pixels,
        layers: layers(&first.histogram, st.covered_pixels),
        fragments: Fragments {
            produced: st.fragments,
            transparent: st.transparent_fragments,
            composited: st.composited_fragments,
        },
        objects: conflicts(
            second.object_pixels,
            &object_sizes,
            &second.object_pairs,
            |d| DrawRef {
                draw: d as usize,
                name: name(d as usize),
            },
            first.object_wrong,
            first.object_draw_wrong,
        ),
        triangles: conflicts(
            second.triangle_pixels,
            &triangle_sizes,
            &second.triangle_pairs,
            |r| {
                let (draw, triangle) = ranks.draw_and_triangle(r);
                TriangleRef {
                    draw,
                    name: name(draw),
                    triangle,
                }
            },
            first.triangle_wrong,
            first.triangle_wrong,
        ),
        self_overlap: SelfOverlap {
            pixels: first.self_overlap_pixels,
            draws: self_overlap,
        },
        alpha: Alpha {
            near_zero: first.near_zero,
            near_one: first.near_one,
        },
        radiance: Radiance {
            premultiplied: first.premultiplied,
            composite,
        },
        depth: Depth {
            window: first.window,
            view,
            depth16_shared_pixels: first.depth16_shared,
            depth16_separates: first.depth16_shared == 0,
            equal_depth_pixels: first.equal_depth,
        },
        seconds: start.elapsed().as_secs_f64(),
    })
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

fn layers(histogram: &[u64], covered_pixels: u64) -> Layers {
    let total: u64 = histogram.iter().sum();
    // Nearest rank: the least count with at least q of the pixels at or below it.
    let percentile = |q: f64| {
        let want = ((q * total as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (n, &c) in histogram.iter().enumerate() {
            seen += c;
            if seen >= want {
                return n as u32;
            }
        }
        0
    };
    Layers {
        max: histogram.iter().rposition(|&c| c > 0).unwrap_or(0) as u32,
        p50: percentile(0.5),
        p95: percentile(0.95),
        p99: percentile(0.99),
        covered_pixels,
        histogram: histogram
            .iter()
            .enumerate()
            .filter(|(_, c)| **c > 0)
            .map(|(n, &c)| [n as u64, c])
            .collect(),
    }
}

fn conflicts<T>(
    conflict_pixels: u64,
    sizes: &[u64],
    pairs: &HashMap<(u32, u32), [u64; 3]>,
    item: impl Fn(u32) -> T,
    wrong: u64,
    draw_wrong: u64,
) -> OrderConflicts<T> {
    let mut sorted: Vec<_> = pairs.iter().collect();
    sorted.sort_by(|(ka, a), (kb, b)| {
        let total = |c: &[u64; 3]| c.iter().sum::<u64>();
        total(b).cmp(&total(a)).then(ka.cmp(kb))
    });
    OrderConflicts {
        conflict_pixels,
        cycles: sizes.len() as u64,
        largest_cycle: sizes.iter().copied().max().unwrap_or(0),
        conflict_pairs: pairs.len() as u64,
        pairs: sorted
            .into_iter()
            .take(LISTED_PAIRS)
            .map(
                |(&(a, b), &[a_in_front, b_in_front, interleaved])| PairCount {
                    a: item(a),
                    b: item(b),
                    a_in_front,
                    b_in_front,
                    interleaved,
                },
            )
            .collect(),
        technique_order_wrong_pixels: wrong,
        technique_draw_order_wrong_pixels: draw_wrong,
    }
}
