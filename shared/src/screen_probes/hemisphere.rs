//! A probe's hemisphere: its 8 × 8 cells as world directions (the equal-area hemi-octahedral map
//! around the seed's geometric normal, in the tangent frame of `orthonormal_basis`), and the
//! parallax-corrected re-binning that moves one probe's cells into another probe's hemisphere
//! (used by reprojection, by ray guiding's neighbour gather and by the probe filter).
//!
//! Re-binning without atomics: each source cell is *mapped* to the target cell its hit point is
//! seen through from the target ([`map_cell`]), one lane links each target cell's sources
//! ([`link_mapped`]), then each target cell averages the sources on its list
//! ([`gather_linked`]). A kernel keeps the 64 mapped cells and the lists in workgroup memory, one
//! per lane; the CPU runs the same steps in loops, so both sum in the same order.

use super::{LANES, ProbeRecord};
use glam::{UVec2, Vec2, Vec3};

use super::{
    EMPTY, MISS_DISTANCE, PROBE_CELLS, PROBE_SIZE, cell_is_filled, cell_radiance, make_cell,
};
use crate::octahedral::{equal_area_hemi_decode, probe_cell_direction, probe_direction_cell};
use crate::sampling::{tangent_to_world, world_to_tangent};

/// Where a probe sits: its origin and the unit axis of its hemisphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeFrame {
    /// World position of the probe (its seed's surface point).
    pub position: Vec3,
    /// Unit geometric normal: the hemisphere's axis.
    pub normal: Vec3,
}

/// Cell index `x + 8 · y` of cell coordinates.
#[inline]
pub fn cell_index(cell: UVec2) -> u32 {
    cell.x + PROBE_SIZE * cell.y
}

/// Cell coordinates of a cell index.
#[inline]
pub fn cell_coords(index: u32) -> UVec2 {
    UVec2::new(index % PROBE_SIZE, (index / PROBE_SIZE) % PROBE_SIZE)
}

impl ProbeFrame {
    /// World direction through the centre of cell `index`.
    #[inline]
    pub fn cell_direction(&self, index: u32) -> Vec3 {
        tangent_to_world(
            probe_cell_direction(cell_coords(index), PROBE_SIZE),
            self.normal,
        )
    }

    /// World direction of the point `u ∈ [0, 1)²` inside cell `index` (uniform in `u` is uniform
    /// in solid angle: the map is equal-area).
    #[inline]
    pub fn direction_in_cell(&self, index: u32, u: Vec2) -> Vec3 {
        tangent_to_world(tangent_direction_in_cell(index, u), self.normal)
    }

    /// The cell a world direction falls into; `None` below the hemisphere (or degenerate).
    #[inline]
    pub fn direction_cell(&self, direction: Vec3) -> Option<u32> {
        let t = world_to_tangent(direction, self.normal);
        if t.z > 0.0 {
            Some(cell_index(probe_direction_cell(t, PROBE_SIZE)))
        } else {
            None
        }
    }
}

/// The direction of the point `u ∈ [0, 1)²` inside cell `index` in the probe's tangent frame
/// (`z`: the cosine to its normal).
#[inline]
pub fn tangent_direction_in_cell(index: u32, u: Vec2) -> Vec3 {
    let c = cell_coords(index).as_vec2();
    let uv = (c + u) / PROBE_SIZE as f32;
    equal_area_hemi_decode(uv * 2.0 - 1.0)
}

/// The hemisphere of a stored probe: its position and its normal after the `pack_snorm10x3`
/// round trip, so that every pass that reads the record builds the same tangent frame.
#[inline]
pub fn record_frame(record: &ProbeRecord) -> ProbeFrame {
    ProbeFrame {
        position: record.world_position(),
        normal: record.world_normal(),
    }
}

/// Solid angle of one probe cell: `2π / 64` sr.
pub const CELL_SOLID_ANGLE: f32 = 2.0 * core::f32::consts::PI / PROBE_CELLS as f32;

/// Where source cell `index` of probe `source` (`cell` = `[r, g, b, hit distance]`) lands in
/// probe `target`: `[target cell, …]` and the cell as the target sees it (its hit distance
/// measured from the target). With `parallax`, the hit point `source + direction × distance` is
/// re-seen from the target (misses keep their direction: the sky is infinitely far); without,
/// every cell keeps its direction. `None` for an empty cell or one below the target's hemisphere.
#[inline]
pub fn map_cell(
    source: &ProbeFrame,
    target: &ProbeFrame,
    index: u32,
    cell: [f32; 4],
    parallax: bool,
) -> Option<(u32, [f32; 4])> {
    if !cell_is_filled(cell) {
        return None;
    }
    let d = source.cell_direction(index);
    let distance = cell[3];
    let (direction, new_distance) = if parallax && distance < MISS_DISTANCE {
        let hit = source.position + d * distance;
        let v = hit - target.position;
        let l = v.length();
        if l > 0.0 && l.is_finite() {
            (v / l, l)
        } else {
            return None;
        }
    } else {
        (d, distance)
    };
    let target_cell = target.direction_cell(direction)?;
    Some((target_cell, make_cell(cell_radiance(cell), new_distance)))
}

/// Marker of a source cell that maps nowhere ([`map_cell`] gave `None`).
pub const UNMAPPED: u32 = u32::MAX;

/// The mean cell of `n` sources whose radiance and hit distance sum to `sum` and `distance`;
/// [`EMPTY`] when `n` is 0.
#[inline]
fn mean_cell(sum: Vec3, distance: f32, n: u32) -> [f32; 4] {
    if n == 0 {
        EMPTY
    } else {
        let inv = 1.0 / n as f32;
        make_cell(sum * inv, distance * inv)
    }
}

/// The sources of each target cell as lists in ascending source order, so that a lane walks its
/// own sources ([`gather_linked`]) instead of scanning all 64 (64 × 64 reads per workgroup):
/// `heads[t]` is the first source mapped to cell `t` ([`LANES`] when none), `next[i]` the
/// source after `i` in its list. `mapped` holds one target per source cell, [`UNMAPPED`] for
/// none. One lane builds them (64 steps) between two barriers. The arrays are workgroup arrays
/// in the kernels (rust-gpu cannot turn them into slices).
#[inline]
pub fn link_mapped(mapped: &[u32; LANES], heads: &mut [u32; LANES], next: &mut [u32; LANES]) {
    let mut t = 0;
    while t < LANES {
        heads[t] = LANES as u32;
        t += 1;
    }
    let mut i = LANES;
    while i > 0 {
        i -= 1;
        let target = mapped[i] as usize;
        if target < LANES {
            next[i] = heads[target];
            heads[target] = i as u32;
        }
    }
}

/// Target cell `target_cell`'s share of the sources [`link_mapped`] listed: the mean radiance
/// and the mean hit distance of the sources mapped to it (`cells[i]` as mapped), or [`EMPTY`]
/// when none lands there.
#[inline]
pub fn gather_linked(
    heads: &[u32; LANES],
    next: &[u32; LANES],
    cells: &[[f32; 4]; LANES],
    target_cell: u32,
) -> [f32; 4] {
    gather_linked_counted(heads, next, cells, target_cell).0
}

/// [`gather_linked`], with how many sources landed in the cell and the last of them (`LANES`
/// when none), in the same walk.
#[inline]
pub fn gather_linked_counted(
    heads: &[u32; LANES],
    next: &[u32; LANES],
    cells: &[[f32; 4]; LANES],
    target_cell: u32,
) -> ([f32; 4], u32, usize) {
    let mut sum = Vec3::ZERO;
    let mut distance = 0.0;
    let mut n = 0u32;
    let mut last = LANES;
    let mut i = if (target_cell as usize) < LANES {
        heads[target_cell as usize] as usize
    } else {
        LANES
    };
    while i < LANES {
        let c = cells[i];
        sum += cell_radiance(c);
        distance += c[3];
        n += 1;
        last = i;
        i = next[i] as usize;
    }
    (mean_cell(sum, distance, n), n, last)
}

/// The lists of `mapped` ([`link_mapped`]), for the CPU models of the kernels.
#[inline]
pub fn linked(mapped: &[u32; LANES]) -> ([u32; LANES], [u32; LANES]) {
    let (mut heads, mut next) = ([0; LANES], [0; LANES]);
    link_mapped(mapped, &mut heads, &mut next);
    (heads, next)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gather the kernels did before the lists: every lane scanning all 64 sources.
    fn scanning_gather(
        mapped: &[u32; LANES],
        cells: &[[f32; 4]; LANES],
        target_cell: u32,
    ) -> ([f32; 4], u32, usize) {
        let mut sum = Vec3::ZERO;
        let mut distance = 0.0;
        let mut n = 0u32;
        let mut last = LANES;
        for i in 0..LANES {
            if mapped[i] == target_cell {
                sum += cell_radiance(cells[i]);
                distance += cells[i][3];
                n += 1;
                last = i;
            }
        }
        (mean_cell(sum, distance, n), n, last)
    }

    /// The linked gather gives the scanning gather's bits, count and last source for every
    /// target cell, whatever the map: random targets, unmapped sources, every source on one
    /// cell, none anywhere.
    #[test]
    fn linked_gather_is_the_scanning_gather() {
        let mut rng = crate::random::Random::new(3, 0);
        for case in 0..200 {
            let mut mapped = [UNMAPPED; LANES];
            let mut cells = [EMPTY; LANES];
            for i in 0..LANES {
                mapped[i] = match case % 4 {
                    0 => (rng.next_f32() * 64.0) as u32,
                    1 if rng.next_f32() < 0.5 => UNMAPPED,
                    1 => (rng.next_f32() * 8.0) as u32,
                    2 => 17,
                    _ => UNMAPPED,
                };
                cells[i] = [
                    rng.next_f32() * 1e3,
                    rng.next_f32(),
                    1e-6,
                    rng.next_f32() * 50.0,
                ];
            }
            let (heads, next) = linked(&mapped);
            for t in 0..LANES as u32 + 1 {
                let (a, an, al) = scanning_gather(&mapped, &cells, t);
                let (b, bn, bl) = gather_linked_counted(&heads, &next, &cells, t);
                assert_eq!(
                    a.map(f32::to_bits),
                    b.map(f32::to_bits),
                    "case {case}, cell {t}"
                );
                assert_eq!((an, al), (bn, bl), "case {case}, cell {t}");
            }
        }
    }

    fn frame(p: Vec3, n: Vec3) -> ProbeFrame {
        ProbeFrame {
            position: p,
            normal: n.normalize(),
        }
    }

    #[test]
    fn every_cell_direction_maps_back_to_its_cell() {
        for n in [Vec3::Z, Vec3::X, -Vec3::Y, Vec3::new(0.3, -0.5, 0.8)] {
            let f = frame(Vec3::ZERO, n);
            for i in 0..PROBE_CELLS {
                assert_eq!(f.direction_cell(f.cell_direction(i)), Some(i));
                let d = f.direction_in_cell(i, Vec2::new(0.25, 0.75));
                assert_eq!(f.direction_cell(d), Some(i));
            }
            assert_eq!(f.direction_cell(-f.normal), None);
        }
    }

    #[test]
    fn the_same_frame_maps_every_cell_onto_itself() {
        let f = frame(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.1, 0.9, 0.2));
        let mut mapped = [UNMAPPED; 64];
        let mut cells = [EMPTY; 64];
        for i in 0..PROBE_CELLS {
            let c = make_cell(Vec3::splat(i as f32), 2.0);
            let (t, moved) = map_cell(&f, &f, i, c, true).unwrap();
            mapped[i as usize] = t;
            cells[i as usize] = moved;
        }
        let (heads, next) = linked(&mapped);
        for i in 0..PROBE_CELLS {
            let g = gather_linked(&heads, &next, &cells, i);
            assert!((g[0] - i as f32).abs() < 1e-6, "{i}: {g:?}");
            assert!((g[3] - 2.0).abs() < 1e-4);
        }
    }

    #[test]
    fn parallax_re_sees_a_hit_from_the_new_origin() {
        let a = frame(Vec3::ZERO, Vec3::Z);
        let b = frame(Vec3::new(1.0, 0.0, 0.0), Vec3::Z);
        // The cell straight up from `a` hits (0, 0, 1); from `b` that point lies up and back.
        let up = (0..PROBE_CELLS)
            .max_by(|&i, &j| {
                a.cell_direction(i)
                    .z
                    .partial_cmp(&a.cell_direction(j).z)
                    .unwrap()
            })
            .unwrap();
        let d = a.cell_direction(up);
        let (t, moved) = map_cell(&a, &b, up, make_cell(Vec3::ONE, 1.0 / d.z), true).unwrap();
        let seen = b.cell_direction(t);
        let expected = (d / d.z - b.position).normalize();
        assert!(seen.dot(expected) > 0.95, "{seen} vs {expected}");
        assert!((moved[3] - (d / d.z - b.position).length()).abs() < 1e-4);
        // Without parallax, and for the sky, the direction is kept.
        let (t2, _) = map_cell(&a, &b, up, make_cell(Vec3::ONE, 1.0), false).unwrap();
        assert_eq!(t2, up);
        let (t3, _) = map_cell(&a, &b, up, make_cell(Vec3::ONE, MISS_DISTANCE), true).unwrap();
        assert_eq!(t3, up);
        assert!(map_cell(&a, &b, up, EMPTY, true).is_none());
    }
}
