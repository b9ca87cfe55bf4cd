//! The GI settings: one struct, each knob with what it costs and what it buys, and a default that
//! suits a frame of the given resolution.

use crate::error::{Error, Result};
use gi_shared::hash_cells::{
    DEFAULT_CELL_SIZE_PIXELS, MAX_NUM_TILES_LOG2, MAX_SAMPLE_COUNT, MIN_CELL_SIZE,
    TILES_PER_BUCKET_LOG2,
};
use gi_shared::layout::{MAX_FRAME_HEIGHT, MAX_FRAME_WIDTH};
use gi_shared::lights::MAX_LIGHT_CANDIDATES;
use gi_shared::screen_probes::PROBE_SIZE;
use gi_shared::screen_probes::interpolate::MAX_INTERPOLATION_JITTER_PIXELS;
use gi_shared::screen_space_gi::MAX_OCCLUSION_RADIUS_PIXELS;

/// Fewest tiles [`GiSettings::for_resolution`] gives a cache (2^11 = 2048 tiles: 1.4 MB of
/// values), so that a tiny image still has room for a whole small scene: with multi-bounce, the
/// cells that bounce rays reach about double a closed room's live tiles (a 64 × 64 view of
/// `indirect-room` overflowed 1024).
pub const MIN_AUTO_TILES_LOG2: u32 = 11;
/// Pixels per tile [`GiSettings::for_resolution`] budgets at the default cell size: one tile per
/// 32 pixels gives the reference's 65 536 tiles at 1920 × 1080.
pub const AUTO_PIXELS_PER_TILE: u64 = 32;
/// Times as many tiles [`GiSettings::with_cache_for`] budgets with multi-bounce: bounce rays reach
/// cells no probe ray does, about doubling a closed room's live tiles. Without the margin the
/// indirect room at 320 × 180 filled 2048 tiles; a full bucket then admits one new key per frame
/// (`gi_shared::hash_cells::full_buckets`), and the image read 0.3 points darker.
pub const MULTI_BOUNCE_TILE_FACTOR: u64 = 2;

/// Largest [`GiSettings::sample_cap`]: a cell's sum stays exact in `f32` far beyond it, and a
/// history of more than 1024 frames would answer to a change of light only after seconds.
pub const MAX_SAMPLE_CAP: u32 = 1024;
/// Largest [`GiSettings::interpolation_jitter_radius`], in probe tiles: the kernel's limit.
pub const MAX_INTERPOLATION_JITTER_TILES: f32 =
    (MAX_INTERPOLATION_JITTER_PIXELS / PROBE_SIZE) as f32;
/// The default [`GiSettings::interpolation_jitter_radius`], in probe tiles: the reference's ±16
/// pixels. The presets use one tile (`presets::PRESET_JITTER_TILES`): less relMSE, FLIP and
/// flicker (README, "Round 11" and "Round 16").
pub const DEFAULT_INTERPOLATION_JITTER_TILES: f32 = 2.0;

/// Everything a GI frame can be tuned by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GiSettings {
    /// `log2` of the hash grid's bucket count (each bucket holds
    /// `2^tiles_per_bucket_log2` tiles). Cost: every tile takes 85 cell values (1360 bytes) and
    /// 64 accumulators (1792 bytes), so each step doubles the cache's ~3.1 KB per tile. Quality:
    /// too few tiles and inserts fail (those rays get no cache light, counted as failed inserts)
    /// or live tiles crowd each other out. Default: [`GiSettings::for_resolution`] scales it
    /// with the pixel count (12 at 1920 × 1080, the reference's 4096 buckets).
    pub buckets_log2: u32,
    /// `log2` of the tiles per bucket (reference: 4, 16 tiles). Cost: an insert or a lookup scans
    /// up to this many keys. Quality: more slots per bucket means fewer failed inserts when
    /// hashes collide; the tile count is `2^(buckets_log2 + tiles_per_bucket_log2)`.
    pub tiles_per_bucket_log2: u32,
    /// Angular size of a cache cell, in pixels (reference: 32). Cost: smaller cells mean more
    /// tiles live at once (more memory, more failed inserts). Quality: larger cells average more
    /// samples (less noise) over a larger footprint (more bias: light and shadow smeared over
    /// the cell).
    pub cell_size_pixels: f32,
    /// Sample-count cap of a cache cell's history (reference: 16; 1 to [`MAX_SAMPLE_CAP`]), also
    /// the count below which a read steps to the coarser mip. Cost: none per frame. Quality: a
    /// higher cap averages more frames (less noise, slower response to changing light: the
    /// newest sample weighs 1/cap) and reads coarser mips for longer (more blur); a lower cap
    /// reacts faster and is noisier.
    pub sample_cap: u32,
    /// Time constant, in frames, over which a cache cell's samples fade (0: never, the
    /// reference; 1 to [`MAX_SAMPLE_CAP`]): each update of a tile weighs its cells' history
    /// `1 − 1/frames` first (`gi_shared::hash_cells::update`). Cost: none. Quality: without it a
    /// cell reached by few rays holds `sample_cap` samples from up to hundreds of frames ago, and
    /// multi-bounce, whose every bounce reads such cells, converges over hundreds of frames where
    /// most light is bounced (Bitterli staircase −19.5% after 64 frames); 12 frames took it to
    /// −13.7% and the Cornell box from −2.9% to −1.7% (balanced, 64 frames, 128 × 72), at 7%
    /// more relMSE on the staircase and 3% on the Cornell box. Lower is faster and noisier, and
    /// cells without recent samples read coarser mips. Default: 0, as in the reference; every
    /// preset sets [`gi_shared::hash_cells::HISTORY_FRAMES`] (12).
    pub cache_history_frames: u32,
    /// The cache's blend adapts to change (`gi_shared::hash_cells::adaptive_blend`; not in the
    /// reference): each tile pools its cells' luminance change per frame, and while the change
    /// is coherent (a light went off, on or moved) rather than noise, its cells' history weighs
    /// less than `sample_cap` samples, down to none. Cost: one more pass over the tile's 64
    /// accumulators in UpdateRadianceCache and one word of memory per tile. Quality: a light
    /// switched off leaves the cache within a few frames instead of circulating through the
    /// multi-bounce loop for tens (README "Response to change"); static lighting keeps its cap.
    /// Tiles that pool fewer than 4 samples a frame adapt less, and one sample not at all (its
    /// decision would follow its own noise). Bias: up to 1.5 points darker converged means (README
    /// "Bias budget"). Default: off, as in the reference; every preset turns it on.
    pub adaptive_cache_blend: bool,
    /// Smallest world-space cell, in scene units (reference: 0.1, for scenes in metres). Cost:
    /// none. Quality: stops cells near the camera from becoming so small that they never gather
    /// enough samples. It is the one length of the GI frame that does not follow the scene's
    /// scale (cells are otherwise sized by their angle from the eye, and ray offsets by the
    /// float spacing at the hit): a scene modelled in other units, or scaled, scales it alike, or
    /// its cells near the eye are too large (100 × too large for a room modelled in mm).
    pub min_cell_size: f32,
    /// Temporal radiance feedback (reference: on; every preset: off). Cost: a reprojection and a
    /// read per secondary hit, and it saves the shadow ray (and with [`Self::multi_bounce`] the
    /// bounce ray) of every hit that reprojects: no difference in lavapipe's frame time
    /// (`balanced`, 320 × 180). Quality: adds the previous frame's screen radiance to on-screen
    /// hits: multi-bounce at no ray cost, with a lag of a frame; without multi-bounce, off leaves
    /// secondary hits direct light only (one bounce). With multi-bounce it also feeds the screen's
    /// own biases (the hysteresis, the probes' spatial spread) back into the cache, where each
    /// bounce multiplies them: without it the `balanced` mean after 64 frames moves toward the
    /// path tracer on seven of the eight measured scenes (light leak −5.3 → +0.3 %, Cornell box
    /// converged −4.3 → −1.0 %), for a noisier cache where many small lights light it (bathroom
    /// relMSE +17 %) and more of a thin wall's leak (README, "Round 14").
    pub temporal_feedback: bool,
    /// Multi-bounce through the world cache (`gi_shared::multi_bounce`; not in the reference,
    /// which bounces only through temporal feedback): every query that takes a light sample
    /// also traces a cosine bounce ray and adds `albedo ×` the previous frame's cell at its hit,
    /// so a cell converges to its hit's whole reflected light and light that bounces off-screen
    /// is kept; a bounce whose cell is missing or stale carries its hit into the next frame as a
    /// query. Cost: one closest-hit ray and one cache lookup per light-sampled query (one per
    /// probe ray that neither misses nor reprojects), in PopulateRadianceCache, and the carried
    /// queries (about 10–20% more queries in a closed room, more tiles live); memory: the carried
    /// list and room for its queries and shadow rays (208 bytes per ray), and the cells' bounce
    /// copy, the 2-frame history bounces read (1.3 KiB per cache tile), allocated only with it.
    /// Quality: off, the cache holds direct light alone and further bounces come only from
    /// on-screen hits through feedback (a closed furnace of albedo 0.5 reads 1.75 of its exact
    /// 2.0, `indirect-room` −18%); on, the furnace converges (cache view −0.03%, GI frame −1.3%)
    /// and `indirect-room` reads −10.5%, but each further bounce arrives a frame later, so
    /// indirect light in bright rooms settles over more frames, and bounces read cells that
    /// straddle thin walls (README "Bias budget"). Default: off, as in the reference (these are
    /// its settings); every preset turns it on.
    pub multi_bounce: bool,
    /// World-space ReSTIR temporal reuse of the light samples at secondary hits (reference: off).
    /// Cost: three more passes (ClearReservoirs, CompactReservoirs with a prefix scan,
    /// ResampleReservoirs: about 10% of a 320 × 240 cache-view frame on lavapipe) and two
    /// reservoir grids (about 5 MB at 320 × 240). Quality: better light samples where many
    /// lights compete; measured on the test scenes after 64 frames it does not lower the error
    /// (the cache already averages samples over its cells) and it darkens where visibility
    /// differs between the hits that share reservoirs (Cornell box −0.6%, the partitioned
    /// `indirect-room` −3%, −12% without temporal feedback).
    pub restir: bool,
    /// The descriptor's short-ray flag, light-leak fix 1 (reference: on). Cost: up to twice the
    /// tiles near geometry. Quality: hits closer to their ray's origin than a tile use other
    /// cells than long rays reaching the same place, which keeps a thin wall's lit side from
    /// lighting its dark side.
    pub short_ray_flag: bool,
    /// Light-leak fix 2 (reference: on): rays whose hit is closer than a cell use their own
    /// unfiltered light sample instead of the cell's filtered radiance. Cost: none. Quality:
    /// less leaking through thin walls and into corners, more noise there.
    pub bypass: bool,
    /// RIS candidates of the primary hit's next-event estimate (1 to 64; reference path
    /// tracer: 8). Cost: a light sample each, no ray. Quality: picks the light that matters at
    /// each pixel where several compete.
    pub light_candidates: u32,
    /// How often a probe tile is traced: one probe per spawn tile of 8 × 8 (every tile, every
    /// frame), 16 × 16 (a quarter of the tiles per frame, the reference's default) or 32 × 32
    /// pixels. Cost: the frame's probe rays are 64 per spawn tile: one ray per pixel at
    /// [`SpawnRate::Full`], 1/4 and 1/16 ray per pixel below, and every per-probe pass scales
    /// with them. Quality: the untraced tiles reuse reprojected probes, so a lower rate means
    /// older, noisier light that reacts later to change.
    pub spawn_rate: SpawnRate,
    /// Temporal reprojection of last frame's probes (the seed pixel with the best reuse score
    /// per tile, a minimum in workgroup memory). Cost: one pass over the probe tiles. Quality:
    /// off, tiles not spawned this frame have no probe (interpolation must reach farther, or
    /// finds nothing) and nothing is left for ray guiding or hysteresis: much more noise.
    pub reprojection: bool,
    /// Parallax-corrected re-binning of every reprojected and gathered cell. Cost: a direction
    /// per cell. Quality: off, a cell keeps its direction when its probe moves, which shifts
    /// near geometry's light in the probe: bias under motion.
    pub parallax: bool,
    /// Radiance backup: cells left empty take their probe's mean. Cost: negligible. Quality:
    /// off, empty cells read as black in the SH projection: darkening where rays are few.
    pub radiance_backup: bool,
    /// Probe patching (adaptive sampling): disoccluded tiles take over spawns of tiles that
    /// still hold a reprojected probe, so the ray budget goes where the screen has no probe.
    /// Cost: one small pass. Quality: off, disoccluded tiles wait for their spawn turn
    /// (up to 4 or 16 frames): holes filled by farther probes or the relaxed fallback.
    pub patching: bool,
    /// Ray guiding: each probe samples its cells by a CDF of the history's luminance × cosine.
    /// Cost: the history gather from the 3 × 3 neighbourhood and a scan per probe. Quality:
    /// more rays toward the bright cells: less noise, the same expectation per cell.
    pub ray_guiding: bool,
    /// Temporal hysteresis adaptive to change: each probe cell keeps an exponential average of
    /// about 8 frames while the probe's other cells hold still, and takes the new value at once
    /// where they change (a light switched off, a shadow arriving). Cost: negligible. Quality:
    /// off, fireflies of single rays reach the image; on, they are spread over frames without
    /// moving the cell's mean (the weight never looks at the cell's own new value), at the price
    /// of up to 8 frames of lag where only part of a probe's lighting changes.
    pub hysteresis: bool,
    /// The 7 × 7 separable probe filter (plane-distance, normal and same-hit-point rejection:
    /// a neighbour's cell counts where it saw what the centre's saw). Cost: two
    /// passes over every probe. Quality: off, each probe keeps the noise of its own 64 rays.
    pub probe_filter: bool,
    /// Blue-noise jitter of the per-pixel probe lookup, by up to
    /// [`Self::interpolation_jitter_radius`]. Cost: a G-buffer read per pixel. Quality: hides the
    /// probe grid's blocks behind noise the denoiser removes.
    pub interpolation_jitter: bool,
    /// How far the jitter moves a pixel's probe lookup along each axis, in probe tiles (8
    /// pixels), 0 to [`MAX_INTERPOLATION_JITTER_TILES`]. Cost: none. Quality: the farther, the
    /// smoother the probe grid's blocks, but also the more a lit surface and its shadowed part
    /// (any two pixels on one plane) share their probes: light moves across shadow edges and
    /// relMSE rises (README, "Round 11"). A radius is a share of the image that
    /// shrinks as the resolution grows.
    pub interpolation_jitter_radius: f32,
    /// Screen-space GI (`gi_shared::screen_space_gi`; the talk's horizon-based screen-space GI
    /// for detail smaller than the probes resolve): the search radius in pixels, 0 (off) to
    /// [`MAX_OCCLUSION_RADIUS_PIXELS`]. Each pixel finds the horizons of 2 screen slices from 4
    /// depth reads per side within the radius, reads its probes' SH through a cone around its
    /// bent normal that holds its visibility, and adds the light the hiding surfaces reflected
    /// in the previous frame (near-field). Cost: 16 depth reads per pixel and, per read that
    /// raises a horizon, an albedo, a normal and the previous frame's lighting, in
    /// InterpolateScreenProbes (lavapipe, `balanced` Cornell box at 320 × 180: that pass 4.6–5.0
    /// → 7.4–8.1 ms); no memory. Quality: contact shadows and creases, which the probes 8 pixels
    /// apart see past, darken as in the path tracer (README, "Round 27"); a thin object occludes
    /// like a wall behind it, and what is off screen does not occlude. The radius is in pixels,
    /// like the probes' spacing, so it reaches less of the scene as the resolution grows.
    /// Default: 0 (the reference has it; the defaults stay the port's reference settings
    /// without it); every preset sets [`crate::gi::presets::PRESET_OCCLUSION_RADIUS`] (16).
    pub occlusion_radius: u32,
    /// The relaxed fallback of interpolation: a pixel no probe matches takes the found probes
    /// equally (hinted to the denoiser). Cost: none. Quality: off, such pixels get no indirect
    /// light (black holes at disocclusions and thin features).
    pub relaxed_fallback: bool,
    /// The denoiser's temporal reprojection of irradiance (history up to 64 frames, capped by
    /// motion, vignette, each pixel's luminance change and the whole image's trend: down to 16
    /// frames while the image warms, so that it lags less, and to 4 after a sudden change of
    /// the light). Cost: one pass. Quality: off, the image shows each frame's probe noise.
    pub denoiser_temporal: bool,
    /// The denoiser's blur mask and separable bilateral filter, with a radius that shrinks as
    /// history grows and as the screen's blur cost rises. Cost: three passes. Quality: off,
    /// young history (disocclusions, motion) stays noisy.
    pub denoiser_spatial: bool,
    /// Moving objects: probe and denoiser history follow moving objects through the G-buffer's
    /// motion vectors. Cost: a motion read per pixel, a 3 × 3 solve where an object
    /// moved. Quality: off, the moving object's history lags behind it and it leaves a dark
    /// trail; static scenes render the same either way.
    pub object_motion: bool,
    /// Emitter sampling: the primary hit takes the emissive triangles' direct light from one
    /// light sample and shadow ray per pixel, and probe rays leave the emitters they hit to it
    /// (the sky stays in the probes). Cost: a shadow ray per pixel. Quality: the probes' cells
    /// average a small emitter's cosine over their solid angle and their direct light comes out
    /// blocky; with it, the converged error falls by three quarters where small emitters light
    /// the scene. The estimate joins the probes' irradiance before the denoiser, so one frame is
    /// also less noisy (`balanced`, the 64th frame at 128 × 72 against the path tracer, relMSE:
    /// Cornell box 0.023 → 0.005, staircase 0.091 → 0.027, bathroom 0.25 → 0.11; README, "Round
    /// 16"). On in every preset; off in [`Default`], the reference's settings. Scenes without
    /// emissive triangles render the same either way.
    pub emitter_sampling: bool,
}

/// The screen probes' spawn rate: one probe traced per spawn tile per frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpawnRate {
    /// Spawn tiles of 8 × 8 pixels: every probe tile traced every frame.
    Full,
    /// Spawn tiles of 16 × 16 pixels (the reference's default).
    Quarter,
    /// Spawn tiles of 32 × 32 pixels.
    Sixteenth,
}

impl SpawnRate {
    /// The spawn tile's side in pixels.
    pub fn tile(self) -> u32 {
        match self {
            Self::Full => gi_shared::screen_probes::SPAWN_TILE_FULL,
            Self::Quarter => gi_shared::screen_probes::SPAWN_TILE_QUARTER,
            Self::Sixteenth => gi_shared::screen_probes::SPAWN_TILE_SIXTEENTH,
        }
    }
}

impl Default for GiSettings {
    /// The reference's settings at 1920 × 1080.
    fn default() -> Self {
        Self {
            buckets_log2: gi_shared::hash_cells::NUM_BUCKETS_LOG2,
            tiles_per_bucket_log2: TILES_PER_BUCKET_LOG2,
            cell_size_pixels: DEFAULT_CELL_SIZE_PIXELS,
            sample_cap: MAX_SAMPLE_COUNT,
            cache_history_frames: 0,
            adaptive_cache_blend: false,
            min_cell_size: MIN_CELL_SIZE,
            temporal_feedback: true,
            multi_bounce: false,
            restir: false,
            short_ray_flag: true,
            bypass: true,
            light_candidates: 8,
            spawn_rate: SpawnRate::Quarter,
            reprojection: true,
            parallax: true,
            radiance_backup: true,
            patching: true,
            ray_guiding: true,
            hysteresis: true,
            probe_filter: true,
            interpolation_jitter: true,
            interpolation_jitter_radius: DEFAULT_INTERPOLATION_JITTER_TILES,
            occlusion_radius: 0,
            relaxed_fallback: true,
            denoiser_temporal: true,
            denoiser_spatial: true,
            object_motion: true,
            emitter_sampling: false,
        }
    }
}

impl GiSettings {
    /// The interpolation jitter's radius in pixels (`GiFrameParams::interpolation_jitter`): 0
    /// with the jitter off.
    pub fn interpolation_jitter_pixels(&self) -> u32 {
        if self.interpolation_jitter {
            (self.interpolation_jitter_radius * PROBE_SIZE as f32).round() as u32
        } else {
            0
        }
    }

    /// The defaults with the cache sized for a `width × height` frame ([`Self::with_cache_for`]).
    pub fn for_resolution(width: u32, height: u32) -> Self {
        Self::default().with_cache_for(width, height)
    }

    /// `self` with [`Self::buckets_log2`] sized for a `width × height` frame at
    /// `self`'s cell size and tiles per bucket: one tile per [`AUTO_PIXELS_PER_TILE`] pixels at
    /// the default cell size, and `(default / cell)²` times as many for smaller cells (a cell
    /// spans fewer pixels, so more cells are live), [`MULTI_BOUNCE_TILE_FACTOR`] times as many
    /// with multi-bounce, rounded up to a power of two, between
    /// 2^[`MIN_AUTO_TILES_LOG2`] and 2^[`MAX_NUM_TILES_LOG2`] tiles. Larger cells keep the
    /// default cell's count. Call it after changing the cell size: cells of 8 pixels in a cache
    /// sized for 32 filled every tile at 128 × 72 and darkened the image by 11 points.
    pub fn with_cache_for(self, width: u32, height: u32) -> Self {
        let pixels = u64::from(width) * u64::from(height);
        let finer = (DEFAULT_CELL_SIZE_PIXELS / self.cell_size_pixels).max(1.0);
        // At most 2^MAX_NUM_TILES_LOG2 tiles whatever the factor (NaN saturates to 0).
        let factor = (finer * finer).min((1u64 << MAX_NUM_TILES_LOG2) as f32) as u64;
        let bounce = if self.multi_bounce {
            MULTI_BOUNCE_TILE_FACTOR
        } else {
            1
        };
        let tiles = pixels
            .div_ceil(AUTO_PIXELS_PER_TILE)
            .saturating_mul(factor.max(1))
            .saturating_mul(bounce);
        let tiles_log2 = tiles
            .max(1)
            .checked_next_power_of_two()
            .map_or(MAX_NUM_TILES_LOG2, u64::trailing_zeros)
            .clamp(MIN_AUTO_TILES_LOG2, MAX_NUM_TILES_LOG2)
            .max(self.tiles_per_bucket_log2.saturating_add(1));
        self.with_tiles_log2(tiles_log2)
    }

    /// `self` with a cache of `2^tiles_log2` tiles at `self`'s tiles per bucket (too few for two
    /// buckets, or over 2^[`MAX_NUM_TILES_LOG2`], and [`Self::validate`] names it).
    pub fn with_tiles_log2(self, tiles_log2: u32) -> Self {
        Self {
            buckets_log2: tiles_log2.saturating_sub(self.tiles_per_bucket_log2),
            ..self
        }
    }

    /// The tile count, `2^(buckets_log2 + tiles_per_bucket_log2)`.
    pub fn tile_count(&self) -> u32 {
        1 << (self.buckets_log2 + self.tiles_per_bucket_log2)
    }

    /// Checks every knob and the frame size, naming the first that is out of range.
    pub fn validate(&self, width: u32, height: u32) -> Result<()> {
        let bad = |name: &'static str, why: String| Err(Error::InvalidArgument { name, why });
        if width == 0 || height == 0 || width > MAX_FRAME_WIDTH || height > MAX_FRAME_HEIGHT {
            return bad(
                "resolution",
                format!(
                    "{width}x{height}: each side must be 1 to {MAX_FRAME_WIDTH}x{MAX_FRAME_HEIGHT}"
                ),
            );
        }
        if self.buckets_log2 == 0 {
            return bad(
                "buckets_log2",
                "0: the cache needs at least 2 buckets".into(),
            );
        }
        if self
            .buckets_log2
            .checked_add(self.tiles_per_bucket_log2)
            .is_none_or(|log2| log2 > MAX_NUM_TILES_LOG2)
        {
            return bad(
                "buckets_log2",
                format!(
                    "{} buckets × {} tiles per bucket (log2 {} + {}): at most 2^{MAX_NUM_TILES_LOG2} \
                     tiles fit one storage binding",
                    1u64 << self.buckets_log2.min(63),
                    1u64 << self.tiles_per_bucket_log2.min(63),
                    self.buckets_log2,
                    self.tiles_per_bucket_log2
                ),
            );
        }
        if !(self.cell_size_pixels.is_finite() && self.cell_size_pixels > 0.0) {
            return bad(
                "cell_size_pixels",
                format!(
                    "{}: must be a positive number of pixels",
                    self.cell_size_pixels
                ),
            );
        }
        if self.sample_cap == 0 || self.sample_cap > MAX_SAMPLE_CAP {
            return bad(
                "sample_cap",
                format!("{}: must be 1 to {MAX_SAMPLE_CAP}", self.sample_cap),
            );
        }
        if self.cache_history_frames > MAX_SAMPLE_CAP {
            return bad(
                "cache_history_frames",
                format!(
                    "{}: must be 0 (no fading) to {MAX_SAMPLE_CAP}",
                    self.cache_history_frames
                ),
            );
        }
        if !(self.min_cell_size.is_finite() && self.min_cell_size >= 0.0) {
            return bad(
                "min_cell_size",
                format!(
                    "{}: must be a finite size ≥ 0 in metres",
                    self.min_cell_size
                ),
            );
        }
        let jitter = self.interpolation_jitter_radius;
        if !(jitter.is_finite() && (0.0..=MAX_INTERPOLATION_JITTER_TILES).contains(&jitter)) {
            return bad(
                "interpolation_jitter_radius",
                format!("{jitter}: must be 0 to {MAX_INTERPOLATION_JITTER_TILES} probe tiles"),
            );
        }
        if self.occlusion_radius > MAX_OCCLUSION_RADIUS_PIXELS {
            return bad(
                "occlusion_radius",
                format!(
                    "{}: must be 0 (off) to {MAX_OCCLUSION_RADIUS_PIXELS} pixels",
                    self.occlusion_radius
                ),
            );
        }
        if self.light_candidates == 0 || self.light_candidates > MAX_LIGHT_CANDIDATES {
            return bad(
                "light_candidates",
                format!(
                    "{}: must be 1 to {MAX_LIGHT_CANDIDATES}",
                    self.light_candidates
                ),
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_jitter_radius_is_in_probe_tiles_and_zero_when_off() {
        let s = |radius, on| GiSettings {
            interpolation_jitter_radius: radius,
            interpolation_jitter: on,
            ..GiSettings::default()
        };
        assert_eq!(s(1.0, true).interpolation_jitter_pixels(), 8);
        // The default is the reference's ±16 pixels.
        assert_eq!(GiSettings::default().interpolation_jitter_pixels(), 16);
        assert_eq!(s(0.5, true).interpolation_jitter_pixels(), 4);
        assert_eq!(s(0.0, true).interpolation_jitter_pixels(), 0);
        assert_eq!(s(2.0, false).interpolation_jitter_pixels(), 0);
        // The largest radius the settings accept is the largest the kernel reaches.
        assert_eq!(
            s(MAX_INTERPOLATION_JITTER_TILES, true).interpolation_jitter_pixels(),
            MAX_INTERPOLATION_JITTER_PIXELS
        );
    }

    #[test]
    fn the_cache_scales_with_the_resolution() {
        assert_eq!(GiSettings::for_resolution(1920, 1080).tile_count(), 1 << 16);
        assert_eq!(
            GiSettings::for_resolution(1920, 1080),
            GiSettings::default()
        );
        assert_eq!(GiSettings::for_resolution(64, 64).tile_count(), 1 << 11);
        assert_eq!(GiSettings::for_resolution(640, 480).tile_count(), 1 << 14);
        assert_eq!(GiSettings::for_resolution(1, 1).tile_count(), 1 << 11);
        for (w, h) in [(1, 1), (64, 48), (3840, 2160)] {
            GiSettings::for_resolution(w, h).validate(w, h).unwrap();
        }
    }

    #[test]
    fn smaller_cells_get_a_larger_cache() {
        let cells = |px: f32, w, h| {
            GiSettings {
                cell_size_pixels: px,
                ..GiSettings::default()
            }
            .with_cache_for(w, h)
        };
        // 128 × 72: 288 tiles' worth of 32-pixel cells (the floor, 2048), 16 × as many of 8.
        assert_eq!(cells(32.0, 128, 72).tile_count(), 1 << 11);
        assert_eq!(cells(8.0, 128, 72).tile_count(), 1 << 13);
        assert_eq!(cells(16.0, 640, 480).tile_count(), 1 << 16);
        // Larger cells keep the default's count; the ceiling holds for any cell.
        assert_eq!(cells(64.0, 640, 480).tile_count(), 1 << 14);
        for px in [1e-30, 0.5, f32::NAN] {
            let s = cells(px, 3840, 2160);
            assert_eq!(s.tile_count(), 1 << MAX_NUM_TILES_LOG2, "{px}");
        }
        // Tiles per bucket are kept; the buckets make up the rest.
        let wide = GiSettings {
            tiles_per_bucket_log2: 6,
            cell_size_pixels: 8.0,
            ..GiSettings::default()
        }
        .with_cache_for(128, 72);
        assert_eq!((wide.buckets_log2, wide.tile_count()), (7, 1 << 13));
        // Multi-bounce doubles the budget: 320 × 180 is 1800 tiles' worth, 3600 with it.
        let bouncing = |on| {
            GiSettings {
                multi_bounce: on,
                ..GiSettings::default()
            }
            .with_cache_for(320, 180)
            .tile_count()
        };
        assert_eq!((bouncing(false), bouncing(true)), (1 << 11, 1 << 12));
    }

    #[test]
    fn bad_settings_name_the_setting() {
        let ok = GiSettings::for_resolution(64, 64);
        let name = |s: GiSettings, w, h| match s.validate(w, h) {
            Err(Error::InvalidArgument { name, .. }) => name,
            other => panic!("{other:?}"),
        };
        assert_eq!(name(ok, 0, 64), "resolution");
        assert_eq!(name(ok, 64, 100_000), "resolution");
        let zero = GiSettings {
            buckets_log2: 0,
            ..ok
        };
        assert_eq!(name(zero, 64, 64), "buckets_log2");
        let huge = GiSettings {
            buckets_log2: 40,
            ..ok
        };
        assert_eq!(name(huge, 64, 64), "buckets_log2");
        let cells = GiSettings {
            cell_size_pixels: f32::NAN,
            ..ok
        };
        assert_eq!(name(cells, 64, 64), "cell_size_pixels");
        let min = GiSettings {
            min_cell_size: -1.0,
            ..ok
        };
        assert_eq!(name(min, 64, 64), "min_cell_size");
        let fading = GiSettings {
            cache_history_frames: MAX_SAMPLE_CAP + 1,
            ..ok
        };
        assert_eq!(name(fading, 64, 64), "cache_history_frames");
        for sample_cap in [0, MAX_SAMPLE_CAP + 1] {
            let cap = GiSettings { sample_cap, ..ok };
            assert_eq!(name(cap, 64, 64), "sample_cap");
        }
        let cands = GiSettings {
            light_candidates: 0,
            ..ok
        };
        assert_eq!(name(cands, 64, 64), "light_candidates");
        let occlusion = GiSettings {
            occlusion_radius: MAX_OCCLUSION_RADIUS_PIXELS + 1,
            ..ok
        };
        assert_eq!(name(occlusion, 64, 64), "occlusion_radius");
        for radius in [
            -0.5,
            MAX_INTERPOLATION_JITTER_TILES + 0.5,
            f32::NAN,
            f32::INFINITY,
        ] {
            let jitter = GiSettings {
                interpolation_jitter_radius: radius,
                ..ok
            };
            assert_eq!(name(jitter, 64, 64), "interpolation_jitter_radius");
        }
    }
}
