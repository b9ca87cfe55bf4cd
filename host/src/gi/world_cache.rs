//! The world-space radiance cache as one unit the frames share: the cache passes that follow a
//! tracing pass (InsertRadianceCache, UpdateLightGrid, ClearReservoirs, GenerateReservoirs,
//! CompactReservoirs, ResampleReservoirs, PopulateRadianceCache, UpdateRadianceCache,
//! ResolveRadianceCache) and the push constants every cache pass reads. `gi cache-view` feeds the
//! cache with one ray per pixel, the GI frame with the screen probes' rays.

use super::hash_cells::HashCellPasses;
use super::lighting::LightingPasses;
use super::pass_inputs::{SceneLighting, ViewOptions};
use super::resources::{CacheResources, RestirResources};
use super::settings::GiSettings;
use crate::error::Result;
use crate::frame::Recorder;
use crate::scene::upload::GpuScene;
use crate::vulkan::{Context, KernelModule};
use gi_shared::camera::CameraParams;
use gi_shared::hash_cells::cell_size_const;
use gi_shared::hash_cells::layout::HashGridParams;
use gi_shared::world_cache::{
    CacheFrameParams, CachePassParams, FLAG_BYPASS, FLAG_ENVIRONMENT_LIGHT, FLAG_FEEDBACK,
    FLAG_HISTORY, FLAG_MULTI_BOUNCE, FLAG_RESTIR, FLAG_RESTIR_HISTORY, FLAG_SHORT_RAY,
};
use gi_shared::world_restir::reservoir_cell_const;

/// The cache passes' pipelines.
pub struct WorldCache {
    /// The hash grid's passes.
    pub hash_cells: HashCellPasses,
    /// Light grid, light sampling at secondary hits and world-space ReSTIR.
    pub lighting: LightingPasses,
}

/// The inputs of [`WorldCache::params`] that change per frame.
#[derive(Clone, Copy, Debug)]
pub struct CacheFrame<'a> {
    /// The frame's index.
    pub frame: u32,
    /// The frame's camera.
    pub camera: &'a CameraParams,
    /// The previous frame's camera (none on the first frame).
    pub previous: Option<&'a CameraParams>,
    /// The previous frame filled a reservoir grid.
    pub restir_history: bool,
    /// Extra `CacheFrameParams::flags`.
    pub extra_flags: u32,
}

impl WorldCache {
    /// Creates the pipelines, for reservoir grids of `restir_slots` slots.
    pub fn new(ctx: &Context, module: &KernelModule, restir_slots: u32) -> Result<Self> {
        Ok(Self {
            hash_cells: HashCellPasses::new(ctx, module)?,
            lighting: LightingPasses::new(ctx, module, restir_slots)?,
        })
    }

    /// The push constants of every cache pass of a `size` frame.
    pub fn params(
        settings: &GiSettings,
        options: &ViewOptions,
        lighting: &SceneLighting,
        restir: &RestirResources,
        size: [u32; 2],
        frame: CacheFrame<'_>,
    ) -> CachePassParams {
        let s = settings;
        let camera = frame.camera;
        let fov_y = 2.0 * camera.tan_half_fov_y.atan();
        let mut grid = HashGridParams::new(
            camera.position(),
            cell_size_const(fov_y, size[0], size[1], s.cell_size_pixels),
            frame.frame,
        );
        grid.min_cell_size = s.min_cell_size;
        grid.num_buckets_log2 = s.buckets_log2;
        grid.tiles_per_bucket_log2 = s.tiles_per_bucket_log2;
        grid.sample_cap = s.sample_cap;
        grid.history_frames = s.cache_history_frames;
        grid.adaptive_blend = u32::from(s.adaptive_cache_blend);
        let mut flags = frame.extra_flags;
        for (on, flag) in [
            (s.temporal_feedback, FLAG_FEEDBACK),
            (frame.previous.is_some(), FLAG_HISTORY),
            (s.short_ray_flag, FLAG_SHORT_RAY),
            (s.bypass, FLAG_BYPASS),
            (s.restir, FLAG_RESTIR),
            (s.restir && frame.restir_history, FLAG_RESTIR_HISTORY),
            (lighting.environment_light, FLAG_ENVIRONMENT_LIGHT),
            (s.multi_bounce, FLAG_MULTI_BOUNCE),
        ] {
            if on {
                flags |= flag;
            }
        }
        CachePassParams {
            grid,
            view: CacheFrameParams {
                sky: options.sky.to_array(),
                frame_index: frame.frame,
                emissive_multiplier: options.emissive_multiplier,
                light_count: lighting.light_count,
                seed: options.seed,
                flags,
                environment_size: lighting.environment_size,
                environment_irradiance: lighting.environment_irradiance,
                light_candidates: s.light_candidates,
                image_size: size,
                max_groups: 0,
                reservoir_cell_const: reservoir_cell_const(fov_y, size[0], size[1]),
                previous_eye: frame.previous.map_or(camera.position, |p| p.position),
                reservoir_buckets: restir.buckets,
            },
        }
    }

    /// Records the cache passes that complete the queries a tracing pass appended: from
    /// InsertRadianceCache to ResolveRadianceCache, which adds each query's cache radiance to
    /// its ray's record.
    pub fn record_after_trace(
        &self,
        rec: &mut Recorder<'_>,
        scene: &GpuScene,
        res: &CacheResources,
        restir: &RestirResources,
        settings: &GiSettings,
        params: &CachePassParams,
    ) -> Result<()> {
        let (hash_cells, lighting) = (&self.hash_cells, &self.lighting);
        rec.pass("InsertRadianceCache", |rec| {
            hash_cells.record_insert(rec, res, params)
        })?;
        rec.pass("UpdateLightGrid", |rec| {
            lighting.record_light_grid(rec, res, &scene.lights, params)
        })?;
        if settings.restir {
            rec.pass("ClearReservoirs", |rec| {
                lighting.record_clear_reservoirs(rec, restir);
                Ok(())
            })?;
        }
        rec.pass("GenerateReservoirs", |rec| {
            lighting.record_generate(rec, res, restir, &scene.lights, params)?;
            hash_cells.record_shadow_ray_args(rec, res)
        })?;
        if settings.restir {
            rec.pass("CompactReservoirs", |rec| {
                lighting.record_compact(rec, res, restir, params)
            })?;
            rec.pass("ResampleReservoirs", |rec| {
                lighting.record_resample(rec, res, restir, &scene.lights, params)
            })?;
        }
        rec.pass("PopulateRadianceCache", |rec| {
            hash_cells.record_populate(
                rec,
                scene.sets(),
                res,
                &restir.grids.current().reservoirs,
                &scene.lights,
                params,
            )
        })?;
        rec.pass("UpdateRadianceCache", |rec| {
            hash_cells.record_update(rec, res, params)
        })?;
        rec.pass("ResolveRadianceCache", |rec| {
            hash_cells.record_resolve(rec, res, params)
        })
    }
}
