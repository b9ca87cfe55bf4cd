//! The primary hit's own light and the final composite on the host (kernels
//! `kernels/src/primary_lighting.rs`, math `gi_shared::primary_lighting`, which states how the
//! frame splits light paths so that each is counted once): DirectLight (emission, the sky seen
//! by the camera, punctual lights by shadow rays) and ResolveGI (emission + albedo × irradiance,
//! and the feedback image of the next frame).

use super::gi_denoiser::DenoiserResources;
use super::pass_inputs::{PrimaryView, pixel_groups};
use super::screen_probes::ScreenProbeResources;
use crate::error::Result;
use crate::frame::Recorder;
use crate::scene::upload::GpuScene;
use crate::vulkan::{Buffer, Context, Image, Kernel, KernelModule};
use gi_shared::primary_lighting::PrimaryLighting;

/// The per-pixel buffers of the primary hit's light and the output.
pub struct PrimaryResources {
    /// One [`PrimaryLighting`] per pixel.
    pub primary: Buffer,
    /// The final image, `[r, g, b, 1]` per pixel, linear HDR, where it has a buffer of its own;
    /// `None` where the composite writes it over the interpolated irradiance
    /// (`DenoiserResources::new`; [`Self::color`]).
    pub own_color: Option<Buffer>,
}

impl PrimaryResources {
    /// The buffers of a `pixels`-pixel frame; the image in a buffer of its own only where
    /// `denoiser` keeps the interpolated irradiance ([`DenoiserResources::keeps_interpolated`]).
    pub fn new(ctx: &Context, pixels: usize, denoiser: &DenoiserResources) -> Result<Self> {
        Ok(Self {
            primary: Buffer::device_zeroed::<PrimaryLighting>(ctx, "primary lighting", pixels)?,
            own_color: match denoiser.keeps_interpolated() {
                true => Some(Buffer::device_zeroed::<[f32; 4]>(ctx, "GI image", pixels)?),
                false => None,
            },
        })
    }

    /// The final image's buffer: its own, or `denoiser`'s interpolated irradiance, which the
    /// denoiser has read by the time the composite writes.
    pub fn color<'a>(&'a self, denoiser: &'a DenoiserResources) -> &'a Buffer {
        match &self.own_color {
            Some(c) => c,
            None => &denoiser.irradiance,
        }
    }
}

crate::bindings! {
    /// DirectLight's set 0 (`kernels::primary_lighting::direct_light`).
    pub(crate) struct DirectLight<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        shading_normal: &'a Image,
        emissive: &'a Image,
        ids: &'a Image,
        lighting: &'a Buffer,
        irradiance: &'a Buffer,
    }
}

crate::bindings! {
    /// ResolveGI's set 0 (`kernels::primary_lighting::resolve_gi`).
    pub(crate) struct ResolveGi<'a> {
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        albedo: &'a Image,
        lighting: &'a Buffer,
        irradiance: &'a Buffer,
        color: &'a Buffer,
        history: &'a Buffer,
        undenoised: &'a Buffer,
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
            direct: Kernel::new::<DirectLight>(ctx, module, "primary_lighting::direct_light", 0)?,
            resolve: Kernel::new::<ResolveGi>(ctx, module, "primary_lighting::resolve_gi", 0)?,
        })
    }

    /// DirectLight: emission, the sky and punctual lights at every pixel, the direct light it
    /// samples (resampled punctual lights, emitter sampling) added to `irradiance`
    /// (InterpolateScreenProbes' output, which the denoiser reads next).
    pub fn record_direct(
        &self,
        rec: &mut Recorder<'_>,
        scene: &GpuScene,
        probes: &ScreenProbeResources,
        res: &PrimaryResources,
        view: PrimaryView<'_>,
        irradiance: &Buffer,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let g = gbuffer;
        rec.dispatch_traced(
            &self.direct,
            scene.sets(),
            &DirectLight {
                frame: &probes.frame,
                camera,
                depth: &g.depth,
                geometric_normal: &g.geometric_normal,
                shading_normal: &g.shading_normal,
                emissive: &g.emissive,
                ids: &g.ids,
                lighting: &res.primary,
                irradiance,
            },
            &[],
            pixel_groups(gbuffer),
        )?;
        Ok(())
    }

    /// ResolveGI: the final image `color` from `irradiance` (the denoiser's output), and the
    /// feedback image (`feedback`, one `FeedbackTexel` per pixel) the next frame's secondary hits
    /// read, from `undenoised` (the interpolated irradiance before the denoiser).
    #[allow(
        clippy::too_many_arguments,
        reason = "one argument per buffer the pass binds"
    )]
    pub fn record_resolve(
        &self,
        rec: &mut Recorder<'_>,
        res: &PrimaryResources,
        view: PrimaryView<'_>,
        irradiance: &Buffer,
        color: &Buffer,
        feedback: &Buffer,
        undenoised: &Buffer,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let g = gbuffer;
        rec.dispatch(
            &self.resolve,
            &ResolveGi {
                camera,
                depth: &g.depth,
                geometric_normal: &g.geometric_normal,
                albedo: &g.albedo,
                lighting: &res.primary,
                irradiance,
                color,
                history: feedback,
                undenoised,
            },
            &[],
            pixel_groups(gbuffer),
        )?;
        Ok(())
    }
}
