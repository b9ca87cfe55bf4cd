//! The G-buffer import: an engine's depth, normal, albedo, motion and emissive images (sampled
//! images read by texel fetch, which every depth format allows and storage images do not)
//! converted by [`gi_shared::gbuffer_import::imported_texel`] into our G-buffer's storage images.
//!
//! Push constants: `GBufferImportParams`. Set 0: the camera (`CameraParams`), the engine's depth,
//! normal, albedo, motion and emissive images (the host binds the depth image for an absent motion
//! image and the albedo image for an absent emissive one: the flags say they are not read), then
//! our depth, geometric normal, shading normal, albedo, emissive, motion and ids. Workgroups of
//! 8 × 8 pixels.

use crate::gbuffer::{DepthImage, FloatImage, HalfImage, IdImage, UnormImage};
use gi_shared::camera::CameraParams;
use gi_shared::gbuffer::{GBufferTexel, in_image};
use gi_shared::gbuffer_import::{
    EngineTexels, FLAG_EMISSIVE, FLAG_MOTION, GBufferImportParams, imported_texel,
};
use spirv_std::glam::{UVec2, UVec3, Vec4};
use spirv_std::{Image, spirv};

/// An engine image: any float, UNORM, SNORM, sRGB or depth format, read by texel fetch.
pub type EngineImage = Image!(2D, type = f32, sampled);

/// The stored depth `(dx, dy)` pixels from `pixel`, or NaN outside the image.
fn depth_at(depth: &EngineImage, camera: &CameraParams, pixel: UVec2, dx: i32, dy: i32) -> f32 {
    // Wrapping: a pixel off the left or top edge lands far outside the image.
    let p = UVec2::new(
        pixel.x.wrapping_add(dx as u32),
        pixel.y.wrapping_add(dy as u32),
    );
    if in_image(camera, p) {
        let texel: Vec4 = depth.fetch(p);
        texel.x
    } else {
        f32::NAN
    }
}

/// Converts the engine's pixel `id` into ours.
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn import_gbuffer(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &GBufferImportParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 1)] engine_depth: &EngineImage,
    #[spirv(descriptor_set = 0, binding = 2)] engine_normal: &EngineImage,
    #[spirv(descriptor_set = 0, binding = 3)] engine_albedo: &EngineImage,
    #[spirv(descriptor_set = 0, binding = 4)] engine_motion: &EngineImage,
    #[spirv(descriptor_set = 0, binding = 5)] engine_emissive: &EngineImage,
    #[spirv(descriptor_set = 0, binding = 6)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 7)] geometric_normal: &HalfImage,
    #[spirv(descriptor_set = 0, binding = 8)] shading_normal: &HalfImage,
    #[spirv(descriptor_set = 0, binding = 9)] albedo: &UnormImage,
    #[spirv(descriptor_set = 0, binding = 10)] emissive: &HalfImage,
    #[spirv(descriptor_set = 0, binding = 11)] motion: &FloatImage,
    #[spirv(descriptor_set = 0, binding = 12)] ids: &IdImage,
) {
    let pixel = UVec2::new(id.x, id.y);
    if !in_image(camera, pixel) {
        return;
    }
    let d = engine_depth;
    let texels = EngineTexels {
        depth: [
            depth_at(d, camera, pixel, 0, 0),
            depth_at(d, camera, pixel, -1, 0),
            depth_at(d, camera, pixel, -2, 0),
            depth_at(d, camera, pixel, 1, 0),
            depth_at(d, camera, pixel, 2, 0),
            depth_at(d, camera, pixel, 0, -1),
            depth_at(d, camera, pixel, 0, -2),
            depth_at(d, camera, pixel, 0, 1),
            depth_at(d, camera, pixel, 0, 2),
        ],
        normal: engine_normal.fetch(pixel),
        albedo: engine_albedo.fetch(pixel),
        motion: if params.has(FLAG_MOTION) {
            engine_motion.fetch(pixel)
        } else {
            Vec4::ZERO
        },
        emissive: if params.has(FLAG_EMISSIVE) {
            engine_emissive.fetch(pixel)
        } else {
            Vec4::ZERO
        },
    };
    let texel = imported_texel(camera, params, pixel, &texels);
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
