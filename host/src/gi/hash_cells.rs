//! The hash-grid radiance cache's passes on the host (kernels `kernels/src/hash_cells/`):
//! PurgeRadianceCache, InsertRadianceCache, PopulateRadianceCache, UpdateRadianceCache and
//! ResolveRadianceCache, each recorded into the caller's command buffer over
//! [`CacheResources`], most dispatched indirectly from the count of the list they walk.

use super::pass_inputs::PUSH_BYTES;
use super::resources::CacheResources;
use crate::error::Result;
use crate::frame::Recorder;
use crate::frame::{DispatchFromCounter, indirect_offset};
use crate::scene::lights::GpuLights;
use crate::vulkan::{Buffer, Context, Kernel, KernelModule, SceneSets};
use gi_shared::hash_cells::full_buckets::MARKS_CLEAR;
use gi_shared::hash_cells::lists::{UPDATE_TILES, previous_live_list};
use gi_shared::world_cache::{
    ARGS_PURGE, ARGS_QUERIES, ARGS_SHADOW_RAYS, ARGS_UPDATE, CachePassParams, QUERY_COUNT,
    SHADOW_RAY_COUNT,
};

crate::bindings! {
    /// PurgeRadianceCache (opening the frame)'s set 0 (`kernels::hash_cells::purge::begin_frame`).
    pub(crate) struct BeginFrame<'a> {
        lists: &'a Buffer,
        counters: &'a Buffer,
        bounds: &'a Buffer,
        carried: &'a Buffer,
    }
}

crate::bindings! {
    /// PurgeRadianceCache (carrying multi-bounce queries)'s set 0 (`kernels::hash_cells::purge::carry_queries`).
    pub(crate) struct CarryQueries<'a> {
        counters: &'a Buffer,
        carried: &'a Buffer,
        queries: &'a Buffer,
    }
}

crate::bindings! {
    /// PurgeRadianceCache's set 0 (`kernels::hash_cells::purge::purge_tiles`).
    pub(crate) struct PurgeTiles<'a> {
        keys: &'a Buffer,
        last_touch: &'a Buffer,
        lists: &'a Buffer,
    }
}

crate::bindings! {
    /// PopulateRadianceCache's set 0 (`kernels::hash_cells::populate::populate_radiance_cache`).
    pub(crate) struct PopulateRadianceCache<'a> {
        counters: &'a Buffer,
        shadow_rays: &'a Buffer,
        queries: &'a Buffer,
        accumulators: &'a Buffer,
        pixels: &'a Buffer,
        lists: &'a Buffer,
        reservoirs: &'a Buffer,
        keys: &'a Buffer,
        values: &'a Buffer,
        environment: &'a Buffer,
        last_touch: &'a Buffer,
        carried: &'a Buffer,
        bounce_values: &'a Buffer,
    }
}

crate::bindings! {
    /// UpdateRadianceCache's set 0 (`kernels::hash_cells::update_tiles::update_radiance_cache`).
    pub(crate) struct UpdateRadianceCache<'a> {
        values: &'a Buffer,
        accumulators: &'a Buffer,
        lists: &'a Buffer,
        bounce_values: &'a Buffer,
    }
}

crate::bindings! {
    /// ResolveRadianceCache's set 0 (`kernels::hash_cells::resolve::resolve_radiance_cache`).
    pub(crate) struct ResolveRadianceCache<'a> {
        counters: &'a Buffer,
        queries: &'a Buffer,
        values: &'a Buffer,
        pixels: &'a Buffer,
    }
}

crate::bindings! {
    /// InsertRadianceCache (and admitting keys to full buckets)'s set 0 (`kernels::hash_cells::insert::insert_radiance_cache`).
    pub(crate) struct InsertRadianceCache<'a> {
        keys: &'a Buffer,
        last_touch: &'a Buffer,
        values: &'a Buffer,
        lists: &'a Buffer,
        counters: &'a Buffer,
        queries: &'a Buffer,
        marks: &'a Buffer,
    }
}

crate::bindings! {
    /// InsertRadianceCache (settling full buckets)'s set 0 (`kernels::hash_cells::insert::settle_full_buckets`).
    pub(crate) struct SettleFullBuckets<'a> {
        keys: &'a Buffer,
        lists: &'a Buffer,
        counters: &'a Buffer,
        queries: &'a Buffer,
        marks: &'a Buffer,
    }
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
            begin_frame: Kernel::new::<BeginFrame>(
                ctx,
                module,
                "hash_cells::purge::begin_frame",
                PUSH_BYTES,
            )?,
            carry: Kernel::new::<CarryQueries>(
                ctx,
                module,
                "hash_cells::purge::carry_queries",
                PUSH_BYTES,
            )?,
            purge: Kernel::new::<PurgeTiles>(
                ctx,
                module,
                "hash_cells::purge::purge_tiles",
                PUSH_BYTES,
            )?,
            insert: Kernel::new::<InsertRadianceCache>(
                ctx,
                module,
                "hash_cells::insert::insert_radiance_cache",
                PUSH_BYTES,
            )?,
            settle: Kernel::new::<SettleFullBuckets>(
                ctx,
                module,
                "hash_cells::insert::settle_full_buckets",
                PUSH_BYTES,
            )?,
            admit: Kernel::new::<InsertRadianceCache>(
                ctx,
                module,
                "hash_cells::insert::admit_to_full_buckets",
                PUSH_BYTES,
            )?,
            populate: Kernel::new::<PopulateRadianceCache>(
                ctx,
                module,
                "hash_cells::populate::populate_radiance_cache",
                PUSH_BYTES,
            )?,
            update: Kernel::new::<UpdateRadianceCache>(
                ctx,
                module,
                "hash_cells::update_tiles::update_radiance_cache",
                PUSH_BYTES,
            )?,
            resolve: Kernel::new::<ResolveRadianceCache>(
                ctx,
                module,
                "hash_cells::resolve::resolve_radiance_cache",
                PUSH_BYTES,
            )?,
            dispatch: DispatchFromCounter::new(ctx, module)?,
        })
    }

    /// PurgeRadianceCache: resets the frame's counters and the light grid's bounds, opens the
    /// query list with the queries multi-bounce carried over, then evicts the previous live
    /// list's expired tiles and carries the others into this frame's list.
    pub fn record_purge(
        &self,
        rec: &mut Recorder<'_>,
        res: &CacheResources,
        params: &CachePassParams,
    ) -> Result<()> {
        let push = bytemuck::bytes_of(params);
        rec.dispatch(
            &self.begin_frame,
            &BeginFrame {
                lists: &res.lists,
                counters: &res.counters,
                bounds: &res.bounds,
                carried: &res.carried,
            },
            push,
            [1, 1, 1],
        )?;
        if res.carried_capacity() > 0 {
            rec.dispatch(
                &self.carry,
                &CarryQueries {
                    counters: &res.counters,
                    carried: &res.carried,
                    queries: &res.queries,
                },
                push,
                [res.carried_capacity().div_ceil(64), 1, 1],
            )?;
        }
        self.dispatch.record(
            rec,
            &res.lists,
            previous_live_list(params.grid.frame_index),
            res.tile_count(),
            &res.args,
            ARGS_PURGE,
        )?;
        rec.dispatch_indirect(
            &self.purge,
            &PurgeTiles {
                keys: &res.keys,
                last_touch: &res.last_touch,
                lists: &res.lists,
            },
            push,
            &res.args,
            indirect_offset(ARGS_PURGE),
        )?;
        Ok(())
    }

    /// InsertRadianceCache over the queries the frame appended: the marks cleared, then the
    /// inserts, the full buckets settled and their admitted keys inserted
    /// (`gi_shared::hash_cells::full_buckets`), each a dispatch over the queries.
    pub fn record_insert(
        &self,
        rec: &mut Recorder<'_>,
        res: &CacheResources,
        params: &CachePassParams,
    ) -> Result<()> {
        rec.fill(&res.insert_marks, MARKS_CLEAR);
        self.dispatch.record(
            rec,
            &res.counters,
            QUERY_COUNT as u32,
            res.query_capacity(),
            &res.args,
            ARGS_QUERIES,
        )?;
        let insert = InsertRadianceCache {
            keys: &res.keys,
            last_touch: &res.last_touch,
            values: &res.values,
            lists: &res.lists,
            counters: &res.counters,
            queries: &res.queries,
            marks: &res.insert_marks,
        };
        let settle = SettleFullBuckets {
            keys: &res.keys,
            lists: &res.lists,
            counters: &res.counters,
            queries: &res.queries,
            marks: &res.insert_marks,
        };
        let (push, offset) = (bytemuck::bytes_of(params), indirect_offset(ARGS_QUERIES));
        rec.dispatch_indirect(&self.insert, &insert, push, &res.args, offset)?;
        rec.dispatch_indirect(&self.settle, &settle, push, &res.args, offset)?;
        // Admitted keys are inserted as the first inserts were.
        rec.dispatch_indirect(&self.admit, &insert, push, &res.args, offset)?;
        Ok(())
    }

    /// The indirect arguments of the passes over the shadow rays (CompactReservoirs,
    /// ResampleReservoirs, PopulateRadianceCache).
    pub fn record_shadow_ray_args(
        &self,
        rec: &mut Recorder<'_>,
        res: &CacheResources,
    ) -> Result<()> {
        self.dispatch.record(
            rec,
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
    pub fn record_populate(
        &self,
        rec: &mut Recorder<'_>,
        scene: SceneSets<'_>,
        res: &CacheResources,
        reservoirs: &Buffer,
        lights: &GpuLights,
        params: &CachePassParams,
    ) -> Result<()> {
        let [_, _, environment, _] = lights.buffers();
        rec.dispatch_indirect_traced(
            &self.populate,
            scene,
            &PopulateRadianceCache {
                counters: &res.counters,
                shadow_rays: &res.shadow_rays,
                queries: &res.queries,
                accumulators: &res.accumulators,
                pixels: &res.ray_records,
                lists: &res.lists,
                reservoirs,
                keys: &res.keys,
                values: &res.values,
                environment,
                last_touch: &res.last_touch,
                carried: &res.carried,
                bounce_values: &res.bounce_values,
            },
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_SHADOW_RAYS),
        )?;
        Ok(())
    }

    /// UpdateRadianceCache over the tiles touched this frame.
    pub fn record_update(
        &self,
        rec: &mut Recorder<'_>,
        res: &CacheResources,
        params: &CachePassParams,
    ) -> Result<()> {
        self.dispatch.record(
            rec,
            &res.lists,
            UPDATE_TILES,
            res.tile_count(),
            &res.args,
            ARGS_UPDATE,
        )?;
        rec.dispatch_indirect(
            &self.update,
            &UpdateRadianceCache {
                values: &res.values,
                accumulators: &res.accumulators,
                lists: &res.lists,
                bounce_values: &res.bounce_values,
            },
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_UPDATE),
        )?;
        Ok(())
    }

    /// ResolveRadianceCache over the queries (reusing InsertRadianceCache's arguments).
    pub fn record_resolve(
        &self,
        rec: &mut Recorder<'_>,
        res: &CacheResources,
        params: &CachePassParams,
    ) -> Result<()> {
        rec.dispatch_indirect(
            &self.resolve,
            &ResolveRadianceCache {
                counters: &res.counters,
                queries: &res.queries,
                values: &res.values,
                pixels: &res.ray_records,
            },
            bytemuck::bytes_of(params),
            &res.args,
            indirect_offset(ARGS_QUERIES),
        )?;
        Ok(())
    }
}
