//! ReprojectGI (`gi_shared::gi_denoiser::reproject_gi`): temporal accumulation of the
//! interpolated irradiance and the blur mask.
//!
//! Set 0: 0 frame (`GiFrameParams`), 1 camera (`CameraParams`), 2 depth, 3 geometric normal
//! (images), 4 irradiance (`[f32; 4]`, this frame's interpolation), 5 previous history, 6
//! current history (`[f32; 4]`: rgb mean, w count), 7 previous surface, 8 current surface
//! (`[f32; 4]`: position, packed normal bits), 9 previous luma delta, 10 current luma delta
//! (`f32`), 11 blur mask (`f32`), 12 G-buffer motion (image), 13 previous trend, 14 current trend
//! (`[u32; TREND_WORDS]`, cleared before the pass). Workgroups of 8 × 8 pixels, dispatched
//! `[ceil(W / 8), ceil(H / 8), 1]`.

use crate::atomics::DeviceWords;
use crate::gbuffer::{DepthImage, FloatImage, HalfImage};
use gi_shared::camera::CameraParams;
use gi_shared::gbuffer::ReprojectionTexel;
use gi_shared::gi_denoiser::reproject_gi::{
    PreviousGiHistory, add_trend, reproject_gi_pixel, store_trend_reference, trend_reference,
};
use gi_shared::screen_probes::GiFrameParams;
use spirv_std::glam::{UVec2, UVec3};
use spirv_std::spirv;

/// The temporal history of pixel `id`.
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn reproject_gi(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] irradiance: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] previous_history: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] history: &mut [[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] previous_surface: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] surface: &mut [[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] previous_luma_delta: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] luma_delta: &mut [f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] blur_mask: &mut [f32],
    #[spirv(descriptor_set = 0, binding = 12)] motion: &FloatImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] previous_trend: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] trend: &mut [u32],
) {
    let pixel = UVec2::new(id.x, id.y);
    if pixel.x >= frame.image_size[0] || pixel.y >= frame.image_size[1] {
        return;
    }
    let i = (pixel.y * frame.image_size[0] + pixel.x) as usize;
    if i >= irradiance.len()
        || i >= history.len()
        || i >= surface.len()
        || i >= luma_delta.len()
        || i >= blur_mask.len()
    {
        return;
    }
    let texel = ReprojectionTexel {
        depth: depth.read(pixel),
        geometric_normal: geometric_normal.read(pixel),
        motion: motion.read(pixel),
    };
    let previous = PreviousGiHistory {
        history: previous_history,
        surface: previous_surface,
        luma_delta: previous_luma_delta,
        trend: previous_trend,
    };
    let r = reproject_gi_pixel(frame, camera, pixel, texel, irradiance[i], previous);
    let reference = trend_reference(previous_trend);
    let mut trend = DeviceWords(trend);
    if i == 0 {
        store_trend_reference(&mut trend, reference);
    }
    add_trend(&mut trend, reference, &r);
    history[i] = r.history;
    surface[i] = r.surface;
    luma_delta[i] = r.luma_delta;
    blur_mask[i] = r.blur_mask;
}
