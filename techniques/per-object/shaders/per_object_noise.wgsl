// pygfx's dither thresholds (pygfx 0.17, pygfx/renderers/wgpu/wgsl/noise.wgsl and the
// `stochastic` fragment output of engine/blender.py), reimplemented: Bob Jenkins'
// one-at-a-time mix for the seeds, and Fil's "pseudoblue" noise (observablehq.com/@fil/
// pseudoblue) for the threshold of each pixel.

// One-at-a-time mixing steps of a 32-bit word (pygfx `hashu`).
fn mix_word(value: u32) -> u32 {
    var h = value;
    h += h << 10u;
    h ^= h >> 6u;
    h += h << 3u;
    h ^= h >> 11u;
    h += h << 15u;
    return h;
}

// The bit that flips a level's x digit, from the coarser cell (x, y): a masked linear hash,
// scaled in f32 as pygfx does (so its f32 rounding is part of the pattern).
fn flip_x(x: u32, y: u32) -> u32 {
    return u32(f32((x * 212281u + y * 384817u) & 0x5555555u) * 0.003257328990228013);
}

// The same for the y digit.
fn flip_y(x: u32, y: u32) -> u32 {
    return u32(f32((x * 484829u + y * 112279u) & 0x5555555u) * 0.002004008016032064);
}

// Pseudo-blue noise in [0, 1): eight levels of a 2×2 ordered-dither digit, finest level first
// into the most significant bits, each digit scrambled by its coarser cell; a 16-bit rank.
fn pseudo_blue(p: vec2<u32>) -> f32 {
    var x = p.x;
    var y = p.y;
    var rank = 0u;
    for (var level = 0u; level < 8u; level++) {
        let fine_x = x;
        let fine_y = y;
        x = x >> 1u;
        y = y >> 1u;
        let dx = (fine_x ^ flip_x(x, y)) & 1u;
        let dy = (fine_y ^ flip_y(x, y)) & 1u;
        rank = (rank << 2u) | ((dx + (dy << 1u) + 1u) & 3u);
    }
    return f32(rank) / 65536.0;
}

// pygfx's `element` seed: the pixel shifted by the mix of the object id xor the mix of the
// face index + 1, 16 bits per axis (wrapping, as u32 arithmetic does).
fn element_offset(object_id: u32, face: u32) -> vec2<u32> {
    let seed = mix_word(object_id) ^ mix_word(face + 1u);
    return vec2<u32>(seed >> 16u, seed & 0xffffu);
}
