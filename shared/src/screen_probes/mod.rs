//! GI-1.0's first cache level: screen-space probes. One probe per 8 × 8 pixel *probe tile*,
//! holding 8 × 8 hemispherical cells (equal-area hemi-octahedral map around its seed pixel's
//! geometric normal), refreshed by tracing at a *spawn rate* and otherwise carried over frames by
//! reprojection.
//!
//! This module holds what every screen-probe pass shares: the frame's parameters
//! ([`GiFrameParams`], a storage buffer every GI kernel binds), the technique switches (`FLAG_*`),
//! the counter words, the per-probe and per-ray layouts and the probe mask's mip chain. One
//! submodule per technique, named with the talk's words, holds its per-item math, which the
//! kernels of the same name run and the CPU tests.
//!
//! # Buffers (per frame resolution; `P` = probe tiles, `S` = spawn tiles)
//!
//! | buffer            | element              | count       | written by |
//! |-------------------|----------------------|-------------|------------|
//! | probe records ×2  | [`ProbeRecord`]      | `P`         | ReprojectScreenProbes, BlendScreenProbes |
//! | probe mask ×2     | `u32` packed seed    | [`mask_words`] | Reproject/Blend (mip 0), FilterProbeMask |
//! | probe atlas ×2    | [`StoredCell`]       | `P × 64`    | Reproject, Blend |
//! | spawns            | `u32` packed seed    | `S`         | SpawnScreenProbes, PatchScreenProbes |
//! | empty tiles       | `u32` probe tile     | `P`         | ReprojectScreenProbes |
//! | overrides         | `u32` spawn index    | `S`         | SpawnScreenProbes |
//! | probe history     | [`StoredCell`]       | `S × 64`    | SampleScreenProbes (ray guiding) |
//! | probe rays        | [`ProbeRay`]         | `S × 64`    | SampleScreenProbes, PopulateScreenProbes |
//! | filtered ×2       | [`StoredCell`]       | `P × 64`    | FilterScreenProbes (H, then V) |
//! | probe SH          | `[f32; 4]` × 9       | `P × 9`     | ProjectScreenProbes |
//! | counters          | `u32`                | [`GI_COUNTER_WORDS`] | every appending pass |
//!
//! A cell is `[r, g, b, hit distance]`: radiance arriving from the cell's directions and the
//! distance to what it saw ([`MISS_DISTANCE`] for the sky); a hit distance below zero
//! ([`EMPTY_CELL`]) marks a cell without radiance. Probe `p`'s cells are `p × 64 + x + 8 · y`.
//!
//! The probe rays' radiance lives in the cache passes' per-ray records
//! (`cache_view::RayRecord::ray_radiance`, indexed by the ray index `spawn × 64 + lane`),
//! so that InsertRadianceCache ... ResolveRadianceCache complete them unchanged.

use bytemuck::{Pod, Zeroable};
use glam::{UVec2, Vec3, Vec4};

use crate::math::max_u32;
use crate::packing::{
    SEED_NONE, WIDE16_MANTISSA_BITS, pack_wide16x4_dithered, running_mean_dither, unpack_seed,
    unpack_snorm10x3, unpack_wide16x4,
};
use crate::screen_space_gi::HorizonSearch;

pub mod blend;
pub mod hemisphere;
pub mod hysteresis;
pub mod interpolate;
pub mod patch;
pub mod probe_filter;
pub mod probe_mask;
pub mod radiance_backup;
pub mod ray_guiding;
pub mod reproject;
pub mod reuse;
pub mod sh_projection;
pub mod spawn;

/// Pixels along a probe tile's side, and cells along a probe's side.
pub const PROBE_SIZE: u32 = 8;
/// Cells of a probe (one ray each when spawned).
pub const PROBE_CELLS: u32 = PROBE_SIZE * PROBE_SIZE;
/// Invocations of a per-probe workgroup: one per cell.
pub const LANES: usize = PROBE_CELLS as usize;
/// Mask texel of a probe tile without a probe.
pub const NO_PROBE: u32 = SEED_NONE;
/// Hit distance of a ray that missed (the reference's `MAX_HIT_DISTANCE`, 10⁹, rounded to 2^30 so
/// that a [`StoredCell`] holds it exactly).
pub const MISS_DISTANCE: f32 = 1_073_741_824.0;
/// Hit distance of a cell without radiance.
pub const EMPTY_CELL: f32 = -1.0;
/// Probe reuse: at most this plane distance, in units of the probe cell size (reference: 1).
pub const REUSE_PLANE_DISTANCE: f32 = 1.0;
/// Probe reuse: the normals' dot product must exceed this (reference: 0.95).
pub const REUSE_MIN_NORMAL_DOT: f32 = 0.95;
/// The screen-probe cell size in pixels of `hash_cells::cell_size_const` (plane tolerance).
pub const PROBE_CELL_PIXELS: f32 = 8.0;

/// Spawn tile of rate 1 (one probe per probe tile per frame).
pub const SPAWN_TILE_FULL: u32 = 8;
/// Spawn tile of rate 1/4 (the default).
pub const SPAWN_TILE_QUARTER: u32 = 16;
/// Spawn tile of rate 1/16.
pub const SPAWN_TILE_SIXTEENTH: u32 = 32;

/// [`GiFrameParams::flags`]: the previous frame's probes, denoiser history and image exist.
pub const FLAG_HISTORY: u32 = 1;
/// Temporal reprojection of last frame's probes (off: every probe tile starts empty each frame).
pub const FLAG_REPROJECTION: u32 = 1 << 1;
/// Parallax-corrected re-binning of reprojected and gathered cells (off: a cell keeps its
/// direction).
pub const FLAG_PARALLAX: u32 = 1 << 2;
/// Radiance backup for cells left empty.
pub const FLAG_RADIANCE_BACKUP: u32 = 1 << 3;
/// Probe patching of disoccluded tiles through the override list.
pub const FLAG_PATCHING: u32 = 1 << 4;
/// Ray guiding from the history hemisphere (off: one ray per cell).
pub const FLAG_RAY_GUIDING: u32 = 1 << 5;
/// Shadow-preserving biased temporal hysteresis when blending.
pub const FLAG_HYSTERESIS: u32 = 1 << 6;
/// The 7 × 7 separable probe filter.
pub const FLAG_PROBE_FILTER: u32 = 1 << 8;
/// The relaxed fallback of per-pixel interpolation (off: a pixel without a matching probe gets
/// no indirect light).
pub const FLAG_RELAXED_FALLBACK: u32 = 1 << 10;
/// The denoiser's temporal reprojection of irradiance.
pub const FLAG_DENOISER_TEMPORAL: u32 = 1 << 11;
/// The denoiser's blur mask and separable bilateral filter.
pub const FLAG_DENOISER_SPATIAL: u32 = 1 << 12;
/// Direct light of punctual lights is resampled (too many to sum: one RIS sample and shadow ray
/// per pixel) instead of summed exactly.
pub const FLAG_SAMPLED_DIRECT: u32 = 1 << 13;
/// Per-object reprojection: probe and denoiser reprojection find a moving object's pixels in
/// the previous frame through the G-buffer's motion vectors ([`crate::gbuffer::previous_point`]),
/// so that history follows the object (off: the previous camera reprojects every surface point as
/// if the scene were static, and a moving object's history stays behind, a trail).
pub const FLAG_OBJECT_MOTION: u32 = 1 << 14;
/// Emitter sampling: DirectLight adds one light-sampled estimate of the emissive triangles'
/// direct light ([`crate::primary_lighting::emitter_light`]), and probe rays leave the emission
/// they hit to it ([`crate::world_cache::FLAG_EMITTERS_SAMPLED`]), so each path still counts once.
pub const FLAG_EMITTER_SAMPLING: u32 = 1 << 15;

/// Counter word: probes appended to the spawn list this frame.
pub const SPAWN_COUNT: usize = 0;
/// Counter word: empty tiles (no valid reprojected probe, not spawned) this frame.
pub const EMPTY_COUNT: usize = 1;
/// Counter word: spawns whose probe tile already held a reprojected probe (override slots).
pub const OVERRIDE_COUNT: usize = 2;
/// Counter word: empty tiles patched this frame.
pub const PATCHED_COUNT: usize = 3;
/// Counter word: probe tiles that reprojected a probe this frame.
pub const REPROJECTED_COUNT: usize = 4;
/// Counter word: blur taps of the denoiser's spatial filter this frame (FilterBlurMask).
pub const BLUR_TAPS: usize = 5;
/// Counter word: pixels whose interpolation fell back to the relaxed weights.
pub const RELAXED_COUNT: usize = 6;
/// [`crate::world_cache::pass_random`] stream of SampleScreenProbes.
pub const PASS_SAMPLE: u32 = 16;
/// Random stream of PatchScreenProbes.
pub const PASS_PATCH: u32 = 17;
/// Random stream of InterpolateScreenProbes (when not blue noise).
pub const PASS_INTERPOLATE: u32 = 18;
/// Random stream of the primary hit's direct light.
pub const PASS_DIRECT: u32 = 19;

/// Words of the GI counter buffer.
pub const GI_COUNTER_WORDS: usize = 8;

const _: () = assert!(RELAXED_COUNT < GI_COUNTER_WORDS);

/// The frame's parameters every GI kernel reads (a storage buffer the host writes per frame).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GiFrameParams {
    /// Image width and height.
    pub image_size: [u32; 2],
    /// Probe tiles across and down: `ceil(size / 8)`.
    pub probe_grid: [u32; 2],
    /// Spawn tiles across and down: `ceil(size / spawn_tile)`.
    pub spawn_grid: [u32; 2],
    /// Spawn tile side in pixels: [`SPAWN_TILE_FULL`], [`SPAWN_TILE_QUARTER`] or
    /// [`SPAWN_TILE_SIXTEENTH`].
    pub spawn_tile: u32,
    /// Frame counter (random streams, Halton jitter).
    pub frame_index: u32,
    /// `FLAG_*` switches.
    pub flags: u32,
    /// Seed of every random stream.
    pub seed: u32,
    /// Screen-probe cell size per unit of distance (`cell_size_const` with
    /// [`PROBE_CELL_PIXELS`]): the reuse plane tolerance at distance `d` is `d ×` this.
    pub probe_cell_const: f32,
    /// Mips of the probe mask ([`mask_mip_count`]).
    pub mask_mips: u32,
    /// Probe tiles: `probe_grid.x × probe_grid.y`.
    pub probe_count: u32,
    /// Spawn tiles: `spawn_grid.x × spawn_grid.y` (capacity of the spawn list).
    pub spawn_capacity: u32,
    /// Punctual lights at the front of the light buffer (point, spot, directional).
    pub punctual_count: u32,
    /// `maxComputeWorkGroupCount[0]`.
    pub max_groups: u32,
    /// The camera's position this frame.
    pub eye: [f32; 3],
    /// Factor on every surface's emission.
    pub emissive_multiplier: f32,
    /// The previous frame's camera position.
    pub previous_eye: [f32; 3],
    /// RIS candidates of sampled direct light.
    pub light_candidates: u32,
    /// Constant sky radiance where there is no environment image.
    pub sky: [f32; 3],
    /// Lights in the light buffer (punctual first, then triangles, then the environment).
    pub light_count: u32,
    /// Width and height of the environment image (zero for none: the sky is `sky`).
    pub environment_size: [u32; 2],
    /// Largest move of a pixel's probe lookup along each axis, in pixels (InterpolateScreenProbes'
    /// jitter, `crate::screen_probes::interpolate`); 0: no jitter.
    pub interpolation_jitter: u32,
    /// Screen-space GI's search radius in pixels (`crate::screen_space_gi`; at most
    /// `MAX_OCCLUSION_RADIUS_PIXELS`); 0: no occlusion.
    pub occlusion_radius: u32,
}

impl GiFrameParams {
    /// Whether every bit of `flag` is set.
    #[inline]
    pub fn has(&self, flag: u32) -> bool {
        self.flags & flag == flag
    }

    /// The probe tile of `pixel`, as an index.
    #[inline]
    pub fn probe_tile_of(&self, pixel: UVec2) -> u32 {
        (pixel.y / PROBE_SIZE) * self.probe_grid[0] + pixel.x / PROBE_SIZE
    }

    /// Screen-space GI's horizon search this frame.
    #[inline]
    pub fn horizon_search(&self) -> HorizonSearch {
        HorizonSearch {
            radius: self.occlusion_radius,
            frame_index: self.frame_index,
        }
    }

    /// The screen-probe cell size (reuse plane tolerance) at `distance` from the eye.
    #[inline]
    pub fn probe_cell_size(&self, distance: f32) -> f32 {
        distance * self.probe_cell_const * REUSE_PLANE_DISTANCE
    }
}

/// One probe (32 bytes): where its seed pixel's surface is.
///
/// | offset | field      |
/// |--------|------------|
/// | 0      | `position` |
/// | 12     | `normal`   |
/// | 16     | `seed`     |
/// | 20     | `depth`    |
/// | 24     | `age`      |
/// | 28     | `_pad`     |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ProbeRecord {
    /// World position of the seed pixel's surface, offset off it (rays start here).
    pub position: [f32; 3],
    /// Unit geometric normal facing the camera, `pack_snorm10x3`: the hemisphere's axis.
    pub normal: u32,
    /// The seed pixel, `pack_seed`; [`NO_PROBE`] when the tile has no probe.
    pub seed: u32,
    /// Linear depth of the seed pixel in the frame that wrote the record.
    pub depth: f32,
    /// Frames since the probe was last traced (0 = traced this frame).
    pub age: u32,
    /// Explicit padding.
    pub _pad: u32,
}

impl crate::layout::FloatLayout for ProbeRecord {
    const FLOAT_WORDS: &'static [u32] = &[0, 1, 2, 5];
}

impl ProbeRecord {
    /// A tile without a probe.
    pub const NONE: Self = Self {
        position: [0.0; 3],
        normal: 0,
        seed: NO_PROBE,
        depth: 0.0,
        age: 0,
        _pad: 0,
    };

    /// Whether the record holds a probe.
    #[inline]
    pub fn is_valid(&self) -> bool {
        self.seed != NO_PROBE
    }

    /// Position.
    #[inline]
    pub fn world_position(&self) -> Vec3 {
        Vec3::from_array(self.position)
    }

    /// Unit normal.
    #[inline]
    pub fn world_normal(&self) -> Vec3 {
        unpack_snorm10x3(self.normal).normalize_or_zero()
    }

    /// Seed pixel.
    #[inline]
    pub fn seed_pixel(&self) -> UVec2 {
        unpack_seed(self.seed)
    }

    /// The probe-age debug view's colour (ProbeAgeView): green for a probe traced this frame,
    /// through yellow to red at [`AGE_VIEW_OLDEST`] frames or more; black for a tile without one.
    #[inline]
    pub fn age_colour(&self) -> Vec3 {
        if !self.is_valid() {
            return Vec3::ZERO;
        }
        let t = crate::math::min_u32(self.age, AGE_VIEW_OLDEST) as f32 / AGE_VIEW_OLDEST as f32;
        Vec3::new(
            crate::math::min(2.0 * t, 1.0),
            crate::math::min(2.0 - 2.0 * t, 1.0),
            0.0,
        )
    }
}

/// The age at which ProbeAgeView's colour is fully red: `fast` traces each probe tile once in 16
/// frames, so an older probe missed its turn (its tile was reprojected instead).
pub const AGE_VIEW_OLDEST: u32 = 16;

/// One probe ray (32 bytes): written by SampleScreenProbes (direction, cell), completed by
/// PopulateScreenProbes (hit distance).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ProbeRay {
    /// Unit world direction; zero for a ray not to trace.
    pub direction: [f32; 3],
    /// The probe cell the direction lies in, `x + 8 · y`.
    pub cell: u32,
    /// Distance to the hit, [`MISS_DISTANCE`] for a miss.
    pub hit_distance: f32,
    /// Guided rays: the probability that one ray of the probe lands in this ray's cell (its
    /// share of the guiding CDF). 0 when the rays are not guided (each cell traces its own ray).
    pub cell_probability: f32,
    /// The weight of the ray's radiance in its cell, `sh_projection::cosine_weight`: its cosine to
    /// the probe's normal over the cell's mean cosine (0 for a ray not to trace).
    pub cosine_weight: f32,
    /// Explicit padding.
    pub _pad: u32,
}

impl crate::layout::FloatLayout for ProbeRay {
    const FLOAT_WORDS: &'static [u32] = &[0, 1, 2, 4, 5, 6];
}

/// A cell `[r, g, b, hit distance]` as radiance and distance.
#[inline]
pub fn cell_radiance(cell: [f32; 4]) -> Vec3 {
    Vec3::new(cell[0], cell[1], cell[2])
}

/// Whether a cell holds radiance.
#[inline]
pub fn cell_is_filled(cell: [f32; 4]) -> bool {
    cell[3] >= 0.0
}

/// A cell from radiance and hit distance.
#[inline]
pub fn make_cell(radiance: Vec3, hit_distance: f32) -> [f32; 4] {
    Vec4::new(radiance.x, radiance.y, radiance.z, hit_distance).to_array()
}

/// The empty cell.
pub const EMPTY: [f32; 4] = [0.0, 0.0, 0.0, EMPTY_CELL];

/// A cell as the probe buffers store it (atlas, probe history, the probe filter's output): its
/// `[r, g, b, hit distance]` as four [`crate::packing::pack_wide16`]s, 8 bytes instead of 16, at
/// 2^-10 of precision over any radiance and distance. Distance code 0 marks an empty cell (so a zeroed
/// buffer is empty); a filled cell's distance is at least [`crate::packing::WIDE16_MIN`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct StoredCell {
    /// `r | g << 16`, `b | hit distance << 16`.
    words: [u32; 2],
}

/// `cells` as the probe buffers store them (the CPU models' tests).
#[cfg(test)]
pub(crate) fn stored_cells(cells: &[[f32; 4]]) -> std::vec::Vec<StoredCell> {
    cells.iter().map(|&c| StoredCell::pack(c)).collect()
}

impl StoredCell {
    /// The empty cell, all zero bits.
    pub const EMPTY: Self = Self { words: [0; 2] };

    /// `cell` packed, rounded to nearest: negative radiance and NaN store 0; an empty cell stores
    /// distance code 0.
    #[inline]
    pub fn pack(cell: [f32; 4]) -> Self {
        Self::pack_dithered(cell, 0.5)
    }

    /// `cell` as the probe's running mean stores it in frame `frame` (BlendScreenProbes'
    /// hysteresis): rounded with [`running_mean_dither`], so that a cell keeps following a change
    /// smaller than the hysteresis's 8 frames times half a unit.
    #[inline]
    pub fn pack_running(cell: [f32; 4], frame: u32) -> Self {
        Self::pack_dithered(cell, running_mean_dither(Vec4::from_array(cell), frame))
    }

    /// [`Self::pack`] with [`pack_wide16x4_dithered`]'s rounding.
    #[inline]
    fn pack_dithered(cell: [f32; 4], dither: f32) -> Self {
        let [rg, b_distance] = pack_wide16x4_dithered(Vec4::from_array(cell), dither);
        let distance = if cell_is_filled(cell) {
            max_u32(b_distance >> 16, 1 << WIDE16_MANTISSA_BITS)
        } else {
            0
        };
        Self {
            words: [rg, (b_distance & 0xffff) | (distance << 16)],
        }
    }

    /// The cell [`Self::pack`] stored, [`EMPTY_CELL`] as the distance of an empty one.
    #[inline]
    pub fn unpack(self) -> [f32; 4] {
        let mut cell = unpack_wide16x4(self.words).to_array();
        if self.words[1] >> 16 == 0 {
            cell[3] = EMPTY_CELL;
        }
        cell
    }
}

/// Mips of the probe mask of a `grid` of probe tiles: down to 1 × 1.
#[inline]
pub fn mask_mip_count(grid: [u32; 2]) -> u32 {
    let mut n = 1;
    let mut w = grid[0];
    let mut h = grid[1];
    while w > 1 || h > 1 {
        w = w.div_ceil(2);
        h = h.div_ceil(2);
        n += 1;
    }
    n
}

/// Size of mip `mip` of the probe mask: `ceil(grid / 2^mip)`, at least 1.
#[inline]
pub fn mask_mip_size(grid: [u32; 2], mip: u32) -> [u32; 2] {
    let mut w = grid[0];
    let mut h = grid[1];
    let mut i = 0;
    while i < mip {
        w = w.div_ceil(2);
        h = h.div_ceil(2);
        i += 1;
    }
    [w.max(1), h.max(1)]
}

/// First word of mip `mip` in the mask buffer (mips stored one after another).
#[inline]
pub fn mask_mip_offset(grid: [u32; 2], mip: u32) -> u32 {
    let mut offset = 0;
    let mut i = 0;
    while i < mip {
        let s = mask_mip_size(grid, i);
        offset += s[0] * s[1];
        i += 1;
    }
    offset
}

/// Words of the whole mask chain.
#[inline]
pub fn mask_words(grid: [u32; 2]) -> u32 {
    mask_mip_offset(grid, mask_mip_count(grid))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stored_cells_keep_empty_filled_and_the_miss_apart() {
        use crate::packing::{WIDE16_MAX_RELATIVE_ERROR, WIDE16_MIN};
        // A zeroed buffer is empty; the empty cell round-trips.
        assert_eq!(StoredCell::default(), StoredCell::EMPTY);
        assert_eq!(StoredCell::EMPTY.unpack(), EMPTY);
        assert_eq!(StoredCell::pack(EMPTY), StoredCell::EMPTY);
        // A miss keeps its distance exactly; a hit at distance 0 stays filled.
        let miss = make_cell(Vec3::new(1e6, 0.5, 0.0), MISS_DISTANCE);
        assert_eq!(StoredCell::pack(miss).unpack()[3], MISS_DISTANCE);
        let touching = StoredCell::pack(make_cell(Vec3::ONE, 0.0)).unpack();
        assert!(cell_is_filled(touching) && touching[3] == WIDE16_MIN);
        // Radiance within the packing's precision; NaN and negative radiance store 0; a NaN
        // distance is empty.
        let c = make_cell(Vec3::new(1e6, 2.5e-7, 3.0), 17.5);
        let back = StoredCell::pack(c).unpack();
        for k in 0..4 {
            assert!(
                (back[k] - c[k]).abs() <= c[k] * WIDE16_MAX_RELATIVE_ERROR,
                "{back:?}"
            );
        }
        let bad = StoredCell::pack([f32::NAN, -1.0, f32::INFINITY, 2.0]).unpack();
        assert_eq!((bad[0], bad[1]), (0.0, 0.0));
        assert!(bad[2].is_finite() && bad[3] == 2.0);
        assert!(!cell_is_filled(
            StoredCell::pack([1.0, 1.0, 1.0, f32::NAN]).unpack()
        ));
        // The running mean's rounding: 0.3 of a unit above a code, its mean over frames is
        // the value (nearest rounding is 0.3 of a unit low).
        let lo = crate::packing::unpack_wide16(0x7e40);
        let x = lo + 0.3 * (crate::packing::unpack_wide16(0x7e41) - lo);
        let cell = make_cell(Vec3::splat(x), 1.0);
        let mean = (0..4096)
            .map(|f| f64::from(StoredCell::pack_running(cell, f).unpack()[0]))
            .sum::<f64>()
            / 4096.0;
        assert!((mean / f64::from(x) - 1.0).abs() < 2e-5, "{mean} for {x}");
        assert_eq!(StoredCell::pack(cell).unpack()[0], lo);
    }

    #[test]
    fn probe_age_colours_run_from_green_to_red() {
        let probe = |age| ProbeRecord {
            seed: 0,
            age,
            ..ProbeRecord::NONE
        };
        assert_eq!(ProbeRecord::NONE.age_colour(), Vec3::ZERO);
        assert_eq!(probe(0).age_colour(), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(
            probe(AGE_VIEW_OLDEST / 2).age_colour(),
            Vec3::new(1.0, 1.0, 0.0)
        );
        assert_eq!(
            probe(AGE_VIEW_OLDEST).age_colour(),
            Vec3::new(1.0, 0.0, 0.0)
        );
        assert_eq!(probe(u32::MAX).age_colour(), Vec3::new(1.0, 0.0, 0.0));
    }

    #[test]
    fn the_mask_chain_goes_down_to_one_texel() {
        let grid = [40, 23];
        assert_eq!(mask_mip_count(grid), 7);
        assert_eq!(mask_mip_size(grid, 1), [20, 12]);
        assert_eq!(mask_mip_size(grid, 6), [1, 1]);
        assert_eq!(mask_mip_offset(grid, 1), 920);
        assert_eq!(mask_words([1, 1]), 1);
        assert_eq!(mask_mip_count([1, 1]), 1);
    }

    #[test]
    fn layouts_are_their_documented_size() {
        use crate::layout::{FloatLayout, float_field_words};
        use core::mem::offset_of;
        assert_eq!(
            ProbeRay::FLOAT_WORDS,
            float_field_words(&[
                (offset_of!(ProbeRay, direction), 3),
                (offset_of!(ProbeRay, hit_distance), 1),
                (offset_of!(ProbeRay, cell_probability), 1),
                (offset_of!(ProbeRay, cosine_weight), 1)
            ])
        );
        assert_eq!(
            ProbeRecord::FLOAT_WORDS,
            float_field_words(&[
                (offset_of!(ProbeRecord, position), 3),
                (offset_of!(ProbeRecord, depth), 1)
            ])
        );
        assert_eq!(core::mem::size_of::<ProbeRecord>(), 32);
        assert_eq!(core::mem::size_of::<ProbeRay>(), 32);
        assert_eq!(core::mem::size_of::<GiFrameParams>() % 16, 0);
    }
}
