//! Resource helpers shared by the two techniques: draw order and instance ids, bind group
//! entries, and the seed pass.

use glam::Vec3;
use oit_gpu::bind;
use oit_gpu::wgpu;
use oit_gpu::{Context, GpuError, GpuScene, ScenePipelines};
use oit_scene::{Draw, Scene};

/// Window depths this close may come out equal on the GPU. An f32 vertex depth and its
/// interpolation each land within a few ulps (under 1e-6 in [0, 1]) of the f64 depths
/// [`dither_order`] computes, so draws whose depth ranges are nearer than this are treated as
/// able to tie.
const TIE_MARGIN: f64 = 1.0 / 65536.0;

/// The order the dither passes issue the transparent draws in (indices into `scene.draws`).
///
/// With a strictly-nearer depth test, the image depends on the order only through exact depth
/// ties: the first survivor at a depth keeps it. The reference's rule is that the later draw
/// wins, so draws that could tie go in reverse draw order. Two draws whose window-depth ranges
/// are more than [`TIE_MARGIN`] apart never tie, though. So the draws are grouped by
/// overlapping ranges (directly or through other draws), each group in reverse draw order,
/// and the groups go nearest first: the depth test then rejects fragments behind a survivor
/// before they are shaded, as engines draw dithered objects front to back. The image is the
/// one plain reverse draw order gives, bit for bit. Draws without vertices draw nothing and
/// are left out.
pub fn dither_order(scene: &Scene) -> Vec<usize> {
    let mut ranges: Vec<(usize, f64, f64)> = scene
        .draws
        .iter()
        .enumerate()
        .filter(|(_, d)| d.vertex_count > 0 && scene.material_of(d).mode.is_transparent())
        .map(|(i, d)| {
            let (near, far) = nearness_range(scene, d).unwrap_or((f64::MIN, f64::MAX));
            (i, near, far)
        })
        .collect();
    ranges.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    let mut order = Vec::with_capacity(ranges.len());
    let mut group = Vec::new();
    let mut group_far = f64::MIN;
    for (i, near, far) in ranges {
        if !group.is_empty() && near > group_far + TIE_MARGIN {
            group.sort_unstable_by(|a: &usize, b| b.cmp(a));
            order.append(&mut group);
        }
        group.push(i);
        group_far = group_far.max(far);
    }
    group.sort_unstable_by(|a, b| b.cmp(a));
    order.append(&mut group);
    order
}

/// The window depths of a draw's fragments as a nearness range (the depth, negated under
/// reverse-Z, so that smaller is nearer): its vertices' `z / w`. Every point of a triangle
/// whose vertices have `w > 0` has a depth between theirs (z/w is a convex combination of
/// the vertices' along it), and so has what clipping keeps of it. None (unbounded) when a
/// vertex lies at or behind the eye plane.
fn nearness_range(scene: &Scene, draw: &Draw) -> Option<(f64, f64)> {
    let mut range = (f64::INFINITY, f64::NEG_INFINITY);
    for v in &scene.vertices[draw.vertex_range()] {
        let clip = scene.camera.clip(Vec3::from(v.position));
        let depth = f64::from(clip.z) / f64::from(clip.w);
        if !(clip.w > 0.0 && depth.is_finite()) {
            return None;
        }
        let nearness = if scene.camera.reverse_z {
            -depth
        } else {
            depth
        };
        range = (range.0.min(nearness), range.1.max(nearness));
    }
    Some(range)
}

/// The dither passes' draw order for one technique instance, computed once per uploaded
/// scene ([`GpuScene::id`]).
#[derive(Debug, Default)]
pub(crate) struct DrawOrder {
    /// Plain reverse draw order instead of [`dither_order`].
    reverse_only: bool,
    cached: Option<(u64, Vec<usize>)>,
}

impl DrawOrder {
    /// Plain reverse draw order: the same image as [`dither_order`], for tests and
    /// measurements.
    pub(crate) fn reverse_only() -> Self {
        DrawOrder {
            reverse_only: true,
            cached: None,
        }
    }

    pub(crate) fn of(&mut self, scene: &GpuScene) -> &[usize] {
        if self.cached.as_ref().is_none_or(|(id, _)| *id != scene.id) {
            let order = if self.reverse_only {
                let mut order = scene.transparent_draws();
                order.reverse();
                order
            } else {
                dither_order(&scene.scene)
            };
            self.cached = Some((scene.id, order));
        }
        &self.cached.as_ref().expect("set above").1
    }
}

/// Draws one scene draw as instance `draw.id` (the vertex stage reads it as the object seed).
pub(crate) fn draw_with_id(
    pass: &mut wgpu::RenderPass<'_>,
    scene: &GpuScene,
    pipelines: &ScenePipelines,
    index: usize,
) {
    let d = &scene.scene.draws[index];
    if d.vertex_count == 0 {
        return;
    }
    scene.use_draw(pass, pipelines, index);
    // Not indexed (GpuScene::draw_range): the vertex stage seeds each triangle with its vertex
    // index divided by 3, which only a non-indexed draw makes the triangle's own.
    pass.draw(
        d.first_vertex..d.first_vertex + d.vertex_count,
        d.id..d.id + 1,
    );
}

/// WGSL of the fullscreen pass that copies the opaque pass's colour and depth into other
/// targets (the multisampled ones of `a2c`, the per-frame ones of `stochastic:spp=N`).
pub const SEED_WGSL: &str = include_str!("../shaders/stochastic_seed.wgsl");

/// A fullscreen pass writing the opaque colour and depth (read from the final targets) into
/// other targets. A draw rather than `copy_texture_to_texture`: wgpu's GL backend leaves a
/// depth copy undone without an error.
#[derive(Debug)]
pub(crate) struct SeedPass {
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    /// The same copy of the depth alone (colour writes off), when asked for
    /// ([`SeedPass::with_depth_reset`]).
    depth_reset: Option<wgpu::RenderPipeline>,
}

impl SeedPass {
    pub fn new(
        ctx: &Context,
        color_format: wgpu::TextureFormat,
        multisample: wgpu::MultisampleState,
    ) -> Result<Self, GpuError> {
        Self::build(ctx, color_format, multisample, false)
    }

    /// [`SeedPass::new`] plus the depth-only copy of [`SeedPass::draw_depth_reset`].
    pub fn with_depth_reset(
        ctx: &Context,
        color_format: wgpu::TextureFormat,
    ) -> Result<Self, GpuError> {
        Self::build(ctx, color_format, Default::default(), true)
    }

    fn build(
        ctx: &Context,
        color_format: wgpu::TextureFormat,
        multisample: wgpu::MultisampleState,
        depth_reset: bool,
    ) -> Result<Self, GpuError> {
        // Depth32Float is bound as an unfilterable float texture (WebGPU allows it): GLSL has
        // no texelFetch of depth (shadow) textures.
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("stochastic seed"),
            entries: &[
                bind::float_texture(0, wgpu::ShaderStages::FRAGMENT),
                bind::float_texture(1, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let module = ctx.shader_with("stochastic_seed.wgsl", SEED_WGSL, &[crate::SHADERS])?;
        let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("stochastic seed"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let seed = |label, write_mask| {
            oit_gpu::fullscreen_pipeline(
                ctx,
                &oit_gpu::FullscreenDesc {
                    label,
                    layout: &pipeline_layout,
                    module: &module,
                    fragment_entry: "fs_seed",
                    targets: &[Some(wgpu::ColorTargetState {
                        format: color_format,
                        blend: None,
                        write_mask,
                    })],
                    depth: Some(oit_gpu::depth_test(wgpu::CompareFunction::Always, true)),
                    multisample,
                    constants: &[],
                },
            )
        };
        let pipeline = seed("stochastic seed", wgpu::ColorWrites::ALL);
        let depth_reset =
            depth_reset.then(|| seed("stochastic depth reset", wgpu::ColorWrites::empty()));
        Ok(SeedPass {
            layout,
            pipeline,
            depth_reset,
        })
    }

    /// Puts the opaque depth back and leaves the colour as it is (between the per-channel
    /// dither passes of coloured transmission). Needs a pass built `with_depth_reset`.
    pub fn draw_depth_reset(&self, pass: &mut wgpu::RenderPass<'_>, bind_group: &wgpu::BindGroup) {
        let pipeline = self
            .depth_reset
            .as_ref()
            .expect("SeedPass built with_depth_reset");
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.draw(0..3, 0..1);
    }

    /// The bind group reading `targets` (made per frame: targets are the caller's).
    pub fn bind_group(&self, ctx: &Context, targets: &oit_gpu::Targets) -> wgpu::BindGroup {
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("stochastic seed"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&targets.color_view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&targets.depth_view),
                },
            ],
        })
    }

    /// Draws the copy into the pass's attachments (which must be those it was built for).
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, bind_group: &wgpu::BindGroup) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Blended unit quads at `(x, z)`, turned `tilt` degrees about the y axis, listed in draw
    /// order and seen from z = 5 (perspective, or orthographic), with reverse-Z on or off.
    fn quads(at: &[(f32, f32, f32)], reverse_z: bool, orthographic: bool) -> Scene {
        let objects: Vec<String> = at
            .iter()
            .map(|(x, z, tilt)| {
                format!(
                    r#"{{"mesh": {{"kind": "quad", "size": [1, 1]}}, "transform": {{"translate": [{x}, 0, {z}], "rotate": [0, {tilt}, 0]}}, "material": {{"base_color": [1, 0, 0], "alpha": 0.5, "mode": "blend"}}}}"#
                )
            })
            .collect();
        let projection = if orthographic {
            r#""orthographic": {"height": 4}"#
        } else {
            r#""fov_y": 45"#
        };
        let json = format!(
            r#"{{"name": "quads", "resolution": [64, 64], "reverse_z": {reverse_z},
                "camera": {{"eye": [0, 0, 5], "target": [0, 0, 0], "up": [0, 1, 0], {projection}, "near": 0.1, "far": 100}},
                "objects": [{}]}}"#,
            objects.join(",")
        );
        oit_scene::parse(&json, "quads").expect("test scene")
    }

    #[test]
    fn separated_layers_go_nearest_first_in_every_depth_convention() {
        // Listed far, near, middle: the draw order is neither front to back nor back to front.
        let at = [(0.0, -2.0, 0.0), (0.0, 1.0, 0.0), (0.0, -0.5, 30.0)];
        for reverse_z in [true, false] {
            for orthographic in [true, false] {
                let scene = quads(&at, reverse_z, orthographic);
                assert_eq!(
                    dither_order(&scene),
                    [1, 2, 0],
                    "reverse_z {reverse_z}, orthographic {orthographic}"
                );
            }
        }
    }

    #[test]
    fn draws_that_could_tie_keep_reverse_draw_order() {
        // 0 and 2 are coplanar (side by side, so their centres differ), 1 is nearer, 3 is far
        // behind: {0, 2} stay in reverse draw order between 1 and 3.
        let scene = quads(
            &[
                (-0.8, 0.0, 0.0),
                (0.0, 2.0, 0.0),
                (0.8, 0.0, 0.0),
                (0.0, -3.0, 0.0),
            ],
            true,
            false,
        );
        assert_eq!(dither_order(&scene), [1, 2, 0, 3]);
        // Ranges closer than the margin count as touching: 1e-6 apart in z is far below it.
        let scene = quads(
            &[(0.0, 0.0, 0.0), (0.0, 1e-6, 0.0), (0.0, 2.0, 0.0)],
            true,
            true,
        );
        assert_eq!(dither_order(&scene), [2, 1, 0]);
    }

    #[test]
    fn overlap_chains_join_one_group() {
        // Tilted 60°, each quad spans ±0.43 in z: the ones at z = 1.4 and z = 0 are apart, but
        // the one at z = 0.7 overlaps both, so the three keep reverse draw order (nearest first
        // would be 0, 2, 1); the flat quad far behind them comes last.
        let scene = quads(
            &[
                (0.0, 1.4, 60.0),
                (0.0, 0.0, 60.0),
                (0.0, 0.7, 60.0),
                (0.0, -3.0, 0.0),
            ],
            false,
            false,
        );
        assert_eq!(dither_order(&scene), [2, 1, 0, 3]);
        // Without the middle one, the two are apart and go nearest first.
        let scene = quads(&[(0.0, 0.0, 60.0), (0.0, 1.4, 60.0)], false, false);
        assert_eq!(dither_order(&scene), [1, 0]);
    }

    #[test]
    fn a_draw_reaching_behind_the_eye_keeps_everything_in_reverse_draw_order() {
        // The last quad lies behind the eye (z = 6 > 5): its depth range is unbounded.
        let scene = quads(
            &[(0.0, -2.0, 0.0), (0.0, 1.0, 0.0), (0.0, 6.0, 0.0)],
            true,
            false,
        );
        assert_eq!(dither_order(&scene), [2, 1, 0]);
    }
}
