//! The G-buffer pass: one primary ray per pixel, traced with [`crate::trace`], shaded by
//! [`gi_shared::gbuffer::gbuffer_texel`] and written to the G-buffer's storage images (formats and
//! contents in `gi_shared::gbuffer`).
//!
//! Set 0: the camera (`CameraParams`), then the images (depth, geometric normal, shading normal,
//! albedo, emissive, motion, ids), then the instances' previous transforms
//! (`PreviousTransform`s, for the motion vectors of moving objects). Set 1: the scene's geometry. Set 2: the scene's shading data
//! (instances, meshes, vertices, triangles, materials, texture table, texels; the lights that
//! follow are unused). Workgroups of 8 × 8 pixels.

use crate::texture_images::Bindless;
use gi_shared::camera::{CameraParams, primary_ray};
use gi_shared::gbuffer::{GBufferTexel, PreviousTransform, gbuffer_texel, in_image};
use spirv_std::glam::{UVec2, UVec3};
use spirv_std::{Image, spirv};

/// Linear depth.
pub type DepthImage = Image!(2D, format = r32f, sampled = false);
/// Normals and emission.
pub type HalfImage = Image!(2D, format = rgba16f, sampled = false);
/// Albedo.
pub type UnormImage = Image!(2D, format = rgba8, sampled = false);
/// Motion vectors.
pub type FloatImage = Image!(2D, format = rgba32f, sampled = false);
/// Ids.
pub type IdImage = Image!(2D, format = rgba32ui, sampled = false);

/// Writes one pixel of every image.
macro_rules! write_texel {
    (
        $pixel:expr, $texel:expr, $depth:expr, $gn:expr, $sn:expr, $albedo:expr, $emissive:expr,
        $motion:expr, $ids:expr
    ) => {{
        let texel: GBufferTexel = $texel;
        let pixel: UVec2 = $pixel;
        unsafe {
            $depth.write(pixel, texel.depth);
            $gn.write(pixel, texel.geometric_normal);
            $sn.write(pixel, texel.shading_normal);
            $albedo.write(pixel, texel.albedo);
            $emissive.write(pixel, texel.emissive);
            $motion.write(pixel, texel.motion);
            $ids.write(pixel, texel.ids);
        }
    }};
}

traced_kernel! {
    /// Writes the G-buffer pixel of invocation `id`.
    #[spirv(compute(threads(8, 8)))]
    pub fn gbuffer(
        scene, texture_images;
        #[spirv(global_invocation_id)] id: UVec3,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] camera: &CameraParams,
        #[spirv(descriptor_set = 0, binding = 1)] depth: &DepthImage,
        #[spirv(descriptor_set = 0, binding = 2)] geometric_normal: &HalfImage,
        #[spirv(descriptor_set = 0, binding = 3)] shading_normal: &HalfImage,
        #[spirv(descriptor_set = 0, binding = 4)] albedo: &UnormImage,
        #[spirv(descriptor_set = 0, binding = 5)] emissive: &HalfImage,
        #[spirv(descriptor_set = 0, binding = 6)] motion: &FloatImage,
        #[spirv(descriptor_set = 0, binding = 7)] ids: &IdImage,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] previous_transforms: &[PreviousTransform],
    ) {
        let pixel = UVec2::new(id.x, id.y);
        if !in_image(camera, pixel) {
            return;
        }
        let ray = primary_ray(camera, pixel, camera.jitter());
        let hit = scene.closest_hit(&ray, texture_images);
        let texel = gbuffer_texel(
            camera, &ray, &hit, previous_transforms, scene.surfaces, &Bindless(texture_images),
        );
        write_texel!(
            pixel,
            texel,
            depth,
            geometric_normal,
            shading_normal,
            albedo,
            emissive,
            motion,
            ids
        );
    }
}
