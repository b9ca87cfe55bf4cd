//! Sampled images made from host texels, left in a layout of the caller's choice: images like an
//! engine's G-buffer, for tests and examples that have no renderer to draw them.

use super::context::{Context, SharedDevice};
use super::image::{create_bound_image, destroy_image, layout_barrier};
use super::memory::{Buffer, MemoryLocation};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::vulkan::Allocation;
use std::sync::Arc;

/// Bytes per texel and aspect of the formats [`SampledImage::upload`] takes.
fn texel_layout(format: vk::Format) -> Option<(u64, vk::ImageAspectFlags)> {
    use vk::Format as F;
    let color = vk::ImageAspectFlags::COLOR;
    match format {
        F::D32_SFLOAT => Some((4, vk::ImageAspectFlags::DEPTH)),
        F::D16_UNORM => Some((2, vk::ImageAspectFlags::DEPTH)),
        F::R16_SFLOAT | F::R8G8_UNORM | F::R8G8_SNORM => Some((2, color)),
        F::R32_SFLOAT
        | F::R16G16_SFLOAT
        | F::R16G16_UNORM
        | F::R16G16_SNORM
        | F::R8G8B8A8_UNORM
        | F::R8G8B8A8_SNORM
        | F::R8G8B8A8_SRGB
        | F::B8G8R8A8_UNORM
        | F::B8G8R8A8_SRGB
        | F::A2B10G10R10_UNORM_PACK32
        | F::B10G11R11_UFLOAT_PACK32 => Some((4, color)),
        F::R32G32_SFLOAT
        | F::R16G16B16A16_SFLOAT
        | F::R16G16B16A16_UNORM
        | F::R16G16B16A16_SNORM => Some((8, color)),
        F::R32G32B32A32_SFLOAT => Some((16, color)),
        _ => None,
    }
}

/// A 2D sampled image (one level, one layer) with a view of it, holding uploaded texels, in the
/// layout it was made for; freed when dropped.
pub struct SampledImage {
    /// The Vulkan handle.
    pub handle: vk::Image,
    /// A view of the whole image (the `DEPTH` aspect of a depth format).
    pub view: vk::ImageView,
    /// Texel format.
    pub format: vk::Format,
    /// The layout it is in.
    pub layout: vk::ImageLayout,
    /// Width and height in pixels.
    pub extent: vk::Extent2D,
    allocation: Option<Allocation>,
    shared: Arc<SharedDevice>,
}

impl SampledImage {
    /// Creates a `width × height` image of `format` holding `texels` (rows from the top, tightly
    /// packed, in the format's layout), left in `layout` with its contents visible to compute
    /// shaders. Submits and waits.
    ///
    /// `format`: `D32_SFLOAT`, `D16_UNORM`, or an 8-, 16- or 32-bit colour format of one, two or
    /// four channels (the formats of `crate::gi::gbuffer_import`).
    pub fn upload(
        ctx: &Context,
        name: &str,
        extent: vk::Extent2D,
        format: vk::Format,
        texels: &[u8],
        layout: vk::ImageLayout,
    ) -> Result<Self> {
        let bad = |why: String| Error::InvalidArgument {
            name: "sampled image",
            why: format!("image {name:?}: {why}"),
        };
        let (bytes, aspect) =
            texel_layout(format).ok_or_else(|| bad(format!("{format:?} is not supported")))?;
        let expected = bytes * u64::from(extent.width) * u64::from(extent.height);
        if expected == 0 || texels.len() as u64 != expected {
            return Err(bad(format!(
                "{} bytes of texels for {}×{} of {format:?} ({expected} bytes)",
                texels.len(),
                extent.width,
                extent.height
            )));
        }
        let mut usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        if aspect == vk::ImageAspectFlags::DEPTH {
            // As an engine's depth buffer; the depth read-only layouts require it.
            usage |= vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
        }
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(extent.into())
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let (handle, allocation, _) = create_bound_image(ctx, name, &info)?;
        // From here on, `image` frees what exists if a later step fails.
        let mut image = Self {
            handle,
            view: vk::ImageView::null(),
            format,
            layout,
            extent,
            allocation: Some(allocation),
            shared: ctx.shared.clone(),
        };
        let range = vk::ImageSubresourceRange {
            aspect_mask: aspect,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        };
        let view_info = vk::ImageViewCreateInfo::default()
            .image(handle)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(range);
        image.view =
            unsafe { ctx.device.create_image_view(&view_info, None) }.vk("vkCreateImageView")?;
        let mut staging = Buffer::new(
            ctx,
            &format!("{name} staging"),
            expected,
            vk::BufferUsageFlags::empty(),
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(texels)?;
        ctx.submit(|cmd| unsafe {
            let to_transfer = [layout_barrier(
                handle,
                range,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::AccessFlags::empty(),
                vk::AccessFlags::TRANSFER_WRITE,
            )];
            ctx.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_transfer,
            );
            let region = [vk::BufferImageCopy::default()
                .image_subresource(vk::ImageSubresourceLayers {
                    aspect_mask: aspect,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                })
                .image_extent(extent.into())];
            ctx.device.cmd_copy_buffer_to_image(
                cmd,
                staging.handle,
                handle,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &region,
            );
            let to_layout = [layout_barrier(
                handle,
                range,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                layout,
                vk::AccessFlags::TRANSFER_WRITE,
                vk::AccessFlags::SHADER_READ,
            )];
            ctx.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_layout,
            );
        })?;
        Ok(image)
    }
}

impl Drop for SampledImage {
    fn drop(&mut self) {
        destroy_image(&self.shared, self.handle, self.view, self.allocation.take());
    }
}
