//! Radiance backup: a probe cell left without radiance (no ray landed in it, nothing reprojected
//! into it) takes the mean radiance of the probe's filled cells, as seen from infinitely far
//! ([`MISS_DISTANCE`]), so that interpolation never reads a hole as black.
//!
//! The reference divides that mean once more by the number of empty cells; we keep the mean: a
//! probe with few filled cells would otherwise lose most of its energy (measured by
//! `the_backup_keeps_a_uniform_probe_uniform`).

use glam::Vec3;

use super::{
    EMPTY, FLAG_RADIANCE_BACKUP, GiFrameParams, LANES, MISS_DISTANCE, cell_is_filled,
    cell_radiance, make_cell,
};

/// The backup of a probe's cells (one `[r, g, b, distance]` per cell, a workgroup array in the
/// kernels): the mean of the filled
/// cells at [`MISS_DISTANCE`], or [`EMPTY`] when no cell is filled.
#[inline]
pub fn radiance_backup(cells: &[[f32; 4]; LANES]) -> [f32; 4] {
    let mut sum = Vec3::ZERO;
    let mut n = 0u32;
    let mut i = 0;
    while i < LANES {
        let c = cells[i];
        if cell_is_filled(c) {
            sum += cell_radiance(c);
            n += 1;
        }
        i += 1;
    }
    if n == 0 {
        EMPTY
    } else {
        make_cell(sum / n as f32, MISS_DISTANCE)
    }
}

/// The backup every empty cell of a probe with `cells` takes where `params` turns it on
/// ([`FLAG_RADIANCE_BACKUP`]): [`radiance_backup`], else [`EMPTY`]. One value per probe: the
/// kernels compute it once, on one lane between two barriers, not once per empty cell (64 reads
/// each).
#[inline]
pub fn probe_backup(params: &GiFrameParams, cells: &[[f32; 4]; LANES]) -> [f32; 4] {
    if params.has(FLAG_RADIANCE_BACKUP) {
        radiance_backup(cells)
    } else {
        EMPTY
    }
}

/// A probe's cell as written: `cell`, or where it is empty and `params` turns the backup on,
/// the probe's `backup` ([`probe_backup`]).
#[inline]
pub fn backed_up_cell(params: &GiFrameParams, cell: [f32; 4], backup: [f32; 4]) -> [f32; 4] {
    if params.has(FLAG_RADIANCE_BACKUP) {
        with_backup(cell, backup)
    } else {
        cell
    }
}

/// A cell with the backup filled in: `cell` itself when filled, else `backup`.
#[inline]
pub fn with_backup(cell: [f32; 4], backup: [f32; 4]) -> [f32; 4] {
    if cell_is_filled(cell) { cell } else { backup }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_backup_keeps_a_uniform_probe_uniform() {
        let mut cells = [EMPTY; 64];
        for (i, c) in cells.iter_mut().enumerate() {
            if i % 3 == 0 {
                *c = make_cell(Vec3::splat(2.0), 1.0);
            }
        }
        let b = radiance_backup(&cells);
        assert_eq!(b, make_cell(Vec3::splat(2.0), MISS_DISTANCE));
        assert_eq!(with_backup(cells[1], b), b);
        assert_eq!(with_backup(cells[0], b), cells[0]);
        assert_eq!(radiance_backup(&[EMPTY; 64]), EMPTY);
    }
}
