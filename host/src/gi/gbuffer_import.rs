//! Bringing an engine's own G-buffer: [`GBufferImport`] records the `gbuffer_import` kernel
//! (`kernels/src/gbuffer_import.rs`), which reads the engine's images ([`ExternalGBuffer`]) and
//! writes our [`GBufferImages`], in place of our G-buffer pass. What each of our channels then
//! holds, and what an import cannot know (instance, triangle and material ids), is in
//! `gi_shared::gbuffer_import`.
//!
//! # What the engine hands over
//!
//! Each image is the engine's ([`ExternalImage`]: not owned, never destroyed or transitioned
//! here), the size of our G-buffer, created with `SAMPLED` usage, with a 2D view of one level
//! and one layer (a depth/stencil format's view with the `DEPTH` aspect only). The kernel reads
//! them by texel fetch, no sampler, at stage [`READ_STAGE`] with access [`READ_ACCESS`]: before
//! [`GBufferImport::record`], the engine's barrier must make its writes (colour attachment or
//! depth writes) available to that stage and access and move each image to the layout it names
//! ([`ACCEPTED_LAYOUTS`], [`DEPTH_LAYOUTS`]); before it writes them again (the next frame), a
//! barrier must wait for [`READ_STAGE`].
//!
//! Formats ([`DEPTH_FORMATS`] and the others): a UNORM normal format holds `0.5 + 0.5 · v`; an
//! sRGB albedo format is decoded to linear by the read. Conventions: [`Conventions`] (depth
//! encoding and planes, normal encoding, motion units and direction). The camera passed to
//! `record` is the engine's frame: same position, orientation, field of view and jitter (in
//! pixels, `y` down: the sample position of pixel `(x, y)` is `(x + 0.5, y + 0.5) + jitter`), and
//! the previous frame's view-projection for the motion of the camera.

use crate::error::{Error, Result};
use crate::frame::Recorder;
use crate::gbuffer::GBufferImages;
use crate::vulkan::{Buffer, Context, Image, Kernel, KernelModule, Sampled, SampledImage};
use ash::vk;
use gi_shared::camera::CameraParams;
pub use gi_shared::gbuffer_import::{Conventions, DepthEncoding, MotionUnits, MotionVectors};
use gi_shared::gbuffer_import::{
    FLAG_EMISSIVE, FLAG_MOTION, FLAG_UNORM_NORMALS, GBufferImportParams, IMPORT_TILE,
    NormalEncoding,
};
use glam::UVec2;

/// The stage the import reads the engine's images at.
pub const READ_STAGE: vk::PipelineStageFlags = vk::PipelineStageFlags::COMPUTE_SHADER;
/// The access the import reads the engine's images with.
pub const READ_ACCESS: vk::AccessFlags = vk::AccessFlags::SHADER_READ;

/// Layouts any engine image may be in while the import runs.
pub const ACCEPTED_LAYOUTS: [vk::ImageLayout; 2] = [
    vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
    vk::ImageLayout::GENERAL,
];
/// Layouts a depth image of a depth format may be in besides [`ACCEPTED_LAYOUTS`].
pub const DEPTH_LAYOUTS: [vk::ImageLayout; 1] = [vk::ImageLayout::DEPTH_STENCIL_READ_ONLY_OPTIMAL];

/// Depth formats: depth formats (read through a `DEPTH`-aspect view), or one float channel
/// (any [`DepthEncoding`]).
pub const DEPTH_FORMATS: [vk::Format; 7] = [
    vk::Format::D32_SFLOAT,
    vk::Format::D32_SFLOAT_S8_UINT,
    vk::Format::D24_UNORM_S8_UINT,
    vk::Format::X8_D24_UNORM_PACK32,
    vk::Format::D16_UNORM,
    vk::Format::R32_SFLOAT,
    vk::Format::R16_SFLOAT,
];
/// Normal formats of [`NormalEncoding::World`] (`xyz`).
pub const WORLD_NORMAL_FORMATS: [vk::Format; 7] = [
    vk::Format::R16G16B16A16_SFLOAT,
    vk::Format::R32G32B32A32_SFLOAT,
    vk::Format::R16G16B16A16_SNORM,
    vk::Format::R8G8B8A8_SNORM,
    vk::Format::A2B10G10R10_UNORM_PACK32,
    vk::Format::R16G16B16A16_UNORM,
    vk::Format::R8G8B8A8_UNORM,
];
/// Normal formats of [`NormalEncoding::Octahedral`] (`xy`).
pub const OCTAHEDRAL_NORMAL_FORMATS: [vk::Format; 6] = [
    vk::Format::R16G16_SFLOAT,
    vk::Format::R32G32_SFLOAT,
    vk::Format::R16G16_SNORM,
    vk::Format::R8G8_SNORM,
    vk::Format::R16G16_UNORM,
    vk::Format::R8G8_UNORM,
];
/// Albedo formats (linear, or sRGB decoded by the read; alpha kept).
pub const ALBEDO_FORMATS: [vk::Format; 6] = [
    vk::Format::R8G8B8A8_UNORM,
    vk::Format::R8G8B8A8_SRGB,
    vk::Format::B8G8R8A8_UNORM,
    vk::Format::B8G8R8A8_SRGB,
    vk::Format::A2B10G10R10_UNORM_PACK32,
    vk::Format::R16G16B16A16_SFLOAT,
];
/// Motion formats (`xy`).
pub const MOTION_FORMATS: [vk::Format; 4] = [
    vk::Format::R16G16_SFLOAT,
    vk::Format::R32G32_SFLOAT,
    vk::Format::R16G16B16A16_SFLOAT,
    vk::Format::R32G32B32A32_SFLOAT,
];
/// Emission formats (`xyz`, radiance in W/(sr·m²) like ours).
pub const EMISSIVE_FORMATS: [vk::Format; 3] = [
    vk::Format::R16G16B16A16_SFLOAT,
    vk::Format::R32G32B32A32_SFLOAT,
    vk::Format::B10G11R11_UFLOAT_PACK32,
];

/// Normal formats whose stored values are `0.5 + 0.5 · v`.
const UNORM_NORMAL_FORMATS: [vk::Format; 5] = [
    vk::Format::A2B10G10R10_UNORM_PACK32,
    vk::Format::R16G16B16A16_UNORM,
    vk::Format::R8G8B8A8_UNORM,
    vk::Format::R16G16_UNORM,
    vk::Format::R8G8_UNORM,
];

/// One of the engine's images, as the import reads it: the engine owns it and keeps it alive
/// until the recorded commands finished.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExternalImage {
    /// The image (for the engine's barriers; the import binds the view).
    pub image: vk::Image,
    /// A 2D view of one level and layer; of a depth/stencil format, with the `DEPTH` aspect only.
    pub view: vk::ImageView,
    /// The view's format: one of the image's accepted formats ([`DEPTH_FORMATS`] etc.).
    pub format: vk::Format,
    /// The layout the image is in while the recorded commands run ([`ACCEPTED_LAYOUTS`], and for
    /// a depth format [`DEPTH_LAYOUTS`]).
    pub layout: vk::ImageLayout,
    /// Width and height in pixels: those of our G-buffer.
    pub extent: vk::Extent2D,
}

impl From<&SampledImage> for ExternalImage {
    fn from(image: &SampledImage) -> Self {
        Self {
            image: image.handle,
            view: image.view,
            format: image.format,
            layout: image.layout,
            extent: image.extent,
        }
    }
}

/// An engine's G-buffer: its images and their conventions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExternalGBuffer {
    /// Depth, [`DEPTH_FORMATS`], encoded as `conventions.depth` says.
    pub depth: ExternalImage,
    /// World-space normals: [`WORLD_NORMAL_FORMATS`] or [`OCTAHEDRAL_NORMAL_FORMATS`], as
    /// `conventions.normal` says.
    pub normal: ExternalImage,
    /// Albedo (base colour), [`ALBEDO_FORMATS`].
    pub albedo: ExternalImage,
    /// Motion vectors, [`MOTION_FORMATS`], as `conventions.motion` says; `None`: the camera's
    /// motion alone, from depth and the previous camera (moving objects then get no history of
    /// their own).
    pub motion: Option<ExternalImage>,
    /// Emitted radiance, [`EMISSIVE_FORMATS`]; `None`: no emission.
    pub emissive: Option<ExternalImage>,
    /// Depth, normal and motion conventions.
    pub conventions: Conventions,
}

/// An error naming the engine image at fault.
fn refused(image: &str, why: String) -> Error {
    Error::InvalidArgument {
        name: "external G-buffer",
        why: format!("{image} image: {why}"),
    }
}

/// Checks one engine image: format among `formats`, a layout the import reads, size `size`.
fn check(
    name: &str,
    image: &ExternalImage,
    formats: &[vk::Format],
    size: vk::Extent2D,
) -> Result<()> {
    // The formats read through a `DEPTH`-aspect view.
    let depth_format = DEPTH_FORMATS[..5].contains(&image.format);
    if !formats.contains(&image.format) {
        return Err(refused(
            name,
            format!(
                "format {:?} is not accepted (accepted: {formats:?})",
                image.format
            ),
        ));
    }
    if !ACCEPTED_LAYOUTS.contains(&image.layout)
        && !(depth_format && DEPTH_LAYOUTS.contains(&image.layout))
    {
        return Err(refused(
            name,
            format!(
                "layout {:?} cannot be read by a sampled-image fetch (accepted: {ACCEPTED_LAYOUTS:?}{})",
                image.layout,
                if depth_format {
                    format!(", {DEPTH_LAYOUTS:?}")
                } else {
                    String::new()
                }
            ),
        ));
    }
    if image.extent != size {
        return Err(refused(
            name,
            format!(
                "{}×{} differs from the G-buffer's {}×{}",
                image.extent.width, image.extent.height, size.width, size.height
            ),
        ));
    }
    Ok(())
}

impl ExternalGBuffer {
    /// The kernel's flags, or an error naming the image at fault when an image does not fit a
    /// G-buffer of `size`.
    fn flags(&self, size: vk::Extent2D) -> Result<u32> {
        check("depth", &self.depth, &DEPTH_FORMATS, size)?;
        let normal_formats: &[vk::Format] = match self.conventions.normal {
            NormalEncoding::World => &WORLD_NORMAL_FORMATS,
            NormalEncoding::Octahedral => &OCTAHEDRAL_NORMAL_FORMATS,
        };
        check("normal", &self.normal, normal_formats, size)?;
        check("albedo", &self.albedo, &ALBEDO_FORMATS, size)?;
        let mut flags = 0;
        if UNORM_NORMAL_FORMATS.contains(&self.normal.format) {
            flags |= FLAG_UNORM_NORMALS;
        }
        if let Some(motion) = &self.motion {
            check("motion", motion, &MOTION_FORMATS, size)?;
            flags |= FLAG_MOTION;
        }
        if let Some(emissive) = &self.emissive {
            check("emissive", emissive, &EMISSIVE_FORMATS, size)?;
            flags |= FLAG_EMISSIVE;
        }
        Ok(flags)
    }
}

/// The binding of one engine image.
fn sampled(image: &ExternalImage) -> Sampled {
    Sampled {
        view: image.view,
        layout: image.layout,
    }
}

crate::bindings! {
    /// The G-buffer import's set 0 (`kernels::gbuffer_import::import_gbuffer`).
    pub(crate) struct ImportGbuffer<'a> {
        camera: &'a Buffer,
        engine_depth: Sampled,
        engine_normal: Sampled,
        engine_albedo: Sampled,
        engine_motion: Sampled,
        engine_emissive: Sampled,
        depth: &'a Image,
        geometric_normal: &'a Image,
        shading_normal: &'a Image,
        albedo: &'a Image,
        emissive: &'a Image,
        motion: &'a Image,
        ids: &'a Image,
    }
}

/// The `gbuffer_import::import_gbuffer` pipeline and the camera buffer it reads.
pub struct GBufferImport {
    kernel: Kernel,
    camera: Buffer,
}

impl GBufferImport {
    /// Creates the pipeline and a device-local camera buffer.
    pub fn new(ctx: &Context) -> Result<Self> {
        let module = KernelModule::new(ctx)?;
        let kernel = Kernel::new::<ImportGbuffer>(
            ctx,
            &module,
            "gbuffer_import::import_gbuffer",
            std::mem::size_of::<GBufferImportParams>() as u32,
        )?;
        let camera = Buffer::device_zeroed::<CameraParams>(ctx, "G-buffer import camera", 1)?;
        Ok(Self { kernel, camera })
    }

    /// Records into `cmd` (the engine's, recording, outside a render pass; nothing is submitted)
    /// the conversion of `engine` into `out` for `camera`, whose image size must be `out`'s.
    /// Recorded first: a barrier after earlier compute work (earlier readers of `out` and of the
    /// camera buffer), the camera's upload (`vkCmdUpdateBuffer`); last: a barrier that makes `out`
    /// visible to later compute shaders, transfers and host reads. Errors, recording nothing,
    /// when an image does not fit (naming it) or the depth planes are out of range.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        engine: &ExternalGBuffer,
        camera: &CameraParams,
        out: &GBufferImages,
    ) -> Result<()> {
        let (width, height) = (out.width(), out.height());
        if camera.image_size != [width, height] {
            return Err(Error::InvalidArgument {
                name: "camera",
                why: format!(
                    "image size {:?} differs from the G-buffer's {width}×{height}",
                    camera.image_size
                ),
            });
        }
        let flags = engine.flags(vk::Extent2D { width, height })?;
        let params =
            GBufferImportParams::new(&engine.conventions, UVec2::new(width, height), flags)
                .map_err(|why| refused("depth", why.to_string()))?;
        let mut rec = Recorder::new(ctx, cmd, None);
        // Earlier dispatches may still read the camera buffer and our images.
        rec.begin();
        rec.update(&self.camera, 0, bytemuck::bytes_of(camera));
        // An absent image's binding gets a present one: the flags say it is not read.
        let motion = engine.motion.as_ref().unwrap_or(&engine.depth);
        let emissive = engine.emissive.as_ref().unwrap_or(&engine.albedo);
        let [
            depth,
            geometric_normal,
            shading_normal,
            albedo,
            emissive_out,
            motion_out,
            ids,
        ] = out.all();
        let bindings = ImportGbuffer {
            camera: &self.camera,
            engine_depth: sampled(&engine.depth),
            engine_normal: sampled(&engine.normal),
            engine_albedo: sampled(&engine.albedo),
            engine_motion: sampled(motion),
            engine_emissive: sampled(emissive),
            depth,
            geometric_normal,
            shading_normal,
            albedo,
            emissive: emissive_out,
            motion: motion_out,
            ids,
        };
        let groups = [width.div_ceil(IMPORT_TILE), height.div_ceil(IMPORT_TILE), 1];
        rec.dispatch(&self.kernel, &bindings, bytemuck::bytes_of(&params), groups)?;
        rec.finish();
        Ok(())
    }
}
