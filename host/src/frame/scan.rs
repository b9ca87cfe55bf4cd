//! Host side of the `scan::scan_blocks` and `scan::add_block_offsets` kernels: an exclusive prefix
//! sum of `u32` words in place on the GPU, level by level (`gi_shared::scan`).

use super::Recorder;
use crate::error::{Error, Result};
use crate::vulkan::{Buffer, Context, Kernel, KernelModule, MemoryLocation};
use ash::vk;
use gi_shared::scan::{NO_WORD, SCAN_BLOCK, ScanPush, level_count, level_len};

crate::bindings! {
    /// The scan (per block)'s set 0 (`kernels::scan::scan_blocks`).
    pub(crate) struct ScanBlocks<'a> {
        data: &'a Buffer,
        sums: &'a Buffer,
        total: &'a Buffer,
    }
}

crate::bindings! {
    /// The scan (adding block offsets)'s set 0 (`kernels::scan::add_block_offsets`).
    pub(crate) struct AddBlockOffsets<'a> {
        data: &'a Buffer,
        sums: &'a Buffer,
    }
}

/// An exclusive prefix sum of up to `max_count` words, with its scratch buffer of block sums.
pub struct Scan {
    blocks: Kernel,
    add: Kernel,
    scratch: Buffer,
    max_count: u32,
}

/// Where level `level` (at least 1) of a scan of `n` words starts in the scratch buffer.
fn scratch_offset(n: u32, level: u32) -> u32 {
    (1..level).map(|l| level_len(n, l)).sum()
}

impl Scan {
    /// The kernel scanning blocks.
    pub const SCAN_BLOCKS: &str = "scan::scan_blocks";
    /// The kernel adding the scanned block sums back.
    pub const ADD_BLOCK_OFFSETS: &str = "scan::add_block_offsets";

    /// Creates the pipelines and a device-local scratch buffer for scans of up to `max_count`
    /// words. Errors when a level would need more workgroups than the device dispatches.
    pub fn new(ctx: &Context, module: &KernelModule, max_count: u32) -> Result<Self> {
        let groups = max_count.div_ceil(SCAN_BLOCK);
        let limit = ctx.capabilities().max_workgroup_count[0];
        if groups > limit {
            return Err(Error::InvalidArgument {
                name: "scan size",
                why: format!(
                    "{max_count} words need {groups} workgroups, the device dispatches {limit}"
                ),
            });
        }
        let blocks = Kernel::new::<ScanBlocks>(
            ctx,
            module,
            Self::SCAN_BLOCKS,
            std::mem::size_of::<ScanPush>() as u32,
        )?;
        let add = match Kernel::new::<AddBlockOffsets>(
            ctx,
            module,
            Self::ADD_BLOCK_OFFSETS,
            std::mem::size_of::<ScanPush>() as u32,
        ) {
            Ok(k) => k,
            Err(e) => {
                drop(blocks);
                return Err(e);
            }
        };
        let words = scratch_offset(max_count, level_count(max_count)).max(1);
        let scratch = match Buffer::new(
            ctx,
            "scan block sums",
            u64::from(words) * 4,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        ) {
            Ok(b) => b,
            Err(e) => {
                drop(blocks);
                drop(add);
                return Err(e);
            }
        };
        Ok(Self {
            blocks,
            add,
            scratch,
            max_count,
        })
    }

    /// Records the scan of the first `count` words of `data` in place (exclusive, wrapping) and,
    /// with `total = Some((buffer, index))`, the sum of all of them into that word, for example
    /// the counter of a later [`super::DispatchFromCounter`]. The recorder orders each level
    /// after the one before and later readers after the last. `count` may be 0 (the total is 0).
    pub fn record(
        &self,
        rec: &mut Recorder<'_>,
        data: &Buffer,
        count: u32,
        total: Option<(&Buffer, u32)>,
    ) -> Result<()> {
        if count > self.max_count || u64::from(count) * 4 > data.size {
            return Err(Error::InvalidArgument {
                name: "scan size",
                why: format!(
                    "{count} words: the scan holds {}, buffer {:?} {} bytes",
                    self.max_count,
                    data.name(),
                    data.size
                ),
            });
        }
        let levels = level_count(count);
        let level_data = |level| {
            if level == 0 {
                (data, 0)
            } else {
                (&self.scratch, scratch_offset(count, level))
            }
        };
        for level in 0..levels {
            let (words, data_offset) = level_data(level);
            let top = level + 1 == levels;
            let (total_buffer, total_index) = match total {
                Some((buffer, index)) if top => (buffer, index),
                _ => (&self.scratch, NO_WORD),
            };
            let push = ScanPush {
                count: level_len(count, level),
                data_offset,
                sums_offset: if top {
                    NO_WORD
                } else {
                    scratch_offset(count, level + 1)
                },
                total_index,
            };
            rec.dispatch(
                &self.blocks,
                &ScanBlocks {
                    data: words,
                    sums: &self.scratch,
                    total: total_buffer,
                },
                bytemuck::bytes_of(&push),
                [push.count.div_ceil(SCAN_BLOCK).max(1), 1, 1],
            )?;
        }
        for level in (0..levels - 1).rev() {
            let (words, data_offset) = level_data(level);
            let push = ScanPush {
                count: level_len(count, level),
                data_offset,
                sums_offset: scratch_offset(count, level + 1),
                total_index: NO_WORD,
            };
            rec.dispatch(
                &self.add,
                &AddBlockOffsets {
                    data: words,
                    sums: &self.scratch,
                },
                bytemuck::bytes_of(&push),
                [push.count.div_ceil(SCAN_BLOCK), 1, 1],
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scratch_levels_follow_each_other() {
        let n = 1_000_000;
        assert_eq!(scratch_offset(n, 1), 0);
        assert_eq!(scratch_offset(n, 2), level_len(n, 1));
        assert_eq!(scratch_offset(n, 3), level_len(n, 1) + level_len(n, 2));
    }
}
