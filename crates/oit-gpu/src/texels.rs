//! The scene's texel store on the GPU: every texture's 8-bit RGBA codes (all mip levels) in
//! one `texture_2d_array<u32>` (R32Uint) of 2048 × 2048-texel pages, 16 MiB each, and the
//! 512-entry decode table (`oit_scene::decode_tables`) in a small storage buffer.
//!
//! Why pages of a texture array and not a storage buffer: one storage binding is limited by
//! `max_storage_buffer_binding_size` (128 MiB on lavapipe and the WebGPU default), which real
//! assets exceed, while a texture array holds `max_texture_array_layers` pages (256 by default:
//! 4 GiB). Shaders read it with `textureLoad` (exact integer fetches, no sampler), so the
//! filtering stays the one rule shared with the reference (shaders/common.wgsl
//! `sample_texture`). Texel n of the concatenated codes is at (n % 2048, n / 2048 % 2048) of
//! layer n / 2^22; a store of one page is only as tall as its texels need.

use crate::context::Context;
use crate::error::GpuError;
use oit_scene::Scene;
use wgpu::util::DeviceExt;

/// Bytes per stored texel: four 8-bit codes.
pub const TEXEL_BYTES: u64 = 4;
/// Width and height of a page of the texel store.
pub const TEXEL_PAGE_SIDE: u32 = 2048;
/// Texels per page.
pub const TEXEL_PAGE_TEXELS: u64 = (TEXEL_PAGE_SIDE as u64) * (TEXEL_PAGE_SIDE as u64);
/// Bytes of the decode table buffer (512 f32).
pub const DECODE_TABLE_BYTES: u64 = 512 * 4;

/// Texels of every texture of `scene`, all levels.
pub fn texel_count(scene: &Scene) -> u64 {
    scene.textures.iter().map(|t| t.codes().len() as u64).sum()
}

/// (width, height, layers) of the store for `texels` texels (at least one).
pub fn store_extent(texels: u64) -> (u32, u32, u32) {
    let texels = texels.max(1);
    let layers = texels.div_ceil(TEXEL_PAGE_TEXELS);
    if layers > 1 {
        return (
            TEXEL_PAGE_SIDE,
            TEXEL_PAGE_SIDE,
            layers.min(u64::from(u32::MAX)) as u32,
        );
    }
    let side = u64::from(TEXEL_PAGE_SIDE);
    (texels.min(side) as u32, texels.div_ceil(side) as u32, 1)
}

/// Bytes the store takes for `texels` texels: whole 16 MiB pages when there are several (the
/// layers of an array share one size), else only the rows the texels need.
pub fn store_bytes(texels: u64) -> u64 {
    let (w, h, layers) = store_extent(texels);
    u64::from(w) * u64::from(h) * u64::from(layers) * TEXEL_BYTES
}

fn mib(bytes: u64) -> String {
    crate::mib(bytes)
}

/// The uploaded store: the page array (viewed as D2Array) and the decode table.
pub(crate) struct TexelStore {
    pub pages: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub decode: wgpu::Buffer,
}

/// Uploads every texture's codes, page by page (one page of host memory at a time), after
/// checking the adapter's texture array limits: an error in MiB names what the scene needs.
pub(crate) fn upload(ctx: &Context, scene: &Scene) -> Result<TexelStore, GpuError> {
    let device = &ctx.device;
    let texels = texel_count(scene);
    let (width, height, layers) = store_extent(texels);
    let limits = device.limits();
    let max_layers = limits.max_texture_array_layers;
    if layers > max_layers || width > limits.max_texture_dimension_2d {
        let page_bytes = TEXEL_PAGE_TEXELS * TEXEL_BYTES;
        return Err(GpuError::TexturesTooLarge(format!(
            "the textures of scene {:?} need {} ({texels} texels with mip levels, {layers} pages of {}), but this adapter allows at most {} ({max_layers} texture array layers of {TEXEL_PAGE_SIDE}x{TEXEL_PAGE_SIDE} texels)",
            scene.name,
            mib(texels * TEXEL_BYTES),
            mib(page_bytes),
            mib(u64::from(max_layers) * page_bytes),
        )));
    }
    let pages = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("texel pages"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Uint,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    // The concatenated codes, copied out one page at a time.
    let mut sources = scene.textures.iter().map(|t| t.codes());
    let mut current: &[u32] = &[];
    for layer in 0..layers {
        let first = u64::from(layer) * TEXEL_PAGE_TEXELS;
        let count = (texels.saturating_sub(first)).min(TEXEL_PAGE_TEXELS) as usize;
        let rows = count.div_ceil(width as usize).max(1);
        let mut page = vec![0u32; rows * width as usize];
        let mut filled = 0;
        while filled < count {
            if current.is_empty() {
                match sources.next() {
                    Some(next) => current = next,
                    None => break,
                }
                continue;
            }
            let take = current.len().min(count - filled);
            page[filled..filled + take].copy_from_slice(&current[..take]);
            current = &current[take..];
            filled += take;
        }
        ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &pages,
                mip_level: 0,
                origin: wgpu::Origin3d {
                    x: 0,
                    y: 0,
                    z: layer,
                },
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&page),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(width * TEXEL_BYTES as u32),
                rows_per_image: Some(rows as u32),
            },
            wgpu::Extent3d {
                width,
                height: rows as u32,
                depth_or_array_layers: 1,
            },
        );
    }
    let view = pages.create_view(&wgpu::TextureViewDescriptor {
        label: Some("texel pages"),
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let decode = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("texel decode table"),
        contents: bytemuck::cast_slice(oit_scene::decode_tables()),
        usage: wgpu::BufferUsages::STORAGE,
    });
    Ok(TexelStore {
        pages,
        view,
        decode,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn store_extents_page_the_texels() {
        assert_eq!(store_extent(0), (1, 1, 1));
        assert_eq!(store_extent(5), (5, 1, 1));
        assert_eq!(store_extent(2049), (2048, 2, 1));
        assert_eq!(store_extent(TEXEL_PAGE_TEXELS), (2048, 2048, 1));
        assert_eq!(store_extent(TEXEL_PAGE_TEXELS + 1), (2048, 2048, 2));
        // Four 2048² textures with mip chains: 4 · 4/3 pages, rounded up.
        let four = 4 * (TEXEL_PAGE_TEXELS * 4).div_ceil(3);
        assert_eq!(store_extent(four).2, 6);
        assert_eq!(store_bytes(2049), 2 * 2048 * 4);
    }
}
