//! Every pixel's transparent list, kept: what a technique's CPU model ([`PixelLists::model_error`])
//! composites in the technique's own order, or with the technique's own losses, to predict
//! before a run whether the technique is exact on a scene and why not.

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use oit_scene::Scene;
use rayon::prelude::*;

use crate::{Reference, ReferenceError, ReferenceOptions, render_visiting};

/// One transparent fragment of a pixel, as the reference composites it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layer {
    /// Premultiplied linear RGB.
    pub premultiplied: [f32; 3],
    /// Coverage α (`1 − mean transmittance` for coloured transmission).
    pub alpha: f32,
    /// Per-channel transmittance (`1 − α` in every channel without coloured transmission).
    pub transmittance: [f32; 3],
    /// Window depth as stored.
    pub depth: f32,
    /// Index of its draw in `scene.draws`.
    pub draw: u32,
    /// Triangle index within the draw.
    pub triangle: u32,
}

/// One pixel: its layers nearest first, and the colour they are composited over.
#[derive(Debug, Clone, Copy)]
pub struct Pixel<'a> {
    pub layers: &'a [Layer],
    pub behind: [f64; 3],
}

/// The per-pixel lists of a whole frame, nearest first, with the reference they were made with.
#[derive(Debug)]
pub struct PixelLists {
    pub width: u32,
    pub height: u32,
    /// Pixel `p`'s layers are `layers[offsets[p]..offsets[p + 1]]`.
    offsets: Vec<u32>,
    layers: Vec<Layer>,
    behind: Vec<[f64; 3]>,
    /// Pixels where rounding, not geometry, may decide the GPU's answer (undecided cutoffs,
    /// precision ties): a model's difference there is not held against it.
    rounding: Vec<bool>,
}

/// One visited rectangle's lists, before they are put in frame order.
struct Rect {
    x0: u32,
    y0: u32,
    width: u32,
    counts: Vec<u32>,
    layers: Vec<Layer>,
    behind: Vec<[f64; 3]>,
}

impl Rect {
    /// Frame coordinates of the rectangle's pixel `i`.
    fn at(&self, i: usize) -> (usize, usize) {
        let w = self.width as usize;
        (self.x0 as usize + i % w, self.y0 as usize + i / w)
    }
}

/// Bytes kept per layer and per pixel (for the memory check).
const LAYER_BYTES: u64 = std::mem::size_of::<Layer>() as u64;
const PIXEL_BYTES: u64 = 4 + 24 + 1;

/// How far a model's composite is from the exact one, over the pixels.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ModelError {
    /// Largest per-channel difference, relative above 1 (`|m − e| / max(1, |e|)`), over the
    /// pixels that rounding does not decide.
    pub max_relative: f64,
    /// Pixels whose difference exceeds `threshold` (the argument of [`PixelLists::model_error`]).
    pub pixels_over: u64,
    /// Pixels that rounding decides and where the model differs by more than `threshold`.
    pub rounding_pixels_over: u64,
    /// The pixel with the largest difference (x, y).
    pub worst: Option<(u32, u32)>,
}

/// The reference of `scene` and its per-pixel lists, together within `options.memory_budget`:
/// the render takes half of it, the lists a quarter (they are held twice while they are put in
/// frame order, so at most the other half). Refused with [`ReferenceError::ListsOverBudget`]
/// when the lists need more than their quarter.
pub fn render_lists(
    scene: &Scene,
    options: &ReferenceOptions,
) -> Result<(Reference, PixelLists), ReferenceError> {
    let res = scene.resolution;
    let pixels = res.pixel_count();
    let collected: Mutex<Vec<Rect>> = Mutex::new(Vec::new());
    let held = AtomicU64::new(0);
    let lists_budget = options.memory_budget / 4;
    let render_options = ReferenceOptions {
        memory_budget: options.memory_budget / 2,
        ..options.clone()
    };
    let visit = |rect: &crate::RectFragments<'_>| {
        let n = rect.pixel_count();
        let mut counts = Vec::with_capacity(n);
        let mut layers = Vec::new();
        let mut behind = Vec::with_capacity(n);
        for i in 0..n {
            counts.push(rect.layers(i) as u32);
            behind.push(rect.behind(i));
            for (f, t) in rect.fragments(i).zip(rect.transmittances(i)) {
                layers.push(Layer {
                    premultiplied: f.premultiplied,
                    alpha: f.alpha,
                    transmittance: t.map(|c| c as f32),
                    depth: f.depth,
                    draw: f.draw as u32,
                    triangle: f.triangle,
                });
            }
        }
        // Kept only while the lists fit the budget (counted as they arrive, so an
        // oversized scene stops holding them long before the render ends).
        let bytes = layers.len() as u64 * LAYER_BYTES + n as u64 * PIXEL_BYTES;
        if held.fetch_add(bytes, Ordering::Relaxed) + bytes > lists_budget {
            return;
        }
        if let Ok(mut all) = collected.lock() {
            all.push(Rect {
                x0: rect.x0,
                y0: rect.y0,
                width: rect.width,
                counts,
                layers,
                behind,
            });
        }
    };
    let reference = render_visiting(scene, &render_options, &visit)?;
    let need = held.into_inner();
    if need > lists_budget {
        return Err(ReferenceError::ListsOverBudget {
            need,
            budget: lists_budget,
        });
    }
    let rects = collected.into_inner().unwrap_or_else(|e| e.into_inner());
    // Scatter the rectangles into frame order: counts first, then the layers.
    let width = res.width as usize;
    let mut counts = vec![0u32; pixels];
    let mut behind = vec![[0.0f64; 3]; pixels];
    for r in &rects {
        for (i, (&n, &bh)) in r.counts.iter().zip(&r.behind).enumerate() {
            let (x, y) = r.at(i);
            counts[y * width + x] = n;
            behind[y * width + x] = bh;
        }
    }
    let mut offsets = Vec::with_capacity(pixels + 1);
    let mut sum = 0u32;
    offsets.push(0);
    for &n in &counts {
        sum += n;
        offsets.push(sum);
    }
    let placeholder = Layer {
        premultiplied: [0.0; 3],
        alpha: 0.0,
        transmittance: [1.0; 3],
        depth: 0.0,
        draw: 0,
        triangle: 0,
    };
    let mut layers = vec![placeholder; sum as usize];
    for r in &rects {
        let mut next = 0usize;
        for (i, &n) in r.counts.iter().enumerate() {
            let (x, y) = r.at(i);
            let at = offsets[y * width + x] as usize;
            layers[at..at + n as usize].copy_from_slice(&r.layers[next..next + n as usize]);
            next += n as usize;
        }
    }
    let rounding = reference
        .undecided
        .iter()
        .zip(&reference.precision_ties)
        .map(|(&u, &t)| u > 0 || t)
        .collect();
    let lists = PixelLists {
        width: res.width,
        height: res.height,
        offsets,
        layers,
        behind,
        rounding,
    };
    Ok((reference, lists))
}

impl PixelLists {
    pub fn pixel_count(&self) -> usize {
        self.behind.len()
    }

    /// Host bytes the lists hold (their arrays' lengths, not spare capacity): what a
    /// comparison keeps beside its runs while it predicts them.
    pub fn heap_bytes(&self) -> u64 {
        (self.offsets.len() * std::mem::size_of::<u32>()
            + self.layers.len() * std::mem::size_of::<Layer>()
            + self.behind.len() * std::mem::size_of::<[f64; 3]>()
            + self.rounding.len()) as u64
    }

    /// Pixel `p` (row-major from the top-left).
    pub fn pixel(&self, p: usize) -> Pixel<'_> {
        Pixel {
            layers: &self.layers[self.offsets[p] as usize..self.offsets[p + 1] as usize],
            behind: self.behind[p],
        }
    }

    /// Whether rounding may decide pixel `p` on a GPU (undecided cutoff, precision tie).
    pub fn rounding_decides(&self, p: usize) -> bool {
        self.rounding[p]
    }

    /// Transparent fragments in all the lists.
    pub fn fragment_count(&self) -> u64 {
        self.layers.len() as u64
    }

    /// Most layers of any pixel.
    pub fn max_layers(&self) -> u32 {
        self.offsets
            .windows(2)
            .map(|w| w[1] - w[0])
            .max()
            .unwrap_or(0)
    }

    /// Pixels some of whose neighbouring layers have the same f32 window depth.
    pub fn equal_depth_pixels(&self) -> u64 {
        (0..self.pixel_count())
            .into_par_iter()
            .filter(|&p| {
                self.pixel(p)
                    .layers
                    .windows(2)
                    .any(|w| w[0].depth == w[1].depth)
            })
            .count() as u64
    }

    /// Runs `model` on every pixel and measures it against the exact composite
    /// ([`composite`] of the layers in their order): the difference of a model that composites
    /// the same layers in the same order is 0, bit for bit.
    /// `model` returns the pixel's colour and whether rounding decides it (the model is
    /// ill-conditioned there): such pixels count as [`ModelError::rounding_pixels_over`].
    pub fn model_error(
        &self,
        threshold: f64,
        model: impl Fn(Pixel<'_>) -> ([f64; 3], bool) + Sync,
    ) -> ModelError {
        (0..self.pixel_count())
            .into_par_iter()
            .map(|p| {
                let px = self.pixel(p);
                let exact = composite(px.layers.iter(), px.behind);
                let (got, sensitive) = model(px);
                let d = (0..3)
                    .map(|c| (got[c] - exact[c]).abs() / exact[c].abs().max(1.0))
                    .fold(0.0, f64::max);
                let d = if d.is_nan() { f64::INFINITY } else { d };
                let w = self.width as usize;
                let at = ((p % w) as u32, (p / w) as u32);
                if self.rounding[p] || sensitive {
                    ModelError {
                        rounding_pixels_over: u64::from(d > threshold),
                        ..ModelError::default()
                    }
                } else {
                    ModelError {
                        max_relative: d,
                        pixels_over: u64::from(d > threshold),
                        rounding_pixels_over: 0,
                        worst: (d > 0.0).then_some(at),
                    }
                }
            })
            .reduce(ModelError::default, |a, b| {
                let (max_relative, worst) = if b.max_relative > a.max_relative {
                    (b.max_relative, b.worst)
                } else {
                    (a.max_relative, a.worst)
                };
                ModelError {
                    max_relative,
                    pixels_over: a.pixels_over + b.pixels_over,
                    rounding_pixels_over: a.rounding_pixels_over + b.rounding_pixels_over,
                    worst,
                }
            })
    }
}

/// Composites `layers`, front to back, over `behind`, per channel in f64: the reference's
/// formula (`crate::composite`), for a model to call with the layers in its own order.
pub fn composite<'a>(layers: impl Iterator<Item = &'a Layer>, behind: [f64; 3]) -> [f64; 3] {
    let mut color = [0.0f64; 3];
    let mut t = [1.0f64; 3];
    for l in layers {
        for c in 0..3 {
            color[c] += t[c] * f64::from(l.premultiplied[c]);
            t[c] *= f64::from(l.transmittance[c]);
        }
    }
    [0, 1, 2].map(|c| color[c] + t[c] * behind[c])
}

/// Composites `layers` back to front (the last one nearest), as OVER blending does in the
/// order draws arrive: `dst = C + t ⊙ dst`, starting from `behind`.
pub fn composite_back_to_front<'a>(
    layers: impl Iterator<Item = &'a Layer>,
    behind: [f64; 3],
) -> [f64; 3] {
    let mut dst = behind;
    for l in layers {
        dst = [0, 1, 2]
            .map(|c| f64::from(l.premultiplied[c]) + f64::from(l.transmittance[c]) * dst[c]);
    }
    dst
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kept lists are the reference's: their exact composite is its image (to f32), their
    /// fragments its composited count; a budget too small for them is refused, not clamped.
    #[test]
    fn lists_composite_to_the_reference_and_respect_their_budget() {
        let mut refused = 0;
        for seed in 0..6 {
            let (text, _) = oit_scene::random::random_scene_json(seed);
            let scene = oit_scene::parse(&text, "random").expect("random scene");
            let (reference, lists) =
                render_lists(&scene, &ReferenceOptions::default()).expect("lists fit");
            assert_eq!(lists.fragment_count(), reference.stats.composited_fragments);
            for p in 0..lists.pixel_count() {
                let px = lists.pixel(p);
                let rgb = composite(px.layers.iter(), px.behind);
                let want = reference.image.pixels[p];
                for c in 0..3 {
                    let tol = 1e-5 * f64::from(want[c].abs()).max(1.0);
                    assert!(
                        (rgb[c] - f64::from(want[c])).abs() <= tol,
                        "seed {seed} pixel {p}: {rgb:?} against {want:?}"
                    );
                }
            }
            // A budget whose quarter is one byte short of what these lists hold.
            let need =
                lists.fragment_count() * LAYER_BYTES + lists.pixel_count() as u64 * PIXEL_BYTES;
            // What a comparison counts as held is what the check priced (one more offset).
            assert_eq!(lists.heap_bytes(), need + 4, "seed {seed}");
            let short = ReferenceOptions {
                memory_budget: 4 * need - 4,
                ..Default::default()
            };
            match render_lists(&scene, &short).map(|_| ()) {
                Err(ReferenceError::ListsOverBudget { need: n, budget }) => {
                    assert_eq!((n, budget), (need, need - 1), "seed {seed}");
                    refused += 1;
                }
                // The render's own minimum can refuse first, as clearly.
                Err(ReferenceError::MemoryBudget { .. }) => {}
                other => panic!("seed {seed}: {other:?}"),
            }
        }
        assert!(refused > 0, "no seed reached the lists' own refusal");
    }
}
