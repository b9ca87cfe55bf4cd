//! Host side of the `indirect::dispatch_from_counter` kernel: the arguments buffer of indirect
//! dispatches and the barrier before they are read.

use crate::error::Result;
use crate::vulkan::memory_barrier;
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
    /// word `counter_index` of `counters`, clamped to `capacity` items, then
    /// [`indirect_barrier`]. Whatever wrote the counter must be followed by
    /// [`crate::vulkan::compute_barrier`] before this. Dispatch with
    /// `Kernel::dispatch_indirect(.., args, indirect_offset(args_index))`.
    #[allow(
        clippy::too_many_arguments,
        reason = "the counter and the arguments are each a buffer and an index"
    )]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        counters: &Buffer,
        counter_index: u32,
        capacity: u32,
        args: &Buffer,
        args_index: u32,
    ) -> Result<()> {
        let push = IndirectPush {
            counter_index,
            capacity,
            max_groups: ctx.capabilities().max_workgroup_count[0],
            args_index,
        };
        self.kernel.dispatch(
            ctx,
            cmd,
            &CounterToArguments { counters, args },
            bytemuck::bytes_of(&push),
            [1, 1, 1],
        )?;
        indirect_barrier(ctx, cmd);
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

/// Makes shader writes before it visible to the indirect-argument reads of later dispatches (and
/// to later shaders).
pub fn indirect_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::SHADER_WRITE,
        ),
        (
            vk::PipelineStageFlags::DRAW_INDIRECT | vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::INDIRECT_COMMAND_READ
                | vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::SHADER_WRITE,
        ),
    );
}
