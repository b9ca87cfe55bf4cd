//! Filtered texture reads with mip maps: the trilinear filter of a Vulkan sampler
//! (`VK_FILTER_LINEAR`, `VK_SAMPLER_MIPMAP_MODE_LINEAR`, an explicit level of detail), written
//! out so that the CPU reference reads textures exactly as the kernels' sampled images do.
//!
//! # Where the texels live
//!
//! On the device every texture is its own sampled image (`R8G8B8A8_SRGB` or `_UNORM`, with its
//! whole mip chain) in one bindless array, indexed by the texture's index in the table
//! ([`GpuTexture`]); the sampler carries the wrap modes. On the CPU the same texels sit in one
//! `u32` array (RGBA8, red in the low byte): texture by texture from [`GpuTexture::offset`],
//! level after level, each level row by row from the top. Both read through [`TextureImages`].
//!
//! # The filter
//!
//! For a level of detail `lod`, Vulkan's `d' = clamp(lod, 0, levels - 1)`; the two levels
//! `floor(d')` and `floor(d') + 1` (clamped to the last) are each read bilinearly
//! ([`crate::scene_data::sample_texture`], sRGB decoded before filtering like an `_SRGB` format),
//! then blended by `fract(d')`. A NaN `lod` reads level 0 ([`clamped_lod`]). Devices filter with limited
//! sub-texel precision (Vulkan requires at least 4 bits for the weights; lavapipe and current
//! GPUs use 8), so the CPU and the device agree to about 1/256 of the texel contrast, not bit for
//! bit.

use glam::{Vec2, Vec4};
use num_traits::Float;

use crate::math::{ceil, clamp, floor};
use crate::scene_data::{GpuTexture, sample_texture};

/// Most mip levels a texture may have: a 65536² level 0 has 17. The table and the images use it
/// as the bound of the level loop.
pub const MAX_MIP_LEVELS: u32 = 17;

/// A texture read, as the kernels' shading functions need it: implemented by the device's
/// bindless array of sampled images (`kernels`) and by the CPU's texel array (`[u32]`).
pub trait TextureImages {
    /// Texture `index` (its table entry is `texture`) at `uv`, filtered at level of detail `lod`
    /// (level 0 = full resolution; see the [module](self)).
    fn sample(&self, texture: &GpuTexture, index: u32, uv: Vec2, lod: f32) -> Vec4;
}

/// The CPU's texel array (see the [module](self)).
impl TextureImages for [u32] {
    #[inline]
    fn sample(&self, texture: &GpuTexture, _index: u32, uv: Vec2, lod: f32) -> Vec4 {
        sample_mips(texture, self, uv, lod)
    }
}

/// The number of levels of a full mip chain of a `width × height` image (down to 1 × 1).
pub fn mip_levels(width: u32, height: u32) -> u32 {
    let largest = if width > height { width } else { height };
    if largest == 0 {
        0
    } else {
        32 - largest.leading_zeros()
    }
}

/// The size of level `level` of a `width × height` image: each side halved per level, rounded
/// down, at least 1 (as Vulkan sizes mip levels).
#[inline]
pub fn level_size(width: u32, height: u32, level: u32) -> (u32, u32) {
    let shift = if level < 32 { level } else { 31 };
    let w = width >> shift;
    let h = height >> shift;
    (if w == 0 { 1 } else { w }, if h == 0 { 1 } else { h })
}

/// Texels of levels `0..level` of a `width × height` image: where level `level` starts after
/// the texture's first texel.
pub fn level_offset(width: u32, height: u32, level: u32) -> usize {
    let mut offset = 0;
    let mut l = 0;
    while l < level && l < MAX_MIP_LEVELS {
        let (w, h) = level_size(width, height, l);
        offset += w as usize * h as usize;
        l += 1;
    }
    offset
}

/// Vulkan's `clamp(lod, 0, levels - 1)`, NaN read as 0: the level of detail a sampler uses.
#[inline]
pub fn clamped_lod(lod: f32, levels: u32) -> f32 {
    let last = if levels == 0 {
        0.0
    } else {
        (levels - 1) as f32
    };
    if lod.is_nan() {
        0.0
    } else {
        clamp(lod, 0.0, last)
    }
}

/// The table entry of level `level` alone, for a bilinear read.
#[inline]
fn level_entry(texture: &GpuTexture, level: u32) -> GpuTexture {
    let (w, h) = level_size(texture.width, texture.height, level);
    GpuTexture {
        offset: texture.offset + level_offset(texture.width, texture.height, level) as u32,
        width: w,
        height: h,
        levels: 1,
        ..*texture
    }
}

/// Trilinear read of `texture` from the CPU's texel array (see the [module](self)): the same
/// filter as a device sampler. A texture whose texels lie outside `texels` reads as 1.
pub fn sample_mips(texture: &GpuTexture, texels: &[u32], uv: Vec2, lod: f32) -> Vec4 {
    let levels = texture.levels.clamp(1, MAX_MIP_LEVELS);
    let d = clamped_lod(lod, levels);
    let low = floor(d);
    let fraction = d - low;
    let low = low as u32;
    let near = sample_texture(&level_entry(texture, low), texels, uv);
    if fraction <= 0.0 || low + 1 >= levels {
        return near;
    }
    let far = sample_texture(&level_entry(texture, low + 1), texels, uv);
    near + (far - near) * fraction
}

/// Most taps of one anisotropic read ([`sample_footprint`]): footprints longer than this many
/// times their width are read this many times, each tap a little blurred along the long axis,
/// as a device sampler's `maxAnisotropy` (16 on current GPUs) does.
pub const MAX_ANISOTROPY: u32 = 16;

/// Where a texture read falls in texture coordinates: the UV change across the footprint along
/// its two axes (for a pixel, the UV derivatives along the image's x and y). A parallelogram
/// centred on the read's coordinate; both zero read level 0 at that point alone.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct UvFootprint {
    /// The footprint's first axis, UV units.
    pub x: Vec2,
    /// The footprint's second axis, UV units.
    pub y: Vec2,
}

impl UvFootprint {
    /// A point: level 0, one tap.
    pub const POINT: Self = Self {
        x: Vec2::ZERO,
        y: Vec2::ZERO,
    };

    /// A disc `width` UV units across (a ray cone's footprint, [`crate::ray_cone`]); a point for a
    /// width that is 0, negative or NaN.
    #[inline]
    pub fn isotropic(width: f32) -> Self {
        let w = if width > 0.0 { width } else { 0.0 };
        Self {
            x: Vec2::new(w, 0.0),
            y: Vec2::new(0.0, w),
        }
    }
}

/// Texture `index` (table entry `texture`) at `uv`, filtered over `footprint`: the anisotropic
/// filter of a sampler with explicit gradients. Both axes are scaled to texels; the footprint's
/// length over its width, rounded up and at most [`MAX_ANISOTROPY`], is the tap count `n`; the
/// `n` trilinear taps sit evenly along the long axis, each at the level of the footprint's width,
/// or of its length over [`MAX_ANISOTROPY`] where that is coarser (so the level never jumps
/// where `n` does, unlike Vulkan's `ρmax / N`). A narrow footprint at a grazing angle so keeps the detail across it
/// that one isotropic read, sized by its length, would blur away. Non-finite axes read one tap
/// at the coarsest level (infinite) or at level 0 (NaN).
pub fn sample_footprint<I: TextureImages + ?Sized>(
    images: &I,
    texture: &GpuTexture,
    index: u32,
    uv: Vec2,
    footprint: UvFootprint,
) -> Vec4 {
    let texels = Vec2::new(texture.width as f32, texture.height as f32);
    let (a, b) = (
        (footprint.x * texels).length(),
        (footprint.y * texels).length(),
    );
    let (axis, major, minor) = if a >= b {
        (footprint.x, a, b)
    } else {
        (footprint.y, b, a)
    };
    let max = MAX_ANISOTROPY as f32;
    let (taps, width) = if !(major.is_finite() && major > 0.0) {
        (1.0, major)
    } else if minor * max > major {
        (ceil(major / minor), minor)
    } else {
        (max, major / max)
    };
    let lod = Float::log2(width);
    if taps <= 1.0 {
        return images.sample(texture, index, uv, lod);
    }
    let mut sum = Vec4::ZERO;
    let mut i = 0.0;
    while i < taps {
        let offset = (i + 0.5) / taps - 0.5;
        sum += images.sample(texture, index, uv + axis * offset, lod);
        i += 1.0;
    }
    sum / taps
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene_data::{WRAP_CLAMP_TO_EDGE, WRAP_REPEAT};

    fn grey(v: u32) -> u32 {
        v | (v << 8) | (v << 16) | (255 << 24)
    }

    /// A 4 × 2 texture with its chain (2 × 1, 1 × 1): level 0 has grey 0 and 200 in alternate
    /// columns, level 1 is grey 100, level 2 grey 40.
    fn chain() -> (GpuTexture, Vec<u32>) {
        let mut texels = vec![0xdead_beef];
        for _ in 0..2 {
            texels.extend([grey(0), grey(200), grey(0), grey(200)]);
        }
        texels.extend([grey(100), grey(100)]);
        texels.push(grey(40));
        let texture = GpuTexture {
            offset: 1,
            width: 4,
            height: 2,
            srgb: 0,
            wrap_u: WRAP_REPEAT,
            wrap_v: WRAP_CLAMP_TO_EDGE,
            levels: 3,
            _pad: 0,
        };
        (texture, texels)
    }

    #[test]
    fn level_sizes_and_offsets_follow_vulkan() {
        assert_eq!(mip_levels(1, 1), 1);
        assert_eq!(mip_levels(4, 2), 3);
        assert_eq!(mip_levels(1000, 3), 10);
        assert_eq!(mip_levels(65536, 1), MAX_MIP_LEVELS);
        assert_eq!(mip_levels(0, 0), 0);
        assert_eq!(level_size(1000, 3, 1), (500, 1));
        assert_eq!(level_size(1000, 3, 9), (1, 1));
        assert_eq!(level_offset(4, 2, 0), 0);
        assert_eq!(level_offset(4, 2, 1), 8);
        assert_eq!(level_offset(4, 2, 2), 10);
        assert_eq!(level_offset(4, 2, 3), 11);
    }

    #[test]
    fn the_level_of_detail_picks_and_blends_levels() {
        let (t, texels) = chain();
        let at = |uv: Vec2, lod: f32| sample_mips(&t, &texels, uv, lod).x * 255.0;
        // Level 0 at a texel centre: exact.
        let centre = Vec2::new(0.375, 0.25);
        assert!((at(centre, 0.0) - 200.0).abs() < 1e-3);
        // Negative and NaN levels read level 0 (magnification).
        assert!((at(centre, -3.0) - 200.0).abs() < 1e-3);
        assert!((at(centre, f32::NAN) - 200.0).abs() < 1e-3);
        assert!((at(centre, f32::NEG_INFINITY) - 200.0).abs() < 1e-3);
        assert!((at(centre, f32::INFINITY) - 40.0).abs() < 1e-3);
        // Level 1 everywhere 100, level 2 40; half way between is the mean.
        assert!((at(centre, 1.0) - 100.0).abs() < 1e-3);
        assert!((at(centre, 1.5) - 70.0).abs() < 1e-3);
        assert!((at(centre, 2.0) - 40.0).abs() < 1e-3);
        // Past the last level: the last level.
        assert!((at(centre, 9.0) - 40.0).abs() < 1e-3);
        // A quarter of the way from level 0 to level 1.
        assert!((at(centre, 0.25) - (200.0 * 0.75 + 100.0 * 0.25)).abs() < 1e-3);
        // A table entry claiming more levels than the texels hold reads as 1, not out of bounds.
        let short = GpuTexture { levels: 5, ..t };
        assert_eq!(sample_mips(&short, &texels, centre, 4.0), Vec4::ONE);
    }

    #[test]
    fn an_isotropic_footprint_reads_the_level_of_its_width_in_texels() {
        let (t, texels) = chain();
        let at = |f: UvFootprint| sample_footprint(&texels[..], &t, 0, Vec2::new(0.375, 0.5), f);
        // A point and a NaN footprint read level 0; half a UV unit is 2 × 1 texels: level 1.
        assert_eq!(
            at(UvFootprint::POINT),
            sample_mips(&t, &texels, Vec2::new(0.375, 0.5), 0.0)
        );
        assert_eq!(at(UvFootprint::isotropic(f32::NAN)), at(UvFootprint::POINT));
        let level1 = sample_mips(&t, &texels, Vec2::new(0.375, 0.5), 1.0);
        assert_eq!(
            at(UvFootprint {
                x: Vec2::new(0.5, 0.0),
                y: Vec2::new(0.0, 1.0)
            }),
            level1
        );
        // Infinitely wide: the coarsest level, one tap.
        let last = sample_mips(&t, &texels, Vec2::new(0.375, 0.5), 2.0);
        assert_eq!(at(UvFootprint::isotropic(f32::INFINITY)), last);
    }

    #[test]
    fn a_long_footprint_keeps_the_detail_across_it() {
        // 16 × 16 texels of vertical stripes (a column is black or white, alternating every
        // texel pair) read with a footprint 8 texels long down the stripes, 1 texel across.
        let size = 16;
        let mut texels = vec![0];
        let mut chain_size = size;
        while chain_size >= 1 {
            for _y in 0..chain_size {
                for x in 0..chain_size {
                    let white = chain_size == size && (x / 2) % 2 == 1;
                    texels.push(grey(if chain_size < size {
                        128
                    } else if white {
                        255
                    } else {
                        0
                    }));
                }
            }
            chain_size /= 2;
        }
        let t = GpuTexture {
            offset: 1,
            width: size,
            height: size,
            levels: mip_levels(size, size),
            wrap_u: WRAP_REPEAT,
            wrap_v: WRAP_REPEAT,
            ..GpuTexture::default()
        };
        let texel = 1.0 / size as f32;
        let long = UvFootprint {
            x: Vec2::new(texel, 0.0),
            y: Vec2::new(0.0, 8.0 * texel),
        };
        // The centre of a black and of a white column pair.
        let black = sample_footprint(&texels[..], &t, 0, Vec2::new(1.0 * texel, 0.5), long);
        let white = sample_footprint(&texels[..], &t, 0, Vec2::new(3.0 * texel, 0.5), long);
        assert!(black.x < 0.01 && white.x > 0.99, "{black} {white}");
        // One isotropic read sized by the footprint's length would blur them together.
        let blurred = sample_footprint(
            &texels[..],
            &t,
            0,
            Vec2::new(1.0 * texel, 0.5),
            UvFootprint::isotropic(8.0 * texel),
        );
        assert!(blurred.x > 0.1, "{blurred}");
        // Longer than MAX_ANISOTROPY times its width: capped taps, never more.
        let needle = UvFootprint {
            x: Vec2::new(1e-9, 0.0),
            y: Vec2::new(0.0, 1.0),
        };
        assert!(sample_footprint(&texels[..], &t, 0, Vec2::splat(0.5), needle).is_finite());
    }
}
