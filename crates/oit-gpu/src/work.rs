//! What a technique's passes move, stated per pass from the formats they use: bytes read and
//! written and atomics per fragment that reaches the output, and what each pass draws. The
//! harness multiplies these by the occlusion counts of a counted frame
//! ([`crate::GpuTimer::counting_fragments`]) into results.json's `counts`: numbers that mean
//! the same on every GPU, unlike its milliseconds.
//!
//! Stated, not measured: what the formats imply for a fragment that passes the depth test.
//! Not counted: fragments that fail the depth test (their depth read), texture fetches of the
//! scene's materials, caches and compression. Storage bytes are what the shader reads and
//! writes as written, not what a GPU's memory system moves.

/// What a pass draws, which sets the triangles it submits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PassDraws {
    /// Every transparent draw once.
    Transparent,
    /// Every transparent draw, the double-sided ones twice (back faces, then front faces).
    TransparentDoubleSidedTwice,
    /// The transparent draws with coloured transmission only.
    Transmissive,
    /// The transparent draws without coloured transmission only.
    NotTransmissive,
    /// The transparent draws that add or subtract their colour (`BlendOperator::Add` or
    /// `Subtract`) only: the passes approximate techniques give them.
    Additive,
    /// The transparent draws that neither add nor subtract their colour.
    NotAdditive,
    /// The opaque and mask draws (the shared opaque pass, and copies of it).
    Opaque,
    /// One full-screen triangle per draw call (a composite, resolve or seed): its fragments
    /// are pixels.
    FullScreen,
    /// A compute pass: no fragments.
    Compute,
}

/// One kind of pass, matched to the timer's pass names by [`PassWork::matches`].
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PassWork {
    /// The name the pass is registered with in [`crate::GpuTimer::pass`], or with
    /// `numbered` the part before a number ("layer " for "layer 1", "layer 2", …).
    pub name: String,
    pub numbered: bool,
    pub draws: PassDraws,
    /// Bytes read per fragment that reaches the output: depth tested, blend destination,
    /// storage and textures the shader reads.
    pub bytes_read: u32,
    /// Bytes written per such fragment: depth, colour attachments, storage.
    pub bytes_written: u32,
    /// Atomic read-modify-write operations per such fragment (a mean where only some
    /// fragments make one); their bytes are not in `bytes_read`/`bytes_written`.
    pub atomics: f64,
    /// Bytes read per fragment of another pass (named as in `name`): a resolve that walks
    /// every node the insert pass stored reads by the inserted fragments, not by its pixels.
    pub reads_fragments_of: Option<(String, u32)>,
}

impl PassWork {
    /// A pass registered as `name`.
    pub fn new(name: impl Into<String>, draws: PassDraws) -> Self {
        PassWork {
            name: name.into(),
            numbered: false,
            draws,
            bytes_read: 0,
            bytes_written: 0,
            atomics: 0.0,
            reads_fragments_of: None,
        }
    }

    /// Passes registered as `prefix` followed by a number.
    pub fn numbered(prefix: impl Into<String>, draws: PassDraws) -> Self {
        PassWork {
            numbered: true,
            ..Self::new(prefix, draws)
        }
    }

    /// Sets the bytes read and written per fragment.
    pub fn bytes(self, read: u32, written: u32) -> Self {
        PassWork {
            bytes_read: read,
            bytes_written: written,
            ..self
        }
    }

    pub fn atomics(self, atomics: f64) -> Self {
        PassWork { atomics, ..self }
    }

    /// Also reads `bytes` per fragment that the pass `pass` let through.
    pub fn reads_fragments_of(self, pass: impl Into<String>, bytes: u32) -> Self {
        PassWork {
            reads_fragments_of: Some((pass.into(), bytes)),
            ..self
        }
    }

    /// Whether the timer's pass `name` is this kind.
    pub fn matches(&self, name: &str) -> bool {
        if self.numbered {
            name.strip_prefix(self.name.as_str())
                .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
        } else {
            name == self.name
        }
    }
}

/// A technique's passes, as stated by [`crate::Technique::work`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Work {
    pub passes: Vec<PassWork>,
}

impl Work {
    pub fn new(passes: Vec<PassWork>) -> Self {
        Work { passes }
    }

    /// The declaration of the timer's pass `name` (the first that matches).
    pub fn of_pass(&self, name: &str) -> Option<&PassWork> {
        self.passes.iter().find(|p| p.matches(name))
    }
}

/// Bytes of one texel of `format` (colour formats; depth formats by their storage).
pub fn texel_bytes(format: wgpu::TextureFormat) -> u32 {
    match format {
        wgpu::TextureFormat::Depth32Float => 4,
        f => f.block_copy_size(None).unwrap_or(0),
    }
}

/// `Depth32Float`: the depth every pass tests against.
pub const DEPTH_BYTES: u32 = 4;

/// A premultiplied blend into the final target: reads and writes one texel of `target`.
pub fn blend(target: wgpu::TextureFormat) -> (u32, u32) {
    let t = texel_bytes(target);
    (t, t)
}

/// The shared opaque pass: a depth test and write, a colour write.
pub fn opaque_pass(target: wgpu::TextureFormat) -> PassWork {
    PassWork::new("opaque", PassDraws::Opaque).bytes(DEPTH_BYTES, DEPTH_BYTES + texel_bytes(target))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbered_names_match_only_a_number() {
        let p = PassWork::numbered("layer ", PassDraws::Transparent);
        assert!(p.matches("layer 1"));
        assert!(p.matches("layer 12"));
        assert!(!p.matches("layer "));
        assert!(!p.matches("layer 1b"));
        assert!(!p.matches("under 1"));
        let exact = PassWork::new("blend", PassDraws::Transparent);
        assert!(exact.matches("blend"));
        assert!(!exact.matches("blend nearest layer"));
    }

    #[test]
    fn texels_of_the_target_formats() {
        assert_eq!(texel_bytes(wgpu::TextureFormat::Rgba16Float), 8);
        assert_eq!(texel_bytes(wgpu::TextureFormat::Rgba32Float), 16);
        assert_eq!(texel_bytes(wgpu::TextureFormat::R16Float), 2);
        assert_eq!(texel_bytes(wgpu::TextureFormat::Depth32Float), 4);
        assert_eq!(
            opaque_pass(wgpu::TextureFormat::Rgba16Float).bytes_written,
            12
        );
    }
}
