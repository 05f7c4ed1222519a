//! Bind group layout entries of the shapes every technique uses (non-multisampled 2D textures
//! read with `textureLoad`, uniforms, storage buffers), and the dynamic-offset stride.

use crate::context::Context;

/// A uniform buffer, checked whole at bind time.
pub fn uniform(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    buffer(
        binding,
        visibility,
        wgpu::BufferBindingType::Uniform,
        false,
        None,
    )
}

/// A uniform selected by a dynamic offset: `size` bytes per entry, entries
/// [`uniform_stride`] apart in one buffer (per pass or per frame parameters).
pub fn dynamic_uniform(
    binding: u32,
    visibility: wgpu::ShaderStages,
    size: u64,
) -> wgpu::BindGroupLayoutEntry {
    buffer(
        binding,
        visibility,
        wgpu::BufferBindingType::Uniform,
        true,
        wgpu::BufferSize::new(size),
    )
}

/// A storage buffer (counters, tables).
pub fn storage(
    binding: u32,
    visibility: wgpu::ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    buffer(
        binding,
        visibility,
        wgpu::BufferBindingType::Storage { read_only },
        false,
        None,
    )
}

/// `entry` (a buffer entry) with a minimum binding size, so a too-small buffer is rejected
/// when the bind group is created rather than at draw time. Other entries are returned as is.
pub fn min_size(mut entry: wgpu::BindGroupLayoutEntry, size: u64) -> wgpu::BindGroupLayoutEntry {
    if let wgpu::BindingType::Buffer {
        min_binding_size, ..
    } = &mut entry.ty
    {
        *min_binding_size = wgpu::BufferSize::new(size);
    }
    entry
}

fn buffer(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BufferBindingType,
    has_dynamic_offset: bool,
    min_binding_size: Option<wgpu::BufferSize>,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset,
            min_binding_size,
        },
        count: None,
    }
}

/// A single-sampled 2D texture of `sample_type`.
pub fn texture(
    binding: u32,
    visibility: wgpu::ShaderStages,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A single-sampled 2D float texture read with `textureLoad` (unfilterable, so 32-bit float
/// formats and `Depth32Float` can be bound: GLSL has no `texelFetch` of depth textures, see
/// [`Caps::depth_texture_loads`](crate::Caps::depth_texture_loads)).
pub fn float_texture(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    texture(
        binding,
        visibility,
        wgpu::TextureSampleType::Float { filterable: false },
    )
}

/// `size` rounded up to the device's uniform dynamic-offset alignment (at least 1).
pub fn uniform_stride(ctx: &Context, size: u64) -> u64 {
    let align = u64::from(ctx.device.limits().min_uniform_buffer_offset_alignment).max(1);
    size.div_ceil(align) * align
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_size_sets_buffers_and_leaves_textures() {
        let fs = wgpu::ShaderStages::FRAGMENT;
        let sized = min_size(storage(3, fs, true), 48);
        assert_eq!(sized.binding, 3);
        assert!(matches!(
            sized.ty,
            wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: Some(s),
            } if s.get() == 48
        ));
        let texture = float_texture(0, fs);
        assert_eq!(min_size(texture, 48), texture);
        assert!(matches!(
            dynamic_uniform(1, fs, 16).ty,
            wgpu::BindingType::Buffer { has_dynamic_offset: true, min_binding_size: Some(s), .. } if s.get() == 16
        ));
    }
}
