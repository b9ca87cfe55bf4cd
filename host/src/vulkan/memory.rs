//! Buffers, allocated through `gpu-allocator`, and where their memory lives.
//!
//! Long-lived data (scene, BVH, accumulation, kernel outputs) lives in device-local memory
//! ([`MemoryLocation::GpuOnly`]): [`Buffer::device_local`] uploads it through a staging buffer,
//! [`Buffer::device_zeroed`] clears it on the device, and [`Buffer::read_back`] copies it out.
//! Host-visible memory is only for small parameters rewritten between submissions
//! ([`Buffer::parameters`]) and for read-back staging ([`Buffer::readback`]). Every live buffer is
//! listed by [`Context::live_buffers`], so tests can check where each one landed.

use super::context::{Context, SharedDevice};
use crate::error::{Error, Result, VkContext};
use ash::vk;
pub use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use std::sync::{Arc, Mutex};

/// Allocates memory for a resource named `name` (named in errors and allocator reports).
pub(crate) fn allocate(
    ctx: &Context,
    name: &str,
    requirements: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> Result<Allocation> {
    let mut allocator = ctx
        .shared
        .allocator
        .lock()
        .map_err(|_| Error::InvalidArgument {
            name: "allocator",
            why: "poisoned by an earlier panic".into(),
        })?;
    allocator
        .allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        })
        .map_err(|e| Error::Allocation {
            what: name.to_string(),
            bytes: Some(requirements.size),
            why: match e {
                gpu_allocator::AllocationError::OutOfMemory => {
                    "the device is out of memory (free other resources, lower the resolution or \
                     the scene's size)"
                        .to_owned()
                }
                other => other.to_string(),
            },
        })
}

/// An error unless the device could ever hold a buffer of `size` bytes: Vulkan forbids creating
/// a buffer over `maxBufferSize` or allocating more than a heap holds, so a larger request is
/// refused here, by name, before any call.
fn check_buffer_size(ctx: &Context, name: &str, size: u64) -> Result<()> {
    let caps = ctx.capabilities();
    let over = |limit: &str, bytes: u64| Error::Allocation {
        what: name.to_string(),
        bytes: Some(size),
        why: format!(
            "larger than the device's {limit} ({bytes} bytes, {:.3} GiB)",
            bytes as f64 / f64::from(1 << 30)
        ),
    };
    if size > caps.max_buffer_size {
        return Err(over("largest buffer (maxBufferSize)", caps.max_buffer_size));
    }
    if size > caps.largest_heap_bytes {
        return Err(over("largest memory heap", caps.largest_heap_bytes));
    }
    Ok(())
}

/// One live buffer or image, as listed by [`Context::live_buffers`] and
/// [`Context::live_images`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BufferInfo {
    /// The name it was created with.
    pub name: String,
    /// Its size in bytes (for an image, the size of its memory allocation).
    pub bytes: u64,
    /// The memory location it asked the allocator for (what the code chose, whatever the device
    /// made of it: on a CPU device every location is both device-local and host-visible).
    pub location: MemoryLocation,
}

/// What a context's allocator holds from the device ([`Context::device_memory`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceMemoryUse {
    /// Bytes in live allocations (buffers, images, acceleration structures).
    pub allocated: u64,
    /// Bytes of the memory blocks the allocator holds from the driver, used or not.
    pub reserved: u64,
    /// Live allocations.
    pub allocations: usize,
    /// Memory blocks.
    pub blocks: usize,
}

/// The resources (buffers or images) alive on a context, in creation order, keyed by their
/// handle.
pub(crate) struct ResourceRegistry<H>(Mutex<Vec<(H, BufferInfo)>>);

impl<H> Default for ResourceRegistry<H> {
    fn default() -> Self {
        Self(Mutex::new(vec![]))
    }
}

impl<H: Copy + PartialEq> ResourceRegistry<H> {
    fn entries(&self) -> std::sync::MutexGuard<'_, Vec<(H, BufferInfo)>> {
        // The list stays consistent even if a panic poisoned the lock: every edit is one push or
        // one removal.
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub(crate) fn add(&self, handle: H, info: BufferInfo) {
        self.entries().push((handle, info));
    }

    pub(crate) fn remove(&self, handle: H) {
        let mut entries = self.entries();
        if let Some(i) = entries.iter().position(|(h, _)| *h == handle) {
            entries.remove(i);
        }
    }

    pub(crate) fn snapshot(&self) -> Vec<BufferInfo> {
        self.entries().iter().map(|(_, i)| i.clone()).collect()
    }
}

/// A storage buffer and its memory, freed when dropped.
pub struct Buffer {
    /// The Vulkan handle.
    pub handle: vk::Buffer,
    /// Size in bytes.
    pub size: u64,
    allocation: Option<Allocation>,
    name: String,
    location: MemoryLocation,
    shared: Arc<SharedDevice>,
}

/// Usage flags every storage buffer gets: kernels read and write it, copies fill and drain it.
const STORAGE_USAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::STORAGE_BUFFER.as_raw()
        | vk::BufferUsageFlags::TRANSFER_SRC.as_raw()
        | vk::BufferUsageFlags::TRANSFER_DST.as_raw(),
);

impl Buffer {
    /// Creates a buffer of `size` bytes in `location`, contents undefined. `extra` usage flags
    /// are added to storage and transfer. Prefer the constructors below, which say what the
    /// memory is for.
    pub fn new(
        ctx: &Context,
        name: &str,
        size: u64,
        extra: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Self> {
        if size == 0 {
            return Err(Error::InvalidArgument {
                name: "buffer size",
                why: format!("buffer {name:?} would be empty"),
            });
        }
        check_buffer_size(ctx, name, size)?;
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(STORAGE_USAGE | extra)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let handle = unsafe { ctx.device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        let requirements = unsafe { ctx.device.get_buffer_memory_requirements(handle) };
        let allocation = allocate(ctx, name, requirements, location, true);
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                unsafe { ctx.device.destroy_buffer(handle, None) };
                return Err(e);
            }
        };
        if let Err(result) = unsafe {
            ctx.device
                .bind_buffer_memory(handle, allocation.memory(), allocation.offset())
        } {
            unsafe { ctx.device.destroy_buffer(handle, None) };
            ctx.shared
                .allocator
                .lock()
                .ok()
                .map(|mut a| a.free(allocation));
            return Err(Error::Vulkan {
                call: "vkBindBufferMemory",
                result,
            });
        }
        ctx.shared.buffers.add(
            handle,
            BufferInfo {
                name: name.to_string(),
                bytes: size,
                location,
            },
        );
        Ok(Self {
            handle,
            size,
            allocation: Some(allocation),
            name: name.to_string(),
            location,
            shared: ctx.shared.clone(),
        })
    }

    /// Creates a device-local buffer holding `data`, for data kernels read many times (scene,
    /// BVH, lights, kernel inputs). Uploads through a host-visible staging buffer and one
    /// submission that waits (at most [`super::SUBMIT_TIMEOUT`]) and ends with a barrier that
    /// makes the copy visible to every later command; the staging buffer is freed before
    /// returning. `extra` usage flags are added to storage and transfer.
    pub fn device_local<T: bytemuck::Pod>(
        ctx: &Context,
        name: &str,
        data: &[T],
        extra: vk::BufferUsageFlags,
    ) -> Result<Self> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let size = bytes.len() as u64;
        let buffer = Self::new(ctx, name, size, extra, MemoryLocation::GpuOnly)?;
        // Freed when this returns, after the copy finished.
        let mut staging = Self::new(
            ctx,
            &format!("{name} staging"),
            size,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(bytes)?;
        ctx.submit(|cmd| {
            staging.record_copy_to(ctx, cmd, &buffer)?;
            transfer_barrier(ctx, cmd);
            Ok(())
        })??;
        Ok(buffer)
    }

    /// Creates a device-local buffer of `count` elements of `T`, zeroed on the device with one
    /// submission that waits, for kernels to write (outputs, accumulation).
    pub fn device_zeroed<T: bytemuck::Pod>(
        ctx: &Context,
        name: &str,
        count: usize,
    ) -> Result<Self> {
        let size = (count * std::mem::size_of::<T>()) as u64;
        let buffer = Self::new(
            ctx,
            name,
            size,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuOnly,
        )?;
        ctx.submit(|cmd| {
            buffer.record_fill_zero(ctx, cmd);
            transfer_barrier(ctx, cmd);
        })?;
        Ok(buffer)
    }

    /// Creates a small host-visible buffer holding `data`: parameters the host rewrites with
    /// [`Buffer::write`] between submissions (a camera). Not for anything large or long-lived:
    /// on a discrete GPU kernels would read it over the bus.
    pub fn parameters<T: bytemuck::Pod>(ctx: &Context, name: &str, data: &[T]) -> Result<Self> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let mut buffer = Self::new(
            ctx,
            name,
            bytes.len() as u64,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::CpuToGpu,
        )?;
        buffer.write(bytes)?;
        Ok(buffer)
    }

    /// Creates a host-readable staging buffer for `count` elements of `T`, contents undefined:
    /// the destination of [`Buffer::record_copy_to`], read with [`Buffer::read`] once the
    /// submission finished.
    pub fn readback<T: bytemuck::Pod>(ctx: &Context, name: &str, count: usize) -> Result<Self> {
        Self::new(
            ctx,
            name,
            (count * std::mem::size_of::<T>()) as u64,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuToCpu,
        )
    }

    /// The name it was created with.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The memory location it asked for.
    pub fn location(&self) -> MemoryLocation {
        self.location
    }

    /// The mapped memory of a buffer created host-visible. A device-local buffer is refused even
    /// where the device happens to map it (CPU devices), so that code which works there also
    /// works on a discrete GPU.
    fn host_bytes(&mut self) -> Result<&mut [u8]> {
        let mapped = match self.location {
            MemoryLocation::GpuOnly => None,
            _ => self.allocation.as_mut().and_then(|a| a.mapped_slice_mut()),
        };
        mapped.ok_or_else(|| Error::InvalidArgument {
            name: "buffer",
            why: format!(
                "buffer {:?} is not host-visible ({:?}): use Buffer::read_back",
                self.name, self.location
            ),
        })
    }

    /// Copies `bytes` to the start of a host-visible buffer ([`Buffer::parameters`]). No
    /// submission may be using the buffer.
    pub fn write(&mut self, bytes: &[u8]) -> Result<()> {
        let name = self.name.clone();
        let dst = self.host_bytes()?;
        if bytes.len() > dst.len() {
            return Err(Error::InvalidArgument {
                name: "buffer write",
                why: format!(
                    "{} bytes do not fit in buffer {name:?} of {}",
                    bytes.len(),
                    dst.len()
                ),
            });
        }
        dst[..bytes.len()].copy_from_slice(bytes);
        Ok(())
    }

    /// Reads a host-visible buffer ([`Buffer::readback`]) as a vector of `T`. The submission that
    /// filled it must have finished and ended with [`transfer_barrier`] (or
    /// [`super::compute_barrier`] when a kernel wrote it).
    pub fn read<T: bytemuck::Pod>(&mut self) -> Result<Vec<T>> {
        let n = self.size as usize / std::mem::size_of::<T>();
        let src = self.host_bytes()?;
        let mut out = vec![T::zeroed(); n];
        bytemuck::cast_slice_mut::<T, u8>(&mut out)
            .copy_from_slice(&src[..n * std::mem::size_of::<T>()]);
        Ok(out)
    }

    /// Copies the buffer, wherever it lives, to the host as a vector of `T`: one submission that
    /// waits for everything submitted before (kernel or copy writes), copies into a temporary
    /// [`Buffer::readback`] buffer, and waits at most [`super::SUBMIT_TIMEOUT`].
    pub fn read_back<T: bytemuck::Pod>(&self, ctx: &Context) -> Result<Vec<T>> {
        let mut staging =
            Self::readback::<u8>(ctx, &format!("{} read-back", self.name), self.size as usize)?;
        let copied = ctx.submit(|cmd| {
            let before = [vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::TRANSFER_READ)];
            unsafe {
                ctx.device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::DependencyFlags::empty(),
                    &before,
                    &[],
                    &[],
                )
            };
            self.record_copy_to(ctx, cmd, &staging)?;
            transfer_barrier(ctx, cmd);
            Ok(())
        });
        copied??;
        staging.read::<T>()
    }

    /// Records a fill of the whole buffer with zero bytes. Follow it with [`transfer_barrier`]
    /// before a kernel or the host uses the buffer.
    pub fn record_fill_zero(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        self.record_fill(ctx, cmd, 0);
    }

    /// Records a fill of the whole buffer with the word `word`. Follow it with
    /// [`transfer_barrier`] before a kernel or the host uses the buffer.
    pub fn record_fill(&self, ctx: &Context, cmd: vk::CommandBuffer, word: u32) {
        unsafe {
            ctx.device
                .cmd_fill_buffer(cmd, self.handle, 0, vk::WHOLE_SIZE, word)
        };
    }

    /// Records a copy of the whole buffer to the start of `dst`. If a kernel wrote this buffer
    /// in the same command buffer, record [`super::compute_barrier`] first; follow the copy with
    /// [`transfer_barrier`] before the host reads `dst` or a kernel uses it. Errors, recording
    /// nothing, when `dst` is smaller.
    pub fn record_copy_to(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        dst: &Buffer,
    ) -> Result<()> {
        if dst.size < self.size {
            return Err(Error::InvalidArgument {
                name: "buffer copy",
                why: format!(
                    "buffer {:?} of {} bytes does not fit in {:?} of {}",
                    self.name, self.size, dst.name, dst.size
                ),
            });
        }
        let region = [vk::BufferCopy::default().size(self.size)];
        unsafe {
            ctx.device
                .cmd_copy_buffer(cmd, self.handle, dst.handle, &region)
        };
        Ok(())
    }

    /// The buffer's device address (needs `bufferDeviceAddress`, enabled with ray queries).
    pub fn device_address(&self, ctx: &Context) -> vk::DeviceAddress {
        let info = vk::BufferDeviceAddressInfo::default().buffer(self.handle);
        unsafe { ctx.device.get_buffer_device_address(&info) }
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        self.shared.buffers.remove(self.handle);
        unsafe { self.shared.device.destroy_buffer(self.handle, None) };
        if let (Some(a), Ok(mut alloc)) = (self.allocation.take(), self.shared.allocator.lock()) {
            alloc.free(a).ok();
        }
    }
}

/// Records a barrier that makes transfer writes (fills and copies recorded before it) visible to
/// every later command (kernels, copies, acceleration-structure builds) and to the host once the
/// submission's fence signalled.
pub fn transfer_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
        ),
        (
            vk::PipelineStageFlags::ALL_COMMANDS | vk::PipelineStageFlags::HOST,
            vk::AccessFlags::MEMORY_READ
                | vk::AccessFlags::MEMORY_WRITE
                | vk::AccessFlags::HOST_READ,
        ),
    );
}

/// Records one global memory barrier from the `(stages, accesses)` of `src` to those of `dst`.
pub(crate) fn memory_barrier(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    src: (vk::PipelineStageFlags, vk::AccessFlags),
    dst: (vk::PipelineStageFlags, vk::AccessFlags),
) {
    let barrier = [vk::MemoryBarrier::default()
        .src_access_mask(src.1)
        .dst_access_mask(dst.1)];
    unsafe {
        ctx.device.cmd_pipeline_barrier(
            cmd,
            src.0,
            dst.0,
            vk::DependencyFlags::empty(),
            &barrier,
            &[],
            &[],
        )
    };
}

/// Writes into existing device-local buffers, in place and batched: the bytes are gathered on
/// the host ([`StagedWrites::write`]), then [`StagedWrites::submit`] copies them through one
/// staging buffer in one submission, one copy region per run of adjacent bytes. The buffers keep
/// their handles, so the descriptor sets that bind them stay valid.
#[derive(Default)]
pub struct StagedWrites<'a> {
    bytes: Vec<u8>,
    copies: Vec<(&'a Buffer, vk::BufferCopy)>,
}

impl<'a> StagedWrites<'a> {
    /// No writes yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Queues `data` for `dst` at byte `offset`. Errors, queueing nothing, when it does not fit.
    pub fn write<T: bytemuck::Pod>(
        &mut self,
        dst: &'a Buffer,
        offset: u64,
        data: &[T],
    ) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let size = bytes.len() as u64;
        if offset.checked_add(size).is_none_or(|end| end > dst.size) {
            return Err(Error::InvalidArgument {
                name: "buffer write",
                why: format!(
                    "{size} bytes at offset {offset} do not fit in buffer {:?} of {}",
                    dst.name, dst.size
                ),
            });
        }
        if size == 0 {
            return Ok(());
        }
        let src_offset = self.bytes.len() as u64;
        self.bytes.extend_from_slice(bytes);
        // Records of neighbouring instances (or lights) become one region.
        if let Some((last, region)) = self.copies.last_mut()
            && last.handle == dst.handle
            && region.dst_offset + region.size == offset
        {
            region.size += size;
            return Ok(());
        }
        self.copies.push((
            dst,
            vk::BufferCopy {
                src_offset,
                dst_offset: offset,
                size,
            },
        ));
        Ok(())
    }

    /// Bytes queued.
    pub fn bytes(&self) -> u64 {
        self.bytes.len() as u64
    }

    /// Copies what was queued, then records `then` (a build that reads the written buffers) in
    /// the same submission, and waits (at most [`super::SUBMIT_TIMEOUT`]). The copies wait for
    /// every command submitted before (which may still read the old contents) and are visible to
    /// every later command. Submits `then` alone when nothing was queued.
    pub fn submit<R>(self, ctx: &Context, then: impl FnOnce(vk::CommandBuffer) -> R) -> Result<R> {
        let staging = match self.bytes.is_empty() {
            true => None,
            false => {
                let mut staging = Buffer::new(
                    ctx,
                    "staged writes",
                    self.bytes(),
                    vk::BufferUsageFlags::empty(),
                    MemoryLocation::CpuToGpu,
                )?;
                staging.write(&self.bytes)?;
                Some(staging)
            }
        };
        ctx.submit(|cmd| {
            if let Some(staging) = &staging {
                memory_barrier(
                    ctx,
                    cmd,
                    (
                        vk::PipelineStageFlags::ALL_COMMANDS,
                        vk::AccessFlags::MEMORY_WRITE,
                    ),
                    (
                        vk::PipelineStageFlags::TRANSFER,
                        vk::AccessFlags::TRANSFER_WRITE,
                    ),
                );
                for run in self.copies.chunk_by(|a, b| a.0.handle == b.0.handle) {
                    let regions: Vec<vk::BufferCopy> = run.iter().map(|(_, r)| *r).collect();
                    unsafe {
                        ctx.device
                            .cmd_copy_buffer(cmd, staging.handle, run[0].0.handle, &regions)
                    };
                }
                transfer_barrier(ctx, cmd);
            }
            then(cmd)
        })
    }
}
