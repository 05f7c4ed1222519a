//! Where ray coverage and rasterized coverage may differ. A ray meets the triangle as stored
//! (f32 world positions, lavapipe's ray–triangle test); the rasterizer, and the reference that
//! mirrors it, snap window coordinates to 1/256 pixel and apply the top-left fill rule. The two
//! agree on every pixel centre farther than a small band from a transparent triangle's
//! projected edge; inside the band either may include the triangle.

use oit_scene::Scene;

/// Half-width of the band, in pixels: snapping moves a vertex by up to 1/512 px per axis, so an
/// edge moves by less than 1/256 px; twice that covers the ray test's f32 rounding.
pub const BAND_PX: f64 = 1.0 / 128.0;

/// Per pixel (row-major): whether a transparent triangle's projected edge passes within
/// [`BAND_PX`] of its centre, so that rays and the rasterizer may disagree on whether the
/// triangle covers it. Edges are those of the triangle clipped to the near and far planes.
pub fn coverage_band(scene: &Scene) -> Vec<bool> {
    let (w, h) = (scene.resolution.width, scene.resolution.height);
    let mut band = vec![false; w as usize * h as usize];
    let view_proj = scene.camera.view_proj.as_dmat4();
    for d in &scene.draws {
        if !scene.material_of(d).mode.is_transparent() {
            continue;
        }
        for t in 0..d.triangle_count() {
            let first = (d.first_vertex + 3 * t) as usize;
            let clip: Vec<glam::DVec4> = (0..3)
                .map(|k| {
                    let v = glam::Vec3::from(scene.vertices[first + k].position).as_dvec3();
                    view_proj * v.extend(1.0)
                })
                .collect();
            // Near and far planes, 0 ≤ z ≤ w (either depth direction): both the rasterizer
            // and the ray (t from the near plane to the far plane) cut there, and the cut
            // is an edge of its own.
            let clipped = clip_polygon(clip, |c| c.z);
            let clipped = clip_polygon(clipped, |c| c.w - c.z);
            let p: Vec<[f64; 2]> = clipped
                .iter()
                .map(|c| {
                    [
                        (c.x / c.w + 1.0) * 0.5 * f64::from(w),
                        (1.0 - c.y / c.w) * 0.5 * f64::from(h),
                    ]
                })
                .collect();
            for e in 0..p.len() {
                mark_edge(&mut band, w, h, p[e], p[(e + 1) % p.len()]);
            }
        }
    }
    band
}

/// The part of convex polygon `poly` (clip space) where `inside` ≥ 0 (Sutherland–Hodgman).
fn clip_polygon(poly: Vec<glam::DVec4>, inside: impl Fn(glam::DVec4) -> f64) -> Vec<glam::DVec4> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (da, db) = (inside(a), inside(b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

/// Marks the pixels whose centre lies within [`BAND_PX`] of segment `a`–`b`.
fn mark_edge(band: &mut [bool], w: u32, h: u32, a: [f64; 2], b: [f64; 2]) {
    let lo = |i: usize| (a[i].min(b[i]) - BAND_PX - 0.5).floor().max(0.0);
    let hi = |i: usize, n: u32| {
        (a[i].max(b[i]) + BAND_PX - 0.5)
            .ceil()
            .min(f64::from(n) - 1.0)
    };
    let (x0, x1, y0, y1) = (lo(0), hi(0, w), lo(1), hi(1, h));
    if !(x0 <= x1 && y0 <= y1) {
        return;
    }
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    for y in y0 as u32..=y1 as u32 {
        for x in x0 as u32..=x1 as u32 {
            let (px, py) = (f64::from(x) + 0.5 - a[0], f64::from(y) + 0.5 - a[1]);
            // Distance to the segment (to its nearer end beyond the ends).
            let s = if len2 > 0.0 {
                ((px * dx + py * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (ex, ey) = (px - s * dx, py - s * dy);
            if ex * ex + ey * ey <= BAND_PX * BAND_PX {
                band[(y * w + x) as usize] = true;
            }
        }
    }
}
