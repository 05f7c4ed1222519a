// Wavelet OIT's Haar basis (Aizenshtein, Smal & McGuire 2022): the projection of one
// fragment's absorbance step, the reconstruction at a depth, the same with the fragment's own
// step taken out, and the total. Line-comparable with oit_wavelet::math (the derivation is
// there). No bindings, no includes: the passes and the twin test include it.
//
// Coefficients: index 0 the scaling function, 2^j + k the wavelet of level j (0..=rank) and
// shift k; N = 2^(rank + 1) of the 32 used.

const WAVELET_MIN_TRANSMITTANCE: f32 = 1e-5;
const WAVELET_MAX_TRANSMITTANCE: f32 = 0.9999999;
const WAVELET_SQRT_HALF: f32 = 0.70710677;

fn wavelet_coefficient_count(rank: u32) -> u32 {
    return 1u << (rank + 1u);
}

// The fragment's absorbance, or a negative value when it is discarded.
fn wavelet_absorbance(alpha: f32) -> f32 {
    let t = 1.0 - alpha;
    if t > WAVELET_MAX_TRANSMITTANCE {
        return -1.0;
    }
    return -log(max(t, WAVELET_MIN_TRANSMITTANCE));
}

fn wavelet_normalized_depth(z: f32, z_min: f32, z_max: f32) -> f32 {
    if z_max > z_min {
        return clamp((z - z_min) / (z_max - z_min), 0.0, 1.0);
    }
    return 0.0;
}

fn wavelet_level_shrink(j: u32) -> f32 {
    let odd = select(1.0, WAVELET_SQRT_HALF, j % 2u == 1u);
    return odd * exp2(-f32(j / 2u));
}

fn wavelet_level_grow(j: u32) -> f32 {
    let odd = select(1.0, 2.0 * WAVELET_SQRT_HALF, j % 2u == 1u);
    return odd * exp2(f32(j / 2u));
}

fn wavelet_basis_depth(rank: u32, depth: f32) -> f32 {
    let n = f32(wavelet_coefficient_count(rank));
    return depth * ((n - 1.0) / n);
}

fn wavelet_project(c: ptr<function, array<f32, 32>>, rank: u32, signal: f32, depth: f32) {
    let x = wavelet_basis_depth(rank, depth);
    (*c)[0] += signal * (1.0 - x);
    for (var j = 0u; j <= rank; j++) {
        let level = f32(1u << j);
        let scaled = x * level;
        let k = min(floor(scaled), level - 1.0);
        let u = scaled - k;
        let i = (1u << j) + u32(k);
        (*c)[i] += -signal * wavelet_level_shrink(j) * min(u, 1.0 - u);
    }
}

fn wavelet_cell_value(c: ptr<function, array<f32, 32>>, rank: u32, cell: u32) -> f32 {
    var v = (*c)[0];
    for (var j = 0u; j <= rank; j++) {
        let k = cell >> (rank + 1u - j);
        let first_half = ((cell >> (rank - j)) & 1u) == 0u;
        let sign = select(-1.0, 1.0, first_half);
        v += sign * wavelet_level_grow(j) * (*c)[(1u << j) + k];
    }
    return v;
}

fn wavelet_absorbance_at(c: ptr<function, array<f32, 32>>, rank: u32, depth: f32) -> f32 {
    let n = wavelet_coefficient_count(rank);
    let x = wavelet_basis_depth(rank, depth) * f32(n);
    let cell = min(u32(max(floor(x), 0.0)), n - 1u);
    let f = clamp(x - f32(cell), 0.0, 1.0);
    let b = wavelet_cell_value(c, rank, cell);
    var a = 0.0;
    if cell > 0u {
        a = wavelet_cell_value(c, rank, cell - 1u);
    }
    return a + (b - a) * f;
}

fn wavelet_absorbance_before(c: ptr<function, array<f32, 32>>, rank: u32, depth: f32, signal: f32) -> f32 {
    var without = *c;
    wavelet_project(&without, rank, -signal, depth);
    return wavelet_absorbance_at(&without, rank, depth);
}

fn wavelet_total_absorbance(c: ptr<function, array<f32, 32>>, rank: u32) -> f32 {
    return wavelet_cell_value(c, rank, wavelet_coefficient_count(rank) - 1u);
}

fn wavelet_transmittance(absorbance: f32) -> f32 {
    return clamp(exp(-absorbance), 0.0, 1.0);
}
