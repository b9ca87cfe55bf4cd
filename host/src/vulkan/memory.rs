//! Buffers, allocated through `gpu-allocator`, with typed upload and read-back.

use super::context::Context;
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};

/// Allocates memory for a resource named `name` (named in errors and allocator reports).
pub(crate) fn allocate(
    ctx: &Context,
    name: &str,
    requirements: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> Result<Allocation> {
    let mut allocator = ctx.allocator.lock().map_err(|_| Error::InvalidArgument {
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
        .map_err(|source| Error::Allocation {
            what: name.to_string(),
            source,
        })
}

/// A storage buffer and its memory. Destroy it with [`Buffer::destroy`] before the context goes.
pub struct Buffer {
    /// The Vulkan handle.
    pub handle: vk::Buffer,
    /// Size in bytes.
    pub size: u64,
    allocation: Option<Allocation>,
    name: String,
}

/// Usage flags every storage buffer gets: kernels read and write it, copies fill and drain it.
const STORAGE_USAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::STORAGE_BUFFER.as_raw()
        | vk::BufferUsageFlags::TRANSFER_SRC.as_raw()
        | vk::BufferUsageFlags::TRANSFER_DST.as_raw(),
);

impl Buffer {
    /// Creates a buffer of `size` bytes. `extra` usage flags are added to storage and transfer.
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
            ctx.allocator.lock().ok().map(|mut a| a.free(allocation));
            return Err(Error::Vulkan {
                call: "vkBindBufferMemory",
                result,
            });
        }
        Ok(Self {
            handle,
            size,
            allocation: Some(allocation),
            name: name.to_string(),
        })
    }

    /// Creates a host-visible buffer holding `data`.
    pub fn from_slice<T: bytemuck::Pod>(
        ctx: &Context,
        name: &str,
        data: &[T],
        extra: vk::BufferUsageFlags,
    ) -> Result<Self> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let mut buffer = Self::new(
            ctx,
            name,
            bytes.len() as u64,
            extra,
            MemoryLocation::CpuToGpu,
        )?;
        buffer.write(bytes)?;
        Ok(buffer)
    }

    /// Creates a host-visible buffer of `count` zeroed elements of `T`, for kernels to write and
    /// the CPU to read back.
    pub fn zeroed<T: bytemuck::Pod>(ctx: &Context, name: &str, count: usize) -> Result<Self> {
        let size = (count * std::mem::size_of::<T>()) as u64;
        let mut buffer = Self::new(
            ctx,
            name,
            size,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::GpuToCpu,
        )?;
        buffer.write(&vec![0u8; size as usize])?;
        Ok(buffer)
    }

    fn mapped(&mut self) -> Result<&mut [u8]> {
        let name = self.name.clone();
        self.allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or(Error::InvalidArgument {
                name: "buffer",
                why: format!("buffer {name:?} is not host-visible"),
            })
    }

    /// Copies `bytes` to the start of a host-visible buffer.
    pub fn write(&mut self, bytes: &[u8]) -> Result<()> {
        let name = self.name.clone();
        let dst = self.mapped()?;
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

    /// Reads a host-visible buffer back as a vector of `T`.
    pub fn read<T: bytemuck::Pod>(&mut self) -> Result<Vec<T>> {
        let size = self.size as usize;
        let src = self.mapped()?;
        let n = size / std::mem::size_of::<T>();
        let mut out = vec![T::zeroed(); n];
        bytemuck::cast_slice_mut::<T, u8>(&mut out)
            .copy_from_slice(&src[..n * std::mem::size_of::<T>()]);
        Ok(out)
    }

    /// The buffer's device address (needs `bufferDeviceAddress`, enabled with ray queries).
    pub fn device_address(&self, ctx: &Context) -> vk::DeviceAddress {
        let info = vk::BufferDeviceAddressInfo::default().buffer(self.handle);
        unsafe { ctx.device.get_buffer_device_address(&info) }
    }

    /// Frees the buffer and its memory.
    pub fn destroy(mut self, ctx: &Context) {
        unsafe { ctx.device.destroy_buffer(self.handle, None) };
        if let (Some(a), Ok(mut alloc)) = (self.allocation.take(), ctx.allocator.lock()) {
            alloc.free(a).ok();
        }
    }
}
