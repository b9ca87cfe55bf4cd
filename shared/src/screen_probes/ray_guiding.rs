//! SampleScreenProbes: the history hemisphere of a spawned probe and its ray guiding.
//!
//! One workgroup of 64 lanes per spawned probe. The *history hemisphere* is gathered from the
//! current (reprojected) probes of the 3 × 3 probe tiles around the seed's tile that pass the
//! reuse test: neighbour after neighbour, each lane maps one source cell into the new probe's
//! hemisphere ([`map_history_source`], into workgroup memory), then each lane gathers its target
//! cell (`hemisphere::gather_linked` over the lists of `hemisphere::link_mapped`) and adds it to
//! its running [`HistorySum`], the mean over the neighbours that filled the cell. *Ray guiding*
//! turns that mean into a CDF over the 64 cells (weight = luminance × cos θ, plus
//! [`GUIDING_UNIFORM_FRACTION`] of the mean weight everywhere so that no cell is ever
//! unreachable) and every lane draws one cell from it and a uniform direction inside that cell,
//! recording the cell's probability ([`cell_share`]) for BlendScreenProbes' estimate; without
//! guiding, lane `i` traces a uniform direction inside cell `i`. The history that BlendScreenProbes' hysteresis blends with is the probe's own: the cell
//! of the spawn's own tile's probe ([`OWN_NEIGHBOUR`]), the neighbourhood's mean only where that
//! is empty ([`blend_history`]). Averaging the neighbours over frames blurred the probe and moved
//! the converged mean by −6 to +4 points (README, "Bias budget").
//!
//! Phases of the workgroup, with a barrier after each (the kernel and [`sample_workgroup`] run
//! the same functions in the same order):
//! 1. for each of the [`HISTORY_NEIGHBOURS`] neighbours: [`map_history_source`] per lane (source
//!    cell), barrier, one lane links the cells' sources (`hemisphere::link_mapped`), barrier,
//!    `hemisphere::gather_linked` + [`HistorySum::add`] per lane (target cell,
//!    kept apart for the own tile), barrier;
//! 2. [`guiding_raw_weight`] per lane into workgroup memory, barrier;
//! 3. [`guiding_cdf`] per lane (inclusive prefix sum, each lane summing `0..=lane`), barrier;
//! 4. [`guiding_active`] and [`sample_ray`] per lane.

use super::StoredCell;
use glam::{UVec2, Vec3};

use super::hemisphere::{
    ProbeFrame, UNMAPPED, cell_coords, map_cell, record_frame, tangent_direction_in_cell,
};
use super::reuse::reuse_score;
use super::sh_projection::cosine_weight;
use super::{
    EMPTY, FLAG_HISTORY, FLAG_PARALLAX, FLAG_RAY_GUIDING, FLAG_REPROJECTION, GiFrameParams, LANES,
    PASS_SAMPLE, PROBE_CELLS, PROBE_SIZE, ProbeRay, ProbeRecord, cell_is_filled, cell_radiance,
    make_cell,
};
use crate::color::luminance;
use crate::octahedral::probe_cell_direction;
use crate::sampling::tangent_to_world;
use crate::world_cache::pass_random;

/// Share of the mean cell weight added to every cell of the guiding CDF, so that a light that
/// appears where the history was dark is still found. It also bounds the weight of a guided
/// cell's estimate (`blend::cell_estimate`): a cell is drawn with probability at least
/// `0.25 / (64 × 1.25)`, so one ray weighs at most 5 × its radiance. With 0.1 (this port's value
/// until issue 22's round 5, weights up to 11×) a moved light's share still missing after 15 frames was 0.113
/// (`light_change`), 0.078 with 0.25, and the living room's relMSE 0.40 against 0.37.
pub const GUIDING_UNIFORM_FRACTION: f32 = 0.25;

/// Probe tiles the history hemisphere gathers from: the 3 × 3 neighbourhood of the seed's tile.
pub const HISTORY_NEIGHBOURS: u32 = 9;

/// The neighbour `k` that is the spawn's own probe tile (the centre of the 3 × 3).
pub const OWN_NEIGHBOUR: u32 = 4;

/// The history cell hysteresis blends with: the own tile's probe's cell `own` (mapped into the
/// new hemisphere) where filled, else the neighbourhood's mean `mean`.
#[inline]
pub fn blend_history(own: [f32; 4], mean: [f32; 4]) -> [f32; 4] {
    if cell_is_filled(own) { own } else { mean }
}

/// Raw guiding weight of a cell without history ([`guiding_raw_weight`]); it takes the mean.
pub const NO_WEIGHT: f32 = -1.0;

/// History neighbour `k` (`0..9`, row by row from the top-left) of a probe with frame `frame`
/// whose seed pixel is `seed`: its probe tile and frame when the tile lies in the probe grid and
/// its current record holds a probe that may stand for the seed (`reuse_score`). `None` for
/// every `k` unless both [`FLAG_HISTORY`] and [`FLAG_REPROJECTION`] are set (no current probes
/// to gather from). The same for every lane of a workgroup.
#[inline]
pub fn history_neighbour(
    params: &GiFrameParams,
    records: &[ProbeRecord],
    seed: UVec2,
    frame: &ProbeFrame,
    k: u32,
) -> Option<(u32, ProbeFrame)> {
    if !params.has(FLAG_HISTORY | FLAG_REPROJECTION) || k >= HISTORY_NEIGHBOURS {
        return None;
    }
    let tx = (seed.x / PROBE_SIZE) as i32 + (k % 3) as i32 - 1;
    let ty = (seed.y / PROBE_SIZE) as i32 + (k / 3) as i32 - 1;
    if tx < 0 || ty < 0 || tx >= params.probe_grid[0] as i32 || ty >= params.probe_grid[1] as i32 {
        return None;
    }
    let tile = ty as u32 * params.probe_grid[0] + tx as u32;
    if tile as usize >= records.len() {
        return None;
    }
    let record = records[tile as usize];
    if !record.is_valid() {
        return None;
    }
    let source = record_frame(&record);
    reuse_score(
        params,
        source.position,
        source.normal,
        frame.position,
        frame.normal,
    )?;
    Some((tile, source))
}

/// Phase 1a, lane = source cell `lane` of the neighbour (`None`: no neighbour this round): the
/// target cell it maps to in `frame`'s hemisphere ([`UNMAPPED`] for none) and the cell as seen
/// from there; parallax-corrected with [`FLAG_PARALLAX`].
#[inline]
pub fn map_history_source(
    params: &GiFrameParams,
    atlas: &[StoredCell],
    neighbour: Option<(u32, ProbeFrame)>,
    frame: &ProbeFrame,
    lane: u32,
) -> (u32, [f32; 4]) {
    if let Some((tile, source)) = neighbour {
        let i = (tile * PROBE_CELLS + lane) as usize;
        if lane < PROBE_CELLS && i < atlas.len() {
            let cell = atlas[i].unpack();
            if let Some(mapped) = map_cell(&source, frame, lane, cell, params.has(FLAG_PARALLAX)) {
                return mapped;
            }
        }
    }
    (UNMAPPED, EMPTY)
}

/// One lane's running sum of the history cells gathered from the neighbours.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HistorySum {
    /// Sum of the gathered radiance.
    pub radiance: Vec3,
    /// Sum of the gathered hit distances.
    pub distance: f32,
    /// Neighbours that filled the cell.
    pub count: u32,
}

impl HistorySum {
    /// Nothing gathered yet.
    pub const ZERO: Self = Self {
        radiance: Vec3::ZERO,
        distance: 0.0,
        count: 0,
    };

    /// Phase 1b: adds one neighbour's gathered cell (nothing when it is empty).
    #[inline]
    pub fn add(&mut self, gathered: [f32; 4]) {
        if cell_is_filled(gathered) {
            self.radiance += cell_radiance(gathered);
            self.distance += gathered[3];
            self.count += 1;
        }
    }

    /// The history cell: the mean over the neighbours that filled it, [`EMPTY`] when none did.
    #[inline]
    pub fn cell(&self) -> [f32; 4] {
        if self.count == 0 {
            EMPTY
        } else {
            let inv = 1.0 / self.count as f32;
            make_cell(self.radiance * inv, self.distance * inv)
        }
    }
}

/// Phase 2, lane = cell `lane`: the cell's guiding weight from its history cell, luminance times
/// the cosine of its centre direction to the normal (non-finite or negative radiance counts as 0);
/// [`NO_WEIGHT`] for a cell without history.
#[inline]
pub fn guiding_raw_weight(history: [f32; 4], lane: u32) -> f32 {
    if !cell_is_filled(history) {
        return NO_WEIGHT;
    }
    let cos_theta = probe_cell_direction(cell_coords(lane), PROBE_SIZE).z;
    let w = luminance(cell_radiance(history)) * cos_theta;
    if w.is_finite() && w > 0.0 { w } else { 0.0 }
}

/// The mean raw weight of the cells with history (0 when none has).
#[inline]
pub fn guiding_mean(raw: &[f32; LANES]) -> f32 {
    let mut sum = 0.0;
    let mut n = 0u32;
    let mut i = 0;
    while i < LANES {
        let w = raw[i];
        if w >= 0.0 {
            sum += w;
            n += 1;
        }
        i += 1;
    }
    if n == 0 { 0.0 } else { sum / n as f32 }
}

/// A cell's weight in the CDF: its raw weight (the mean for a cell without history) plus
/// [`GUIDING_UNIFORM_FRACTION`] × the mean.
#[inline]
pub fn guiding_weight(raw: f32, mean: f32) -> f32 {
    let w = if raw >= 0.0 { raw } else { mean };
    w + GUIDING_UNIFORM_FRACTION * mean
}

/// Phase 3, lane = cell `lane`: the inclusive prefix sum of the CDF weights of cells
/// `0..=lane` (`raw` = the 64 raw weights of phase 2), summed in cell order so every lane and the
/// CPU agree bit for bit.
#[inline]
pub fn guiding_cdf(raw: &[f32; LANES], lane: u32) -> f32 {
    let mean = guiding_mean(raw);
    let mut sum = 0.0;
    let mut i = 0;
    while i <= lane as usize && i < LANES {
        sum += guiding_weight(raw[i], mean);
        i += 1;
    }
    sum
}

/// Whether the rays follow the CDF: [`FLAG_RAY_GUIDING`] is set and the CDF's total (its last
/// entry) is positive and finite, which needs at least one history cell with light.
#[inline]
pub fn guiding_active(params: &GiFrameParams, cdf: &[f32; LANES]) -> bool {
    if !params.has(FLAG_RAY_GUIDING) {
        return false;
    }
    let total = cdf[LANES - 1];
    total.is_finite() && total > 0.0
}

/// The cell whose CDF interval holds `x ∈ [0, total)`: the first `i` with `cdf[i] > x` (binary
/// search; the last cell when none is).
#[inline]
pub fn guided_cell(cdf: &[f32; LANES], x: f32) -> u32 {
    let mut lo = 0usize;
    let mut hi = LANES - 1;
    while lo < hi {
        let mid = (lo + hi) / 2;
        if cdf[mid] > x {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo as u32
}

/// The probability that a ray drawn from `cdf` lands in `cell`: its interval over the total.
#[inline]
pub fn cell_share(cdf: &[f32; LANES], cell: u32) -> f32 {
    let c = cell as usize;
    if c >= LANES {
        return 0.0;
    }
    let below = if c == 0 { 0.0 } else { cdf[c - 1] };
    (cdf[c] - below) / cdf[LANES - 1]
}

/// Phase 4, lane `lane` of spawn `spawn`: its ray. Guided: a cell drawn from `cdf` (one number of
/// the lane's [`PASS_SAMPLE`] stream) and a uniform direction inside it (two more); else a
/// uniform direction inside cell `lane`. The hit distance is PopulateScreenProbes' to fill.
#[inline]
pub fn sample_ray(
    params: &GiFrameParams,
    frame: &ProbeFrame,
    spawn: u32,
    lane: u32,
    cdf: &[f32; LANES],
    guided: bool,
) -> ProbeRay {
    let mut rng = pass_random(
        params.seed,
        spawn.wrapping_mul(PROBE_CELLS).wrapping_add(lane),
        PASS_SAMPLE,
        params.frame_index,
    );
    let (cell, cell_probability) = if guided {
        let total = cdf[LANES - 1];
        let cell = guided_cell(cdf, rng.next_f32() * total);
        (cell, cell_share(cdf, cell))
    } else {
        (lane % PROBE_CELLS, 0.0)
    };
    let tangent = tangent_direction_in_cell(cell, rng.next_vec2());
    ProbeRay {
        direction: tangent_to_world(tangent, frame.normal).to_array(),
        cell,
        hit_distance: 0.0,
        cell_probability,
        cosine_weight: cosine_weight(cell, tangent.z),
        _pad: 0,
    }
}

/// A ray not to trace (zero direction), for a spawn whose seed is no surface.
#[inline]
pub fn untraced_ray(lane: u32) -> ProbeRay {
    ProbeRay {
        direction: [0.0; 3],
        cell: lane % PROBE_CELLS,
        hit_distance: 0.0,
        cell_probability: 0.0,
        cosine_weight: 0.0,
        _pad: 0,
    }
}

/// What one SampleScreenProbes workgroup writes: the history hemisphere and the 64 rays.
#[cfg(not(target_arch = "spirv"))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledProbe {
    /// The history cell of each cell (`probe_history[spawn × 64 + cell]`).
    pub history: [[f32; 4]; LANES],
    /// The ray of each lane (`probe_rays[spawn × 64 + lane]`).
    pub rays: [ProbeRay; LANES],
    /// The CDF the rays followed (phase 3).
    pub cdf: [f32; LANES],
    /// Whether they followed it.
    pub guided: bool,
}

/// The CPU model of one SampleScreenProbes workgroup: spawn `spawn`, whose probe has frame `frame`
/// and seed pixel `seed`, over the current `records` and `atlas`. Runs the kernel's phases in
/// order, each over the lanes in lane order.
#[cfg(not(target_arch = "spirv"))]
pub fn sample_workgroup(
    params: &GiFrameParams,
    records: &[ProbeRecord],
    atlas: &[StoredCell],
    seed: UVec2,
    frame: &ProbeFrame,
    spawn: u32,
) -> SampledProbe {
    let mut mapped = [UNMAPPED; LANES];
    let mut moved = [EMPTY; LANES];
    let mut sums = [HistorySum::ZERO; LANES];
    let mut own = [EMPTY; LANES];
    let mut k = 0;
    while k < HISTORY_NEIGHBOURS {
        let neighbour = history_neighbour(params, records, seed, frame, k);
        for lane in 0..PROBE_CELLS {
            let (m, c) = map_history_source(params, atlas, neighbour, frame, lane);
            mapped[lane as usize] = m;
            moved[lane as usize] = c;
        }
        let (heads, next) = super::hemisphere::linked(&mapped);
        for lane in 0..PROBE_CELLS {
            let gathered = super::hemisphere::gather_linked(&heads, &next, &moved, lane);
            if k == OWN_NEIGHBOUR {
                own[lane as usize] = gathered;
            }
            sums[lane as usize].add(gathered);
        }
        k += 1;
    }
    let mean = sums.map(|s| s.cell());
    let mut raw = [0.0; LANES];
    for lane in 0..PROBE_CELLS {
        raw[lane as usize] = guiding_raw_weight(mean[lane as usize], lane);
    }
    let mut history = [EMPTY; LANES];
    for lane in 0..LANES {
        history[lane] = blend_history(own[lane], mean[lane]);
    }
    let mut cdf = [0.0; LANES];
    for lane in 0..PROBE_CELLS {
        cdf[lane as usize] = guiding_cdf(&raw, lane);
    }
    let guided = guiding_active(params, &cdf);
    let mut rays = [ProbeRay::default(); LANES];
    for lane in 0..PROBE_CELLS {
        rays[lane as usize] = sample_ray(params, frame, spawn, lane, &cdf, guided);
    }
    SampledProbe {
        history,
        rays,
        cdf,
        guided,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::{pack_seed, pack_snorm10x3};
    use crate::screen_probes::hemisphere::cell_index;

    /// Eye at the origin, probes 10 units ahead on the plane z = −10 facing it.
    fn params(flags: u32) -> GiFrameParams {
        GiFrameParams {
            image_size: [64, 64],
            probe_grid: [8, 8],
            probe_cell_const: 0.01,
            flags,
            seed: 7,
            ..Default::default()
        }
    }

    fn record(position: Vec3, normal: Vec3, seed: UVec2) -> ProbeRecord {
        ProbeRecord {
            position: position.to_array(),
            normal: pack_snorm10x3(normal),
            seed: pack_seed(seed),
            depth: -position.z,
            age: 0,
            _pad: 0,
        }
    }

    const ALL: u32 = FLAG_HISTORY | FLAG_REPROJECTION | FLAG_PARALLAX | FLAG_RAY_GUIDING;

    /// A spawned probe at `seed` on the plane, with a current probe at the same place in the tile
    /// to the right of the seed's (cells from `cell`, stored as the atlas stores them) and nothing
    /// else.
    fn scene(
        cell: impl Fn(u32) -> [f32; 4],
    ) -> (Vec<ProbeRecord>, Vec<StoredCell>, ProbeFrame, UVec2) {
        let seed = UVec2::new(20, 20);
        let p = Vec3::new(0.0, 0.0, -10.0);
        let n = Vec3::Z;
        let mut records = vec![ProbeRecord::NONE; 64];
        let mut atlas = vec![StoredCell::EMPTY; 64 * 64];
        let tile = (seed.y / 8) * 8 + seed.x / 8 + 1;
        records[tile as usize] = record(p, n, seed + UVec2::new(8, 0));
        for c in 0..PROBE_CELLS {
            atlas[(tile * 64 + c) as usize] = StoredCell::pack(cell(c));
        }
        let frame = record_frame(&records[tile as usize]);
        (records, atlas, frame, seed)
    }

    #[test]
    fn a_neighbour_at_the_same_place_hands_over_its_cells() {
        let (records, atlas, frame, seed) =
            scene(|c| make_cell(Vec3::new(c as f32, 1.0, 2.0), 3.0 + c as f32 * 0.01));
        let tile = 2 * 8 + 2 + 1;
        let out = sample_workgroup(&params(ALL), &records, &atlas, seed, &frame, 0);
        for c in 0..PROBE_CELLS {
            let expected = atlas[(tile * 64 + c) as usize].unpack();
            let got = out.history[c as usize];
            for k in 0..4 {
                assert!(
                    // Parallax's rounding, then the stored cell's.
                    (got[k] - expected[k]).abs()
                        < 1e-3 + expected[k].abs() * crate::packing::WIDE16_MAX_RELATIVE_ERROR,
                    "cell {c}: {got:?} vs {expected:?}"
                );
            }
        }
        // Without history (or without reprojection) nothing is gathered and every lane traces
        // its own cell.
        for flags in [ALL & !FLAG_HISTORY, ALL & !FLAG_REPROJECTION] {
            let out = sample_workgroup(&params(flags), &records, &atlas, seed, &frame, 0);
            assert!(out.history.iter().all(|&h| h == EMPTY));
            assert!(!out.guided);
            for (lane, ray) in out.rays.iter().enumerate() {
                assert_eq!(ray.cell, lane as u32);
                assert_eq!(
                    frame.direction_cell(Vec3::from_array(ray.direction)),
                    Some(ray.cell)
                );
            }
        }
    }

    #[test]
    fn the_own_tile_is_the_history_neighbours_guide_and_a_tilted_one_is_rejected() {
        let (mut records, mut atlas, frame, seed) = scene(|_| make_cell(Vec3::splat(1.0), 1e9));
        // A second probe at the same place in the seed's own tile, twice as bright.
        let own = (seed.y / 8) * 8 + seed.x / 8;
        records[own as usize] = records[own as usize + 1];
        for c in 0..64 {
            atlas[(own * 64 + c) as usize] = StoredCell::pack(make_cell(Vec3::splat(3.0), 1e9));
        }
        // A tilted probe below: fails the normal test.
        let below = own + 8;
        records[below as usize] = record(
            Vec3::new(0.0, 0.0, -10.0),
            Vec3::new(0.5, 0.0, 1.0).normalize(),
            seed + UVec2::new(0, 8),
        );
        for c in 0..64 {
            atlas[(below * 64 + c) as usize] = StoredCell::pack(make_cell(Vec3::splat(100.0), 1e9));
        }
        // The history is the own tile's probe; guiding follows the mean of the two (2).
        let out = sample_workgroup(&params(ALL), &records, &atlas, seed, &frame, 0);
        for h in out.history {
            assert!((h[0] - 3.0).abs() < 1e-5, "{h:?}");
        }
        let mut uniform = records.clone();
        uniform[(below) as usize] = ProbeRecord::NONE;
        let guided = sample_workgroup(&params(ALL), &uniform, &atlas, seed, &frame, 0);
        assert_eq!(guided.cdf, out.cdf);
        // Without a probe in its own tile, the neighbour's cells stand in.
        records[own as usize] = ProbeRecord::NONE;
        let out = sample_workgroup(&params(ALL), &records, &atlas, seed, &frame, 0);
        for h in out.history {
            assert!((h[0] - 1.0).abs() < 1e-5, "{h:?}");
        }
    }

    #[test]
    fn guiding_samples_bright_cells_more_and_every_cell_sometimes() {
        let bright = cell_index(UVec2::new(3, 4));
        // History: one bright cell, the rest black (zero weight); some cells without history.
        let (records, atlas, frame, seed) = scene(|c| {
            if c == bright {
                make_cell(Vec3::splat(50.0), 2.0)
            } else if c % 7 == 0 {
                EMPTY
            } else {
                make_cell(Vec3::ZERO, 2.0)
            }
        });
        let p = params(ALL);
        let mut counts = [0u32; 64];
        let draws = 800;
        for frame_index in 0..draws {
            let p = GiFrameParams { frame_index, ..p };
            let out = sample_workgroup(&p, &records, &atlas, seed, &frame, 3);
            assert!(out.guided);
            for ray in out.rays {
                counts[ray.cell as usize] += 1;
                let d = Vec3::from_array(ray.direction);
                assert!((d.length() - 1.0).abs() < 1e-4);
                assert_eq!(frame.direction_cell(d), Some(ray.cell));
            }
        }
        let total = (draws * 64) as f32;
        // The CDF's probabilities: every cell has a positive share.
        let out = sample_workgroup(&p, &records, &atlas, seed, &frame, 3);
        let mut last = 0.0;
        let mut probability = [0.0f32; 64];
        for (i, &c) in out.cdf.iter().enumerate() {
            assert!(c > last, "cell {i} has no weight");
            probability[i] = (c - last) / out.cdf[63];
            last = c;
        }
        assert!(probability[bright as usize] > 0.5);
        for c in 0..64 {
            let expected = probability[c] * total;
            let got = counts[c] as f32;
            assert!(counts[c] > 0, "cell {c} never sampled");
            // Within 5 standard deviations of the binomial count.
            let sigma = (expected * (1.0 - probability[c])).sqrt();
            assert!(
                (got - expected).abs() < 5.0 * sigma + 1.0,
                "cell {c}: {got} vs {expected}"
            );
        }
        assert!(counts[bright as usize] > 20 * counts[1]);
    }

    #[test]
    fn guiding_needs_the_flag_and_light_in_the_history() {
        let (records, atlas, frame, seed) = scene(|_| make_cell(Vec3::ZERO, 2.0));
        let out = sample_workgroup(&params(ALL), &records, &atlas, seed, &frame, 0);
        assert!(!out.guided, "a black history has no CDF");
        let (records, atlas, frame, seed) = scene(|_| make_cell(Vec3::ONE, 2.0));
        let out = sample_workgroup(
            &params(ALL & !FLAG_RAY_GUIDING),
            &records,
            &atlas,
            seed,
            &frame,
            0,
        );
        assert!(!out.guided);
        let out = sample_workgroup(&params(ALL), &records, &atlas, seed, &frame, 0);
        assert!(out.guided);
    }

    #[test]
    fn cdf_search_finds_the_interval() {
        let mut cdf = [6.0; LANES];
        cdf[..3].copy_from_slice(&[1.0, 1.0, 3.0]);
        assert_eq!(guided_cell(&cdf, 0.0), 0);
        assert_eq!(guided_cell(&cdf, 0.999), 0);
        assert_eq!(guided_cell(&cdf, 1.0), 2);
        assert_eq!(guided_cell(&cdf, 5.9), 3);
        assert_eq!(guided_cell(&cdf, 6.0), 63);
        let mut raw = [NO_WEIGHT; LANES];
        assert_eq!(guiding_mean(&raw), 0.0);
        raw[5] = 2.0;
        raw[9] = 4.0;
        assert_eq!(guiding_mean(&raw), 3.0);
        let f = 1.0 + GUIDING_UNIFORM_FRACTION;
        assert!((guiding_cdf(&raw, 63) - 64.0 * 3.0 * f).abs() < 1e-3);
        assert!((guiding_weight(NO_WEIGHT, 3.0) - 3.0 * f).abs() < 1e-6);
        // The smallest share a cell can get bounds a guided ray's weight at 5.
        let mut only = [0.0; LANES];
        only[7] = 1.0;
        let mut cdf = [0.0; LANES];
        for (lane, c) in cdf.iter_mut().enumerate() {
            *c = guiding_cdf(&only, lane as u32);
        }
        let least = cell_share(&cdf, 0);
        assert!((1.0 / (64.0 * least) - 5.0).abs() < 1e-3, "{least}");
        assert_eq!(guiding_raw_weight(EMPTY, 0), NO_WEIGHT);
        assert_eq!(
            guiding_raw_weight(make_cell(Vec3::splat(f32::INFINITY), 1.0), 0),
            0.0
        );
    }
}
