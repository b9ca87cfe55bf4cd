//! FilterScreenProbes: the 7 × 7 separable probe filter, one pass along x ([`AXIS_HORIZONTAL`])
//! then one along y ([`AXIS_VERTICAL`]). One workgroup of 64 lanes per probe tile, lane = cell;
//! each lane is independent ([`filter_cell`]), so no workgroup memory is needed.
//!
//! Every valid probe is filtered every frame from unfiltered input into a separate output (the
//! horizontal pass reads the atlas, the vertical pass reads the horizontal output), so a probe
//! carried over many frames by reprojection is never filtered again and again.
//!
//! For cell `c` of the centre probe, with direction `d`: the centre counts with weight 1; each
//! probe ±1, ±2, ±3 tiles along the axis (mip 0 of the mask) that passes the reuse test against
//! the centre contributes its cell in direction `d` when that cell saw the same thing as the
//! centre's ([`same_point`]): both missed, or both hit and the neighbour's point
//! (`neighbour + d × its distance`) lies within [`FILTER_POINT_TOLERANCE`] × the larger distance of
//! the centre's (`centre + d × its distance`). Its weight is `saturate(1 − |Δdepth| / depth)⁸`.
//! The output is the weighted mean radiance with the centre's hit distance. An empty centre cell
//! stays empty (filling holes is the radiance backup's job).
//!
//! # Why the test compares the two hit points
//!
//! The reference accepts a neighbour when its hit point is seen from the centre within `0.02π` of
//! `d`, whatever the centre's own ray hit, and accepts misses untested. That test prefers far
//! samples (parallax shrinks with distance) and misses over near hits, so a bright near surface
//! (a small light, a lit box) loses to whatever lies behind it: it darkened the Cornell box by
//! 7 % of its mean (`--no hysteresis,feedback,temporal,spatial`, 128 frames averaged: −8.6 %
//! with the filter, −1.3 % without). Comparing the neighbour's point with the centre's is
//! symmetric in near and far, and the filter keeps the mean (−1.3 %).

use super::StoredCell;
use glam::{UVec2, Vec3};

use super::hemisphere::record_frame;
use super::reuse::reuse_score;
use super::{
    EMPTY, FLAG_PROBE_FILTER, GiFrameParams, MISS_DISTANCE, NO_PROBE, PROBE_CELLS, ProbeRecord,
    cell_is_filled, cell_radiance, make_cell,
};
use crate::math::{abs, max, saturate};

/// Push constant of the horizontal pass.
pub const AXIS_HORIZONTAL: u32 = 0;
/// Push constant of the vertical pass.
pub const AXIS_VERTICAL: u32 = 1;
/// Neighbours on each side along the axis (7 taps).
pub const FILTER_RADIUS: i32 = 3;
/// How far apart a neighbour's hit point and the centre's may be, per unit of the larger hit
/// distance: `√(1/32)`, the angular radius (radians) of a disc with one cell's solid angle
/// (`2π / 64`), so that two samples of the same cell's surface pass.
pub const FILTER_POINT_TOLERANCE: f32 = 0.176_776_7;

/// Depth weight of a neighbour at linear depth `depth` for a centre at `centre_depth`:
/// `saturate(1 − |depth − centre_depth| / centre_depth)⁸` (0 for a centre depth of 0 or NaN).
#[inline]
pub fn depth_weight(centre_depth: f32, depth: f32) -> f32 {
    let w = saturate(1.0 - abs(depth - centre_depth) / centre_depth);
    let w2 = w * w;
    let w4 = w2 * w2;
    w4 * w4
}

/// The probe of probe tile `tile`: its record when both the record and the mask's mip-0 word
/// say it holds one.
#[inline]
pub fn probe_at(records: &[ProbeRecord], mask: &[u32], tile: u32) -> Option<ProbeRecord> {
    let i = tile as usize;
    if i >= records.len() || i >= mask.len() || mask[i] == NO_PROBE {
        return None;
    }
    let record = records[i];
    if record.is_valid() {
        Some(record)
    } else {
        None
    }
}

/// The probe tile `offset` tiles from `tile` along `axis`, `None` outside the probe grid.
#[inline]
pub fn tile_along(params: &GiFrameParams, tile: UVec2, axis: u32, offset: i32) -> Option<u32> {
    let x = tile.x as i32 + if axis == AXIS_HORIZONTAL { offset } else { 0 };
    let y = tile.y as i32 + if axis == AXIS_HORIZONTAL { 0 } else { offset };
    if x < 0 || y < 0 || x >= params.probe_grid[0] as i32 || y >= params.probe_grid[1] as i32 {
        None
    } else {
        Some(y as u32 * params.probe_grid[0] + x as u32)
    }
}

/// Lane `cell` of probe tile `tile` in the pass along `axis`: the filtered cell from the `input`
/// cells (`probe × 64 + cell`). Without [`FLAG_PROBE_FILTER`], for a tile without a probe and
/// for an empty cell: the input cell as is.
#[inline]
pub fn filter_cell(
    params: &GiFrameParams,
    records: &[ProbeRecord],
    mask: &[u32],
    input: &[StoredCell],
    tile: u32,
    axis: u32,
    cell: u32,
) -> [f32; 4] {
    let index = (tile * PROBE_CELLS + cell) as usize;
    if index >= input.len() || cell >= PROBE_CELLS {
        return EMPTY;
    }
    let centre_cell = input[index].unpack();
    if !params.has(FLAG_PROBE_FILTER) || !cell_is_filled(centre_cell) || params.probe_grid[0] == 0 {
        return centre_cell;
    }
    let Some(centre) = probe_at(records, mask, tile) else {
        return centre_cell;
    };
    let frame = record_frame(&centre);
    let d = frame.cell_direction(cell);
    let tile_xy = UVec2::new(tile % params.probe_grid[0], tile / params.probe_grid[0]);
    let mut sum = cell_radiance(centre_cell);
    let mut weights = 1.0;
    let mut offset = -FILTER_RADIUS;
    while offset <= FILTER_RADIUS {
        if offset != 0
            && let Some(t) = tile_along(params, tile_xy, axis, offset)
            && let Some(n) = probe_at(records, mask, t)
        {
            let (w, radiance) = neighbour_tap(params, input, &n, t, &centre, d, centre_cell[3]);
            if w > 0.0 {
                sum += radiance * w;
                weights += w;
            }
        }
        offset += 1;
    }
    make_cell(sum / weights, centre_cell[3])
}

/// Whether a neighbour at `neighbour` whose cell in direction `d` reached `neighbour_distance`
/// saw what the centre at `centre` saw at `centre_distance` ([`MISS_DISTANCE`] and beyond: a miss):
/// both missed, or both hit within [`FILTER_POINT_TOLERANCE`] × the larger distance of each other.
/// NaN fails.
#[inline]
pub fn same_point(
    centre: Vec3,
    centre_distance: f32,
    neighbour: Vec3,
    neighbour_distance: f32,
    d: Vec3,
) -> bool {
    let centre_missed = centre_distance >= MISS_DISTANCE;
    let neighbour_missed = neighbour_distance >= MISS_DISTANCE;
    if centre_missed || neighbour_missed {
        return centre_missed && neighbour_missed;
    }
    let apart = (neighbour + d * neighbour_distance - (centre + d * centre_distance)).length();
    apart <= FILTER_POINT_TOLERANCE * max(centre_distance, neighbour_distance)
}

/// One neighbour's weight and radiance for the centre's direction `d` (weight 0: rejected).
#[inline]
fn neighbour_tap(
    params: &GiFrameParams,
    input: &[StoredCell],
    neighbour: &ProbeRecord,
    tile: u32,
    centre: &ProbeRecord,
    d: Vec3,
    centre_distance: f32,
) -> (f32, Vec3) {
    let n = record_frame(neighbour);
    let c = record_frame(centre);
    if reuse_score(params, n.position, n.normal, c.position, c.normal).is_none() {
        return (0.0, Vec3::ZERO);
    }
    let Some(k) = n.direction_cell(d) else {
        return (0.0, Vec3::ZERO);
    };
    let i = (tile * PROBE_CELLS + k) as usize;
    if i >= input.len() {
        return (0.0, Vec3::ZERO);
    }
    let cell = input[i].unpack();
    if !cell_is_filled(cell) {
        return (0.0, Vec3::ZERO);
    }
    if !same_point(c.position, centre_distance, n.position, cell[3], d) {
        return (0.0, Vec3::ZERO);
    }
    (
        depth_weight(centre.depth, neighbour.depth),
        cell_radiance(cell),
    )
}

/// The CPU model of one FilterScreenProbes dispatch along `axis`: every cell of every probe tile.
pub fn filter_probes(
    params: &GiFrameParams,
    records: &[ProbeRecord],
    mask: &[u32],
    input: &[StoredCell],
    output: &mut [StoredCell],
    axis: u32,
) {
    let tiles = params.probe_grid[0] * params.probe_grid[1];
    let mut tile = 0;
    while tile < tiles {
        let mut cell = 0;
        while cell < PROBE_CELLS {
            let i = (tile * PROBE_CELLS + cell) as usize;
            if i < output.len() {
                output[i] =
                    StoredCell::pack(filter_cell(params, records, mask, input, tile, axis, cell));
            }
            cell += 1;
        }
        tile += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::{pack_seed, pack_snorm10x3};
    use crate::screen_probes::{FLAG_HISTORY, mask_words};

    const GRID: [u32; 2] = [9, 9];

    fn params(flags: u32) -> GiFrameParams {
        GiFrameParams {
            probe_grid: GRID,
            probe_cell_const: 0.01,
            flags,
            ..Default::default()
        }
    }

    /// Probes on the plane z = −10 facing the eye at the origin, one unit apart.
    struct Probes {
        records: Vec<ProbeRecord>,
        mask: Vec<u32>,
        cells: Vec<[f32; 4]>,
    }

    impl Probes {
        fn new() -> Self {
            let n = (GRID[0] * GRID[1]) as usize;
            Self {
                records: vec![ProbeRecord::NONE; n],
                mask: vec![NO_PROBE; mask_words(GRID) as usize],
                cells: vec![EMPTY; n * 64],
            }
        }

        fn put(&mut self, x: u32, y: u32, depth: f32, normal: Vec3, cell: [f32; 4]) -> u32 {
            let tile = y * GRID[0] + x;
            let seed = pack_seed(UVec2::new(x * 8, y * 8));
            self.records[tile as usize] = ProbeRecord {
                position: [x as f32, y as f32, -10.0],
                normal: pack_snorm10x3(normal),
                seed,
                depth,
                age: 0,
                _pad: 0,
            };
            self.mask[tile as usize] = seed;
            for c in 0..64 {
                self.cells[(tile * 64 + c) as usize] = cell;
            }
            tile
        }

        fn filter(&self, p: &GiFrameParams, axis: u32) -> Vec<[f32; 4]> {
            let mut out = vec![StoredCell::pack([9.0; 4]); self.cells.len()];
            let input = crate::screen_probes::stored_cells(&self.cells);
            filter_probes(p, &self.records, &self.mask, &input, &mut out, axis);
            out.iter().map(|c| c.unpack()).collect()
        }
    }

    fn grey(v: f32, distance: f32) -> [f32; 4] {
        make_cell(Vec3::splat(v), distance)
    }

    #[test]
    fn a_row_of_probes_is_averaged_with_depth_weights() {
        let mut probes = Probes::new();
        let centre = probes.put(4, 4, 10.0, Vec3::Z, grey(1.0, 50.0));
        for x in [1, 2, 3, 5, 6, 7] {
            probes.put(x, 4, 10.0, Vec3::Z, grey(2.0, 50.0));
        }
        // Beyond the radius: ignored.
        probes.put(0, 4, 10.0, Vec3::Z, grey(100.0, MISS_DISTANCE));
        probes.put(8, 4, 10.0, Vec3::Z, grey(100.0, MISS_DISTANCE));
        let p = params(FLAG_PROBE_FILTER);
        let out = probes.filter(&p, AXIS_HORIZONTAL);
        for c in 0..64 {
            let got = out[(centre * 64 + c) as usize];
            // Within the stored cell's rounding.
            let e = 13.0 / 7.0 * crate::packing::WIDE16_MAX_RELATIVE_ERROR;
            assert!((got[0] - 13.0 / 7.0).abs() <= e, "{got:?}");
            assert_eq!(got[3], 50.0, "the centre's hit distance is kept");
        }
        // The vertical pass sees no neighbour in the column: the centre as is.
        let out = probes.filter(&p, AXIS_VERTICAL);
        assert_eq!(out[(centre * 64) as usize], grey(1.0, 50.0));
        // Tiles without a probe are copied.
        assert_eq!(out[0], EMPTY);
        // A deeper neighbour weighs (1 − 0.05)⁸.
        let mut probes = Probes::new();
        let centre = probes.put(4, 4, 10.0, Vec3::Z, grey(1.0, MISS_DISTANCE));
        probes.put(4, 5, 10.5, Vec3::Z, grey(2.0, MISS_DISTANCE));
        let out = probes.filter(&p, AXIS_VERTICAL);
        let w = 0.95f32.powi(8);
        assert!((depth_weight(10.0, 10.5) - w).abs() < 1e-6);
        let expected = (1.0 + 2.0 * w) / (1.0 + w);
        let e = expected * crate::packing::WIDE16_MAX_RELATIVE_ERROR;
        assert!((out[(centre * 64 + 9) as usize][0] - expected).abs() <= e);
        // Without the flag every cell is copied.
        let out = probes.filter(&params(FLAG_HISTORY), AXIS_VERTICAL);
        assert_eq!(out, probes.cells);
    }

    #[test]
    fn neighbours_failing_reuse_or_seeing_something_else_are_skipped() {
        let mut probes = Probes::new();
        let centre = probes.put(4, 4, 10.0, Vec3::Z, grey(1.0, 5.0));
        // Tilted: fails the normal test.
        probes.put(
            5,
            4,
            10.0,
            Vec3::new(0.5, 0.0, 1.0).normalize(),
            grey(50.0, MISS_DISTANCE),
        );
        // Its hit point 5 units out lies 1 unit from the centre's (tolerance 0.88).
        probes.put(3, 4, 10.0, Vec3::Z, grey(50.0, 5.0));
        // A miss where the centre hit.
        probes.put(2, 4, 10.0, Vec3::Z, grey(50.0, MISS_DISTANCE));
        // Off the plane by 1 unit: fails the plane test (cell size 0.1 at distance ~10).
        let off = probes.put(6, 4, 10.0, Vec3::Z, grey(50.0, MISS_DISTANCE));
        probes.records[off as usize].position[2] = -9.0;
        let p = params(FLAG_PROBE_FILTER);
        let out = probes.filter(&p, AXIS_HORIZONTAL);
        assert_eq!(out[(centre * 64 + 20) as usize], grey(1.0, 5.0));
        // A hit 6 units out from one unit away, where the centre hit 5 units out: its point is
        // √2 from the centre's, within 0.177 × 6 = 1.06? No: skipped.
        let mut probes = Probes::new();
        let centre = probes.put(4, 4, 10.0, Vec3::Z, grey(1.0, 5.0));
        probes.put(3, 4, 10.0, Vec3::Z, grey(3.0, 6.0));
        let out = probes.filter(&p, AXIS_HORIZONTAL);
        assert_eq!(out[(centre * 64 + 20) as usize], grey(1.0, 5.0));
        // Far hits (1000 units) of the same wall from one unit apart: accepted.
        let mut probes = Probes::new();
        let centre = probes.put(4, 4, 10.0, Vec3::Z, grey(1.0, 1000.0));
        probes.put(3, 4, 10.0, Vec3::Z, grey(3.0, 1000.0));
        let out = probes.filter(&p, AXIS_HORIZONTAL);
        let filled = (0..64)
            .filter(|&c| out[(centre * 64 + c) as usize][0] == 2.0)
            .count();
        assert_eq!(filled, 64);
        // An empty centre cell stays empty.
        probes.cells[(centre * 64 + 3) as usize] = EMPTY;
        let out = probes.filter(&p, AXIS_HORIZONTAL);
        assert_eq!(out[(centre * 64 + 3) as usize], EMPTY);
        // A neighbour whose mask word says no probe is skipped.
        probes.mask[(centre - 1) as usize] = NO_PROBE;
        let out = probes.filter(&p, AXIS_HORIZONTAL);
        assert_eq!(out[(centre * 64 + 4) as usize], grey(1.0, 1000.0));
    }

    #[test]
    fn the_same_point_test_is_symmetric_in_near_and_far() {
        let d = Vec3::Z;
        // Both missed; one missed.
        assert!(same_point(
            Vec3::ZERO,
            MISS_DISTANCE,
            Vec3::X,
            MISS_DISTANCE,
            d
        ));
        assert!(!same_point(Vec3::ZERO, 5.0, Vec3::X, MISS_DISTANCE, d));
        assert!(!same_point(Vec3::ZERO, MISS_DISTANCE, Vec3::X, 5.0, d));
        // A near occluder before the centre, a far wall at the neighbour: rejected either way.
        assert!(!same_point(Vec3::ZERO, 1.0, Vec3::X * 0.1, 10.0, d));
        assert!(!same_point(Vec3::ZERO, 10.0, Vec3::X * 0.1, 1.0, d));
        // The same plane from 0.1 apart, 2 units out: accepted.
        assert!(same_point(Vec3::ZERO, 2.0, Vec3::X * 0.1, 2.0, d));
        assert!(!same_point(Vec3::ZERO, f32::NAN, Vec3::X * 0.1, 2.0, d));
    }

    /// Probes on a plane under a bright near surface (1 ray in 8, 5 units out) before a dark far
    /// one (50 units out): the filter keeps the mean within 1 % (the reference's angle test,
    /// which prefers far samples, kept 7 % of it here).
    #[test]
    fn the_filter_keeps_the_mean_before_a_far_background() {
        let mut probes = Probes::new();
        let mut rng = crate::random::Random::new(7, 0);
        let mut sum_in = 0.0;
        for y in 0..GRID[1] {
            for x in 0..GRID[0] {
                let tile = probes.put(x, y, 10.0, Vec3::Z, EMPTY);
                for c in 0..64 {
                    let near = rng.next_f32() < 0.125;
                    let (v, t) = if near { (8.0, 5.0) } else { (0.0, 50.0) };
                    probes.cells[(tile * 64 + c) as usize] = grey(v, t);
                    sum_in += v;
                }
            }
        }
        let p = params(FLAG_PROBE_FILTER);
        let horizontal = probes.filter(&p, AXIS_HORIZONTAL);
        let mut out = vec![StoredCell::EMPTY; horizontal.len()];
        filter_probes(
            &p,
            &probes.records,
            &probes.mask,
            &crate::screen_probes::stored_cells(&horizontal),
            &mut out,
            AXIS_VERTICAL,
        );
        let sum_out: f32 = out.iter().map(|c| c.unpack()[0]).sum();
        assert!(
            (sum_out / sum_in - 1.0).abs() < 0.01,
            "{sum_in} → {sum_out}"
        );
    }
}
