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
//! ([`sample_texture`], sRGB decoded before filtering like an `_SRGB` format),
//! then blended by `fract(d')`. A NaN `lod` reads level 0 ([`clamped_lod`]). Devices filter with limited
//! sub-texel precision (Vulkan requires at least 4 bits for the weights; lavapipe and current
//! GPUs use 8), so the CPU and the device agree to about 1/256 of the texel contrast, not bit for
//! bit.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec4};
use num_traits::Float;

use crate::color::srgb_to_linear;
use crate::math::{ceil, clamp, floor, floor_to_i32_clamped, max_i32, min_i32};

/// Most mip levels a texture may have: a 65536² level 0 has 17. The table and the images use it
/// as the bound of the level loop.
pub const MAX_MIP_LEVELS: u32 = 17;

/// [`GpuTexture::wrap_u`]/[`GpuTexture::wrap_v`]: tile.
pub const WRAP_REPEAT: u32 = 0;
/// Tile, mirroring every other tile.
pub const WRAP_MIRRORED_REPEAT: u32 = 1;
/// Clamp to the edge texels.
pub const WRAP_CLAMP_TO_EDGE: u32 = 2;

/// An entry of the texture table (32 bytes).
///
/// | offset | field    |
/// |--------|----------|
/// | 0      | `offset` |
/// | 4      | `width`  |
/// | 8      | `height` |
/// | 12     | `srgb`   |
/// | 16     | `wrap_u` |
/// | 20     | `wrap_v` |
/// | 24     | `levels` |
/// | 28     | `_pad`   |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuTexture {
    /// Index of the texture's first texel in the CPU's texel array (see [`crate::textures`]);
    /// unused on the device, where each texture is its own image.
    pub offset: u32,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// 1 when the colour channels are sRGB-encoded (alpha never is).
    pub srgb: u32,
    /// Wrap mode of u: [`WRAP_REPEAT`], [`WRAP_MIRRORED_REPEAT`] or [`WRAP_CLAMP_TO_EDGE`].
    pub wrap_u: u32,
    /// Wrap mode of v.
    pub wrap_v: u32,
    /// Mip levels stored, level 0 first (at least 1).
    pub levels: u32,
    /// Explicit padding.
    pub _pad: u32,
}

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

/// Bilinear sample of one level, `texture`, at `uv` (`(0, 0)` is the top-left corner of the first texel) with
/// its wrap modes; sRGB colour channels are decoded to linear before filtering, like an `_SRGB`
/// image format. Non-finite coordinates read as 0; a texture whose texels lie outside `texels`, or
/// that is empty, reads as 1.
pub fn sample_texture(texture: &GpuTexture, texels: &[u32], uv: Vec2) -> Vec4 {
    let w = texture.width;
    let h = texture.height;
    let end = texture.offset as usize + w as usize * h as usize;
    if w == 0 || h == 0 || end > texels.len() {
        return Vec4::ONE;
    }
    let (x0, x1, fx) = texel_pair(uv.x, w, texture.wrap_u);
    let (y0, y1, fy) = texel_pair(uv.y, h, texture.wrap_v);
    let base = texture.offset as usize;
    let row0 = base + y0 as usize * w as usize;
    let row1 = base + y1 as usize * w as usize;
    let srgb = texture.srgb;
    let t00 = decode_texel(texels[row0 + x0 as usize], srgb);
    let t10 = decode_texel(texels[row0 + x1 as usize], srgb);
    let t01 = decode_texel(texels[row1 + x0 as usize], srgb);
    let t11 = decode_texel(texels[row1 + x1 as usize], srgb);
    let top = t00 + (t10 - t00) * fx;
    let bottom = t01 + (t11 - t01) * fx;
    top + (bottom - top) * fy
}

/// The two texel indices (each in `0..size`) that bilinear filtering at `coord` blends along one
/// axis, and the weight of the second.
#[inline]
fn texel_pair(coord: f32, size: u32, wrap: u32) -> (u32, u32, f32) {
    let c = if coord.is_finite() { coord } else { 0.0 };
    // Wrap in texture space first: exact for any magnitude, and keeps the texel index small.
    let c = if wrap == WRAP_CLAMP_TO_EDGE {
        clamp(c, 0.0, 1.0)
    } else if wrap == WRAP_MIRRORED_REPEAT {
        let t = c - 2.0 * floor(0.5 * c);
        if t > 1.0 { 2.0 - t } else { t }
    } else {
        c - floor(c)
    };
    let x = c * size as f32 - 0.5;
    let fx = floor(x);
    let n = size as i32;
    // x is in [-0.5, size - 0.5]: i0 in [-1, size - 1].
    let i0 = floor_to_i32_clamped(fx, -1, n - 1);
    let i1 = i0 + 1;
    let (a, b) = if wrap == WRAP_REPEAT {
        (
            if i0 < 0 { n - 1 } else { i0 },
            if i1 >= n { 0 } else { i1 },
        )
    } else {
        // Clamp and the mirror's seam both repeat the edge texel.
        (max_i32(i0, 0), min_i32(i1, n - 1))
    };
    (a as u32, b as u32, clamp(x - fx, 0.0, 1.0))
}

/// A packed RGBA8 texel (red in the low byte) as linear floats in `[0, 1]`.
#[inline]
pub fn decode_texel(texel: u32, srgb: u32) -> Vec4 {
    let c = Vec4::new(
        (texel & 0xff) as f32,
        ((texel >> 8) & 0xff) as f32,
        ((texel >> 16) & 0xff) as f32,
        (texel >> 24) as f32,
    ) * (1.0 / 255.0);
    if srgb != 0 {
        Vec4::new(
            srgb_to_linear(c.x),
            srgb_to_linear(c.y),
            srgb_to_linear(c.z),
            c.w,
        )
    } else {
        c
    }
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
pub(crate) mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

    #[test]
    fn gpu_texture_layout() {
        assert_eq!(size_of::<GpuTexture>(), 32);
        assert_eq!(offset_of!(GpuTexture, offset), 0);
        assert_eq!(offset_of!(GpuTexture, width), 4);
        assert_eq!(offset_of!(GpuTexture, height), 8);
        assert_eq!(offset_of!(GpuTexture, srgb), 12);
        assert_eq!(offset_of!(GpuTexture, wrap_u), 16);
        assert_eq!(offset_of!(GpuTexture, wrap_v), 20);
        assert_eq!(offset_of!(GpuTexture, levels), 24);
        assert_eq!(offset_of!(GpuTexture, _pad), 28);
    }

    fn rgba(r: u32, g: u32, b: u32, a: u32) -> u32 {
        r | (g << 8) | (b << 16) | (a << 24)
    }

    /// A 2×2 texture at offset 1 of the texel buffer: black, white / red, green.
    pub(crate) fn two_by_two(wrap: u32, srgb: u32) -> (GpuTexture, [u32; 5]) {
        let texels = [
            0xdead_beef,
            rgba(0, 0, 0, 255),
            rgba(255, 255, 255, 255),
            rgba(255, 0, 0, 255),
            rgba(0, 255, 0, 0),
        ];
        let t = GpuTexture {
            offset: 1,
            width: 2,
            height: 2,
            srgb,
            wrap_u: wrap,
            wrap_v: wrap,
            levels: 1,
            _pad: 0,
        };
        (t, texels)
    }

    fn close(a: Vec4, b: Vec4) -> bool {
        (a - b).abs().max_element() < 1e-6
    }

    #[test]
    fn texel_centres_read_exactly() {
        let (t, texels) = two_by_two(WRAP_REPEAT, 0);
        let at = |u, v| sample_texture(&t, &texels, Vec2::new(u, v));
        assert!(close(at(0.25, 0.25), Vec4::new(0.0, 0.0, 0.0, 1.0)));
        assert!(close(at(0.75, 0.25), Vec4::ONE));
        assert!(close(at(0.25, 0.75), Vec4::new(1.0, 0.0, 0.0, 1.0)));
        assert!(close(at(0.75, 0.75), Vec4::new(0.0, 1.0, 0.0, 0.0)));
        // Half way between the two top texels.
        assert!(close(at(0.5, 0.25), Vec4::new(0.5, 0.5, 0.5, 1.0)));
    }

    #[test]
    fn wrap_modes() {
        // u = 0: between the last and the first texel of a row when repeating, the first alone when
        // clamping or mirroring.
        let (t, texels) = two_by_two(WRAP_REPEAT, 0);
        let s = sample_texture(&t, &texels, Vec2::new(0.0, 0.25));
        assert!(close(s, Vec4::new(0.5, 0.5, 0.5, 1.0)), "{s}");
        // Whole tiles away, repeating gives the same value, even far out.
        for k in [-3.0, 1.0, 1000.0] {
            let s = sample_texture(&t, &texels, Vec2::new(0.75 + k, 0.25 - k));
            assert!(close(s, Vec4::ONE), "{k}: {s}");
        }
        let (t, texels) = two_by_two(WRAP_CLAMP_TO_EDGE, 0);
        let s = sample_texture(&t, &texels, Vec2::new(0.0, 0.25));
        assert!(close(s, Vec4::new(0.0, 0.0, 0.0, 1.0)), "{s}");
        let s = sample_texture(&t, &texels, Vec2::new(7.0, -5.0));
        assert!(close(s, Vec4::ONE), "clamped to the top right: {s}");
        let (t, texels) = two_by_two(WRAP_MIRRORED_REPEAT, 0);
        // Mirrored: u = 1.25 reads like u = 0.75, u = 1.75 like u = 0.25.
        let s = sample_texture(&t, &texels, Vec2::new(1.25, 0.25));
        assert!(close(s, Vec4::ONE), "{s}");
        let s = sample_texture(&t, &texels, Vec2::new(1.75, 0.25));
        assert!(close(s, Vec4::new(0.0, 0.0, 0.0, 1.0)), "{s}");
        let s = sample_texture(&t, &texels, Vec2::new(-0.25, 0.25));
        assert!(close(s, Vec4::new(0.0, 0.0, 0.0, 1.0)), "{s}");
    }

    #[test]
    fn srgb_decodes_colour_not_alpha() {
        let t = GpuTexture {
            offset: 0,
            width: 1,
            height: 1,
            srgb: 1,
            wrap_u: WRAP_REPEAT,
            wrap_v: WRAP_REPEAT,
            levels: 1,
            _pad: 0,
        };
        let s = sample_texture(&t, &[rgba(230, 40, 0, 128)], Vec2::splat(0.3));
        assert!((s.x - 0.791_298).abs() < 1e-5, "{s}");
        assert!((s.y - 0.021_219).abs() < 1e-5, "{s}");
        assert_eq!(s.z, 0.0);
        assert!((s.w - 128.0 / 255.0).abs() < 1e-6);
    }

    #[test]
    fn bad_input_is_defined() {
        let (t, texels) = two_by_two(WRAP_REPEAT, 0);
        for uv in [
            Vec2::new(f32::NAN, 0.5),
            Vec2::new(f32::INFINITY, f32::NEG_INFINITY),
        ] {
            let s = sample_texture(&t, &texels, uv);
            assert!(s.is_finite(), "{uv}: {s}");
        }
        let big = GpuTexture { width: 4, ..t };
        assert_eq!(sample_texture(&big, &texels, Vec2::ZERO), Vec4::ONE);
        let empty = GpuTexture { width: 0, ..t };
        assert_eq!(sample_texture(&empty, &texels, Vec2::ZERO), Vec4::ONE);
    }

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
