//! The world-space hash-grid radiance cache's passes (`gi_shared::hash_cells`), in the talk's
//! order: [`purge`] (PurgeRadianceCache), [`insert`] (InsertRadianceCache, split from the tracing
//! pass so that screen probes and test batches append the same queries), [`populate`]
//! (PopulateRadianceCache, tracing), [`update_tiles`] (UpdateRadianceCache) and [`resolve`]
//! (ResolveRadianceCache).
//!
//! Buffers, as every pass binds them in set 0: `keys` and `last_touch` (one `u32` per tile),
//! `values` (85 `HashCellValue`s per tile), `accumulators` (`ACCUMULATOR_WORDS` `u32`s per mip-0
//! cell), `lists` (the hash grid's counters and tile lists, `gi_shared::hash_cells::lists`), the
//! cache view's `counters`, `queries` (`CacheQuery`), `shadow_rays` (`ShadowRay`) and `pixels`
//! (`RayRecord`). Push constants: `CachePassParams`. One-dimensional kernels run
//! `WORKGROUP_SIZE` (64) invocations per workgroup, dispatched indirectly over their list.

#[cfg(not(feature = "ray-query"))]
pub mod insert;
pub mod populate;
#[cfg(not(feature = "ray-query"))]
pub mod purge;
#[cfg(not(feature = "ray-query"))]
pub mod resolve;
#[cfg(not(feature = "ray-query"))]
pub mod update_tiles;
