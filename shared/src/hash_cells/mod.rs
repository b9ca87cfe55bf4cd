//! The world-space hash-grid radiance cache's cell descriptor (`HashGridCache_GetDesc`, notes §3.2).
//!
//! A hit point is keyed by a level of detail `L` (cells of `2^L` mm, growing with distance to the
//! eye so a cell covers roughly [`DEFAULT_CELL_SIZE_PIXELS`] on screen), a tile coordinate (boxes of
//! 8 cells), a direction bin (5 per axis) and a short-ray flag. The key's chained PCG picks one of
//! `2^num_buckets_log2` buckets; its chained xxHash is the checksum stored in the bucket's slots.
//! Inside a tile, cells form an 8 × 8 grid projected along the ray's dominant axis, followed by
//! prefiltered 4 × 4, 2 × 2 and 1 × 1 mips (85 cells per tile).
//!
//! The cache's life cycle per frame, each step a function here that the kernels call as they are:
//! [`purge`] evicts tiles untouched for [`TILE_DECAY_FRAMES`] frames, [`storage`] inserts and
//! finds tiles ([`full_buckets`] settles a bucket that could not take every new key), [`touch`] stamps them and lists them for the update, [`accumulate`] adds radiance
//! samples, [`update`] blends them into the cells and builds the mips, and [`read`] returns the
//! adaptively prefiltered radiance. [`layout`] holds the cache's buffer records and capacities,
//! [`lists`] lays out the frame's counters and tile lists,
//! [`passes`] strings the steps into the per-invocation bodies of the GPU passes, and `model`
//! (tests and `std` only) runs whole frames of them on the CPU.
//!
//! The LOD is taken from float exponent bits and positions are scaled by exact powers of two, so
//! CPU and GPU agree bit-for-bit given the same `|p − eye|²` (no `log2`/`exp2` approximations).

pub mod accumulate;
pub mod adaptive_blend;
pub mod full_buckets;
pub mod layout;
pub mod lists;
#[cfg(any(test, feature = "std"))]
pub mod model;
pub mod passes;
pub mod purge;
pub mod read;
#[cfg(test)]
pub(crate) mod shared_words;
pub mod storage;
pub mod touch;
pub mod update;

use glam::Vec3;

use self::layout::HashGridParams;
use crate::hash::{pcg_chain, xxhash32_chain};
use crate::math::{
    abs, floor, floor_to_i32_clamped, max, max_i32, max_u32, min_i32, min_u32, tan, to_u32_clamped,
};

/// Angular cell size of the hash grid, in pixels (`gi1_hash_grid_cache_cell_size`).
pub const DEFAULT_CELL_SIZE_PIXELS: f32 = 32.0;
/// Lower clamp of the world-space cell size (`gi1_hash_grid_cache_min_cell_size`).
pub const MIN_CELL_SIZE: f32 = 0.1;
/// Cells along one side of a tile.
pub const TILE_CELL_RATIO: u32 = 8;
/// Mip levels per tile: 8 × 8, 4 × 4, 2 × 2, 1 × 1.
pub const NUM_MIPS: u32 = 4;
/// Mip-0 cells per tile (8 × 8): the cells that receive samples.
pub const MIP0_CELLS_PER_TILE: u32 = TILE_CELL_RATIO * TILE_CELL_RATIO;
/// Cells per tile including its mips: 64 + 16 + 4 + 1.
pub const CELLS_PER_TILE: u32 = 85;
/// First cell of each mip inside a tile.
pub const MIP_OFFSETS: [u32; NUM_MIPS as usize] = [0, 64, 80, 84];
/// Default `log2` of the bucket count (4096 buckets).
pub const NUM_BUCKETS_LOG2: u32 = 12;
/// Default `log2` of the tiles per bucket (16).
pub const TILES_PER_BUCKET_LOG2: u32 = 4;
/// Bound on `num_buckets_log2 + tiles_per_bucket_log2` so the cell buffers fit one storage binding
/// (checked in [`layout`]); also clamps the bucket count the descriptor uses.
pub const MAX_NUM_TILES_LOG2: u32 = 16;
/// Default tile count: 65 536.
pub const NUM_TILES: u32 = 1 << (NUM_BUCKETS_LOG2 + TILES_PER_BUCKET_LOG2);
/// Default cell count: 5 570 560.
pub const NUM_CELLS: u32 = NUM_TILES * CELLS_PER_TILE;
/// Sample-count cap of a cell's history.
pub const MAX_SAMPLE_COUNT: u32 = 16;
/// With a fading history, a read takes a cell whose history weighs at least this many samples,
/// else steps to the coarser mip ([`read`]; the reference steps up below the sample cap).
pub const READ_MIN_SAMPLES: f32 = 1.0;
/// [`HashGridParams::history_frames`] of the presets: a cell's samples fade with a time constant
/// of 12 updates of its tile ([`update`]). 6 and 8 converged faster (Bitterli staircase −12%
/// after 64 frames, against −13.7%) but left a light switched on 5–9% short after 15 frames
/// (`tests/tests/light_change.rs`), against 3% with 12.
pub const HISTORY_FRAMES: u32 = 12;
/// Time constant, in updates of its tile, of multi-bounce's bounce copy of a cell
/// ([`update::update_bounce_copy`]): bounce rays read this shorter history, so each further bounce
/// arrives within a few frames instead of a [`HISTORY_FRAMES`] blend later, while reads from the
/// screen keep the longer, quieter history. 2 against 3: the Bitterli staircase's 64th frame at
/// 320 × 180 −6.8 → −6.3 %, a light switched off 0.053 → 0.050 after 15 frames (README, "Round
/// 19"); 1 would keep no history at all ([`update::history_keep`]).
pub const BOUNCE_HISTORY_FRAMES: u32 = 2;
/// Tiles untouched for this many frames are evicted.
pub const TILE_DECAY_FRAMES: u32 = 50;
/// Cell sizes are `2^L` millimetres: the LOD key is `floor(log2(1000 · step))`.
pub const LOD_STEP_FACTOR: f32 = 1e3;
/// Smallest LOD: cells of 2^-20 mm ≈ 1 nm, so that a scene modelled a million times smaller
/// (with [`MIN_CELL_SIZE`] scaled alike) keeps its cells' angular size: a floor of 1 mm made
/// cells of a millimetre-sized scene cover it whole. Tile coordinates stay below
/// [`MAX_TILE_COORD`] for `|p|` up to `8.6 · 10⁶ · 2^L` m at LOD `L` (8 m at this one, reached
/// only by hits within nanometres of the eye).
pub const MIN_LOD: i32 = -20;
/// Largest LOD: cells of 2^31 mm ≈ 2147 km, beyond any finite scene distance times the cell constant.
pub const MAX_LOD: i32 = 31;
/// Tile coordinates are clamped to `±MAX_TILE_COORD` (reached only for `|p| ≥ 2^30` tiles, about
/// `8.6 · 10⁶ · 2^L` m).
pub const MAX_TILE_COORD: i32 = 1 << 30;
/// Direction bins per axis: `floor(2.5 + 2·d)` of a unit direction lies in `0..=4`.
pub const DIRECTION_BINS: u32 = 5;

/// Angular cell-size constant: `tan(fov_y · pixels · max(1/H, H/W²))`, roughly the tangent of the
/// angle `pixels` pixels subtend. `pixels` = 32 keys the hash grid, 16 the reservoir grid and 8
/// gives the screen-probe plane tolerance. Zero sizes count as 1 pixel.
#[inline]
pub fn cell_size_const(fov_y: f32, width: u32, height: u32, pixels: f32) -> f32 {
    let w = max_u32(width, 1) as f32;
    let h = max_u32(height, 1) as f32;
    tan(fov_y * pixels * max(1.0 / h, h / (w * w)))
}

/// `2^e` for `e` in `[-126, 127]`, exact (unlike `exp2` on the GPU).
#[inline]
fn pow2(e: i32) -> f32 {
    f32::from_bits(((e + 127) as u32) << 23)
}

/// Level of detail of a hit at `position` seen from `eye`:
/// `floor(log2(1000 · max(|p − eye| · cell_size_const, min_cell_size)))`, clamped to
/// `[MIN_LOD, MAX_LOD]`. Infinite distances give `MAX_LOD`; a NaN distance or cell-size constant
/// falls back to the `min_cell_size` LOD, and a NaN `min_cell_size` as well gives `MIN_LOD`.
#[inline]
pub fn lod(eye: Vec3, position: Vec3, params: &HashGridParams) -> i32 {
    let d = position - eye;
    // floor(log2(sqrt(x))) = floor(floor(log2(x)) / 2): square the step instead of taking a root.
    let step2 = d.dot(d) * (params.cell_size_const * params.cell_size_const);
    let min2 = params.min_cell_size * params.min_cell_size;
    let x2 = max(step2, min2) * (LOD_STEP_FACTOR * LOD_STEP_FACTOR);
    let biased = ((x2.to_bits() >> 23) & 0xff) as i32;
    let floor_log2 = if x2 > 0.0 { biased - 127 } else { MIN_LOD * 2 };
    // Arithmetic shift = floor division by 2, also for negatives.
    clamp_lod(floor_log2 >> 1)
}

/// World-space cell size at LOD `lod`: `2^lod / 1000` (LOD clamped to the valid range).
#[inline]
pub fn lod_cell_size(lod: i32) -> f32 {
    pow2(clamp_lod(lod)) * (1.0 / LOD_STEP_FACTOR)
}

/// `HashGridCache_GetCellSize`: world-space size of the cell a hit at `position` falls into.
#[inline]
pub fn cell_size(eye: Vec3, position: Vec3, params: &HashGridParams) -> f32 {
    lod_cell_size(lod(eye, position, params))
}

#[inline]
fn clamp_lod(lod: i32) -> i32 {
    max_i32(min_i32(lod, MAX_LOD), MIN_LOD)
}

/// Where a hit lives in the hash grid.
///
/// `checksum == 0` means "no cell" ([`CellDescriptor::NONE`], also the `Default`): returned for any
/// NaN/∞ input or a zero direction; every other field is then 0. A valid descriptor has
/// `checksum ≥ 1` and `bucket < 2^min(num_buckets_log2, MAX_NUM_TILES_LOG2)`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CellDescriptor {
    /// Level of detail, in `[MIN_LOD, MAX_LOD]`.
    pub lod: i32,
    /// Tile coordinate `floor(p / tile_size)`, each in `±MAX_TILE_COORD`.
    pub tile: [i32; 3],
    /// Cell inside the tile's 8 × 8 grid, on the two axes orthogonal to the dominant ray axis.
    pub cell: [u32; 2],
    /// Direction bin per axis, each in `0..DIRECTION_BINS`.
    pub dir_bin: [u32; 3],
    /// 1 if the ray was shorter than the tile size (light-leak separation), else 0.
    pub short_ray: u32,
    /// Bucket index.
    pub bucket: u32,
    /// Checksum stored in the bucket's slots; never 0 for a valid cell.
    pub checksum: u32,
}

impl CellDescriptor {
    /// "No cell".
    pub const NONE: Self = Self {
        lod: 0,
        tile: [0; 3],
        cell: [0; 2],
        dir_bin: [0; 3],
        short_ray: 0,
        bucket: 0,
        checksum: 0,
    };

    /// Whether this is [`CellDescriptor::NONE`].
    #[inline]
    pub fn is_none(&self) -> bool {
        self.checksum == 0
    }

    /// World-space cell size.
    #[inline]
    pub fn cell_size(&self) -> f32 {
        lod_cell_size(self.lod)
    }
}

/// Descriptor of the cell a ray with unit `direction` hitting `position` after `hit_distance`
/// falls into, seen from `eye` (explicit so previous-frame lookups can pass the previous camera;
/// `params.eye` is not read).
#[inline]
pub fn cell_descriptor(
    eye: Vec3,
    position: Vec3,
    direction: Vec3,
    hit_distance: f32,
    params: &HashGridParams,
) -> CellDescriptor {
    if !eye.is_finite() {
        return CellDescriptor::NONE;
    }
    cell_descriptor_at_lod(
        lod(eye, position, params),
        position,
        direction,
        hit_distance,
        params,
    )
}

/// [`cell_descriptor`] with the level of detail given (clamped to the valid range).
#[inline]
pub fn cell_descriptor_at_lod(
    lod: i32,
    position: Vec3,
    direction: Vec3,
    hit_distance: f32,
    params: &HashGridParams,
) -> CellDescriptor {
    if !position.is_finite()
        || !direction.is_finite()
        || !hit_distance.is_finite()
        || direction == Vec3::ZERO
    {
        return CellDescriptor::NONE;
    }
    let lod = clamp_lod(lod);
    // 1000 · 2^-L and 125 · 2^-L are exact, so p · inv_size rounds once, identically everywhere.
    let inv_cell_size = LOD_STEP_FACTOR * pow2(-lod);
    let inv_tile_size = inv_cell_size * (1.0 / TILE_CELL_RATIO as f32);
    let tile_size = TILE_CELL_RATIO as f32 * lod_cell_size(lod);

    let pc = position * inv_cell_size;
    let pt = position * inv_tile_size;
    let tile = [
        floor_to_i32_clamped(pt.x, -MAX_TILE_COORD, MAX_TILE_COORD),
        floor_to_i32_clamped(pt.y, -MAX_TILE_COORD, MAX_TILE_COORD),
        floor_to_i32_clamped(pt.z, -MAX_TILE_COORD, MAX_TILE_COORD),
    ];
    // floor(p / cell) − 8 · floor(p / tile), in 0..8; clamped where f32 runs out of integer bits.
    let last = TILE_CELL_RATIO - 1;
    let e = [
        min_u32(to_u32_clamped(floor(pc.x) - floor(pt.x) * 8.0), last),
        min_u32(to_u32_clamped(floor(pc.y) - floor(pt.y) * 8.0), last),
        min_u32(to_u32_clamped(floor(pc.z) - floor(pt.z) * 8.0), last),
    ];
    // The 2-D grid is projected along the ray's dominant axis.
    let cell = match dominant_axis(direction) {
        0 => [e[1], e[2]],
        1 => [e[0], e[2]],
        _ => [e[0], e[1]],
    };
    let bins = DIRECTION_BINS - 1;
    // floor(0.5 + (0.5·d + 0.5)·4) written as floor(2.5 + 2·d): one rounding.
    let dir_bin = [
        min_u32(to_u32_clamped(floor(2.5 + 2.0 * direction.x)), bins),
        min_u32(to_u32_clamped(floor(2.5 + 2.0 * direction.y)), bins),
        min_u32(to_u32_clamped(floor(2.5 + 2.0 * direction.z)), bins),
    ];
    let short_ray = if hit_distance < tile_size { 1 } else { 0 };

    let key = [
        lod as u32,
        tile[0] as u32,
        tile[1] as u32,
        tile[2] as u32,
        dir_bin[0],
        dir_bin[1],
        dir_bin[2],
        short_ray,
    ];
    let buckets_log2 = min_u32(params.num_buckets_log2, MAX_NUM_TILES_LOG2);
    let checksum = xxhash32_chain(key);
    CellDescriptor {
        lod,
        tile,
        cell,
        dir_bin,
        short_ray,
        bucket: pcg_chain(key) & ((1u32 << buckets_log2) - 1),
        checksum: if checksum > 1 { checksum } else { 1 },
    }
}

/// First cell of mip `mip` inside a tile: 0, 64, 80, 84 (mip clamped to 3).
#[inline]
pub fn mip_offset(mip: u32) -> u32 {
    // Σ_{k<mip} 4^(3−k) = (256 − 4^(4−mip)) / 3.
    let mip = min_u32(mip, NUM_MIPS - 1);
    (256 - (256 >> (2 * mip))) / 3
}

/// Index of cell `(x, y)` of mip `mip` in tile slot `tile_slot`:
/// `tile_slot · 85 + mip_offset(mip) + x + y · (8 >> mip)`. `mip` is clamped to 3 and `x`, `y` to the
/// mip's side, so the result always stays inside the tile.
#[inline]
pub fn cell_index(tile_slot: u32, mip: u32, x: u32, y: u32) -> u32 {
    let mip = min_u32(mip, NUM_MIPS - 1);
    let side = TILE_CELL_RATIO >> mip;
    let x = min_u32(x, side - 1);
    let y = min_u32(y, side - 1);
    tile_slot
        .wrapping_mul(CELLS_PER_TILE)
        .wrapping_add(mip_offset(mip) + x + y * side)
}

/// Tile slot `slot` (of `2^tiles_per_bucket_log2`) of bucket `bucket`.
#[inline]
pub fn tile_slot(bucket: u32, slot: u32, tiles_per_bucket_log2: u32) -> u32 {
    let log2 = min_u32(tiles_per_bucket_log2, MAX_NUM_TILES_LOG2);
    (bucket << log2) | (slot & ((1u32 << log2) - 1))
}

/// The world-space centre of a descriptor's cell on its two grid axes, and `along` (e.g. the hit
/// coordinate) on the dominant axis `axis` (0 = x). Used by debug views and tests.
#[inline]
pub fn cell_center(desc: &CellDescriptor, axis: u32, along: f32) -> Vec3 {
    let cell_size = desc.cell_size();
    let tile_size = cell_size * TILE_CELL_RATIO as f32;
    let corner = Vec3::new(
        desc.tile[0] as f32,
        desc.tile[1] as f32,
        desc.tile[2] as f32,
    ) * tile_size;
    let u = (desc.cell[0] as f32 + 0.5) * cell_size;
    let v = (desc.cell[1] as f32 + 0.5) * cell_size;
    match axis {
        0 => Vec3::new(along, corner.y + u, corner.z + v),
        1 => Vec3::new(corner.x + u, along, corner.z + v),
        _ => Vec3::new(corner.x + u, corner.y + v, along),
    }
}

/// Dominant axis of a direction (0 = x, 1 = y, 2 = z); ties prefer x, then y.
#[inline]
pub fn dominant_axis(direction: Vec3) -> u32 {
    let ad = Vec3::new(abs(direction.x), abs(direction.y), abs(direction.z));
    if ad.x >= ad.y && ad.x >= ad.z {
        0
    } else if ad.y >= ad.z {
        1
    } else {
        2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Random;
    use crate::sampling::sample_uniform_sphere;

    fn params() -> HashGridParams {
        let csc = cell_size_const(60f32.to_radians(), 1920, 1080, DEFAULT_CELL_SIZE_PIXELS);
        HashGridParams::new(Vec3::ZERO, csc, 0)
    }

    fn assert_valid(d: &CellDescriptor, p: &HashGridParams) {
        assert!(!d.is_none());
        assert!(d.checksum >= 1);
        assert!(d.bucket < 1 << p.num_buckets_log2.min(MAX_NUM_TILES_LOG2));
        assert!((MIN_LOD..=MAX_LOD).contains(&d.lod));
        assert!(d.tile.iter().all(|t| t.abs() <= MAX_TILE_COORD));
        assert!(d.cell.iter().all(|&c| c < TILE_CELL_RATIO));
        assert!(d.dir_bin.iter().all(|&b| b < DIRECTION_BINS));
        assert!(d.short_ray <= 1);
        assert!(d.cell_size().is_finite() && d.cell_size() > 0.0);
    }

    #[test]
    fn defaults() {
        assert_eq!(NUM_TILES, 65_536);
        assert_eq!(NUM_CELLS, 5_570_560);
        for m in 0..NUM_MIPS {
            assert_eq!(mip_offset(m), MIP_OFFSETS[m as usize]);
        }
        assert_eq!(mip_offset(9), 84);
        let csc = cell_size_const(60f32.to_radians(), 1920, 1080, 32.0);
        let expected = (60f64.to_radians() * 32.0 / 1080.0).tan() as f32;
        assert!((csc - expected).abs() < 1e-6 * expected, "{csc}");
        // Portrait: H/W² wins over 1/H.
        let portrait = cell_size_const(1.0, 500, 1000, 32.0);
        assert!((portrait - (32.0f32 * 1000.0 / 250_000.0).tan()).abs() < 1e-6);
        assert!(cell_size_const(1.0, 0, 0, 32.0).is_finite());
    }

    #[test]
    fn lod_matches_the_reference_formula() {
        let p = params();
        let mut rng = Random::new(1, 0);
        for _ in 0..100_000 {
            let dist = 10f32.powf(rng.next_f32() * 12.0 - 6.0);
            let pos = sample_uniform_sphere(rng.next_vec2()) * dist;
            let step =
                ((pos.as_dvec3().length()) * p.cell_size_const as f64).max(MIN_CELL_SIZE as f64);
            let exact = (1000.0 * step).log2();
            // Skip points within rounding distance of an LOD boundary.
            if (exact - exact.round()).abs() < 1e-5 {
                continue;
            }
            let expected = (exact.floor() as i32).clamp(MIN_LOD, MAX_LOD);
            assert_eq!(lod(Vec3::ZERO, pos, &p), expected, "dist {dist}");
        }
        // Close hits clamp to the minimum cell size: 0.1 m → 2^6 mm.
        assert_eq!(lod(Vec3::ZERO, Vec3::splat(1e-6), &p), 6);
        assert!(cell_size(Vec3::ZERO, Vec3::ZERO, &p) >= 0.064);
        // Overflowing distances clamp to MAX_LOD; NaN parameters to MIN_LOD.
        assert_eq!(lod(Vec3::splat(-3e38), Vec3::splat(3e38), &p), MAX_LOD);
        let mut nan = p;
        nan.cell_size_const = f32::NAN;
        nan.min_cell_size = f32::NAN;
        assert_eq!(lod(Vec3::ZERO, Vec3::ONE, &nan), MIN_LOD);
        let mut zero = p;
        zero.min_cell_size = 0.0;
        assert_eq!(lod(Vec3::ZERO, Vec3::ZERO, &zero), MIN_LOD);
    }

    #[test]
    fn stable_and_finite_from_micro_to_mega_metres() {
        let p = params();
        let mut rng = Random::new(2, 0);
        for k in -6..=6 {
            let scale = 10f32.powi(k);
            for _ in 0..2_000 {
                let dir = sample_uniform_sphere(rng.next_vec2());
                let pos = (rng.next_vec2().extend(rng.next_f32()) * 2.0 - 1.0) * scale;
                for eye in [Vec3::ZERO, Vec3::new(-1e6, 3.0, 1e6), pos + dir * 0.5] {
                    let d = cell_descriptor(eye, pos, dir, 1.0, &p);
                    assert_valid(&d, &p);
                    // Deterministic.
                    assert_eq!(d, cell_descriptor(eye, pos, dir, 1.0, &p));
                    // The cell's centre (same LOD, same coordinate along the projection axis)
                    // maps back to the same cell: floors agree at every scale and sign. Skipped
                    // where the cell is below ~2^10 ulps of |p|: f32 cannot place its centre.
                    let axis = dominant_axis(dir);
                    if d.cell_size() < pos.abs().max_element() * 2f32.powi(-13) {
                        continue;
                    }
                    let c = cell_center(&d, axis, pos[axis as usize]);
                    assert_eq!(
                        cell_descriptor_at_lod(d.lod, c, dir, 1.0, &p),
                        d,
                        "{pos} {eye}"
                    );
                    let half = 0.5 * d.cell_size();
                    for i in 0..3 {
                        if i != axis as usize {
                            assert!((c[i] - pos[i]).abs() <= half * 1.0001 + 1e-6 * pos[i].abs());
                        }
                    }
                }
            }
        }
    }

    /// Scaling the eye, the hit, its distance and the minimum cell size by `2^k` (exact in
    /// `f32`) moves the LOD by `k` and keeps every other part of the key: the grid is the same
    /// relative to the scene from micrometre to kilometre scenes.
    #[test]
    fn the_grid_scales_with_the_scene() {
        let normal = params();
        let mut rng = Random::new(3, 0);
        for k in -24..=18 {
            let s = 2f32.powi(k);
            let scaled = HashGridParams {
                min_cell_size: normal.min_cell_size * s,
                ..normal
            };
            for _ in 0..500 {
                // Hits in a 6 m room seen from inside it.
                let eye = (rng.next_vec2().extend(rng.next_f32()) - 0.5) * 6.0;
                let pos = (rng.next_vec2().extend(rng.next_f32()) - 0.5) * 6.0;
                let dir = sample_uniform_sphere(rng.next_vec2());
                let hit = 6.0 * rng.next_f32();
                let a = cell_descriptor(eye, pos, dir, hit, &normal);
                let b = cell_descriptor(eye * s, pos * s, dir, hit * s, &scaled);
                assert_eq!(b.lod, a.lod + k, "scale 2^{k}: {pos} from {eye}");
                assert_eq!(
                    (b.tile, b.cell, b.dir_bin, b.short_ray),
                    (a.tile, a.cell, a.dir_bin, a.short_ray),
                    "scale 2^{k}: {pos} from {eye}"
                );
            }
        }
    }

    #[test]
    fn non_finite_inputs_give_no_cell() {
        let p = params();
        let ok = (Vec3::ONE, Vec3::new(3.0, -2.0, 1.0), Vec3::Z, 2.0);
        assert!(!cell_descriptor(ok.0, ok.1, ok.2, ok.3, &p).is_none());
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for i in 0..3 {
                let mut v = Vec3::ONE;
                v[i] = bad;
                assert_eq!(
                    cell_descriptor(v, ok.1, ok.2, ok.3, &p),
                    CellDescriptor::NONE
                );
                assert_eq!(
                    cell_descriptor(ok.0, v, ok.2, ok.3, &p),
                    CellDescriptor::NONE
                );
                assert_eq!(
                    cell_descriptor(ok.0, ok.1, v, ok.3, &p),
                    CellDescriptor::NONE
                );
            }
            assert_eq!(
                cell_descriptor(ok.0, ok.1, ok.2, bad, &p),
                CellDescriptor::NONE
            );
        }
        assert!(cell_descriptor(ok.0, ok.1, Vec3::ZERO, ok.3, &p).is_none());
        assert_eq!(CellDescriptor::default(), CellDescriptor::NONE);
    }

    #[test]
    fn buckets_stay_in_range_for_every_bucket_count() {
        let mut rng = Random::new(3, 0);
        for log2 in [0, 1, 8, 12, 16, 17, 31, 32, 1000] {
            let mut p = params();
            p.num_buckets_log2 = log2;
            for _ in 0..5_000 {
                let pos = (rng.next_vec2().extend(rng.next_f32()) - 0.5) * 2e4;
                let dir = sample_uniform_sphere(rng.next_vec2());
                let d = cell_descriptor(Vec3::ZERO, pos, dir, rng.next_f32() * 10.0, &p);
                assert_valid(&d, &p);
            }
        }
    }

    #[test]
    fn key_components() {
        let p = params();
        // LOD 6 → cells of 64 mm, tiles of 512 mm.
        let d = cell_descriptor_at_lod(6, Vec3::new(-0.01, 0.07, 1.0), Vec3::X, 0.3, &p);
        assert_eq!(d.tile, [-1, 0, 1]);
        assert_eq!(d.cell, [1, 7]); // y: 0.07/0.064 → 1; z: 1.0/0.064 = 15.6 → 15 − 8
        assert_eq!(d.dir_bin, [4, 2, 2]);
        assert_eq!(d.short_ray, 1);
        let long = cell_descriptor_at_lod(6, Vec3::new(-0.01, 0.07, 1.0), Vec3::X, 0.6, &p);
        assert_eq!(long.short_ray, 0);
        assert_ne!(long.checksum, d.checksum);
        // Opposite directions land in different tiles of the cache.
        let back = cell_descriptor_at_lod(6, Vec3::new(-0.01, 0.07, 1.0), -Vec3::X, 0.3, &p);
        assert_eq!(back.dir_bin, [0, 2, 2]);
        assert_ne!(back.checksum, d.checksum);
        // Dominant-axis projection.
        let dz = cell_descriptor_at_lod(6, Vec3::new(-0.01, 0.07, 1.0), -Vec3::Z, 0.3, &p);
        assert_eq!(dz.cell, [7, 1]);
    }

    #[test]
    fn cell_indices() {
        assert_eq!(cell_index(0, 0, 0, 0), 0);
        assert_eq!(cell_index(1, 0, 7, 7), 85 + 63);
        assert_eq!(cell_index(2, 1, 3, 3), 170 + 64 + 3 + 12);
        assert_eq!(cell_index(0, 3, 0, 0), 84);
        assert_eq!(cell_index(NUM_TILES - 1, 3, 0, 0), NUM_CELLS - 1);
        // Out-of-range mips and coordinates clamp inside the tile.
        assert_eq!(cell_index(0, 7, 5, 5), 84);
        assert_eq!(cell_index(0, 0, 99, 0), 7);
        // Every (mip, x, y) of a tile is a distinct index in 0..85.
        let mut seen = [false; CELLS_PER_TILE as usize];
        for mip in 0..NUM_MIPS {
            let side = TILE_CELL_RATIO >> mip;
            for y in 0..side {
                for x in 0..side {
                    let i = cell_index(0, mip, x, y) as usize;
                    assert!(!seen[i]);
                    seen[i] = true;
                }
            }
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(tile_slot(3, 5, 4), 53);
        assert_eq!(tile_slot(3, 17, 4), 49);
    }
}
