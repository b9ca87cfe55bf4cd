//! The screen probes on the host (kernels `kernels/src/screen_probes/`, math
//! `gi_shared::screen_probes`): their resources, sized from the resolution and the spawn rate,
//! and the recording of each pass under the talk's name: ReprojectScreenProbes,
//! SpawnScreenProbes, PatchScreenProbes, SampleScreenProbes, PopulateScreenProbes,
//! BlendScreenProbes, FilterProbeMask, FilterScreenProbes and ProjectScreenProbes.
//! InterpolateScreenProbes is recorded with the denoiser's passes, which read its output.

use super::pass_inputs::{PUSH_BYTES, PrimaryView};
use super::resources::CacheResources;
use super::settings::GiSettings;
use crate::error::Result;
use crate::frame::Recorder;
use crate::vulkan::{Buffer, Context, Image, Kernel, KernelModule, PingPong, SceneSets};
use ash::vk;
use gi_shared::screen_probes::{
    GI_COUNTER_WORDS, GiFrameParams, NO_PROBE, PROBE_CELLS, PROBE_SIZE, ProbeRay, ProbeRecord,
    StoredCell, mask_mip_count, mask_mip_size, mask_words,
};
use gi_shared::sh::SH_COEFFICIENT_COUNT;
use gi_shared::world_cache::CachePassParams;

crate::bindings! {
    /// ReprojectScreenProbes's set 0 (`kernels::screen_probes::reproject::reproject_screen_probes`).
    pub(crate) struct ReprojectScreenProbes<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        previous_records: &'a Buffer,
        previous_mask: &'a Buffer,
        previous_atlas: &'a Buffer,
        records: &'a Buffer,
        mask: &'a Buffer,
        atlas: &'a Buffer,
        empty_tiles: &'a Buffer,
        counters: &'a Buffer,
        motion: &'a Image,
    }
}

crate::bindings! {
    /// SpawnScreenProbes's set 0 (`kernels::screen_probes::spawn::spawn_screen_probes`).
    pub(crate) struct SpawnScreenProbes<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        records: &'a Buffer,
        spawns: &'a Buffer,
        overrides: &'a Buffer,
        counters: &'a Buffer,
    }
}

crate::bindings! {
    /// PatchScreenProbes (claiming override slots)'s set 0 (`kernels::screen_probes::patch::claim_override_slots`).
    pub(crate) struct ClaimOverrideSlots<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        empty_tiles: &'a Buffer,
        overrides: &'a Buffer,
        counters: &'a Buffer,
    }
}

crate::bindings! {
    /// PatchScreenProbes's set 0 (`kernels::screen_probes::patch::patch_screen_probes`).
    pub(crate) struct PatchScreenProbes<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        empty_tiles: &'a Buffer,
        overrides: &'a Buffer,
        spawns: &'a Buffer,
        counters: &'a Buffer,
    }
}

crate::bindings! {
    /// SampleScreenProbes's set 0 (`kernels::screen_probes::sample::sample_screen_probes`).
    pub(crate) struct SampleScreenProbes<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        spawns: &'a Buffer,
        records: &'a Buffer,
        atlas: &'a Buffer,
        probe_history: &'a Buffer,
        probe_rays: &'a Buffer,
    }
}

crate::bindings! {
    /// PopulateScreenProbes's set 0 (`kernels::screen_probes::populate::populate_screen_probes`).
    pub(crate) struct PopulateScreenProbes<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        spawns: &'a Buffer,
        probe_rays: &'a Buffer,
        ray_records: &'a Buffer,
        queries: &'a Buffer,
        counters: &'a Buffer,
        bounds: &'a Buffer,
    }
}

crate::bindings! {
    /// BlendScreenProbes's set 0 (`kernels::screen_probes::blend::blend_screen_probes`).
    pub(crate) struct BlendScreenProbes<'a> {
        frame: &'a Buffer,
        camera: &'a Buffer,
        depth: &'a Image,
        geometric_normal: &'a Image,
        spawns: &'a Buffer,
        probe_rays: &'a Buffer,
        ray_records: &'a Buffer,
        probe_history: &'a Buffer,
        records: &'a Buffer,
        mask: &'a Buffer,
        atlas: &'a Buffer,
    }
}

crate::bindings! {
    /// FilterProbeMask's set 0 (`kernels::screen_probes::probe_mask::filter_probe_mask`).
    pub(crate) struct FilterProbeMask<'a> {
        frame: &'a Buffer,
        mask: &'a Buffer,
    }
}

crate::bindings! {
    /// FilterScreenProbes's set 0 (`kernels::screen_probes::filter::filter_screen_probes`).
    pub(crate) struct FilterScreenProbes<'a> {
        frame: &'a Buffer,
        records: &'a Buffer,
        mask: &'a Buffer,
        input: &'a Buffer,
        output: &'a Buffer,
    }
}

crate::bindings! {
    /// ProjectScreenProbes's set 0 (`kernels::screen_probes::project::project_screen_probes`).
    pub(crate) struct ProjectScreenProbes<'a> {
        frame: &'a Buffer,
        records: &'a Buffer,
        cells: &'a Buffer,
        sh: &'a Buffer,
    }
}

/// How many probes a frame holds and spawns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeLayout {
    /// Probe tiles across and down.
    pub probe_grid: [u32; 2],
    /// Spawn tiles across and down.
    pub spawn_grid: [u32; 2],
    /// Spawn tile side in pixels.
    pub spawn_tile: u32,
    /// Mips of the probe mask.
    pub mask_mips: u32,
}

impl ProbeLayout {
    /// The layout of a `width × height` frame spawning one probe per `spawn_tile` pixels.
    pub fn new(width: u32, height: u32, spawn_tile: u32) -> Self {
        let probe_grid = [width.div_ceil(PROBE_SIZE), height.div_ceil(PROBE_SIZE)];
        Self {
            probe_grid,
            spawn_grid: [width.div_ceil(spawn_tile), height.div_ceil(spawn_tile)],
            spawn_tile,
            mask_mips: mask_mip_count(probe_grid),
        }
    }

    /// Probe tiles.
    pub fn probe_count(&self) -> u32 {
        self.probe_grid[0] * self.probe_grid[1]
    }

    /// Spawn tiles: the most probes a frame traces.
    pub fn spawn_capacity(&self) -> u32 {
        self.spawn_grid[0] * self.spawn_grid[1]
    }

    /// Probe rays per frame at most (64 per spawned probe).
    pub fn ray_capacity(&self) -> u32 {
        self.spawn_capacity() * PROBE_CELLS
    }
}

/// Every buffer of the screen probes.
pub struct ScreenProbeResources {
    /// The frame's [`GiFrameParams`] (host-written).
    pub frame: Buffer,
    /// One [`ProbeRecord`] per probe tile, this frame's and the previous frame's.
    pub records: PingPong<Buffer>,
    /// The probe mask's mip chain (packed seeds), this frame's and the previous frame's.
    pub mask: PingPong<Buffer>,
    /// 64 cells per probe tile ([`StoredCell`]), this frame's and the previous frame's.
    pub atlas: PingPong<Buffer>,
    /// The spawn list (packed seeds).
    pub spawns: Buffer,
    /// Disoccluded tiles without a probe or a spawn.
    pub empty_tiles: Buffer,
    /// One override word per spawn slot: open where the spawn's tile still held a reprojected
    /// probe (patching takes such spawns over), then the index + 1 of the tile that claimed it.
    pub overrides: Buffer,
    /// The gathered history hemisphere of every spawned probe (64 cells each).
    pub history: Buffer,
    /// One [`ProbeRay`] per probe ray.
    pub rays: Buffer,
    /// The probe filter's horizontal output where it has a buffer of its own (64 cells per probe
    /// tile; see [`Self::new`]), else a one-element placeholder. Its vertical output is the
    /// previous atlas ([`Self::projected_cells`]).
    pub filtered: Buffer,
    /// Whether [`Self::filtered`] is the probe filter's output ([`Self::filter_output`]).
    own_filter_output: bool,
    /// Nine SH coefficients per probe tile (`[f32; 4]`).
    pub sh: Buffer,
    /// The GI counter words (`gi_shared::screen_probes::SPAWN_COUNT` ...).
    pub counters: Buffer,
    /// How many probes.
    pub layout: ProbeLayout,
}

/// Whether the probe filter's horizontal output (64 [`StoredCell`]s per probe tile of `layout`)
/// fits the frame's per-pixel scratch, the interpolated irradiance (`[f32; 4]` per pixel of a
/// `pixels`-pixel frame), which holds nothing between the previous frame's GI image (read or
/// copied by then) and this frame's InterpolateScreenProbes: half of it from 8 × 8 pixels up.
pub fn filter_output_fits(layout: &ProbeLayout, pixels: usize) -> bool {
    let cells = layout.probe_count() as usize * PROBE_CELLS as usize;
    cells * std::mem::size_of::<StoredCell>() <= pixels * std::mem::size_of::<[f32; 4]>()
}

impl ScreenProbeResources {
    /// The resources of `layout` in a `pixels`-pixel frame, with no probe yet; the probe filter's
    /// horizontal output in a buffer of its own only with `probe_filter` where it does not fit the
    /// frame's per-pixel scratch ([`filter_output_fits`]; else a one-element placeholder).
    pub fn new(
        ctx: &Context,
        layout: ProbeLayout,
        probe_filter: bool,
        pixels: usize,
    ) -> Result<Self> {
        let own_filter_output = probe_filter && !filter_output_fits(&layout, pixels);
        let probes = layout.probe_count() as usize;
        let spawns = layout.spawn_capacity() as usize;
        let cells = probes * PROBE_CELLS as usize;
        let mask = vec![NO_PROBE; mask_words(layout.probe_grid) as usize];
        let none = vec![ProbeRecord::NONE; probes];
        let usage = vk::BufferUsageFlags::empty();
        let pair =
            |name: &str, make: &dyn Fn(&str) -> Result<Buffer>| -> Result<PingPong<Buffer>> {
                Ok(PingPong::new(
                    make(&format!("{name} (a)"))?,
                    make(&format!("{name} (b)"))?,
                ))
            };
        Ok(Self {
            frame: Buffer::parameters(ctx, "GI frame parameters", &[GiFrameParams::default()])?,
            records: pair("probe records", &|n| {
                Buffer::device_local(ctx, n, &none, usage)
            })?,
            mask: pair("probe mask", &|n| {
                Buffer::device_local(ctx, n, &mask, usage)
            })?,
            atlas: pair("probe atlas", &|n| {
                Buffer::device_zeroed::<StoredCell>(ctx, n, cells)
            })?,
            spawns: Buffer::device_zeroed::<u32>(ctx, "probe spawns", spawns)?,
            empty_tiles: Buffer::device_zeroed::<u32>(ctx, "empty tiles", probes)?,
            overrides: Buffer::device_zeroed::<u32>(ctx, "override tiles", spawns)?,
            history: Buffer::device_zeroed::<StoredCell>(
                ctx,
                "probe history",
                spawns * PROBE_CELLS as usize,
            )?,
            rays: Buffer::device_zeroed::<ProbeRay>(
                ctx,
                "probe rays",
                spawns * PROBE_CELLS as usize,
            )?,
            filtered: Buffer::device_zeroed::<StoredCell>(
                ctx,
                "filtered probes (horizontal)",
                if own_filter_output { cells } else { 1 },
            )?,
            own_filter_output,
            sh: Buffer::device_zeroed::<[f32; 4]>(ctx, "probe SH", probes * SH_COEFFICIENT_COUNT)?,
            counters: Buffer::device_zeroed::<u32>(ctx, "GI counters", GI_COUNTER_WORDS)?,
            layout,
        })
    }

    /// The probe filter's horizontal output: its own buffer, or `scratch` (the interpolated
    /// irradiance, which holds the previous frame's GI image until InterpolateScreenProbes, read
    /// or copied by then) where it fits ([`filter_output_fits`]).
    pub fn filter_output<'a>(&'a self, scratch: &'a Buffer) -> &'a Buffer {
        if self.own_filter_output {
            &self.filtered
        } else {
            scratch
        }
    }

    /// Starts a frame: the previous frame's probes become `previous`.
    pub fn swap(&mut self) {
        self.records.swap();
        self.mask.swap();
        self.atlas.swap();
    }

    /// The cells SH projection reads: the probe filter's output when it ran, else the atlas.
    /// The filter writes its vertical output over the previous atlas, which ReprojectScreenProbes
    /// has read by then and overwrites in full next frame: no buffer of its own.
    pub fn projected_cells(&self, filtered: bool) -> &Buffer {
        if filtered {
            self.atlas.previous()
        } else {
            self.atlas.current()
        }
    }
}

/// The pipelines of the screen-probe passes.
pub struct ScreenProbePasses {
    reproject: Kernel,
    spawn: Kernel,
    claim: Kernel,
    patch: Kernel,
    sample: Kernel,
    populate: Kernel,
    blend: Kernel,
    probe_mask: Kernel,
    filter: Kernel,
    project: Kernel,
}

/// Bytes of a `u32` push constant.
const U32_PUSH: u32 = 4;

impl ScreenProbePasses {
    /// Creates the pipelines.
    pub fn new(ctx: &Context, module: &KernelModule) -> Result<Self> {
        let sp = "screen_probes::";
        Ok(Self {
            reproject: Kernel::new::<ReprojectScreenProbes>(
                ctx,
                module,
                &format!("{sp}reproject::reproject_screen_probes"),
                0,
            )?,
            spawn: Kernel::new::<SpawnScreenProbes>(
                ctx,
                module,
                &format!("{sp}spawn::spawn_screen_probes"),
                0,
            )?,
            claim: Kernel::new::<ClaimOverrideSlots>(
                ctx,
                module,
                &format!("{sp}patch::claim_override_slots"),
                0,
            )?,
            patch: Kernel::new::<PatchScreenProbes>(
                ctx,
                module,
                &format!("{sp}patch::patch_screen_probes"),
                0,
            )?,
            sample: Kernel::new::<SampleScreenProbes>(
                ctx,
                module,
                &format!("{sp}sample::sample_screen_probes"),
                0,
            )?,
            populate: Kernel::new::<PopulateScreenProbes>(
                ctx,
                module,
                &format!("{sp}populate::populate_screen_probes"),
                PUSH_BYTES,
            )?,
            blend: Kernel::new::<BlendScreenProbes>(
                ctx,
                module,
                &format!("{sp}blend::blend_screen_probes"),
                0,
            )?,
            probe_mask: Kernel::new::<FilterProbeMask>(
                ctx,
                module,
                &format!("{sp}probe_mask::filter_probe_mask"),
                U32_PUSH,
            )?,
            filter: Kernel::new::<FilterScreenProbes>(
                ctx,
                module,
                &format!("{sp}filter::filter_screen_probes"),
                U32_PUSH,
            )?,
            project: Kernel::new::<ProjectScreenProbes>(
                ctx,
                module,
                &format!("{sp}project::project_screen_probes"),
                0,
            )?,
        })
    }

    /// ReprojectScreenProbes: last frame's probes into this frame's tiles.
    pub fn record_reproject(
        &self,
        rec: &mut Recorder<'_>,
        res: &ScreenProbeResources,
        view: PrimaryView<'_>,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let (depth, normal) = (&gbuffer.depth, &gbuffer.geometric_normal);
        let g = res.layout.probe_grid;
        rec.dispatch(
            &self.reproject,
            &ReprojectScreenProbes {
                frame: &res.frame,
                camera,
                depth,
                geometric_normal: normal,
                previous_records: res.records.previous(),
                previous_mask: res.mask.previous(),
                previous_atlas: res.atlas.previous(),
                records: res.records.current(),
                mask: res.mask.current(),
                atlas: res.atlas.current(),
                empty_tiles: &res.empty_tiles,
                counters: &res.counters,
                motion: &gbuffer.motion,
            },
            &[],
            [g[0], g[1], 1],
        )?;
        Ok(())
    }

    /// SpawnScreenProbes, then (with patching) PatchScreenProbes.
    pub fn record_spawn(
        &self,
        rec: &mut Recorder<'_>,
        res: &ScreenProbeResources,
        view: PrimaryView<'_>,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let (depth, normal) = (&gbuffer.depth, &gbuffer.geometric_normal);
        rec.dispatch(
            &self.spawn,
            &SpawnScreenProbes {
                frame: &res.frame,
                camera,
                depth,
                geometric_normal: normal,
                records: res.records.current(),
                spawns: &res.spawns,
                overrides: &res.overrides,
                counters: &res.counters,
            },
            &[],
            [res.layout.spawn_capacity().div_ceil(64), 1, 1],
        )?;
        Ok(())
    }

    /// PatchScreenProbes: disoccluded tiles claim open spawn slots (ClaimOverrideSlots), then
    /// take the first they won.
    pub fn record_patch(
        &self,
        rec: &mut Recorder<'_>,
        res: &ScreenProbeResources,
        view: PrimaryView<'_>,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let (depth, normal) = (&gbuffer.depth, &gbuffer.geometric_normal);
        let patch = PatchScreenProbes {
            frame: &res.frame,
            camera,
            depth,
            geometric_normal: normal,
            empty_tiles: &res.empty_tiles,
            overrides: &res.overrides,
            spawns: &res.spawns,
            counters: &res.counters,
        };
        let claim = ClaimOverrideSlots {
            frame: patch.frame,
            camera,
            depth,
            geometric_normal: normal,
            empty_tiles: patch.empty_tiles,
            overrides: patch.overrides,
            counters: patch.counters,
        };
        let groups = [res.layout.probe_count().div_ceil(64), 1, 1];
        rec.dispatch(&self.claim, &claim, &[], groups)?;
        rec.dispatch(&self.patch, &patch, &[], groups)?;
        Ok(())
    }

    /// SampleScreenProbes: each spawned probe's history hemisphere and ray directions.
    pub fn record_sample(
        &self,
        rec: &mut Recorder<'_>,
        res: &ScreenProbeResources,
        view: PrimaryView<'_>,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let (depth, normal) = (&gbuffer.depth, &gbuffer.geometric_normal);
        let s = res.layout.spawn_grid;
        rec.dispatch(
            &self.sample,
            &SampleScreenProbes {
                frame: &res.frame,
                camera,
                depth,
                geometric_normal: normal,
                spawns: &res.spawns,
                records: res.records.current(),
                atlas: res.atlas.current(),
                probe_history: &res.history,
                probe_rays: &res.rays,
            },
            &[],
            [s[0], s[1], 1],
        )?;
        Ok(())
    }

    /// PopulateScreenProbes: one ray per cell of every spawned probe.
    pub fn record_populate(
        &self,
        rec: &mut Recorder<'_>,
        scene: SceneSets<'_>,
        res: &ScreenProbeResources,
        cache: &CacheResources,
        view: PrimaryView<'_>,
        params: &CachePassParams,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let (depth, normal) = (&gbuffer.depth, &gbuffer.geometric_normal);
        let s = res.layout.spawn_grid;
        rec.dispatch_traced(
            &self.populate,
            scene,
            &PopulateScreenProbes {
                frame: &res.frame,
                camera,
                depth,
                geometric_normal: normal,
                spawns: &res.spawns,
                probe_rays: &res.rays,
                ray_records: &cache.ray_records,
                queries: &cache.queries,
                counters: &cache.counters,
                bounds: &cache.bounds,
            },
            bytemuck::bytes_of(params),
            [s[0], s[1], 1],
        )?;
        Ok(())
    }

    /// BlendScreenProbes: the rays' radiance into the spawned probes' cells.
    pub fn record_blend(
        &self,
        rec: &mut Recorder<'_>,
        res: &ScreenProbeResources,
        cache: &CacheResources,
        view: PrimaryView<'_>,
    ) -> Result<()> {
        let PrimaryView { camera, gbuffer } = view;
        let (depth, normal) = (&gbuffer.depth, &gbuffer.geometric_normal);
        let s = res.layout.spawn_grid;
        rec.dispatch(
            &self.blend,
            &BlendScreenProbes {
                frame: &res.frame,
                camera,
                depth,
                geometric_normal: normal,
                spawns: &res.spawns,
                probe_rays: &res.rays,
                ray_records: &cache.ray_records,
                probe_history: &res.history,
                records: res.records.current(),
                mask: res.mask.current(),
                atlas: res.atlas.current(),
            },
            &[],
            [s[0], s[1], 1],
        )?;
        Ok(())
    }

    /// FilterProbeMask: mips 1.. of the probe mask, one dispatch each.
    pub fn record_probe_mask(
        &self,
        rec: &mut Recorder<'_>,
        res: &ScreenProbeResources,
    ) -> Result<()> {
        for mip in 1..res.layout.mask_mips {
            let size = mask_mip_size(res.layout.probe_grid, mip);
            rec.dispatch(
                &self.probe_mask,
                &FilterProbeMask {
                    frame: &res.frame,
                    mask: res.mask.current(),
                },
                &mip.to_le_bytes(),
                [size[0].div_ceil(8), size[1].div_ceil(8), 1],
            )?;
        }
        Ok(())
    }

    /// FilterScreenProbes, horizontal then vertical, from the atlas through `horizontal` (its
    /// 64 cells per probe tile) into [`ScreenProbeResources::projected_cells`].
    pub fn record_filter(
        &self,
        rec: &mut Recorder<'_>,
        res: &ScreenProbeResources,
        horizontal: &Buffer,
    ) -> Result<()> {
        let g = res.layout.probe_grid;
        let steps = [
            (res.atlas.current(), horizontal),
            (horizontal, res.projected_cells(true)),
        ];
        for (direction, (input, output)) in steps.into_iter().enumerate() {
            rec.dispatch(
                &self.filter,
                &FilterScreenProbes {
                    frame: &res.frame,
                    records: res.records.current(),
                    mask: res.mask.current(),
                    input,
                    output,
                },
                &(direction as u32).to_le_bytes(),
                [g[0], g[1], 1],
            )?;
        }
        Ok(())
    }

    /// ProjectScreenProbes: SH L2 of every probe from `cells`.
    pub fn record_project(
        &self,
        rec: &mut Recorder<'_>,
        res: &ScreenProbeResources,
        cells: &Buffer,
    ) -> Result<()> {
        let g = res.layout.probe_grid;
        rec.dispatch(
            &self.project,
            &ProjectScreenProbes {
                frame: &res.frame,
                records: res.records.current(),
                cells,
                sh: &res.sh,
            },
            &[],
            [g[0], g[1], 1],
        )?;
        Ok(())
    }
}

/// The technique switches of `settings` as `GiFrameParams::flags` (`FLAG_HISTORY` and
/// `FLAG_SAMPLED_DIRECT` depend on the frame and the scene: the caller adds them).
pub fn technique_flags(settings: &GiSettings) -> u32 {
    use gi_shared::screen_probes::*;
    [
        (settings.reprojection, FLAG_REPROJECTION),
        (settings.parallax, FLAG_PARALLAX),
        (settings.radiance_backup, FLAG_RADIANCE_BACKUP),
        (settings.patching, FLAG_PATCHING),
        (settings.ray_guiding, FLAG_RAY_GUIDING),
        (settings.hysteresis, FLAG_HYSTERESIS),
        (settings.probe_filter, FLAG_PROBE_FILTER),
        (settings.relaxed_fallback, FLAG_RELAXED_FALLBACK),
        (settings.denoiser_temporal, FLAG_DENOISER_TEMPORAL),
        (settings.denoiser_spatial, FLAG_DENOISER_SPATIAL),
        (settings.object_motion, FLAG_OBJECT_MOTION),
        (settings.emitter_sampling, FLAG_EMITTER_SAMPLING),
    ]
    .into_iter()
    .filter(|(on, _)| *on)
    .fold(0, |flags, (_, flag)| flags | flag)
}
