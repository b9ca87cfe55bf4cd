//! Per-pixel irradiance and the GI denoiser on the host (kernels
//! `kernels/src/screen_probes/interpolate.rs` and `kernels/src/gi_denoiser/`, math
//! `gi_shared::screen_probes::interpolate` and `gi_shared::gi_denoiser`): InterpolateScreenProbes,
//! ReprojectGI, FilterBlurMask and FilterGI (horizontal, then vertical), with their per-pixel
//! buffers.

use super::screen_probes::{ScreenProbeResources, kernel};
use crate::error::Result;
use crate::gbuffer::GBufferImages;
use crate::vulkan::{Buffer, Context, Kernel, KernelModule, PingPong, Resource, compute_barrier};
use ash::vk;

/// The per-pixel buffers of interpolation and the denoiser.
pub struct DenoiserResources {
    /// This frame's interpolated irradiance (`[r, g, b, hint]`).
    pub irradiance: Buffer,
    /// The temporal history (`[r, g, b, count]`), this frame's and the previous frame's.
    pub history: PingPong<Buffer>,
    /// Each pixel's world position and packed normal, this frame's and the previous frame's.
    pub surface: PingPong<Buffer>,
    /// The smoothed luminance change, this frame's and the previous frame's.
    pub luma_delta: PingPong<Buffer>,
    /// The blur mask (radius in pixels before dilation).
    pub blur_mask: Buffer,
    /// The dilated, cost-adapted blur radius.
    pub blur_radius: Buffer,
    /// FilterGI's horizontal and vertical outputs.
    pub filtered: [Buffer; 2],
}

impl DenoiserResources {
    /// The buffers of a `pixels`-pixel frame.
    pub fn new(ctx: &Context, pixels: usize) -> Result<Self> {
        let v4 = |name: &str| Buffer::device_zeroed::<[f32; 4]>(ctx, name, pixels);
        let f = |name: &str| Buffer::device_zeroed::<f32>(ctx, name, pixels);
        Ok(Self {
            irradiance: v4("interpolated irradiance")?,
            history: PingPong::new(v4("GI history (a)")?, v4("GI history (b)")?),
            surface: PingPong::new(v4("GI surfaces (a)")?, v4("GI surfaces (b)")?),
            luma_delta: PingPong::new(f("GI luma delta (a)")?, f("GI luma delta (b)")?),
            blur_mask: f("blur mask")?,
            blur_radius: f("blur radius")?,
            filtered: [
                v4("filtered GI (horizontal)")?,
                v4("filtered GI (vertical)")?,
            ],
        })
    }

    /// Starts a frame: this frame's histories become the previous ones.
    pub fn swap(&mut self) {
        self.history.swap();
        self.surface.swap();
        self.luma_delta.swap();
    }

    /// The irradiance the composite reads: the last stage that ran.
    pub fn output(&self, temporal: bool, spatial: bool) -> &Buffer {
        if spatial {
            &self.filtered[1]
        } else if temporal {
            self.history.current()
        } else {
            &self.irradiance
        }
    }
}

/// The pipelines of interpolation and the denoiser.
pub struct DenoiserPasses {
    interpolate: Kernel,
    reproject: Kernel,
    blur_mask: Kernel,
    filter: Kernel,
}

impl DenoiserPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &Context, module: &KernelModule) -> Result<Self> {
        Ok(Self {
            interpolate: kernel(
                ctx,
                module,
                "screen_probes::interpolate::interpolate_screen_probes",
                "bbiiibbbbb",
                0,
            )?,
            reproject: kernel(
                ctx,
                module,
                "gi_denoiser::reproject_gi::reproject_gi",
                "bbiibbbbbbbbi",
                0,
            )?,
            blur_mask: kernel(
                ctx,
                module,
                "gi_denoiser::blur_mask::filter_blur_mask",
                "bbbb",
                0,
            )?,
            filter: kernel(
                ctx,
                module,
                "gi_denoiser::filter_gi::filter_gi",
                "bbiibbbb",
                4,
            )?,
        })
    }

    /// InterpolateScreenProbes: each pixel's irradiance from up to four probes.
    pub fn record_interpolate(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        probes: &ScreenProbeResources,
        res: &DenoiserResources,
        camera: &Buffer,
        gbuffer: &GBufferImages,
    ) -> Result<()> {
        let i = &gbuffer.images;
        self.interpolate.dispatch(
            ctx,
            cmd,
            &[
                Resource::Buffer(&probes.frame),
                Resource::Buffer(camera),
                Resource::Image(&i[0]),
                Resource::Image(&i[1]),
                Resource::Image(&i[2]),
                Resource::Buffer(probes.records.current()),
                Resource::Buffer(probes.mask.current()),
                Resource::Buffer(&probes.sh),
                Resource::Buffer(&res.irradiance),
                Resource::Buffer(&probes.counters),
            ],
            &[],
            pixel_groups(gbuffer),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }

    /// ReprojectGI: temporal accumulation of the irradiance and the blur mask.
    pub fn record_reproject(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        probes: &ScreenProbeResources,
        res: &DenoiserResources,
        camera: &Buffer,
        gbuffer: &GBufferImages,
    ) -> Result<()> {
        let i = &gbuffer.images;
        self.reproject.dispatch(
            ctx,
            cmd,
            &[
                Resource::Buffer(&probes.frame),
                Resource::Buffer(camera),
                Resource::Image(&i[0]),
                Resource::Image(&i[1]),
                Resource::Buffer(&res.irradiance),
                Resource::Buffer(res.history.previous()),
                Resource::Buffer(res.history.current()),
                Resource::Buffer(res.surface.previous()),
                Resource::Buffer(res.surface.current()),
                Resource::Buffer(res.luma_delta.previous()),
                Resource::Buffer(res.luma_delta.current()),
                Resource::Buffer(&res.blur_mask),
                Resource::Image(&i[5]),
            ],
            &[],
            pixel_groups(gbuffer),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }

    /// FilterBlurMask, then FilterGI horizontal and vertical; `input` is the irradiance the
    /// blur starts from (the temporal history, or the interpolated irradiance without it).
    #[allow(clippy::too_many_arguments, reason = "the pass's inputs")]
    pub fn record_filter(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        probes: &ScreenProbeResources,
        res: &DenoiserResources,
        camera: &Buffer,
        gbuffer: &GBufferImages,
        input: &Buffer,
    ) -> Result<()> {
        self.blur_mask.dispatch(
            ctx,
            cmd,
            &[
                Resource::Buffer(&probes.frame),
                Resource::Buffer(&res.blur_mask),
                Resource::Buffer(&res.blur_radius),
                Resource::Buffer(&probes.counters),
            ],
            &[],
            pixel_groups(gbuffer),
        )?;
        compute_barrier(ctx, cmd);
        let i = &gbuffer.images;
        for (direction, (from, to)) in [input, &res.filtered[0]]
            .into_iter()
            .zip(&res.filtered)
            .enumerate()
        {
            self.filter.dispatch(
                ctx,
                cmd,
                &[
                    Resource::Buffer(&probes.frame),
                    Resource::Buffer(camera),
                    Resource::Image(&i[0]),
                    Resource::Image(&i[1]),
                    Resource::Buffer(&res.blur_radius),
                    Resource::Buffer(from),
                    Resource::Buffer(to),
                    Resource::Buffer(res.history.current()),
                ],
                &(direction as u32).to_le_bytes(),
                pixel_groups(gbuffer),
            )?;
            compute_barrier(ctx, cmd);
        }
        Ok(())
    }
}

/// Workgroups of 8 × 8 pixels over the G-buffer.
pub(crate) fn pixel_groups(gbuffer: &GBufferImages) -> [u32; 3] {
    [gbuffer.width().div_ceil(8), gbuffer.height().div_ceil(8), 1]
}
