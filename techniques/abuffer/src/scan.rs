//! The exclusive prefix sum of the per-pixel counts (shaders/prefix_sum.wgsl): reduce-then-scan
//! in levels of [`BLOCK`] values, each level's block totals scanned by the next, then added
//! back from the top. [`exclusive_scan`] is its CPU twin, level for level.

use oit_gpu::wgpu;
use oit_gpu::{Context, GpuError, MemoryLedger, bind};

/// Values one workgroup scans (`BLOCK` of prefix_sum.wgsl).
pub const BLOCK: usize = 256;

/// Most workgroups in one row of a dispatch (WebGPU's `maxComputeWorkgroupsPerDimension`
/// default); longer levels wrap into rows.
const MAX_GROUPS_X: u32 = 65_535;

/// shaders/prefix_sum.wgsl.
pub const WGSL: &str = include_str!("../shaders/prefix_sum.wgsl");

/// The lengths of the levels for `len` values: `len`, then one total per block, until one
/// block holds a level (its single total is the grand total).
pub fn level_lengths(len: usize) -> Vec<usize> {
    let mut lengths = vec![len];
    while *lengths.last().unwrap_or(&0) > BLOCK {
        let last = lengths[lengths.len() - 1];
        lengths.push(last.div_ceil(BLOCK));
    }
    lengths
}

/// CPU twin of the GPU scan, pass for pass: `cs_scan_blocks` on every level going up (each
/// block scanned exclusively, its total to the next level), then `cs_add_block_sums` going
/// down. Wrapping u32 arithmetic, as the shader's. Returns the scanned values and the total.
pub fn exclusive_scan(values: &[u32]) -> (Vec<u32>, u32) {
    let lengths = level_lengths(values.len());
    let mut levels: Vec<Vec<u32>> = vec![values.to_vec()];
    for _ in &lengths {
        let current = levels.last_mut().expect("a level");
        let mut sums = vec![0u32; current.len().div_ceil(BLOCK).max(1)];
        for (b, block) in current.chunks_mut(BLOCK).enumerate() {
            let mut running = 0u32;
            for x in block.iter_mut() {
                let value = *x;
                *x = running;
                running = running.wrapping_add(value);
            }
            sums[b] = running;
        }
        levels.push(sums);
    }
    // levels[j + 1] holds level j's block totals; the last is the grand total alone.
    let total = levels.last().and_then(|l| l.first()).copied().unwrap_or(0);
    for j in (0..lengths.len().saturating_sub(1)).rev() {
        let (lower, upper) = levels.split_at_mut(j + 1);
        let sums = &upper[0];
        for (b, block) in lower[j].chunks_mut(BLOCK).enumerate() {
            for x in block {
                *x = x.wrapping_add(sums[b]);
            }
        }
    }
    (levels.swap_remove(0), total)
}

/// The GPU scan for arrays of one length: a block-totals buffer, a parameter block and a bind
/// group per level.
#[derive(Debug)]
pub struct PrefixSum {
    len: usize,
    levels: Vec<Level>,
    scan: wgpu::ComputePipeline,
    add: wgpu::ComputePipeline,
}

#[derive(Debug)]
struct Level {
    groups: (u32, u32),
    group: wgpu::BindGroup,
}

fn grid(len: usize) -> (u32, u32) {
    let blocks = len.div_ceil(BLOCK).max(1) as u32;
    let x = blocks.min(MAX_GROUPS_X);
    (x, blocks.div_ceil(x))
}

impl PrefixSum {
    /// A scan of `values` (u32, storage, at least `len` of them) in place; its buffers are
    /// counted in `ledger`.
    pub fn new(
        ctx: &Context,
        ledger: &mut MemoryLedger,
        values: &wgpu::Buffer,
        len: usize,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let cs = wgpu::ShaderStages::COMPUTE;
        let layout = ctx.bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("prefix sum"),
            entries: &[
                bind::uniform(0, cs),
                bind::storage(1, cs, false),
                bind::storage(2, cs, false),
            ],
        });
        let module = ctx.shader_with("prefix_sum.wgsl", WGSL, &[crate::SHADERS])?;
        let pipeline_layout = ctx.pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("prefix sum"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            ctx.compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let (scan, add) = (pipeline("cs_scan_blocks"), pipeline("cs_add_block_sums"));
        let lengths = level_lengths(len);
        let mut sums_buffers: Vec<wgpu::Buffer> = Vec::new();
        let mut params_buffers: Vec<wgpu::Buffer> = Vec::new();
        for (j, &n) in lengths.iter().enumerate() {
            let blocks = n.div_ceil(BLOCK).max(1) as u64;
            sums_buffers.push(ledger.create_buffer(
                device,
                &wgpu::BufferDescriptor {
                    label: Some(&format!("prefix sum level {j} block totals")),
                    size: blocks * 4,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                },
            ));
            let params = ledger.create_buffer(
                device,
                &wgpu::BufferDescriptor {
                    label: Some(&format!("prefix sum level {j} params")),
                    size: 16,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                },
            );
            let words: [u32; 4] = [n as u32, grid(n).0, 0, 0];
            ctx.queue
                .write_buffer(&params, 0, bytemuck::cast_slice(&words));
            params_buffers.push(params);
        }
        let levels = lengths
            .iter()
            .enumerate()
            .map(|(j, &n)| {
                let values = if j == 0 { values } else { &sums_buffers[j - 1] };
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("prefix sum level"),
                    layout: &layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: params_buffers[j].as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: values.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: sums_buffers[j].as_entire_binding(),
                        },
                    ],
                });
                Level {
                    groups: grid(n),
                    group,
                }
            })
            .collect();
        Ok(PrefixSum {
            len,
            levels,
            scan,
            add,
        })
    }

    /// Values this scan was built for.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it scans nothing.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Records the scan into `pass`: every level up, then the block totals added back down.
    pub fn record(&self, pass: &mut wgpu::ComputePass<'_>) {
        pass.set_pipeline(&self.scan);
        for level in &self.levels {
            pass.set_bind_group(0, &level.group, &[]);
            pass.dispatch_workgroups(level.groups.0, level.groups.1, 1);
        }
        pass.set_pipeline(&self.add);
        for level in self.levels.iter().rev().skip(1) {
            pass.set_bind_group(0, &level.group, &[]);
            pass.dispatch_workgroups(level.groups.0, level.groups.1, 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn naive(values: &[u32]) -> (Vec<u32>, u32) {
        let mut running = 0u32;
        let out = values
            .iter()
            .map(|&v| {
                let before = running;
                running = running.wrapping_add(v);
                before
            })
            .collect();
        (out, running)
    }

    #[test]
    fn levels_shrink_by_a_block_until_one_block_holds_them() {
        assert_eq!(level_lengths(1), vec![1]);
        assert_eq!(level_lengths(256), vec![256]);
        assert_eq!(level_lengths(257), vec![257, 2]);
        assert_eq!(level_lengths(65_537), vec![65_537, 257, 2]);
        // 3840 × 2160 + 1 counts: three levels.
        assert_eq!(level_lengths(8_294_401), vec![8_294_401, 32_401, 127]);
        assert_eq!(grid(8_294_401), (32_401, 1));
        assert_eq!(grid(256 * 70_000), (65_535, 2));
    }

    #[test]
    fn block_boundaries_and_the_total() {
        for len in [
            0usize, 1, 255, 256, 257, 511, 512, 513, 65_536, 65_537, 70_001,
        ] {
            let values: Vec<u32> = (0..len as u32).map(|i| i % 7 + (i >> 9) % 3).collect();
            assert_eq!(exclusive_scan(&values), naive(&values), "len {len}");
        }
    }

    proptest! {
        #[test]
        fn equals_the_running_sum(values in proptest::collection::vec(0u32..200, 0..3000)) {
            prop_assert_eq!(exclusive_scan(&values), naive(&values));
        }

        #[test]
        fn wraps_as_the_shader_does(values in proptest::collection::vec(any::<u32>(), 0..700)) {
            prop_assert_eq!(exclusive_scan(&values), naive(&values));
        }
    }
}
