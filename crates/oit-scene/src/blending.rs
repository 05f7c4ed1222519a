//! How a fragment combines with what is behind it ([`BlendOperator`]), and the one ordering
//! model that pygfx's, Unity's, Babylon's and three.js's draw orders map to ([`Ordering`],
//! [`RenderQueue`], [`ObjectMethod`]). docs/scene-format.md "Blend operators" and "Render
//! queues" give the semantics with worked examples and the mapping to each engine.

use crate::scene::AlphaMode;

/// The operator a transparent fragment composites with, applied in depth order by the exact
/// reference (front to back: `C += T ⊙ P`, `T ⊙= t`; back to front: `C ← P + t ⊙ C`), in float,
/// never clamped between layers. `P` is the fragment's premultiplied colour (`α·c` for straight
/// alpha) and `t` what it leaves of the colour behind:
///
/// | operator | `P` | `t` | back to front |
/// |---|---|---|---|
/// | `over` | `α·c` | `1 − α` | `C ← α·c + (1 − α)·C` |
/// | `add` | `α·c` | `1` | `C ← C + α·c` |
/// | `subtract` | `−α·c` | `1` | `C ← C − α·c` |
/// | `multiply` | `0` | `(1 − α) + α·c` | `C ← C ⊙ (1 − α + α·c)` |
///
/// Every operator is one `(P, t)` pair, so every technique that composites premultiplied colour
/// and (coloured) transmittance handles all four with the same arithmetic.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum BlendOperator {
    /// Porter–Duff OVER, the default.
    #[default]
    Over,
    /// Adds the fragment's premultiplied colour; what is behind shows through undimmed.
    Add,
    /// Subtracts the fragment's premultiplied colour (a true subtraction: results may go below 0).
    Subtract,
    /// Filters what is behind by `1 − α + α·c` per channel and adds nothing.
    Multiply,
}

impl BlendOperator {
    pub const ALL: [BlendOperator; 4] = [
        BlendOperator::Over,
        BlendOperator::Add,
        BlendOperator::Subtract,
        BlendOperator::Multiply,
    ];

    /// The scene-file spelling.
    pub fn name(self) -> &'static str {
        match self {
            BlendOperator::Over => "over",
            BlendOperator::Add => "add",
            BlendOperator::Subtract => "subtract",
            BlendOperator::Multiply => "multiply",
        }
    }

    /// `add` and `subtract`: `t = 1`, colour added or taken away with nothing behind hidden.
    /// Techniques that estimate coverage keep such fragments out of their sums and add them
    /// after their composite.
    pub fn is_additive(self) -> bool {
        matches!(self, BlendOperator::Add | BlendOperator::Subtract)
    }

    /// The shader's code (`Material.operator` in shaders/common.wgsl).
    pub fn code(self) -> u32 {
        match self {
            BlendOperator::Over => 0,
            BlendOperator::Add => 1,
            BlendOperator::Subtract => 2,
            BlendOperator::Multiply => 3,
        }
    }
}

/// A render queue as pygfx numbers them (1–4999; Unity's queues are the same numbers): the
/// outer draw-order key after the render group. Queues 1501–2500 are drawn front to back, the
/// rest back to front. Only values in range can be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct RenderQueue(u16);

impl RenderQueue {
    pub const BACKGROUND: RenderQueue = RenderQueue(1000);
    pub const OPAQUE: RenderQueue = RenderQueue(2000);
    /// Alpha-tested and stochastic objects (pygfx 2400; Unity's AlphaTest is 2450).
    pub const ALPHA_TEST: RenderQueue = RenderQueue(2400);
    /// Transparent objects that write depth (pygfx's `auto`).
    pub const DEPTH_WRITING: RenderQueue = RenderQueue(2600);
    pub const TRANSPARENT: RenderQueue = RenderQueue(3000);
    pub const OVERLAY: RenderQueue = RenderQueue(4000);
    pub const MIN: u16 = 1;
    pub const MAX: u16 = 4999;

    /// `None` outside 1..=4999.
    pub fn new(value: u16) -> Option<RenderQueue> {
        (Self::MIN..=Self::MAX)
            .contains(&value)
            .then_some(RenderQueue(value))
    }

    pub fn get(self) -> u16 {
        self.0
    }

    /// pygfx draws queues 1501–2500 front to back (opaque work, for early depth rejection) and
    /// every other queue back to front.
    pub fn front_to_back(self) -> bool {
        (1501..=2500).contains(&self.0)
    }

    /// The queue pygfx derives when none is given (`Material._derive_render_queue`): from the
    /// object's method when it has one, otherwise from the material's mode.
    pub fn derived(mode: AlphaMode, depth_write: bool, method: Option<ObjectMethod>) -> Self {
        match method {
            Some(ObjectMethod::Opaque) if mode.uses_cutoff() => Self::ALPHA_TEST,
            Some(ObjectMethod::Opaque) => Self::OPAQUE,
            Some(ObjectMethod::Stochastic) => Self::ALPHA_TEST,
            Some(ObjectMethod::Blended | ObjectMethod::Weighted) if depth_write => {
                Self::DEPTH_WRITING
            }
            Some(ObjectMethod::Blended | ObjectMethod::Weighted) => Self::TRANSPARENT,
            None => match mode {
                AlphaMode::Opaque => Self::OPAQUE,
                AlphaMode::Mask => Self::ALPHA_TEST,
                AlphaMode::Blend | AlphaMode::MaskBlend if depth_write => Self::DEPTH_WRITING,
                AlphaMode::Blend | AlphaMode::MaskBlend => Self::TRANSPARENT,
            },
        }
    }
}

/// A per-object transparency method, as pygfx's `alpha_method`: what a mixed renderer
/// (`per-object`) draws the object with. The exact reference does not read it: the right
/// answer does not depend on how an engine chose to approximate it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ObjectMethod {
    /// Drawn as if α were 1 (pygfx `solid`), writes depth.
    Opaque,
    /// Blue-noise dithered coverage, writes depth (pygfx `dither`).
    Stochastic,
    /// Sorted per object, composited with the material's operator (pygfx `blend`).
    Blended,
    /// Weighted blended OIT, unsorted (pygfx `weighted_blend`).
    Weighted,
}

impl ObjectMethod {
    pub const ALL: [ObjectMethod; 4] = [
        ObjectMethod::Opaque,
        ObjectMethod::Stochastic,
        ObjectMethod::Blended,
        ObjectMethod::Weighted,
    ];

    pub fn name(self) -> &'static str {
        match self {
            ObjectMethod::Opaque => "opaque",
            ObjectMethod::Stochastic => "stochastic",
            ObjectMethod::Blended => "blended",
            ObjectMethod::Weighted => "weighted",
        }
    }

    pub fn parse(name: &str) -> Option<ObjectMethod> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// Where a draw goes in an engine's draw order: the key is (`group`, queue, `order`, distance
/// to the eye, front to back or back to front by queue), ties kept in scene order.
/// pygfx: `render_queue`, `render_order`; Unity: `renderQueue`, `sortingOrder`; Babylon:
/// `renderingGroupId` (group), `alphaIndex` (order), queues derived from the mode; three.js:
/// `renderOrder` (order), opaque before transparent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Ordering {
    /// Babylon's rendering group: every draw of a lower group comes first.
    pub group: u32,
    /// The queue the file gave; `None` derives it ([`RenderQueue::derived`]).
    pub queue: Option<RenderQueue>,
    /// Within a queue, lower first (pygfx `render_order`, Babylon `alphaIndex`).
    pub order: i32,
    /// The object's method for a mixed renderer; `None` leaves it to the renderer's default.
    pub method: Option<ObjectMethod>,
}
