// Per-pixel lighting of lit materials, included by common.wgsl: `reflect_lights` is the
// line-comparable twin of `oit_scene::reflect_lights` (crates/oit-scene/src/lighting.rs, whose
// header gives the BRDF and its source, the glTF 2.0 specification's appendix B): the same f32
// products in the same order.

// Most lights (`oit_scene::MAX_LIGHTS`).
const MAX_LIGHTS: u32 = 8u;
const LIGHT_DIRECTIONAL: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_SPOT: u32 = 2u;
// `oit_scene::MIN_GGX_ALPHA` and 1/π (`std::f32::consts::FRAC_1_PI`).
const MIN_GGX_ALPHA: f32 = 0.002;
const INV_PI: f32 = 0.31830987;

// One `oit_scene::PunctualLight` (64 bytes, `oit_gpu::scene::light_words`).
struct Light {
    position: vec3<f32>,
    kind: u32,
    direction: vec3<f32>,
    range: f32,
    radiance: vec3<f32>,
    cone_scale: f32,
    cone_offset: f32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// The scene's `LightRig` and the camera eye: `Camera::lights` (common.wgsl), in the camera
// uniform after the matrix. A uniform of its own (group 0 binding 4) crashed lavapipe's
// dual-peel passes (2026-12-07), so it shares the camera's binding.
struct Lights {
    eye: vec3<f32>,
    count: u32,
    ambient: vec3<f32>,
    pad: u32,
    lights: array<Light, MAX_LIGHTS>,
}

// Set per pipeline by `oit_gpu::ScenePipelines`: true only for lit materials, so unlit
// pipelines compile the lighting (and the reads of the world position and normal) out.
override LIT: bool = false;

// Material::specular codes: 0 unlit, 1 faded, 2 kept.
const SPECULAR_KEPT: u32 = 2u;

struct Reflected {
    diffuse: vec3<f32>,
    specular: vec3<f32>,
}

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

// `a / |a|` by a square root and a division; zero stays zero (`unit_vector` in lighting.rs).
fn unit_vector(a: vec3<f32>) -> vec3<f32> {
    let len2 = dot3(a, a);
    if len2 > 0.0 {
        let len = sqrt(len2);
        return vec3<f32>(a.x / len, a.y / len, a.z / len);
    }
    return vec3<f32>(0.0);
}

struct Incidence {
    to_light: vec3<f32>,
    radiance: vec3<f32>,
}

// `oit_scene::lighting::incidence`.
fn incidence(l: Light, p: vec3<f32>) -> Incidence {
    var out: Incidence;
    if l.kind == LIGHT_DIRECTIONAL {
        out.to_light = l.direction * -1.0;
        out.radiance = l.radiance;
        return out;
    }
    let d = l.position - p;
    let dist2 = dot3(d, d);
    let dist = sqrt(dist2);
    let to_light = vec3<f32>(d.x / dist, d.y / dist, d.z / dist);
    var attenuation = 1.0 / dist2;
    if l.range > 0.0 {
        let q = dist / l.range;
        let q2 = q * q;
        let window = clamp(1.0 - q2 * q2, 0.0, 1.0);
        attenuation = window * window / dist2;
    }
    if l.kind == LIGHT_SPOT {
        let cd = -dot3(l.direction, to_light);
        let cone = clamp(cd * l.cone_scale + l.cone_offset, 0.0, 1.0);
        attenuation = attenuation * (cone * cone);
    }
    out.to_light = to_light;
    out.radiance = l.radiance * attenuation;
    return out;
}

fn all_finite(v: vec3<f32>) -> bool {
    // Finite: not NaN (x == x) and below the largest f32 in magnitude.
    let a = abs(v);
    return all(v == v) && all(a <= vec3<f32>(3.4028235e38));
}

// `oit_scene::reflect_lights`: the reflection of a surface of albedo `albedo` at `position`
// with the (interpolated, unnormalised, front-facing) `normal`.
fn reflect_lights(
    albedo: vec3<f32>,
    metallic: f32,
    roughness: f32,
    position: vec3<f32>,
    normal: vec3<f32>,
) -> Reflected {
    let n = unit_vector(normal);
    let v = unit_vector(camera.lights.eye - position);
    let m = metallic;
    let c_diff = albedo * (1.0 - m);
    let f0 = vec3<f32>(0.04) + (albedo - vec3<f32>(0.04)) * m;
    let a = max(roughness * roughness, MIN_GGX_ALPHA);
    let a2 = a * a;
    let n_v = max(dot3(n, v), 0.0);
    let vis_v = n_v + sqrt(a2 + (1.0 - a2) * (n_v * n_v));
    var diffuse = camera.lights.ambient;
    var specular = vec3<f32>(0.0);
    for (var i = 0u; i < min(camera.lights.count, MAX_LIGHTS); i++) {
        let inc = incidence(camera.lights.lights[i], position);
        let l = inc.to_light;
        let n_l = max(dot3(n, l), 0.0);
        if n_l > 0.0 && all_finite(inc.radiance) {
            let h = unit_vector(l + v);
            let n_h = max(dot3(n, h), 0.0);
            let v_h = max(dot3(v, h), 0.0);
            let k = 1.0 - v_h;
            let k2 = k * k;
            let k5 = k2 * k2 * k;
            let dd = n_h * n_h * (a2 - 1.0) + 1.0;
            let distribution = a2 * INV_PI / (dd * dd);
            let vis_l = n_l + sqrt(a2 + (1.0 - a2) * (n_l * n_l));
            let brdf = distribution / (vis_l * vis_v);
            let fresnel = f0 + (vec3<f32>(1.0) - f0) * k5;
            let e = inc.radiance * n_l;
            diffuse += e * (vec3<f32>(1.0) - fresnel) * INV_PI;
            specular += e * fresnel * brdf;
        }
    }
    var out: Reflected;
    out.diffuse = c_diff * diffuse;
    out.specular = specular;
    return out;
}
