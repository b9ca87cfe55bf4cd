//! FilterProbeMask: the probe mask's mip chain. Mip 0 holds one packed seed per probe tile
//! ([`NO_PROBE`] for none); each texel of mip `k ≥ 1` holds the first valid seed of its 2 × 2
//! children in mip `k − 1`, in the order (0, 0), (1, 0), (0, 1), (1, 1). One dispatch per mip,
//! one invocation per texel ([`filter_mask_texel`]); [`build_mask_chain`] is the CPU model.
//! [`nearest_probe_seed`] walks the chain up from a probe tile to the nearest probe, for
//! per-pixel interpolation.

use glam::UVec2;

use super::{NO_PROBE, mask_mip_count, mask_mip_offset, mask_mip_size};

/// Word index of `texel` of mip `mip` in the mask buffer of a `grid` of probe tiles, `None`
/// outside the mip.
#[inline]
pub fn mask_texel_index(grid: [u32; 2], mip: u32, texel: UVec2) -> Option<usize> {
    let size = mask_mip_size(grid, mip);
    if texel.x < size[0] && texel.y < size[1] {
        Some((mask_mip_offset(grid, mip) + texel.y * size[0] + texel.x) as usize)
    } else {
        None
    }
}

/// The mask word at `texel` of mip `mip`; [`NO_PROBE`] outside the mip or the buffer.
#[inline]
pub fn mask_texel(mask: &[u32], grid: [u32; 2], mip: u32, texel: UVec2) -> u32 {
    match mask_texel_index(grid, mip, texel) {
        Some(i) if i < mask.len() => mask[i],
        _ => NO_PROBE,
    }
}

/// Texel `texel` of mip `mip ≥ 1`: the first of its 2 × 2 children in mip `mip − 1` that holds
/// a probe, in the order (0, 0), (1, 0), (0, 1), (1, 1) (children outside the mip are skipped);
/// [`NO_PROBE`] when none does, or for mip 0.
#[inline]
pub fn filter_mask_texel(mask: &[u32], grid: [u32; 2], mip: u32, texel: UVec2) -> u32 {
    if mip == 0 {
        return NO_PROBE;
    }
    let mut child = 0;
    while child < 4 {
        let c = UVec2::new(texel.x * 2 + (child & 1), texel.y * 2 + (child >> 1));
        let seed = mask_texel(mask, grid, mip - 1, c);
        if seed != NO_PROBE {
            return seed;
        }
        child += 1;
    }
    NO_PROBE
}

/// The CPU model of the FilterProbeMask dispatches: mips 1.. of `mask`, each from the one
/// before, from mip 0 as it is.
pub fn build_mask_chain(mask: &mut [u32], grid: [u32; 2]) {
    let mips = mask_mip_count(grid);
    let mut mip = 1;
    while mip < mips {
        let size = mask_mip_size(grid, mip);
        let mut y = 0;
        while y < size[1] {
            let mut x = 0;
            while x < size[0] {
                let texel = UVec2::new(x, y);
                let seed = filter_mask_texel(mask, grid, mip, texel);
                if let Some(i) = mask_texel_index(grid, mip, texel)
                    && i < mask.len()
                {
                    mask[i] = seed;
                }
                x += 1;
            }
            y += 1;
        }
        mip += 1;
    }
}

/// The nearest probe seed of probe tile `tile` through the mask chain: its own mip-0 texel when
/// it holds a probe, else the texel covering it in the first coarser mip that holds one;
/// [`NO_PROBE`] when the whole mask is empty (or the tile lies outside the grid).
#[inline]
pub fn nearest_probe_seed(mask: &[u32], grid: [u32; 2], tile: UVec2) -> u32 {
    if tile.x >= grid[0] || tile.y >= grid[1] {
        return NO_PROBE;
    }
    let mips = mask_mip_count(grid);
    let mut mip = 0;
    while mip < mips {
        let seed = mask_texel(mask, grid, mip, UVec2::new(tile.x >> mip, tile.y >> mip));
        if seed != NO_PROBE {
            return seed;
        }
        mip += 1;
    }
    NO_PROBE
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::{pack_seed, unpack_seed};
    use crate::screen_probes::mask_words;

    #[test]
    fn each_texel_takes_its_first_valid_child() {
        // 5 × 3 tiles: mips 3 × 2, 2 × 1, 1 × 1.
        let grid = [5, 3];
        let mut mask = vec![NO_PROBE; mask_words(grid) as usize];
        let put = |mask: &mut Vec<u32>, x: u32, y: u32| {
            let i = mask_texel_index(grid, 0, UVec2::new(x, y)).unwrap();
            mask[i] = pack_seed(UVec2::new(x * 8 + 1, y * 8 + 2));
        };
        put(&mut mask, 1, 1);
        put(&mut mask, 0, 1);
        put(&mut mask, 1, 0);
        put(&mut mask, 4, 2);
        build_mask_chain(&mut mask, grid);
        let at = |mip, x, y| mask_texel(&mask, grid, mip, UVec2::new(x, y));
        // Block (0, 0) holds (1, 0), (0, 1) and (1, 1): (1, 0) comes first.
        assert_eq!(unpack_seed(at(1, 0, 0)), UVec2::new(9, 2));
        assert_eq!(at(1, 1, 0), NO_PROBE);
        // Texel (2, 1) of mip 1 has one child inside the grid, (4, 2).
        assert_eq!(unpack_seed(at(1, 2, 1)), UVec2::new(33, 18));
        assert_eq!(unpack_seed(at(2, 0, 0)), UVec2::new(9, 2));
        assert_eq!(unpack_seed(at(2, 1, 0)), UVec2::new(33, 18));
        assert_eq!(unpack_seed(at(3, 0, 0)), UVec2::new(9, 2));
        assert_eq!(filter_mask_texel(&mask, grid, 0, UVec2::ZERO), NO_PROBE);
        assert_eq!(mask_texel_index(grid, 1, UVec2::new(3, 0)), None);
    }

    #[test]
    fn the_nearest_seed_comes_from_the_finest_mip_that_has_one() {
        let grid = [5, 3];
        let mut mask = vec![NO_PROBE; mask_words(grid) as usize];
        assert_eq!(nearest_probe_seed(&mask, grid, UVec2::new(2, 2)), NO_PROBE);
        let own = pack_seed(UVec2::new(17, 17));
        let far = pack_seed(UVec2::new(33, 1));
        mask[mask_texel_index(grid, 0, UVec2::new(2, 2)).unwrap()] = own;
        mask[mask_texel_index(grid, 0, UVec2::new(4, 0)).unwrap()] = far;
        build_mask_chain(&mut mask, grid);
        assert_eq!(nearest_probe_seed(&mask, grid, UVec2::new(2, 2)), own);
        // (3, 2): mip 1 texel (1, 1) covers (2, 2).
        assert_eq!(nearest_probe_seed(&mask, grid, UVec2::new(3, 2)), own);
        // (4, 1): mip 1 texel (2, 0) covers (4, 0).
        assert_eq!(nearest_probe_seed(&mask, grid, UVec2::new(4, 1)), far);
        // (0, 0): nothing until mip 2 texel (0, 0), which took its child (1, 1) of mip 1 = own.
        assert_eq!(nearest_probe_seed(&mask, grid, UVec2::new(0, 0)), own);
        assert_eq!(nearest_probe_seed(&mask, grid, UVec2::new(5, 0)), NO_PROBE);
    }
}
