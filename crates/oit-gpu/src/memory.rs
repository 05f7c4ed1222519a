//! Exact byte counts of what a technique allocates.
//!
//! Bytes are the formats' nominal sizes (block size × blocks × layers × mips × samples): what
//! the technique asks for. Drivers may pad or compress; that is not visible through wgpu and is
//! not counted.

/// Bytes of one texture as described.
pub fn texture_bytes(desc: &wgpu::TextureDescriptor<'_>) -> u64 {
    let (bw, bh) = desc.format.block_dimensions();
    let block = block_bytes(desc.format);
    let mut total = 0u64;
    for level in 0..desc.mip_level_count {
        let size = desc.size.mip_level_size(level, desc.dimension);
        let blocks_x = u64::from(size.width.div_ceil(bw));
        let blocks_y = u64::from(size.height.div_ceil(bh));
        total += blocks_x * blocks_y * u64::from(size.depth_or_array_layers) * block;
    }
    total * u64::from(desc.sample_count)
}

/// Bytes per block (per texel for uncompressed formats), all aspects together.
fn block_bytes(format: wgpu::TextureFormat) -> u64 {
    if let Some(b) = format.block_copy_size(None) {
        return u64::from(b);
    }
    // Combined or opaque depth formats have no single copy size; count each aspect at its
    // nominal size (Depth24Plus counted as 4 bytes, stencil as 1).
    let depth = match format {
        wgpu::TextureFormat::Depth16Unorm => 2,
        wgpu::TextureFormat::Depth24Plus
        | wgpu::TextureFormat::Depth24PlusStencil8
        | wgpu::TextureFormat::Depth32Float
        | wgpu::TextureFormat::Depth32FloatStencil8 => 4,
        _ => 0,
    };
    let stencil = u64::from(format.has_stencil_aspect());
    depth + stencil
}

/// Bytes of one buffer as described.
pub fn buffer_bytes(desc: &wgpu::BufferDescriptor<'_>) -> u64 {
    desc.size
}

/// Creates textures and buffers and remembers what each costs.
#[derive(Debug, Default, Clone)]
pub struct MemoryLedger {
    entries: Vec<(String, u64)>,
}

impl MemoryLedger {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn create_texture(
        &mut self,
        device: &wgpu::Device,
        desc: &wgpu::TextureDescriptor<'_>,
    ) -> wgpu::Texture {
        self.entries.push((
            desc.label.unwrap_or("texture").to_owned(),
            texture_bytes(desc),
        ));
        device.create_texture(desc)
    }

    pub fn create_buffer(
        &mut self,
        device: &wgpu::Device,
        desc: &wgpu::BufferDescriptor<'_>,
    ) -> wgpu::Buffer {
        self.entries.push((
            desc.label.unwrap_or("buffer").to_owned(),
            buffer_bytes(desc),
        ));
        device.create_buffer(desc)
    }

    /// A one-mip 2D texture covering `resolution`: the shape of every per-pixel target a
    /// technique allocates (`sample_count` 1 unless it is a multisampled attachment).
    pub fn create_texture_2d(
        &mut self,
        device: &wgpu::Device,
        label: &str,
        resolution: oit_scene::Resolution,
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
        sample_count: u32,
    ) -> wgpu::Texture {
        self.create_texture(
            device,
            &wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: resolution.width,
                    height: resolution.height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            },
        )
    }

    /// Forget everything (call when the resources are dropped and recreated).
    pub fn clear(&mut self) {
        self.entries.clear();
    }

    pub fn total(&self) -> u64 {
        self.entries.iter().map(|(_, b)| b).sum()
    }

    /// `(label, bytes)` per allocation, in creation order.
    pub fn entries(&self) -> &[(String, u64)] {
        &self.entries
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn desc(
        format: wgpu::TextureFormat,
        w: u32,
        h: u32,
        mips: u32,
        samples: u32,
    ) -> wgpu::TextureDescriptor<'static> {
        wgpu::TextureDescriptor {
            label: None,
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: mips,
            sample_count: samples,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        }
    }

    #[test]
    fn texture_sizes() {
        use wgpu::TextureFormat as F;
        assert_eq!(
            texture_bytes(&desc(F::Rgba16Float, 256, 128, 1, 1)),
            256 * 128 * 8
        );
        assert_eq!(texture_bytes(&desc(F::Rg32Float, 3, 5, 1, 1)), 3 * 5 * 8);
        assert_eq!(
            texture_bytes(&desc(F::Depth32Float, 10, 10, 1, 4)),
            10 * 10 * 4 * 4
        );
        assert_eq!(
            texture_bytes(&desc(F::Depth24PlusStencil8, 2, 2, 1, 1)),
            2 * 2 * 5
        );
        // 4x4 + 2x2 + 1x1 texels.
        assert_eq!(texture_bytes(&desc(F::R8Unorm, 4, 4, 3, 1)), 16 + 4 + 1);
        // 5x5 BC1 = 2x2 blocks of 8 bytes.
        assert_eq!(texture_bytes(&desc(F::Bc1RgbaUnorm, 5, 5, 1, 1)), 4 * 8);
    }

    #[test]
    fn ledger_sums() {
        let mut l = MemoryLedger::new();
        l.entries.push(("a".into(), 3));
        l.entries.push(("b".into(), 4));
        assert_eq!(l.total(), 7);
        l.clear();
        assert_eq!(l.total(), 0);
    }
}
