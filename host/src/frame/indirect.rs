//! Host side of the `indirect::dispatch_from_counter` kernel: the arguments buffer of indirect
//! dispatches and the barrier before they are read.

use super::Recorder;
use crate::error::Result;
use crate::vulkan::{Buffer, Context, Kernel, KernelModule, MemoryLocation};
use ash::vk;
use gi_shared::indirect::{DispatchIndirect, IndirectPush};

crate::bindings! {
    /// DispatchFromCounter's set 0 (`kernels::indirect::dispatch_from_counter`).
    pub(crate) struct CounterToArguments<'a> {
        counters: &'a Buffer,
        args: &'a Buffer,
    }
}

/// Writes a `VkDispatchIndirectCommand` from a counter word on the GPU.
pub struct DispatchFromCounter {
    kernel: Kernel,
}

impl DispatchFromCounter {
    /// The kernel's entry point.
    pub const ENTRY: &str = "indirect::dispatch_from_counter";

    /// Creates the pipeline.
    pub fn new(ctx: &Context, module: &KernelModule) -> Result<Self> {
        Ok(Self {
            kernel: Kernel::new::<CounterToArguments>(
                ctx,
                module,
                Self::ENTRY,
                std::mem::size_of::<IndirectPush>() as u32,
            )?,
        })
    }

    /// Records the kernel writing `args[args_index]` (a [`DispatchIndirect`]) for the count in
    /// word `counter_index` of `counters`, clamped to `capacity` items. Dispatch with
    /// `Recorder::dispatch_indirect(.., args, indirect_offset(args_index))`, which waits for it.
    pub fn record(
        &self,
        rec: &mut Recorder<'_>,
        counters: &Buffer,
        counter_index: u32,
        capacity: u32,
        args: &Buffer,
        args_index: u32,
    ) -> Result<()> {
        let push = IndirectPush {
            counter_index,
            capacity,
            max_groups: rec.ctx().capabilities().max_workgroup_count[0],
            args_index,
        };
        rec.dispatch(
            &self.kernel,
            &CounterToArguments { counters, args },
            bytemuck::bytes_of(&push),
            [1, 1, 1],
        )?;
        Ok(())
    }
}

/// A device-local buffer of `count` [`DispatchIndirect`]s, usable as indirect arguments and as
/// a storage buffer (which is how kernels write it). Contents undefined until written.
pub fn indirect_args(ctx: &Context, name: &str, count: usize) -> Result<Buffer> {
    Buffer::new(
        ctx,
        name,
        (count * std::mem::size_of::<DispatchIndirect>()) as u64,
        vk::BufferUsageFlags::INDIRECT_BUFFER,
        MemoryLocation::GpuOnly,
    )
}

/// Byte offset of [`DispatchIndirect`] `index` in an [`indirect_args`] buffer.
pub fn indirect_offset(index: u32) -> u64 {
    u64::from(index) * std::mem::size_of::<DispatchIndirect>() as u64
}
