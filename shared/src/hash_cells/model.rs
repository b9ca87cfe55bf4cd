//! CPU model of the hash-grid radiance cache: owns the buffers and runs a frame's passes with the
//! very functions of [`super::passes`] the kernels call, one invocation after another. A GPU test
//! replays the same batch and compares [`Snapshot`]s: integer state bit for bit, keyed by
//! `(bucket, checksum)` because slot order inside a bucket depends on the order of concurrent
//! inserts, and values within a tolerance. The comparison is exact only while no bucket overflows
//! (`FAILED_INSERTS` = 0): which keys win a full bucket's slots depends on the order too.

use std::collections::BTreeSet;

use glam::Vec3;

use super::CELLS_PER_TILE;
use super::adaptive_blend::TileTrend;
use super::layout::{
    HashCellValue, HashGridParams, HashGridQuery, TILE_ACCUMULATOR_WORDS, TREND_WORD,
};
use super::lists::{
    COUNTER_WORDS, UPDATE_TILES, begin_frame, list_buffer_words, list_len, list_word, live_list,
    previous_live_list,
};
use super::passes::{purge_pass, query_descriptor, query_pass, update_pass};
use super::read::lookup;
use super::touch::initial_last_touch;

/// Largest difference of two snapshots' tile trends that [`Snapshot::compare`] accepts: a few
/// half-precision steps of values in `[-1, 1]`.
const TREND_TOLERANCE: f32 = 4e-3;

/// The cache's buffers, laid out as on the GPU.
#[derive(Clone, Debug)]
pub struct HashGridModel {
    /// Checksum per tile slot, 0 = empty.
    pub keys: Vec<u32>,
    /// Frame of each tile's last touch.
    pub last_touch: Vec<u32>,
    /// 85 cells per tile.
    pub values: Vec<HashCellValue>,
    /// [`TILE_ACCUMULATOR_WORDS`] words per tile.
    pub accumulators: Vec<u32>,
    /// Counters and tile lists ([`super::lists`]).
    pub lists: Vec<u32>,
}

impl HashGridModel {
    /// An empty cache sized for `params` (which must [fit the buffers](HashGridParams::fits_buffers)),
    /// whose first frame is `params.frame_index`.
    pub fn new(params: &HashGridParams) -> Self {
        assert!(params.fits_buffers(), "hash grid too large: {params:?}");
        let tiles = params.tile_count() as usize;
        Self {
            keys: vec![0; tiles],
            last_touch: vec![initial_last_touch(params.frame_index); tiles],
            values: vec![HashCellValue::ZERO; tiles * CELLS_PER_TILE as usize],
            accumulators: vec![0; tiles * TILE_ACCUMULATOR_WORDS],
            lists: vec![0; list_buffer_words(params.tile_count())],
        }
    }

    /// Frame start and purge pass of frame `params.frame_index`.
    pub fn purge(&mut self, params: &HashGridParams) {
        begin_frame(&mut self.lists[..], params.frame_index);
        let previous = previous_live_list(params.frame_index);
        let count = list_len(&self.lists[..], previous, params.tile_count());
        for index in 0..count {
            purge_pass(
                &mut self.keys[..],
                &self.last_touch[..],
                &mut self.lists[..],
                params,
                index,
            );
        }
    }

    /// Query pass over a batch, in order.
    pub fn query(&mut self, params: &HashGridParams, queries: &[HashGridQuery]) {
        for query in queries {
            query_pass(
                &mut self.keys[..],
                &mut self.last_touch[..],
                &mut self.values,
                &mut self.accumulators[..],
                &mut self.lists[..],
                params,
                query,
            );
        }
    }

    /// Update pass over the tiles touched this frame.
    pub fn update(&mut self, params: &HashGridParams) {
        let count = list_len(&self.lists[..], UPDATE_TILES, params.tile_count());
        for index in 0..count {
            update_pass(
                &mut self.values,
                &mut [],
                &mut self.accumulators[..],
                &self.lists[..],
                params,
                index,
            );
        }
    }

    /// A whole frame: purge, queries, update.
    pub fn run_frame(&mut self, params: &HashGridParams, queries: &[HashGridQuery]) {
        self.purge(params);
        self.query(params, queries);
        self.update(params);
    }

    /// Filtered radiance the cache returns for `query`'s cell (its radiance is not read).
    pub fn filtered_radiance(
        &self,
        params: &HashGridParams,
        query: &HashGridQuery,
    ) -> Option<Vec3> {
        lookup(
            &self.keys[..],
            &self.values,
            &query_descriptor(query, params),
            params,
        )
    }

    /// Counter word `counter` ([`super::lists`]).
    pub fn counter(&self, counter: u32) -> u32 {
        self.lists[counter as usize]
    }

    /// Valid entries of list `list`.
    pub fn list(&self, params: &HashGridParams, list: u32) -> &[u32] {
        let start = list_word(list, params.tile_count(), 0);
        let len = list_len(&self.lists[..], list, params.tile_count()) as usize;
        &self.lists[start..start + len]
    }

    /// The slot-order-independent state of these buffers.
    pub fn snapshot(&self, params: &HashGridParams) -> Snapshot {
        Snapshot::new(
            params,
            &self.keys,
            &self.last_touch,
            &self.values,
            &self.accumulators,
            &self.lists,
        )
    }
}

/// One live tile of a [`Snapshot`].
#[derive(Clone, Debug, PartialEq)]
pub struct TileSnapshot {
    /// Bucket of the tile's slot.
    pub bucket: u32,
    /// Key.
    pub checksum: u32,
    /// Frame of the last touch.
    pub last_touch: u32,
    /// Whether the tile is in this frame's live list.
    pub live: bool,
    /// Whether the tile is in the update list.
    pub update: bool,
    /// The accumulator words of the tile's cells.
    pub accumulators: Vec<u32>,
    /// The tile's luminance trend (compared within a tolerance: it is a running mean of
    /// divisions, which the GPU need not round as the CPU does).
    pub trend: TileTrend,
    /// The tile's 85 cells.
    pub values: Vec<HashCellValue>,
}

/// The cache's state with tiles identified by `(bucket, checksum)` instead of slot, so that runs
/// whose concurrent inserts filled buckets in different orders compare equal.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Occupied tiles, sorted by `(bucket, checksum)`.
    pub tiles: Vec<TileSnapshot>,
    /// The counter words.
    pub counters: Vec<u32>,
    /// Entries of the lists that name an empty slot (0 in a consistent state).
    pub dangling_list_entries: u32,
}

impl Snapshot {
    /// Snapshot of buffers laid out as [`HashGridModel`]'s (e.g. read back from the GPU).
    pub fn new(
        params: &HashGridParams,
        keys: &[u32],
        last_touch: &[u32],
        values: &[HashCellValue],
        accumulators: &[u32],
        lists: &[u32],
    ) -> Self {
        let tile_count = params.tile_count();
        let list_set = |list: u32| -> BTreeSet<u32> {
            let start = list_word(list, tile_count, 0);
            let len = list_len(lists, list, tile_count) as usize;
            lists[start..start + len].iter().copied().collect()
        };
        let live = list_set(live_list(params.frame_index));
        let update = list_set(UPDATE_TILES);
        let dangling = live
            .iter()
            .chain(update.iter())
            .filter(|&&t| keys[t as usize] == 0)
            .count() as u32;
        let cells = CELLS_PER_TILE as usize;
        let words = TILE_ACCUMULATOR_WORDS;
        let mut tiles: Vec<TileSnapshot> = (0..tile_count)
            .filter(|&t| keys[t as usize] != 0)
            .map(|t| {
                let i = t as usize;
                TileSnapshot {
                    bucket: t >> params.tiles_per_bucket_log2,
                    checksum: keys[i],
                    last_touch: last_touch[i],
                    live: live.contains(&t),
                    update: update.contains(&t),
                    accumulators: accumulators[i * words..i * words + TREND_WORD].to_vec(),
                    trend: TileTrend::unpack(accumulators[i * words + TREND_WORD]),
                    values: values[i * cells..(i + 1) * cells].to_vec(),
                }
            })
            .collect();
        tiles.sort_by_key(|t| (t.bucket, t.checksum));
        Self {
            tiles,
            counters: lists[..COUNTER_WORDS as usize].to_vec(),
            dangling_list_entries: dangling,
        }
    }

    /// Compares with `other`: everything but the values exactly, values within relative tolerance
    /// `rel` (of the larger magnitude, at least 1). The first difference, if any.
    pub fn compare(&self, other: &Snapshot, rel: f32) -> Result<(), String> {
        if self.counters != other.counters {
            return Err(format!(
                "counters {:?} vs {:?}",
                self.counters, other.counters
            ));
        }
        if self.dangling_list_entries != other.dangling_list_entries {
            return Err("dangling list entries differ".into());
        }
        if self.tiles.len() != other.tiles.len() {
            return Err(format!(
                "{} vs {} tiles",
                self.tiles.len(),
                other.tiles.len()
            ));
        }
        for (a, b) in self.tiles.iter().zip(&other.tiles) {
            let id = (a.bucket, a.checksum);
            if (a.bucket, a.checksum, a.last_touch, a.live, a.update)
                != (b.bucket, b.checksum, b.last_touch, b.live, b.update)
                || a.accumulators != b.accumulators
            {
                return Err(format!("tile {id:?}: {a:?} vs {b:?}"));
            }
            let trend_tolerance = rel.max(TREND_TOLERANCE);
            if (a.trend.trend - b.trend.trend).abs() > trend_tolerance
                || (a.trend.spread - b.trend.spread).abs() > trend_tolerance
            {
                return Err(format!("tile {id:?} trend: {:?} vs {:?}", a.trend, b.trend));
            }
            for (i, (va, vb)) in a.values.iter().zip(&b.values).enumerate() {
                let (x, y) = (va.sum_and_count(), vb.sum_and_count());
                let scale = x.abs().max(y.abs()).max_element().max(1.0);
                if (x - y).abs().max_element() > rel * scale {
                    return Err(format!("tile {id:?} cell {i}: {va:?} vs {vb:?}"));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_cells::lists::{DROPPED_SAMPLES, EVICTED_TILES, FAILED_INSERTS};
    use crate::hash_cells::shared_words::{SharedWords, atomic_buffer};
    use crate::hash_cells::{DEFAULT_CELL_SIZE_PIXELS, TILE_DECAY_FRAMES, cell_size_const};
    use crate::random::Random;
    use crate::sampling::sample_uniform_sphere;
    use core::sync::atomic::Ordering::SeqCst;

    fn params(buckets_log2: u32, frame: u32) -> HashGridParams {
        let csc = cell_size_const(1.0, 640, 360, DEFAULT_CELL_SIZE_PIXELS);
        let mut p = HashGridParams::new(Vec3::new(0.5, 1.0, -2.0), csc, frame);
        p.num_buckets_log2 = buckets_log2;
        p
    }

    /// Rays from the eye to random points of the box `[-4, 4]³` plus a floor, each carrying `l`.
    fn queries(rng: &mut Random, eye: Vec3, n: usize, l: Vec3) -> Vec<HashGridQuery> {
        (0..n)
            .map(|_| {
                let hit = (rng.next_vec2().extend(rng.next_f32()) - 0.5) * 8.0;
                let d = hit - eye;
                HashGridQuery::new(hit, d.normalize(), d.length(), l)
            })
            .collect()
    }

    fn at_frame(p: &HashGridParams, frame: u32) -> HashGridParams {
        HashGridParams {
            frame_index: frame,
            ..*p
        }
    }

    #[test]
    fn furnace_converges_to_the_constant() {
        let l = Vec3::new(1.0, 0.5, 3.7);
        let base = params(8, 3);
        let mut model = HashGridModel::new(&base);
        let mut rng = Random::new(21, 0);
        // A fixed set of hit points, re-sampled every frame.
        let batch = queries(&mut rng, base.eye(), 4000, l);
        for f in 0..6 {
            model.run_frame(&at_frame(&base, 3 + f), &batch);
        }
        let p = at_frame(&base, 8);
        assert_eq!(model.counter(FAILED_INSERTS), 0);
        assert!(model.list(&p, live_list(8)).len() > 10);
        for q in &batch {
            let r = model.filtered_radiance(&p, q).expect("cached");
            // The packed sums' rounding, dithered in a mip-0 cell (up to a whole unit, 2^-9) and
            // to nearest again in the mip it may read (the counts, integers, are exact).
            let bound = 3.0 * crate::packing::WIDE16_MAX_RELATIVE_ERROR;
            assert!(((r - l).abs() / l).max_element() <= bound, "{r}");
        }
        // Every mip-0 cell is capped at 16 samples.
        assert!(
            model
                .values
                .chunks(CELLS_PER_TILE as usize)
                .all(|t| t[..64].iter().all(|v| v.count() <= 16.0))
        );
        assert_eq!(model.snapshot(&p).dangling_list_entries, 0);
    }

    #[test]
    fn a_tiny_cache_overflows_gracefully() {
        // 2 buckets × 16 tiles, thousands of distinct tiles.
        let p = params(1, 0);
        let mut model = HashGridModel::new(&p);
        let mut rng = Random::new(22, 0);
        let batch = queries(&mut rng, p.eye(), 3000, Vec3::ONE);
        model.run_frame(&p, &batch);
        assert!(model.keys.iter().all(|&k| k != 0));
        let failed = model.counter(FAILED_INSERTS);
        assert!(failed > 0);
        let served = batch
            .iter()
            .filter(|q| model.filtered_radiance(&p, q).is_some())
            .count();
        // Served queries are exactly those whose tile made it in.
        let stored = batch
            .iter()
            .filter(|q| {
                let d = query_descriptor(q, &p);
                model.keys.contains(&d.checksum)
            })
            .count();
        assert_eq!(served, stored);
        assert_eq!(served + failed as usize, batch.len());
        assert_eq!(model.list(&p, live_list(0)).len(), 32);
        assert_eq!(model.list(&p, UPDATE_TILES).len(), 32);
    }

    #[test]
    fn tiles_expire_after_50_untouched_frames_across_the_wrap() {
        for first in [100u32, u32::MAX - 20] {
            let p = params(4, first);
            let mut model = HashGridModel::new(&p);
            let q = HashGridQuery::new(Vec3::new(1.0, 0.0, 0.0), Vec3::X, 2.0, Vec3::ONE);
            model.run_frame(&p, &[q]);
            assert!(model.filtered_radiance(&p, &q).is_some());
            for age in 1..=TILE_DECAY_FRAMES {
                let pf = at_frame(&p, first.wrapping_add(age));
                model.run_frame(&pf, &[]);
                let alive = model.filtered_radiance(&pf, &q).is_some();
                assert_eq!(alive, age < TILE_DECAY_FRAMES, "age {age}");
                assert_eq!(
                    model.list(&pf, live_list(pf.frame_index)).len(),
                    usize::from(alive)
                );
                assert_eq!(model.counter(EVICTED_TILES), u32::from(!alive));
            }
            // Re-inserting the evicted tile starts from zeroed values.
            let pf = at_frame(&p, first.wrapping_add(TILE_DECAY_FRAMES + 1));
            let dark = HashGridQuery {
                radiance: [0.0; 3],
                ..q
            };
            model.run_frame(&pf, &[dark]);
            assert_eq!(model.filtered_radiance(&pf, &q), Some(Vec3::ZERO));
            assert_eq!(model.list(&pf, UPDATE_TILES).len(), 1);
        }
    }

    #[test]
    fn non_finite_samples_are_dropped_and_counted() {
        let p = params(4, 0);
        let mut model = HashGridModel::new(&p);
        let q = HashGridQuery::new(Vec3::new(1.0, 0.0, 0.0), Vec3::X, 2.0, Vec3::ONE);
        let nan = HashGridQuery {
            radiance: [f32::NAN, 1.0, 1.0],
            ..q
        };
        let no_cell = HashGridQuery {
            hit_position: [f32::INFINITY, 0.0, 0.0],
            ..q
        };
        model.run_frame(&p, &[q, nan, no_cell]);
        assert_eq!(model.counter(DROPPED_SAMPLES), 1);
        assert_eq!(model.filtered_radiance(&p, &q), Some(Vec3::ONE));
        assert_eq!(model.list(&p, live_list(0)).len(), 1);
    }

    /// The query pass run from 4 threads on atomic buffers ends in the same state as the
    /// sequential model, up to slot order; so does the update pass after it.
    #[test]
    fn concurrent_query_pass_matches_the_model() {
        let p = params(8, 7);
        let mut rng = Random::new(23, 0);
        // Buckets shared by several tiles, none overflowing (with overflow, the set of keys that
        // win a bucket depends on the order).
        let mut batch = queries(&mut rng, p.eye(), 3000, Vec3::ZERO);
        for q in &mut batch {
            q.radiance = (rng.next_vec2().extend(rng.next_f32()) * 10.0).to_array();
            if rng.next_f32() < 0.3 {
                let d = sample_uniform_sphere(rng.next_vec2());
                q.direction = d.to_array();
            }
        }
        let mut model = HashGridModel::new(&p);
        model.purge(&p);
        model.query(&p, &batch);

        let tiles = p.tile_count() as usize;
        let keys = atomic_buffer(tiles);
        let stamps = atomic_buffer(tiles);
        let accs = atomic_buffer(model.accumulators.len());
        let lists = atomic_buffer(model.lists.len());
        for s in stamps.iter() {
            s.store(initial_last_touch(7), SeqCst);
        }
        begin_frame(&mut SharedWords(&lists), 7);
        std::thread::scope(|s| {
            for chunk in batch.chunks(750) {
                let (mut k, mut t, mut a, mut l) = (
                    SharedWords(&keys),
                    SharedWords(&stamps),
                    SharedWords(&accs),
                    SharedWords(&lists),
                );
                s.spawn(move || {
                    // Values of a fresh cache are zero: new tiles' clears change nothing, so
                    // each thread clears a private copy.
                    let mut values = vec![HashCellValue::ZERO; tiles * CELLS_PER_TILE as usize];
                    for q in chunk {
                        query_pass(&mut k, &mut t, &mut values, &mut a, &mut l, &p, q);
                    }
                });
            }
        });
        let read = |b: &[core::sync::atomic::AtomicU32]| -> Vec<u32> {
            b.iter().map(|w| w.load(SeqCst)).collect()
        };
        let (keys, stamps, mut accs, lists) =
            (read(&keys), read(&stamps), read(&accs), read(&lists));
        let mut values = vec![HashCellValue::ZERO; model.values.len()];
        let threaded = Snapshot::new(&p, &keys, &stamps, &values, &accs, &lists);
        assert_eq!(model.counter(FAILED_INSERTS), 0);
        assert!(model.list(&p, UPDATE_TILES).len() > 300);
        assert_eq!(threaded.dangling_list_entries, 0);
        threaded.compare(&model.snapshot(&p), 0.0).unwrap();

        // The update pass on the threaded state gives the model's values (same bits even: the
        // blend reads the same integers).
        model.update(&p);
        let len = list_len(&lists[..], UPDATE_TILES, p.tile_count());
        for index in 0..len {
            update_pass(&mut values, &mut [], &mut accs[..], &lists[..], &p, index);
        }
        let threaded = Snapshot::new(&p, &keys, &stamps, &values, &accs, &lists);
        threaded.compare(&model.snapshot(&p), 0.0).unwrap();
    }
}
