// Moment-based OIT (Munstermann, Kerzner, Kolb, Peters 2018): depth warp, the moments of one
// fragment, and the reconstruction of the transmittance in front of a depth from a pixel's
// moment sums. No bindings and no includes. The CPU twin is oit_mboit::math (same names, same
// order of operations; read the two side by side).
//
// Kinds (oit_mboit::MomentKind::index): 0 power4, 1 power6, 2 power8, 3 trig2, 4 trig3, 5 trig4.
// Moment sums: b0 and b[0..8]; power: b[k-1] = sum A z'^k; trigonometric: b[2(k-1)], b[2(k-1)+1]
// = sum A (cos k phi, sin k phi).

const MBOIT_MAX_ABSORBANCE: f32 = 10.0;
const MBOIT_MAX_TRANSMITTANCE: f32 = 0.9999999;
const MBOIT_MIN_B0: f32 = 0.00100050033;
const MBOIT_PI: f32 = 3.14159265;

fn mboit_is_trig(kind: u32) -> bool {
    return kind >= 3u;
}

// Size of the Hankel or Toeplitz matrix (one more than the number of roots).
fn mboit_order(kind: u32) -> u32 {
    return kind % 3u + 3u;
}

fn mboit_warp(view_z: f32, ln_z_min: f32, warp_scale: f32) -> f32 {
    return clamp((log(max(view_z, 1.17549435e-38)) - ln_z_min) * warp_scale - 1.0, -1.0, 1.0);
}

// Absorbance of a fragment, or a negative value when it is discarded.
fn mboit_absorbance(alpha: f32) -> f32 {
    let t = 1.0 - alpha;
    if t > MBOIT_MAX_TRANSMITTANCE {
        return -1.0;
    }
    return min(-log(max(t, 0.0)), MBOIT_MAX_ABSORBANCE);
}

fn circle_to_parameter(p: vec2<f32>) -> f32 {
    var r = abs(p.y) - abs(p.x);
    if p.x < 0.0 {
        r = 2.0 - r;
    }
    if p.y < 0.0 {
        r = 6.0 - r;
    }
    return r;
}

fn c_mul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

fn c_conj(a: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x, -a.y);
}

fn c_div(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let d = b.x * b.x + b.y * b.y;
    return vec2<f32>(a.x * b.x + a.y * b.y, a.y * b.x - a.x * b.y) / d;
}

fn c_abs2(a: vec2<f32>) -> f32 {
    return a.x * a.x + a.y * a.y;
}

fn c_sqrt(a: vec2<f32>) -> vec2<f32> {
    let r = sqrt(c_abs2(a));
    let re = sqrt(max(0.5 * (r + a.x), 0.0));
    var im = sqrt(max(0.5 * (r - a.x), 0.0));
    if a.y < 0.0 {
        im = -im;
    }
    return vec2<f32>(re, im);
}

fn c_cbrt(a: vec2<f32>) -> vec2<f32> {
    let r = sqrt(c_abs2(a));
    if r <= 0.0 {
        return vec2<f32>(0.0);
    }
    let angle = atan2(a.y, a.x) / 3.0;
    let m = pow(r, 1.0 / 3.0);
    return vec2<f32>(m * cos(angle), m * sin(angle));
}

// The moments one fragment adds (b0 is the absorbance itself).
fn mboit_fragment_moments(kind: u32, zw: f32, a: f32, wrapping: vec4<f32>) -> array<f32, 8> {
    var b = array<f32, 8>();
    let m = mboit_order(kind) - 1u;
    if mboit_is_trig(kind) {
        let phase = (zw + 1.0) * wrapping.y;
        let circle = vec2<f32>(cos(phase), sin(phase));
        var power = circle;
        for (var k = 0u; k < m; k++) {
            b[2u * k] = a * power.x;
            b[2u * k + 1u] = a * power.y;
            power = c_mul(power, circle);
        }
    } else {
        var power = zw;
        for (var k = 0u; k < 2u * m; k++) {
            b[k] = a * power;
            power *= zw;
        }
    }
    return b;
}

fn solve_quadratic(c0: f32, c1: f32, c2: f32) -> array<f32, 2> {
    let disc = max(c1 * c1 - 4.0 * c2 * c0, 0.0);
    var s = sqrt(disc);
    if c1 < 0.0 {
        s = -s;
    }
    let q = -0.5 * (c1 + s);
    if q == 0.0 {
        return array<f32, 2>(0.0, 0.0);
    }
    return array<f32, 2>(q / c2, c0 / q);
}

fn solve_cubic(c0: f32, c1: f32, c2: f32, c3: f32) -> array<f32, 3> {
    let a = c2 / c3;
    let b = c1 / c3;
    let c = c0 / c3;
    let s = a / 3.0;
    let p = b - a * s;
    let q = c + s * (2.0 * s * s - b);
    if p >= 0.0 {
        let t = sign(-q) * pow(abs(q), 1.0 / 3.0);
        return array<f32, 3>(t - s, t - s, t - s);
    }
    let r = sqrt(-p / 3.0);
    let cos3 = clamp(-q / (2.0 * r * r * r), -1.0, 1.0);
    let theta = acos(cos3) / 3.0;
    let third = 2.0 * MBOIT_PI / 3.0;
    return array<f32, 3>(
        2.0 * r * cos(theta) - s,
        2.0 * r * cos(theta - third) - s,
        2.0 * r * cos(theta + third) - s,
    );
}

fn solve_quartic(c0: f32, c1: f32, c2: f32, c3: f32, c4: f32) -> array<f32, 4> {
    let a = c3 / c4;
    let b = c2 / c4;
    let c = c1 / c4;
    let d = c0 / c4;
    let ys = solve_cubic(c * c + a * a * d - a * b * c, b * b + a * c - 4.0 * d, -2.0 * b, 1.0);
    let y = min(min(ys[0], ys[1]), ys[2]);
    let s = sqrt(max(a * a - 4.0 * y, 0.0));
    var big_g = 0.5 * (a + s);
    var g = 0.5 * (a - s);
    if a >= 0.0 && big_g != 0.0 {
        g = y / big_g;
    } else if a < 0.0 && g != 0.0 {
        big_g = y / g;
    }
    let u = 0.5 * (b - y);
    var w = sqrt(max(u * u - d, 0.0));
    if s > 0.0 {
        w = (a * (b - y) - 2.0 * c) / (2.0 * s);
    }
    var big_h = u + w;
    var h = u - w;
    if abs(big_h) >= abs(h) && big_h != 0.0 {
        h = d / big_h;
    } else if h != 0.0 {
        big_h = d / h;
    }
    let r0 = solve_quadratic(big_h, big_g, 1.0);
    let r1 = solve_quadratic(h, g, 1.0);
    return array<f32, 4>(r0[0], r0[1], r1[0], r1[1]);
}

fn solve_quadratic_complex(c0: vec2<f32>, c1: vec2<f32>, c2: vec2<f32>) -> array<vec2<f32>, 2> {
    let disc = c_mul(c1, c1) - 4.0 * c_mul(c2, c0);
    var s = c_sqrt(disc);
    if c1.x * s.x + c1.y * s.y < 0.0 {
        s = -s;
    }
    let q = -0.5 * (c1 + s);
    if c_abs2(q) == 0.0 {
        return array<vec2<f32>, 2>(vec2<f32>(0.0), vec2<f32>(0.0));
    }
    return array<vec2<f32>, 2>(c_div(q, c2), c_div(c0, q));
}

fn solve_cubic_complex(c0: vec2<f32>, c1: vec2<f32>, c2: vec2<f32>, c3: vec2<f32>) -> array<vec2<f32>, 3> {
    let a = c_div(c2, c3);
    let b = c_div(c1, c3);
    let c = c_div(c0, c3);
    let s = a / 3.0;
    let p = b - c_mul(a, s);
    let q = c + c_mul(s, 2.0 * c_mul(s, s) - b);
    let p3 = p / 3.0;
    let disc = 0.25 * c_mul(q, q) + c_mul(p3, c_mul(p3, p3));
    let root = c_sqrt(disc);
    var w = -0.5 * q + root;
    let w2 = -0.5 * q - root;
    if c_abs2(w2) > c_abs2(w) {
        w = w2;
    }
    let u = c_cbrt(w);
    if c_abs2(u) == 0.0 {
        return array<vec2<f32>, 3>(-s, -s, -s);
    }
    let third = vec2<f32>(-0.5, 0.8660254);
    var out = array<vec2<f32>, 3>();
    var uk = u;
    for (var k = 0u; k < 3u; k++) {
        out[k] = uk - c_div(p3, uk) - s;
        uk = c_mul(uk, third);
    }
    return out;
}

fn solve_quartic_complex(c0: vec2<f32>, c1: vec2<f32>, c2: vec2<f32>, c3: vec2<f32>, c4: vec2<f32>) -> array<vec2<f32>, 4> {
    let a = c_div(c3, c4);
    let b = c_div(c2, c4);
    let c = c_div(c1, c4);
    let d = c_div(c0, c4);
    let aa = c_mul(a, a);
    let ys = solve_cubic_complex(
        c_mul(c, c) + c_mul(aa, d) - c_mul(a, c_mul(b, c)),
        c_mul(b, b) + c_mul(a, c) - 4.0 * d,
        -2.0 * b,
        vec2<f32>(1.0, 0.0),
    );
    var y = ys[0];
    var gap = c_abs2(aa - 4.0 * ys[0]);
    for (var k = 1u; k < 3u; k++) {
        let gk = c_abs2(aa - 4.0 * ys[k]);
        if gk > gap {
            gap = gk;
            y = ys[k];
        }
    }
    let s = c_sqrt(aa - 4.0 * y);
    let big_g = 0.5 * (a + s);
    let g = 0.5 * (a - s);
    let u = 0.5 * (b - y);
    var w = c_sqrt(c_mul(u, u) - d);
    if c_abs2(s) > 0.0 {
        w = c_div(c_mul(a, b - y) - 2.0 * c, 2.0 * s);
    }
    let big_h = u + w;
    let h = u - w;
    let one = vec2<f32>(1.0, 0.0);
    let r0 = solve_quadratic_complex(big_h, big_g, one);
    let r1 = solve_quadratic_complex(h, g, one);
    return array<vec2<f32>, 4>(r0[0], r0[1], r1[0], r1[1]);
}

fn reciprocal(x: f32) -> f32 {
    if abs(x) < 1e-20 {
        if x < 0.0 {
            return -1e20;
        }
        return 1e20;
    }
    return 1.0 / x;
}

fn interpolate(n: u32, x: array<f32, 5>, f: array<f32, 5>) -> array<f32, 5> {
    var d = f;
    for (var j = 1u; j < n; j++) {
        for (var i = n - 1u; i >= j; i--) {
            d[i] = (d[i] - d[i - 1u]) / (x[i] - x[i - j]);
        }
    }
    var p = array<f32, 5>();
    p[0] = d[n - 1u];
    for (var i = i32(n) - 2; i >= 0; i--) {
        for (var k = n - 1u; k >= 1u; k--) {
            p[k] = p[k - 1u] - x[i] * p[k];
        }
        p[0] = d[i] - x[i] * p[0];
    }
    return p;
}

fn interpolate_complex(n: u32, x: array<vec2<f32>, 5>, f: array<f32, 5>) -> array<vec2<f32>, 5> {
    var d = array<vec2<f32>, 5>();
    for (var i = 0u; i < n; i++) {
        d[i] = vec2<f32>(f[i], 0.0);
    }
    for (var j = 1u; j < n; j++) {
        for (var i = n - 1u; i >= j; i--) {
            d[i] = c_div(d[i] - d[i - 1u], x[i] - x[i - j]);
        }
    }
    var p = array<vec2<f32>, 5>();
    p[0] = d[n - 1u];
    for (var i = i32(n) - 2; i >= 0; i--) {
        for (var k = n - 1u; k >= 1u; k--) {
            p[k] = p[k - 1u] - c_mul(x[i], p[k]);
        }
        p[0] = d[i] - c_mul(x[i], p[0]);
    }
    return p;
}

fn absorbance_power(n: u32, m: array<f32, 9>, zw: f32, overestimation: f32) -> f32 {
    // LDL^T of the Hankel matrix B[i][j] = m[i + j].
    var l = array<array<f32, 5>, 5>();
    var dg = array<f32, 5>();
    for (var j = 0u; j < n; j++) {
        var djj = m[2u * j];
        for (var k = 0u; k < j; k++) {
            djj -= l[j][k] * l[j][k] * dg[k];
        }
        dg[j] = djj;
        for (var i = j + 1u; i < n; i++) {
            var lij = m[i + j];
            for (var k = 0u; k < j; k++) {
                lij -= l[i][k] * l[j][k] * dg[k];
            }
            l[i][j] = lij / djj;
        }
    }
    // B c = (1, z, z^2, ...).
    var c = array<f32, 5>();
    var power = 1.0;
    for (var i = 0u; i < n; i++) {
        var ci = power;
        for (var k = 0u; k < i; k++) {
            ci -= l[i][k] * c[k];
        }
        c[i] = ci;
        power *= zw;
    }
    for (var i = 0u; i < n; i++) {
        c[i] /= dg[i];
    }
    for (var i = i32(n) - 1; i >= 0; i--) {
        for (var k = u32(i) + 1u; k < n; k++) {
            c[i] -= l[k][i] * c[k];
        }
    }
    // Roots of the kernel polynomial (reversed when its leading coefficient is the smaller).
    let reversed = abs(c[n - 1u]) < abs(c[0]);
    var e = array<f32, 5>();
    for (var k = 0u; k < n; k++) {
        if reversed {
            e[k] = c[n - 1u - k];
        } else {
            e[k] = c[k];
        }
    }
    var x = array<f32, 5>(zw, 0.0, 0.0, 0.0, 0.0);
    if n == 3u {
        let r = solve_quadratic(e[0], e[1], e[2]);
        x[1] = r[0];
        x[2] = r[1];
    } else if n == 4u {
        let r = solve_cubic(e[0], e[1], e[2], e[3]);
        x[1] = r[0];
        x[2] = r[1];
        x[3] = r[2];
    } else {
        let r = solve_quartic(e[0], e[1], e[2], e[3], e[4]);
        x[1] = r[0];
        x[2] = r[1];
        x[3] = r[2];
        x[4] = r[3];
    }
    if reversed {
        for (var i = 1u; i < n; i++) {
            x[i] = reciprocal(x[i]);
        }
    }
    // Farthest root last (see oit_mboit::math).
    for (var i = 2u; i < n; i++) {
        var j = i;
        while j > 1u && abs(x[j - 1u]) > abs(x[j]) {
            let swap = x[j - 1u];
            x[j - 1u] = x[j];
            x[j] = swap;
            j -= 1u;
        }
    }
    var f = array<f32, 5>();
    f[0] = overestimation;
    for (var i = 1u; i < n; i++) {
        if x[i] < zw {
            f[i] = 1.0;
        }
    }
    let p = interpolate(n, x, f);
    var absorbance = 0.0;
    for (var k = 0u; k < n; k++) {
        absorbance += p[k] * m[k];
    }
    return absorbance;
}

fn absorbance_trig(n: u32, t: array<vec2<f32>, 5>, zw: f32, overestimation: f32, wrapping: vec4<f32>) -> f32 {
    // LDL^H of the Hermitian Toeplitz matrix B[i][j] = t[i - j].
    var l = array<array<vec2<f32>, 5>, 5>();
    var dg = array<f32, 5>();
    for (var j = 0u; j < n; j++) {
        var djj = t[0].x;
        for (var k = 0u; k < j; k++) {
            djj -= c_abs2(l[j][k]) * dg[k];
        }
        dg[j] = djj;
        for (var i = j + 1u; i < n; i++) {
            var lij = t[i - j];
            for (var k = 0u; k < j; k++) {
                lij -= c_mul(l[i][k], c_conj(l[j][k])) * dg[k];
            }
            l[i][j] = lij / djj;
        }
    }
    let phase = (zw + 1.0) * wrapping.y;
    let circle = vec2<f32>(cos(phase), sin(phase));
    var c = array<vec2<f32>, 5>();
    var power = vec2<f32>(1.0, 0.0);
    for (var i = 0u; i < n; i++) {
        var ci = power;
        for (var k = 0u; k < i; k++) {
            ci -= c_mul(l[i][k], c[k]);
        }
        c[i] = ci;
        power = c_mul(power, circle);
    }
    for (var i = 0u; i < n; i++) {
        c[i] /= dg[i];
    }
    for (var i = i32(n) - 1; i >= 0; i--) {
        for (var k = u32(i) + 1u; k < n; k++) {
            c[i] -= c_mul(c_conj(l[k][i]), c[k]);
        }
    }
    var x = array<vec2<f32>, 5>(circle, vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0));
    if n == 3u {
        let r = solve_quadratic_complex(c_conj(c[0]), c_conj(c[1]), c_conj(c[2]));
        x[1] = r[0];
        x[2] = r[1];
    } else if n == 4u {
        let r = solve_cubic_complex(c_conj(c[0]), c_conj(c[1]), c_conj(c[2]), c_conj(c[3]));
        x[1] = r[0];
        x[2] = r[1];
        x[3] = r[2];
    } else {
        let r = solve_quartic_complex(c_conj(c[0]), c_conj(c[1]), c_conj(c[2]), c_conj(c[3]), c_conj(c[4]));
        x[1] = r[0];
        x[2] = r[1];
        x[3] = r[2];
        x[4] = r[3];
    }
    let depth_parameter = circle_to_parameter(circle);
    var f = array<f32, 5>();
    f[0] = overestimation;
    for (var i = 1u; i < n; i++) {
        let root_parameter = circle_to_parameter(x[i] / sqrt(c_abs2(x[i])));
        if root_parameter < depth_parameter {
            f[i] = 1.0;
        }
        f[i] += clamp(root_parameter * wrapping.z + wrapping.w, 0.0, 1.0);
    }
    let p = interpolate_complex(n, x, f);
    var absorbance = 0.0;
    for (var k = 0u; k < n; k++) {
        absorbance += c_mul(p[k], t[k]).x;
    }
    return absorbance;
}

// Exponent bits all set: Inf or NaN (tested on the bits; compilers may fold `x != x`).
fn mboit_is_nan(x: f32) -> bool {
    let bits = bitcast<u32>(x);
    return (bits & 0x7f800000u) == 0x7f800000u && (bits & 0x007fffffu) != 0u;
}

// Transmittance in front of warped depth zw from the moment sums; 0 when the reconstruction is
// not a number (the fragment then adds nothing).
fn mboit_transmittance_at(kind: u32, b0: f32, b: array<f32, 8>, zw: f32, moment_bias: f32, bias_vector: array<f32, 8>, overestimation: f32, wrapping: vec4<f32>) -> f32 {
    let n = mboit_order(kind);
    let inv_b0 = 1.0 / b0;
    var absorbance: f32;
    if mboit_is_trig(kind) {
        var t = array<vec2<f32>, 5>();
        t[0] = vec2<f32>(1.0, 0.0);
        for (var k = 1u; k < n; k++) {
            let raw = vec2<f32>(b[2u * k - 2u], b[2u * k - 1u]) * inv_b0;
            t[k] = raw * (1.0 - moment_bias);
        }
        absorbance = absorbance_trig(n, t, zw, overestimation, wrapping);
    } else {
        var m = array<f32, 9>();
        m[0] = 1.0;
        for (var k = 1u; k < 2u * n - 1u; k++) {
            let raw = b[k - 1u] * inv_b0;
            m[k] = raw + (bias_vector[k - 1u] - raw) * moment_bias;
        }
        absorbance = absorbance_power(n, m, zw, overestimation);
    }
    let transmittance = exp(-b0 * absorbance);
    if mboit_is_nan(transmittance) {
        return 0.0;
    }
    return clamp(transmittance, 0.0, 1.0);
}
