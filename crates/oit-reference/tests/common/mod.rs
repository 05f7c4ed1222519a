//! Test support: builds `Scene` values by hand (no loader), so the reference is tested on
//! geometry whose coverage and colours can be worked out on paper.
#![allow(
    dead_code,
    reason = "each test binary uses a different subset of the helpers"
)]

use glam::Vec3;
use oit_scene::{
    AlphaMode, Camera, Draw, LinearImage, Material, Projection, Resolution, Scene, Vertex,
};

/// A material with straight colour `rgb`, coverage `alpha` and mode `mode`.
pub fn material(rgb: [f32; 3], alpha: f32, mode: AlphaMode) -> Material {
    Material::plain(rgb, alpha, mode)
}

pub fn blend(rgb: [f32; 3], alpha: f32) -> Material {
    material(rgb, alpha, AlphaMode::Blend)
}

pub fn opaque(rgb: [f32; 3]) -> Material {
    material(rgb, 1.0, AlphaMode::Opaque)
}

pub fn double_sided(mut m: Material) -> Material {
    m.double_sided = true;
    m
}

/// Orthographic camera looking down −z from z = 10 whose view volume is x, y in [−1, 1]
/// (square resolutions): NDC x, y equal world x, y, so window positions are exact dyadics.
pub fn ortho_camera(width: u32, height: u32, reverse_z: bool) -> Camera {
    Camera::new(
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Orthographic { height: 2.0 },
        0.5,
        100.0,
        reverse_z,
        width as f32 / height as f32,
    )
}

pub fn white() -> [f32; 4] {
    [1.0; 4]
}

#[derive(Debug)]
pub struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    /// Empty scene at `width`x`height` with [`ortho_camera`] (reverse-Z) and a black background.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            scene: Scene {
                name: "test".into(),
                description: "hand-built test scene".into(),
                resolution: Resolution { width, height },
                camera: ortho_camera(width, height, true),
                background: [0.0; 3],
                materials: Vec::new(),
                draws: Vec::new(),
                vertices: Vec::new(),
                textures: Vec::new(),
                ignored: Vec::new(),
                credits: Vec::new(),
                frame: 0,
                animation: None,
                lights: oit_scene::LightRig::none(),
            },
        }
    }

    pub fn camera(mut self, camera: Camera) -> Self {
        self.scene.camera = camera;
        self
    }

    pub fn background(mut self, rgb: [f32; 3]) -> Self {
        self.scene.background = rgb;
        self
    }

    /// Adds a draw of `triangles` (each `[position; 3]`) with per-vertex colour `color`.
    pub fn triangles(
        &mut self,
        material: Material,
        triangles: &[[Vec3; 3]],
        color: [f32; 4],
    ) -> &mut Self {
        let tris: Vec<[(Vec3, [f32; 4]); 3]> =
            triangles.iter().map(|t| t.map(|p| (p, color))).collect();
        self.colored_triangles(material, &tris)
    }

    /// Adds a draw whose vertices carry their own colours.
    pub fn colored_triangles(
        &mut self,
        material: Material,
        triangles: &[[(Vec3, [f32; 4]); 3]],
    ) -> &mut Self {
        let material_index = self.scene.materials.len() as u32;
        self.scene.materials.push(material);
        let first = self.scene.vertices.len() as u32;
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for t in triangles {
            for (p, c) in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
                self.scene.vertices.push(Vertex {
                    position: p.to_array(),
                    color: *c,
                    uv: [0.0; 2],
                    normal: [0.0; 3],
                });
            }
        }
        let id = self.scene.draws.len() as u32;
        self.scene.draws.push(Draw {
            id,
            name: format!("objects[{id}]"),
            material: material_index,
            first_vertex: first,
            vertex_count: 3 * triangles.len() as u32,
            ordering: Default::default(),
            bounds_center: (lo + hi) * 0.5,
            bounds_radius: (hi - lo).length() * 0.5,
        });
        self
    }

    /// Adds a quad a, b, c, d (counter-clockwise seen from its front) as triangles (a, b, c),
    /// (a, c, d).
    pub fn quad(&mut self, material: Material, corners: [Vec3; 4], color: [f32; 4]) -> &mut Self {
        let [a, b, c, d] = corners;
        self.triangles(material, &[[a, b, c], [a, c, d]], color)
    }

    pub fn build(&self) -> Scene {
        self.scene.clone()
    }
}

/// Axis-aligned quad in the plane z = `z`, counter-clockwise seen from +z.
pub fn rect(x0: f32, y0: f32, x1: f32, y1: f32, z: f32) -> [Vec3; 4] {
    [
        Vec3::new(x0, y0, z),
        Vec3::new(x1, y0, z),
        Vec3::new(x1, y1, z),
        Vec3::new(x0, y1, z),
    ]
}

/// Full-screen quad of [`ortho_camera`] at depth `z`.
pub fn fullscreen(z: f32) -> [Vec3; 4] {
    rect(-1.5, -1.5, 1.5, 1.5, z)
}

/// World x (or y) of window position `p` pixels under [`ortho_camera`] at `size` pixels:
/// x_win = (x + 1) · size / 2.
pub fn world_of_window_x(p: f64, size: u32) -> f32 {
    (p * 2.0 / f64::from(size) - 1.0) as f32
}

/// World y of window row position `p` (rows grow downwards).
pub fn world_of_window_y(p: f64, size: u32) -> f32 {
    (1.0 - p * 2.0 / f64::from(size)) as f32
}

/// The image's bit patterns: outputs must be identical, not merely equal as floats.
pub fn image_bits(image: &LinearImage) -> Vec<u32> {
    image
        .pixels
        .iter()
        .flat_map(|p| p.map(f32::to_bits))
        .collect()
}

pub fn assert_all_finite(image: &LinearImage) {
    for (i, px) in image.pixels.iter().enumerate() {
        assert!(
            px.iter().all(|c| c.is_finite()),
            "pixel {i} is not finite: {px:?}"
        );
    }
}
