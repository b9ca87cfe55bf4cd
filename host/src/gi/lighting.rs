//! Lighting at secondary hits on the host (kernels `kernels/src/lighting/`): UpdateLightGrid
//! (grid over this frame's hits, then its entries, dispatched by the GPU from the grid's size),
//! GenerateReservoirs (temporal feedback or one RIS light sample and shadow ray per query) and
//! world-space ReSTIR's ClearReservoirs, CompactReservoirs and ResampleReservoirs.

use super::hash_cells::buffers_kernel;
use super::resources::{CacheResources, RestirResources};
use crate::error::Result;
use crate::frame::indirect_offset;
use crate::frame::{Scan, indirect_barrier};
use crate::scene::lights::GpuLights;
use crate::vulkan::{Context, Kernel, KernelModule, Resource, compute_barrier, transfer_barrier};
use ash::vk;
use gi_shared::cache_view::{ARGS_LIGHT_GRID, ARGS_QUERIES, ARGS_SHADOW_RAYS, CachePassParams};

/// The pipelines of the lighting passes.
pub struct LightingPasses {
    update_grid: Kernel,
    build_grid: Kernel,
    generate: Kernel,
    compact: Kernel,
    resample: Kernel,
    scan: Scan,
}

impl LightingPasses {
    /// Creates the pipelines, with a prefix scan for reservoir grids of up to `slots` slots.
    pub fn new(ctx: &Context, module: &KernelModule, slots: u32) -> Result<Self> {
        Ok(Self {
            update_grid: buffers_kernel(ctx, module, "lighting::light_grid::update_light_grid", 3)?,
            build_grid: buffers_kernel(ctx, module, "lighting::light_grid::build_light_grid", 3)?,
            generate: buffers_kernel(ctx, module, "lighting::reservoirs::generate_reservoirs", 18)?,
            compact: buffers_kernel(ctx, module, "lighting::restir::compact_reservoirs", 4)?,
            resample: buffers_kernel(ctx, module, "lighting::restir::resample_reservoirs", 13)?,
            scan: Scan::new(ctx, module, slots)?,
        })
    }

    /// UpdateLightGrid: the grid's parameters from this frame's hit bounds (which TraceCacheRays
    /// reported), then its entries.
    pub fn record_light_grid(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &CacheResources,
        lights: &GpuLights,
        params: &CachePassParams,
    ) -> Result<()> {
        let push = bytemuck::bytes_of(params);
        self.update_grid.dispatch(
            ctx,
            cmd,
            &[
                Resource::Buffer(&res.bounds),
                Resource::Buffer(&res.light_grid),
                Resource::Buffer(&res.args),
            ],
            push,
            [1, 1, 1],
        )?;
        indirect_barrier(ctx, cmd);
        let [light_buffer, ..] = lights.resources();
        self.build_grid.dispatch_indirect(
            ctx,
            cmd,
            &[
                Resource::Buffer(&res.light_grid),
                Resource::Buffer(&res.light_grid_entries),
                light_buffer,
            ],
            push,
            &res.args,
            indirect_offset(ARGS_LIGHT_GRID),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }

    /// ClearReservoirs: empties this frame's reservoir grid.
    pub fn record_clear_reservoirs(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        restir: &RestirResources,
    ) {
        let grid = restir.grids.current();
        grid.keys.record_fill_zero(ctx, cmd);
        grid.offsets.record_fill_zero(ctx, cmd);
        transfer_barrier(ctx, cmd);
    }

    /// GenerateReservoirs over the queries (InsertRadianceCache's arguments); with ReSTIR
    /// (`params`' flags) the hits also join this frame's reservoir grid.
    pub fn record_generate(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &CacheResources,
        restir: &RestirResources,
        lights: &GpuLights,
        params: &CachePassParams,
    ) -> Result<()> {
        let [light_buffer, _, environment, distribution] = lights.resources();
        let grid = restir.grids.current();
        self.generate.dispatch_indirect(
            ctx,
            cmd,
            &[
                Resource::Buffer(&res.camera),
                Resource::Buffer(&res.queries),
                Resource::Buffer(&res.counters),
                Resource::Buffer(&res.ray_records),
                Resource::Buffer(&res.history),
                Resource::Buffer(&res.accumulators),
                Resource::Buffer(&res.light_grid),
                Resource::Buffer(&res.light_grid_entries),
                Resource::Buffer(&res.shadow_rays),
                Resource::Buffer(&res.lists),
                light_buffer,
                environment,
                distribution,
                Resource::Buffer(&grid.keys),
                Resource::Buffer(&grid.offsets),
                Resource::Buffer(&restir.places),
                Resource::Buffer(&grid.reservoirs),
                Resource::Buffer(&grid.hits),
            ],
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_QUERIES),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }

    /// CompactReservoirs: the prefix scan of this frame's slot counts, then each shadow ray's
    /// entry in the compacted list (over the shadow rays' indirect arguments, which must be
    /// written).
    pub fn record_compact(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &CacheResources,
        restir: &RestirResources,
        params: &CachePassParams,
    ) -> Result<()> {
        let grid = restir.grids.current();
        self.scan.record(
            ctx,
            cmd,
            &grid.offsets,
            restir.slots,
            Some((&grid.offsets, restir.slots)),
        )?;
        self.compact.dispatch_indirect(
            ctx,
            cmd,
            &[
                Resource::Buffer(&res.counters),
                Resource::Buffer(&restir.places),
                Resource::Buffer(&grid.offsets),
                Resource::Buffer(&grid.entries),
            ],
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_SHADOW_RAYS),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }

    /// ResampleReservoirs: each shadow ray's reservoir merged with the previous frame's
    /// neighbours, its light sample rewritten.
    pub fn record_resample(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &CacheResources,
        restir: &RestirResources,
        lights: &GpuLights,
        params: &CachePassParams,
    ) -> Result<()> {
        let [light_buffer, _, environment, distribution] = lights.resources();
        let (current, previous) = restir.grids.pair();
        self.resample.dispatch_indirect(
            ctx,
            cmd,
            &[
                Resource::Buffer(&res.counters),
                Resource::Buffer(&res.queries),
                Resource::Buffer(&res.shadow_rays),
                Resource::Buffer(&current.reservoirs),
                Resource::Buffer(&previous.keys),
                Resource::Buffer(&previous.offsets),
                Resource::Buffer(&previous.entries),
                Resource::Buffer(&previous.reservoirs),
                Resource::Buffer(&previous.hits),
                Resource::Buffer(&res.light_grid),
                light_buffer,
                environment,
                distribution,
            ],
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_SHADOW_RAYS),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }
}
