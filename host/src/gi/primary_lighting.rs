//! The primary hit's own light and the final composite on the host (kernels
//! `kernels/src/primary_lighting.rs`, math `gi_shared::primary_lighting`, which states how the
//! frame splits light paths so that each is counted once): DirectLight (emission, the sky seen
//! by the camera, punctual lights by shadow rays) and ResolveGI (emission + albedo × irradiance,
//! and the feedback image of the next frame).

use super::gi_denoiser::pixel_groups;
use super::screen_probes::{ScreenProbeResources, kernel};
use crate::error::Result;
use crate::gbuffer::GBufferImages;
use crate::scene::upload::GpuScene;
use crate::vulkan::{Buffer, Context, Kernel, KernelModule, Resource, compute_barrier};
use ash::vk;
use gi_shared::primary_lighting::PrimaryLighting;

/// The per-pixel buffers of the primary hit's light and the output.
pub struct PrimaryResources {
    /// One [`PrimaryLighting`] per pixel.
    pub primary: Buffer,
    /// The final image, `[r, g, b, 1]` per pixel, linear HDR.
    pub color: Buffer,
}

impl PrimaryResources {
    /// The buffers of a `pixels`-pixel frame.
    pub fn new(ctx: &Context, pixels: usize) -> Result<Self> {
        Ok(Self {
            primary: Buffer::device_zeroed::<PrimaryLighting>(ctx, "primary lighting", pixels)?,
            color: Buffer::device_zeroed::<[f32; 4]>(ctx, "GI image", pixels)?,
        })
    }
}

/// The pipelines of DirectLight and ResolveGI.
pub struct PrimaryPasses {
    direct: Kernel,
    resolve: Kernel,
}

impl PrimaryPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &Context, module: &KernelModule) -> Result<Self> {
        Ok(Self {
            direct: kernel(ctx, module, "primary_lighting::direct_light", "bbiiiiib", 0)?,
            resolve: kernel(ctx, module, "primary_lighting::resolve_gi", "biiibbbbb", 0)?,
        })
    }

    /// DirectLight: emission, the sky and punctual lights at every pixel.
    #[allow(clippy::too_many_arguments, reason = "the pass's inputs")]
    pub fn record_direct(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        scene: &GpuScene,
        probes: &ScreenProbeResources,
        res: &PrimaryResources,
        camera: &Buffer,
        gbuffer: &GBufferImages,
    ) -> Result<()> {
        let i = &gbuffer.images;
        self.direct.dispatch_traced(
            ctx,
            cmd,
            scene.sets(),
            &[
                Resource::Buffer(&probes.frame),
                Resource::Buffer(camera),
                Resource::Image(&i[0]),
                Resource::Image(&i[1]),
                Resource::Image(&i[2]),
                Resource::Image(&i[4]),
                Resource::Image(&i[6]),
                Resource::Buffer(&res.primary),
            ],
            &[],
            pixel_groups(gbuffer),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }

    /// ResolveGI: the final image from `irradiance` (the denoiser's output), and the feedback
    /// image (`feedback`, one `FeedbackTexel` per pixel) the next frame's secondary hits read,
    /// from `undenoised` (the interpolated irradiance before the denoiser).
    #[allow(clippy::too_many_arguments, reason = "the pass's inputs")]
    pub fn record_resolve(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &PrimaryResources,
        camera: &Buffer,
        gbuffer: &GBufferImages,
        irradiance: &Buffer,
        feedback: &Buffer,
        undenoised: &Buffer,
    ) -> Result<()> {
        let i = &gbuffer.images;
        self.resolve.dispatch(
            ctx,
            cmd,
            &[
                Resource::Buffer(camera),
                Resource::Image(&i[0]),
                Resource::Image(&i[1]),
                Resource::Image(&i[3]),
                Resource::Buffer(&res.primary),
                Resource::Buffer(irradiance),
                Resource::Buffer(&res.color),
                Resource::Buffer(feedback),
                Resource::Buffer(undenoised),
            ],
            &[],
            pixel_groups(gbuffer),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }
}
