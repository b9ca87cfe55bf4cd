//! FilterGI (`gi_shared::gi_denoiser::filter_gi`): one pass of the separable bilateral blur.
//!
//! Push constant: `u32` direction (0 horizontal, 1 vertical). Set 0: 0 frame (`GiFrameParams`),
//! 1 camera (`CameraParams`), 2 depth, 3 geometric normal (images), 4 blur radius (`f32`), 5
//! input (`[f32; 4]`), 6 output (`[f32; 4]`, written), 7 current history (`[f32; 4]`, w =
//! count). Workgroups of 8 × 8 pixels, dispatched `[ceil(W / 8), ceil(H / 8), 1]`.

use crate::gbuffer::{DepthImage, HalfImage};
use gi_shared::camera::CameraParams;
use gi_shared::gi_denoiser::filter_gi::{
    FilterSum, filter_centre, filters, tap_count, tap_pixel, tap_weight,
};
use gi_shared::screen_probes::GiFrameParams;
use spirv_std::glam::{UVec2, UVec3, Vec4};
use spirv_std::spirv;

/// One pass of the blur for pixel `id`.
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn filter_gi(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] direction: &u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] _camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] radius: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] input: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] output: &mut [[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] history: &[[f32; 4]],
) {
    let pixel = UVec2::new(id.x, id.y);
    let size = frame.image_size;
    if pixel.x >= size[0] || pixel.y >= size[1] {
        return;
    }
    let i = (pixel.y * size[0] + pixel.x) as usize;
    if i >= input.len() || i >= output.len() || i >= radius.len() || i >= history.len() {
        return;
    }
    let centre = input[i];
    let d: f32 = depth.read(pixel);
    let gn: Vec4 = geometric_normal.read(pixel);
    let r = radius[i];
    if !filters(frame, d, gn, r) {
        output[i] = centre;
        return;
    }
    let c = filter_centre(d, gn, history[i][3]);
    let n = tap_count(r) as i32;
    let axis = *direction;
    let mut acc = FilterSum::new(centre);
    let mut o = -n;
    while o <= n {
        if o != 0
            && let Some(t) = tap_pixel(pixel, axis, o, size)
        {
            let j = (t.y * size[0] + t.x) as usize;
            if j < input.len() {
                let td: f32 = depth.read(t);
                let tn: Vec4 = geometric_normal.read(t);
                acc.add(input[j], tap_weight(&c, td, tn));
            }
        }
        o += 1;
    }
    output[i] = acc.finish(centre[3]);
}
