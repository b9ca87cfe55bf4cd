//! The hash-grid radiance cache's passes on the host (kernels `kernels/src/hash_cells/`):
//! PurgeRadianceCache, InsertRadianceCache, PopulateRadianceCache, UpdateRadianceCache and
//! ResolveRadianceCache, each recorded into the caller's command buffer over
//! [`CacheResources`], most dispatched indirectly from the count of the list they walk.

use super::resources::CacheResources;
use crate::error::Result;
use crate::frame::{DispatchFromCounter, indirect_offset};
use crate::scene::lights::GpuLights;
use crate::vulkan::{
    BindingKind, Buffer, Context, Kernel, KernelModule, Resource, SceneSets, compute_barrier,
    transfer_barrier,
};
use ash::vk;
use gi_shared::cache_view::{
    ARGS_PURGE, ARGS_QUERIES, ARGS_SHADOW_RAYS, ARGS_UPDATE, CachePassParams, QUERY_COUNT,
    SHADOW_RAY_COUNT,
};
use gi_shared::hash_cells::full_buckets::MARKS_CLEAR;
use gi_shared::hash_cells::lists::{UPDATE_TILES, previous_live_list};

/// Bytes of the push constants every cache pass takes.
pub const PUSH_BYTES: u32 = std::mem::size_of::<CachePassParams>() as u32;

/// Creates `entry` with `n` storage buffers in set 0 and the cache passes' push constants.
pub(crate) fn buffers_kernel(
    ctx: &Context,
    module: &KernelModule,
    entry: &str,
    n: usize,
) -> Result<Kernel> {
    Kernel::new(
        ctx,
        module,
        entry,
        &vec![BindingKind::StorageBuffer; n],
        PUSH_BYTES,
    )
}

/// The pipelines of the hash-grid passes.
pub struct HashCellPasses {
    begin_frame: Kernel,
    carry: Kernel,
    purge: Kernel,
    insert: Kernel,
    settle: Kernel,
    admit: Kernel,
    populate: Kernel,
    update: Kernel,
    resolve: Kernel,
    /// Turns a counter into an indirect dispatch.
    pub dispatch: DispatchFromCounter,
}

impl HashCellPasses {
    /// Creates the pipelines.
    pub fn new(ctx: &Context, module: &KernelModule) -> Result<Self> {
        Ok(Self {
            begin_frame: buffers_kernel(ctx, module, "hash_cells::purge::begin_frame", 4)?,
            carry: buffers_kernel(ctx, module, "hash_cells::purge::carry_queries", 3)?,
            purge: buffers_kernel(ctx, module, "hash_cells::purge::purge_tiles", 3)?,
            insert: buffers_kernel(ctx, module, "hash_cells::insert::insert_radiance_cache", 7)?,
            settle: buffers_kernel(ctx, module, "hash_cells::insert::settle_full_buckets", 7)?,
            admit: buffers_kernel(ctx, module, "hash_cells::insert::admit_to_full_buckets", 7)?,
            populate: buffers_kernel(
                ctx,
                module,
                "hash_cells::populate::populate_radiance_cache",
                12,
            )?,
            update: buffers_kernel(
                ctx,
                module,
                "hash_cells::update_tiles::update_radiance_cache",
                3,
            )?,
            resolve: buffers_kernel(
                ctx,
                module,
                "hash_cells::resolve::resolve_radiance_cache",
                4,
            )?,
            dispatch: DispatchFromCounter::new(ctx, module)?,
        })
    }

    /// PurgeRadianceCache: resets the frame's counters and the light grid's bounds, opens the
    /// query list with the queries multi-bounce carried over, then evicts the previous live
    /// list's expired tiles and carries the others into this frame's list.
    pub fn record_purge(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &CacheResources,
        params: &CachePassParams,
    ) -> Result<()> {
        let push = bytemuck::bytes_of(params);
        self.begin_frame.dispatch(
            ctx,
            cmd,
            &[
                Resource::Buffer(&res.lists),
                Resource::Buffer(&res.counters),
                Resource::Buffer(&res.bounds),
                Resource::Buffer(&res.carried),
            ],
            push,
            [1, 1, 1],
        )?;
        compute_barrier(ctx, cmd);
        if res.carried_capacity() > 0 {
            self.carry.dispatch(
                ctx,
                cmd,
                &[
                    Resource::Buffer(&res.counters),
                    Resource::Buffer(&res.carried),
                    Resource::Buffer(&res.queries),
                ],
                push,
                [res.carried_capacity().div_ceil(64), 1, 1],
            )?;
        }
        self.dispatch.record(
            ctx,
            cmd,
            &res.lists,
            previous_live_list(params.grid.frame_index),
            res.tile_count(),
            &res.args,
            ARGS_PURGE,
        )?;
        self.purge.dispatch_indirect(
            ctx,
            cmd,
            &[
                Resource::Buffer(&res.keys),
                Resource::Buffer(&res.last_touch),
                Resource::Buffer(&res.lists),
            ],
            push,
            &res.args,
            indirect_offset(ARGS_PURGE),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }

    /// InsertRadianceCache over the queries the frame appended: the marks cleared, then the
    /// inserts, the full buckets settled and their admitted keys inserted
    /// (`gi_shared::hash_cells::full_buckets`), each a dispatch over the queries.
    pub fn record_insert(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &CacheResources,
        params: &CachePassParams,
    ) -> Result<()> {
        res.insert_marks.record_fill(ctx, cmd, MARKS_CLEAR);
        transfer_barrier(ctx, cmd);
        self.dispatch.record(
            ctx,
            cmd,
            &res.counters,
            QUERY_COUNT as u32,
            res.query_capacity(),
            &res.args,
            ARGS_QUERIES,
        )?;
        let buffers = [
            Resource::Buffer(&res.keys),
            Resource::Buffer(&res.last_touch),
            Resource::Buffer(&res.values),
            Resource::Buffer(&res.lists),
            Resource::Buffer(&res.counters),
            Resource::Buffer(&res.queries),
            Resource::Buffer(&res.insert_marks),
        ];
        for kernel in [&self.insert, &self.settle, &self.admit] {
            kernel.dispatch_indirect(
                ctx,
                cmd,
                &buffers,
                bytemuck::bytes_of(params),
                &res.args,
                indirect_offset(ARGS_QUERIES),
            )?;
            compute_barrier(ctx, cmd);
        }
        Ok(())
    }

    /// The indirect arguments of the passes over the shadow rays (CompactReservoirs,
    /// ResampleReservoirs, PopulateRadianceCache).
    pub fn record_shadow_ray_args(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &CacheResources,
    ) -> Result<()> {
        self.dispatch.record(
            ctx,
            cmd,
            &res.counters,
            SHADOW_RAY_COUNT as u32,
            res.query_capacity(),
            &res.args,
            ARGS_SHADOW_RAYS,
        )
    }

    /// PopulateRadianceCache: traces the frame's shadow rays (`reservoirs`: this frame's ReSTIR
    /// reservoirs, whose occluded samples it invalidates) and, with multi-bounce, each one's
    /// bounce ray (which reads the cells and, on a miss, the environment of `lights`), one
    /// invocation per shadow ray from the arguments [`Self::record_shadow_ray_args`] wrote.
    #[allow(clippy::too_many_arguments, reason = "the pass's inputs")]
    pub fn record_populate(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        scene: SceneSets<'_>,
        res: &CacheResources,
        reservoirs: &Buffer,
        lights: &GpuLights,
        params: &CachePassParams,
    ) -> Result<()> {
        let [_, _, environment, _] = lights.resources();
        self.populate.dispatch_indirect_traced(
            ctx,
            cmd,
            scene,
            &[
                Resource::Buffer(&res.counters),
                Resource::Buffer(&res.shadow_rays),
                Resource::Buffer(&res.queries),
                Resource::Buffer(&res.accumulators),
                Resource::Buffer(&res.ray_records),
                Resource::Buffer(&res.lists),
                Resource::Buffer(reservoirs),
                Resource::Buffer(&res.keys),
                Resource::Buffer(&res.values),
                environment,
                Resource::Buffer(&res.last_touch),
                Resource::Buffer(&res.carried),
            ],
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_SHADOW_RAYS),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }

    /// UpdateRadianceCache over the tiles touched this frame.
    pub fn record_update(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &CacheResources,
        params: &CachePassParams,
    ) -> Result<()> {
        self.dispatch.record(
            ctx,
            cmd,
            &res.lists,
            UPDATE_TILES,
            res.tile_count(),
            &res.args,
            ARGS_UPDATE,
        )?;
        self.update.dispatch_indirect(
            ctx,
            cmd,
            &[
                Resource::Buffer(&res.values),
                Resource::Buffer(&res.accumulators),
                Resource::Buffer(&res.lists),
            ],
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_UPDATE),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }

    /// ResolveRadianceCache over the queries (reusing InsertRadianceCache's arguments).
    pub fn record_resolve(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        res: &CacheResources,
        params: &CachePassParams,
    ) -> Result<()> {
        self.resolve.dispatch_indirect(
            ctx,
            cmd,
            &[
                Resource::Buffer(&res.counters),
                Resource::Buffer(&res.queries),
                Resource::Buffer(&res.values),
                Resource::Buffer(&res.ray_records),
            ],
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_QUERIES),
        )?;
        compute_barrier(ctx, cmd);
        Ok(())
    }
}
