//! Sampled images with their mip chains, for the scene's textures, and the samplers that read
//! them: the device side of `gi_shared::textures`.
//!
//! Each texture is its own `R8G8B8A8_SRGB` (colour, decoded by the sampler before filtering) or
//! `R8G8B8A8_UNORM` image, in `SHADER_READ_ONLY_OPTIMAL` from its upload on. Uploads go through
//! host-visible staging buffers of at most [`STAGING_BYTES`], one submission per batch of
//! textures, so a scene's whole texture set never needs a staging copy of its size.

use super::context::{Context, SharedDevice};
use super::image::{create_bound_image, destroy_image, layout_barrier};
use super::memory::Buffer;
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::Allocation;
use std::sync::Arc;

/// Largest staging buffer of a texture upload (a larger texture gets a buffer of its own size).
pub const STAGING_BYTES: u64 = 64 << 20;

/// One texture's texels as uploaded: RGBA8 levels, level 0 first, each level half the previous
/// one (rounded down, at least 1), as `gi_shared::textures::level_size` sizes them.
pub struct TextureLevels<'a> {
    /// Name, for errors and the memory report.
    pub name: &'a str,
    /// Level 0 width.
    pub width: u32,
    /// Level 0 height.
    pub height: u32,
    /// Colour channels sRGB-encoded.
    pub srgb: bool,
    /// Each level's texels, 4 bytes each, rows from the top.
    pub levels: Vec<&'a [u8]>,
}

/// A sampled 2D image with its mip chain and a view of all of it; freed when dropped.
pub struct TextureImage {
    /// The Vulkan handle.
    pub handle: vk::Image,
    /// A view of every level.
    pub view: vk::ImageView,
    /// Bytes of device memory.
    pub bytes: u64,
    allocation: Option<Allocation>,
    shared: Arc<SharedDevice>,
}

impl TextureImage {
    /// Creates the image of `texture` (contents undefined until [`upload_textures`] copies them).
    fn new(ctx: &Context, texture: &TextureLevels<'_>) -> Result<Self> {
        let format = if texture.srgb {
            vk::Format::R8G8B8A8_SRGB
        } else {
            vk::Format::R8G8B8A8_UNORM
        };
        let bad = |why: String| Error::InvalidArgument {
            name: "texture",
            why: format!("texture {:?}: {why}", texture.name),
        };
        if texture.width == 0 || texture.height == 0 || texture.levels.is_empty() {
            return Err(bad(format!(
                "{}×{} with {} levels is empty",
                texture.width,
                texture.height,
                texture.levels.len()
            )));
        }
        for (l, level) in texture.levels.iter().enumerate() {
            let (w, h) = gi_shared::textures::level_size(texture.width, texture.height, l as u32);
            if level.len() as u64 != u64::from(w) * u64::from(h) * 4 {
                return Err(bad(format!(
                    "level {l} has {} bytes, not {w}×{h}×4",
                    level.len()
                )));
            }
        }
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: texture.width,
                height: texture.height,
                depth: 1,
            })
            .mip_levels(texture.levels.len() as u32)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let (handle, allocation, bytes) =
            create_bound_image(ctx, texture.name, &info).map_err(|e| {
                bad(format!(
                    "{e} for {}×{} {format:?} with {} levels",
                    texture.width,
                    texture.height,
                    texture.levels.len()
                ))
            })?;
        // From here on, `image` frees what exists if a later step fails.
        let mut image = Self {
            handle,
            view: vk::ImageView::null(),
            bytes,
            allocation: Some(allocation),
            shared: ctx.shared.clone(),
        };
        let view_info = vk::ImageViewCreateInfo::default()
            .image(handle)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(all_levels(texture.levels.len() as u32));
        image.view =
            unsafe { ctx.device.create_image_view(&view_info, None) }.vk("vkCreateImageView")?;
        Ok(image)
    }
}

impl Drop for TextureImage {
    fn drop(&mut self) {
        destroy_image(&self.shared, self.handle, self.view, self.allocation.take());
    }
}

fn all_levels(levels: u32) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: levels,
        base_array_layer: 0,
        layer_count: 1,
    }
}

/// Creates the images of `textures` and uploads their texels, in batches of at most
/// [`STAGING_BYTES`] of staging memory; every image ends in `SHADER_READ_ONLY_OPTIMAL`, visible
/// to compute shaders.
pub fn upload_textures(ctx: &Context, textures: &[TextureLevels<'_>]) -> Result<Vec<TextureImage>> {
    let images = textures
        .iter()
        .map(|t| TextureImage::new(ctx, t))
        .collect::<Result<Vec<_>>>()?;
    let bytes = |t: &TextureLevels<'_>| t.levels.iter().map(|l| l.len() as u64).sum::<u64>();
    let mut start = 0;
    while start < textures.len() {
        let mut end = start + 1;
        let mut size = bytes(&textures[start]);
        while end < textures.len() && size + bytes(&textures[end]) <= STAGING_BYTES {
            size += bytes(&textures[end]);
            end += 1;
        }
        upload_batch(ctx, &textures[start..end], &images[start..end], size)?;
        start = end;
    }
    Ok(images)
}

/// One staging buffer and one submission for `textures` (`size` bytes in all).
fn upload_batch(
    ctx: &Context,
    textures: &[TextureLevels<'_>],
    images: &[TextureImage],
    size: u64,
) -> Result<()> {
    let mut staging = Buffer::new(
        ctx,
        "texture staging",
        size,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::CpuToGpu,
    )?;
    let mut contents = Vec::with_capacity(size as usize);
    let mut copies: Vec<Vec<vk::BufferImageCopy>> = Vec::with_capacity(textures.len());
    for texture in textures {
        let mut regions = Vec::with_capacity(texture.levels.len());
        for (l, level) in texture.levels.iter().enumerate() {
            let (w, h) = gi_shared::textures::level_size(texture.width, texture.height, l as u32);
            regions.push(
                vk::BufferImageCopy::default()
                    .buffer_offset(contents.len() as u64)
                    .image_subresource(vk::ImageSubresourceLayers {
                        aspect_mask: vk::ImageAspectFlags::COLOR,
                        mip_level: l as u32,
                        base_array_layer: 0,
                        layer_count: 1,
                    })
                    .image_extent(vk::Extent3D {
                        width: w,
                        height: h,
                        depth: 1,
                    }),
            );
            contents.extend_from_slice(level);
        }
        copies.push(regions);
    }
    staging.write(&contents)?;
    // Every image of the batch, all levels, from layout `old` to `new`.
    let barriers = |old, new, src, dst| -> Vec<vk::ImageMemoryBarrier<'static>> {
        images
            .iter()
            .zip(textures)
            .map(|(image, t)| {
                let range = all_levels(t.levels.len() as u32);
                layout_barrier(image.handle, range, old, new, src, dst)
            })
            .collect()
    };
    let to_transfer = barriers(
        vk::ImageLayout::UNDEFINED,
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::AccessFlags::empty(),
        vk::AccessFlags::TRANSFER_WRITE,
    );
    let to_read = barriers(
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        vk::AccessFlags::TRANSFER_WRITE,
        vk::AccessFlags::SHADER_READ,
    );
    ctx.submit(|cmd| unsafe {
        ctx.device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TOP_OF_PIPE,
            vk::PipelineStageFlags::TRANSFER,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &to_transfer,
        );
        for (image, regions) in images.iter().zip(&copies) {
            ctx.device.cmd_copy_buffer_to_image(
                cmd,
                staging.handle,
                image.handle,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                regions,
            );
        }
        ctx.device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &to_read,
        );
    })?;
    Ok(())
}

/// A texture's wrap modes (`gi_shared::textures::WRAP_*`, u then v).
pub type WrapModes = [u32; 2];

/// The samplers of a scene's textures, one per pair of wrap modes in use: trilinear, explicit
/// level of detail (no sampler anisotropy: the kernels take their own anisotropic taps,
/// `gi_shared::textures::sample_footprint`, so the CPU reference reads the same). Freed when
/// dropped.
pub struct Samplers {
    samplers: Vec<(WrapModes, vk::Sampler)>,
    shared: Arc<SharedDevice>,
}

impl Samplers {
    /// No samplers yet.
    pub fn new(ctx: &Context) -> Self {
        Self {
            samplers: Vec::new(),
            shared: ctx.shared.clone(),
        }
    }

    /// The sampler for `wrap`, created on first use.
    pub fn get(&mut self, ctx: &Context, wrap: WrapModes) -> Result<vk::Sampler> {
        if let Some((_, s)) = self.samplers.iter().find(|(w, _)| *w == wrap) {
            return Ok(*s);
        }
        let mode = |w: u32| match w {
            gi_shared::textures::WRAP_MIRRORED_REPEAT => vk::SamplerAddressMode::MIRRORED_REPEAT,
            gi_shared::textures::WRAP_CLAMP_TO_EDGE => vk::SamplerAddressMode::CLAMP_TO_EDGE,
            _ => vk::SamplerAddressMode::REPEAT,
        };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::LINEAR)
            .min_filter(vk::Filter::LINEAR)
            .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
            .address_mode_u(mode(wrap[0]))
            .address_mode_v(mode(wrap[1]))
            .address_mode_w(vk::SamplerAddressMode::REPEAT)
            .min_lod(0.0)
            .max_lod(vk::LOD_CLAMP_NONE);
        let sampler = unsafe { ctx.device.create_sampler(&info, None) }.vk("vkCreateSampler")?;
        self.samplers.push((wrap, sampler));
        Ok(sampler)
    }
}

impl Drop for Samplers {
    fn drop(&mut self) {
        for (_, s) in self.samplers.drain(..) {
            unsafe { self.shared.device.destroy_sampler(s, None) };
        }
    }
}
