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

// True in pipelines for materials that blend OVER with no coloured transmission (operator
// `over`, transmission 0; `oit_gpu::ScenePipelines`): the code below that handles the other
// operators and transmission would leave such a fragment's result unchanged, bit for bit, and
// llvmpipe would still run it under masks (it made `wboit` and `dual-peel` 10–20 % slower on
// lavapipe, 2026-12-07).
override OVER_ONLY: bool = false;

// True in pipelines for unlit, straight-alpha (not premultiplied) transparent materials that
// blend OVER with no coloured transmission (`oit_gpu::ScenePipelines`): `shade()` then takes
// the one path such a material takes below, bit for bit, without the mode and alpha-form
// branches llvmpipe would run under masks (0.95x `unsorted`'s time on 12 000 small
// billboards, where partly covered 4x4 blocks make shading weigh more, 2026-12-07).
override STRAIGHT_OVER: bool = false;

// True in pipelines for materials whose factors are units: base colour and alpha 1, intensity
// 1, no emission, no transmission (`oit_gpu::ScenePipelines`; glTF's defaults, and what
// vertex-coloured content uses). `shade()` then multiplies by constant ones and adds constant
// zeros instead of reading those factors per fragment, which leaves every value as it was (a
// -0 colour stays -0 rather than becoming +0, and blends to the same value). llvmpipe reads
// uniforms again in every step of 8 fragments: the nine reads were 44 % of `unsorted`'s fragment
// instructions on 12 000 small billboards (callgrind, 2026-12-08).
override UNIT_FACTORS: bool = false;

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
    // Base colour texture, emissive texture: (first texel of level 0 in `texel_pages`,
    // width | height << 16); a size of 0 means none (samples as 1).
    textures: vec4<u32>,
    // The two slots' samplers, 12 bits each (base in bits 0..12, emissive in 12..24):
    // `Sampler::code` (wrap u | wrap v << 2 | mag linear << 4 | min linear << 5 | mip filter << 6,
    // 0 none, 1 nearest, 2 linear) | UNORM rgb << 9 (0: sRGB colour).
    wrap: u32,
    // Thin-surface transmission factor τ (0: scalar alpha).
    transmission: f32,
    // `oit_scene::BlendOperator::code`: 0 over, 1 add, 2 subtract, 3 multiply.
    blend_operator: u32,
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

const OPERATOR_OVER: u32 = 0u;
const OPERATOR_ADD: u32 = 1u;
const OPERATOR_SUBTRACT: u32 = 2u;
const OPERATOR_MULTIPLY: u32 = 3u;

@group(0) @binding(0) var<uniform> camera: Camera;
@group(0) @binding(1) var<storage, read> materials: array<Material>;
// The decode tables of `oit_scene::decode_tables`, computed once on the CPU: [0, 256) sRGB →
// linear, [256, 512) UNORM code / 255. Both sides decode codes through the same f32 values.
@group(0) @binding(2) var<storage, read> texel_decode: array<f32, 512>;
// Every texture's 8-bit RGBA codes (r | g << 8 | b << 16 | a << 24), all mip levels, level 0
// first, each row-major from the image's top-left, one texture after the other, in pages of
// 2048 × 2048 texels (`oit_gpu::scene::TEXEL_PAGE_SIDE`): texel n is at (n % 2048, n / 2048 %
// 2048) of layer n / 2^22. Read with `textureLoad`: exact integer fetches, no sampler.
@group(0) @binding(4) var texel_pages: texture_2d_array<u32>;

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

fn texel_code(n: u32) -> u32 {
    return textureLoad(texel_pages, vec2<u32>(n & 2047u, (n >> 11u) & 2047u), n >> 22u, 0).x;
}

// `Texture::decode` (crates/oit-scene/src/texture.rs): rgb through the sRGB or UNORM table,
// alpha through the UNORM table.
fn decode_texel(code: u32, bits: u32) -> vec4<f32> {
    let rgb = select(0u, 256u, ((bits >> 9u) & 1u) != 0u);
    return vec4<f32>(
        texel_decode[rgb + (code & 0xffu)],
        texel_decode[rgb + ((code >> 8u) & 0xffu)],
        texel_decode[rgb + ((code >> 16u) & 0xffu)],
        texel_decode[256u + (code >> 24u)],
    );
}

// `Texture::texel_at`.
fn texel_at(first: u32, width: i32, height: i32, bits: u32, i: i32, j: i32) -> vec4<f32> {
    let x = wrap_texel(i, width, bits & 3u);
    let y = wrap_texel(j, height, (bits >> 2u) & 3u);
    return decode_texel(texel_code(first + u32(y * width + x)), bits);
}

// `Texture::level_offset`: the first texel of level `k`, levels halving down to 1.
fn level_first(first: u32, width: u32, height: u32, k: u32) -> u32 {
    var n = first;
    for (var l = 0u; l < k; l++) {
        n += max(width >> l, 1u) * max(height >> l, 1u);
    }
    return n;
}

// `Texture::filter_level`: nearest or bilinear on one level, f32, same order.
fn filter_level(first: u32, size: u32, bits: u32, level: u32, linear: bool, uv: vec2<f32>) -> vec4<f32> {
    let width0 = size & 0xffffu;
    let height0 = size >> 16u;
    let width = i32(max(width0 >> level, 1u));
    let height = i32(max(height0 >> level, 1u));
    let base = level_first(first, width0, height0, level);
    if !linear {
        let i = i32(floor(uv.x * f32(width)));
        let j = i32(floor(uv.y * f32(height)));
        return texel_at(base, width, height, bits, i, j);
    }
    let x = uv.x * f32(width) - 0.5;
    let y = uv.y * f32(height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let i = i32(x0);
    let j = i32(y0);
    let t00 = texel_at(base, width, height, bits, i, j);
    let t10 = texel_at(base, width, height, bits, i + 1, j);
    let t01 = texel_at(base, width, height, bits, i, j + 1);
    let t11 = texel_at(base, width, height, bits, i + 1, j + 1);
    let top = t00 + (t10 - t00) * fx;
    let bottom = t01 + (t11 - t01) * fx;
    return top + (bottom - top) * fy;
}

// `Texture::footprint_squared`: ρ² of Vulkan's isotropic rule from (du/dx, dv/dx, du/dy, dv/dy).
fn footprint_squared(size: u32, grad: vec4<f32>) -> f32 {
    let w = f32(size & 0xffffu);
    let h = f32(size >> 16u);
    let xu = grad.x * w;
    let xv = grad.y * h;
    let yu = grad.z * w;
    let yv = grad.w * h;
    let x = xu * xu + xv * xv;
    let y = yu * yu + yv * yv;
    return max(x, y);
}

// `Texture::sample` (crates/oit-scene/src/texture.rs), its twin: magnification on level 0 where
// ρ² ≤ 1, else minification on level 0, the nearest level or the two around the level of
// detail blended. `size` = width | height << 16, 0 for no texture (samples as 1); `bits` is the
// slot's 12 sampler bits (see `Material::wrap`); `grad` the fine derivatives of `uv`.
fn sample_texture(first: u32, size: u32, bits: u32, uv: vec2<f32>, grad: vec4<f32>) -> vec4<f32> {
    if size == 0u {
        return vec4<f32>(1.0);
    }
    let rho2 = footprint_squared(size, grad);
    if !(rho2 > 1.0) {
        return filter_level(first, size, bits, 0u, ((bits >> 4u) & 1u) != 0u, uv);
    }
    let mip = (bits >> 6u) & 3u;
    // `Texture::levels`: the full chain with mipmaps, else level 0 alone.
    let levels = select(1u, firstLeadingBit(max(size & 0xffffu, size >> 16u)) + 1u, mip != 0u);
    // `Texture::lod`.
    let lod = min(0.5 * log2(rho2), f32(levels - 1u));
    let min_linear = ((bits >> 5u) & 1u) != 0u;
    if mip == 0u {
        return filter_level(first, size, bits, 0u, min_linear, uv);
    }
    if mip == 1u {
        return filter_level(first, size, bits, u32(floor(lod + 0.5)), min_linear, uv);
    }
    let l0 = floor(lod);
    let f = lod - l0;
    let l1 = min(u32(l0) + 1u, levels - 1u);
    let a = filter_level(first, size, bits, u32(l0), min_linear, uv);
    let b = filter_level(first, size, bits, l1, min_linear, uv);
    return a + (b - a) * f;
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

// `BlendOperator` on a transparent fragment shaded for `over` (premultiplied colour, coverage
// `alpha`): add and subtract leave what is behind undimmed (t = 1, α = 0), subtract negating
// the colour; multiply is the filter t = (1 − α) + P with no colour of its own. The twin of
// the operator arms of `Material::shade_lit` (tests/gpu/harness/operators.rs evaluates both).
fn apply_operator(over: Shaded, alpha: f32, blend_operator: u32) -> Shaded {
    var s = over;
    if blend_operator == OPERATOR_ADD {
        s.alpha = 0.0;
        s.transmittance = vec3<f32>(1.0);
    } else if blend_operator == OPERATOR_SUBTRACT {
        s.color = -s.color;
        s.alpha = 0.0;
        s.transmittance = vec3<f32>(1.0);
    } else if blend_operator == OPERATOR_MULTIPLY {
        let tt = vec3<f32>(1.0 - alpha) + s.color;
        s.color = vec3<f32>(0.0);
        s.transmittance = tt;
        s.alpha = 1.0 - (tt.r + tt.g + tt.b) * (1.0 / 3.0);
    }
    return s;
}

// `Material::shade`, plus back-face culling for single-sided materials. Pipelines also cull in
// fixed function; the test here makes passes with culling disabled (one pipeline for a globally
// sorted triangle stream) obey the same rule.
fn shade(v: VertexOut, front_facing: bool) -> Shaded {
    var grad = vec4<f32>(0.0);
    if TEXTURED {
        // Fine derivatives first, in uniform control flow (TEXTURED is a constant): the level
        // of detail of both slots (`quad_gradient` in crates/oit-reference/src/raster/shading.rs).
        let uv = texcoord(v);
        grad = vec4<f32>(dpdxFine(uv), dpdyFine(uv));
    }
    return shade_at(v, front_facing, grad);
}

// `shade` with the texture coordinates' fine derivatives `grad` = (du/dx, dv/dx, du/dy,
// dv/dy) given: passes that shade outside a rasterized quad (ray queries) compute them.
fn shade_at(v: VertexOut, front_facing: bool, grad: vec4<f32>) -> Shaded {
    var m = material_of(v);
    if UNIT_FACTORS {
        // The material's own values (`unit_factors` in crates/oit-gpu/src/scene.rs).
        m.base_alpha = vec4<f32>(1.0);
        m.intensity = 1.0;
        m.emissive = vec3<f32>(0.0);
        m.transmission = 0.0;
    }
    var t = vec4<f32>(1.0);
    var e = vec4<f32>(1.0);
    if TEXTURED {
        let uv = texcoord(v);
        t = sample_texture(m.textures.x, m.textures.y, m.wrap & 0xfffu, uv, grad);
        e = sample_texture(m.textures.z, m.textures.w, m.wrap >> 12u, uv, grad);
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
    if STRAIGHT_OVER {
        // = the general form below for `is_transparent`, `premultiplied == 0`, not `kept`
        // (unlit) and OVER_ONLY.
        s.color = alpha * (c + sp);
        s.alpha = alpha;
        s.transmittance = vec3<f32>(1.0 - alpha);
        return s;
    }
    if is_transparent(m.mode) {
        if m.premultiplied != 0u {
            s.color = c + sp;
        } else if kept {
            s.color = alpha * c + sp;
        } else {
            s.color = alpha * (c + sp);
        }
        s.alpha = alpha;
        if OVER_ONLY {
            // = the general form with m.transmission = 0 and the operator `over`.
            s.transmittance = vec3<f32>(1.0 - alpha);
        } else {
            let filtered = alpha * m.transmission;
            s.transmittance = vec3<f32>(1.0 - alpha) + filtered * lit;
            if m.transmission > 0.0 {
                // Scalar-alpha techniques composite the mean transmittance (exact for grey
                // filters): `opacity` of `Shaded::Transmissive`.
                let tt = s.transmittance;
                s.alpha = 1.0 - (tt.r + tt.g + tt.b) * (1.0 / 3.0);
            }
            s = apply_operator(s, alpha, m.blend_operator);
        }
    } else {
        s.color = c + sp;
        s.alpha = 1.0;
    }
    return s;
}
