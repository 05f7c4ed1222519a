//! Procedural meshes as non-indexed triangle lists with per-vertex normals, colours and uvs.
//!
//! Conventions: every closed or single-sided mesh has counter-clockwise front faces when seen
//! from outside (the side its normals point to), which is wgpu's `FrontFace::Ccw` with y up.
//! Quads and layers lie in the local XY plane facing +z; sphere, torus and cylinder have their
//! axis along local +y. Validated parameters only: `load.rs` checks ranges before calling here.

use glam::{Affine3A, Vec2, Vec3, Vec4};

use crate::format::{
    BoxMesh, CylinderMesh, LayersMesh, QuadMesh, RawMesh, ScatterMesh, SphereMesh, TorusMesh,
};
use crate::rng::SplitMix64;

/// Geometry of one mesh. `parts` split it into draws (one per layer for `layers`, else one).
#[derive(Debug, Default, Clone)]
pub(crate) struct Geometry {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub colors: Vec<Vec4>,
    pub uvs: Vec<Vec2>,
    /// Vertex ranges, each a multiple of 3.
    pub parts: Vec<std::ops::Range<usize>>,
}

impl Geometry {
    fn with_capacity(triangles: usize) -> Self {
        Self {
            positions: Vec::with_capacity(triangles * 3),
            normals: Vec::with_capacity(triangles * 3),
            colors: Vec::with_capacity(triangles * 3),
            uvs: Vec::with_capacity(triangles * 3),
            parts: Vec::new(),
        }
    }

    fn push(&mut self, p: Vec3, n: Vec3, c: Vec4, uv: Vec2) {
        self.positions.push(p);
        self.normals.push(n);
        self.colors.push(c);
        self.uvs.push(uv);
    }

    /// A quad `a b c d` (counter-clockwise seen from its front) as triangles (a b c) (a c d).
    fn quad(&mut self, v: [(Vec3, Vec3, Vec4, Vec2); 4]) {
        for i in [0, 1, 2, 0, 2, 3] {
            let (p, n, c, uv) = v[i];
            self.push(p, n, c, uv);
        }
    }

    /// One triangle, oriented so that its geometric normal agrees with the analytic normals:
    /// parametric surfaces then cannot get a face backwards by a sign slip in the formulas.
    fn oriented_triangle(&mut self, v: [(Vec3, Vec3, Vec2); 3], c: Vec4) {
        let face = (v[1].0 - v[0].0).cross(v[2].0 - v[0].0);
        let order = if face.dot(v[0].1 + v[1].1 + v[2].1) >= 0.0 {
            [0, 1, 2]
        } else {
            [0, 2, 1]
        };
        for i in order {
            self.push(v[i].0, v[i].1, c, v[i].2);
        }
    }

    fn close_part(&mut self) {
        let start = self.parts.last().map_or(0, |r| r.end);
        self.parts.push(start..self.positions.len());
    }
}

/// Triangle count of a mesh, saturating, computed without generating it (for the memory cap).
pub(crate) fn triangle_count(mesh: &RawMesh) -> u64 {
    let m = |a: u32, b: u32| u64::from(a).saturating_mul(u64::from(b));
    match mesh {
        RawMesh::Quad(_) => 2,
        RawMesh::Box(_) => 12,
        RawMesh::UvSphere(s) => m(2, s.segments).saturating_mul(u64::from(s.rings.max(1)) - 1),
        RawMesh::Torus(t) => m(2, t.segments).saturating_mul(u64::from(t.tube_segments)),
        RawMesh::Cylinder(c) => m(if c.capped { 4 } else { 2 }, c.segments),
        RawMesh::Layers(l) => m(2, l.count),
        RawMesh::Soup(s) => u64::from(s.count),
        RawMesh::Billboards(b) => m(2, b.count),
    }
}

/// Local-space geometry of every kind except billboards (which depend on the camera and the
/// world transform; see [`billboards`]).
pub(crate) fn local(mesh: &RawMesh) -> Geometry {
    match mesh {
        RawMesh::Quad(q) => quad(q),
        RawMesh::Box(b) => cuboid(b),
        RawMesh::UvSphere(s) => sphere(s),
        RawMesh::Torus(t) => torus(t),
        RawMesh::Cylinder(c) => cylinder(c),
        RawMesh::Layers(l) => layers(l),
        RawMesh::Soup(s) => soup(s),
        // Built in world space by `billboards`; the loader never asks for them here.
        RawMesh::Billboards(_) => Geometry::default(),
    }
}

const WHITE: Vec4 = Vec4::ONE;

fn quad(q: &QuadMesh) -> Geometry {
    let (hx, hy) = (q.size[0] * 0.5, q.size[1] * 0.5);
    let n = Vec3::Z;
    let a = q.corner_alpha;
    let mut g = Geometry::with_capacity(2);
    g.quad([
        (
            Vec3::new(-hx, -hy, 0.0),
            n,
            Vec4::new(1.0, 1.0, 1.0, a[0]),
            Vec2::new(0.0, 1.0),
        ),
        (
            Vec3::new(hx, -hy, 0.0),
            n,
            Vec4::new(1.0, 1.0, 1.0, a[1]),
            Vec2::new(1.0, 1.0),
        ),
        (
            Vec3::new(hx, hy, 0.0),
            n,
            Vec4::new(1.0, 1.0, 1.0, a[2]),
            Vec2::new(1.0, 0.0),
        ),
        (
            Vec3::new(-hx, hy, 0.0),
            n,
            Vec4::new(1.0, 1.0, 1.0, a[3]),
            Vec2::new(0.0, 0.0),
        ),
    ]);
    g.close_part();
    g
}

/// A rectangle centred at `c` spanned by half-axes `u`, `v` with `u × v` along the front normal.
fn face(g: &mut Geometry, c: Vec3, u: Vec3, v: Vec3, color: Vec4) {
    let n = u.cross(v).normalize();
    g.quad([
        (c - u - v, n, color, Vec2::new(0.0, 1.0)),
        (c + u - v, n, color, Vec2::new(1.0, 1.0)),
        (c + u + v, n, color, Vec2::new(1.0, 0.0)),
        (c - u + v, n, color, Vec2::new(0.0, 0.0)),
    ]);
}

fn cuboid(b: &BoxMesh) -> Geometry {
    let h = Vec3::from(b.size) * 0.5;
    let (x, y, z) = (Vec3::X * h.x, Vec3::Y * h.y, Vec3::Z * h.z);
    let mut g = Geometry::with_capacity(12);
    face(&mut g, z, x, y, WHITE); // +z
    face(&mut g, -z, -x, y, WHITE); // -z
    face(&mut g, x, -z, y, WHITE); // +x
    face(&mut g, -x, z, y, WHITE); // -x
    face(&mut g, y, x, -z, WHITE); // +y
    face(&mut g, -y, x, z, WHITE); // -y
    g.close_part();
    g
}

fn sphere(s: &SphereMesh) -> Geometry {
    let (seg, rings) = (s.segments, s.rings);
    let point = |ring: u32, j: u32| -> (Vec3, Vec3, Vec2) {
        let uv = Vec2::new(j as f32 / seg as f32, ring as f32 / rings as f32);
        // Exact poles, so the fan triangles there share one vertex.
        if ring == 0 {
            return (Vec3::Y * s.radius, Vec3::Y, uv);
        }
        if ring == rings {
            return (-Vec3::Y * s.radius, -Vec3::Y, uv);
        }
        let theta = std::f32::consts::PI * ring as f32 / rings as f32;
        let phi = std::f32::consts::TAU * (j % seg) as f32 / seg as f32;
        let n = Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            -theta.sin() * phi.sin(),
        );
        (n * s.radius, n, uv)
    };
    let mut g = Geometry::with_capacity(2 * seg as usize * (rings as usize - 1));
    for ring in 0..rings {
        for j in 0..seg {
            let (a, b) = (point(ring, j), point(ring, j + 1));
            let (c, d) = (point(ring + 1, j + 1), point(ring + 1, j));
            if ring == 0 {
                g.oriented_triangle([a, d, c], WHITE);
            } else if ring + 1 == rings {
                g.oriented_triangle([a, d, b], WHITE);
            } else {
                g.oriented_triangle([a, d, c], WHITE);
                g.oriented_triangle([a, c, b], WHITE);
            }
        }
    }
    g.close_part();
    g
}

fn torus(t: &TorusMesh) -> Geometry {
    let (seg, tube) = (t.segments, t.tube_segments);
    let point = |i: u32, j: u32| -> (Vec3, Vec3, Vec2) {
        let phi = std::f32::consts::TAU * (i % seg) as f32 / seg as f32;
        let theta = std::f32::consts::TAU * (j % tube) as f32 / tube as f32;
        let n = Vec3::new(
            theta.cos() * phi.cos(),
            theta.sin(),
            theta.cos() * phi.sin(),
        );
        let centre = Vec3::new(phi.cos(), 0.0, phi.sin()) * t.major_radius;
        let uv = Vec2::new(i as f32 / seg as f32, j as f32 / tube as f32);
        (centre + n * t.minor_radius, n, uv)
    };
    let mut g = Geometry::with_capacity(2 * seg as usize * tube as usize);
    for i in 0..seg {
        for j in 0..tube {
            let (a, b, c, d) = (
                point(i, j),
                point(i + 1, j),
                point(i + 1, j + 1),
                point(i, j + 1),
            );
            g.oriented_triangle([a, b, c], WHITE);
            g.oriented_triangle([a, c, d], WHITE);
        }
    }
    g.close_part();
    g
}

fn cylinder(c: &CylinderMesh) -> Geometry {
    let seg = c.segments;
    let h = c.height * 0.5;
    let radial = |j: u32| {
        let phi = std::f32::consts::TAU * (j % seg) as f32 / seg as f32;
        Vec3::new(phi.cos(), 0.0, -phi.sin())
    };
    let mut g = Geometry::with_capacity(4 * seg as usize);
    for j in 0..seg {
        let (n0, n1) = (radial(j), radial(j + 1));
        let (u0, u1) = (j as f32 / seg as f32, (j + 1) as f32 / seg as f32);
        let a = (n0 * c.radius - Vec3::Y * h, n0, Vec2::new(u0, 1.0));
        let b = (n1 * c.radius - Vec3::Y * h, n1, Vec2::new(u1, 1.0));
        let cc = (n1 * c.radius + Vec3::Y * h, n1, Vec2::new(u1, 0.0));
        let d = (n0 * c.radius + Vec3::Y * h, n0, Vec2::new(u0, 0.0));
        g.oriented_triangle([a, b, cc], WHITE);
        g.oriented_triangle([a, cc, d], WHITE);
    }
    if c.capped {
        for (y, n) in [(h, Vec3::Y), (-h, -Vec3::Y)] {
            for j in 0..seg {
                let (r0, r1) = (radial(j), radial(j + 1));
                let uv = |r: Vec3| Vec2::new(0.5 + 0.5 * r.x, 0.5 + 0.5 * r.z);
                g.oriented_triangle(
                    [
                        (Vec3::Y * y, n, Vec2::splat(0.5)),
                        (r0 * c.radius + Vec3::Y * y, n, uv(r0)),
                        (r1 * c.radius + Vec3::Y * y, n, uv(r1)),
                    ],
                    WHITE,
                );
            }
        }
    }
    g.close_part();
    g
}

/// `count` quads in planes z = -i·spacing (layer 0 at z = 0, nearest to a camera on +z), each
/// its own part (draw) so per-object sorting can order them. Colour and alpha ramp linearly
/// with t = i / (count - 1) (t = 0 for a single layer) and are stored in the vertex colour.
fn layers(l: &LayersMesh) -> Geometry {
    let mut g = Geometry::with_capacity(2 * l.count as usize);
    let (from, to) = (Vec3::from(l.color_from), Vec3::from(l.color_to));
    let (hx, hy) = (l.size[0] * 0.5, l.size[1] * 0.5);
    for i in 0..l.count {
        let t = if l.count > 1 {
            i as f32 / (l.count - 1) as f32
        } else {
            0.0
        };
        let rgb = from + (to - from) * t;
        let alpha = l.alpha_from + (l.alpha_to - l.alpha_from) * t;
        let color = rgb.extend(alpha);
        let z = -(i as f32) * l.spacing;
        let n = Vec3::Z;
        g.quad([
            (Vec3::new(-hx, -hy, z), n, color, Vec2::new(0.0, 1.0)),
            (Vec3::new(hx, -hy, z), n, color, Vec2::new(1.0, 1.0)),
            (Vec3::new(hx, hy, z), n, color, Vec2::new(1.0, 0.0)),
            (Vec3::new(-hx, hy, z), n, color, Vec2::new(0.0, 0.0)),
        ]);
        g.close_part();
    }
    g
}

fn random_color(r: &mut SplitMix64, s: &ScatterMesh) -> Vec4 {
    Vec4::new(
        r.range(s.color_min[0], s.color_max[0]),
        r.range(s.color_min[1], s.color_max[1]),
        r.range(s.color_min[2], s.color_max[2]),
        r.range(s.alpha_min, s.alpha_max),
    )
}

fn random_point(r: &mut SplitMix64, s: &ScatterMesh) -> Vec3 {
    Vec3::new(
        r.range(s.bounds.min[0], s.bounds.max[0]),
        r.range(s.bounds.min[1], s.bounds.max[1]),
        r.range(s.bounds.min[2], s.bounds.max[2]),
    )
}

/// A uniformly random unit vector (Marsaglia's method: 2D rejection, no trigonometry needed
/// beyond a square root, so it is the same on every platform).
fn random_unit(r: &mut SplitMix64) -> Vec3 {
    loop {
        let (a, b) = (r.range(-1.0, 1.0), r.range(-1.0, 1.0));
        let s = a * a + b * b;
        if s < 1.0 && s > 1e-6 {
            let k = 2.0 * (1.0 - s).sqrt();
            return Vec3::new(a * k, b * k, 1.0 - 2.0 * s);
        }
    }
}

/// Two unit vectors completing `n` to a right-handed frame (`u × v = n`).
fn frame(n: Vec3, hint: Vec3) -> (Vec3, Vec3) {
    let hint = if n.cross(hint).length_squared() < 1e-6 {
        if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y }
    } else {
        hint
    };
    let u = hint.cross(n).normalize();
    let v = n.cross(u);
    (u, v)
}

/// `count` equilateral triangles with circumradius `size`, random centres in `bounds`, random
/// orientation and a flat random colour each. Never degenerate, so every face normal is defined.
fn soup(s: &ScatterMesh) -> Geometry {
    let mut r = SplitMix64::new(s.seed);
    let mut g = Geometry::with_capacity(s.count as usize);
    for _ in 0..s.count {
        let centre = random_point(&mut r, s);
        let n = random_unit(&mut r);
        let spin = r.range(0.0, std::f32::consts::TAU);
        let color = random_color(&mut r, s);
        let (u, v) = frame(n, Vec3::Y);
        for k in 0..3 {
            let a = spin + k as f32 * std::f32::consts::TAU / 3.0;
            let p = centre + (u * a.cos() + v * a.sin()) * s.size;
            let uv = Vec2::new(0.5 + 0.5 * a.cos(), 0.5 - 0.5 * a.sin());
            g.push(p, n, color, uv);
        }
    }
    g.close_part();
    g
}

/// Where billboards look: at the eye (perspective) or against the view direction (orthographic).
#[derive(Debug, Clone, Copy)]
pub(crate) enum Facing {
    Eye(Vec3),
    Direction(Vec3),
}

/// `count` square billboards of side `size` (world units) centred at random points of `bounds`
/// (object space, moved by `world`), built in world space facing the camera, with the camera's
/// `up` as the billboard's up where possible. Normals point towards the camera.
pub(crate) fn billboards(s: &ScatterMesh, world: &Affine3A, facing: Facing, up: Vec3) -> Geometry {
    let mut r = SplitMix64::new(s.seed);
    let mut g = Geometry::with_capacity(2 * s.count as usize);
    let h = s.size * 0.5;
    for _ in 0..s.count {
        let centre = world.transform_point3(random_point(&mut r, s));
        let color = random_color(&mut r, s);
        let n = match facing {
            Facing::Eye(eye) => (eye - centre).normalize_or(Vec3::Z),
            Facing::Direction(d) => d,
        };
        // right = up × n, upv = n × right, so right × upv = n: counter-clockwise seen from n.
        let (right, upv) = frame(n, up);
        g.quad([
            (centre - right * h - upv * h, n, color, Vec2::new(0.0, 1.0)),
            (centre + right * h - upv * h, n, color, Vec2::new(1.0, 1.0)),
            (centre + right * h + upv * h, n, color, Vec2::new(1.0, 0.0)),
            (centre - right * h + upv * h, n, color, Vec2::new(0.0, 0.0)),
        ]);
    }
    g.close_part();
    g
}
