//! Validation of the blending and ordering fields of a JSON object and its material
//! (`crate::blending`): what the loader accepts, with errors that name the field.

use crate::error::Problem;
use crate::error::SceneError;
use crate::format::{RawMaterial, RawObject};
use crate::load::Ctx;

type Result<T> = std::result::Result<T, SceneError>;

impl Ctx<'_> {
    /// The operator and depth write of a material: both only where they mean something, a
    /// transparent mode, and the operator only with scalar alpha (transmission 0).
    pub(crate) fn check_blending(&self, m: &RawMaterial, p: &str) -> Result<()> {
        let bad = |field: &str, value: String, allowed: &str| {
            self.err(
                format!("{p}.{field}"),
                Problem::BadValue {
                    what: field.into(),
                    value,
                    allowed: allowed.into(),
                },
            )
        };
        if m.operator != crate::BlendOperator::Over {
            let name = m.operator.name();
            if !m.mode.is_transparent() {
                return Err(bad(
                    "operator",
                    format!("\"{name}\" with mode {:?}", m.mode),
                    "add, subtract and multiply only with mode \"blend\" or \"mask-blend\" (opaque and mask fragments replace what is behind)",
                ));
            }
            if m.transmission > 0.0 {
                return Err(bad(
                    "operator",
                    format!("\"{name}\" with transmission {}", m.transmission),
                    "add, subtract and multiply only with transmission 0 (a transmissive material composites with over)",
                ));
            }
        }
        if m.depth_write && !m.mode.is_transparent() {
            return Err(bad(
                "depth_write",
                format!("true with mode {:?}", m.mode),
                "depth_write only with mode \"blend\" or \"mask-blend\" (opaque and mask materials always write depth)",
            ));
        }
        Ok(())
    }

    /// An object's place in engines' draw orders (`crate::Ordering`): `render_order` and
    /// Babylon's `alpha_index` name the same key, so at most one may be given.
    pub(crate) fn ordering(&self, obj: &RawObject, p: &str) -> Result<crate::Ordering> {
        let order = match (obj.render_order, obj.alpha_index) {
            (Some(_), Some(_)) => {
                return Err(self.err(
                    format!("{p}.alpha_index"),
                    Problem::BadValue {
                        what: "alpha_index".into(),
                        value: "given with render_order".into(),
                        allowed: "one of render_order (pygfx, Unity) and alpha_index (Babylon): they are the same key".into(),
                    },
                ));
            }
            (Some(o), None) | (None, Some(o)) => o,
            (None, None) => 0,
        };
        let queue = match obj.render_queue {
            None => None,
            Some(q) => Some(crate::RenderQueue::new(q).ok_or_else(|| {
                self.err(
                    format!("{p}.render_queue"),
                    Problem::BadValue {
                        what: "render_queue".into(),
                        value: q.to_string(),
                        allowed: format!(
                            "an integer in {}..={} (pygfx: 1000 background, 2000 opaque, 2400 alpha-tested, 2600 depth-writing transparent, 3000 transparent, 4000 overlay)",
                            crate::RenderQueue::MIN,
                            crate::RenderQueue::MAX
                        ),
                    },
                )
            })?),
        };
        Ok(crate::Ordering {
            group: obj.render_group,
            queue,
            order,
            method: obj.method,
        })
    }
}

impl Ctx<'_> {
    /// Refuses an opaque or mask draw that an engine would draw after a transparent one (a
    /// higher render group, or queue, than the lowest transparent draw's): it would replace the
    /// transparent fragments in front of it, which the exact reference does not model
    /// (`Scene::opaque_after_transparent`).
    pub(crate) fn check_queue_order(&self, scene: &crate::Scene) -> Result<()> {
        let Some((opaque, transparent)) = scene.opaque_after_transparent() else {
            return Ok(());
        };
        let (o, t) = (&scene.draws[opaque], &scene.draws[transparent]);
        let (lo, lt) = (scene.queue_level(o), scene.queue_level(t));
        let object = |name: &str| {
            name.split(['.', ' '])
                .next()
                .unwrap_or_default()
                .to_string()
        };
        let field = if lo.group > lt.group {
            "render_group"
        } else {
            "render_queue"
        };
        Err(self.err(
            format!("{}.{field}", object(&o.name)),
            Problem::BadValue {
                what: field.into(),
                value: format!(
                    "opaque draw {} in render group {}, queue {}, after transparent draw {} in render group {}, queue {}",
                    o.name,
                    lo.group,
                    lo.queue.get(),
                    t.name,
                    lt.group,
                    lt.queue.get()
                ),
                allowed: "opaque and mask objects in a render group and queue at or below every transparent object's (drawn later, they would replace transparent fragments in front of them)".into(),
            },
        ))
    }
}
