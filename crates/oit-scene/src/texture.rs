//! Textures and the one sampling rule the GPU and the reference share.
//!
//! Hardware filtering cannot be mirrored on the CPU (fixed-point weights of
//! implementation-defined precision, implicit level-of-detail selection), so every pass samples
//! with [`Texture::sample`]'s twin in crates/oit-gpu/shaders/common.wgsl (`sample_texture`): bilinear on level 0
//! from `textureLoad`-style integer fetches, computed in f32 in the same order, with the glTF
//! sampler's wrap modes applied to integer texel coordinates. The two stay line-comparable.

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

/// Largest |u| or |v| a vertex may carry. Beyond it the f32 texel coordinate `u·size` has no
/// fractional bits left at the largest texture size (2^20 · 8192 = 2^33 > 2^24) and the integer
/// texel index would leave i32; the loader rejects such coordinates.
pub const MAX_UV: f32 = 1_048_576.0;

/// Largest texture width or height (the smallest `maxTextureDimension2D` wgpu guarantees).
pub const MAX_TEXTURE_DIMENSION: u32 = 8192;

/// A decoded texture: linear RGBA f32 texels (colour textures already sRGB-decoded, alpha
/// always linear) plus the sampler's wrap modes. Row-major from the image's top-left, which is
/// glTF's uv origin (v grows downwards).
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// Where it came from, e.g. `AlphaBlendModeTest.glb /images/3`.
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
    pub wrap_u: Wrap,
    pub wrap_v: Wrap,
}

impl Texture {
    /// Bytes the GPU copy takes (RGBA f32 per texel).
    pub fn gpu_bytes(&self) -> u64 {
        self.texels.len() as u64 * 16
    }

    /// The largest value of each channel: the most any sample can return (bilinear weights
    /// are convex).
    pub fn max_texel(&self) -> [f32; 4] {
        self.texels
            .iter()
            .fold([0.0f32; 4], |m, t| std::array::from_fn(|k| m[k].max(t[k])))
    }

    /// Whether the texel array matches the dimensions (hand-built textures can get it wrong).
    pub fn is_consistent(&self) -> bool {
        self.width > 0
            && self.height > 0
            && self.width <= MAX_TEXTURE_DIMENSION
            && self.height <= MAX_TEXTURE_DIMENSION
            && self.texels.len() == self.width as usize * self.height as usize
    }

    #[inline(always)]
    fn texel(&self, i: i32, j: i32) -> [f32; 4] {
        let x = self.wrap_u.apply(i, self.width as i32);
        let y = self.wrap_v.apply(j, self.height as i32);
        self.texels[y as usize * self.width as usize + x as usize]
    }

    /// Bilinear sample of level 0 at `uv` (texel centres at (i + 0.5) / size), in f32 in the
    /// order of `sample_texture` in crates/oit-gpu/shaders/common.wgsl: `a + (b − a)·f` along u, then along v.
    #[inline]
    pub fn sample(&self, uv: [f32; 2]) -> [f32; 4] {
        let x = uv[0] * self.width as f32 - 0.5;
        let y = uv[1] * self.height as f32 - 0.5;
        let x0 = x.floor();
        let y0 = y.floor();
        let fx = x - x0;
        let fy = y - y0;
        let i = x0 as i32;
        let j = y0 as i32;
        let t00 = self.texel(i, j);
        let t10 = self.texel(i.wrapping_add(1), j);
        let t01 = self.texel(i, j.wrapping_add(1));
        let t11 = self.texel(i.wrapping_add(1), j.wrapping_add(1));
        std::array::from_fn(|k| {
            let top = t00[k] + (t10[k] - t00[k]) * fx;
            let bottom = t01[k] + (t11[k] - t01[k]) * fx;
            top + (bottom - top) * fy
        })
    }

    /// Smallest and largest alpha of the 4×4 texels around `uv`'s bilinear footprint: every
    /// value a sample within a texel of `uv` can blend (the footprint moves by one texel when
    /// the coordinate crosses a texel centre).
    pub fn alpha_range_near(&self, uv: [f32; 2]) -> (f32, f32) {
        let i = (uv[0] * self.width as f32 - 0.5).floor() as i32;
        let j = (uv[1] * self.height as f32 - 0.5).floor() as i32;
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for dj in -1..=2 {
            for di in -1..=2 {
                let a = self.texel(i.wrapping_add(di), j.wrapping_add(dj))[3];
                lo = lo.min(a);
                hi = hi.max(a);
            }
        }
        (lo, hi)
    }
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

    fn ramp(width: u32, height: u32, wrap: Wrap) -> Texture {
        let texels = (0..width * height)
            .map(|k| {
                let (x, y) = ((k % width) as f32, (k / width) as f32);
                [x, y, x + 10.0 * y, 1.0]
            })
            .collect();
        Texture {
            name: "ramp".into(),
            width,
            height,
            texels,
            wrap_u: wrap,
            wrap_v: wrap,
        }
    }

    #[test]
    fn texel_centres_return_the_texel() {
        let t = ramp(4, 3, Wrap::ClampToEdge);
        for j in 0..3 {
            for i in 0..4 {
                let uv = [(i as f32 + 0.5) / 4.0, (j as f32 + 0.5) / 3.0];
                assert_eq!(
                    t.sample(uv),
                    t.texels[(j * 4 + i) as usize],
                    "texel {i},{j}"
                );
            }
        }
    }

    #[test]
    fn halfway_between_centres_is_the_mean() {
        let t = ramp(4, 4, Wrap::ClampToEdge);
        // Between texels (1, 2) and (2, 2): x = 2.0 in texel space.
        let s = t.sample([2.0 / 4.0, 2.5 / 4.0]);
        assert_eq!(s[0], 1.5);
        assert_eq!(s[1], 2.0);
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
        let t = ramp(4, 4, Wrap::Repeat);
        assert_eq!(t.sample([0.375, 0.625]), t.sample([1.375, -0.375]));
        // Clamp: beyond the edge is the edge texel.
        let c = ramp(4, 4, Wrap::ClampToEdge);
        assert_eq!(c.sample([5.0, 0.125]), c.texels[3]);
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
        let t = ramp(8, 8, Wrap::Repeat);
        for uv in [[MAX_UV, -MAX_UV], [-MAX_UV, MAX_UV]] {
            assert!(t.sample(uv).iter().all(|c| c.is_finite()));
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
