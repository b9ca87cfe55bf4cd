//! InterpolateScreenProbes (`gi_shared::screen_probes::interpolate`): each pixel's irradiance
//! from at most four screen probes, `[r, g, b, hint]`, through screen-space GI's occlusion
//! (`gi_shared::screen_space_gi`).
//!
//! Set 0: 0 frame (`GiFrameParams`), 1 camera (`CameraParams`), 2 depth, 3 geometric normal, 4
//! shading normal (images), 5 probe records (`ProbeRecord`), 6 probe mask (`u32`, mip chain), 7
//! probe SH (`[f32; 4]`, 9 per probe tile), 8 irradiance (`[f32; 4]`, written), 9 GI counters
//! (`u32`, [`RELAXED_COUNT`]), 10 albedo (image), 11 primary lighting (`PrimaryLighting`, the
//! previous frame's until DirectLight writes this frame's), 12 the previous frame's final
//! irradiance (`[f32; 4]`, the denoiser's output; near-field term). Workgroups of
//! 8 × 8 pixels, dispatched `[ceil(W / 8), ceil(H / 8), 1]`.

use crate::atomics::DeviceWords;
use crate::gbuffer::{DepthImage, HalfImage, UnormImage};
use gi_shared::atomics::AtomicWords;
use gi_shared::camera::CameraParams;
use gi_shared::primary_lighting::{PreviousLight, PrimaryLighting};
use gi_shared::primary_surface::primary_surface;
use gi_shared::screen_probes::interpolate::{
    InterpolationProbes, SKY_IRRADIANCE, accepts_jitter, interpolate_pixel, jitter_candidate,
};
use gi_shared::screen_probes::{GiFrameParams, ProbeRecord, RELAXED_COUNT};
use gi_shared::screen_space_gi::{AlbedoSource, DepthSource, NormalSource, horizon_occlusion};
use spirv_std::glam::{UVec2, UVec3, Vec3, Vec4};
use spirv_std::spirv;

/// The depth image as screen-space GI's horizon search reads it.
struct ImageDepths<'a>(&'a DepthImage);

impl DepthSource for ImageDepths<'_> {
    fn depth_at(&self, pixel: UVec2) -> f32 {
        self.0.read(pixel)
    }
}

/// The geometric normal image as screen-space GI's near-field term reads it.
struct ImageNormals<'a>(&'a HalfImage);

impl NormalSource for ImageNormals<'_> {
    fn normal_at(&self, pixel: UVec2) -> Vec3 {
        let n: Vec4 = self.0.read(pixel);
        n.truncate().normalize_or_zero()
    }
}

/// The albedo image as screen-space GI's near-field term reads it.
struct ImageAlbedo<'a>(&'a UnormImage);

impl AlbedoSource for ImageAlbedo<'_> {
    fn albedo_at(&self, pixel: UVec2) -> Vec3 {
        let a: Vec4 = self.0.read(pixel);
        a.truncate()
    }
}

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
    #[spirv(descriptor_set = 0, binding = 10)] albedo: &UnormImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] lighting: &[PrimaryLighting],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] previous: &[[f32; 4]],
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
    let occlusion = horizon_occlusion(
        camera,
        frame.horizon_search(),
        pixel,
        d,
        surface.geometric_normal,
        surface.shading_normal,
        (
            &ImageDepths(depth),
            &ImageNormals(geometric_normal),
            &ImageAlbedo(albedo),
        ),
        &PreviousLight::for_frame(frame, lighting, previous),
    );
    let probes = InterpolationProbes { records, mask, sh };
    let r = interpolate_pixel(frame, &surface, d, &occlusion, lookup, probes);
    irradiance[i] = r.irradiance;
    if r.relaxed && RELAXED_COUNT < counters.len() {
        DeviceWords(counters).fetch_add(RELAXED_COUNT, 1);
    }
}
