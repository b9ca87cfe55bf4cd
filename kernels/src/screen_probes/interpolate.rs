//! InterpolateScreenProbes (`gi_shared::screen_probes::interpolate`): each pixel's irradiance
//! from at most four screen probes, `[r, g, b, hint]`.
//!
//! Set 0: 0 frame (`GiFrameParams`), 1 camera (`CameraParams`), 2 depth, 3 geometric normal, 4
//! shading normal (images), 5 probe records (`ProbeRecord`), 6 probe mask (`u32`, mip chain), 7
//! probe SH (`[f32; 4]`, 9 per probe tile), 8 irradiance (`[f32; 4]`, written), 9 GI counters
//! (`u32`, [`RELAXED_COUNT`]). Workgroups of
//! 8 × 8 pixels, dispatched `[ceil(W / 8), ceil(H / 8), 1]`.

use crate::atomics::DeviceWords;
use crate::gbuffer::{DepthImage, HalfImage};
use gi_shared::atomics::AtomicWords;
use gi_shared::camera::CameraParams;
use gi_shared::primary_surface::primary_surface;
use gi_shared::screen_probes::interpolate::{
    InterpolationProbes, SKY_IRRADIANCE, accepts_jitter, interpolate_pixel, jitter_candidate,
};
use gi_shared::screen_probes::{GiFrameParams, ProbeRecord, RELAXED_COUNT};
use spirv_std::glam::{UVec2, UVec3, Vec4};
use spirv_std::spirv;

/// The interpolated irradiance of pixel `id`.
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn interpolate_screen_probes(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
    #[spirv(descriptor_set = 0, binding = 4)] shading_normal: &HalfImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] records: &[ProbeRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] mask: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] sh: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] irradiance: &mut [[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] counters: &mut [u32],
) {
    let pixel = UVec2::new(id.x, id.y);
    if pixel.x >= frame.image_size[0] || pixel.y >= frame.image_size[1] {
        return;
    }
    let i = (pixel.y * frame.image_size[0] + pixel.x) as usize;
    if i >= irradiance.len() {
        return;
    }
    let d: f32 = depth.read(pixel);
    let gn: Vec4 = geometric_normal.read(pixel);
    let sn: Vec4 = shading_normal.read(pixel);
    let surface = primary_surface(camera, pixel, d, gn, sn);
    if !surface.valid {
        irradiance[i] = SKY_IRRADIANCE;
        return;
    }
    let mut lookup = pixel;
    if let Some(c) = jitter_candidate(frame, pixel) {
        let cd: f32 = depth.read(c);
        let cn: Vec4 = geometric_normal.read(c);
        let candidate = primary_surface(camera, c, cd, cn, cn);
        if accepts_jitter(frame, &surface, &candidate) {
            lookup = c;
        }
    }
    let probes = InterpolationProbes { records, mask, sh };
    let r = interpolate_pixel(frame, &surface, d, lookup, probes);
    irradiance[i] = r.irradiance;
    if r.relaxed && RELAXED_COUNT < counters.len() {
        DeviceWords(counters).fetch_add(RELAXED_COUNT, 1);
    }
}
