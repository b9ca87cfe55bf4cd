//! Reading the cache (`HashGridCache_FilteredRadiance`): start at the query's mip-0 cell and step
//! to the parent cell while the count is below the sample cap ([`super::MAX_SAMPLE_COUNT`] by default) and a coarser mip exists, so
//! sparsely sampled cells are prefiltered over a larger footprint.

use glam::Vec3;

use super::storage::find_tile;
use super::{CellDescriptor, NUM_MIPS, cell_index};
use crate::atomics::AtomicWords;
use crate::layout::{HashCellValue, HashGridParams};
use crate::math::max_u32;

/// The `(rgb · n, n)` value the adaptive read stops at for mip-0 cell `cell` (`[x, y]`) of tile
/// `tile`.
#[inline]
pub fn filtered_value(
    values: &[HashCellValue],
    tile: u32,
    cell: [u32; 2],
    cap: u32,
) -> HashCellValue {
    let (mut x, mut y) = (cell[0], cell[1]);
    let mut mip = 0;
    let mut value = values[cell_index(tile, 0, x, y) as usize];
    while value.count < max_u32(cap, 1) as f32 && mip + 1 < NUM_MIPS {
        mip += 1;
        x /= 2;
        y /= 2;
        value = values[cell_index(tile, mip, x, y) as usize];
    }
    value
}

/// Filtered radiance of mip-0 cell `cell` of tile `tile`: sum / count of [`filtered_value`];
/// `None` when even the tile's root has no sample.
#[inline]
pub fn filtered_radiance(
    values: &[HashCellValue],
    tile: u32,
    cell: [u32; 2],
    cap: u32,
) -> Option<Vec3> {
    let value = filtered_value(values, tile, cell, cap);
    if value.count > 0.0 {
        Some(value.radiance_sum() / value.count)
    } else {
        None
    }
}

/// Filtered radiance of the cell `desc` describes: `None` when its tile is not in the cache or
/// holds no sample yet.
#[inline]
pub fn lookup<W: AtomicWords + ?Sized>(
    keys: &W,
    values: &[HashCellValue],
    desc: &CellDescriptor,
    params: &HashGridParams,
) -> Option<Vec3> {
    match find_tile(keys, desc, params) {
        Some(tile) => filtered_radiance(values, tile, desc.cell, params.sample_cap),
        None => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_cells::{CELLS_PER_TILE, MAX_SAMPLE_COUNT};

    #[test]
    fn steps_to_parents_until_16_samples() {
        let mut values = vec![HashCellValue::ZERO; 2 * CELLS_PER_TILE as usize];
        let set = |v: &mut Vec<HashCellValue>, mip, x, y, r: f32, n: f32| {
            v[cell_index(1, mip, x, y) as usize] = HashCellValue::new(Vec3::splat(r * n), n);
        };
        // Nothing anywhere: no radiance.
        assert_eq!(
            filtered_radiance(&values, 1, [5, 6], MAX_SAMPLE_COUNT),
            None
        );
        // Only the root has samples (fewer than 16): the root answers.
        set(&mut values, 3, 0, 0, 7.0, 3.0);
        assert_eq!(
            filtered_radiance(&values, 1, [5, 6], MAX_SAMPLE_COUNT),
            Some(Vec3::splat(7.0))
        );
        // Mip 1 parent (2, 3) of (5, 6) with 20 samples answers before the root.
        set(&mut values, 1, 2, 3, 2.0, 20.0);
        assert_eq!(
            filtered_radiance(&values, 1, [5, 6], MAX_SAMPLE_COUNT),
            Some(Vec3::splat(2.0))
        );
        assert_eq!(
            filtered_value(&values, 1, [5, 6], MAX_SAMPLE_COUNT).count,
            20.0
        );
        // A mip-0 cell with exactly 16 samples answers itself.
        set(&mut values, 0, 5, 6, 0.5, 16.0);
        assert_eq!(
            filtered_radiance(&values, 1, [5, 6], MAX_SAMPLE_COUNT),
            Some(Vec3::splat(0.5))
        );
        // Its neighbour (4, 6) with 15 samples shares the mip-1 parent.
        set(&mut values, 0, 4, 6, 9.0, 15.0);
        assert_eq!(
            filtered_radiance(&values, 1, [4, 6], MAX_SAMPLE_COUNT),
            Some(Vec3::splat(2.0))
        );
        // Another mip-1 parent without samples falls through to the root.
        assert_eq!(
            filtered_radiance(&values, 1, [0, 0], MAX_SAMPLE_COUNT),
            Some(Vec3::splat(7.0))
        );
        // Tile 0 is untouched.
        assert_eq!(
            filtered_radiance(&values, 0, [5, 6], MAX_SAMPLE_COUNT),
            None
        );
        // A cap of 15 lets the 15-sample cell answer itself; a cap of 0 reads as 1.
        assert_eq!(
            filtered_radiance(&values, 1, [4, 6], 15),
            Some(Vec3::splat(9.0))
        );
        assert_eq!(filtered_value(&values, 1, [4, 6], 0).count, 15.0);
    }
}
