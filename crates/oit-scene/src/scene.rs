//! The flattened, immutable `Scene`: the single source of truth that both the CPU reference
//! and every GPU technique consume. Everything the loader knows (instancing, billboards,
//! baked lighting, transforms) is already applied here, so the two sides evaluate the same
//! numbers and cannot disagree about what the scene is.

use crate::blending::{BlendOperator, Ordering, RenderQueue};
use crate::lighting::{LightRig, Reflectance, Specular, SurfacePoint};
use glam::{Mat4, Vec3, Vec4};

/// Output size in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Resolution {
    pub width: u32,
    pub height: u32,
}

impl Resolution {
    /// Largest accepted width or height. 8192² RGBA f32 is 1 GiB, about what a 24 GiB CI box can
    /// hold next to the reference's tiles and a readback copy.
    pub const MAX_DIMENSION: u32 = 8192;

    pub fn pixel_count(self) -> usize {
        self.width as usize * self.height as usize
    }

    pub fn aspect(self) -> f32 {
        self.width as f32 / self.height as f32
    }
}

impl std::fmt::Display for Resolution {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

/// Perspective (vertical field of view) or orthographic (vertical extent of the view volume).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    Perspective { fov_y_degrees: f32 },
    Orthographic { height: f32 },
}

/// Camera parameters plus the f32 matrices derived from them. The matrices are computed once
/// here; the GPU uploads them verbatim and the reference multiplies with the same values.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub projection: Projection,
    pub near: f32,
    pub far: f32,
    /// Reverse-Z maps near to window depth 1 and far to 0 (better float precision far away).
    pub reverse_z: bool,
    pub view: Mat4,
    pub proj: Mat4,
    pub view_proj: Mat4,
}

impl Camera {
    /// Builds the matrices for `aspect` (width / height). Right-handed view space, wgpu/Vulkan
    /// clip space (z in [0, 1]).
    #[allow(
        clippy::too_many_arguments,
        reason = "one plain constructor mirroring the scene file's camera fields"
    )]
    pub fn new(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        projection: Projection,
        near: f32,
        far: f32,
        reverse_z: bool,
        aspect: f32,
    ) -> Self {
        let view = glam::camera::rh::view::look_at_mat4(eye, target, up);
        // Reverse-Z is the same projection with near and far swapped: near → 1, far → 0.
        let (zn, zf) = if reverse_z { (far, near) } else { (near, far) };
        let proj = match projection {
            Projection::Perspective { fov_y_degrees } => {
                // wgpu's clip space is DirectX's: y up, z in [0, 1].
                glam::camera::rh::proj::directx::perspective(
                    fov_y_degrees.to_radians(),
                    aspect,
                    zn,
                    zf,
                )
            }
            Projection::Orthographic { height } => {
                let h = height * 0.5;
                let w = h * aspect;
                glam::camera::rh::proj::directx::orthographic(-w, w, -h, h, zn, zf)
            }
        };
        let view_proj = proj * view;
        Self {
            eye,
            target,
            up,
            projection,
            near,
            far,
            reverse_z,
            view,
            proj,
            view_proj,
        }
    }

    /// Clip-space position of a world-space point, with exactly the f32 operations the vertex
    /// shader performs (`view_proj * vec4(p, 1)`) on lavapipe: Mesa's SPIR-V translator sums the
    /// columns from the last one, `((c3 + c2·z) + c1·y) + c0·x`, each product and sum rounded
    /// (llvmpipe lowers the fused multiply-adds it emits to a multiply and an add). Vulkan leaves
    /// the order and fusion to the implementation; glam's `Mat4 * Vec4` sums from the first column
    /// and differed from the GPU in the last bit often enough to move single pixels.
    pub fn clip(&self, world: Vec3) -> Vec4 {
        let m = &self.view_proj;
        ((m.w_axis + m.z_axis * world.z) + m.y_axis * world.y) + m.x_axis * world.x
    }

    /// True when window depth `a` is strictly nearer to the camera than `b`.
    pub fn nearer(&self, a: f32, b: f32) -> bool {
        if self.reverse_z { a > b } else { a < b }
    }

    /// The window depth the depth buffer is cleared to (the far plane).
    pub fn far_depth(&self) -> f32 {
        if self.reverse_z { 0.0 } else { 1.0 }
    }
}

/// How a material treats coverage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AlphaMode {
    /// Coverage ignored; writes depth.
    Opaque,
    /// Discard below `cutoff`, otherwise opaque.
    Mask,
    /// Transparent.
    Blend,
    /// Discard below `cutoff`, blend the rest.
    MaskBlend,
}

impl AlphaMode {
    /// Opaque and mask materials write depth and occlude; the other two are transparent.
    pub fn is_transparent(self) -> bool {
        matches!(self, AlphaMode::Blend | AlphaMode::MaskBlend)
    }

    pub fn uses_cutoff(self) -> bool {
        matches!(self, AlphaMode::Mask | AlphaMode::MaskBlend)
    }
}

/// Material of one draw. See [`Material::shade`] for the one definition of fragment colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Linear RGB.
    pub base_color: [f32; 3],
    pub alpha: f32,
    pub mode: AlphaMode,
    pub cutoff: f32,
    pub double_sided: bool,
    /// The colour already carries coverage (C = rgb), instead of straight colour (C = α·rgb).
    pub premultiplied: bool,
    /// HDR multiplier on colour.
    pub intensity: f32,
    /// Index into [`Scene::textures`] whose sample multiplies colour and alpha (glTF
    /// `baseColorTexture`); `None` samples as 1.
    pub base_texture: Option<u32>,
    /// Linear RGB radiance added after the multiplications (glTF `emissiveFactor` ×
    /// `KHR_materials_emissive_strength`); not lit, not scaled by `intensity`.
    pub emissive: [f32; 3],
    /// Index into [`Scene::textures`] whose sample's rgb multiplies `emissive`.
    pub emissive_texture: Option<u32>,
    /// Thin-surface transmission factor τ in [0, 1] (glTF `KHR_materials_transmission`): of
    /// the covered part, τ is a coloured filter (the unlit base colour term) and 1 − τ reflects.
    /// 0 is scalar alpha, bit for bit; above 0 only in the transparent modes, straight alpha.
    pub transmission: f32,
    /// Lit per pixel by the scene's [`LightRig`] (`crate::lighting`); `None` is unlit: the
    /// albedo is the colour, as before lighting existed, bit for bit.
    pub reflectance: Option<Reflectance>,
    /// How a transparent fragment combines with what is behind it ([`BlendOperator`]); `Over`
    /// for opaque and mask modes.
    pub operator: BlendOperator,
    /// A transparent material whose fragments also write depth (pygfx's `auto` and "glowy
    /// opaque" additive objects): they hide fragments of later render queues behind them.
    /// Opaque and mask materials always write depth; this is false for them.
    pub depth_write: bool,
}

/// The texture samples one fragment's material reads; `UNTEXTURED` where it has none.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Texels {
    pub base: [f32; 4],
    pub emissive: [f32; 4],
}

impl Texels {
    /// What a material without textures samples: ones, which leave every product unchanged.
    pub const UNTEXTURED: Texels = Texels {
        base: [1.0; 4],
        emissive: [1.0; 4],
    };
}

/// What a fragment contributes after the material is applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shaded {
    /// Discarded by the mask cutoff.
    Discarded,
    /// Opaque colour (occluder).
    Opaque([f32; 3]),
    /// Premultiplied colour `C = α·c` and coverage `α`: what is behind is scaled by `1 − α`.
    Transparent { premultiplied: [f32; 3], alpha: f32 },
    /// A transmissive fragment (`transmission > 0`): premultiplied radiance `C` and a
    /// per-channel transmittance `t` that scales what is behind. `opacity` = 1 − mean(t) is
    /// what a scalar-alpha technique composites instead (exact when `t` is grey); the shader's
    /// `Shaded.alpha` carries it.
    Transmissive {
        premultiplied: [f32; 3],
        opacity: f32,
        transmittance: [f32; 3],
    },
}

impl Material {
    /// A plain material: the given colour and mode, no textures, no emission, intensity 1,
    /// straight alpha, single-sided, cutoff 0.5.
    pub fn plain(base_color: [f32; 3], alpha: f32, mode: AlphaMode) -> Material {
        Material {
            base_color,
            alpha,
            mode,
            cutoff: 0.5,
            double_sided: false,
            premultiplied: false,
            intensity: 1.0,
            base_texture: None,
            emissive: [0.0; 3],
            emissive_texture: None,
            transmission: 0.0,
            reflectance: None,
            operator: BlendOperator::Over,
            depth_write: false,
        }
    }

    /// Whether fragments carry a coloured transmittance ([`Shaded::Transmissive`]): a
    /// transmission factor above 0, or the `multiply` operator (a filter that adds nothing).
    pub fn is_transmissive(&self) -> bool {
        self.mode.is_transparent()
            && (self.transmission > 0.0 || self.operator == BlendOperator::Multiply)
    }

    /// Whether any texture is read (fragments then need their uv).
    pub fn is_textured(&self) -> bool {
        self.base_texture.is_some() || self.emissive_texture.is_some()
    }

    /// The textures this material reads, sampled at `uv` whose screen derivatives are `grad`
    /// = (du/dx, dv/dx, du/dy, dv/dy) ([`crate::Texture::sample`]).
    #[inline]
    pub fn texels(&self, textures: &[crate::Texture], uv: [f32; 2], grad: [f32; 4]) -> Texels {
        let sample = |t: Option<u32>| t.map_or([1.0; 4], |t| textures[t as usize].sample(uv, grad));
        Texels {
            base: sample(self.base_texture),
            emissive: sample(self.emissive_texture),
        }
    }

    /// The largest sample each texture slot can return: with non-negative inputs `shade` is
    /// monotone in the samples, so shading with these bounds every fragment of the material.
    pub fn max_texels(&self, textures: &[crate::Texture]) -> Texels {
        let max = |t: Option<u32>| t.map_or([1.0; 4], |t| textures[t as usize].max_texel());
        Texels {
            base: max(self.base_texture),
            emissive: max(self.emissive_texture),
        }
    }

    /// Fragment colour from the interpolated vertex colour and the texture samples, unlit:
    /// [`Material::shade_lit`] without a surface point.
    #[inline(always)]
    pub fn shade(&self, vertex_rgba: [f32; 4], texels: Texels) -> Shaded {
        self.shade_lit(vertex_rgba, texels, None)
    }

    /// Whether the material is lit per pixel (fragments then need their world position and
    /// normal, [`Material::shade_lit`]).
    pub fn is_lit(&self) -> bool {
        self.reflectance.is_some()
    }

    /// Fragment colour from the interpolated vertex colour, the texture samples and, for a lit
    /// material, the surface point and the scene's lights, in f32, as the shader computes it:
    /// `lit = vertex.rgb · base · texel.rgb` (the albedo); unlit, `diffuse = lit` and
    /// `specular = 0`, lit, both from [`crate::lighting::reflect_lights`]; `c = diffuse ·
    /// intensity · (1 − τ) + emissive · emissive_texel.rgb`, `s = specular · intensity ·
    /// (1 − τ)`, `α = vertex.a · alpha · texel.a`, `C = α·(c + s)` ([`Specular::Faded`]) or
    /// `α·c + s` ([`Specular::Kept`]), `c + s` when the material is premultiplied. Mask modes
    /// discard when `α < cutoff`. A transmissive material (τ > 0) also filters what is behind
    /// by `t = (1 − α) + α·τ·lit` per channel (the unlit albedo: transmitted light is not the
    /// light reflected), and its scalar opacity is `1 − mean(t)`. Untextured, the samples are
    /// 1 and the emission 0; τ = 0 multiplies by 1 and an unlit `s = 0` adds 0: none of them
    /// changes a bit of the products. Transparent fragments then apply the material's
    /// [`BlendOperator`] to the premultiplied `P` above: `add` keeps `P` with α 0 (nothing
    /// behind is dimmed), `subtract` negates it, `multiply` becomes the filter
    /// `t = (1 − α) + P` with no colour of its own.
    #[inline(always)]
    pub fn shade_lit(
        &self,
        vertex_rgba: [f32; 4],
        texels: Texels,
        surface: Option<(&LightRig, &SurfacePoint)>,
    ) -> Shaded {
        let t = texels.base;
        let e = texels.emissive;
        let lit = [
            vertex_rgba[0] * self.base_color[0] * t[0],
            vertex_rgba[1] * self.base_color[1] * t[1],
            vertex_rgba[2] * self.base_color[2] * t[2],
        ];
        let (reflected_light, kept) = match (&self.reflectance, surface) {
            (Some(r), Some((rig, point))) => (
                crate::lighting::reflect_lights(lit, r, rig, point),
                r.specular == Specular::Kept,
            ),
            _ => (
                crate::lighting::Reflected {
                    diffuse: lit,
                    specular: [0.0; 3],
                },
                false,
            ),
        };
        let d = reflected_light.diffuse;
        let sp = reflected_light.specular;
        let reflected = 1.0 - self.transmission;
        let c = [
            d[0] * self.intensity * reflected + self.emissive[0] * e[0],
            d[1] * self.intensity * reflected + self.emissive[1] * e[1],
            d[2] * self.intensity * reflected + self.emissive[2] * e[2],
        ];
        let s = [
            sp[0] * self.intensity * reflected,
            sp[1] * self.intensity * reflected,
            sp[2] * self.intensity * reflected,
        ];
        let alpha = vertex_rgba[3] * self.alpha * t[3];
        if self.mode.uses_cutoff() && alpha < self.cutoff {
            return Shaded::Discarded;
        }
        match self.mode {
            AlphaMode::Opaque | AlphaMode::Mask => {
                Shaded::Opaque([c[0] + s[0], c[1] + s[1], c[2] + s[2]])
            }
            AlphaMode::Blend | AlphaMode::MaskBlend => {
                let premultiplied = if self.premultiplied {
                    [c[0] + s[0], c[1] + s[1], c[2] + s[2]]
                } else if kept {
                    [
                        alpha * c[0] + s[0],
                        alpha * c[1] + s[1],
                        alpha * c[2] + s[2],
                    ]
                } else {
                    [
                        alpha * (c[0] + s[0]),
                        alpha * (c[1] + s[1]),
                        alpha * (c[2] + s[2]),
                    ]
                };
                match self.operator {
                    BlendOperator::Over => {}
                    // What is behind is not dimmed: t = 1, so the scalar alpha is 0.
                    BlendOperator::Add => {
                        return Shaded::Transparent {
                            premultiplied,
                            alpha: 0.0,
                        };
                    }
                    BlendOperator::Subtract => {
                        return Shaded::Transparent {
                            premultiplied: [
                                -premultiplied[0],
                                -premultiplied[1],
                                -premultiplied[2],
                            ],
                            alpha: 0.0,
                        };
                    }
                    // A filter: t = (1 − α) + P, which is (1 − α) + α·c for straight colour.
                    BlendOperator::Multiply => {
                        let transmittance = [
                            (1.0 - alpha) + premultiplied[0],
                            (1.0 - alpha) + premultiplied[1],
                            (1.0 - alpha) + premultiplied[2],
                        ];
                        let opacity = 1.0
                            - (transmittance[0] + transmittance[1] + transmittance[2])
                                * (1.0 / 3.0);
                        return Shaded::Transmissive {
                            premultiplied: [0.0; 3],
                            opacity,
                            transmittance,
                        };
                    }
                }
                if self.transmission > 0.0 {
                    let filtered = alpha * self.transmission;
                    let transmittance = [
                        (1.0 - alpha) + filtered * lit[0],
                        (1.0 - alpha) + filtered * lit[1],
                        (1.0 - alpha) + filtered * lit[2],
                    ];
                    // The scalar opacity of the fragment: 1 − the mean transmittance (a
                    // constant third on both sides, no division: GPUs may round it otherwise).
                    let opacity = 1.0
                        - (transmittance[0] + transmittance[1] + transmittance[2]) * (1.0 / 3.0);
                    return Shaded::Transmissive {
                        premultiplied,
                        opacity,
                        transmittance,
                    };
                }
                Shaded::Transparent {
                    premultiplied,
                    alpha,
                }
            }
        }
    }
}

/// One vertex of a non-indexed triangle list, already in world space.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[repr(C)]
pub struct Vertex {
    pub position: [f32; 3],
    /// Linear RGBA; lighting is baked in here at load time.
    pub color: [f32; 4],
    pub uv: [f32; 2],
    /// World-space unit normal (the glTF `NORMAL`, or the face normal where it has none);
    /// read only by lit materials, zero where the loader had none to give.
    pub normal: [f32; 3],
}

/// One draw call: a contiguous run of triangles with one material.
#[derive(Debug, Clone, PartialEq)]
pub struct Draw {
    /// Stable identity (index in the scene file's expanded object list). Draw *order* is the
    /// position in `Scene::draws`; the id does not change when that order is permuted, which
    /// is what makes the reference's tie-break order independent.
    pub id: u32,
    /// Human-readable name, e.g. `objects[3]` or `objects[2].instances[5]`.
    pub name: String,
    pub material: u32,
    /// Range in `Scene::vertices`; a multiple of 3.
    pub first_vertex: u32,
    pub vertex_count: u32,
    /// Where an engine draws it ([`Ordering`]: render group, queue, order, method).
    pub ordering: Ordering,
    /// Bounding sphere (world space) for per-object sorting.
    pub bounds_center: Vec3,
    pub bounds_radius: f32,
}

impl Draw {
    pub fn triangle_count(&self) -> u32 {
        self.vertex_count / 3
    }

    pub fn vertex_range(&self) -> std::ops::Range<usize> {
        self.first_vertex as usize..(self.first_vertex + self.vertex_count) as usize
    }
}

/// The loaded scene. Immutable: derive variants with the `with_*` methods.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    pub name: String,
    /// What the scene breaks, from the file.
    pub description: String,
    pub resolution: Resolution,
    pub camera: Camera,
    /// Linear RGB background (opaque).
    pub background: [f32; 3],
    pub materials: Vec<Material>,
    /// In draw order.
    pub draws: Vec<Draw>,
    pub vertices: Vec<Vertex>,
    /// Textures that materials index (8-bit codes with their mip chains, see [`crate::Texture`]).
    pub textures: Vec<crate::Texture>,
    /// What the loader read but does not model (e.g. a glTF extension), one line each, for
    /// `oit scenes` and reports. Empty for the JSON format.
    pub ignored: Vec<String>,
    /// Who made the content (a glTF asset's `asset.copyright`), shown wherever the scene is.
    pub credits: Vec<String>,
    /// Which frame of the scene's animation this is (0 for a still scene). Not part of the
    /// image the reference computes: techniques that vary over time (stochastic thresholds)
    /// key their per-frame sequence on it, so a static camera still sees fresh noise.
    pub frame: u32,
    /// The animation this frame belongs to (`None` for a still scene).
    pub animation: Option<crate::Animation>,
    /// The lights of lit materials ([`Material::reflectance`]); [`LightRig::none`] when no
    /// material is lit.
    pub lights: LightRig,
}

impl Camera {
    /// The terms that turn window depth back into view distance: `(a, b, ortho)` with a =
    /// proj[2][2], b = proj[3][2] of the f32 projection (the shaders' `view_distance` twins take
    /// them as uniforms).
    pub fn view_depth_terms(&self) -> (f32, f32, bool) {
        (
            self.proj.z_axis.z,
            self.proj.w_axis.z,
            matches!(self.projection, Projection::Orthographic { .. }),
        )
    }

    /// View distance of a window depth: CPU twin of the shaders' `view_distance`.
    pub fn view_distance(&self, window_z: f32) -> f32 {
        let (a, b, ortho) = self.view_depth_terms();
        if ortho {
            (b - window_z) / a
        } else {
            b / (window_z + a)
        }
    }
}

impl Scene {
    /// The view-distance interval `[near, far]` of the transparent vertices, clipped to the
    /// camera's near (at least `min_near`) and far planes; the whole frustum when there are
    /// none. Vertices rather than bounding spheres: a screen-filling quad's sphere reaches far
    /// in front of and behind the quad.
    pub fn transparent_view_depth_interval(&self, min_near: f32) -> (f32, f32) {
        let cam = &self.camera;
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for d in &self.draws {
            if !self.material_of(d).mode.is_transparent() {
                continue;
            }
            for v in &self.vertices[d.vertex_range()] {
                let z = -cam.view.transform_point3(Vec3::from(v.position)).z;
                lo = lo.min(z);
                hi = hi.max(z);
            }
        }
        let near = cam.near.max(min_near);
        let far = cam.far.max(near);
        if lo > hi || lo.is_nan() || hi.is_nan() {
            return (near, far);
        }
        let lo = lo.clamp(near, far);
        (lo, hi.clamp(lo, far))
    }

    pub fn material_of(&self, draw: &Draw) -> &Material {
        &self.materials[draw.material as usize]
    }

    pub fn triangle_count(&self) -> usize {
        self.draws.iter().map(|d| d.triangle_count() as usize).sum()
    }

    /// The render queue a draw is in: the file's, or the one pygfx derives from the object's
    /// method and the material ([`RenderQueue::derived`]).
    pub fn queue_of(&self, draw: &Draw) -> RenderQueue {
        let m = self.material_of(draw);
        draw.ordering
            .queue
            .unwrap_or_else(|| RenderQueue::derived(m.mode, m.depth_write, draw.ordering.method))
    }

    /// Transparent draws (indices into `draws`) in the order engines draw them
    /// ([`Ordering`]): render group ascending, then render queue, then render order (Babylon's
    /// alphaIndex), then distance from the eye to the bounding sphere centre, far first (near
    /// first in queues 1501–2500). The sort is stable: draws that tie on every key keep their
    /// draw order, so the later-drawn one lands on top, which is the reference's tie-break for
    /// coplanar fragments in natural draw order.
    pub fn babylon_object_order(&self) -> Vec<usize> {
        self.engine_order(|d| self.material_of(d).mode.is_transparent())
    }

    /// The draws `keep` selects, in the engine order of [`Scene::babylon_object_order`]
    /// (queues from [`Scene::exact_queue_of`]: the per-object method is not read).
    pub fn engine_order(&self, keep: impl Fn(&Draw) -> bool) -> Vec<usize> {
        let eye = self.camera.eye;
        let mut order: Vec<(usize, (u32, RenderQueue, i32), f32)> = self
            .draws
            .iter()
            .enumerate()
            .filter(|(_, d)| keep(d))
            .map(|(i, d)| {
                // Whole-scene techniques draw every object with their own method, so the
                // per-object method does not move an object between queues here.
                let queue = self.exact_queue_of(d);
                let distance = d.bounds_center.distance(eye);
                // Far first, except in the front-to-back queues.
                let key = if queue.front_to_back() {
                    distance
                } else {
                    -distance
                };
                (i, (d.ordering.group, queue, d.ordering.order), key)
            })
            .collect();
        order.sort_by(|a, b| a.1.cmp(&b.1).then(a.2.total_cmp(&b.2)));
        order.into_iter().map(|(i, ..)| i).collect()
    }

    /// The blend operators other than `over` that some transparent draw composites with, each
    /// once, in [`BlendOperator::ALL`] order.
    pub fn operators_used(&self) -> Vec<BlendOperator> {
        BlendOperator::ALL
            .into_iter()
            .filter(|&op| op != BlendOperator::Over)
            .filter(|&op| {
                self.draws.iter().any(|d| {
                    let m = self.material_of(d);
                    m.mode.is_transparent() && m.operator == op
                })
            })
            .collect()
    }

    /// Whether any draw's fragments carry coloured transmittance: techniques that composite
    /// scalar alpha only are skipped on such scenes, with the reason.
    pub fn has_transmission(&self) -> bool {
        self.draws
            .iter()
            .any(|d| self.material_of(d).is_transmissive())
    }

    /// Whether some transmissive draw's filter may differ between channels (a non-grey base
    /// colour, a base texture, or a non-grey vertex colour): where it cannot, `t` is grey and
    /// scalar-alpha techniques composite it with `1 − mean(t)`, which equals it up to f32
    /// rounding.
    pub fn has_coloured_transmission(&self) -> bool {
        let grey = |c: &[f32]| c[0] == c[1] && c[1] == c[2];
        self.draws.iter().any(|d| {
            let m = self.material_of(d);
            m.is_transmissive()
                && (!grey(&m.base_color)
                    || m.base_texture.is_some()
                    || self.vertices[d.vertex_range()]
                        .iter()
                        .any(|v| !grey(&v.color)))
        })
    }

    pub fn transparent_triangle_count(&self) -> usize {
        self.draws
            .iter()
            .filter(|d| self.material_of(d).mode.is_transparent())
            .map(|d| d.triangle_count() as usize)
            .sum()
    }

    /// Same scene rendered at another size; the projection follows the new aspect ratio.
    pub fn with_resolution(&self, resolution: Resolution) -> Scene {
        let c = &self.camera;
        let camera = Camera::new(
            c.eye,
            c.target,
            c.up,
            c.projection,
            c.near,
            c.far,
            c.reverse_z,
            resolution.aspect(),
        );
        Scene {
            resolution,
            camera,
            ..self.clone()
        }
    }

    /// Same scene with the draw list permuted (ids kept). `order[i]` is the index into the
    /// current draw list of the draw that goes i-th.
    pub fn with_draw_order(&self, order: &[usize]) -> Scene {
        assert_eq!(
            order.len(),
            self.draws.len(),
            "draw order must be a permutation"
        );
        let draws = order.iter().map(|&i| self.draws[i].clone()).collect();
        Scene {
            draws,
            ..self.clone()
        }
    }

    /// Same scene with the draw order reversed: the cheap probe of order dependence.
    pub fn with_reversed_draw_order(&self) -> Scene {
        let order: Vec<usize> = (0..self.draws.len()).rev().collect();
        self.with_draw_order(&order)
    }

    /// Same scene with everything submitted in reverse: the draw list reversed and, within
    /// each draw, its triangles (each triangle keeps its vertices, so its facing). The probe of
    /// order dependence: a technique whose image changes depends on submission order, whether
    /// between draws or between the triangles of one draw (24 000 particles in one draw).
    pub fn with_reversed_order(&self) -> Scene {
        let mut scene = self.with_reversed_draw_order();
        let mut ranges: Vec<std::ops::Range<usize>> =
            self.draws.iter().map(Draw::vertex_range).collect();
        ranges.sort_by_key(|r| (r.start, r.end));
        ranges.dedup();
        for range in ranges {
            let triangles = &mut scene.vertices[range];
            let whole = triangles.len() - triangles.len() % 3;
            // Reversing the vertices reverses the triangles and each one's vertex order;
            // reversing each triple again restores its winding.
            triangles[..whole].reverse();
            for triangle in triangles[..whole].chunks_exact_mut(3) {
                triangle.reverse();
            }
        }
        scene
    }

    /// A 64-bit FNV-1a hash of everything that affects the rendered image, for caching
    /// references on disk. Draw order is included (it can change tie-breaks on the GPU side).
    pub fn content_hash(&self) -> u64 {
        let mut h = Fnv64::new();
        h.u32(self.resolution.width);
        h.u32(self.resolution.height);
        for m in self.camera.view_proj.to_cols_array() {
            h.f32(m);
        }
        h.u32(self.camera.reverse_z as u32);
        for c in self.background {
            h.f32(c);
        }
        for m in &self.materials {
            for c in m.base_color {
                h.f32(c);
            }
            h.f32(m.alpha);
            h.u32(m.mode as u32);
            h.f32(m.cutoff);
            h.u32(m.double_sided as u32);
            h.u32(m.premultiplied as u32);
            h.f32(m.intensity);
            for t in [m.base_texture, m.emissive_texture] {
                h.u32(t.map_or(u32::MAX, |t| t));
            }
            for c in m.emissive {
                h.f32(c);
            }
            // Hashed only when set, so scenes without transmission keep their hashes.
            if m.transmission != 0.0 {
                h.f32(m.transmission);
            }
            // Likewise lighting: unlit scenes keep their hashes.
            if let Some(r) = m.reflectance {
                h.f32(r.metallic);
                h.f32(r.roughness);
                h.u32(r.specular as u32);
            }
        }
        if self.materials.iter().any(Material::is_lit) {
            for c in self.lights.ambient {
                h.f32(c);
            }
            for l in &self.lights.lights {
                h.u32(l.kind.code());
                for x in l.position.iter().chain(&l.direction).chain(&l.radiance) {
                    h.f32(*x);
                }
                h.f32(l.range);
                h.f32(l.cone_scale);
                h.f32(l.cone_offset);
            }
            for v in &self.vertices {
                for x in v.normal {
                    h.f32(x);
                }
            }
        }
        for t in &self.textures {
            h.u32(t.width());
            h.u32(t.height());
            h.u32(t.sampler().code() | (t.encoding() as u32) << 16);
            for code in t.codes() {
                h.u32(*code);
            }
        }
        for d in &self.draws {
            h.u32(d.id);
            h.u32(d.material);
            h.u32(d.first_vertex);
            h.u32(d.vertex_count);
        }
        for v in &self.vertices {
            for x in v.position.iter().chain(&v.color).chain(&v.uv) {
                h.f32(*x);
            }
        }
        h.finish()
    }
}

/// Minimal FNV-1a, enough for a cache key (not for security).
struct Fnv64(u64);

impl Fnv64 {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= u64::from(*b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.bytes(&v.to_bits().to_le_bytes());
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// A linear RGBA f32 image, row-major from the top-left (the framebuffer's orientation).
#[derive(Debug, Clone, PartialEq)]
pub struct LinearImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 4]>,
}

impl LinearImage {
    pub fn new(width: u32, height: u32, fill: [f32; 4]) -> Self {
        Self {
            width,
            height,
            pixels: vec![fill; width as usize * height as usize],
        }
    }

    pub fn get(&self, x: u32, y: u32) -> [f32; 4] {
        self.pixels[y as usize * self.width as usize + x as usize]
    }
}
