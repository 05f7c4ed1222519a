//! Readback: GPU buffers and textures to CPU memory. Every technique, the timer and the
//! conformance count read results the same way (copy into a `MAP_READ` buffer, map, wait,
//! copy out), so the error they report names what was being read.

use crate::context::Context;
use crate::error::GpuError;

/// Reads mip 0 of a 2D `texture` (which needs `COPY_SRC`) back tightly packed: row padding to
/// 256 bytes removed, `bytes_per_pixel` per texel, row-major, top-left origin. Waits for the
/// GPU. `what` names the texture in the error.
///
/// Depth formats where [`Caps::depth_copies`](crate::Caps::depth_copies) is false (GL) are
/// refused with [`Unsupported`](crate::Unsupported) rather than left to a wgpu validation panic.
pub fn read_texture(
    ctx: &Context,
    texture: &wgpu::Texture,
    bytes_per_pixel: u32,
    what: &str,
) -> Result<Vec<u8>, GpuError> {
    if texture.format().is_depth_stencil_format() && !ctx.caps.depth_copies() {
        return Err(crate::Unsupported::new(format!(
            "{what}: the {} backend cannot copy {:?} textures",
            ctx.caps.backend.to_str(),
            texture.format()
        ))
        .into());
    }
    let (w, h) = (texture.width(), texture.height());
    let row = w * bytes_per_pixel;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(padded) * u64::from(h),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(h),
            },
        },
        texture.size(),
    );
    ctx.queue.submit([encoder.finish()]);
    let data = read_buffer(ctx, &buffer, what)?;
    let mut out = Vec::with_capacity((row * h) as usize);
    for y in 0..h as usize {
        let start = y * padded as usize;
        out.extend_from_slice(&data[start..start + row as usize]);
    }
    Ok(out)
}

/// Maps a `MAP_READ` buffer, waits for the GPU (so every submitted copy into it is done),
/// copies the whole contents out and unmaps it, so the buffer can be reused next frame. `what`
/// names the buffer in the error.
pub fn read_buffer(ctx: &Context, buffer: &wgpu::Buffer, what: &str) -> Result<Vec<u8>, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    let fail = |message: String| GpuError::Readback {
        what: what.to_owned(),
        message,
    };
    rx.recv()
        .map_err(|e| fail(e.to_string()))?
        .map_err(|e| fail(e.to_string()))?;
    let data = buffer
        .get_mapped_range(..)
        .map_err(|e| fail(e.to_string()))?
        .to_vec();
    buffer.unmap();
    Ok(data)
}

/// [`read_buffer`] as little-endian `u32` words (counters, flags), any trailing partial word
/// dropped. Decoded word by word, so the byte vector's alignment does not matter.
pub fn read_buffer_u32(
    ctx: &Context,
    buffer: &wgpu::Buffer,
    what: &str,
) -> Result<Vec<u32>, GpuError> {
    let bytes = read_buffer(ctx, buffer, what)?;
    Ok(bytes
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}
