//! Lighting at secondary hits on the host (kernels `kernels/src/lighting/`): UpdateLightGrid
//! (grid over this frame's hits, then its entries, dispatched by the GPU from the grid's size),
//! GenerateReservoirs (temporal feedback or one RIS light sample and shadow ray per query) and
//! world-space ReSTIR's ClearReservoirs, CompactReservoirs and ResampleReservoirs.

use super::pass_inputs::PUSH_BYTES;
use super::resources::{CacheResources, RestirResources};
use crate::error::Result;
use crate::frame::Recorder;
use crate::frame::Scan;
use crate::frame::indirect_offset;
use crate::scene::lights::GpuLights;
use crate::vulkan::{Buffer, Context, Kernel, KernelModule};
use gi_shared::light_grid::light_grid_needed;
use gi_shared::world_cache::{ARGS_LIGHT_GRID, ARGS_QUERIES, ARGS_SHADOW_RAYS, CachePassParams};

crate::bindings! {
    /// UpdateLightGrid (sizing the grid)'s set 0 (`kernels::lighting::light_grid::update_light_grid`).
    pub(crate) struct UpdateLightGrid<'a> {
        bounds: &'a Buffer,
        grid: &'a Buffer,
        args: &'a Buffer,
    }
}

crate::bindings! {
    /// UpdateLightGrid (filling its entries)'s set 0 (`kernels::lighting::light_grid::build_light_grid`).
    pub(crate) struct BuildLightGrid<'a> {
        grid: &'a Buffer,
        entries: &'a Buffer,
        lights: &'a Buffer,
        clusters: &'a Buffer,
    }
}

crate::bindings! {
    /// GenerateReservoirs's set 0 (`kernels::lighting::reservoirs::generate_reservoirs`).
    pub(crate) struct GenerateReservoirs<'a> {
        camera: &'a Buffer,
        queries: &'a Buffer,
        counters: &'a Buffer,
        pixels: &'a Buffer,
        history: &'a Buffer,
        accumulators: &'a Buffer,
        grid: &'a Buffer,
        entries: &'a Buffer,
        shadow_rays: &'a Buffer,
        lists: &'a Buffer,
        lights: &'a Buffer,
        environment: &'a Buffer,
        environment_cdf: &'a Buffer,
        reservoir_keys: &'a Buffer,
        reservoir_counts: &'a Buffer,
        places: &'a Buffer,
        reservoirs: &'a Buffer,
        hits: &'a Buffer,
    }
}

crate::bindings! {
    /// CompactReservoirs's set 0 (`kernels::lighting::restir::compact_reservoirs`).
    pub(crate) struct CompactReservoirs<'a> {
        counters: &'a Buffer,
        places: &'a Buffer,
        offsets: &'a Buffer,
        queries: &'a Buffer,
        shadow_rays: &'a Buffer,
        unordered: &'a Buffer,
    }
}

crate::bindings! {
    /// CompactReservoirs (ordering each slot's run)'s set 0
    /// (`kernels::lighting::restir::order_reservoirs`).
    pub(crate) struct OrderReservoirs<'a> {
        counters: &'a Buffer,
        places: &'a Buffer,
        offsets: &'a Buffer,
        unordered: &'a Buffer,
        entries: &'a Buffer,
    }
}

crate::bindings! {
    /// ResampleReservoirs's set 0 (`kernels::lighting::restir::resample_reservoirs`).
    pub(crate) struct ResampleReservoirs<'a> {
        counters: &'a Buffer,
        queries: &'a Buffer,
        shadow_rays: &'a Buffer,
        reservoirs: &'a Buffer,
        previous_keys: &'a Buffer,
        previous_offsets: &'a Buffer,
        previous_entries: &'a Buffer,
        previous_reservoirs: &'a Buffer,
        previous_hits: &'a Buffer,
        grid: &'a Buffer,
        lights: &'a Buffer,
        environment: &'a Buffer,
        environment_cdf: &'a Buffer,
    }
}

/// The pipelines of the lighting passes.
pub struct LightingPasses {
    update_grid: Kernel,
    build_grid: Kernel,
    generate: Kernel,
    compact: Kernel,
    order: Kernel,
    resample: Kernel,
    scan: Scan,
}

impl LightingPasses {
    /// Creates the pipelines, with a prefix scan for reservoir grids of up to `slots` slots.
    pub fn new(ctx: &Context, module: &KernelModule, slots: u32) -> Result<Self> {
        Ok(Self {
            update_grid: Kernel::new::<UpdateLightGrid>(
                ctx,
                module,
                "lighting::light_grid::update_light_grid",
                PUSH_BYTES,
            )?,
            build_grid: Kernel::new::<BuildLightGrid>(
                ctx,
                module,
                "lighting::light_grid::build_light_grid",
                PUSH_BYTES,
            )?,
            generate: Kernel::new::<GenerateReservoirs>(
                ctx,
                module,
                "lighting::reservoirs::generate_reservoirs",
                PUSH_BYTES,
            )?,
            compact: Kernel::new::<CompactReservoirs>(
                ctx,
                module,
                "lighting::restir::compact_reservoirs",
                PUSH_BYTES,
            )?,
            order: Kernel::new::<OrderReservoirs>(
                ctx,
                module,
                "lighting::restir::order_reservoirs",
                PUSH_BYTES,
            )?,
            resample: Kernel::new::<ResampleReservoirs>(
                ctx,
                module,
                "lighting::restir::resample_reservoirs",
                PUSH_BYTES,
            )?,
            scan: Scan::new(ctx, module, slots)?,
        })
    }

    /// UpdateLightGrid: the grid's parameters from this frame's hit bounds (which TraceCacheRays
    /// reported), then its entries where the scene's lights need a grid
    /// (`gi_shared::light_grid::light_grid_needed`).
    pub fn record_light_grid(
        &self,
        rec: &mut Recorder<'_>,
        res: &CacheResources,
        lights: &GpuLights,
        params: &CachePassParams,
    ) -> Result<()> {
        let push = bytemuck::bytes_of(params);
        rec.dispatch(
            &self.update_grid,
            &UpdateLightGrid {
                bounds: &res.bounds,
                grid: &res.light_grid,
                args: &res.args,
            },
            push,
            [1, 1, 1],
        )?;
        if !light_grid_needed(lights.count()) {
            // Secondary hits weigh every light themselves: the grid's parameters are all they
            // read.
            return Ok(());
        }
        let [light_buffer, ..] = lights.buffers();
        rec.dispatch_indirect(
            &self.build_grid,
            &BuildLightGrid {
                grid: &res.light_grid,
                entries: &res.light_grid_entries,
                lights: light_buffer,
                clusters: lights.clusters(),
            },
            push,
            &res.args,
            indirect_offset(ARGS_LIGHT_GRID),
        )?;
        Ok(())
    }

    /// ClearReservoirs: empties this frame's reservoir grid.
    pub fn record_clear_reservoirs(&self, rec: &mut Recorder<'_>, restir: &RestirResources) {
        let grid = restir.grids.current();
        rec.fill(&grid.keys, 0);
        rec.fill(&grid.offsets, 0);
    }

    /// GenerateReservoirs over the queries (InsertRadianceCache's arguments); with ReSTIR
    /// (`params`' flags) the hits also join this frame's reservoir grid.
    pub fn record_generate(
        &self,
        rec: &mut Recorder<'_>,
        res: &CacheResources,
        restir: &RestirResources,
        lights: &GpuLights,
        params: &CachePassParams,
    ) -> Result<()> {
        let [light_buffer, _, environment, distribution] = lights.buffers();
        let grid = restir.grids.current();
        rec.dispatch_indirect(
            &self.generate,
            &GenerateReservoirs {
                camera: &res.camera,
                queries: &res.queries,
                counters: &res.counters,
                pixels: &res.ray_records,
                history: &res.history,
                accumulators: &res.accumulators,
                grid: &res.light_grid,
                entries: &res.light_grid_entries,
                shadow_rays: &res.shadow_rays,
                lists: &res.lists,
                lights: light_buffer,
                environment,
                environment_cdf: distribution,
                reservoir_keys: &grid.keys,
                reservoir_counts: &grid.offsets,
                places: &restir.places,
                reservoirs: &grid.reservoirs,
                hits: &grid.hits,
            },
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_QUERIES),
        )?;
        Ok(())
    }

    /// CompactReservoirs: the prefix scan of this frame's slot counts, then each shadow ray's sort
    /// key in the compacted list, scattered in the order of GenerateReservoirs's atomics, then
    /// each ray moved to its place in its slot's run ordered by key, which next frame's ResampleReservoirs
    /// picks its neighbours from (over the shadow rays' indirect arguments, which must be
    /// written).
    pub fn record_compact(
        &self,
        rec: &mut Recorder<'_>,
        res: &CacheResources,
        restir: &RestirResources,
        params: &CachePassParams,
    ) -> Result<()> {
        let grid = restir.grids.current();
        self.scan.record(
            rec,
            &grid.offsets,
            restir.slots,
            Some((&grid.offsets, restir.slots)),
        )?;
        rec.dispatch_indirect(
            &self.compact,
            &CompactReservoirs {
                counters: &res.counters,
                places: &restir.places,
                offsets: &grid.offsets,
                queries: &res.queries,
                shadow_rays: &res.shadow_rays,
                unordered: &restir.unordered,
            },
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_SHADOW_RAYS),
        )?;
        rec.dispatch_indirect(
            &self.order,
            &OrderReservoirs {
                counters: &res.counters,
                places: &restir.places,
                offsets: &grid.offsets,
                unordered: &restir.unordered,
                entries: &grid.entries,
            },
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_SHADOW_RAYS),
        )?;
        Ok(())
    }

    /// ResampleReservoirs: each shadow ray's reservoir merged with the previous frame's
    /// neighbours, its light sample rewritten.
    pub fn record_resample(
        &self,
        rec: &mut Recorder<'_>,
        res: &CacheResources,
        restir: &RestirResources,
        lights: &GpuLights,
        params: &CachePassParams,
    ) -> Result<()> {
        let [light_buffer, _, environment, distribution] = lights.buffers();
        let (current, previous) = restir.grids.pair();
        rec.dispatch_indirect(
            &self.resample,
            &ResampleReservoirs {
                counters: &res.counters,
                queries: &res.queries,
                shadow_rays: &res.shadow_rays,
                reservoirs: &current.reservoirs,
                previous_keys: &previous.keys,
                previous_offsets: &previous.offsets,
                previous_entries: &previous.entries,
                previous_reservoirs: &previous.reservoirs,
                previous_hits: &previous.hits,
                grid: &res.light_grid,
                lights: light_buffer,
                environment,
                environment_cdf: distribution,
            },
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_SHADOW_RAYS),
        )?;
        Ok(())
    }
}
