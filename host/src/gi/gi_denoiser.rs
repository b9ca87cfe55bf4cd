//! Per-pixel irradiance and the GI denoiser on the host (kernels
//! `kernels/src/screen_probes/interpolate.rs` and `kernels/src/gi_denoiser/`, math
//! `gi_shared::screen_probes::interpolate` and `gi_shared::gi_denoiser`): InterpolateScreenProbes,
//! ReprojectGI, FilterBlurMask and FilterGI (horizontal, then vertical), with their per-pixel
//! buffers.

use super::pass_inputs::{PrimaryView, pixel_groups};
use super::screen_probes::ScreenProbeResources;
use super::settings::GiSettings;
use crate::error::Result;
use crate::frame::Recorder;
use crate::gbuffer::GBufferImages;
use crate::vulkan::{Buffer, Context, Image, Kernel, KernelModule, PingPong};
use gi_shared::gi_denoiser::reproject_gi::TREND_WORDS;

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
    /// The image's trend sums (`reproject_gi::TREND_WORDS` words), this frame's and the previous
    /// frame's.
    pub trend: PingPong<Buffer>,
    /// The blur mask (radius in pixels before dilation).
    pub blur_mask: Buffer,
    /// The dilated, cost-adapted blur radius.
    pub blur_radius: Buffer,
    /// FilterGI's horizontal output where it has a buffer of its own (see [`Self::new`]), else a
    /// one-element placeholder. Its vertical output is the previous history ([`Self::output`]).
    pub filtered: Buffer,
    /// Whether the interpolated irradiance is kept through the frame ([`Self::new`]).
    keeps_interpolated: bool,
}

impl DenoiserResources {
    /// The buffers of a `pixels`-pixel frame.
    ///
    /// The interpolated irradiance is the frame's per-pixel scratch buffer: once ReprojectGI has
    /// read it, FilterGI (with `spatial`, the setting `denoiser_spatial`) writes its horizontal
    /// output over it ([`Self::horizontal`]), and the composite then writes the GI image over
    /// that (`GiRenderer`): 32 bytes per pixel less. With `keep_interpolated` (temporal
    /// feedback's composite reads the interpolated irradiance; the debug views show it after the
    /// frame) the horizontal output gets a buffer of its own where FilterGI runs, and so does the
    /// image. [`Self::filtered`] is a one-element placeholder otherwise.
    pub fn new(
        ctx: &Context,
        pixels: usize,
        spatial: bool,
        keep_interpolated: bool,
    ) -> Result<Self> {
        let v4 = |name: &str| Buffer::device_zeroed::<[f32; 4]>(ctx, name, pixels);
        let f = |name: &str| Buffer::device_zeroed::<f32>(ctx, name, pixels);
        let trend = |name: &str| Buffer::device_zeroed::<u32>(ctx, name, TREND_WORDS);
        Ok(Self {
            irradiance: v4("interpolated irradiance")?,
            history: PingPong::new(v4("GI history (a)")?, v4("GI history (b)")?),
            surface: PingPong::new(v4("GI surfaces (a)")?, v4("GI surfaces (b)")?),
            luma_delta: PingPong::new(f("GI luma delta (a)")?, f("GI luma delta (b)")?),
            trend: PingPong::new(trend("GI trend (a)")?, trend("GI trend (b)")?),
            blur_mask: f("blur mask")?,
            blur_radius: f("blur radius")?,
            // Named by its role: without `keep_interpolated` the placeholder stands in for the
            // irradiance the composite does not read.
            filtered: Buffer::device_zeroed::<[f32; 4]>(
                ctx,
                match keep_interpolated {
                    true => "filtered GI (horizontal)",
                    false => "irradiance placeholder",
                },
                if spatial && keep_interpolated {
                    pixels
                } else {
                    1
                },
            )?,
            keeps_interpolated: keep_interpolated,
        })
    }

    /// Whether the interpolated irradiance ([`Self::irradiance`]) still holds it after the frame
    /// (see [`Self::new`]).
    pub fn keeps_interpolated(&self) -> bool {
        self.keeps_interpolated
    }

    /// What the composite reads as the irradiance before the denoiser: the interpolated
    /// irradiance where it is kept, else a one-element placeholder (only temporal feedback's
    /// composite reads it, and feedback keeps it).
    pub fn undenoised(&self) -> &Buffer {
        if self.keeps_interpolated {
            &self.irradiance
        } else {
            &self.filtered
        }
    }

    /// FilterGI's horizontal output: its own buffer, or the interpolated irradiance's, which
    /// ReprojectGI has read by then (see [`Self::new`]).
    pub fn horizontal(&self) -> &Buffer {
        if self.keeps_interpolated {
            &self.filtered
        } else {
            &self.irradiance
        }
    }

    /// Starts a frame: this frame's histories become the previous ones.
    pub fn swap(&mut self) {
        self.history.swap();
        self.surface.swap();
        self.luma_delta.swap();
        self.trend.swap();
    }

    /// Where the previous frame's `stage` output is until this frame's ReprojectGI: after
    /// [`Self::swap`] the history pair's roles are exchanged. The interpolated irradiance is not
    /// kept across frames: its stage reads the temporal history.
    pub fn previous_output(&self, stage: DenoiserStage) -> &Buffer {
        match stage {
            DenoiserStage::Spatial => self.history.current(),
            DenoiserStage::Temporal | DenoiserStage::Interpolated => self.history.previous(),
        }
    }

    /// The irradiance `stage` wrote. FilterGI writes its vertical output over the previous
    /// history, which ReprojectGI has read by then and overwrites in full next frame: no buffer
    /// of its own.
    pub fn output(&self, stage: DenoiserStage) -> &Buffer {
        match stage {
            DenoiserStage::Spatial => self.history.previous(),
            DenoiserStage::Temporal => self.history.current(),
            DenoiserStage::Interpolated => &self.irradiance,
        }
    }
}

/// A stage of interpolation and the denoiser, by the irradiance it writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DenoiserStage {
    /// InterpolateScreenProbes: the probes' irradiance at each pixel, before the denoiser.
    Interpolated,
    /// ReprojectGI: the temporal accumulation (the interpolated irradiance passed through when
    /// `denoiser_temporal` is off).
    Temporal,
    /// FilterGI: the bilateral blur's second direction.
    Spatial,
}

impl DenoiserStage {
    /// The last stage that runs under `settings`: what the composite reads.
    pub fn last(settings: &GiSettings) -> Self {
        if settings.denoiser_spatial {
            Self::Spatial
        } else {
            Self::Temporal
        }
    }
}

crate::bindings! {
    /// InterpolateScreenProbes's set 0 (`kernels::screen_probes::interpolate::interpolate_screen_probes`).
    pub(crate) struct InterpolateScreenProbes<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        shading_normal: &'a Image,
        records: &'a Buffer,
        mask: &'a Buffer,
        sh: &'a Buffer,
        irradiance: &'a Buffer,
        counters: &'a Buffer,
        albedo: &'a Image,
        lighting: &'a Buffer,
        previous: &'a Buffer,
    }
}

crate::bindings! {
    /// ReprojectGI's set 0 (`kernels::gi_denoiser::reproject_gi::reproject_gi`).
    pub(crate) struct ReprojectGi<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        irradiance: &'a Buffer,
        previous_history: &'a Buffer,
        history: &'a Buffer,
        previous_surface: &'a Buffer,
        surface: &'a Buffer,
        previous_luma_delta: &'a Buffer,
        luma_delta: &'a Buffer,
        blur_mask: &'a Buffer,
        motion: &'a Image,
        previous_trend: &'a Buffer,
        trend: &'a Buffer,
    }
}

crate::bindings! {
    /// FilterBlurMask's set 0 (`kernels::gi_denoiser::blur_mask::filter_blur_mask`).
    pub(crate) struct FilterBlurMask<'a> {
        frame: &'a Buffer,
        mask: &'a Buffer,
        radius: &'a Buffer,
        counters: &'a Buffer,
    }
}

crate::bindings! {
    /// FilterGI's set 0 (`kernels::gi_denoiser::filter_gi::filter_gi`).
    pub(crate) struct FilterGi<'a> {
        frame: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        radius: &'a Buffer,
        input: &'a Buffer,
        output: &'a Buffer,
        history: &'a Buffer,
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
            interpolate: Kernel::new::<InterpolateScreenProbes>(
                ctx,
                module,
                "screen_probes::interpolate::interpolate_screen_probes",
                0,
            )?,
            reproject: Kernel::new::<ReprojectGi>(
                ctx,
                module,
                "gi_denoiser::reproject_gi::reproject_gi",
                0,
            )?,
            blur_mask: Kernel::new::<FilterBlurMask>(
                ctx,
                module,
                "gi_denoiser::blur_mask::filter_blur_mask",
                0,
            )?,
            filter: Kernel::new::<FilterGi>(ctx, module, "gi_denoiser::filter_gi::filter_gi", 4)?,
        })
    }

    /// InterpolateScreenProbes: each pixel's irradiance from up to four probes, with
    /// screen-space GI's near-field term from the previous frame's primary `lighting` and
    /// `last` stage's output.
    pub fn record_interpolate(
        &self,
        rec: &mut Recorder<'_>,
        probes: &ScreenProbeResources,
        res: &DenoiserResources,
        view: PrimaryView<'_>,
        lighting: &Buffer,
        last: DenoiserStage,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let g = gbuffer;
        rec.dispatch(
            &self.interpolate,
            &InterpolateScreenProbes {
                frame: &probes.frame,
                camera,
                depth: &g.depth,
                geometric_normal: &g.geometric_normal,
                shading_normal: &g.shading_normal,
                records: probes.records.current(),
                mask: probes.mask.current(),
                sh: &probes.sh,
                irradiance: &res.irradiance,
                counters: &probes.counters,
                albedo: &g.albedo,
                lighting,
                previous: res.previous_output(last),
            },
            &[],
            pixel_groups(gbuffer),
        )?;
        Ok(())
    }

    /// ReprojectGI: temporal accumulation of the irradiance and the blur mask.
    pub fn record_reproject(
        &self,
        rec: &mut Recorder<'_>,
        probes: &ScreenProbeResources,
        res: &DenoiserResources,
        view: PrimaryView<'_>,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let g = gbuffer;
        rec.fill(res.trend.current(), 0);
        rec.dispatch(
            &self.reproject,
            &ReprojectGi {
                frame: &probes.frame,
                camera,
                depth: &g.depth,
                geometric_normal: &g.geometric_normal,
                irradiance: &res.irradiance,
                previous_history: res.history.previous(),
                history: res.history.current(),
                previous_surface: res.surface.previous(),
                surface: res.surface.current(),
                previous_luma_delta: res.luma_delta.previous(),
                luma_delta: res.luma_delta.current(),
                blur_mask: &res.blur_mask,
                motion: &g.motion,
                previous_trend: res.trend.previous(),
                trend: res.trend.current(),
            },
            &[],
            pixel_groups(gbuffer),
        )?;
        Ok(())
    }

    /// FilterBlurMask, then FilterGI horizontal and vertical; `input` is the irradiance the
    /// blur starts from (the temporal history, or the interpolated irradiance without it).
    pub fn record_filter(
        &self,
        rec: &mut Recorder<'_>,
        probes: &ScreenProbeResources,
        res: &DenoiserResources,
        gbuffer: &GBufferImages,
        input: &Buffer,
    ) -> Result<()> {
        rec.dispatch(
            &self.blur_mask,
            &FilterBlurMask {
                frame: &probes.frame,
                mask: &res.blur_mask,
                radius: &res.blur_radius,
                counters: &probes.counters,
            },
            &[],
            pixel_groups(gbuffer),
        )?;
        let g = gbuffer;
        let steps = [
            (input, res.horizontal()),
            (res.horizontal(), res.output(DenoiserStage::Spatial)),
        ];
        for (direction, (from, to)) in steps.into_iter().enumerate() {
            rec.dispatch(
                &self.filter,
                &FilterGi {
                    frame: &probes.frame,
                    depth: &g.depth,
                    geometric_normal: &g.geometric_normal,
                    radius: &res.blur_radius,
                    input: from,
                    output: to,
                    history: res.history.current(),
                },
                &(direction as u32).to_le_bytes(),
                pixel_groups(gbuffer),
            )?;
        }
        Ok(())
    }
}
