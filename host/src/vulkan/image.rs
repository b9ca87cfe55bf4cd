//! Storage images, allocated through `gpu-allocator`, kept in `VK_IMAGE_LAYOUT_GENERAL` for their
//! whole life, with read-back through a host-visible buffer.

use super::context::{Context, SharedDevice};
use super::memory::{Buffer, allocate};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::Allocation;
use std::sync::Arc;

/// A 2D storage image (one mip level, one layer) and its view and memory, in the `GENERAL`
/// layout from creation on; freed when dropped.
pub struct Image {
    /// The Vulkan handle.
    pub handle: vk::Image,
    /// A view of the whole image, for binding.
    pub view: vk::ImageView,
    /// Texel format.
    pub format: vk::Format,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    allocation: Option<Allocation>,
    name: String,
    shared: Arc<SharedDevice>,
}

/// Bytes per texel of the formats [`Image::new`] accepts.
fn texel_bytes(format: vk::Format) -> Option<u32> {
    match format {
        vk::Format::R32_SFLOAT | vk::Format::R32_UINT | vk::Format::R8G8B8A8_UNORM => Some(4),
        vk::Format::R16G16B16A16_SFLOAT => Some(8),
        vk::Format::R32G32B32A32_SFLOAT | vk::Format::R32G32B32A32_UINT => Some(16),
        _ => None,
    }
}

/// Creates the image `info` describes in device memory, binds it, and registers it under `name`;
/// on failure nothing is left behind. Returns the image, its memory (the caller owns and frees
/// both) and the memory's size in bytes.
pub(super) fn create_bound_image(
    ctx: &Context,
    name: &str,
    info: &vk::ImageCreateInfo<'_>,
) -> Result<(vk::Image, Allocation, u64)> {
    let max = ctx.capabilities().max_image_dimension_2d;
    let vk::Extent3D { width, height, .. } = info.extent;
    if width > max || height > max {
        return Err(Error::InvalidArgument {
            name: "image size",
            why: format!(
                "image {name:?} of {width}×{height}: the device's images are at most {max} texels \
                 on a side (maxImageDimension2D)"
            ),
        });
    }
    let handle = unsafe { ctx.device.create_image(info, None) }.vk("vkCreateImage")?;
    let requirements = unsafe { ctx.device.get_image_memory_requirements(handle) };
    let allocation = match allocate(ctx, name, requirements, MemoryLocation::GpuOnly, false) {
        Ok(a) => a,
        Err(e) => {
            unsafe { ctx.device.destroy_image(handle, None) };
            return Err(e);
        }
    };
    if let Err(result) = unsafe {
        ctx.device
            .bind_image_memory(handle, allocation.memory(), allocation.offset())
    } {
        unsafe { ctx.device.destroy_image(handle, None) };
        if let Ok(mut a) = ctx.shared.allocator.lock() {
            a.free(allocation).ok();
        }
        return Err(Error::Vulkan {
            call: "vkBindImageMemory",
            result,
        });
    }
    ctx.shared.images.add(
        handle,
        super::memory::BufferInfo {
            name: name.to_string(),
            bytes: requirements.size,
            location: MemoryLocation::GpuOnly,
        },
    );
    Ok((handle, allocation, requirements.size))
}

const COLOR: vk::ImageSubresourceRange = vk::ImageSubresourceRange {
    aspect_mask: vk::ImageAspectFlags::COLOR,
    base_mip_level: 0,
    level_count: 1,
    base_array_layer: 0,
    layer_count: 1,
};

impl Image {
    /// Creates a `width × height` storage image of `format` in device memory and moves it to the
    /// `GENERAL` layout (its contents are undefined until a kernel writes them).
    ///
    /// `format` must be one of `R32_SFLOAT`, `R32_UINT`, `R8G8B8A8_UNORM`, `R16G16B16A16_SFLOAT`,
    /// `R32G32B32A32_SFLOAT`, `R32G32B32A32_UINT`: Vulkan requires every device to support them
    /// for storage images, so no format query is needed.
    pub fn new(
        ctx: &Context,
        name: &str,
        width: u32,
        height: u32,
        format: vk::Format,
    ) -> Result<Self> {
        if texel_bytes(format).is_none() {
            return Err(Error::InvalidArgument {
                name: "image format",
                why: format!("image {name:?}: {format:?} is not a supported storage format"),
            });
        }
        if width == 0 || height == 0 {
            return Err(Error::InvalidArgument {
                name: "image size",
                why: format!("image {name:?} would be empty ({width}×{height})"),
            });
        }
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width,
                height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(
                vk::ImageUsageFlags::STORAGE
                    | vk::ImageUsageFlags::TRANSFER_SRC
                    | vk::ImageUsageFlags::TRANSFER_DST,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let (handle, allocation, _) = create_bound_image(ctx, name, &info)?;
        // From here on, `image` frees what exists if a later step fails.
        let mut image = Self {
            handle,
            view: vk::ImageView::null(),
            format,
            width,
            height,
            allocation: Some(allocation),
            name: name.to_string(),
            shared: ctx.shared.clone(),
        };
        let view_info = vk::ImageViewCreateInfo::default()
            .image(handle)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(COLOR);
        image.view =
            unsafe { ctx.device.create_image_view(&view_info, None) }.vk("vkCreateImageView")?;
        let to_general = [image.layout_barrier(
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::GENERAL,
            vk::AccessFlags::empty(),
            vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::SHADER_WRITE
                | vk::AccessFlags::TRANSFER_READ
                | vk::AccessFlags::TRANSFER_WRITE,
        )];
        ctx.submit(|cmd| unsafe {
            ctx.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_general,
            )
        })?;
        Ok(image)
    }

    /// A barrier moving the whole image from layout `old` to `new`.
    fn layout_barrier(
        &self,
        old: vk::ImageLayout,
        new: vk::ImageLayout,
        src: vk::AccessFlags,
        dst: vk::AccessFlags,
    ) -> vk::ImageMemoryBarrier<'static> {
        layout_barrier(self.handle, COLOR, old, new, src, dst)
    }

    /// Size of the image's texels in bytes, tightly packed.
    pub fn byte_size(&self) -> u64 {
        u64::from(texel_bytes(self.format).unwrap_or(0))
            * u64::from(self.width)
            * u64::from(self.height)
    }

    /// The descriptor of the image as a storage image.
    pub(crate) fn descriptor(&self) -> vk::DescriptorImageInfo {
        vk::DescriptorImageInfo::default()
            .image_view(self.view)
            .image_layout(vk::ImageLayout::GENERAL)
    }

    /// The name it was created with.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Records a copy of the whole image into `buffer` (at least [`Image::byte_size`] bytes):
    /// texels row by row from the top, tightly packed. Waits for earlier compute writes of the
    /// image; the copy is visible to later compute shaders and host reads of `buffer`.
    pub fn record_copy_to(&self, ctx: &Context, cmd: vk::CommandBuffer, buffer: &Buffer) {
        unsafe {
            // Earlier submissions are in this barrier's first scope (submission order). Copies
            // from GENERAL are slow on some devices: move to TRANSFER_SRC_OPTIMAL and back.
            let to_transfer = [self.layout_barrier(
                vk::ImageLayout::GENERAL,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                vk::AccessFlags::SHADER_WRITE,
                vk::AccessFlags::TRANSFER_READ,
            )];
            ctx.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_transfer,
            );
            let region = [vk::BufferImageCopy::default()
                .image_subresource(vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                })
                .image_extent(vk::Extent3D {
                    width: self.width,
                    height: self.height,
                    depth: 1,
                })];
            ctx.device.cmd_copy_image_to_buffer(
                cmd,
                self.handle,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.handle,
                &region,
            );
            let after = [vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ | vk::AccessFlags::SHADER_READ)];
            let to_general = [self.layout_barrier(
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                vk::ImageLayout::GENERAL,
                vk::AccessFlags::TRANSFER_READ,
                vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
            )];
            ctx.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST | vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::DependencyFlags::empty(),
                &after,
                &[],
                &to_general,
            );
        }
    }

    /// Copies the image to the host: texels row by row from the top, tightly packed, in the
    /// image's format. Waits for all earlier submitted work that wrote it from a compute shader.
    pub fn read_back(&self, ctx: &Context) -> Result<Vec<u8>> {
        let mut staging = Buffer::readback::<u8>(
            ctx,
            &format!("{} read-back", self.name),
            self.byte_size() as usize,
        )?;
        ctx.submit(|cmd| self.record_copy_to(ctx, cmd, &staging))?;
        staging.read::<u8>()
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        destroy_image(&self.shared, self.handle, self.view, self.allocation.take());
    }
}

/// Frees what [`create_bound_image`] made and the view made of it (a null view until one is made:
/// destroying it is a no-op), and forgets the image's registration.
pub(super) fn destroy_image(
    shared: &SharedDevice,
    handle: vk::Image,
    view: vk::ImageView,
    allocation: Option<Allocation>,
) {
    shared.images.remove(handle);
    unsafe {
        shared.device.destroy_image_view(view, None);
        shared.device.destroy_image(handle, None);
    }
    if let (Some(a), Ok(mut alloc)) = (allocation, shared.allocator.lock()) {
        alloc.free(a).ok();
    }
}

/// A barrier moving `range` of `image` from layout `old` to `new` (one queue family).
pub(crate) fn layout_barrier(
    image: vk::Image,
    range: vk::ImageSubresourceRange,
    old: vk::ImageLayout,
    new: vk::ImageLayout,
    src: vk::AccessFlags,
    dst: vk::AccessFlags,
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .src_access_mask(src)
        .dst_access_mask(dst)
        .old_layout(old)
        .new_layout(new)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range)
}
