//! The configuration (`default`, `force`), the method each object is drawn with, and pygfx's
//! draw order (`FlatScene` in pygfx/renderers/wgpu/engine/renderer.py).

use oit_gpu::{Param, ParamInfo, SpecError, TechniqueSpec};
use oit_scene::{BlendOperator, Draw, ObjectMethod, RenderQueue, Scene};

oit_gpu::words! {
    /// The method of objects whose scene entry names none.
    pub enum DefaultMethod {
        Opaque = "opaque",
        Stochastic = "stochastic",
        Blended = "blended",
        Weighted = "weighted",
    }
}

oit_gpu::words! {
    /// A method that overrides every object's own (`none` keeps them).
    pub enum ForcedMethod {
        None = "none",
        Opaque = "opaque",
        Stochastic = "stochastic",
        Blended = "blended",
        Weighted = "weighted",
    }
}

impl DefaultMethod {
    pub fn method(self) -> ObjectMethod {
        match self {
            DefaultMethod::Opaque => ObjectMethod::Opaque,
            DefaultMethod::Stochastic => ObjectMethod::Stochastic,
            DefaultMethod::Blended => ObjectMethod::Blended,
            DefaultMethod::Weighted => ObjectMethod::Weighted,
        }
    }
}

impl ForcedMethod {
    pub fn method(self) -> Option<ObjectMethod> {
        match self {
            ForcedMethod::None => None,
            ForcedMethod::Opaque => Some(ObjectMethod::Opaque),
            ForcedMethod::Stochastic => Some(ObjectMethod::Stochastic),
            ForcedMethod::Blended => Some(ObjectMethod::Blended),
            ForcedMethod::Weighted => Some(ObjectMethod::Weighted),
        }
    }
}

/// A `per-object` configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Config {
    pub default: DefaultMethod,
    pub force: ForcedMethod,
}

impl Config {
    pub const DEFAULT_METHOD: Param<DefaultMethod> = Param::new(
        "default",
        DefaultMethod::Blended,
        "the method of objects whose scene entry has no `method`",
    );
    pub const FORCE: Param<ForcedMethod> = Param::new(
        "force",
        ForcedMethod::None,
        "one method for every object, overriding the scene's (none keeps each object's own)",
    );

    pub fn params() -> Vec<ParamInfo> {
        vec![Self::DEFAULT_METHOD.info(), Self::FORCE.info()]
    }

    pub fn spec(&self) -> TechniqueSpec {
        TechniqueSpec::of(crate::PerObject::NAME)
            .with(&Self::DEFAULT_METHOD, self.default)
            .with(&Self::FORCE, self.force)
    }

    pub fn from_spec(spec: &TechniqueSpec) -> Result<Config, SpecError> {
        spec.expect_name(crate::PerObject::NAME)?;
        let known = [Self::DEFAULT_METHOD.key, Self::FORCE.key];
        if let Some(key) = spec.params().keys().find(|k| !known.contains(&k.as_str())) {
            return Err(SpecError::UnknownKey {
                spec: spec.to_string(),
                name: spec.name().to_owned(),
                key: key.clone(),
                keys: known.join(", "),
            });
        }
        Ok(Config {
            default: Self::DEFAULT_METHOD.read(spec)?,
            force: Self::FORCE.read(spec)?,
        })
    }
}

/// The method `draw` is drawn with: the forced one, else its own, else the default. An object
/// whose material blends with `add`, `subtract` or `multiply` is always drawn `blended`: in
/// pygfx those operators are alpha modes of the blended method (`alpha_mode="add"`), so an
/// object cannot be both `add` and `solid`, `dither` or `weighted_blend`.
pub fn effective_method(config: Config, scene: &Scene, draw: &Draw) -> ObjectMethod {
    let method = config
        .force
        .method()
        .or(draw.ordering.method)
        .unwrap_or(config.default.method());
    if scene.material_of(draw).operator == BlendOperator::Over {
        method
    } else {
        ObjectMethod::Blended
    }
}

/// (render group, render queue, render order): the draw-order key before distance.
type QueueKey = (u32, RenderQueue, i32);

/// The transparent draws in pygfx's draw order, each with its effective method: the key of
/// [`Scene::engine_order`] (render group, queue, render order, distance to the bounding-sphere
/// centre; near first in queues 1501–2500, far first elsewhere), with the queue derived from
/// the effective method where the scene gives none, and distance 0 for weighted objects (pygfx
/// does not sort them). Stable: ties keep draw order.
pub fn draw_order(config: Config, scene: &Scene) -> Vec<(usize, ObjectMethod)> {
    let eye = scene.camera.eye;
    let mut keyed: Vec<(usize, ObjectMethod, QueueKey, f32)> = scene
        .draws
        .iter()
        .enumerate()
        .filter(|(_, d)| scene.material_of(d).mode.is_transparent())
        .map(|(i, d)| {
            let method = effective_method(config, scene, d);
            let m = scene.material_of(d);
            let queue = d
                .ordering
                .queue
                .unwrap_or_else(|| RenderQueue::derived(m.mode, m.depth_write, Some(method)));
            let distance = if method == ObjectMethod::Weighted {
                0.0
            } else if queue.front_to_back() {
                d.bounds_center.distance(eye)
            } else {
                -d.bounds_center.distance(eye)
            };
            (
                i,
                method,
                (d.ordering.group, queue, d.ordering.order),
                distance,
            )
        })
        .collect();
    keyed.sort_by(|a, b| a.2.cmp(&b.2).then(a.3.total_cmp(&b.3)));
    keyed.into_iter().map(|(i, m, ..)| (i, m)).collect()
}

/// Consecutive draws of one method: one render pass each (pygfx
/// `iter_render_pipelines_per_pass_type`).
pub(crate) fn runs(order: &[(usize, ObjectMethod)]) -> Vec<(ObjectMethod, Vec<usize>)> {
    let mut runs: Vec<(ObjectMethod, Vec<usize>)> = Vec::new();
    for &(draw, method) in order {
        match runs.last_mut() {
            Some((m, draws)) if *m == method => draws.push(draw),
            _ => runs.push((method, vec![draw])),
        }
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random(seed: u64) -> Scene {
        let (json, _) = oit_scene::random::random_scene_json(seed);
        oit_scene::parse(&json, "random").unwrap()
    }

    fn config(default: DefaultMethod, force: ForcedMethod) -> Config {
        Config { default, force }
    }

    #[test]
    fn with_blended_objects_the_order_is_the_scenes_engine_order() {
        for seed in 0..8 {
            let scene = random(seed);
            let order: Vec<usize> = draw_order(
                config(DefaultMethod::Blended, ForcedMethod::Blended),
                &scene,
            )
            .into_iter()
            .map(|(i, _)| i)
            .collect();
            let expected = scene.engine_order(|d| scene.material_of(d).mode.is_transparent());
            assert_eq!(order, expected, "seed {seed}");
        }
    }

    #[test]
    fn force_overrides_the_scene_and_default_fills_in() {
        let mut scene = random(3);
        let transparent: Vec<usize> = (0..scene.draws.len())
            .filter(|&i| scene.material_of(&scene.draws[i]).mode.is_transparent())
            .collect();
        assert!(
            transparent.len() >= 2,
            "the random scene has transparent draws"
        );
        for m in &mut scene.materials {
            m.operator = BlendOperator::Over;
        }
        scene.draws[transparent[0]].ordering.method = Some(ObjectMethod::Stochastic);
        scene.draws[transparent[1]].ordering.method = None;
        let c = config(DefaultMethod::Weighted, ForcedMethod::None);
        let d0 = &scene.draws[transparent[0]];
        let d1 = &scene.draws[transparent[1]];
        assert_eq!(effective_method(c, &scene, d0), ObjectMethod::Stochastic);
        assert_eq!(effective_method(c, &scene, d1), ObjectMethod::Weighted);
        let forced = config(DefaultMethod::Weighted, ForcedMethod::Opaque);
        assert_eq!(effective_method(forced, &scene, d0), ObjectMethod::Opaque);
        // Stochastic objects (queue 2400) come before blended and weighted ones (3000).
        let order = draw_order(c, &scene);
        let first = order.iter().position(|&(i, _)| i == transparent[0]);
        assert_eq!(first, Some(0), "{order:?}");
    }

    #[test]
    fn non_over_operators_are_always_drawn_blended() {
        let mut scene = random(5);
        let i = (0..scene.draws.len())
            .find(|&i| scene.material_of(&scene.draws[i]).mode.is_transparent())
            .expect("a transparent draw");
        let material = scene.draws[i].material as usize;
        for op in BlendOperator::ALL {
            scene.materials[material].operator = op;
            for force in ForcedMethod::ALL
                .iter()
                .copied()
                .filter(|f| f.method().is_some())
            {
                let got = effective_method(
                    config(DefaultMethod::Blended, force),
                    &scene,
                    &scene.draws[i],
                );
                let want = match (op, force.method()) {
                    (BlendOperator::Over, Some(m)) => m,
                    _ => ObjectMethod::Blended,
                };
                assert_eq!(got, want, "{op:?} forced {force:?}");
            }
        }
    }

    #[test]
    fn runs_group_consecutive_methods() {
        use ObjectMethod::*;
        let order = [
            (4, Opaque),
            (2, Opaque),
            (0, Blended),
            (1, Weighted),
            (3, Blended),
        ];
        assert_eq!(
            runs(&order),
            vec![
                (Opaque, vec![4, 2]),
                (Blended, vec![0]),
                (Weighted, vec![1]),
                (Blended, vec![3]),
            ]
        );
        assert!(runs(&[]).is_empty());
    }

    #[test]
    fn specs_round_trip_and_refuse_unknown_keys() {
        let c = config(DefaultMethod::Stochastic, ForcedMethod::Weighted);
        assert_eq!(Config::from_spec(&c.spec()).unwrap(), c);
        assert_eq!(
            c.spec().to_string(),
            "per-object:default=stochastic,force=weighted"
        );
        const LAYERS: Param<DefaultMethod> = Param::new("layers", DefaultMethod::Opaque, "none");
        let bad = c.spec().with(&LAYERS, DefaultMethod::Opaque);
        let e = Config::from_spec(&bad).unwrap_err();
        assert!(matches!(e, SpecError::UnknownKey { .. }), "{e}");
        let e = Config::from_spec(&TechniqueSpec::of("wboit")).unwrap_err();
        assert!(matches!(e, SpecError::WrongTechnique { .. }), "{e}");
    }
}
