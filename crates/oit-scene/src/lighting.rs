//! Per-pixel lighting of lit materials: the one reflection rule the CPU reference and the GPU
//! evaluate (`reflect_lights` in crates/oit-gpu/shaders/lighting.wgsl is its line-comparable
//! twin: the same f32 products in the same order).
//!
//! The BRDF is the glTF 2.0 metallic-roughness model of the specification's appendix B
//! ("Specular BRDF", "Metals", "Dielectrics"): Lambert diffuse on `c_diff = albedo·(1 − m)`,
//! GGX/Trowbridge-Reitz distribution `D = α²/(π·((n·h)²(α² − 1) + 1)²)` with `α = r²`, the
//! height-correlated Smith visibility of appendix B.3.2
//! `V = 1/((n·l + √(α² + (1 − α²)(n·l)²))·(n·v + √(α² + (1 − α²)(n·v)²)))` and Schlick's
//! Fresnel `F = f0 + (1 − f0)(1 − v·h)⁵` with `f0 = mix(0.04, albedo, m)`; the diffuse part is
//! weighted by `1 − F` as in the appendix's `fresnel_mix`. Each light adds `E = L·(n·l)` (its
//! radiance times the cosine): diffuse `c_diff·(1 − F)/π·E`, specular `F·D·V·E`. Ambient is a
//! constant radiance times `c_diff` (no specular ambient). Lights are `KHR_lights_punctual`'s:
//! directional, point and spot with the extension's range attenuation
//! `clamp(1 − (d/range)⁴, 0, 1)²/d²` and cone falloff `clamp(cos·scale + offset, 0, 1)²`.

use glam::Vec3;

/// Most punctual lights a scene may have: the GPU keeps them in one fixed-size uniform array.
pub const MAX_LIGHTS: usize = 8;

/// Smallest GGX α (= roughness²) the rule uses: at α = 0 the distribution is a Dirac peak
/// (0/0 where n·h = 1). Stated, not silent: a roughness below √0.002 ≈ 0.045 shades as 0.045.
pub const MIN_GGX_ALPHA: f32 = 0.002;

/// 1/π in f32, a constant on both sides (no division in the shader).
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;

/// How a lit transparent material composites its specular reflection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Specular {
    /// Scaled by coverage like the rest of the colour, `C = α·(diffuse + specular)`: glTF's
    /// BLEND rule and Catlike Coding's "Fade" mode. The default.
    Faded,
    /// Added after the coverage product, `C = α·diffuse + specular`: reflections stay at full
    /// strength on clear glass (Catlike Coding's "Transparent" mode, Babylon's
    /// `specularOverAlpha`).
    Kept,
}

/// What makes a material lit: its metallic-roughness parameters and the specular rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reflectance {
    /// glTF `metallicFactor` in [0, 1].
    pub metallic: f32,
    /// glTF `roughnessFactor` in [0, 1].
    pub roughness: f32,
    pub specular: Specular,
}

impl Reflectance {
    /// glTF's defaults: fully metallic and rough (metallicFactor 1, roughnessFactor 1).
    pub const GLTF_DEFAULT: Reflectance = Reflectance {
        metallic: 1.0,
        roughness: 1.0,
        specular: Specular::Faded,
    };
}

/// The kind of a punctual light (`KHR_lights_punctual` `type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LightKind {
    Directional,
    Point,
    Spot,
}

impl LightKind {
    /// The code the shader reads (shaders/lighting.wgsl `LIGHT_*`).
    pub fn code(self) -> u32 {
        match self {
            LightKind::Directional => 0,
            LightKind::Point => 1,
            LightKind::Spot => 2,
        }
    }
}

/// One punctual light in world space, ready to evaluate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PunctualLight {
    pub kind: LightKind,
    /// World position (point, spot).
    pub position: [f32; 3],
    /// Unit direction the light travels (directional, spot): the node's −Z.
    pub direction: [f32; 3],
    /// Linear colour × intensity (lux for directional, candela otherwise).
    pub radiance: [f32; 3],
    /// Range of a point or spot light; 0 is infinite (no range attenuation).
    pub range: f32,
    /// Spot cone: `scale = 1/max(0.001, cos(inner) − cos(outer))`, `offset = −cos(outer)·scale`
    /// (the extension's own precomputation); 0 and 1 for other kinds (no falloff).
    pub cone_scale: f32,
    pub cone_offset: f32,
}

impl PunctualLight {
    /// A directional light travelling along `direction` (need not be unit length, not zero).
    pub fn directional(direction: Vec3, radiance: [f32; 3]) -> PunctualLight {
        PunctualLight {
            kind: LightKind::Directional,
            position: [0.0; 3],
            direction: direction.normalize().to_array(),
            radiance,
            range: 0.0,
            cone_scale: 0.0,
            cone_offset: 1.0,
        }
    }

    /// The spot cone terms of `KHR_lights_punctual` for inner and outer cone angles (radians).
    pub fn cone(inner: f32, outer: f32) -> (f32, f32) {
        let (ci, co) = (inner.cos(), outer.cos());
        let scale = 1.0 / (ci - co).max(0.001);
        (scale, -co * scale)
    }
}

/// The lights of a scene, shared by every lit material.
#[derive(Debug, Clone, PartialEq)]
pub struct LightRig {
    /// Constant radiance reflected diffusely by every lit surface.
    pub ambient: [f32; 3],
    /// At most [`MAX_LIGHTS`].
    pub lights: Vec<PunctualLight>,
    /// What the rig is, one line for reports (e.g. "default rig", "KHR_lights_punctual").
    pub origin: String,
}

impl LightRig {
    /// No light at all (scenes without lit materials).
    pub fn none() -> LightRig {
        LightRig {
            ambient: [0.0; 3],
            lights: Vec::new(),
            origin: "none".into(),
        }
    }

    /// The rig of lit materials when the scene names no lights: one white directional key
    /// light from above, front and right in world space (travelling along (−0.4, −0.8, −0.45),
    /// so fixed relative to the scene, not the camera) of π·0.75 lux, which a white Lambert
    /// surface facing it reflects as 0.75, plus an ambient radiance of 0.25.
    pub fn default_rig() -> LightRig {
        let key = std::f32::consts::PI * 0.75;
        LightRig {
            ambient: [0.25; 3],
            lights: vec![PunctualLight::directional(
                Vec3::new(-0.4, -0.8, -0.45),
                [key; 3],
            )],
            origin: "default rig (directional key light + ambient)".into(),
        }
    }
}

/// Gives a scene with lit materials but no lights of its own [`LightRig::default_rig`].
pub(crate) fn complete_rig(scene: &mut crate::Scene) {
    let lit = scene.materials.iter().any(crate::Material::is_lit);
    if lit && scene.lights.lights.is_empty() && scene.lights.ambient == [0.0; 3] {
        scene.lights = LightRig::default_rig();
    }
}

/// A point of a lit surface as the fragment stage sees it: interpolated world position and
/// normal (not yet normalised; flipped for back faces by the caller) and the camera eye.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub eye: [f32; 3],
}

/// The reflected light of one fragment before coverage: `diffuse` includes the albedo (it
/// replaces the unlit `albedo`), `specular` is added on top.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reflected {
    pub diffuse: [f32; 3],
    pub specular: [f32; 3],
}

type V3 = [f32; 3];

#[inline(always)]
fn dot(a: V3, b: V3) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
fn scale(a: V3, s: f32) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a / |a|` by a square root and a division (the shader's `unit_vector`); zero stays zero.
#[inline(always)]
fn unit_vector(a: V3) -> V3 {
    let len2 = dot(a, a);
    if len2 > 0.0 {
        let len = len2.sqrt();
        [a[0] / len, a[1] / len, a[2] / len]
    } else {
        [0.0; 3]
    }
}

/// Direction towards light `l` from `p` (unit) and the radiance arriving there.
#[inline(always)]
pub fn incidence(l: &PunctualLight, p: V3) -> (V3, V3) {
    if l.kind == LightKind::Directional {
        return (scale(l.direction, -1.0), l.radiance);
    }
    let d = sub(l.position, p);
    let dist2 = dot(d, d);
    let dist = dist2.sqrt();
    let to_light = [d[0] / dist, d[1] / dist, d[2] / dist];
    let mut attenuation = 1.0 / dist2;
    if l.range > 0.0 {
        let q = dist / l.range;
        let q2 = q * q;
        let window = (1.0 - q2 * q2).clamp(0.0, 1.0);
        attenuation = window * window / dist2;
    }
    if l.kind == LightKind::Spot {
        let cd = -dot(l.direction, to_light);
        let cone = (cd * l.cone_scale + l.cone_offset).clamp(0.0, 1.0);
        attenuation *= cone * cone;
    }
    (to_light, scale(l.radiance, attenuation))
}

/// The reflection rule (module docs) at `s` of a surface of albedo `albedo` (vertex colour ×
/// base colour × base texel). Zero-length normals (or points at a point light) get ambient only.
#[inline(always)]
pub fn reflect_lights(albedo: V3, r: &Reflectance, rig: &LightRig, s: &SurfacePoint) -> Reflected {
    let n = unit_vector(s.normal);
    let v = unit_vector(sub(s.eye, s.position));
    let m = r.metallic;
    let c_diff = scale(albedo, 1.0 - m);
    let f0 = [
        0.04 + (albedo[0] - 0.04) * m,
        0.04 + (albedo[1] - 0.04) * m,
        0.04 + (albedo[2] - 0.04) * m,
    ];
    let a = (r.roughness * r.roughness).max(MIN_GGX_ALPHA);
    let a2 = a * a;
    let n_v = dot(n, v).max(0.0);
    let vis_v = n_v + (a2 + (1.0 - a2) * (n_v * n_v)).sqrt();
    let mut diffuse = rig.ambient;
    let mut specular = [0.0f32; 3];
    for light in &rig.lights {
        let (l, radiance) = incidence(light, s.position);
        let n_l = dot(n, l).max(0.0);
        if n_l > 0.0 && radiance.iter().all(|c| c.is_finite()) {
            let h = unit_vector([l[0] + v[0], l[1] + v[1], l[2] + v[2]]);
            let n_h = dot(n, h).max(0.0);
            let v_h = dot(v, h).max(0.0);
            let k = 1.0 - v_h;
            let k2 = k * k;
            let k5 = k2 * k2 * k;
            let dd = n_h * n_h * (a2 - 1.0) + 1.0;
            let distribution = a2 * INV_PI / (dd * dd);
            let vis_l = n_l + (a2 + (1.0 - a2) * (n_l * n_l)).sqrt();
            let brdf = distribution / (vis_l * vis_v);
            for c in 0..3 {
                let fresnel = f0[c] + (1.0 - f0[c]) * k5;
                let e = radiance[c] * n_l;
                diffuse[c] += e * (1.0 - fresnel) * INV_PI;
                specular[c] += e * fresnel * brdf;
            }
        }
    }
    Reflected {
        diffuse: [
            c_diff[0] * diffuse[0],
            c_diff[1] * diffuse[1],
            c_diff[2] * diffuse[2],
        ],
        specular,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig(lights: Vec<PunctualLight>, ambient: f32) -> LightRig {
        LightRig {
            ambient: [ambient; 3],
            lights,
            origin: "test".into(),
        }
    }

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-6)
    }

    /// Light, normal and view all along +z: n·l = n·v = n·h = v·h = 1, so F = f0,
    /// D = α²/(π·α⁴) and V = 1/((1 + 1)·(1 + 1)) = 1/4 (both square roots are √1).
    #[test]
    fn head_on_light_gives_the_hand_computed_value() {
        let r = Reflectance {
            metallic: 0.0,
            roughness: 0.5,
            specular: Specular::Faded,
        };
        let light = PunctualLight::directional(Vec3::new(0.0, 0.0, -1.0), [2.0; 3]);
        let s = SurfacePoint {
            position: [0.0; 3],
            normal: [0.0, 0.0, 3.0],
            eye: [0.0, 0.0, 5.0],
        };
        let out = reflect_lights([0.5, 0.25, 1.0], &r, &rig(vec![light], 0.1), &s);
        let a: f32 = 0.25;
        let d = a * a / std::f32::consts::PI / (a * a * a * a);
        let spec = 2.0 * 0.04 * d / 4.0;
        for (c, albedo) in [0.5f32, 0.25, 1.0].into_iter().enumerate() {
            let diffuse = albedo * (0.1 + 2.0 * (1.0 - 0.04) / std::f32::consts::PI);
            assert!(close(out.diffuse[c], diffuse, 1e-6), "{out:?}");
            assert!(close(out.specular[c], spec, 1e-5), "{out:?} vs {spec}");
        }
        // A metal has no diffuse part and reflects its albedo as f0.
        let metal = Reflectance { metallic: 1.0, ..r };
        let out = reflect_lights([0.5, 0.25, 1.0], &metal, &rig(vec![light], 0.1), &s);
        assert_eq!(out.diffuse, [0.0; 3]);
        assert!(close(out.specular[0], 2.0 * 0.5 * d / 4.0, 1e-5));
    }

    #[test]
    fn light_from_behind_gives_ambient_only() {
        let r = Reflectance {
            metallic: 0.0,
            roughness: 0.3,
            specular: Specular::Kept,
        };
        let light = PunctualLight::directional(Vec3::new(0.0, 0.0, 1.0), [5.0; 3]);
        let s = SurfacePoint {
            position: [0.0; 3],
            normal: [0.0, 0.0, 1.0],
            eye: [0.0, 1.0, 5.0],
        };
        let out = reflect_lights([0.8; 3], &r, &rig(vec![light], 0.2), &s);
        assert_eq!(out.specular, [0.0; 3]);
        assert!(close(out.diffuse[0], 0.8 * 0.2, 1e-7));
    }

    /// Point light at distance 2 with range 4: window (1 − (1/2)⁴)² = (15/16)², over d² = 4.
    #[test]
    fn point_and_spot_attenuation_follow_the_extension() {
        let point = PunctualLight {
            kind: LightKind::Point,
            position: [0.0, 0.0, 2.0],
            direction: [0.0, 0.0, -1.0],
            radiance: [1.0; 3],
            range: 4.0,
            cone_scale: 0.0,
            cone_offset: 1.0,
        };
        let (l, e) = incidence(&point, [0.0; 3]);
        assert_eq!(l, [0.0, 0.0, 1.0]);
        let expected = (15.0f32 / 16.0).powi(2) / 4.0;
        assert!(close(e[0], expected, 1e-6), "{e:?} vs {expected}");
        // Beyond the range nothing arrives.
        let (_, e) = incidence(&point, [0.0, 0.0, -3.0]);
        assert_eq!(e, [0.0; 3]);
        // A spot with cones 10° / 30°: full inside the inner cone, none outside the outer one,
        // and the squared linear ramp of cos in between.
        let (scale, offset) = PunctualLight::cone(10f32.to_radians(), 30f32.to_radians());
        let spot = PunctualLight {
            kind: LightKind::Spot,
            range: 0.0,
            cone_scale: scale,
            cone_offset: offset,
            ..point
        };
        let at_angle = |deg: f32| {
            let t = deg.to_radians();
            // 2 units from the light along a ray `deg` off its axis (−z).
            let p = [2.0 * t.sin(), 0.0, 2.0 - 2.0 * t.cos()];
            incidence(&spot, p).1[0] * 4.0
        };
        assert!(close(at_angle(5.0), 1.0, 1e-5));
        assert_eq!(at_angle(40.0), 0.0);
        let c20 = 20f32.to_radians().cos();
        let ramp = (c20 - 30f32.to_radians().cos())
            / (10f32.to_radians().cos() - 30f32.to_radians().cos());
        assert!(
            close(at_angle(20.0), ramp * ramp, 1e-3),
            "{}",
            at_angle(20.0)
        );
    }
}
