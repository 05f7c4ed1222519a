//! Blend states the techniques share. Each says what it computes, in the premultiplied
//! convention of the rendering model (`src`/`dst` are the shader output and the target's
//! contents).

/// Premultiplied OVER: `dst = src + (1 − src.a) · dst` on colour and alpha (draw-order
/// blending, back to front).
pub const PREMULTIPLIED_OVER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
};

/// Premultiplied UNDER into a `(Σ C·T, T)` accumulator cleared to `(0, 0, 0, 1)` (front to
/// back): colour `dst + src · dst.a`, alpha (the transmittance) `dst.a · (1 − src.a)`.
pub const PREMULTIPLIED_UNDER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::DstAlpha,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
};

/// A resolved layer stack `(F, T)` (colour in front, transmittance) over what the target
/// holds: colour `F + T · dst`, the target's alpha kept. The composite of front peeling and of
/// WBOIT.
pub const TRANSMITTANCE_OVER: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::SrcAlpha,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};

/// Per-channel maximum (wgpu requires factors One/One with Min/Max), e.g. dual peeling's
/// `(−min, max)` depth range.
pub const MAX: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Max,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Max,
    },
};

const ADD: wgpu::BlendComponent = wgpu::BlendComponent {
    src_factor: wgpu::BlendFactor::One,
    dst_factor: wgpu::BlendFactor::One,
    operation: wgpu::BlendOperation::Add,
};

/// `dst = src + dst` on every channel (weighted sums, counts).
pub const ADDITIVE: wgpu::BlendState = wgpu::BlendState {
    color: ADD,
    alpha: ADD,
};

const ATTENUATE: wgpu::BlendComponent = wgpu::BlendComponent {
    src_factor: wgpu::BlendFactor::Zero,
    dst_factor: wgpu::BlendFactor::OneMinusSrc,
    operation: wgpu::BlendOperation::Add,
};

/// `dst = dst · (1 − src)` on every channel: a running product Π(1 − α), e.g. WBOIT's
/// revealage cleared to 1.
pub const MULTIPLY_ONE_MINUS_SRC: wgpu::BlendState = wgpu::BlendState {
    color: ATTENUATE,
    alpha: ATTENUATE,
};
