//! Animation: the keyframes of a scene file turned into per-frame values, and [`Frames`], which
//! flattens any frame of an animated scene into an ordinary [`Scene`].
//!
//! The semantics (docs/scene-format.md, "Animation") are deliberately the simplest a person can
//! write by hand: every animated field has its own track, made of the keyframes that hold it;
//! at frame `t` a track is linear between the nearest keys on either side (every component, Euler
//! degrees too), held before its first key and after its last; a field no key holds keeps its
//! static value. Everything else about the scene is validated once; the camera and every keyed
//! transform are validated for every frame at load, so a path through an invalid camera (the
//! eye passing through the target) is refused when the file is read, naming the frame.

use crate::error::{Problem, SceneError};
use crate::format::{RawCamera, RawObject, RawOrbit, RawScene, RawTransform};
use crate::load::{Ctx, PreparedScene};
use crate::scene::Scene;

type Result<T> = std::result::Result<T, SceneError>;

/// Longest accepted animation: 10 000 frames is almost 7 minutes at 24 fps, far above any
/// measured path, and bounds the per-frame validation done at load.
pub const MAX_FRAMES: u32 = 10_000;

/// Frame count and rate of an animated scene.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Animation {
    /// Frames `0..frames`.
    pub frames: u32,
    /// Frames per second: what a player shows them at (the path itself is indexed by frame).
    pub fps: f32,
}

/// The keys of one field: `(frame, value)` with strictly increasing frames.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Track<const N: usize>(pub Vec<(u32, [f32; N])>);

impl<const N: usize> Track<N> {
    /// The value at frame `t`, `None` when no key holds the field. Between two keys
    /// `a + (b − a)·s` with `s = (t − f₀)/(f₁ − f₀)` in f32: exactly `a` and `b` at the keys.
    pub fn at(&self, t: u32) -> Option<[f32; N]> {
        let keys = &self.0;
        let first = keys.first()?;
        let last = keys.last()?;
        if t <= first.0 {
            return Some(first.1);
        }
        if t >= last.0 {
            return Some(last.1);
        }
        let next = keys.partition_point(|k| k.0 <= t);
        let (f0, a) = keys[next - 1];
        let (f1, b) = keys[next];
        let s = (t - f0) as f32 / (f1 - f0) as f32;
        Some(std::array::from_fn(|k| a[k] + (b[k] - a[k]) * s))
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// The camera's tracks (or its orbit).
#[derive(Debug, Clone, Default)]
pub(crate) struct CameraTracks {
    pub eye: Track<3>,
    pub target: Track<3>,
    pub up: Track<3>,
    pub fov_y: Track<1>,
    pub ortho_height: Track<1>,
    pub orbit: Option<RawOrbit>,
}

impl<const N: usize> Default for Track<N> {
    fn default() -> Self {
        Track(Vec::new())
    }
}

/// One object's tracks.
#[derive(Debug, Clone, Default)]
pub(crate) struct ObjectTracks {
    pub translate: Track<3>,
    pub rotate: Track<3>,
    pub scale: Track<3>,
    pub alpha: Track<1>,
}

impl ObjectTracks {
    pub fn is_empty(&self) -> bool {
        self.translate.is_empty()
            && self.rotate.is_empty()
            && self.scale.is_empty()
            && self.alpha.is_empty()
    }

    /// The object's transform at frame `t`: keyed fields replaced, the rest static.
    pub fn transform_at(&self, stat: &RawTransform, t: u32) -> RawTransform {
        RawTransform {
            translate: self.translate.at(t).unwrap_or(stat.translate),
            rotate: self.rotate.at(t).unwrap_or(stat.rotate),
            scale: self.scale.at(t).unwrap_or(stat.scale),
        }
    }
}

/// Every track of an animated scene.
#[derive(Debug, Clone)]
pub(crate) struct Timeline {
    pub animation: Animation,
    pub camera: CameraTracks,
    pub objects: Vec<ObjectTracks>,
}

impl CameraTracks {
    /// The camera of frame `t` of `frames`: keyed fields (or the orbit) replaced, the rest static.
    pub fn camera_at(&self, stat: &RawCamera, t: u32, frames: u32) -> RawCamera {
        let mut c = stat.clone();
        if let Some(o) = &self.orbit {
            let turn = t as f32 / frames as f32;
            let angle = (o.start_degrees + 360.0 * o.turns * turn).to_radians();
            c.eye = [
                o.center[0] + o.radius * angle.sin(),
                o.center[1] + o.height,
                o.center[2] + o.radius * angle.cos(),
            ];
            c.target = o.center;
        }
        if let Some(v) = self.eye.at(t) {
            c.eye = v;
        }
        if let Some(v) = self.target.at(t) {
            c.target = v;
        }
        if let Some(v) = self.up.at(t) {
            c.up = v;
        }
        if let Some([v]) = self.fov_y.at(t) {
            c.fov_y = Some(v);
        }
        if let Some([v]) = self.ortho_height.at(t)
            && let Some(o) = &mut c.orthographic
        {
            o.height = v;
        }
        c.keyframes = Vec::new();
        c.orbit = None;
        c
    }
}

/// Any frame of a scene file, flattened on demand. A still scene (no `animation`, or a glTF
/// asset without animations) has one frame; a glTF file loaded directly plays its animation 0
/// at [`crate::GLTF_FPS`]. Frames are built one at a time, so a path of any length is streamed:
/// only the prepared objects (generated meshes' parameters, opened glTF assets) are kept.
#[derive(Debug)]
pub struct Frames {
    inner: Inner,
}

#[derive(Debug)]
enum Inner {
    Still {
        scene: Box<Scene>,
        file: String,
    },
    Animated(Box<AnimatedSource>),
    /// A glTF file loaded directly, with its animation 0.
    Gltf(Box<crate::gltf::GltfFrames>),
}

#[derive(Debug)]
struct AnimatedSource {
    file: String,
    json: String,
    raw: RawScene,
    prepared: PreparedScene,
}

impl Frames {
    /// A still scene as a one-frame sequence; `file` names it in errors.
    pub fn still(scene: Scene, file: impl Into<String>) -> Frames {
        Frames {
            inner: Inner::Still {
                scene: Box::new(scene),
                file: file.into(),
            },
        }
    }

    pub(crate) fn animated(
        file: String,
        json: String,
        raw: RawScene,
        prepared: PreparedScene,
    ) -> Frames {
        Frames {
            inner: Inner::Animated(Box::new(AnimatedSource {
                file,
                json,
                raw,
                prepared,
            })),
        }
    }

    /// A glTF file's animated frames.
    pub(crate) fn gltf(frames: Box<crate::gltf::GltfFrames>) -> Frames {
        Frames {
            inner: Inner::Gltf(frames),
        }
    }

    /// The animation, `None` for a still scene.
    pub fn animation(&self) -> Option<Animation> {
        match &self.inner {
            Inner::Still { .. } => None,
            Inner::Animated(a) => a.prepared.timeline.as_ref().map(|t| t.animation),
            Inner::Gltf(g) => g.animation(),
        }
    }

    /// Frames in the sequence (1 for a still scene).
    pub fn count(&self) -> u32 {
        self.animation().map_or(1, |a| a.frames)
    }

    /// Frame `t` as a flattened scene (`Scene::frame` = `t`). Errors name the file and the
    /// frame: a frame past the end, or geometry that a keyed transform makes non-finite.
    pub fn frame(&self, t: u32) -> Result<Scene> {
        if t >= self.count() {
            return Err(SceneError::Invalid {
                file: self.file().to_string(),
                path: "animation.frames".into(),
                problem: Problem::BadValue {
                    what: "frame".into(),
                    value: t.to_string(),
                    allowed: format!("a frame in 0..{} (the scene's frames)", self.count()),
                },
            });
        }
        match &self.inner {
            Inner::Still { scene, .. } => Ok((**scene).clone()),
            Inner::Animated(a) => {
                let cx = Ctx::new(&a.file, &a.json);
                cx.flatten(&a.raw, &a.prepared, t)
            }
            Inner::Gltf(g) => g.frame(t),
        }
    }

    /// The file the frames come from, as named in errors.
    pub fn file(&self) -> &str {
        match &self.inner {
            Inner::Still { file, .. } => file,
            Inner::Animated(a) => &a.file,
            Inner::Gltf(g) => g.file(),
        }
    }
}

impl Ctx<'_> {
    /// Reads `animation` and every keyframe of the camera and the objects, validating each key
    /// (frames strictly increasing within `0..frames`, every value as its static field is
    /// validated). `None` for a still scene; keyframes without `animation` are an error.
    pub(crate) fn timeline(&self, raw: &RawScene) -> Result<Option<Timeline>> {
        let Some(anim) = &raw.animation else {
            if !raw.camera.keyframes.is_empty() {
                return Err(self.needs_animation("camera.keyframes"));
            }
            if raw.camera.orbit.is_some() {
                return Err(self.needs_animation("camera.orbit"));
            }
            if let Some(i) = raw.objects.iter().position(|o| !o.keyframes.is_empty()) {
                return Err(self.needs_animation(&format!("objects[{i}].keyframes")));
            }
            return Ok(None);
        };
        if anim.frames == 0 || anim.frames > u64::from(MAX_FRAMES) {
            return Err(self.bad(
                "animation.frames",
                "frame count",
                anim.frames.to_string(),
                format!("an integer in 1..={MAX_FRAMES}"),
            ));
        }
        let frames = anim.frames as u32;
        let fps = self.finite(anim.fps, "animation.fps")?;
        if fps <= 0.0 {
            return Err(self.bad(
                "animation.fps",
                "frame rate",
                fps.to_string(),
                "frames per second > 0".into(),
            ));
        }
        let camera = self.camera_tracks(&raw.camera, frames)?;
        let objects = raw
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| self.object_tracks(i, o, frames))
            .collect::<Result<Vec<_>>>()?;
        Ok(Some(Timeline {
            animation: Animation { frames, fps },
            camera,
            objects,
        }))
    }

    fn needs_animation(&self, path: &str) -> SceneError {
        self.err(
            path,
            Problem::BadValue {
                what: "animation without a frame count".into(),
                value: "a top-level `animation` is missing".into(),
                allowed: "keyframes and orbits only in a scene with `\"animation\": {\"frames\": N, \"fps\": F}`".into(),
            },
        )
    }

    fn bad(&self, path: &str, what: &str, value: String, allowed: String) -> SceneError {
        self.err(
            path,
            Problem::BadValue {
                what: what.into(),
                value,
                allowed,
            },
        )
    }

    /// Checks a key's frame against the previous key's and the frame count.
    fn key_frame(&self, frame: u64, previous: Option<u32>, frames: u32, p: &str) -> Result<u32> {
        let path = format!("{p}.frame");
        if frame >= u64::from(frames) {
            return Err(self.bad(
                &path,
                "keyframe",
                frame.to_string(),
                format!("a frame in 0..{frames} (animation.frames)"),
            ));
        }
        let frame = frame as u32;
        if let Some(prev) = previous
            && frame <= prev
        {
            return Err(self.bad(
                &path,
                "keyframe",
                format!("{frame} after a key at frame {prev}"),
                "frames strictly increasing within one `keyframes` list".into(),
            ));
        }
        Ok(frame)
    }

    fn camera_tracks(&self, c: &RawCamera, frames: u32) -> Result<CameraTracks> {
        let mut tracks = CameraTracks::default();
        if let Some(o) = &c.orbit {
            self.vec3(o.center, "camera.orbit.center")?;
            self.positive(o.radius, "camera.orbit.radius")?;
            self.finite(o.height, "camera.orbit.height")?;
            self.finite(o.turns, "camera.orbit.turns")?;
            self.finite(o.start_degrees, "camera.orbit.start_degrees")?;
            tracks.orbit = Some(o.clone());
        }
        let mut previous = None;
        for (k, key) in c.keyframes.iter().enumerate() {
            let p = format!("camera.keyframes[{k}]");
            let frame = self.key_frame(key.frame, previous, frames, &p)?;
            previous = Some(frame);
            if c.orbit.is_some() && (key.eye.is_some() || key.target.is_some()) {
                return Err(self.bad(
                    &p,
                    "eye or target keyframe",
                    "next to camera.orbit".into(),
                    "either an orbit or eye/target keyframes (the orbit sets both)".into(),
                ));
            }
            if let Some(v) = key.eye {
                tracks
                    .eye
                    .0
                    .push((frame, self.vec3(v, &format!("{p}.eye"))?.into()));
            }
            if let Some(v) = key.target {
                let v = self.vec3(v, &format!("{p}.target"))?;
                tracks.target.0.push((frame, v.into()));
            }
            if let Some(v) = key.up {
                tracks
                    .up
                    .0
                    .push((frame, self.vec3(v, &format!("{p}.up"))?.into()));
            }
            if let Some(v) = key.fov_y {
                if c.orthographic.is_some() {
                    return Err(self.err(format!("{p}.fov_y"), Problem::ProjectionConflict));
                }
                let path = format!("{p}.fov_y");
                let v = self.finite(v, &path)?;
                if !(v > 0.0 && v < 180.0) {
                    return Err(self.err(path, Problem::FovOutOfRange { value: v }));
                }
                tracks.fov_y.0.push((frame, [v]));
            }
            if let Some(o) = &key.orthographic {
                if c.orthographic.is_none() {
                    return Err(self.err(format!("{p}.orthographic"), Problem::ProjectionConflict));
                }
                let v = self.positive(o.height, &format!("{p}.orthographic.height"))?;
                tracks.ortho_height.0.push((frame, [v]));
            }
        }
        Ok(tracks)
    }

    fn object_tracks(&self, i: usize, o: &RawObject, frames: u32) -> Result<ObjectTracks> {
        let mut tracks = ObjectTracks::default();
        let is_gltf = o.mesh.get("kind").and_then(serde_json::Value::as_str) == Some("gltf");
        let mut previous = None;
        for (k, key) in o.keyframes.iter().enumerate() {
            let p = format!("objects[{i}].keyframes[{k}]");
            let frame = self.key_frame(key.frame, previous, frames, &p)?;
            previous = Some(frame);
            if let Some(v) = key.translate {
                let v = self.vec3(v, &format!("{p}.translate"))?;
                tracks.translate.0.push((frame, v.into()));
            }
            if let Some(v) = key.rotate {
                let v = self.vec3(v, &format!("{p}.rotate"))?;
                tracks.rotate.0.push((frame, v.into()));
            }
            if let Some(v) = key.scale {
                for (c, x) in v.iter().enumerate() {
                    self.positive(*x, &format!("{p}.scale[{c}]"))?;
                }
                tracks.scale.0.push((frame, v));
            }
            if let Some(v) = key.alpha {
                if is_gltf {
                    return Err(self.err(
                        format!("{p}.alpha"),
                        Problem::GltfObjectField {
                            field: "alpha".into(),
                            allowed: "no `alpha` keyframes on a gltf object (materials come from the asset)".into(),
                        },
                    ));
                }
                tracks
                    .alpha
                    .0
                    .push((frame, [self.alpha(v, &format!("{p}.alpha"))?]));
            }
        }
        Ok(tracks)
    }

    /// Validates the camera and every keyed transform of every frame, so that [`Frames::frame`]
    /// fails only where geometry itself overflows. Errors name the frame.
    pub(crate) fn check_frames(&self, raw: &RawScene, timeline: &Timeline) -> Result<()> {
        let frames = timeline.animation.frames;
        let resolution = crate::scene::Resolution {
            width: 1,
            height: 1,
        };
        let at_frame = |t: u32, e: SceneError| e.at_frame(t, "the keyframes");
        let animated_camera = timeline.camera.orbit.is_some() || !raw.camera.keyframes.is_empty();
        for t in 0..frames {
            if animated_camera {
                let c = timeline.camera.camera_at(&raw.camera, t, frames);
                self.camera(&c, raw.reverse_z, resolution)
                    .map_err(|e| at_frame(t, e))?;
            }
            for (i, (o, tracks)) in raw.objects.iter().zip(&timeline.objects).enumerate() {
                if tracks.is_empty() {
                    continue;
                }
                let transform = tracks.transform_at(&o.transform, t);
                self.transform(&transform, &format!("objects[{i}].transform"))
                    .map_err(|e| at_frame(t, e))?;
            }
        }
        Ok(())
    }
}
