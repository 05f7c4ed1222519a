// Shared scene module: bindings, the vertex stage and the fragment colour rule.
//
// Included by every scene pass with the line `#include "common.wgsl"` (see
// `oit_gpu::shaders::compose`). `shade` must stay line-comparable to `Material::shade` in
// crates/oit-scene/src/scene.rs: the GPU and the CPU reference evaluate the same f32 products
// in the same order.

struct Camera {
    // Column-major, exactly `scene.camera.view_proj`.
    view_proj: mat4x4<f32>,
    // The eye and the lights of lit materials (shaders/lighting.wgsl).
    lights: Lights,
}

// Set per pipeline by `oit_gpu::ScenePipelines` (false for untextured materials): a constant,
// so the compiler removes the texture code. A runtime branch, even on a uniform, still made
// every fragment pay for the texel fetches on CPU rasterizers, which run branches masked.
override TEXTURED: bool = true;

// False in pipelines whose fragments are never discarded (no cutoff, and back faces culled or
// drawn as double-sided; `oit_gpu::ScenePipelines`): `keep` is then the constant true, so the
// rasterizer may test depth before shading (15 % of `unsorted` on 12 000 small billboards).
override MAY_DISCARD: bool = true;

// One entry per `Scene::materials` element (96 bytes, see `oit_gpu::scene::material_words`).
struct Material {
    // rgb = base colour (linear), a = alpha.
    base_alpha: vec4<f32>,
    // Linear radiance added after the products (glTF emission); 0 without emission.
    emissive: vec3<f32>,
    // 0 opaque, 1 mask, 2 blend, 3 mask-blend.
    mode: u32,
    cutoff: f32,
    premultiplied: u32,
    intensity: f32,
    double_sided: u32,
    // Base colour texture, emissive texture: (first texel in `texels`, width | height << 16);
    // a size of 0 means none (samples as 1).
    textures: vec4<u32>,
    // Wrap codes (0 repeat, 1 mirrored repeat, 2 clamp to edge): base u | base v << 2 |
    // emissive u << 4 | emissive v << 6.
    wrap: u32,
    // Thin-surface transmission factor τ (0: scalar alpha).
    transmission: f32,
    pad1: u32,
    pad2: u32,
    // Lighting (`oit_scene::Reflectance`): metallic and roughness factors, and the specular
    // rule, 0 unlit, 1 faded by α, 2 kept (shaders/lighting.wgsl).
    metallic: f32,
    roughness: f32,
    specular: u32,
    pad3: u32,
}

const MODE_OPAQUE: u32 = 0u;
const MODE_MASK: u32 = 1u;
const MODE_BLEND: u32 = 2u;
const MODE_MASK_BLEND: u32 = 3u;

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var<storage, read> materials: array<Material>;
// Every texture's level 0, linear RGBA f32 (sRGB decoded on the CPU), row-major from the
// image's top-left, one after the other. One dummy texel when the scene has no textures.
@group(0) @binding(2) var<storage, read> texels: array<vec4<f32>>;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) material: u32,
    @location(2) color: vec4<f32>,
    @location(3) uv: vec2<f32>,
    // World-space normal, read only by lit materials' pipelines (`LIT`).
    @location(4) normal: vec3<f32>,
}

#include "lighting.wgsl"

// How the vertex stage hands the material to the fragment stage: `VertexOut`, `vs_main`,
// `scene_vertex`, `material_of` and `texcoord`. This file includes the per-vertex form; scene
// pipelines of draws with small triangles compose the module with a per-draw form in its place,
// shaders/scene_io/draw.wgsl or, for untextured materials, draw_untextured.wgsl
// (`oit_gpu::ScenePipelines`). All give `shade()` the same values, bit for bit.
#include "scene_io/vertex.wgsl"

// `Wrap::apply` (crates/oit-scene/src/texture.rs): texel index `i` brought into 0..size.
fn wrap_texel(i: i32, size: i32, mode: u32) -> i32 {
    if mode == 0u {
        return ((i % size) + size) % size;
    }
    if mode == 1u {
        let m = ((i % (2 * size)) + 2 * size) % (2 * size);
        if m >= size {
            return 2 * size - 1 - m;
        }
        return m;
    }
    return clamp(i, 0, size - 1);
}

fn texel_at(first: u32, width: i32, height: i32, wrap: u32, i: i32, j: i32) -> vec4<f32> {
    let x = wrap_texel(i, width, wrap & 3u);
    let y = wrap_texel(j, height, (wrap >> 2u) & 3u);
    return texels[first + u32(y * width + x)];
}

// `Texture::sample` (crates/oit-scene/src/texture.rs): bilinear on level 0, f32, same order.
// `size` = width | height << 16, 0 for no texture (samples as 1).
fn sample_texture(first: u32, size: u32, wrap: u32, uv: vec2<f32>) -> vec4<f32> {
    if size == 0u {
        return vec4<f32>(1.0);
    }
    let width = i32(size & 0xffffu);
    let height = i32(size >> 16u);
    let x = uv.x * f32(width) - 0.5;
    let y = uv.y * f32(height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let i = i32(x0);
    let j = i32(y0);
    let t00 = texel_at(first, width, height, wrap, i, j);
    let t10 = texel_at(first, width, height, wrap, i + 1, j);
    let t01 = texel_at(first, width, height, wrap, i, j + 1);
    let t11 = texel_at(first, width, height, wrap, i + 1, j + 1);
    let top = t00 + (t10 - t00) * fx;
    let bottom = t01 + (t11 - t01) * fx;
    return top + (bottom - top) * fy;
}

// What a fragment contributes (the WGSL twin of `oit_scene::Shaded`).
struct Shaded {
    // False when the fragment is discarded (mask cutoff, or a culled back face).
    keep: bool,
    // Opaque modes: straight colour. Transparent modes: premultiplied colour C = α·c.
    color: vec3<f32>,
    // Coverage α (1 for opaque modes); for a transmissive material (τ > 0) the scalar opacity
    // 1 − mean(transmittance) that scalar-alpha techniques composite.
    alpha: f32,
    // What scales the colour behind, per channel: `(1 − α) + α·τ·lit`, which is exactly
    // `1 − α` for scalar-alpha materials (τ = 0). Meaningful for transparent modes only.
    transmittance: vec3<f32>,
}

fn is_transparent(mode: u32) -> bool {
    return mode == MODE_BLEND || mode == MODE_MASK_BLEND;
}

fn uses_cutoff(mode: u32) -> bool {
    return mode == MODE_MASK || mode == MODE_MASK_BLEND;
}

// `Material::shade`, plus back-face culling for single-sided materials. Pipelines also cull in
// fixed function; the test here makes passes with culling disabled (one pipeline for a globally
// sorted triangle stream) obey the same rule.
fn shade(v: VertexOut, front_facing: bool) -> Shaded {
    let m = material_of(v);
    var t = vec4<f32>(1.0);
    var e = vec4<f32>(1.0);
    if TEXTURED {
        t = sample_texture(m.textures.x, m.textures.y, m.wrap, texcoord(v));
        e = sample_texture(m.textures.z, m.textures.w, m.wrap >> 4u, texcoord(v));
    }
    let lit = v.color.rgb * m.base_alpha.rgb * t.rgb;
    // Unlit: the albedo is the colour. Lit: `reflect_lights` (shaders/lighting.wgsl).
    var light = Reflected(lit, vec3<f32>(0.0));
    var kept = false;
    if LIT && m.specular != 0u {
        var normal = surface_normal(v);
        if !front_facing {
            normal = -normal;
        }
        light = reflect_lights(lit, m.metallic, m.roughness, surface_position(v), normal);
        kept = m.specular == SPECULAR_KEPT;
    }
    let reflected = 1.0 - m.transmission;
    let c = light.diffuse * m.intensity * reflected + m.emissive * e.rgb;
    let sp = light.specular * m.intensity * reflected;
    let alpha = v.color.a * m.base_alpha.a * t.a;
    var s: Shaded;
    s.keep = (front_facing || m.double_sided != 0u) && !(uses_cutoff(m.mode) && alpha < m.cutoff);
    s.keep = s.keep || !MAY_DISCARD;
    if is_transparent(m.mode) {
        if m.premultiplied != 0u {
            s.color = c + sp;
        } else if kept {
            s.color = alpha * c + sp;
        } else {
            s.color = alpha * (c + sp);
        }
        s.alpha = alpha;
        let filtered = alpha * m.transmission;
        s.transmittance = vec3<f32>(1.0 - alpha) + filtered * lit;
        if m.transmission > 0.0 {
            // Scalar-alpha techniques composite the mean transmittance (exact for grey
            // filters): `opacity` of `Shaded::Transmissive`.
            let tt = s.transmittance;
            s.alpha = 1.0 - (tt.r + tt.g + tt.b) * (1.0 / 3.0);
        }
    } else {
        s.color = c + sp;
        s.alpha = 1.0;
    }
    return s;
}
