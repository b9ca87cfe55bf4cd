//! Debug views of the hash-grid cache, computed on the host from the read-back state and the
//! G-buffer, for the cell at each pixel's primary hit: the primary hit is keyed like a query from
//! the eye (its LOD), and of the cells that share its position (every direction bin, short and
//! long rays) the one with the most samples is shown, since queries reach a surface from many
//! directions.
//!
//! Views ([`DebugView`]): cells coloured by hash, LOD level, sample count, cached radiance, and
//! tiles evicted in the last frame.

use crate::error::{Error, Result};
use crate::gbuffer::GBufferData;
use crate::image_io::{HdrImage, ToneCurve, ToneMap};
use gi_shared::camera::CameraParams;
use gi_shared::hash::pcg_chain;
use gi_shared::hash_cells::layout::{HashCellValue, HashGridParams};
use gi_shared::hash_cells::read::filtered_value;
use gi_shared::hash_cells::storage::{find_tile, slots_per_bucket};
use gi_shared::hash_cells::{
    CellDescriptor, DIRECTION_BINS, MAX_LOD, MIN_LOD, cell_descriptor, tile_slot,
};
use gi_shared::primary_surface::primary_surface;
use glam::{UVec2, Vec3};
use std::path::{Path, PathBuf};

/// One debug view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DebugView {
    /// A random colour per cell (from its checksum and its cell coordinates).
    Hash,
    /// The LOD: blue (fine) to red (coarse), over the LODs in view.
    Lod,
    /// The adaptive read's sample count: black (none) to white (the sample cap, 16 by default).
    SampleCount,
    /// The cell's filtered radiance.
    Radiance,
    /// Red where the cell's tile was evicted in the last frame, grey elsewhere on surfaces.
    Evicted,
}

impl DebugView {
    /// Every view.
    pub const ALL: [Self; 5] = [
        Self::Hash,
        Self::Lod,
        Self::SampleCount,
        Self::Radiance,
        Self::Evicted,
    ];

    /// The file name (without extension).
    pub fn name(self) -> &'static str {
        match self {
            Self::Hash => "cells_by_hash",
            Self::Lod => "lod",
            Self::SampleCount => "sample_count",
            Self::Radiance => "cached_radiance",
            Self::Evicted => "evicted",
        }
    }
}

/// The cache's cell at one pixel's primary hit.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PixelCell {
    desc: CellDescriptor,
    value: Option<HashCellValue>,
    evicted: bool,
}

/// A unit direction in direction bin `bins` (`floor(2.5 + 2d)` per axis), if one exists.
fn bin_direction(bins: [u32; 3]) -> Option<Vec3> {
    let d = Vec3::new(
        bins[0] as f32 - 2.0,
        bins[1] as f32 - 2.0,
        bins[2] as f32 - 2.0,
    )
    .normalize_or_zero();
    (d != Vec3::ZERO).then_some(d)
}

/// Whether `desc`'s tile was in `before` and is no longer in `after` at the same slot.
fn was_evicted(
    desc: &CellDescriptor,
    grid: &HashGridParams,
    before: &[u32],
    after: &[u32],
) -> bool {
    (0..slots_per_bucket(grid)).any(|slot| {
        let t = tile_slot(desc.bucket, slot, grid.tiles_per_bucket_log2) as usize;
        t < before.len().min(after.len()) && before[t] == desc.checksum && after[t] != desc.checksum
    })
}

/// The best-sampled cell at the primary hit of `pixel` (see the [module](self)).
fn pixel_cell(
    camera: &CameraParams,
    grid: &HashGridParams,
    data: &GBufferData,
    pixel: UVec2,
    state: (&[u32], &[u32], &[HashCellValue]),
) -> Option<PixelCell> {
    let (keys_before, keys, values) = state;
    let t = data.texel(pixel.x, pixel.y);
    if !t.is_surface() {
        return None;
    }
    let s = primary_surface(camera, pixel, t.depth, t.geometric_normal, t.shading_normal);
    if !s.valid {
        return None;
    }
    let eye = camera.position();
    let view = (s.position - eye).normalize_or_zero();
    let distance = (s.position - eye).length();
    let mut best = PixelCell {
        desc: cell_descriptor(eye, s.position, view, distance, grid),
        value: None,
        evicted: false,
    };
    let n = DIRECTION_BINS;
    for bins in (0..n * n * n).map(|i| [i % n, (i / n) % n, i / (n * n)]) {
        let Some(d) = bin_direction(bins) else {
            continue;
        };
        for hit_distance in [0.0, f32::MAX] {
            let desc = cell_descriptor(eye, s.position, d, hit_distance, grid);
            if desc.is_none() || desc.dir_bin != bins {
                continue;
            }
            if was_evicted(&desc, grid, keys_before, keys) {
                best.evicted = true;
            }
            if let Some(tile) = find_tile(keys, &desc, grid) {
                let v = filtered_value(values, tile, desc.cell, grid.read_min_samples());
                if best.value.is_none_or(|b| v.count() > b.count()) {
                    best.desc = desc;
                    best.value = Some(v);
                }
            }
        }
    }
    Some(best)
}

/// A colour in `[0.2, 1]³` from hash bits.
fn hash_colour(h: u32) -> [f32; 3] {
    [h, h >> 8, h >> 16].map(|c| 0.2 + 0.8 * (c & 0xff) as f32 / 255.0)
}

/// Blue → green → red for `x` in `[0, 1]`.
fn ramp(x: f32) -> [f32; 3] {
    let x = x.clamp(0.0, 1.0);
    [
        (2.0 * x - 1.0).clamp(0.0, 1.0),
        1.0 - (2.0 * x - 1.0).abs(),
        (1.0 - 2.0 * x).clamp(0.0, 1.0),
    ]
}

/// Computes every [`DebugView`] of the last frame: `data` its G-buffer seen by `camera`, `grid`
/// its hash-grid parameters, `keys_before` the keys before the frame and `keys`, `values` after.
pub fn debug_views(
    camera: &CameraParams,
    grid: &HashGridParams,
    data: &GBufferData,
    keys_before: &[u32],
    keys: &[u32],
    values: &[HashCellValue],
) -> Result<Vec<(DebugView, HdrImage)>> {
    let (w, h) = (data.width, data.height);
    let cells: Vec<Option<PixelCell>> = (0..h)
        .flat_map(|y| (0..w).map(move |x| UVec2::new(x, y)))
        .map(|p| pixel_cell(camera, grid, data, p, (keys_before, keys, values)))
        .collect();
    let (lo, hi) = cells
        .iter()
        .flatten()
        .fold((MAX_LOD, MIN_LOD), |(lo, hi), c| {
            (lo.min(c.desc.lod), hi.max(c.desc.lod))
        });
    DebugView::ALL
        .iter()
        .map(|&view| {
            let pixels = cells
                .iter()
                .map(|c| match (view, c) {
                    (_, None) => [0.0; 3],
                    (DebugView::Hash, Some(c)) => {
                        hash_colour(pcg_chain([c.desc.checksum, c.desc.cell[0], c.desc.cell[1]]))
                    }
                    (DebugView::Lod, Some(c)) => {
                        ramp((c.desc.lod - lo) as f32 / (hi - lo).max(1) as f32)
                    }
                    (DebugView::SampleCount, Some(c)) => {
                        let n = c.value.map_or(0.0, |v| v.count());
                        [(n / grid.sample_cap.max(1) as f32).min(1.0); 3]
                    }
                    (DebugView::Radiance, Some(c)) => {
                        c.value.map_or([0.0; 3], |v| v.mean().to_array())
                    }
                    (DebugView::Evicted, Some(c)) => {
                        if c.evicted {
                            [1.0, 0.0, 0.0]
                        } else {
                            [0.25; 3]
                        }
                    }
                })
                .collect();
            Ok((view, HdrImage::from_pixels(w, h, pixels)?))
        })
        .collect()
}

/// Writes each view as `dir/<name>.png` and returns the paths.
pub fn write_debug_views(
    views: &[(DebugView, HdrImage)],
    dir: &Path,
    exposure: f32,
) -> Result<Vec<PathBuf>> {
    write_pngs(
        dir,
        views
            .iter()
            .map(|(v, image)| (v.name(), image, *v == DebugView::Radiance)),
        exposure,
    )
}

/// Writes `(name, image, radiance)` items as `dir/<name>.png` (radiance tone-mapped with
/// `exposure`, false-colour codes clamped), creating `dir`; returns the paths.
pub fn write_pngs<'a>(
    dir: &Path,
    views: impl IntoIterator<Item = (&'a str, &'a HdrImage, bool)>,
    exposure: f32,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::Image {
        path: dir.to_path_buf(),
        why: format!("cannot create the directory: {e}"),
    })?;
    views
        .into_iter()
        .map(|(name, image, radiance)| {
            let path = dir.join(format!("{name}.png"));
            let tone = if radiance {
                ToneMap {
                    exposure,
                    ..ToneMap::default()
                }
            } else {
                ToneMap::new(0.0, ToneCurve::Clamp)
            };
            image.write_png(&path, &tone)?;
            Ok(path)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_have_directions_that_fall_in_them() {
        let mut reachable = 0;
        let n = DIRECTION_BINS;
        for i in 0..n * n * n {
            let bins = [i % n, (i / n) % n, i / (n * n)];
            if let Some(d) = bin_direction(bins) {
                let back = [d.x, d.y, d.z].map(|c| ((2.5 + 2.0 * c).floor() as u32).min(n - 1));
                if back == bins {
                    reachable += 1;
                }
            }
        }
        // The six axis directions at least, and the diagonals.
        assert!(reachable >= 26, "{reachable}");
        assert_eq!(ramp(0.0), [0.0, 0.0, 1.0]);
        assert_eq!(ramp(1.0), [1.0, 0.0, 0.0]);
        assert!(hash_colour(0).iter().all(|&c| c >= 0.2));
    }
}
