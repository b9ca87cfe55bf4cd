//! The whole GI-1.0 frame: [`GiRenderer`] owns every resource and pipeline and records, into one
//! submission per frame, in the talk's order and under its pass names:
//!
//! PurgeRadianceCache, GBuffer, ReprojectScreenProbes, SpawnScreenProbes, PatchScreenProbes,
//! SampleScreenProbes, PopulateScreenProbes, the world cache's passes (InsertRadianceCache ...
//! ResolveRadianceCache, `world_cache`), BlendScreenProbes, FilterProbeMask,
//! FilterScreenProbes, ProjectScreenProbes, InterpolateScreenProbes, DirectLight, ReprojectGI,
//! FilterBlurMask + FilterGI, ResolveGI.
//!
//! Switched-off techniques skip their pass where one exists (patching, the probe filter, the
//! spatial denoiser) and are flags the kernels read otherwise (`GiFrameParams::flags`).

use super::gi_denoiser::{DenoiserPasses, DenoiserResources, DenoiserStage};
use super::pass_inputs::{PrimaryView, SceneLighting, ViewOptions, check_image_size};
use super::primary_lighting::{PrimaryPasses, PrimaryResources};
use super::resources::{CacheResources, Occupancy, RestirResources};
use super::screen_probes::{ProbeLayout, ScreenProbePasses, ScreenProbeResources, technique_flags};
use super::settings::GiSettings;
use super::world_cache::{CacheFrame, WorldCache};
use crate::engine::{FrameInputs, FrameOutputs, GBufferSource, OutputImage};
use crate::error::Result;
use crate::frame::{BarrierCounts, FloatWords, FrameTimer, PassUses, Recorder};
use crate::gbuffer::{GBufferImages, GBufferKernel};
use crate::image_io::HdrImage;
use crate::scene::lights::LightSet;
use crate::scene::upload::GpuScene;
use crate::vulkan::{Buffer, Context, FrameTimings, Image, KernelModule};
use ash::vk;
use gi_shared::camera::CameraParams;
use gi_shared::gi_denoiser::reproject_gi::SURFACE_RECORD_FLOAT_WORDS;
use gi_shared::hash_cells::cell_size_const;
use gi_shared::primary_lighting::samples_direct_light;
use gi_shared::screen_probes::{
    BLUR_TAPS, EMPTY_COUNT, FLAG_HISTORY, FLAG_SAMPLED_DIRECT, GiFrameParams, OVERRIDE_COUNT,
    PATCHED_COUNT, PROBE_CELL_PIXELS, ProbeRay, ProbeRecord, RELAXED_COUNT, REPROJECTED_COUNT,
    SPAWN_COUNT,
};
use gi_shared::world_cache::{CachePassParams, FLAG_EMITTERS_SAMPLED, FLAG_PROBE_RAYS};

/// Timestamp spans per frame: one per pass.
const PASSES_PER_FRAME: u32 = 32;

/// Frames `gi render --method gi` renders by default: the denoiser's history reaches its cap
/// of 64 frames in the image's centre, and the cache's cells their 16 samples, well before.
pub const DEFAULT_GI_FRAMES: u32 = 64;

/// What a frame did, read back after it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GiFrameStats {
    /// The world cache's occupancy and work.
    pub cache: Occupancy,
    /// Probes traced this frame.
    pub spawned: u32,
    /// Probe tiles that kept a reprojected probe.
    pub reprojected: u32,
    /// Disoccluded tiles without a probe or a spawn.
    pub empty: u32,
    /// Spawns over tiles that still held a probe.
    pub overrides: u32,
    /// Empty tiles patched.
    pub patched: u32,
    /// Pixels interpolated with the relaxed fallback.
    pub relaxed: u32,
    /// Taps of the denoiser's spatial filter.
    pub blur_taps: u32,
}

/// The GI frame: resources, pipelines and the frame loop.
pub struct GiRenderer {
    settings: GiSettings,
    options: ViewOptions,
    width: u32,
    height: u32,
    cache_res: CacheResources,
    restir: RestirResources,
    restir_history: bool,
    gbuffer: GBufferImages,
    gbuffer_kernel: GBufferKernel,
    cache: WorldCache,
    /// The reservoir-grid slots `cache`'s pipelines were made for (at least `restir.slots`).
    cache_slots: u32,
    probes: ScreenProbeResources,
    probe_passes: ScreenProbePasses,
    denoiser: DenoiserResources,
    denoiser_passes: DenoiserPasses,
    primary: PrimaryResources,
    primary_passes: PrimaryPasses,
    lighting: SceneLighting,
    frames: FrameTimer,
    frame: u32,
    previous: Option<CameraParams>,
    last: Option<(CameraParams, CachePassParams, GiFrameParams)>,
}

impl GiRenderer {
    /// Creates the frame of a `width × height` image of a scene lit by `lights`, with
    /// `settings` (an error names a bad one).
    pub fn new(
        ctx: &Context,
        lights: &LightSet,
        width: u32,
        height: u32,
        settings: GiSettings,
        options: ViewOptions,
    ) -> Result<Self> {
        settings.validate(width, height)?;
        options.validate()?;
        let layout = ProbeLayout::new(width, height, settings.spawn_rate.tile());
        let rays = layout.ray_capacity();
        let pixels = width as usize * height as usize;
        let module = KernelModule::new(ctx)?;
        let restir = RestirResources::new(ctx, &settings, rays)?;
        let made = (|| -> Result<_> {
            Ok((
                GBufferKernel::new(ctx, &module)?,
                WorldCache::new(ctx, &module, restir.slots)?,
                ScreenProbePasses::new(ctx, &module)?,
                DenoiserPasses::new(ctx, &module)?,
                PrimaryPasses::new(ctx, &module)?,
            ))
        })();
        drop(module);
        let (gbuffer_kernel, cache, probe_passes, denoiser_passes, primary_passes) = made?;
        let (denoiser, primary) =
            per_pixel_resources(ctx, &settings, pixels, settings.temporal_feedback)?;
        let cache_slots = restir.slots;
        Ok(Self {
            settings,
            options,
            width,
            height,
            cache_res: CacheResources::new(
                ctx,
                &settings,
                width,
                height,
                rays,
                0,
                lights.params().count,
            )?,
            restir,
            restir_history: false,
            gbuffer: GBufferImages::new(ctx, width, height)?,
            gbuffer_kernel,
            cache,
            cache_slots,
            probes: ScreenProbeResources::new(ctx, layout, settings.probe_filter, pixels)?,
            probe_passes,
            denoiser,
            denoiser_passes,
            primary,
            primary_passes,
            lighting: SceneLighting::new(lights),
            frames: FrameTimer::new(ctx, PASSES_PER_FRAME),
            frame: 0,
            previous: None,
            last: None,
        })
    }

    /// The settings.
    pub fn settings(&self) -> &GiSettings {
        &self.settings
    }

    /// GPU time per pass, per frame and averaged.
    pub fn timings(&self) -> &FrameTimings {
        self.frames.timings()
    }

    /// Keeps, from the next [`GiRenderer::render_frame`] on, what each pass read and wrote
    /// ([`GiRenderer::pass_uses`]).
    pub fn log_passes(&mut self, on: bool) {
        self.frames.log_passes(on);
    }

    /// The barriers the last [`GiRenderer::render_frame`] recorded ([`Recorder`] placed them).
    pub fn barrier_counts(&self) -> BarrierCounts {
        self.frames.barrier_counts()
    }

    /// What each pass of the last [`GiRenderer::render_frame`] read and wrote, in order (empty
    /// unless [`GiRenderer::log_passes`] is on): the pass table of `docs/integration.md`.
    pub fn pass_uses(&self) -> &[PassUses] {
        self.frames.pass_uses()
    }

    /// Frames rendered.
    pub fn frames(&self) -> u32 {
        self.frame
    }

    /// The screen probes' resources (debug views, tests).
    pub fn probes(&self) -> &ScreenProbeResources {
        &self.probes
    }

    /// The denoiser's resources (debug views, tests).
    pub fn denoiser(&self) -> &DenoiserResources {
        &self.denoiser
    }

    /// Keeps the interpolated irradiance through the frame, so that
    /// [`DenoiserResources::irradiance`] still holds it after [`GiRenderer::render_frame`] (the
    /// debug views show it): FilterGI's horizontal output and the GI image then get buffers of
    /// their own, 32 bytes per pixel more ([`DenoiserResources::new`]). Call it before the first
    /// frame: the screen-space history starts over.
    pub fn keep_interpolated_irradiance(&mut self, ctx: &Context) -> Result<()> {
        if self.denoiser.keeps_interpolated() {
            return Ok(());
        }
        let pixels = self.width as usize * self.height as usize;
        (self.denoiser, self.primary) = per_pixel_resources(ctx, &self.settings, pixels, true)?;
        self.previous = None;
        self.last = None;
        Ok(())
    }

    /// The primary hit's lighting and the output image (tests).
    pub fn primary(&self) -> &PrimaryResources {
        &self.primary
    }

    /// World-space ReSTIR's resources (tests).
    pub fn restir_resources(&self) -> &RestirResources {
        &self.restir
    }

    /// The world cache's resources (debug views, tests).
    pub fn cache_resources(&self) -> &CacheResources {
        &self.cache_res
    }

    /// The G-buffer of the last frame.
    pub fn gbuffer(&self) -> &GBufferImages {
        &self.gbuffer
    }

    /// The last frame's camera and parameters, after a frame.
    pub fn last_frame(&self) -> Option<&(CameraParams, CachePassParams, GiFrameParams)> {
        self.last.as_ref()
    }

    /// The frame parameters of this frame seen by `camera`, after `previous`.
    fn frame_params(
        &self,
        camera: &CameraParams,
        previous: Option<&CameraParams>,
    ) -> GiFrameParams {
        let layout = self.probes.layout;
        let fov_y = 2.0 * camera.tan_half_fov_y.atan();
        let mut flags = technique_flags(&self.settings);
        if previous.is_some() {
            flags |= FLAG_HISTORY;
        }
        if samples_direct_light(self.lighting.punctual_count) {
            flags |= FLAG_SAMPLED_DIRECT;
        }
        GiFrameParams {
            image_size: [self.width, self.height],
            probe_grid: layout.probe_grid,
            spawn_grid: layout.spawn_grid,
            spawn_tile: layout.spawn_tile,
            frame_index: self.frame,
            flags,
            seed: self.options.seed,
            probe_cell_const: cell_size_const(fov_y, self.width, self.height, PROBE_CELL_PIXELS),
            mask_mips: layout.mask_mips,
            probe_count: layout.probe_count(),
            spawn_capacity: layout.spawn_capacity(),
            punctual_count: self.lighting.punctual_count,
            max_groups: 0,
            eye: camera.position,
            emissive_multiplier: self.options.emissive_multiplier,
            previous_eye: previous.map_or(camera.position, |p| p.position),
            light_candidates: self.settings.light_candidates,
            sky: self.options.sky.to_array(),
            light_count: self.lighting.light_count,
            environment_size: self.lighting.environment_size,
            interpolation_jitter: self.settings.interpolation_jitter_pixels(),
            occlusion_radius: self.settings.occlusion_radius,
        }
    }

    /// Renders one frame of `scene` seen by `camera` (its image size must be the renderer's):
    /// [`GiRenderer::record`]s it into a command buffer of the context, submits it, waits, and
    /// reads back the frame's counters and pass timings.
    pub fn render_frame(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        camera: &CameraParams,
    ) -> Result<GiFrameStats> {
        let inputs = FrameInputs::new(*camera);
        let mut frames = std::mem::take(&mut self.frames);
        let recorded = frames.submit(ctx, |rec| {
            self.record_frame(rec, scene, &inputs, &FrameOutputs::default())
        });
        self.frames = frames;
        recorded?;
        self.stats(ctx, self.frame.wrapping_sub(1))
    }

    /// Records one frame into the engine's `cmd` (begun, on the context's device and queue
    /// family), with no submission and no wait: every pass in the [module](self)'s order, then
    /// copies of the image and the irradiance into `outputs` (see [`OutputImage`] for formats,
    /// layouts and access masks). `inputs.scene_update`, if any, is applied to `scene` first,
    /// with one submission that waits ([`FrameInputs::scene_update`]).
    ///
    /// Per-frame parameters are written inside `cmd` (`vkCmdUpdateBuffer`), so earlier frames
    /// may still be in flight; the frame starts with a barrier on the compute and transfer work
    /// before it on the queue (earlier frames, and the engine's writes of the G-buffer for
    /// [`GBufferSource::Written`]). `scene`, the renderer and the output images must live until
    /// the command buffer finished. Counters and pass timings are not read on this path
    /// ([`GiRenderer::frame_stats`] reads the counters of the last finished frame).
    ///
    /// Errors, recording nothing, when the camera's or an output's size is not the renderer's,
    /// or an output's format or layout is not one accepted.
    pub fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        scene: &mut GpuScene,
        inputs: &FrameInputs,
        outputs: &FrameOutputs,
    ) -> Result<()> {
        self.check_frame(inputs, outputs)?;
        if let Some(update) = &inputs.scene_update {
            scene.set_pose(ctx, update.scene, update.lights, update.previous_transforms)?;
            // A pose that only changed the host-visible previous transforms submitted nothing:
            // wait for the frames in flight that read them.
            ctx.submit(|_| ())?;
        }
        let mut rec = Recorder::new(ctx, cmd, None);
        rec.begin();
        self.record_frame(&mut rec, scene, inputs, outputs)?;
        rec.finish();
        Ok(())
    }

    /// The counters of the last frame (spawned probes, cache occupancy, ...), read back with one
    /// submission that waits: after [`GiRenderer::record`], once that frame's command buffer
    /// finished.
    pub fn frame_stats(&self, ctx: &Context) -> Result<GiFrameStats> {
        self.stats(ctx, self.frame.wrapping_sub(1))
    }

    /// Changes the frame's size to `width × height`, keeping the pipelines and the world cache
    /// (hash grid, light grid): only the resolution-sized resources are made again (G-buffer,
    /// screen probes, denoiser, the image, per-ray buffers), and the screen-space history starts
    /// over. The reservoir-grid pipelines are made again only when world-space ReSTIR's grid
    /// grows. No frame may be in flight. On an error the renderer is unchanged.
    pub fn resize(&mut self, ctx: &Context, width: u32, height: u32) -> Result<()> {
        self.settings.validate(width, height)?;
        let layout = ProbeLayout::new(width, height, self.settings.spawn_rate.tile());
        let rays = layout.ray_capacity();
        let pixels = width as usize * height as usize;
        let restir = RestirResources::new(ctx, &self.settings, rays)?;
        let cache = match restir.slots > self.cache_slots {
            true => Some(WorldCache::new(
                ctx,
                &KernelModule::new(ctx)?,
                restir.slots,
            )?),
            false => None,
        };
        let gbuffer = GBufferImages::new(ctx, width, height)?;
        let probes = ScreenProbeResources::new(ctx, layout, self.settings.probe_filter, pixels)?;
        let keep = self.denoiser.keeps_interpolated();
        let (denoiser, primary) = per_pixel_resources(ctx, &self.settings, pixels, keep)?;
        self.cache_res.resize(ctx, width, height, rays)?;
        if let Some(cache) = cache {
            self.cache = cache;
            self.cache_slots = restir.slots;
        }
        (self.width, self.height) = (width, height);
        self.restir = restir;
        self.gbuffer = gbuffer;
        self.probes = probes;
        self.denoiser = denoiser;
        self.primary = primary;
        self.restir_history = false;
        self.previous = None;
        self.last = None;
        Ok(())
    }

    /// Renders another scene from the next frame on (pass its [`GpuScene`] to the next
    /// [`GiRenderer::record`]), lit by `lights` (made from it), without rebuilding the
    /// renderer: the screen-space history and world-space ReSTIR's reservoirs start over. With
    /// `reset_cache` the world cache is emptied too; without, the old scene's cells stay until
    /// they are evicted or their running averages take in the new scene's light (where the two
    /// scenes overlap in space, its light lingers). No frame may be in flight.
    pub fn change_scene(
        &mut self,
        ctx: &Context,
        lights: &LightSet,
        reset_cache: bool,
    ) -> Result<()> {
        if reset_cache {
            let rays = self.cache_res.ray_capacity();
            self.cache_res = CacheResources::new(
                ctx,
                &self.settings,
                self.width,
                self.height,
                rays,
                self.frame,
                lights.params().count,
            )?;
        }
        self.cache_res.fit_light_grid(ctx, lights.params().count)?;
        self.lighting = SceneLighting::new(lights);
        self.restir_history = false;
        self.previous = None;
        Ok(())
    }

    /// An error unless the camera and `outputs` fit the renderer.
    fn check_frame(&self, inputs: &FrameInputs, outputs: &FrameOutputs) -> Result<()> {
        check_image_size(&inputs.camera, self.width, self.height)?;
        if let Some(image) = &outputs.image {
            image.check("output image", self.width, self.height)?;
        }
        if let Some(image) = &outputs.irradiance {
            image.check("irradiance image", self.width, self.height)?;
        }
        Ok(())
    }

    /// The frame counters after frame `frame`.
    fn stats(&self, ctx: &Context, frame: u32) -> Result<GiFrameStats> {
        let c: Vec<u32> = self.probes.counters.read_back(ctx)?;
        Ok(GiFrameStats {
            cache: self.cache_res.occupancy(ctx, frame)?,
            spawned: c[SPAWN_COUNT],
            reprojected: c[REPROJECTED_COUNT],
            empty: c[EMPTY_COUNT],
            overrides: c[OVERRIDE_COUNT],
            patched: c[PATCHED_COUNT],
            relaxed: c[RELAXED_COUNT],
            blur_taps: c[BLUR_TAPS],
        })
    }

    /// Records a frame (see [`GiRenderer::record`]) and moves the renderer's state on to the
    /// next one.
    fn record_frame(
        &mut self,
        rec: &mut Recorder<'_>,
        scene: &GpuScene,
        inputs: &FrameInputs,
        outputs: &FrameOutputs,
    ) -> Result<()> {
        self.check_frame(inputs, outputs)?;
        if inputs.camera_cut {
            self.previous = None;
        }
        let previous = inputs.previous_camera.or(self.previous);
        let mut frame_camera = inputs.camera;
        frame_camera.jitter = [0.0; 2];
        if let Some(p) = &previous {
            frame_camera.previous_view_proj = p.view_proj;
        }
        let mut params = WorldCache::params(
            &self.settings,
            &self.options,
            &self.lighting,
            &self.restir,
            [self.width, self.height],
            CacheFrame {
                frame: self.frame,
                camera: &frame_camera,
                previous: previous.as_ref(),
                restir_history: self.restir_history,
                extra_flags: if self.settings.emitter_sampling {
                    FLAG_PROBE_RAYS | FLAG_EMITTERS_SAMPLED
                } else {
                    FLAG_PROBE_RAYS
                },
            },
        );
        let max_groups = rec.ctx().capabilities().max_workgroup_count[0];
        params.view.max_groups = max_groups;
        let mut frame_params = self.frame_params(&frame_camera, previous.as_ref());
        frame_params.max_groups = max_groups;
        self.probes.swap();
        self.denoiser.swap();
        rec.update(&self.cache_res.camera, 0, bytemuck::bytes_of(&frame_camera));
        rec.update(&self.probes.frame, 0, bytemuck::bytes_of(&frame_params));
        self.record_passes(rec, scene, &params, inputs.gbuffer)?;
        let irradiance = self.denoiser.output(DenoiserStage::last(&self.settings));
        for (buffer, image) in [
            (self.primary.color(&self.denoiser), &outputs.image),
            (irradiance, &outputs.irradiance),
        ] {
            if let Some(image) = image {
                record_copy_to_image(rec, buffer, image);
            }
        }
        self.last = Some((frame_camera, params, frame_params));
        if self.settings.restir {
            self.restir.grids.swap();
        }
        self.restir_history = self.settings.restir;
        self.previous = Some(inputs.camera);
        self.frame = self.frame.wrapping_add(1);
        Ok(())
    }

    /// Records every pass of a frame (see the [module](self)).
    fn record_passes(
        &self,
        rec: &mut Recorder<'_>,
        scene: &GpuScene,
        params: &CachePassParams,
        gbuffer_source: GBufferSource,
    ) -> Result<()> {
        let s = &self.settings;
        let (cache, probes, denoiser, primary) =
            (&self.cache_res, &self.probes, &self.denoiser, &self.primary);
        let (pp, dp) = (&self.probe_passes, &self.denoiser_passes);
        let camera = &cache.camera;
        let gbuffer = &self.gbuffer;
        let view = PrimaryView { camera, gbuffer };
        rec.fill(&probes.counters, 0);
        rec.pass("PurgeRadianceCache", |rec| {
            self.cache.hash_cells.record_purge(rec, cache, params)
        })?;
        if gbuffer_source == GBufferSource::Traced {
            self.gbuffer_kernel.record(rec, scene, camera, gbuffer)?;
        }
        rec.pass("ReprojectScreenProbes", |rec| {
            pp.record_reproject(rec, probes, view)
        })?;
        rec.pass("SpawnScreenProbes", |rec| {
            pp.record_spawn(rec, probes, view)
        })?;
        if s.patching {
            rec.pass("PatchScreenProbes", |rec| {
                pp.record_patch(rec, probes, view)
            })?;
        }
        rec.pass("SampleScreenProbes", |rec| {
            pp.record_sample(rec, probes, view)
        })?;
        rec.pass("PopulateScreenProbes", |rec| {
            pp.record_populate(rec, scene.sets(), probes, cache, view, params)
        })?;
        self.cache
            .record_after_trace(rec, scene, cache, &self.restir, s, params)?;
        rec.pass("BlendScreenProbes", |rec| {
            pp.record_blend(rec, probes, cache, view)
        })?;
        rec.pass("FilterProbeMask", |rec| pp.record_probe_mask(rec, probes))?;
        if s.probe_filter {
            let horizontal = probes.filter_output(&denoiser.irradiance);
            rec.pass("FilterScreenProbes", |rec| {
                pp.record_filter(rec, probes, horizontal)
            })?;
        }
        rec.pass("ProjectScreenProbes", |rec| {
            pp.record_project(rec, probes, probes.projected_cells(s.probe_filter))
        })?;
        rec.pass("InterpolateScreenProbes", |rec| {
            dp.record_interpolate(
                rec,
                probes,
                denoiser,
                view,
                &primary.primary,
                DenoiserStage::last(s),
            )
        })?;
        rec.pass("DirectLight", |rec| {
            self.primary_passes.record_direct(
                rec,
                scene,
                probes,
                primary,
                view,
                denoiser.output(DenoiserStage::Interpolated),
            )
        })?;
        rec.pass("ReprojectGI", |rec| {
            dp.record_reproject(rec, probes, denoiser, view)
        })?;
        let temporal_out = denoiser.output(DenoiserStage::Temporal);
        if s.denoiser_spatial {
            rec.pass("FilterGI", |rec| {
                dp.record_filter(rec, probes, denoiser, gbuffer, temporal_out)
            })?;
        }
        let irradiance = denoiser.output(DenoiserStage::last(s));
        rec.pass("ResolveGI", |rec| {
            self.primary_passes.record_resolve(
                rec,
                primary,
                view,
                irradiance,
                primary.color(denoiser),
                &cache.history,
                denoiser.undenoised(),
            )
        })
    }

    /// Every buffer of the frame that holds floats, with which of its words are floats: what
    /// [`FiniteCheck`](crate::frame::FiniteCheck) reads to prove a frame clean. Parameters the
    /// host writes, counters, keys, lists and packed integers (the probe cells,
    /// [`gi_shared::screen_probes::StoredCell`]; the primary lighting,
    /// [`gi_shared::primary_lighting::PrimaryLighting`]) are left out.
    pub fn float_buffers(&self) -> Result<Vec<(&Buffer, FloatWords)>> {
        let all = FloatWords::ALL;
        let (p, d) = (&self.probes, &self.denoiser);
        let probe_record = FloatWords::of::<ProbeRecord>()?;
        let probe_ray = FloatWords::of::<ProbeRay>()?;
        let surface = FloatWords::new(4, SURFACE_RECORD_FLOAT_WORDS)?;
        let mut buffers = vec![
            (p.records.current(), probe_record),
            (p.records.previous(), probe_record),
            (&p.rays, probe_ray),
            (&p.sh, all),
            (&d.irradiance, all),
            (d.history.current(), all),
            (d.history.previous(), all),
            (d.surface.current(), surface),
            (d.surface.previous(), surface),
            (d.luma_delta.current(), all),
            (d.luma_delta.previous(), all),
            (&d.blur_mask, all),
            (&d.blur_radius, all),
            (&d.filtered, all),
        ];
        if let Some(color) = &self.primary.own_color {
            buffers.push((color, all));
        }
        buffers.extend(self.cache_res.float_buffers()?);
        buffers.extend(self.restir.float_buffers()?);
        Ok(buffers)
    }

    /// The images of the frame with 32-bit float texels (the G-buffer's depth and motion), for
    /// [`FiniteCheck::count_images`](crate::frame::FiniteCheck::count_images). The half-float
    /// G-buffer images (normals, emission) are not among them: the check reads 32-bit floats.
    pub fn float_images(&self) -> Vec<&Image> {
        self.gbuffer
            .all()
            .into_iter()
            .filter(|i| {
                matches!(
                    i.format,
                    vk::Format::R32_SFLOAT | vk::Format::R32G32B32A32_SFLOAT
                )
            })
            .collect()
    }

    /// The last frame's image (linear HDR).
    pub fn image(&self, ctx: &Context) -> Result<HdrImage> {
        let color: Vec<[f32; 4]> = self.primary.color(&self.denoiser).read_back(ctx)?;
        HdrImage::from_pixels(
            self.width,
            self.height,
            color.iter().map(|c| [c[0], c[1], c[2]]).collect(),
        )
    }
}

/// The denoiser's buffers and the composite's of a `pixels`-pixel frame, sharing the per-pixel
/// scratch unless `keep_interpolated` ([`DenoiserResources::new`]).
fn per_pixel_resources(
    ctx: &Context,
    settings: &GiSettings,
    pixels: usize,
    keep_interpolated: bool,
) -> Result<(DenoiserResources, PrimaryResources)> {
    let denoiser =
        DenoiserResources::new(ctx, pixels, settings.denoiser_spatial, keep_interpolated)?;
    let primary = PrimaryResources::new(ctx, pixels, &denoiser)?;
    Ok((denoiser, primary))
}

/// Records a copy of `buffer` (`[f32; 4]` texels, row after row) into the engine's `image`
/// (checked by [`OutputImage::check`]), after the compute writes before it.
fn record_copy_to_image(rec: &mut Recorder<'_>, buffer: &Buffer, image: &OutputImage) {
    let region = [vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D {
            width: image.width,
            height: image.height,
            depth: 1,
        })];
    rec.copy_to_image(buffer, image.image, image.layout, &region);
}
