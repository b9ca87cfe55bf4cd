//! Mip chains of RGBA8 textures.
//!
//! # The filter
//!
//! Level `l + 1` is `max(1, w / 2) × max(1, h / 2)` texels when level `l` is `w × h` (integer
//! division), down to 1×1. Each texel of the smaller level is the average of the area of the
//! larger level it covers: with `w'` texels from `w`, destination texel `x` covers source
//! interval `[x·w/w', (x+1)·w/w')`, and each source texel counts with the length of its overlap
//! with that interval. For even sizes this is the 2×2 box; for odd sizes (`w/w'` between 2 and 3)
//! the middle texel is split between its two neighbours, so every source texel contributes with
//! the weight of its footprint and the level's mean is kept (up to the final rounding). The filter
//! is separable: rows, then columns, with the exact integer overlaps as weights.
//!
//! Colour channels of sRGB textures are averaged in linear space (decoded through
//! [`srgb_to_linear`], re-encoded to the nearest sRGB byte: the inverse,
//! [`linear_to_srgb`](gi_shared::color::linear_to_srgb), rounded); alpha, and every channel of linear
//! textures, is averaged as stored. Results are rounded to the nearest 8-bit value. Each level is
//! made from the one above it, in parallel over its rows.

use gi_shared::color::srgb_to_linear;
use rayon::prelude::*;

/// Width or height of level `level` of a texture whose level 0 is `size`.
pub fn level_size(size: u32, level: usize) -> u32 {
    let level = u32::try_from(level).unwrap_or(u32::MAX);
    gi_shared::textures::level_size(size, 1, level).0
}

/// Number of levels of a complete chain from `width × height` down to 1×1.
pub fn level_count(width: u32, height: u32) -> usize {
    gi_shared::textures::mip_levels(width.max(1), height.max(1)) as usize
}

/// The complete mip chain of a `width × height` RGBA8 image: `level0` first, then each smaller
/// level down to 1×1 (see the [module](self) for the filter).
///
/// # Panics
/// If `level0` does not hold `width × height × 4` bytes.
pub fn mip_chain(level0: Vec<u8>, width: u32, height: u32, srgb: bool) -> Vec<Vec<u8>> {
    assert_eq!(
        level0.len(),
        width as usize * height as usize * 4,
        "level 0 must hold width × height RGBA8 texels"
    );
    let count = level_count(width, height);
    let mut levels = Vec::with_capacity(count);
    levels.push(level0);
    let decode = Decode::new(srgb);
    for level in 1..count {
        let (w, h) = (level_size(width, level - 1), level_size(height, level - 1));
        let next = downsample(&levels[level - 1], w, h, &decode);
        levels.push(next);
    }
    levels
}

/// Cells of the sRGB encoding table over linear [0, 1]: more than the steepest slope of the sRGB
/// curve (12.92 × 255 ≈ 3295 codes per unit, at black), so a cell never spans two code
/// boundaries.
const ENCODE_CELLS: usize = 4096;

/// 8-bit value <-> linear value, per channel, through tables.
struct Decode {
    colour: [f32; 256],
    /// For sRGB colour, encoding without a power function per channel.
    encode: Option<SrgbEncode>,
}

/// Linear value -> nearest sRGB byte.
struct SrgbEncode {
    /// `thresholds[b]`: the linear value from which byte `b + 1` is nearer than byte `b` (the
    /// decoded midpoint of the two codes); infinity after the last.
    thresholds: [f32; 256],
    /// The byte at the start of each of [`ENCODE_CELLS`] equal cells of [0, 1].
    cells: Vec<u8>,
}

impl SrgbEncode {
    fn new() -> Self {
        let thresholds = std::array::from_fn(|b| match b {
            255 => f32::INFINITY,
            _ => srgb_to_linear((b as f32 + 0.5) / 255.0),
        });
        let cells = (0..ENCODE_CELLS)
            .map(|i| {
                let start = i as f32 / ENCODE_CELLS as f32;
                thresholds.partition_point(|&t| t <= start) as u8
            })
            .collect();
        Self { thresholds, cells }
    }

    fn encode(&self, c: f32) -> u8 {
        let c = c.clamp(0.0, 1.0);
        let cell = ((c * ENCODE_CELLS as f32) as usize).min(ENCODE_CELLS - 1);
        let b = self.cells[cell];
        // At most one code boundary lies inside a cell.
        b + u8::from(c >= self.thresholds[b as usize])
    }
}

impl Decode {
    fn new(srgb: bool) -> Self {
        let colour = std::array::from_fn(|v| {
            let c = v as f32 / 255.0;
            if srgb { srgb_to_linear(c) } else { c }
        });
        Self {
            colour,
            encode: srgb.then(SrgbEncode::new),
        }
    }

    fn texel(&self, t: &[u8; 4]) -> [f32; 4] {
        [
            self.colour[t[0] as usize],
            self.colour[t[1] as usize],
            self.colour[t[2] as usize],
            f32::from(t[3]) / 255.0,
        ]
    }

    fn encode(&self, linear: [f32; 4]) -> [u8; 4] {
        let quantise = |c: f32| (c.clamp(0.0, 1.0) * 255.0).round() as u8;
        let colour = |c: f32| match &self.encode {
            Some(srgb) => srgb.encode(c),
            None => quantise(c),
        };
        [
            colour(linear[0]),
            colour(linear[1]),
            colour(linear[2]),
            quantise(linear[3]),
        ]
    }
}

/// For each destination texel along an axis of `from` source texels, the source texels it covers
/// and their weights (summing to one).
fn footprints(from: u32) -> Vec<Vec<(usize, f32)>> {
    let (from, to) = (u64::from(from), u64::from(level_size(from, 1)));
    // In units of 1/to of a source texel: destination x spans [x·from, (x+1)·from), source
    // texel s spans [s·to, (s+1)·to).
    (0..to)
        .map(|x| {
            let (start, end) = (x * from, (x + 1) * from);
            (start / to..end.div_ceil(to))
                .map(|s| {
                    let overlap = end.min((s + 1) * to) - start.max(s * to);
                    (s as usize, overlap as f32 / from as f32)
                })
                .collect()
        })
        .collect()
}

fn downsample(src: &[u8], width: u32, height: u32, decode: &Decode) -> Vec<u8> {
    let (to_w, to_h) = (
        level_size(width, 1) as usize,
        level_size(height, 1) as usize,
    );
    let (columns, rows) = (footprints(width), footprints(height));
    let texels = src.as_chunks::<4>().0;
    let mut out = vec![0u8; to_w * to_h * 4];
    // A few rows per task: enough work to pay for the task, enough tasks for all cores.
    let rows_per_task = (16_384 / to_w).max(1);
    out.par_chunks_mut(to_w * 4)
        .with_min_len(rows_per_task)
        .zip(rows.par_iter())
        .for_each(|(out_row, row_weights)| {
            let mut sum = vec![[0.0f32; 4]; to_w];
            for &(sy, wy) in row_weights {
                let src_row = &texels[sy * width as usize..(sy + 1) * width as usize];
                for (acc, column_weights) in sum.iter_mut().zip(&columns) {
                    for &(sx, wx) in column_weights {
                        let t = decode.texel(&src_row[sx]);
                        let w = wx * wy;
                        acc.iter_mut().zip(t).for_each(|(a, c)| *a += w * c);
                    }
                }
            }
            for (texel, acc) in out_row.as_chunks_mut::<4>().0.iter_mut().zip(sum) {
                *texel = decode.encode(acc);
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use gi_shared::color::linear_to_srgb;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 4]) -> Vec<u8> {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .flat_map(|(x, y)| f(x, y))
            .collect()
    }

    #[test]
    fn level_sizes_go_down_to_one_by_one() {
        let levels = mip_chain(vec![0; 13 * 5 * 4], 13, 5, true);
        let sizes: Vec<(u32, u32)> = (0..levels.len())
            .map(|l| (level_size(13, l), level_size(5, l)))
            .collect();
        assert_eq!(sizes, [(13, 5), (6, 2), (3, 1), (1, 1)]);
        for (level, &(w, h)) in levels.iter().zip(&sizes) {
            assert_eq!(level.len(), (w * h * 4) as usize);
        }
        assert_eq!(level_count(1, 1), 1);
        assert_eq!(level_count(1024, 1), 11);
        assert_eq!(level_count(4, 1024), 11);
    }

    #[test]
    fn a_constant_image_stays_constant() {
        for (w, h) in [(8, 8), (7, 3), (5, 1), (1, 9)] {
            let texel = [200, 13, 77, 128];
            for srgb in [false, true] {
                let levels = mip_chain(image(w, h, |_, _| texel), w, h, srgb);
                for level in &levels {
                    assert!(level.as_chunks::<4>().0.iter().all(|t| *t == texel));
                }
            }
        }
    }

    #[test]
    fn two_by_two_is_the_exact_average() {
        let src = image(2, 2, |x, y| {
            [(x * 100 + y * 20) as u8, 10, 250, (x * 51) as u8]
        });
        let levels = mip_chain(src, 2, 2, false);
        // Red: (0 + 100 + 20 + 120) / 4 = 60; alpha: (0 + 51 + 0 + 51) / 4 = 25.5 -> 26.
        assert_eq!(levels[1], [60, 10, 250, 26]);
    }

    #[test]
    fn srgb_colour_is_averaged_in_linear_space_and_alpha_is_not() {
        let src = image(2, 1, |x, _| match x {
            0 => [0, 0, 0, 0],
            _ => [255, 255, 255, 255],
        });
        let srgb = mip_chain(src.clone(), 2, 1, true);
        // Linear 0.5 is sRGB 0.7354 = 187.5 / 255; alpha stays linear: 127.5 -> 128.
        assert_eq!(srgb[1], [188, 188, 188, 128]);
        let linear = mip_chain(src, 2, 1, false);
        assert_eq!(linear[1], [128, 128, 128, 128]);
    }

    /// The mean of a level's channel `c`, decoded.
    fn mean(level: &[u8], c: usize, decode: &Decode) -> f32 {
        let texels = level.as_chunks::<4>().0;
        texels.iter().map(|t| decode.texel(t)[c]).sum::<f32>() / texels.len() as f32
    }

    #[test]
    fn odd_sizes_keep_the_mean() {
        for (w, h) in [(3, 1), (5, 3), (1, 5), (7, 7), (9, 2)] {
            for srgb in [false, true] {
                let decode = Decode::new(srgb);
                let src = image(w, h, |x, y| {
                    let v = (x * 37 + y * 91) % 256;
                    [v as u8, (255 - v) as u8, (v * 3 % 256) as u8, (v / 2) as u8]
                });
                let levels = mip_chain(src, w, h, srgb);
                for c in 0..4 {
                    let m0 = mean(&levels[0], c, &decode);
                    for level in &levels[1..] {
                        // One rounding step per level, of at most half a code (sRGB codes near
                        // white are 0.011 linear apart).
                        let tolerance = levels.len() as f32 * 0.5 * 0.011;
                        let m = mean(level, c, &decode);
                        assert!(
                            (m - m0).abs() <= tolerance,
                            "{w}x{h} srgb {srgb} channel {c}: {m} vs {m0}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn three_by_one_weighs_each_texel_by_its_footprint() {
        let src = image(3, 1, |x, _| [(x * 90) as u8, 0, 0, 255]);
        // (0 + 90 + 180) / 3 = 90: each texel a third, the middle one not doubled.
        assert_eq!(mip_chain(src, 3, 1, false)[1], [90, 0, 0, 255]);
        // 5 -> 2: weights 1, 1, 1/2 | 1/2, 1, 1 over 2.5 texels.
        let src = image(5, 1, |x, _| [(x * 50) as u8, 0, 0, 255]);
        let expected = |a: f32| (a / 2.5).round() as u8;
        assert_eq!(
            mip_chain(src, 5, 1, false)[1],
            [
                expected(50.0 + 50.0),
                0,
                0,
                255,
                expected(50.0 + 150.0 + 200.0),
                0,
                0,
                255
            ]
        );
    }

    #[test]
    fn non_square_images_reduce_both_axes_until_one_is_one() {
        let src = image(8, 2, |x, _| [if x < 4 { 0 } else { 200 }, 0, 0, 255]);
        let levels = mip_chain(src, 8, 2, false);
        assert_eq!(levels.len(), 4);
        assert_eq!(
            levels[1],
            image(4, 1, |x, _| [if x < 2 { 0 } else { 200 }, 0, 0, 255])
        );
        assert_eq!(
            levels[2],
            image(2, 1, |x, _| [if x < 1 { 0 } else { 200 }, 0, 0, 255])
        );
        assert_eq!(levels[3], [100, 0, 0, 255]);
    }

    #[test]
    fn the_encoding_table_rounds_like_the_transfer_function() {
        let decode = Decode::new(true);
        for i in 0..=100_000 {
            let linear = i as f32 / 100_000.0;
            let exact = linear_to_srgb(linear) * 255.0;
            let table = decode.encode([linear; 4])[0];
            // The same byte, except where the exact value is within float noise of a midpoint.
            if (exact - exact.floor() - 0.5).abs() > 1e-3 {
                assert_eq!(table, exact.round() as u8, "{linear}");
            }
        }
    }

    #[test]
    fn every_srgb_byte_round_trips() {
        let decode = Decode::new(true);
        for v in 0..=255u8 {
            let linear = decode.texel(&[v, v, v, v]);
            assert_eq!(decode.encode(linear), [v; 4], "{v}");
        }
    }

    #[test]
    fn large_images_match_the_per_texel_average() {
        // Exercises the parallel path: several row tasks.
        let (w, h) = (600, 200);
        let src = image(w, h, |x, y| [(x % 256) as u8, (y % 256) as u8, 7, 255]);
        let levels = mip_chain(src.clone(), w, h, false);
        let at = |x: u32, y: u32| &src[((y * w + x) * 4) as usize..][..4];
        for (x, y) in [(0, 0), (123, 45), (299, 99)] {
            let r: u32 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                .iter()
                .map(|&(dx, dy)| u32::from(at(2 * x + dx, 2 * y + dy)[0]))
                .sum();
            let got = levels[1][((y * (w / 2) + x) * 4) as usize];
            assert_eq!(
                u32::from(got),
                (r as f32 / 4.0).round() as u32,
                "({x}, {y})"
            );
        }
    }
}
