//! `gi cache-view`: the hash-grid radiance cache on its own (`gi_shared::cache_view` describes
//! the frame). [`CacheView`] owns the frame's resources and pipelines and records every pass of
//! a frame, in the talk's order and under its pass names, into one submission:
//!
//! PurgeRadianceCache, GBuffer, TraceCacheRays, InsertRadianceCache, UpdateLightGrid,
//! (ClearReservoirs,) GenerateReservoirs, (CompactReservoirs, ResampleReservoirs,)
//! PopulateRadianceCache, UpdateRadianceCache, ResolveRadianceCache, CacheViewComposite; the
//! parenthesised passes run with world-space ReSTIR on.
//!
//! Each frame jitters the camera inside the pixel (Halton 2, 3), so that the running mean filters
//! the pixel like the path tracer does; moving the camera restarts the mean. The cache's state
//! and the frame's query batch can be read back ([`CacheView::read_back_state`],
//! [`CacheView::read_back_queries`]) and a recorded batch replayed through the cache's passes
//! alone ([`CacheView::replay_queries`]).

use super::debug_views::{DebugView, debug_views};
use super::pass_inputs::{PUSH_BYTES, SceneLighting, ViewOptions, check_image_size};
use super::resources::{CacheResources, Occupancy, RestirResources};
use super::settings::GiSettings;
use super::world_cache::{CacheFrame, WorldCache};
use crate::error::{Error, Result};
use crate::frame::{FrameTimer, Recorder};
use crate::gbuffer::{GBufferImages, GBufferKernel};
use crate::image_io::HdrImage;
use crate::scene::lights::LightSet;
use crate::scene::upload::GpuScene;
use crate::vulkan::{Buffer, Context, FrameTimings, Image, Kernel, KernelModule};
use ash::vk;
use gi_shared::cache_view::{CACHE_VIEW_TILE, running_mean};
use gi_shared::camera::CameraParams;
use gi_shared::hash_cells::layout::HashCellValue;
use gi_shared::random::halton23;
use gi_shared::world_cache::{CachePassParams, CacheQuery, QUERY_COUNT};
use glam::Vec2;

/// Timestamp spans per frame: one per pass.
const PASSES_PER_FRAME: u32 = 16;

/// The hash grid's whole state on the host.
#[derive(Clone, Debug, PartialEq)]
pub struct CacheState {
    /// One checksum per tile slot (0 = empty).
    pub keys: Vec<u32>,
    /// The frame each tile was last touched.
    pub last_touch: Vec<u32>,
    /// 85 values per tile.
    pub values: Vec<HashCellValue>,
    /// The per-frame accumulators (zero after UpdateRadianceCache).
    pub accumulators: Vec<u32>,
    /// Counters and tile lists (`gi_shared::hash_cells::lists`).
    pub lists: Vec<u32>,
    /// The cache view's counters (`gi_shared::world_cache::QUERY_COUNT` ...).
    pub counters: Vec<u32>,
}

crate::bindings! {
    /// TraceCacheRays's set 0 (`kernels::cache_view::trace_cache_rays`).
    pub(crate) struct TraceCacheRays<'a> {
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        shading_normal: &'a Image,
        albedo: &'a Image,
        emissive: &'a Image,
        ids: &'a Image,
        pixels: &'a Buffer,
        queries: &'a Buffer,
        counters: &'a Buffer,
        bounds: &'a Buffer,
    }
}

crate::bindings! {
    /// The cache view composite's set 0 (`kernels::cache_view::composite`).
    pub(crate) struct CacheViewComposite<'a> {
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        albedo: &'a Image,
        pixels: &'a Buffer,
        accumulation: &'a Buffer,
        history: &'a Buffer,
    }
}

/// The cache view: resources, pipelines and the frame loop.
pub struct CacheView {
    settings: GiSettings,
    options: ViewOptions,
    width: u32,
    height: u32,
    res: CacheResources,
    /// The running sums of the frames since the last restart (`[r, g, b, count]` per pixel):
    /// the cache view's alone, so the GI frame, which shares [`CacheResources`], has none.
    accumulation: Buffer,
    restir: RestirResources,
    /// Whether the previous frame filled a reservoir grid.
    restir_history: bool,
    gbuffer: GBufferImages,
    gbuffer_kernel: GBufferKernel,
    trace: Kernel,
    composite: Kernel,
    cache: WorldCache,
    frames: FrameTimer,
    /// The next frame's index.
    frame: u32,
    /// Frames since the running mean restarted.
    accumulated: u32,
    previous: Option<CameraParams>,
    /// The last frame's jittered camera and parameters (for the debug views).
    last_frame: Option<(CameraParams, CachePassParams)>,
    lighting: SceneLighting,
}

impl CacheView {
    /// Creates the view of a `width × height` frame of `scene` (uploaded from `lights`), with
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
        let module = KernelModule::new(ctx)?;
        let restir = RestirResources::new(ctx, &settings, width * height)?;
        let made = (|| -> Result<_> {
            Ok((
                GBufferKernel::new(ctx, &module)?,
                Kernel::new::<TraceCacheRays>(
                    ctx,
                    &module,
                    "cache_view::trace_cache_rays",
                    PUSH_BYTES,
                )?,
                Kernel::new::<CacheViewComposite>(ctx, &module, "cache_view::composite", 0)?,
                WorldCache::new(ctx, &module, restir.slots)?,
            ))
        })();
        drop(module);
        let (gbuffer_kernel, trace, composite, cache) = made?;
        Ok(Self {
            settings,
            options,
            width,
            height,
            res: CacheResources::new(
                ctx,
                &settings,
                width,
                height,
                width * height,
                0,
                lights.params().count,
            )?,
            accumulation: Buffer::device_zeroed::<[f32; 4]>(
                ctx,
                "cache-view accumulation",
                width as usize * height as usize,
            )?,
            restir,
            restir_history: false,
            gbuffer: GBufferImages::new(ctx, width, height)?,
            gbuffer_kernel,
            trace,
            composite,
            cache,
            frames: FrameTimer::new(ctx, PASSES_PER_FRAME),
            frame: 0,
            accumulated: 0,
            previous: None,
            last_frame: None,
            lighting: SceneLighting::new(lights),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &GiSettings {
        &self.settings
    }

    /// The frame's resources (for tests that drive passes themselves).
    pub fn resources(&self) -> &CacheResources {
        &self.res
    }

    /// World-space ReSTIR's resources (one-element placeholders when it is off), for tests that
    /// check them.
    pub fn restir_resources(&self) -> &RestirResources {
        &self.restir
    }

    /// GPU time per pass, per frame and averaged.
    pub fn timings(&self) -> &FrameTimings {
        self.frames.timings()
    }

    /// Frames in the running mean.
    pub fn accumulated_frames(&self) -> u32 {
        self.accumulated
    }

    /// The camera of frame `frame`: `camera` jittered inside the pixel, with the previous frame's
    /// view-projection for motion and reprojection.
    fn frame_camera(&self, camera: &CameraParams) -> CameraParams {
        let mut c = *camera;
        c.jitter = (halton23((self.frame & 0xff) + 1) - Vec2::splat(0.5)).to_array();
        // The running mean integrates the pixel: a prefiltered texture would blur it twice.
        c.texture_footprint = 0.0;
        if let Some(p) = &self.previous {
            c.previous_view_proj = p.view_proj;
        }
        c
    }

    /// The push constants of frame `frame` seen by `camera`.
    pub fn params(&self, camera: &CameraParams) -> CachePassParams {
        WorldCache::params(
            &self.settings,
            &self.options,
            &self.lighting,
            &self.restir,
            [self.width, self.height],
            CacheFrame {
                frame: self.frame,
                camera,
                previous: self.previous.as_ref(),
                restir_history: self.restir_history,
                extra_flags: 0,
            },
        )
    }

    /// Renders one frame of `scene` seen by `camera` (its image size must be the view's) and
    /// returns the cache's occupancy after it. A camera that differs from the previous frame's
    /// restarts the running mean.
    pub fn render_frame(
        &mut self,
        ctx: &Context,
        scene: &GpuScene,
        camera: &CameraParams,
    ) -> Result<Occupancy> {
        check_image_size(camera, self.width, self.height)?;
        let moved = self
            .previous
            .is_some_and(|p| p.view_proj != camera.view_proj || p.position != camera.position);
        if moved {
            self.accumulated = 0;
        }
        let frame_camera = self.frame_camera(camera);
        let mut params = self.params(&frame_camera);
        params.view.max_groups = ctx.capabilities().max_workgroup_count[0];
        self.res.camera.write(bytemuck::bytes_of(&frame_camera))?;
        let restart = self.accumulated == 0;
        let mut frames = std::mem::take(&mut self.frames);
        let recorded = frames.submit(ctx, |rec| self.record_frame(rec, scene, &params, restart));
        self.frames = frames;
        recorded?;
        let occupancy = self.res.occupancy(ctx, self.frame)?;
        self.last_frame = Some((frame_camera, params));
        if self.settings.restir {
            self.restir.grids.swap();
        }
        self.restir_history = self.settings.restir;
        self.previous = Some(*camera);
        self.frame = self.frame.wrapping_add(1);
        self.accumulated += 1;
        Ok(occupancy)
    }

    /// Records every pass of a frame (see the [module](self)).
    fn record_frame(
        &self,
        rec: &mut Recorder<'_>,
        scene: &GpuScene,
        params: &CachePassParams,
        restart: bool,
    ) -> Result<()> {
        if restart {
            rec.fill(&self.accumulation, 0);
        }
        let res = &self.res;
        let images = &self.gbuffer;
        let pixel_groups = [
            self.width.div_ceil(CACHE_VIEW_TILE),
            self.height.div_ceil(CACHE_VIEW_TILE),
            1,
        ];
        let push = bytemuck::bytes_of(params);
        rec.pass("PurgeRadianceCache", |rec| {
            self.cache.hash_cells.record_purge(rec, res, params)
        })?;
        self.gbuffer_kernel
            .record(rec, scene, &res.camera, &self.gbuffer)?;

        rec.pass("TraceCacheRays", |rec| {
            rec.dispatch_traced(
                &self.trace,
                scene.sets(),
                &TraceCacheRays {
                    camera: &res.camera,
                    depth: &images.depth,
                    geometric_normal: &images.geometric_normal,
                    shading_normal: &images.shading_normal,
                    albedo: &images.albedo,
                    emissive: &images.emissive,
                    ids: &images.ids,
                    pixels: &res.ray_records,
                    queries: &res.queries,
                    counters: &res.counters,
                    bounds: &res.bounds,
                },
                push,
                pixel_groups,
            )?;
            Ok(())
        })?;
        self.cache
            .record_after_trace(rec, scene, res, &self.restir, &self.settings, params)?;
        rec.pass("CacheViewComposite", |rec| {
            rec.dispatch(
                &self.composite,
                &CacheViewComposite {
                    camera: &res.camera,
                    depth: &images.depth,
                    geometric_normal: &images.geometric_normal,
                    albedo: &images.albedo,
                    pixels: &res.ray_records,
                    accumulation: &self.accumulation,
                    history: &res.history,
                },
                &[],
                pixel_groups,
            )?;
            Ok(())
        })
    }

    /// The running mean of the frames since the last restart.
    pub fn image(&self, ctx: &Context) -> Result<HdrImage> {
        let sums: Vec<[f32; 4]> = self.accumulation.read_back(ctx)?;
        HdrImage::from_pixels(
            self.width,
            self.height,
            sums.iter().map(|s| running_mean(*s).to_array()).collect(),
        )
    }

    /// The hash grid's whole state and the counters.
    pub fn read_back_state(&self, ctx: &Context) -> Result<CacheState> {
        Ok(CacheState {
            keys: self.res.keys.read_back(ctx)?,
            last_touch: self.res.last_touch.read_back(ctx)?,
            values: self.res.values.read_back(ctx)?,
            accumulators: self.res.accumulators.read_back(ctx)?,
            lists: self.res.lists.read_back(ctx)?,
            counters: self.res.counters.read_back(ctx)?,
        })
    }

    /// The last frame's queries, as InsertRadianceCache left them (with their tiles and cells).
    pub fn read_back_queries(&self, ctx: &Context) -> Result<Vec<CacheQuery>> {
        let counters: Vec<u32> = self.res.counters.read_back(ctx)?;
        let mut queries: Vec<CacheQuery> = self.res.queries.read_back(ctx)?;
        queries.truncate(counters[QUERY_COUNT].min(self.res.query_capacity()) as usize);
        Ok(queries)
    }

    /// Runs a recorded batch of queries through the cache alone, as frame `frame` seen from
    /// `camera`: PurgeRadianceCache, InsertRadianceCache and UpdateRadianceCache (no tracing, no
    /// lighting: the cache's integer state then depends on the batch alone). Returns the
    /// occupancy. The batch holds at most one query per pixel.
    pub fn replay_queries(
        &mut self,
        ctx: &Context,
        camera: &CameraParams,
        frame: u32,
        queries: &[CacheQuery],
    ) -> Result<Occupancy> {
        let n = queries.len() as u32;
        if n > self.res.ray_capacity() || queries.is_empty() {
            return Err(Error::InvalidArgument {
                name: "queries",
                why: format!(
                    "{n} queries: a batch holds 1 to {} (one per pixel)",
                    self.res.ray_capacity()
                ),
            });
        }
        self.frame = frame;
        let mut params = self.params(camera);
        params.view.max_groups = ctx.capabilities().max_workgroup_count[0];
        let staging = Buffer::device_local(
            ctx,
            "replayed queries",
            queries,
            vk::BufferUsageFlags::empty(),
        )?;
        let recorded = ctx.submit(|cmd| -> Result<()> {
            let mut rec = Recorder::new(ctx, cmd, None);
            rec.begin();
            let cells = &self.cache.hash_cells;
            cells.record_purge(&mut rec, &self.res, &params)?;
            rec.copy(&staging, &self.res.queries)?;
            let count_offset = (QUERY_COUNT * std::mem::size_of::<u32>()) as u64;
            rec.update(&self.res.counters, count_offset, &n.to_le_bytes());
            cells.record_insert(&mut rec, &self.res, &params)?;
            cells.record_update(&mut rec, &self.res, &params)?;
            rec.finish();
            Ok(())
        });
        drop(staging);
        recorded??;
        let occupancy = self.res.occupancy(ctx, frame)?;
        self.frame = frame.wrapping_add(1);
        Ok(occupancy)
    }

    /// The [`DebugView`]s of the cell at each pixel's primary hit after the last frame;
    /// `keys_before` are the keys read back before it ([`CacheState::keys`]), for the evicted
    /// tiles. Errors before any frame.
    pub fn debug_views(
        &self,
        ctx: &Context,
        keys_before: &[u32],
    ) -> Result<Vec<(DebugView, HdrImage)>> {
        let Some((camera, params)) = &self.last_frame else {
            return Err(Error::InvalidArgument {
                name: "debug views",
                why: "no frame rendered yet".into(),
            });
        };
        let data = self.gbuffer.read_back(ctx)?;
        let keys: Vec<u32> = self.res.keys.read_back(ctx)?;
        let values: Vec<HashCellValue> = self.res.values.read_back(ctx)?;
        debug_views(camera, &params.grid, &data, keys_before, &keys, &values)
    }
}
