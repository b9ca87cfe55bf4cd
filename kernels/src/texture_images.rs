//! The scene's textures as the kernels read them: one bindless array of sampled images (set 2,
//! binding 6; each image with its mip chain, its sampler carrying the wrap modes), behind the
//! shared [`TextureImages`] read that the CPU reference implements over its texel array.

use gi_shared::textures::GpuTexture;
use gi_shared::textures::{TextureImages, clamped_lod};
use spirv_std::glam::{Vec2, Vec4};
use spirv_std::image::SampledImage;
use spirv_std::{Image, RuntimeArray};

/// One texture: a 2D float-sampled image (`R8G8B8A8_SRGB` or `_UNORM`), combined with its sampler.
pub type TextureImage = SampledImage<Image!(2D, type = f32, sampled)>;

/// The scene's textures, indexed like its texture table (`descriptorCount` = the table's length,
/// a variable-count binding).
pub type SceneTextures = RuntimeArray<TextureImage>;

/// The bindless array as a [`TextureImages`].
#[derive(Clone, Copy)]
pub struct Bindless<'a>(pub &'a SceneTextures);

impl TextureImages for Bindless<'_> {
    fn sample(&self, texture: &GpuTexture, index: u32, uv: Vec2, lod: f32) -> Vec4 {
        // SAFETY: the shared callers only pass indices below the texture table's length, and the
        // host writes one descriptor per table entry. `index` makes the access non-uniform.
        let image = unsafe { self.0.index(index as usize) };
        image.sample_by_lod(uv, clamped_lod(lod, texture.levels))
    }
}
