//! Textures as engines store them, and the one sampling rule the GPU and the reference share.
//!
//! **Storage.** Every texel is its four 8-bit code values packed in a `u32` (r | g << 8 |
//! b << 16 | a << 24), on the CPU and on the GPU: 4 bytes a texel, a quarter of linear RGBA f32.
//! Codes decode through two 256-entry tables computed once on the CPU ([`decode_tables`]: sRGB
//! for the rgb of colour textures with [`srgb_to_linear`], UNORM `code / 255` in f64 rounded once
//! for alpha and data), which the GPU receives as they are, so both sides read the same f32
//! values. No hardware sRGB format and no `unpack4x8unorm` (a division, 2.5 ulp in WGSL).
//! 16-bit images are quantised to 8 bits (round to nearest) at load, as engines do, and the
//! loader says so in `Scene::ignored`.
//!
//! **Mipmaps.** When the glTF sampler's `minFilter` uses mipmaps (or is undefined, which engines
//! take as LINEAR_MIPMAP_LINEAR) the chain is built once here ([`Texture::new`]): a 2×2 box
//! filter, colour averaged in linear light and re-encoded to the nearest 8-bit sRGB code, alpha
//! and data averaged as UNORM codes and rounded. The stored codes are the truth both sides
//! decode.
//!
//! **Sampling.** Hardware filtering cannot be mirrored on the CPU (fixed-point weights of
//! implementation-defined precision, implicit level-of-detail selection), so every pass samples
//! with [`Texture::sample`]'s twin in crates/oit-gpu/shaders/common.wgsl (`sample_texture`):
//! `textureLoad`-style integer fetches, filters computed in f32 in the same order, the glTF wrap
//! modes applied to integer texel coordinates, and the level of detail from the texture
//! coordinate's fine screen derivatives by Vulkan's isotropic rule ([`Texture::sample`]). The two
//! stay line-comparable.

use std::sync::OnceLock;

/// How a texel coordinate outside the image is brought back (glTF sampler `wrapS`/`wrapT`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Wrap {
    /// glTF 10497, the default.
    #[default]
    Repeat,
    /// glTF 33648.
    MirroredRepeat,
    /// glTF 33071.
    ClampToEdge,
}

impl Wrap {
    /// The code the shader receives (two bits; see `wrap_texel` in crates/oit-gpu/shaders/common.wgsl).
    pub fn code(self) -> u32 {
        match self {
            Wrap::Repeat => 0,
            Wrap::MirroredRepeat => 1,
            Wrap::ClampToEdge => 2,
        }
    }

    /// `i` brought into `0..size` (size > 0). Mirrors `wrap_texel` in crates/oit-gpu/shaders/common.wgsl.
    #[inline(always)]
    pub fn apply(self, i: i32, size: i32) -> i32 {
        // Inside the texture every mode leaves `i` as it is; only the rest pays for the
        // remainders (two integer divisions per texel, four texels per bilinear sample).
        if (0..size).contains(&i) {
            return i;
        }
        match self {
            Wrap::Repeat => i.rem_euclid(size),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * size);
                if m >= size { 2 * size - 1 - m } else { m }
            }
            Wrap::ClampToEdge => i.clamp(0, size - 1),
        }
    }
}

/// A texture filter of the glTF sampler (`magFilter`, and `minFilter`'s filter within a level).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Filter {
    /// glTF 9728: the texel the coordinate falls in.
    Nearest,
    /// glTF 9729: bilinear between the four nearest texel centres.
    #[default]
    Linear,
}

/// How `minFilter` chooses between mipmap levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum MipFilter {
    /// NEAREST or LINEAR: level 0 only (no chain is built).
    None,
    /// *_MIPMAP_NEAREST: the nearest level.
    Nearest,
    /// *_MIPMAP_LINEAR: the two nearest levels, blended (trilinear with a LINEAR filter).
    #[default]
    Linear,
}

/// The glTF sampler of a texture. The default is what engines use where glTF leaves the
/// filters undefined: REPEAT, LINEAR magnification, LINEAR_MIPMAP_LINEAR minification.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Sampler {
    pub wrap_u: Wrap,
    pub wrap_v: Wrap,
    /// `magFilter`: used where the level of detail is ≤ 0.
    pub mag: Filter,
    /// `minFilter`'s filter within a level.
    pub min: Filter,
    /// `minFilter`'s choice of levels.
    pub mip: MipFilter,
}

impl Sampler {
    /// The filters from glTF's `magFilter` and `minFilter` codes (None: undefined, taken as
    /// LINEAR and LINEAR_MIPMAP_LINEAR). An unknown code is an error naming what is allowed.
    pub fn with_gltf_filters(
        mut self,
        mag: Option<u32>,
        min: Option<u32>,
    ) -> Result<Sampler, String> {
        self.mag = match mag {
            None | Some(9729) => Filter::Linear,
            Some(9728) => Filter::Nearest,
            Some(c) => {
                return Err(format!(
                    "magFilter {c}; allowed: 9728 (NEAREST), 9729 (LINEAR)"
                ));
            }
        };
        (self.min, self.mip) = match min {
            Some(9728) => (Filter::Nearest, MipFilter::None),
            Some(9729) => (Filter::Linear, MipFilter::None),
            Some(9984) => (Filter::Nearest, MipFilter::Nearest),
            Some(9985) => (Filter::Linear, MipFilter::Nearest),
            Some(9986) => (Filter::Nearest, MipFilter::Linear),
            None | Some(9987) => (Filter::Linear, MipFilter::Linear),
            Some(c) => {
                return Err(format!(
                    "minFilter {c}; allowed: 9728, 9729, 9984, 9985, 9986, 9987"
                ));
            }
        };
        Ok(self)
    }

    /// The bits the shader receives (9 of them; see `sample_texture` in
    /// crates/oit-gpu/shaders/common.wgsl): wrap u | wrap v << 2 | mag linear << 4 | min linear
    /// << 5 | mip filter << 6 (0 none, 1 nearest, 2 linear).
    pub fn code(self) -> u32 {
        let mip = match self.mip {
            MipFilter::None => 0,
            MipFilter::Nearest => 1,
            MipFilter::Linear => 2,
        };
        self.wrap_u.code()
            | self.wrap_v.code() << 2
            | u32::from(self.mag == Filter::Linear) << 4
            | u32::from(self.min == Filter::Linear) << 5
            | mip << 6
    }
}

/// What a texture's rgb codes mean. Alpha is always UNORM.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Encoding {
    /// Colour (base colour, emissive): sRGB-encoded rgb.
    #[default]
    Srgb,
    /// Data: UNORM rgb, `code / 255`.
    Unorm,
}

/// Largest |u| or |v| a vertex may carry. Beyond it the f32 texel coordinate `u·size` has no
/// fractional bits left at the largest texture size (2^20 · 8192 = 2^33 > 2^24) and the integer
/// texel index would leave i32; the loader rejects such coordinates.
pub const MAX_UV: f32 = 1_048_576.0;

/// Largest texture width or height (the smallest `maxTextureDimension2D` wgpu guarantees).
pub const MAX_TEXTURE_DIMENSION: u32 = 8192;

/// The two decode tables, computed once: `[0..256)` sRGB → linear ([`srgb_to_linear`] of
/// `c / 255` in f64), `[256..512)` UNORM (`c / 255` in f64, rounded once to f32). The GPU
/// receives exactly these 512 values (shaders/common.wgsl `texel_decode`).
pub fn decode_tables() -> &'static [f32; 512] {
    static TABLES: OnceLock<[f32; 512]> = OnceLock::new();
    TABLES.get_or_init(|| {
        std::array::from_fn(|k| {
            let code = (k % 256) as f64 / 255.0;
            if k < 256 {
                srgb_to_linear(code)
            } else {
                code as f32
            }
        })
    })
}

/// Where the UNORM table starts in [`decode_tables`].
pub const UNORM_TABLE: usize = 256;

/// The 8-bit sRGB code nearest to linear `value` (encoded in f64, rounded to nearest): how a
/// mipmap level re-encodes its averaged colour.
pub fn linear_to_srgb_code(value: f64) -> u8 {
    let v = value.clamp(0.0, 1.0);
    let encoded = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (encoded * 255.0).round().clamp(0.0, 255.0) as u8
}

/// Packs four 8-bit codes as the GPU stores them.
pub fn pack_rgba8(c: [u8; 4]) -> u32 {
    u32::from_le_bytes(c)
}

/// A texture: 8-bit RGBA codes of every mipmap level (level 0 first, each row-major from the
/// image's top-left, which is glTF's uv origin: v grows downwards), how they decode, and the
/// glTF sampler. Built only by [`Texture::new`], so sizes, codes and levels always agree.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// Where it came from, e.g. `AlphaBlendModeTest.glb /images/3`.
    pub name: String,
    width: u32,
    height: u32,
    encoding: Encoding,
    sampler: Sampler,
    /// 1 without mipmaps, else the full chain down to 1×1.
    levels: u32,
    /// Packed codes ([`pack_rgba8`]) of every level, one after the other; shared by clones
    /// (a scene is cloned into each GPU upload and each reference job).
    codes: std::sync::Arc<[u32]>,
    /// The largest code of each channel over every level, packed as a code: found once here,
    /// since every technique that bounds a scene's colours asks for it (WBOIT's colour scale
    /// per uploaded scene: 16 % of a WBOIT test's time went to scanning the same textures).
    max_codes: u32,
}

/// Size of level `k` of a `width`×`height` texture (halved, at least 1).
pub fn level_size(width: u32, height: u32, k: u32) -> (u32, u32) {
    ((width >> k).max(1), (height >> k).max(1))
}

impl Texture {
    /// A texture from its level-0 codes (`width·height` packed codes, row-major); builds the
    /// mip chain when the sampler's minification uses mipmaps. Errors name what is allowed.
    pub fn new(
        name: impl Into<String>,
        width: u32,
        height: u32,
        level0: Vec<u32>,
        encoding: Encoding,
        sampler: Sampler,
    ) -> Result<Texture, String> {
        let name = name.into();
        if !(1..=MAX_TEXTURE_DIMENSION).contains(&width)
            || !(1..=MAX_TEXTURE_DIMENSION).contains(&height)
        {
            return Err(format!(
                "texture {name:?}: {width}x{height}; allowed: 1..={MAX_TEXTURE_DIMENSION} per side"
            ));
        }
        if level0.len() != width as usize * height as usize {
            return Err(format!(
                "texture {name:?}: {} codes for {width}x{height}; allowed: width·height",
                level0.len()
            ));
        }
        let levels = match sampler.mip {
            MipFilter::None => 1,
            _ => 32 - width.max(height).leading_zeros(),
        };
        let mut codes = level0;
        for k in 1..levels {
            let (pw, ph) = level_size(width, height, k - 1);
            let start = codes.len() - pw as usize * ph as usize;
            let next = downsample(&codes[start..], pw, ph, encoding);
            codes.extend(next);
        }
        let mut max = [0u32; 4];
        for c in &codes {
            for (k, m) in max.iter_mut().enumerate() {
                *m = (*m).max(c >> (8 * k) & 0xff);
            }
        }
        Ok(Texture {
            name,
            width,
            height,
            encoding,
            sampler,
            levels,
            codes: codes.into(),
            max_codes: max[0] | max[1] << 8 | max[2] << 16 | max[3] << 24,
        })
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    pub fn encoding(&self) -> Encoding {
        self.encoding
    }

    pub fn sampler(&self) -> Sampler {
        self.sampler
    }

    /// Mipmap levels stored (1 without mipmaps).
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Packed codes of every level, level 0 first (what the GPU stores).
    pub fn codes(&self) -> &[u32] {
        &self.codes
    }

    /// First code of level `k` in [`Texture::codes`]. Mirrors `level_first` in
    /// crates/oit-gpu/shaders/common.wgsl.
    pub fn level_offset(&self, k: u32) -> usize {
        (0..k)
            .map(|l| {
                let (w, h) = level_size(self.width, self.height, l);
                w as usize * h as usize
            })
            .sum()
    }

    /// Packed codes of level `k`.
    pub fn level_codes(&self, k: u32) -> &[u32] {
        let (w, h) = level_size(self.width, self.height, k);
        let first = self.level_offset(k);
        &self.codes[first..first + w as usize * h as usize]
    }

    /// Level-0 texel `k`, decoded.
    pub fn texel(&self, k: usize) -> [f32; 4] {
        self.decode(self.codes[k])
    }

    /// Bytes the GPU copy takes: 4 per texel, every level.
    pub fn gpu_bytes(&self) -> u64 {
        self.codes.len() as u64 * 4
    }

    /// Always true: [`Texture::new`] checks sizes and codes (kept for callers that validate
    /// scenes).
    pub fn is_consistent(&self) -> bool {
        self.codes.len() == self.level_offset(self.levels)
    }

    /// A packed code as linear RGBA f32, through [`decode_tables`]. Mirrors `decode_texel` in
    /// crates/oit-gpu/shaders/common.wgsl.
    #[inline(always)]
    pub fn decode(&self, code: u32) -> [f32; 4] {
        let table = decode_tables();
        let rgb = match self.encoding {
            Encoding::Srgb => 0,
            Encoding::Unorm => UNORM_TABLE,
        };
        [
            table[rgb + (code & 0xff) as usize],
            table[rgb + (code >> 8 & 0xff) as usize],
            table[rgb + (code >> 16 & 0xff) as usize],
            table[UNORM_TABLE + (code >> 24) as usize],
        ]
    }

    /// The largest value of each channel over every level: the most any sample can return
    /// (filter weights are convex).
    pub fn max_texel(&self) -> [f32; 4] {
        self.decode(self.max_codes)
    }

    #[inline(always)]
    fn texel_at(&self, first: usize, width: u32, height: u32, i: i32, j: i32) -> [f32; 4] {
        let x = self.sampler.wrap_u.apply(i, width as i32);
        let y = self.sampler.wrap_v.apply(j, height as i32);
        self.decode(self.codes[first + y as usize * width as usize + x as usize])
    }

    /// `filter` on level `level` at `uv` (texel centres at (i + 0.5) / size), in f32 in the
    /// order of `filter_level` in crates/oit-gpu/shaders/common.wgsl: bilinear is `a + (b − a)·f`
    /// along u, then along v.
    #[inline]
    pub fn filter_level(&self, level: u32, filter: Filter, uv: [f32; 2]) -> [f32; 4] {
        let (width, height) = level_size(self.width, self.height, level);
        let first = self.level_offset(level);
        if filter == Filter::Nearest {
            let i = (uv[0] * width as f32).floor() as i32;
            let j = (uv[1] * height as f32).floor() as i32;
            return self.texel_at(first, width, height, i, j);
        }
        let x = uv[0] * width as f32 - 0.5;
        let y = uv[1] * height as f32 - 0.5;
        let x0 = x.floor();
        let y0 = y.floor();
        let fx = x - x0;
        let fy = y - y0;
        let i = x0 as i32;
        let j = y0 as i32;
        let t00 = self.texel_at(first, width, height, i, j);
        let t10 = self.texel_at(first, width, height, i.wrapping_add(1), j);
        let t01 = self.texel_at(first, width, height, i, j.wrapping_add(1));
        let t11 = self.texel_at(first, width, height, i.wrapping_add(1), j.wrapping_add(1));
        std::array::from_fn(|k| {
            let top = t00[k] + (t10[k] - t00[k]) * fx;
            let bottom = t01[k] + (t11[k] - t01[k]) * fx;
            top + (bottom - top) * fy
        })
    }

    /// ρ² of Vulkan's isotropic level-of-detail rule: the larger squared length of the texel
    /// footprint's two screen axes, from `grad` = (du/dx, dv/dx, du/dy, dv/dy). Mirrors
    /// `footprint_squared` in crates/oit-gpu/shaders/common.wgsl.
    #[inline(always)]
    pub fn footprint_squared(&self, grad: [f32; 4]) -> f32 {
        let w = self.width as f32;
        let h = self.height as f32;
        let xu = grad[0] * w;
        let xv = grad[1] * h;
        let yu = grad[2] * w;
        let yv = grad[3] * h;
        let x = xu * xu + xv * xv;
        let y = yu * yu + yv * yv;
        x.max(y)
    }

    /// The level of detail for a footprint ρ² > 1: `log2(ρ) = 0.5·log2(ρ²)`, clamped to the
    /// last level. Mirrors `texture_lod` in crates/oit-gpu/shaders/common.wgsl.
    #[inline(always)]
    pub fn lod(&self, rho2: f32) -> f32 {
        (0.5 * rho2.log2()).min((self.levels - 1) as f32)
    }

    /// The sample at `uv` with screen derivatives `grad` = (du/dx, dv/dx, du/dy, dv/dy): the
    /// magnification filter on level 0 where ρ² ≤ 1 (level of detail ≤ 0, decided without a
    /// logarithm), else the minification filter on the level the mip filter picks: level 0,
    /// the nearest (⌊lod + 0.5⌋), or the two around `lod` blended by its fraction. f32 in the
    /// order of `sample_texture` in crates/oit-gpu/shaders/common.wgsl, its twin.
    #[inline]
    pub fn sample(&self, uv: [f32; 2], grad: [f32; 4]) -> [f32; 4] {
        let rho2 = self.footprint_squared(grad);
        // Written as the shader writes it: NaN magnifies too.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(rho2 > 1.0) {
            return self.filter_level(0, self.sampler.mag, uv);
        }
        let lod = self.lod(rho2);
        match self.sampler.mip {
            MipFilter::None => self.filter_level(0, self.sampler.min, uv),
            MipFilter::Nearest => {
                self.filter_level((lod + 0.5).floor() as u32, self.sampler.min, uv)
            }
            MipFilter::Linear => {
                let l0 = lod.floor();
                let f = lod - l0;
                let l1 = (l0 as u32 + 1).min(self.levels - 1);
                let a = self.filter_level(l0 as u32, self.sampler.min, uv);
                let b = self.filter_level(l1, self.sampler.min, uv);
                std::array::from_fn(|k| a[k] + (b[k] - a[k]) * f)
            }
        }
    }

    /// Smallest and largest alpha of the 4×4 texels of level `level` around `uv`'s bilinear
    /// footprint: every value a sample of that level within a texel of `uv` can blend, with
    /// either filter (the footprint moves by one texel when the coordinate crosses a centre).
    pub fn alpha_range_near(&self, level: u32, uv: [f32; 2]) -> (f32, f32) {
        let (width, height) = level_size(self.width, self.height, level);
        let first = self.level_offset(level);
        let i = (uv[0] * width as f32 - 0.5).floor() as i32;
        let j = (uv[1] * height as f32 - 0.5).floor() as i32;
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for dj in -1..=2 {
            for di in -1..=2 {
                let a =
                    self.texel_at(first, width, height, i.wrapping_add(di), j.wrapping_add(dj))[3];
                lo = lo.min(a);
                hi = hi.max(a);
            }
        }
        (lo, hi)
    }
}

/// One mipmap step: each texel the 2×2 box of the level above (coordinates clamped, so an odd
/// last row or column is dropped and a 1-wide side repeats). sRGB colour is averaged in linear
/// light (f64) and re-encoded to the nearest code; alpha and UNORM data average the codes,
/// rounded half up.
fn downsample(src: &[u32], width: u32, height: u32, encoding: Encoding) -> Vec<u32> {
    let (w, h) = ((width >> 1).max(1), (height >> 1).max(1));
    let table = decode_tables();
    let mut out = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h {
        for x in 0..w {
            let xs = [(2 * x).min(width - 1), (2 * x + 1).min(width - 1)];
            let ys = [(2 * y).min(height - 1), (2 * y + 1).min(height - 1)];
            let quad = [
                src[(ys[0] * width + xs[0]) as usize],
                src[(ys[0] * width + xs[1]) as usize],
                src[(ys[1] * width + xs[0]) as usize],
                src[(ys[1] * width + xs[1]) as usize],
            ];
            let channel = |k: u32| -> u8 {
                let codes = quad.map(|c| (c >> (8 * k) & 0xff) as usize);
                if k < 3 && encoding == Encoding::Srgb {
                    let sum: f64 = codes.iter().map(|&c| f64::from(table[c])).sum();
                    linear_to_srgb_code(sum / 4.0)
                } else {
                    ((codes.iter().sum::<usize>() + 2) / 4) as u8
                }
            };
            out.push(pack_rgba8([channel(0), channel(1), channel(2), channel(3)]));
        }
    }
    out
}

/// The sRGB transfer function's inverse (IEC 61966-2-1), in f64 rounded once to f32: what a
/// colour texture's 8- or 16-bit code means in linear light. Decoded on the CPU once per texel;
/// the GPU receives the f32 values, so both sides sample the same numbers.
pub fn srgb_to_linear(encoded: f64) -> f32 {
    let c = encoded.clamp(0.0, 1.0);
    let linear = if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    };
    linear as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Linear magnification and minification without mipmaps: plain bilinear on level 0.
    fn bilinear(wrap: Wrap) -> Sampler {
        Sampler {
            wrap_u: wrap,
            wrap_v: wrap,
            mip: MipFilter::None,
            ..Sampler::default()
        }
    }

    /// Data codes (UNORM) r = x, g = y, b = x + 10·y, a = 255.
    fn ramp(width: u32, height: u32, sampler: Sampler) -> Texture {
        let codes = (0..width * height)
            .map(|k| {
                let (x, y) = ((k % width) as u8, (k / width) as u8);
                pack_rgba8([x, y, x + 10 * y, 255])
            })
            .collect();
        Texture::new("ramp", width, height, codes, Encoding::Unorm, sampler).unwrap()
    }

    const STILL: [f32; 4] = [0.0; 4];

    fn unorm(c: u8) -> f32 {
        (f64::from(c) / 255.0) as f32
    }

    #[test]
    fn decoding_through_the_tables_is_bit_exact() {
        let srgb = Texture::new("s", 1, 1, vec![0], Encoding::Srgb, Sampler::default()).unwrap();
        let data = Texture::new("d", 1, 1, vec![0], Encoding::Unorm, Sampler::default()).unwrap();
        for c in 0..=255u8 {
            let code = pack_rgba8([c, c, c, c]);
            let linear = srgb_to_linear(f64::from(c) / 255.0);
            assert_eq!(
                srgb.decode(code),
                [linear, linear, linear, unorm(c)],
                "code {c}"
            );
            assert_eq!(data.decode(code), [unorm(c); 4], "code {c}");
            assert_eq!(decode_tables()[c as usize].to_bits(), linear.to_bits());
        }
        // The channels are where the GPU unpacks them.
        assert_eq!(
            data.decode(pack_rgba8([1, 2, 3, 4])),
            [unorm(1), unorm(2), unorm(3), unorm(4)]
        );
    }

    #[test]
    fn srgb_re_encoding_inverts_decoding() {
        for c in 0..=255u8 {
            let linear = srgb_to_linear(f64::from(c) / 255.0);
            assert_eq!(linear_to_srgb_code(f64::from(linear)), c);
        }
    }

    #[test]
    fn mip_chain_of_a_known_image() {
        // 4×2, sRGB: left 2×2 black and white in linear light, right 2×2 all code 100.
        let black = pack_rgba8([0, 0, 0, 0]);
        let white = pack_rgba8([255, 255, 255, 255]);
        let grey = pack_rgba8([100, 100, 100, 255]);
        let level0 = vec![black, white, grey, grey, white, white, grey, grey];
        let t = Texture::new("known", 4, 2, level0, Encoding::Srgb, Sampler::default()).unwrap();
        assert_eq!(t.levels(), 3);
        assert_eq!(t.gpu_bytes(), (8 + 2 + 1) * 4);
        // Mean linear 0.75 of white and black; alpha (0 + 3·255 + 2) / 4 = 191.
        let mean = linear_to_srgb_code(0.75);
        assert_eq!(mean, 225);
        assert_eq!(
            t.level_codes(1),
            [pack_rgba8([mean, mean, mean, 191]), grey]
        );
        // Level 2 (1×1) averages level 1's two texels, each twice (the 1-high side repeats).
        let (a, b) = (
            f64::from(srgb_to_linear(f64::from(mean) / 255.0)),
            f64::from(srgb_to_linear(100.0 / 255.0)),
        );
        let l2 = (a + b + a + b) / 4.0;
        let c = linear_to_srgb_code(l2);
        assert_eq!(t.level_codes(2), [pack_rgba8([c, c, c, 223])]);
        // No mipmaps unless the sampler uses them.
        let flat = Texture::new(
            "flat",
            4,
            2,
            vec![grey; 8],
            Encoding::Srgb,
            bilinear(Wrap::Repeat),
        )
        .unwrap();
        assert_eq!((flat.levels(), flat.gpu_bytes()), (1, 32));
    }

    #[test]
    fn max_texel_is_each_channels_largest_decoded_sample_over_every_level() {
        // Each channel peaks at another texel (red 255, green 250, blue 128, alpha 0).
        let codes = vec![
            pack_rgba8([9, 250, 3, 0]),
            pack_rgba8([7, 1, 0, 0]),
            pack_rgba8([255, 2, 4, 0]),
            pack_rgba8([0, 0, 128, 0]),
        ];
        let sampler = Sampler {
            mip: MipFilter::Linear,
            ..Sampler::default()
        };
        let t = Texture::new("peaks", 2, 2, codes, Encoding::Srgb, sampler).unwrap();
        let every: Vec<[f32; 4]> = (0..t.codes().len())
            .map(|k| t.decode(t.codes()[k]))
            .collect();
        let scanned = [0, 1, 2, 3].map(|c| every.iter().map(|v| v[c]).fold(0.0f32, f32::max));
        assert_eq!(t.max_texel(), scanned);
        assert_eq!(t.max_texel()[0], 1.0);
        assert_eq!(t.max_texel()[3], 0.0);
    }

    #[test]
    fn invalid_textures_are_refused() {
        let s = Sampler::default();
        assert!(Texture::new("z", 0, 4, vec![], Encoding::Srgb, s).is_err());
        assert!(Texture::new("n", 2, 2, vec![0; 3], Encoding::Srgb, s).is_err());
        let big = MAX_TEXTURE_DIMENSION + 1;
        let e = Texture::new("b", big, 1, vec![0; big as usize], Encoding::Srgb, s).unwrap_err();
        assert!(e.contains("allowed: 1..=8192"), "{e}");
    }

    #[test]
    fn texel_centres_return_the_texel() {
        let t = ramp(4, 3, bilinear(Wrap::ClampToEdge));
        for j in 0..3 {
            for i in 0..4 {
                let uv = [(i as f32 + 0.5) / 4.0, (j as f32 + 0.5) / 3.0];
                assert_eq!(t.sample(uv, STILL), t.texel(j * 4 + i), "texel {i},{j}");
            }
        }
    }

    #[test]
    fn halfway_between_centres_is_the_mean() {
        let t = ramp(4, 4, bilinear(Wrap::ClampToEdge));
        // Between texels (1, 2) and (2, 2): x = 2.0 in texel space.
        let s = t.sample([2.0 / 4.0, 2.5 / 4.0], STILL);
        assert_eq!(s[0], unorm(1) + (unorm(2) - unorm(1)) * 0.5);
        assert_eq!(s[1], unorm(2));
    }

    #[test]
    fn level_of_detail_follows_the_isotropic_rule() {
        let t = ramp(16, 16, Sampler::default());
        assert_eq!(t.levels(), 5);
        let uv = [0.3, 0.6];
        // A footprint of 4 texels along x: level 2 exactly.
        let four = [4.0 / 16.0, 0.0, 0.0, 1.0 / 16.0];
        assert_eq!(t.footprint_squared(four), 16.0);
        assert_eq!(t.lod(16.0), 2.0);
        assert_eq!(t.sample(uv, four), t.filter_level(2, Filter::Linear, uv));
        // The larger axis decides, whichever it is.
        let swapped = [1.0 / 16.0, 0.0, 0.0, 4.0 / 16.0];
        assert_eq!(t.sample(uv, swapped), t.sample(uv, four));
        // 2^1.5 texels: halfway between levels 1 and 2.
        let between = [2f32.powf(1.5) / 16.0, 0.0, 0.0, 0.0];
        assert!((t.lod(t.footprint_squared(between)) - 1.5).abs() < 1e-6);
        let (a, b) = (
            t.filter_level(1, Filter::Linear, uv),
            t.filter_level(2, Filter::Linear, uv),
        );
        let s = t.sample(uv, between);
        let f = t.lod(t.footprint_squared(between)) - 1.0;
        assert_eq!(s, std::array::from_fn(|k| a[k] + (b[k] - a[k]) * f));
        // Beyond the last level: clamped to it.
        assert_eq!(
            t.sample(uv, [64.0, 0.0, 0.0, 0.0]),
            t.filter_level(4, Filter::Linear, uv)
        );
        // ρ ≤ 1: magnification, here NEAREST, on level 0.
        let nearest_mag = Sampler {
            mag: Filter::Nearest,
            ..Sampler::default()
        };
        let n = ramp(16, 16, nearest_mag);
        assert_eq!(
            n.sample([0.3, 0.6], [1.0 / 16.0, 0.0, 0.0, 0.0]),
            n.texel(9 * 16 + 4)
        );
        // MIPMAP_NEAREST rounds the level: lod 1.4 → 1, 1.6 → 2.
        let nearest_mip = ramp(
            16,
            16,
            Sampler {
                mip: MipFilter::Nearest,
                ..Sampler::default()
            },
        );
        let at = |lod: f32| [2f32.powf(lod) / 16.0, 0.0, 0.0, 0.0];
        assert_eq!(
            nearest_mip.sample(uv, at(1.4)),
            nearest_mip.filter_level(1, Filter::Linear, uv)
        );
        assert_eq!(
            nearest_mip.sample(uv, at(1.6)),
            nearest_mip.filter_level(2, Filter::Linear, uv)
        );
    }

    #[test]
    fn wrap_modes_follow_gltf() {
        assert_eq!(Wrap::Repeat.apply(-1, 4), 3);
        assert_eq!(Wrap::Repeat.apply(9, 4), 1);
        assert_eq!(Wrap::MirroredRepeat.apply(4, 4), 3);
        assert_eq!(Wrap::MirroredRepeat.apply(-1, 4), 0);
        assert_eq!(Wrap::MirroredRepeat.apply(8, 4), 0);
        assert_eq!(Wrap::ClampToEdge.apply(-7, 4), 0);
        assert_eq!(Wrap::ClampToEdge.apply(7, 4), 3);
        // Repeat: u and u + 1 sample the same value (coordinates exact in f32, so the texel
        // positions u·size − 0.5 are too; 0.3 vs 1.3 differ in the last bit).
        let t = ramp(4, 4, bilinear(Wrap::Repeat));
        assert_eq!(
            t.sample([0.375, 0.625], STILL),
            t.sample([1.375, -0.375], STILL)
        );
        // Clamp: beyond the edge is the edge texel.
        let c = ramp(4, 4, bilinear(Wrap::ClampToEdge));
        assert_eq!(c.sample([5.0, 0.125], STILL), c.texel(3));
    }

    /// Wrapping applies on every mipmap level with that level's size: repeat returns the same
    /// trilinear sample one period over, mirrored repeat the mirror image.
    #[test]
    fn wrap_modes_apply_on_every_level() {
        let grad = [2.5 / 16.0, 0.0, 0.0, 0.0];
        let repeat = ramp(16, 8, Sampler::default());
        // Binary fractions, so u + 1 and v − 2 are exact in f32.
        for uv in [[0.125, 0.25], [0.968_75, 0.031_25], [0.5, 0.984_375]] {
            let s = repeat.sample(uv, grad);
            assert_eq!(s, repeat.sample([uv[0] + 1.0, uv[1] - 2.0], grad), "{uv:?}");
        }
        let mirrored = ramp(
            16,
            8,
            Sampler {
                wrap_u: Wrap::MirroredRepeat,
                wrap_v: Wrap::MirroredRepeat,
                ..Sampler::default()
            },
        );
        // At a level's texel centre the sample is that texel; the mirror of level 1's texel
        // (1, 1) across u = 0 is texel (0, 1)'s twin at u = −1.5/8, which reads texel 1.
        let level1 = |uv: [f32; 2]| mirrored.filter_level(1, Filter::Linear, uv);
        assert_eq!(
            level1([-1.5 / 8.0, 1.5 / 4.0]),
            level1([1.5 / 8.0, 1.5 / 4.0])
        );
        let clamp = ramp(
            16,
            8,
            Sampler {
                wrap_u: Wrap::ClampToEdge,
                wrap_v: Wrap::ClampToEdge,
                ..Sampler::default()
            },
        );
        assert_eq!(
            clamp.sample([3.0, 0.5], grad),
            clamp.sample([1.0, 0.5], grad)
        );
    }

    #[test]
    fn gltf_filters_parse_and_unknown_codes_are_refused() {
        let s = |mag, min| Sampler::default().with_gltf_filters(mag, min);
        assert_eq!(s(None, None).unwrap(), Sampler::default());
        let n = s(Some(9728), Some(9984)).unwrap();
        assert_eq!(
            (n.mag, n.min, n.mip),
            (Filter::Nearest, Filter::Nearest, MipFilter::Nearest)
        );
        let l = s(Some(9729), Some(9985)).unwrap();
        assert_eq!(
            (l.mag, l.min, l.mip),
            (Filter::Linear, Filter::Linear, MipFilter::Nearest)
        );
        assert_eq!(s(None, Some(9986)).unwrap().mip, MipFilter::Linear);
        assert_eq!(s(None, Some(9986)).unwrap().min, Filter::Nearest);
        assert_eq!(s(None, Some(9729)).unwrap().mip, MipFilter::None);
        assert!(s(Some(9984), None).unwrap_err().contains("magFilter 9984"));
        assert!(s(None, Some(1)).unwrap_err().contains("allowed"));
        // Mip linear (2) << 6 | min linear << 5 | mag linear << 4 | repeat, repeat.
        assert_eq!(Sampler::default().code(), 0b1011_0000);
    }

    /// The in-range short cut of [`Wrap::apply`] changes no index: against the remainders
    /// written out, for every mode, small and odd sizes, and indices far outside.
    #[test]
    fn wrapping_equals_the_remainder_formulas_everywhere() {
        for size in [1, 2, 3, 4, 7, 8, 255, 8192] {
            for i in (-3 * size - 5..3 * size + 5).chain([i32::MIN / 2, i32::MAX / 2]) {
                let mirrored = i.rem_euclid(2 * size);
                let expected = [
                    (Wrap::Repeat, i.rem_euclid(size)),
                    (
                        Wrap::MirroredRepeat,
                        if mirrored >= size {
                            2 * size - 1 - mirrored
                        } else {
                            mirrored
                        },
                    ),
                    (Wrap::ClampToEdge, i.clamp(0, size - 1)),
                ];
                for (wrap, want) in expected {
                    assert_eq!(wrap.apply(i, size), want, "{wrap:?} of {i} in {size}");
                }
            }
        }
    }

    #[test]
    fn extreme_coordinates_do_not_overflow() {
        let t = ramp(8, 8, Sampler::default());
        for uv in [[MAX_UV, -MAX_UV], [-MAX_UV, MAX_UV]] {
            for grad in [STILL, [1.0, 0.0, 0.0, 0.0], [MAX_UV, MAX_UV, 0.0, 0.0]] {
                assert!(t.sample(uv, grad).iter().all(|c| c.is_finite()));
            }
        }
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert_eq!(srgb_to_linear(1.0), 1.0);
        // 0.5 encodes 0.214 041 1 linear.
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-7);
        // The linear segment below the knee.
        assert_eq!(srgb_to_linear(0.04), (0.04f64 / 12.92) as f32);
    }
}
