//! The tiled threshold lookup of shaders/stochastic_dither.wgsl (`tiled_threshold`: the table
//! texture shifted by seed and frame, its value rotated per frame) against its CPU twin
//! (`oit_stochastic::pattern::tiled_threshold` over the tables `pattern::table` builds), on the
//! GPU, bit for bit: every step is exact in f32 (integer shifts and masks, a 24-bit hash scaled
//! by a power of two, one addition and `fract`), so any conformant adapter must agree to the
//! bit. The uniform is the production one (`dither_words`). cargo-mutants does not mutate WGSL:
//! a mask, shift or hash constant changed on one side only fails here. `pcg`, which seeded
//! frames hash their rotation with, is twinned in Rust too (`pattern::pcg`). The `stbn` pattern
//! goes through the same shader function (its slice's rows, its period's shift, no rotation)
//! and is held against `pattern::stbn_threshold`, across slice and period boundaries.
//!
//! Not twinned: white noise (`pcg4d`) and hashed alpha (`cell_hash`, `hashed_threshold`) have
//! no CPU counterpart, since no CPU code needs their values; what they must deliver, uniform
//! unbiased thresholds, is asserted from images in `stochastic::gpu` (convergence at spp^−½ and
//! the bias bound at spp = 64).

use oit_gpu::testing::{context_or_skip, eval_f32_with, uniform_buffer};
use oit_gpu::wgpu;
use oit_stochastic::pattern;
use oit_stochastic::{DITHER_WGSL, Pattern, Seed, StochasticConfig, dither_words};

/// Pixels: the origin, tile edges of every size, and far coordinates (16 383 is the largest
/// texture side an adapter is likely to have).
const PIXELS: [u32; 12] = [0, 1, 3, 4, 7, 31, 63, 64, 100, 255, 1000, 16383];

/// Seeds: none, each 16-bit half alone, both halves full, and hashed draw seeds as the vertex
/// stage makes them (`pcg(draw id + 1)`).
fn seeds() -> Vec<u32> {
    let mut s = vec![0, 1, 0xffff, 0x1_0000, 0xffff_ffff, 0x8000_8000];
    s.extend((1..=4).map(pattern::pcg));
    s
}

/// `(pixel x, pixel y, seed low 16 bits, seed high 16 bits)`: integers exactly in f32.
fn inputs() -> Vec<[f32; 4]> {
    let mut out = Vec::new();
    for (i, &x) in PIXELS.iter().enumerate() {
        for &y in &PIXELS[i % 4..] {
            for seed in seeds() {
                out.push([
                    x as f32,
                    y as f32,
                    (seed & 0xffff) as f32,
                    (seed >> 16) as f32,
                ]);
            }
        }
    }
    out
}

#[test]
fn tiled_threshold_on_the_gpu_equals_its_cpu_twin_bit_for_bit() {
    let Some(ctx) = context_or_skip("stochastic_tiled_threshold_twin") else {
        return;
    };
    let source = oit_gpu::shaders::compose_with(DITHER_WGSL, &[oit_stochastic::SHADERS])
        .expect("includes resolve");
    let inputs = inputs();
    let expr = "tiled_threshold(vec2<u32>(x.xy), u32(x.z) | (u32(x.w) << 16u))";
    let mut failures = Vec::new();
    let mut compared = 0;
    for pattern in [
        Pattern::Blue,
        Pattern::Bayer4,
        Pattern::Bayer16,
        Pattern::Bayer256,
        Pattern::Stbn,
    ] {
        let side = pattern.tile().expect("tiled pattern");
        let (_, rows) = pattern.table_size();
        let table = pattern::table(pattern);
        let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("threshold table"),
            size: wgpu::Extent3d {
                width: side,
                height: rows,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        ctx.queue.write_texture(
            texture.as_image_copy(),
            bytemuck::cast_slice(&table),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(side * 4),
                rows_per_image: Some(rows),
            },
            texture.size(),
        );
        let view = texture.create_view(&Default::default());
        // Primitive seeds take the same branch as object seeds; both are run, so a shader that
        // tested `seed_mode == SEED_OBJECT` instead of `!= SEED_NONE` fails.
        for seed_mode in [Seed::None, Seed::Object, Seed::Primitive] {
            // Sub-frame 0 is the plain pattern; 1 and 2 the first shifts and rotations; 127 the
            // last sample of spp = 128. STBN: the last slice of the first period, the first of
            // the second and third (shifted), and a sub-frame of a late animation frame.
            let frames: &[u32] = if pattern == Pattern::Stbn {
                &[0, 1, 31, 32, 33, 64, 127, 1_000_003]
            } else {
                &[0, 1, 2, 127]
            };
            for &frame in frames {
                let config = StochasticConfig {
                    pattern,
                    seed: seed_mode,
                    spp: oit_stochastic::Spp::of(frame.min(127) + 1),
                };
                let words = dither_words(&config, frame);
                let uniform = uniform_buffer(&ctx, bytemuck::cast_slice(&words));
                let group1 = [
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&view),
                    },
                ];
                let gpu =
                    eval_f32_with(&ctx, &source, expr, &inputs, &group1, &[]).expect("kernel runs");
                for (x, g) in inputs.iter().zip(&gpu) {
                    let pixel = [x[0] as u32, x[1] as u32];
                    let seed = x[2] as u32 | ((x[3] as u32) << 16);
                    let cpu = if pattern == Pattern::Stbn {
                        pattern::stbn_threshold(&table, side, pixel, seed, frame)
                    } else {
                        pattern::tiled_threshold(&table, side, pixel, seed, seed_mode, frame)
                    };
                    compared += 1;
                    if g.to_bits() != cpu.to_bits() || !(0.0..1.0).contains(&cpu) {
                        failures.push(format!(
                            "{} seed {seed:#x} ({}) frame {frame} pixel {pixel:?}: GPU {g} CPU {cpu}",
                            pattern.name(),
                            seed_mode.name()
                        ));
                    }
                }
            }
        }
    }
    println!("{compared} thresholds compared");
    let count = failures.len();
    failures.truncate(20);
    assert!(
        failures.is_empty(),
        "{count} of {compared} differ:\n{}",
        failures.join("\n")
    );
}
