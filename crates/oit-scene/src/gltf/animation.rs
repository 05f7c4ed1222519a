//! glTF node animations (glTF 2.0, 3.11 "Animations"): animation 0 of an asset loaded
//! directly, sampled at [`GLTF_FPS`] frames per second. docs/scene-format.md ("glTF
//! animations") is the contract.
//!
//! Channels targeting a node's `translation`, `rotation` or `scale` are played; `weights`
//! (morph targets) and every other animation are listed in `Scene::ignored`. Every sampler of
//! animation 0 is read and validated once, at load ([`Asset::clip`]); a frame only evaluates
//! the channels ([`Clip::pose`]) and the node matrices they change.

use glam::{Mat4, Quat, Vec3};
use gltf::json::animation::{Interpolation, Property};
use gltf::json::validation::Checked;

use super::{Asset, Result, accessor};
use crate::animation::MAX_FRAMES;
use crate::error::Problem;

/// Frame rate at which a glTF animation is sampled: frame `i` shows the asset at
/// `i / GLTF_FPS` seconds. 30 fps resolves motion over a second into 30 steps, and keeps a
/// 2-second clip at 61 frames.
pub const GLTF_FPS: f32 = 30.0;

/// The node property a channel animates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Target {
    Translation,
    Rotation,
    Scale,
}

impl Target {
    fn name(self) -> &'static str {
        match self {
            Target::Translation => "translation",
            Target::Rotation => "rotation",
            Target::Scale => "scale",
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Interp {
    Step,
    Linear,
    Cubic,
}

/// One validated channel: key times strictly increasing, finite and >= 0; one value per key
/// (three for CUBICSPLINE: in-tangent, value, out-tangent), finite; rotation values unit
/// quaternions.
#[derive(Debug)]
struct Channel {
    node: usize,
    target: Target,
    interp: Interp,
    times: Vec<f64>,
    values: Vec<[f64; 4]>,
}

impl Channel {
    /// The value of key `k` (the middle element of its triple for CUBICSPLINE).
    fn key(&self, k: usize) -> [f64; 4] {
        let i = if self.interp == Interp::Cubic {
            3 * k + 1
        } else {
            k
        };
        self.values.get(i).copied().unwrap_or([0.0; 4])
    }

    /// The channel's value at `tc` seconds: the first key's value before it, the last key's
    /// after it, else interpolated between the keys `k`, `k + 1` around `tc` with
    /// `s = (tc − t_k) / (t_{k+1} − t_k)`, in f64 from the f32 keys:
    /// STEP holds key `k`; LINEAR is `a + (b − a)·s` (slerp along the shorter arc for a
    /// rotation); CUBICSPLINE is the cubic Hermite spline through the two values with
    /// out-tangent `b_k` and in-tangent `a_{k+1}` scaled by the interval `t_{k+1} − t_k`
    /// (a rotation renormalised).
    fn sample(&self, tc: f64) -> [f64; 4] {
        let n = self.times.len();
        let (Some(&first), Some(&last)) = (self.times.first(), self.times.last()) else {
            return [0.0; 4];
        };
        if tc <= first {
            return self.key(0);
        }
        if tc >= last {
            return self.key(n - 1);
        }
        // first < tc < last: 1 <= next <= n − 1.
        let next = self.times.partition_point(|&t| t <= tc);
        let k = next - 1;
        let (t0, t1) = (self.times[k], self.times[next]);
        let td = t1 - t0;
        let s = (tc - t0) / td;
        let (a, b) = (self.key(k), self.key(next));
        match self.interp {
            Interp::Step => a,
            Interp::Linear if self.target == Target::Rotation => slerp(a, b, s),
            Interp::Linear => std::array::from_fn(|c| a[c] + (b[c] - a[c]) * s),
            Interp::Cubic => {
                let out_tangent = self.values[3 * k + 2];
                let in_tangent = self.values[3 * next];
                let (s2, s3) = (s * s, s * s * s);
                let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
                let h10 = s3 - 2.0 * s2 + s;
                let h01 = -2.0 * s3 + 3.0 * s2;
                let h11 = s3 - s2;
                let v: [f64; 4] = std::array::from_fn(|c| {
                    h00 * a[c] + h10 * td * out_tangent[c] + h01 * b[c] + h11 * td * in_tangent[c]
                });
                if self.target == Target::Rotation {
                    normalised(v).unwrap_or(a)
                } else {
                    v
                }
            }
        }
    }
}

/// `v / |v|`, `None` for a zero or non-finite length.
fn normalised(v: [f64; 4]) -> Option<[f64; 4]> {
    let len = v.iter().map(|c| c * c).sum::<f64>().sqrt();
    (len.is_finite() && len > 1e-12).then(|| v.map(|c| c / len))
}

/// Spherical interpolation between unit quaternions `a` and `b` along the shorter arc (`b`
/// negated when `a · b < 0`); nearly equal quaternions are interpolated linearly and
/// renormalised, where the sines vanish.
fn slerp(a: [f64; 4], b: [f64; 4], s: f64) -> [f64; 4] {
    let dot: f64 = (0..4).map(|c| a[c] * b[c]).sum();
    let sign = if dot < 0.0 { -1.0 } else { 1.0 };
    let d = dot.abs().min(1.0);
    let (wa, wb) = if d > 1.0 - 1e-12 {
        (1.0 - s, s)
    } else {
        let angle = d.acos();
        let sin = angle.sin();
        (((1.0 - s) * angle).sin() / sin, (s * angle).sin() / sin)
    };
    let v = std::array::from_fn(|c| wa * a[c] + sign * wb * b[c]);
    normalised(v).unwrap_or(a)
}

/// A node's rest transform, as translation, rotation, scale.
#[derive(Debug, Clone, Copy)]
struct Trs {
    t: Vec3,
    r: Quat,
    s: Vec3,
}

/// Animation 0 of an asset, validated: its channels, the rest TRS of every node they animate,
/// and the frame count.
#[derive(Debug)]
pub(crate) struct Clip {
    channels: Vec<Channel>,
    /// Per node index: the node's own TRS when a channel animates it.
    rest: Vec<Option<Trs>>,
    /// `round(last key time × GLTF_FPS) + 1`, at most [`MAX_FRAMES`].
    pub frames: u32,
}

/// The local matrices of the animated nodes at one frame (`None`: the node's own).
#[derive(Debug)]
pub(crate) struct Pose(Vec<Option<Mat4>>);

impl Pose {
    /// Node `i`'s animated local matrix, `None` when no channel animates it.
    pub(crate) fn local(&self, i: usize) -> Option<Mat4> {
        self.0.get(i).copied().flatten()
    }
}

impl Clip {
    /// The node matrices of frame `frame`, at `frame / GLTF_FPS` seconds: each animated node's
    /// rest TRS with its animated properties replaced, as `T · R · S`.
    pub(crate) fn pose(&self, frame: u32) -> Pose {
        let tc = f64::from(frame) / f64::from(GLTF_FPS);
        let mut trs = self.rest.clone();
        for ch in &self.channels {
            let Some(Some(x)) = trs.get_mut(ch.node) else {
                continue;
            };
            let v = ch.sample(tc).map(|c| c as f32);
            match ch.target {
                Target::Translation => x.t = Vec3::new(v[0], v[1], v[2]),
                Target::Rotation => x.r = Quat::from_array(v),
                Target::Scale => x.s = Vec3::new(v[0], v[1], v[2]),
            }
        }
        Pose(
            trs.into_iter()
                .map(|o| o.map(|x| Mat4::from_scale_rotation_translation(x.s, x.r, x.t)))
                .collect(),
        )
    }
}

/// `n` followed by `word`, plural unless `n` is 1.
fn count(n: usize, word: &str) -> String {
    if n == 1 {
        format!("1 {word}")
    } else {
        format!("{n} {word}s")
    }
}

impl Asset {
    /// The line `Scene::ignored` gets for an asset placed as an object of a JSON scene, whose
    /// animations are not played; `None` when it has none.
    pub(crate) fn unplayed_animations(&self) -> Option<String> {
        let n = self.doc.as_json().animations.len();
        (n > 0).then(|| {
            format!(
                "{}: {}: not played for a glTF object inside a JSON scene",
                self.name,
                count(n, "animation")
            )
        })
    }

    /// Reads and validates animation 0, for an asset loaded directly: the clip (`None` when the
    /// asset has no animation or animation 0 no channel that is played) and the lines for
    /// `Scene::ignored` (the other animations, `weights` channels).
    pub(crate) fn clip(&self) -> Result<(Option<Clip>, Vec<String>)> {
        let json = self.doc.as_json();
        let mut ignored = Vec::new();
        let Some(anim) = json.animations.first() else {
            return Ok((None, ignored));
        };
        let more = json.animations.len() - 1;
        if more > 0 {
            ignored.push(format!(
                "{}: {} after /animations/0: not played (only animation 0 is)",
                self.name,
                count(more, "more animation")
            ));
        }
        let mut channels: Vec<Channel> = Vec::new();
        let mut rest: Vec<Option<Trs>> = vec![None; json.nodes.len()];
        let mut weights = 0usize;
        // (node, target, channel) of every played channel so far.
        let mut seen: Vec<(usize, Target, usize)> = Vec::new();
        // (last key time, sampler) of the longest sampler.
        let mut longest: Option<(f64, usize)> = None;
        for (c, ch) in anim.channels.iter().enumerate() {
            let cp = format!("/animations/0/channels/{c}");
            let node = ch.target.node.value();
            let Some(n) = json.nodes.get(node) else {
                return Err(self.cx.err(
                    format!("{cp}/target/node"),
                    Problem::NoSuchItem {
                        index: node,
                        count: json.nodes.len(),
                    },
                ));
            };
            let target = match ch.target.path {
                Checked::Valid(Property::Translation) => Target::Translation,
                Checked::Valid(Property::Rotation) => Target::Rotation,
                Checked::Valid(Property::Scale) => Target::Scale,
                Checked::Valid(Property::MorphTargetWeights) => {
                    weights += 1;
                    continue;
                }
                Checked::Invalid => {
                    return Err(self.cx.bad(
                        format!("{cp}/target/path"),
                        "target path",
                        "(not a glTF 2.0 path)",
                        "\"translation\", \"rotation\", \"scale\" or \"weights\"",
                    ));
                }
            };
            if n.matrix.is_some() {
                return Err(self.cx.bad(
                    format!("{cp}/target/node"),
                    "animated node",
                    format!("/nodes/{node} has a `matrix`"),
                    "animated nodes with translation/rotation/scale only (glTF 2.0: a node targeted by an animation MUST NOT have a matrix)",
                ));
            }
            if let Some(&(_, _, earlier)) = seen.iter().find(|o| o.0 == node && o.1 == target) {
                return Err(self.cx.bad(
                    format!("{cp}/target"),
                    "target",
                    format!(
                        "/nodes/{node} {}, already animated by /animations/0/channels/{earlier}",
                        target.name()
                    ),
                    "each node and path targeted by at most one channel of an animation (glTF 2.0)",
                ));
            }
            seen.push((node, target, c));
            let s = ch.sampler.value();
            let channel = self.channel(s, node, target)?;
            if let Some(&last) = channel.times.last()
                && longest.is_none_or(|(l, _)| last > l)
            {
                longest = Some((last, s));
            }
            if let Some(slot) = rest.get_mut(node) {
                *slot = Some(Trs {
                    t: Vec3::from(n.translation.unwrap_or([0.0; 3])),
                    r: Quat::from_array(n.rotation.map_or([0.0, 0.0, 0.0, 1.0], |q| q.0)),
                    s: Vec3::from(n.scale.unwrap_or([1.0; 3])),
                });
            }
            channels.push(channel);
        }
        if weights > 0 {
            ignored.push(format!(
                "{}: {} of /animations/0 targeting `weights`: not played (morph targets are not modelled)",
                self.name,
                count(weights, "channel")
            ));
        }
        let Some((last, s)) = longest else {
            return Ok((None, ignored));
        };
        let frames = (last * f64::from(GLTF_FPS)).round() + 1.0;
        if frames > f64::from(MAX_FRAMES) {
            return Err(self.cx.bad(
                format!("/animations/0/samplers/{s}/input"),
                "last key time",
                format!("{last} s, {frames} frames at {GLTF_FPS} fps"),
                &format!(
                    "animations of at most {MAX_FRAMES} frames (last key <= {} s)",
                    f64::from(MAX_FRAMES - 1) / f64::from(GLTF_FPS)
                ),
            ));
        }
        let clip = Clip {
            channels,
            rest,
            frames: frames as u32,
        };
        Ok((Some(clip), ignored))
    }

    /// Reads and validates sampler `s` of animation 0 for a channel animating `target` of
    /// `node`.
    fn channel(&self, s: usize, node: usize, target: Target) -> Result<Channel> {
        let json = self.doc.as_json();
        let sp = format!("/animations/0/samplers/{s}");
        let sampler = json.animations.first().and_then(|a| a.samplers.get(s));
        let Some(sampler) = sampler else {
            return Err(self.cx.err(
                "/animations/0/samplers",
                Problem::NoSuchItem {
                    index: s,
                    count: json.animations.first().map_or(0, |a| a.samplers.len()),
                },
            ));
        };
        let interp = match sampler.interpolation {
            Checked::Valid(Interpolation::Step) => Interp::Step,
            Checked::Valid(Interpolation::Linear) => Interp::Linear,
            Checked::Valid(Interpolation::CubicSpline) => Interp::Cubic,
            Checked::Invalid => {
                return Err(self.cx.bad(
                    format!("{sp}/interpolation"),
                    "interpolation",
                    "(not a glTF 2.0 interpolation)",
                    "\"LINEAR\", \"STEP\" or \"CUBICSPLINE\"",
                ));
            }
        };
        let accessor = |i: usize, what: &str| {
            self.doc.accessors().nth(i).ok_or_else(|| {
                self.cx.err(
                    format!("{sp}/{what}"),
                    Problem::NoSuchItem {
                        index: i,
                        count: self.doc.accessors().len(),
                    },
                )
            })
        };
        let input = accessor(sampler.input.value(), "input")?;
        let output = accessor(sampler.output.value(), "output")?;
        let ip = format!("{sp}/input");
        let op = format!("{sp}/output");
        let times: Vec<f64> =
            accessor::read(&self.cx, &self.buffers, &input, &accessor::TIMES, &ip)?
                .into_iter()
                .map(|v| v[0])
                .collect();
        let min_keys = if interp == Interp::Cubic { 2 } else { 1 };
        if times.len() < min_keys {
            return Err(self.cx.bad(
                &ip,
                "key count",
                format!("{} (accessor {})", times.len(), input.index()),
                "at least 1 key (2 for CUBICSPLINE)",
            ));
        }
        let allowed_times = "finite key times >= 0 s, strictly increasing";
        for (k, &t) in times.iter().enumerate() {
            if !t.is_finite() || t < 0.0 {
                return Err(self.cx.bad(
                    &ip,
                    "key time",
                    format!("{t} (key {k} of accessor {})", input.index()),
                    allowed_times,
                ));
            }
            if k > 0 && t <= times[k - 1] {
                return Err(self.cx.bad(
                    &ip,
                    "key time",
                    format!(
                        "{t} s after {} s (keys {} and {k} of accessor {})",
                        times[k - 1],
                        k - 1,
                        input.index()
                    ),
                    allowed_times,
                ));
            }
        }
        let spec = match target {
            Target::Rotation => &accessor::ROTATION,
            Target::Translation | Target::Scale => &accessor::TRANSLATION_SCALE,
        };
        let mut values = accessor::read(&self.cx, &self.buffers, &output, spec, &op)?;
        let per_key = if interp == Interp::Cubic { 3 } else { 1 };
        let expected = times.len() * per_key;
        if values.len() != expected {
            let why = if interp == Interp::Cubic {
                "3 per key of the input (in-tangent, value, out-tangent) for CUBICSPLINE"
            } else {
                "one per key of the input"
            };
            return Err(self.cx.err(
                &op,
                Problem::AccessorFormat {
                    found: format!(
                        "accessor {} has {} elements for {} keys",
                        output.index(),
                        values.len(),
                        times.len()
                    ),
                    expected: format!("{expected} elements: {why}"),
                },
            ));
        }
        for (j, v) in values.iter_mut().enumerate() {
            if v.iter().any(|c| !c.is_finite()) {
                return Err(self.cx.bad(
                    &op,
                    &format!("element {j} of accessor {} is", output.index()),
                    format!("{v:?}"),
                    "finite values",
                ));
            }
            let is_value = per_key == 1 || j % 3 == 1;
            if target == Target::Rotation && is_value {
                let Some(unit) = normalised(*v) else {
                    return Err(self.cx.bad(
                        &op,
                        &format!("rotation {j} of accessor {} is", output.index()),
                        format!("{v:?}"),
                        "unit quaternions (x, y, z, w); other non-zero lengths are normalised",
                    ));
                };
                *v = unit;
            }
        }
        Ok(Channel {
            node,
            target,
            interp,
            times,
            values,
        })
    }
}
