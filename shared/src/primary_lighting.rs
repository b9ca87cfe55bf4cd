//! The primary hit's own lighting (DirectLight) and the final composite (ResolveGI, GI-1.0 step
//! 26).
//!
//! # Each light path counted once
//!
//! The converged image holds every light path exactly once, split between three sources:
//!
//! * **Camera-visible emission** at the primary hit comes from the G-buffer
//!   ([`crate::primary_surface::primary_emission`], × the emissive multiplier). The sky the camera
//!   sees directly is the emission of a sky pixel ([`sky_lighting`]).
//! * **Direct light of punctual lights** (point, spot, directional: the first
//!   `GiFrameParams::punctual_count` lights of the light buffer) comes from shadow rays at the
//!   primary hit, in DirectLight ([`surface_lighting`]): no ray can hit a punctual light, so no
//!   other estimator sees it. Up to [`EXACT_DIRECT_LIGHTS`] lights are summed exactly, one shadow
//!   ray each; with more, the host sets [`FLAG_SAMPLED_DIRECT`] and one light is resampled (RIS
//!   over `GiFrameParams::light_candidates` uniformly drawn punctual lights, one shadow ray),
//!   added to the pixel's interpolated GI irradiance so that the denoiser filters it
//!   ([`add_sampled_light`]).
//! * **Direct light of emissive triangles**, under `FLAG_EMITTER_SAMPLING` (the setting
//!   `emitter_sampling`), also comes from DirectLight: one light sample and shadow ray
//!   ([`emitter_light`]), added to the interpolated irradiance in the same way; probe rays then add
//!   nothing where they hit an emitter.
//! * **Everything else** arrives through the screen probes: emissive surfaces (without emitter
//!   sampling) and the sky (which probe rays take at full weight when they hit or miss), and all
//!   multi-bounce light (probe rays that hit another surface read the world cache, which lights
//!   secondary hits with every light, punctual ones included, and feeds back the previous frame's
//!   radiance, resolved from its irradiance before the denoiser: [`resolve_feedback`]).
//!
//! ResolveGI puts them together ([`resolve_color`]): `emission + albedo / π × (GI irradiance +
//! direct)`, the sampled direct light inside the denoised GI irradiance. Added undenoised in the
//! composite, one light sample per pixel and frame was the noisiest part of the image (the
//! many-lights scene's 64th frame: relMSE 3.1 against 0.032 through the denoiser); through the
//! denoiser it was over-weighted (+52 %) until the denoiser's history stopped weighing a sample
//! by its own value (`crate::gi_denoiser::reproject_gi`).

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::camera::CameraParams;
use crate::color::luminance;
use crate::lights::{
    EXACT_DIRECT_LIGHTS, GpuLight, LIGHT_TRIANGLE, MAX_LIGHT_CANDIDATES, punctual_incidence,
    sample_triangle_light_ray, select_light, sky_radiance,
};
use crate::math::{INV_PI, max, max_u32, min_u32, to_u32_clamped};
use crate::packing::{pack_wide16x4, unpack_wide16x4};
use crate::primary_surface::PrimarySurface;
use crate::radiance_feedback::{FeedbackTexel, reproject};
use crate::random::Random;
use crate::ray::Ray;
use crate::reservoir::Reservoir;
use crate::screen_probes::{
    FLAG_EMITTER_SAMPLING, FLAG_HISTORY, FLAG_SAMPLED_DIRECT, GiFrameParams,
};
use crate::screen_space_gi::NearFieldSource;
use crate::world_cache::finite_sample;

/// What DirectLight leaves for a pixel (16 bytes), read by ResolveGI: the emission and the
/// exactly summed direct irradiance as [`crate::packing::pack_wide16`]s (2^-10 of precision at any brightness,
/// 10⁶ emitters included) and two flags.
///
/// | word | low 16 bits | high 16 bits |
/// |------|-------------|--------------|
/// | 0    | emission r  | emission g   |
/// | 1    | emission b  | flags: [`Self::SURFACE`], [`Self::EMISSIVE`] |
/// | 2    | direct r    | direct g     |
/// | 3    | direct b    | 0            |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PrimaryLighting {
    words: [u32; 4],
}

impl PrimaryLighting {
    /// Flag: the pixel sees a surface.
    pub const SURFACE: u32 = 1;
    /// Flag: the surface emits toward the camera; the pixel is then no source of temporal
    /// radiance feedback (a neighbouring hit that reprojects onto it would take its emission).
    pub const EMISSIVE: u32 = 2;

    /// A record: `emission`, radiance toward the camera (the surface's emission, or the sky's
    /// along the camera ray for a sky pixel); `direct`, the irradiance from punctual lights, `Σ
    /// Li cos θ` with shadow rays (W/m²), when they are summed exactly (zero under
    /// [`FLAG_SAMPLED_DIRECT`], whose estimate goes through the denoiser:
    /// [`SurfaceLighting::sampled`]); `flags`, [`Self::SURFACE`] and [`Self::EMISSIVE`].
    /// Negative and NaN channels store 0.
    #[inline]
    pub fn new(emission: Vec3, direct: Vec3, flags: u32) -> Self {
        let e = pack_wide16x4(emission.extend(0.0));
        let d = pack_wide16x4(direct.extend(0.0));
        Self {
            words: [e[0], e[1] | ((flags & 3) << 16), d[0], d[1]],
        }
    }

    /// Emission (or sky) radiance.
    #[inline]
    pub fn emission(&self) -> Vec3 {
        unpack_wide16x4([self.words[0], self.words[1] & 0xffff]).truncate()
    }

    /// Direct irradiance of the exactly summed punctual lights.
    #[inline]
    pub fn direct(&self) -> Vec3 {
        unpack_wide16x4([self.words[2], self.words[3]]).truncate()
    }

    /// Whether the pixel sees a surface.
    #[inline]
    pub fn surface(&self) -> bool {
        (self.words[1] >> 16) & Self::SURFACE != 0
    }

    /// Whether the surface emits toward the camera.
    #[inline]
    pub fn emissive(&self) -> bool {
        (self.words[1] >> 16) & Self::EMISSIVE != 0
    }
}

/// Whether `punctual_count` punctual lights are too many to sum: the host sets
/// [`FLAG_SAMPLED_DIRECT`] when this holds.
#[inline]
pub fn samples_direct_light(punctual_count: u32) -> bool {
    punctual_count > EXACT_DIRECT_LIGHTS
}

/// One punctual light seen from a primary surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PunctualTerm {
    /// Unshadowed `Li cos θ` (W/m²): the light's irradiance times the cosine with the shading
    /// normal; zero when the light lies behind the geometric normal's side.
    pub irradiance: Vec3,
    /// The shadow ray toward the light (untraceable when `irradiance` is zero).
    pub ray: Ray,
}

/// The unshadowed irradiance of the punctual light `light` at `surface` and its shadow ray (from
/// the offset surface point to the light; infinite for a directional light). The light must lie
/// on the geometric normal's side; the cosine is taken with the shading normal.
#[inline]
pub fn punctual_term(light: &GpuLight, surface: &PrimarySurface) -> PunctualTerm {
    let incidence = punctual_incidence(light, surface.position);
    let l = incidence.direction;
    let cos_geometric = surface.geometric_normal.dot(l);
    let cos_shading = max(surface.shading_normal.dot(l), 0.0);
    let e = finite_sample(incidence.irradiance * cos_shading);
    let usable = surface.valid && cos_geometric > 0.0 && e.max_element() > 0.0;
    PunctualTerm {
        irradiance: if usable { e } else { Vec3::ZERO },
        ray: Ray {
            origin: surface.position.to_array(),
            t_min: 0.0,
            direction: l.to_array(),
            t_max: if usable { incidence.distance } else { -1.0 },
        },
    }
}

/// The exact direct irradiance of the first `count` punctual lights at `surface`: the sum of
/// [`punctual_term`] over those whose shadow ray `occluded` says is free (`occluded` gets `images`
/// with each ray, see [`surface_lighting`]).
#[inline]
pub fn exact_direct_light<I: ?Sized, F: FnMut(&Ray, &I) -> bool>(
    surface: &PrimarySurface,
    lights: &[GpuLight],
    count: u32,
    images: &I,
    occluded: &mut F,
) -> Vec3 {
    let n = min_u32(count, lights.len() as u32);
    let mut sum = Vec3::ZERO;
    let mut i = 0;
    while i < n {
        let light = lights[i as usize];
        let term = punctual_term(&light, surface);
        if term.irradiance.max_element() > 0.0 && !occluded(&term.ray, images) {
            sum += term.irradiance;
        }
        i += 1;
    }
    sum
}

/// A resampled punctual light: which, its unshadowed term and its contribution weight `W`, so
/// that `irradiance × W` (when the shadow ray is free) estimates the exact sum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResampledLight {
    /// The light chosen.
    pub light: u32,
    /// Its unshadowed term.
    pub term: PunctualTerm,
    /// RIS contribution weight (0 when no candidate could light the surface).
    pub weight: f32,
}

/// RIS over `candidates` (1 to [`MAX_LIGHT_CANDIDATES`]) punctual lights drawn uniformly from the
/// first `count` (source density `1 / count`), target `luminance(Li cos θ)` unshadowed; one light
/// kept.
#[inline]
pub fn resample_punctual_light(
    surface: &PrimarySurface,
    lights: &[GpuLight],
    count: u32,
    candidates: u32,
    rng: &mut Random,
) -> ResampledLight {
    let n = min_u32(count, lights.len() as u32);
    let mut out = ResampledLight {
        light: 0,
        term: PunctualTerm {
            irradiance: Vec3::ZERO,
            ray: Ray {
                origin: surface.position.to_array(),
                t_min: 0.0,
                direction: [0.0; 3],
                t_max: -1.0,
            },
        },
        weight: 0.0,
    };
    if n == 0 || !surface.valid {
        return out;
    }
    let m = min_u32(max_u32(candidates, 1), MAX_LIGHT_CANDIDATES);
    let mut reservoir = Reservoir::EMPTY;
    let mut i = 0;
    while i < m {
        let index = min_u32(to_u32_clamped(rng.next_f32() * n as f32), n - 1);
        let light = lights[index as usize];
        let target = luminance(punctual_term(&light, surface).irradiance);
        // Resampling weight p̂ / p with p = 1 / n.
        reservoir.update(index, target * n as f32, rng.next_f32());
        i += 1;
    }
    let light = lights[reservoir.sample as usize];
    let term = punctual_term(&light, surface);
    reservoir.finalize(luminance(term.irradiance));
    out.light = reservoir.sample;
    out.term = term;
    out.weight = reservoir.ucw;
    out
}

/// The resampled estimate of the punctual lights' direct irradiance: [`resample_punctual_light`]
/// and its one shadow ray (`occluded` gets `images` with it, see [`surface_lighting`]).
#[inline]
pub fn sampled_direct_light<I: ?Sized, F: FnMut(&Ray, &I) -> bool>(
    surface: &PrimarySurface,
    lights: &[GpuLight],
    count: u32,
    candidates: u32,
    rng: &mut Random,
    images: &I,
    occluded: &mut F,
) -> Vec3 {
    let s = resample_punctual_light(surface, lights, count, candidates, rng);
    if s.weight > 0.0 && s.term.irradiance.max_element() > 0.0 && !occluded(&s.term.ray, images) {
        finite_sample(s.term.irradiance * s.weight)
    } else {
        Vec3::ZERO
    }
}

/// DirectLight for a sky pixel: the sky's radiance along the (unit) camera ray `direction`.
#[inline]
pub fn sky_lighting(
    frame: &GiFrameParams,
    environment: &[[f32; 4]],
    direction: Vec3,
) -> PrimaryLighting {
    PrimaryLighting::new(
        finite_sample(sky_radiance(
            frame.environment_size,
            frame.sky,
            environment,
            direction,
        )),
        Vec3::ZERO,
        0,
    )
}

/// DirectLight's result for a surface pixel: its record, and the direct irradiance it sampled,
/// which DirectLight adds to the pixel's interpolated GI irradiance ([`add_sampled_light`]) so
/// that the denoiser filters it. A pixel without a surface gets the default: all zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SurfaceLighting {
    /// The pixel's record: emission and the exactly summed punctual lights' direct irradiance.
    pub record: PrimaryLighting,
    /// The sampled direct irradiance: the resampled punctual light under [`FLAG_SAMPLED_DIRECT`]
    /// ([`sampled_direct_light`]) plus the emissive triangles' light sample under
    /// [`FLAG_EMITTER_SAMPLING`] ([`emitter_light`]); zero without either ([`samples_light`]).
    pub sampled: Vec3,
}

/// DirectLight for a surface pixel: its `emission` toward the camera (already × the multiplier)
/// and the punctual lights' direct irradiance, exact or (under [`FLAG_SAMPLED_DIRECT`]) resampled
/// from `rng`, plus under [`FLAG_EMITTER_SAMPLING`] the emissive triangles' ([`emitter_light`]);
/// `occluded` traces a shadow ray, given `images`: the scene's textures, which tracing reads for
/// the alpha test. They are an argument rather than a capture because on the device they are the
/// bindless image array, and a closure holding it would be a composite holding an opaque handle,
/// which SPIR-V forbids.
#[inline]
pub fn surface_lighting<I: ?Sized, F: FnMut(&Ray, &I) -> bool>(
    frame: &GiFrameParams,
    surface: &PrimarySurface,
    emission: Vec3,
    lights: &[GpuLight],
    rng: &mut Random,
    images: &I,
    mut occluded: F,
) -> SurfaceLighting {
    if !surface.valid {
        return SurfaceLighting::default();
    }
    let emission = finite_sample(emission);
    let (direct, punctual_sample) = if frame.has(FLAG_SAMPLED_DIRECT) {
        let sample = sampled_direct_light(
            surface,
            lights,
            frame.punctual_count,
            frame.light_candidates,
            rng,
            images,
            &mut occluded,
        );
        (Vec3::ZERO, sample)
    } else {
        let exact =
            exact_direct_light(surface, lights, frame.punctual_count, images, &mut occluded);
        (exact, Vec3::ZERO)
    };
    let emitter_sample = if frame.has(FLAG_EMITTER_SAMPLING) {
        emitter_light(frame, surface, lights, rng, images, &mut occluded)
    } else {
        Vec3::ZERO
    };
    SurfaceLighting {
        record: PrimaryLighting::new(
            emission,
            direct,
            if emission.max_element() > 0.0 {
                PrimaryLighting::SURFACE | PrimaryLighting::EMISSIVE
            } else {
                PrimaryLighting::SURFACE
            },
        ),
        sampled: punctual_sample + emitter_sample,
    }
}

/// Whether DirectLight samples any direct light under `frame`'s flags, and so adds
/// [`SurfaceLighting::sampled`] to the interpolated irradiance.
#[inline]
pub fn samples_light(frame: &GiFrameParams) -> bool {
    frame.has(FLAG_SAMPLED_DIRECT) || frame.has(FLAG_EMITTER_SAMPLING)
}

/// The interpolated GI irradiance `[r, g, b, hint]` of a pixel with the sampled direct
/// irradiance added ([`SurfaceLighting::sampled`]). One light sample per pixel and frame is
/// noisy where many lights or many small emitters light the scene; through the denoiser it is
/// filtered with the probes' light, as the emitters' light was when the probes carried it (added
/// undenoised in the composite instead, one frame of the Bitterli bathroom had relMSE 0.33
/// against 0.11, the many-lights scene 3.1 against 0.032).
#[inline]
pub fn add_sampled_light(irradiance: [f32; 4], sampled: Vec3) -> [f32; 4] {
    let e = finite_sample(sampled);
    [
        irradiance[0] + e.x,
        irradiance[1] + e.y,
        irradiance[2] + e.z,
        irradiance[3],
    ]
}

/// One light-sampled estimate of the emissive triangles' direct irradiance at `surface`
/// (`FLAG_EMITTER_SAMPLING`): a light drawn from the light buffer's alias table (punctual lights
/// and the environment, drawn too, add nothing here: they have their own estimators), a uniform
/// point on it, one shadow ray; `radiance × cos θ / (pdf_area→solid angle × pmf)`. The emitter's
/// factor is its radiance (its emissive texture is not read, as at the cache's light samples).
/// The cells of a probe average a small source's cosine over the cell's solid angle; this
/// estimate takes its own.
#[inline]
pub fn emitter_light<I: ?Sized, F: FnMut(&Ray, &I) -> bool>(
    frame: &GiFrameParams,
    surface: &PrimarySurface,
    lights: &[GpuLight],
    rng: &mut Random,
    images: &I,
    occluded: &mut F,
) -> Vec3 {
    let count = min_u32(frame.light_count, lights.len() as u32);
    let u = rng.next_vec2();
    let u2 = rng.next_vec2();
    if count <= frame.punctual_count {
        return Vec3::ZERO;
    }
    let light = lights[select_light(lights, count, u) as usize];
    if light.kind != LIGHT_TRIANGLE || light.select_pmf.is_nan() || light.select_pmf <= 0.0 {
        return Vec3::ZERO;
    }
    let sample = sample_triangle_light_ray(&light, surface.position, u2);
    let cos_g = surface.geometric_normal.dot(sample.direction);
    let cos_s = max(surface.shading_normal.dot(sample.direction), 0.0);
    if sample.pdf.is_nan()
        || sample.pdf <= 0.0
        || cos_g <= 0.0
        || cos_s <= 0.0
        || occluded(&sample.ray, images)
    {
        return Vec3::ZERO;
    }
    let radiance = sample.radiance * frame.emissive_multiplier;
    finite_sample(radiance * cos_s / (sample.pdf * light.select_pmf))
}

/// ResolveGI's colour of a pixel (linear HDR radiance): `emission + albedo / π × (irradiance +
/// direct)`. `irradiance` is the denoised GI `[r, g, b, hint]`. Non-finite or
/// negative terms count as black; a sky pixel is its emission.
#[inline]
pub fn resolve_color(lighting: &PrimaryLighting, albedo: Vec3, irradiance: [f32; 4]) -> Vec3 {
    let emission = finite_sample(lighting.emission());
    if !lighting.surface() {
        return emission;
    }
    emission + reflected_color(lighting, albedo, irradiance)
}

/// The reflected part of [`resolve_color`], `albedo / π × (irradiance + direct)`: black for a sky
/// pixel. Screen-space GI's near-field term reads it (an emitter's light toward the camera is not
/// its light toward its neighbours, and emitter sampling already counts it).
#[inline]
pub fn reflected_color(lighting: &PrimaryLighting, albedo: Vec3, irradiance: [f32; 4]) -> Vec3 {
    if !lighting.surface() {
        return Vec3::ZERO;
    }
    let e = finite_sample(Vec3::new(irradiance[0], irradiance[1], irradiance[2]))
        + finite_sample(lighting.direct());
    finite_sample(albedo) * INV_PI * e
}

/// The previous frame's light on screen as screen-space GI's near-field term reads it
/// ([`NearFieldSource`]): ResolveGI's inputs, which last until this frame's DirectLight and
/// ReprojectGI overwrite them.
#[derive(Clone, Copy)]
pub struct PreviousLight<'a> {
    /// The previous frame's primary lighting per pixel.
    pub lighting: &'a [PrimaryLighting],
    /// The previous frame's final irradiance per pixel (the denoiser's output).
    pub irradiance: &'a [[f32; 4]],
    /// Whether there was a previous frame; without one the near-field term is zero.
    pub known: bool,
    /// Whether the occluders' emission counts: not with emitter sampling, whose shadow rays
    /// already bring every emitter's light, near ones included.
    pub emission: bool,
}

impl<'a> PreviousLight<'a> {
    /// The previous frame's `lighting` and final `irradiance` as `frame` reads them: known with
    /// a previous frame ([`FLAG_HISTORY`]), emission only without emitter sampling
    /// ([`FLAG_EMITTER_SAMPLING`]).
    #[inline]
    pub fn for_frame(
        frame: &GiFrameParams,
        lighting: &'a [PrimaryLighting],
        irradiance: &'a [[f32; 4]],
    ) -> Self {
        Self {
            lighting,
            irradiance,
            known: frame.has(FLAG_HISTORY),
            emission: !frame.has(FLAG_EMITTER_SAMPLING),
        }
    }
}

impl NearFieldSource for PreviousLight<'_> {
    /// The previous frame's colour of the surface at `position`, as ResolveGI made it
    /// ([`resolve_color`] where it is `facing` with [`PreviousLight::emission`], else
    /// [`reflected_color`]): its pixel under the previous camera ([`reproject`]), that pixel's
    /// lighting and irradiance with `albedo`; zero off the previous image or without a previous
    /// frame.
    #[inline]
    fn radiance(&self, camera: &CameraParams, albedo: Vec3, position: Vec3, facing: bool) -> Vec3 {
        if !self.known {
            return Vec3::ZERO;
        }
        let Some(at) = reproject(camera, position) else {
            return Vec3::ZERO;
        };
        let i = (at.pixel.y * camera.image_size[0] + at.pixel.x) as usize;
        if i >= self.lighting.len() || i >= self.irradiance.len() {
            return Vec3::ZERO;
        }
        let (lighting, irradiance) = (&self.lighting[i], self.irradiance[i]);
        if self.emission && facing {
            resolve_color(lighting, albedo, irradiance)
        } else {
            reflected_color(lighting, albedo, irradiance)
        }
    }

    /// Only the emission looks at the side: without it the normal is not read.
    #[inline]
    fn uses_facing(&self) -> bool {
        self.emission
    }
}

/// The feedback texel a pixel leaves for the next frame's temporal radiance feedback: its colour,
/// linear depth and geometric normal; a source only where it sees a surface that does not emit.
/// Sky: all zero.
#[inline]
pub fn resolve_feedback(
    lighting: &PrimaryLighting,
    color: Vec3,
    depth: f32,
    geometric_normal: Vec3,
) -> FeedbackTexel {
    if !lighting.surface() || depth <= 0.0 {
        return FeedbackTexel::default();
    }
    FeedbackTexel::new(
        finite_sample(color),
        depth,
        geometric_normal,
        !lighting.emissive(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::{EMIT_BACK, EMIT_FRONT};
    use crate::math::PI;
    use crate::packing::WIDE16_MAX_RELATIVE_ERROR;
    use core::mem::size_of;

    #[test]
    fn the_previous_light_is_the_previous_pixels_colour() {
        use crate::primary_surface::primary_point;
        use glam::UVec2;
        let (w, h) = (8u32, 6u32);
        let camera = CameraParams::new(Vec3::new(0.0, 0.0, 4.0), Vec3::NEG_Z, Vec3::Y, 0.9, w, h);
        let camera = camera.with_previous(&camera);
        let mut lighting = vec![PrimaryLighting::default(); (w * h) as usize];
        let mut irradiance = vec![[0.0f32; 4]; (w * h) as usize];
        let at = UVec2::new(5, 2);
        let i = (at.y * w + at.x) as usize;
        let (emission, direct) = (Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, PI, 0.0));
        lighting[i] = PrimaryLighting::new(emission, direct, PrimaryLighting::SURFACE);
        irradiance[i] = [0.0, 0.0, 2.0 * PI, 1.0];
        let light = |known, emission| PreviousLight {
            lighting: &lighting,
            irradiance: &irradiance,
            known,
            emission,
        };
        let albedo = Vec3::splat(0.5);
        let position = primary_point(&camera, at, 3.0);
        let reflected = light(true, false).radiance(&camera, albedo, position, true);
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 2e-3;
        assert!(close(reflected, Vec3::new(0.0, 0.5, 1.0)), "{reflected}");
        let all = light(true, true).radiance(&camera, albedo, position, true);
        assert!(close(all, Vec3::new(2.0, 0.5, 1.0)), "{all}");
        // Seen from behind: no emission.
        let behind = light(true, true).radiance(&camera, albedo, position, false);
        assert_eq!(behind, reflected);
        // No previous frame, another pixel, behind the camera: nothing.
        assert_eq!(
            light(false, true).radiance(&camera, albedo, position, true),
            Vec3::ZERO
        );
        let beside = primary_point(&camera, UVec2::new(1, 1), 3.0);
        assert_eq!(
            light(true, true).radiance(&camera, albedo, beside, true),
            Vec3::ZERO
        );
        let eye_side = Vec3::new(0.0, 0.0, 9.0);
        assert_eq!(
            light(true, true).radiance(&camera, albedo, eye_side, true),
            Vec3::ZERO
        );
    }

    #[test]
    fn layout() {
        assert_eq!(size_of::<PrimaryLighting>(), 16);
        // A 10⁶ emitter, a sky pixel, NaN: within 2^-10, flags kept, NaN stored as 0.
        let e = Vec3::new(1e6, 0.25, 0.0);
        let l = PrimaryLighting::new(e, Vec3::new(3.0, f32::NAN, 1e-6), PrimaryLighting::EMISSIVE);
        assert!(
            (l.emission() - e)
                .abs()
                .cmple(e * WIDE16_MAX_RELATIVE_ERROR)
                .all()
        );
        assert_eq!(l.direct().y, 0.0);
        assert!((l.direct().z - 1e-6).abs() <= 1e-6 * WIDE16_MAX_RELATIVE_ERROR);
        assert!(l.emissive() && !l.surface());
        assert_eq!(
            PrimaryLighting::default(),
            PrimaryLighting::new(Vec3::ZERO, Vec3::ZERO, 0)
        );
    }

    /// A surface at the origin of the plane z = 0, normal +z.
    fn plane() -> PrimarySurface {
        PrimarySurface {
            position: Vec3::ZERO,
            geometric_normal: Vec3::Z,
            shading_normal: Vec3::Z,
            valid: true,
        }
    }

    /// A point light and a tilted triangle light (radiance 3) above [`plane`], drawn with
    /// probability ½ each.
    fn point_and_triangle() -> ([GpuLight; 2], [Vec3; 3]) {
        let tri = [
            Vec3::new(-0.5, -0.2, 1.0),
            Vec3::new(0.7, 0.1, 1.3),
            Vec3::new(0.0, 0.8, 0.9),
        ];
        let mut lights = [
            GpuLight::point(Vec3::new(0.0, 0.0, 2.0), Vec3::ONE),
            GpuLight::triangle(0, 0, tri, Vec3::splat(3.0), EMIT_FRONT | EMIT_BACK),
        ];
        for l in &mut lights {
            l.select_pmf = 0.5;
            l.alias_threshold = 1.0;
        }
        (lights, tri)
    }

    #[test]
    fn emitter_light_estimates_the_triangles_irradiance() {
        let (lights, tri) = point_and_triangle();
        let frame = GiFrameParams {
            flags: FLAG_EMITTER_SAMPLING,
            punctual_count: 1,
            light_count: 2,
            emissive_multiplier: 1.0,
            ..GiFrameParams::default()
        };
        // Lambert's formula for a polygon of radiance L over a unit normal n at the origin.
        let mut exact = 0.0;
        for i in 0..3 {
            let (a, b) = (tri[i].normalize(), tri[(i + 1) % 3].normalize());
            exact += a.dot(b).acos() * Vec3::Z.dot(a.cross(b).normalize());
        }
        let exact = 3.0 * 0.5 * exact.abs();
        let mut rng = Random::new(5, 0);
        let n = 200_000;
        let mut sum = 0.0f64;
        let mut sum2 = 0.0f64;
        for _ in 0..n {
            let e = emitter_light(&frame, &plane(), &lights, &mut rng, &(), &mut |_, _| false);
            sum += f64::from(e.x);
            sum2 += f64::from(e.x) * f64::from(e.x);
        }
        let mean = sum / f64::from(n);
        let error = ((sum2 / f64::from(n) - mean * mean) / f64::from(n)).sqrt();
        assert!(
            (mean - f64::from(exact)).abs() < 4.0 * error,
            "{mean} ± {error} vs {exact}"
        );
        // An occluded shadow ray adds nothing.
        let blocked = emitter_light(&frame, &plane(), &lights, &mut rng, &(), &mut |_, _| true);
        assert_eq!(blocked, Vec3::ZERO);
    }

    #[test]
    fn without_emitter_sampling_the_direct_light_is_the_punctual_lights_alone() {
        let (lights, _) = point_and_triangle();
        let off = GiFrameParams {
            punctual_count: 1,
            light_count: 2,
            ..GiFrameParams::default()
        };
        let (mut a, b) = (Random::new(9, 0), Random::new(9, 0));
        let lit = surface_lighting(&off, &plane(), Vec3::ZERO, &lights, &mut a, &(), |_, _| {
            false
        });
        let point = punctual_term(&lights[0], &plane()).irradiance;
        assert_eq!(lit.record.direct(), point);
        assert_eq!(lit.sampled, Vec3::ZERO);
        // The random stream is untouched, so the frame's other samples are as before.
        assert_eq!(a.next_u32(), { b }.next_u32());
    }

    #[test]
    fn with_emitter_sampling_the_emitters_light_is_kept_apart_for_the_denoiser() {
        let (lights, _) = point_and_triangle();
        let on = GiFrameParams {
            punctual_count: 1,
            light_count: 2,
            flags: FLAG_EMITTER_SAMPLING,
            emissive_multiplier: 1.0,
            ..GiFrameParams::default()
        };
        let mut lit_by_emitter = 0;
        for seed in 0..8 {
            let (mut a, mut b) = (Random::new(seed, 0), Random::new(seed, 0));
            let lit = surface_lighting(&on, &plane(), Vec3::ZERO, &lights, &mut a, &(), |_, _| {
                false
            });
            // The record holds the punctual light alone; the emitters' estimate is the one
            // emitter_light draws from the same stream.
            assert_eq!(
                lit.record.direct(),
                punctual_term(&lights[0], &plane()).irradiance
            );
            let expected = emitter_light(&on, &plane(), &lights, &mut b, &(), &mut |_, _| false);
            assert_eq!(lit.sampled, expected);
            assert_eq!(a.next_u32(), b.next_u32());
            lit_by_emitter += u32::from(expected.x > 0.0);
        }
        assert!(lit_by_emitter > 0);
        // Added to the interpolated irradiance, hint kept; a non-finite estimate adds nothing.
        let gi = add_sampled_light([1.0, 2.0, 3.0, 0.5], Vec3::new(0.5, 0.0, 1.0));
        assert_eq!(gi, [1.5, 2.0, 4.0, 0.5]);
        let nan = add_sampled_light(
            [1.0, 2.0, 3.0, 0.5],
            Vec3::new(f32::NAN, f32::INFINITY, -1.0),
        );
        assert_eq!(nan, [1.0, 2.0, 3.0, 0.5]);
    }

    #[test]
    fn a_point_light_above_a_plane_gives_i_cos_over_d_squared() {
        let s = plane();
        let p = Vec3::new(1.0, 0.5, 2.0);
        let light = GpuLight::point(p, Vec3::new(8.0, 4.0, 2.0));
        let t = punctual_term(&light, &s);
        let d2 = p.length_squared();
        let cos = p.z / p.length();
        let exact = Vec3::new(8.0, 4.0, 2.0) * cos / d2;
        assert!(
            (t.irradiance - exact).abs().max_element() < 1e-6,
            "{}",
            t.irradiance
        );
        assert!((Vec3::from_array(t.ray.direction) - p.normalize()).length() < 1e-6);
        assert!((t.ray.t_max - p.length()).abs() < 1e-5);
        // Below the plane: nothing, and no ray to trace.
        let below = GpuLight::point(Vec3::new(0.0, 0.0, -1.0), Vec3::ONE);
        let t = punctual_term(&below, &s);
        assert_eq!(t.irradiance, Vec3::ZERO);
        assert!(!t.ray.is_traceable());
        // A shading normal tilted away still needs the light on the geometric side.
        let tilted = PrimarySurface {
            shading_normal: Vec3::new(0.6, 0.0, 0.8),
            ..s
        };
        let side = GpuLight::point(Vec3::new(-1.0, 0.0, 0.0), Vec3::ONE);
        assert_eq!(punctual_term(&side, &tilted).irradiance, Vec3::ZERO);
        // A directional light shining straight down: its irradiance, an infinite ray.
        let sun = GpuLight::directional(Vec3::NEG_Z, Vec3::splat(3.0));
        let t = punctual_term(&sun, &s);
        assert!((t.irradiance - Vec3::splat(3.0)).length() < 1e-6);
        assert_eq!(t.ray.t_max, f32::INFINITY);
    }

    #[test]
    fn exact_sum_honours_shadow_rays() {
        let s = plane();
        let lights = [
            GpuLight::point(Vec3::new(0.0, 0.0, 1.0), Vec3::splat(1.0)),
            GpuLight::point(Vec3::new(0.0, 0.0, 2.0), Vec3::splat(4.0)),
            GpuLight::directional(Vec3::NEG_Z, Vec3::splat(2.0)),
        ];
        let mut none = |_: &Ray, _: &()| false;
        let e = exact_direct_light(&s, &lights, 3, &(), &mut none);
        assert!((e - Vec3::splat(4.0)).abs().max_element() < 1e-5, "{e}");
        // Occlude the directional light (infinite ray).
        let mut sun_blocked = |r: &Ray, _: &()| r.t_max == f32::INFINITY;
        let e = exact_direct_light(&s, &lights, 3, &(), &mut sun_blocked);
        assert!((e - Vec3::splat(2.0)).abs().max_element() < 1e-5, "{e}");
        // Only the punctual prefix counts.
        let e = exact_direct_light(&s, &lights, 1, &(), &mut none);
        assert!((e - Vec3::ONE).abs().max_element() < 1e-5);
        // A count beyond the buffer is clamped.
        let e = exact_direct_light(&s, &lights, 40, &(), &mut none);
        assert!((e - Vec3::splat(4.0)).abs().max_element() < 1e-5);
    }

    /// RIS over many lights is unbiased and its single sample follows the target.
    #[test]
    fn resampled_direct_light_is_unbiased() {
        let s = plane();
        let mut lights = Vec::new();
        for i in 0..40 {
            let x = (i % 8) as f32 - 3.5;
            let y = (i / 8) as f32 - 2.0;
            let intensity = Vec3::new(1.0 + (i % 3) as f32, 2.0, 0.5 * (i % 5) as f32);
            lights.push(GpuLight::point(Vec3::new(x, y, 1.5), intensity));
        }
        // One light below the plane: never useful.
        lights.push(GpuLight::point(
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::splat(100.0),
        ));
        let count = lights.len() as u32;
        let mut none = |_: &Ray, _: &()| false;
        let exact = exact_direct_light(&s, &lights, count, &(), &mut none);
        let n = 40_000;
        let mut sum = glam::DVec3::ZERO;
        let mut rng = Random::new(5, 0);
        for _ in 0..n {
            let e = sampled_direct_light(&s, &lights, count, 8, &mut rng, &(), &mut none);
            sum += e.as_dvec3();
        }
        let mean = sum / f64::from(n);
        let rel = (mean - exact.as_dvec3()).abs() / exact.as_dvec3();
        assert!(rel.max_element() < 0.01, "{mean} vs {exact}");
        // The light below is never picked.
        let mut rng = Random::new(6, 0);
        for _ in 0..1000 {
            let r = resample_punctual_light(&s, &lights, count, 8, &mut rng);
            assert_ne!(r.light, count - 1);
            assert!(r.weight > 0.0);
        }
        // Nothing to sample: zero.
        let mut rng = Random::new(7, 0);
        assert_eq!(
            sampled_direct_light(&s, &lights[40..], 1, 8, &mut rng, &(), &mut none),
            Vec3::ZERO
        );
        assert_eq!(
            sampled_direct_light(&s, &lights, 0, 8, &mut rng, &(), &mut none),
            Vec3::ZERO
        );
    }

    #[test]
    fn surface_lighting_switches_between_exact_and_sampled() {
        let s = plane();
        let lights = [GpuLight::point(Vec3::new(0.0, 0.0, 2.0), Vec3::splat(4.0))];
        let mut frame = GiFrameParams {
            punctual_count: 1,
            light_candidates: 4,
            ..Default::default()
        };
        let mut rng = Random::new(1, 0);
        let l = surface_lighting(
            &frame,
            &s,
            Vec3::ZERO,
            &lights,
            &mut rng,
            &(),
            |_, _: &()| false,
        )
        .record;
        assert!(l.surface() && !l.emissive());
        assert!((l.direct() - Vec3::ONE).length() < WIDE16_MAX_RELATIVE_ERROR);
        assert!(!samples_light(&frame));
        // One light sampled: the estimate is exact, and goes to the denoiser, not the record.
        frame.flags = FLAG_SAMPLED_DIRECT;
        assert!(samples_light(&frame));
        let lit = surface_lighting(&frame, &s, Vec3::X, &lights, &mut rng, &(), |_, _: &()| {
            false
        });
        assert_eq!(lit.record.direct(), Vec3::ZERO);
        assert!((lit.sampled - Vec3::ONE).length() < 1e-5);
        assert!(lit.record.emissive());
        assert_eq!(lit.record.emission(), Vec3::X);
        // Shadowed.
        let lit = surface_lighting(
            &frame,
            &s,
            Vec3::ZERO,
            &lights,
            &mut rng,
            &(),
            |_, _: &()| true,
        );
        assert_eq!(lit.record.direct(), Vec3::ZERO);
        assert_eq!(lit.sampled, Vec3::ZERO);
        // Not a surface.
        let sky = PrimarySurface { valid: false, ..s };
        let l = surface_lighting(
            &frame,
            &sky,
            Vec3::ONE,
            &lights,
            &mut rng,
            &(),
            |_, _: &()| false,
        )
        .record;
        assert_eq!(l, PrimaryLighting::default());
        assert!(samples_direct_light(EXACT_DIRECT_LIGHTS + 1));
        assert!(!samples_direct_light(EXACT_DIRECT_LIGHTS));
    }

    #[test]
    fn resolve_adds_each_term_once() {
        let lighting = PrimaryLighting::new(
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::splat(PI),
            PrimaryLighting::SURFACE | PrimaryLighting::EMISSIVE,
        );
        // The record's rounding of π.
        let e = 2.0 * WIDE16_MAX_RELATIVE_ERROR;
        let albedo = Vec3::new(0.5, 1.0, 0.0);
        let gi = [PI, 2.0 * PI, 0.0, 1.0];
        let c = resolve_color(&lighting, albedo, gi);
        // emission + albedo × (1 + [1, 2, 0]).
        assert!((c - Vec3::new(0.5 + 1.0, 3.0, 0.0)).length() < e, "{c}");
        // A non-finite irradiance is black: emission + albedo × direct remain.
        let c = resolve_color(&lighting, albedo, [f32::NAN, 1.0, 1.0, 1.0]);
        assert!((c - Vec3::new(1.0, 1.0, 0.0)).length() < e, "{c}");
        // Sky: emission only, whatever the irradiance says.
        let sky = PrimaryLighting::new(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, 0);
        assert_eq!(resolve_color(&sky, albedo, gi), Vec3::new(1.0, 2.0, 3.0));
        // Feedback: emitters and sky are no source.
        let f = resolve_feedback(&lighting, c, 2.0, Vec3::Z);
        assert_eq!((f.is_source(), f.depth), (false, 2.0));
        let plain = PrimaryLighting::new(
            lighting.emission(),
            lighting.direct(),
            PrimaryLighting::SURFACE,
        );
        let f = resolve_feedback(&plain, Vec3::ONE, 2.0, Vec3::Z);
        assert!(f.is_source());
        assert_eq!(f.radiance, [1.0; 3]);
        assert_eq!(f.geometric_normal(), Vec3::Z);
        assert_eq!(
            resolve_feedback(&sky, Vec3::ONE, 0.0, Vec3::Z),
            FeedbackTexel::default()
        );
    }

    #[test]
    fn sky_pixels_see_the_sky() {
        let frame = GiFrameParams {
            sky: [0.25, 0.5, 1.0],
            ..Default::default()
        };
        let l = sky_lighting(&frame, &[], Vec3::Y);
        assert_eq!(l.emission(), Vec3::new(0.25, 0.5, 1.0));
        assert_eq!((l.surface(), l.emissive()), (false, false));
    }
}
