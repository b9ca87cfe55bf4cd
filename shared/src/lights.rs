//! Lights for next-event estimation: punctual lights (glTF `KHR_lights_punctual` semantics) and
//! emissive triangles, all in one buffer of [`GpuLight`]s, with the sampling and evaluation the
//! path tracer needs on the CPU and the GPU.
//!
//! # Light selection
//!
//! Uniform: each next-event estimate picks one light of the buffer with probability `1 / count`
//! ([`select_light`]). Power-proportional selection samples better in scenes whose lights differ
//! much in power, but it needs the selection probability of any emissive triangle a BSDF-sampled
//! ray hits (for MIS), that is a map from (instance, primitive) to light; uniform selection needs
//! only the count. Punctual lights and triangles share the buffer so that one choice covers both.
//!
//! # Conventions
//!
//! Sampling a triangle ignores which side faces the shading point; whether that side emits (the
//! front face, or both for a double-sided material) is the path tracer's business. Punctual lights ignore glTF's `range` (a culling hint; the
//! falloff is inverse-square without a window).

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

use crate::math::{clamp, max, min, saturate, to_u32_clamped};
use crate::sampling::{area_to_solid_angle_pdf, sample_triangle};

/// [`GpuLight::kind`]: a point light, `position` and `intensity` (W/sr).
pub const LIGHT_POINT: u32 = 0;
/// A spot light: a point light limited to a cone around `direction`.
pub const LIGHT_SPOT: u32 = 1;
/// A directional light: parallel light along `direction`, `intensity` an irradiance (W/m²).
pub const LIGHT_DIRECTIONAL: u32 = 2;
/// An emissive triangle: vertices `p0`, `p1`, `p2` in world space, `intensity` its emitted
/// radiance (W/(sr·m²), before any emissive texture).
pub const LIGHT_TRIANGLE: u32 = 3;

/// One light (80 bytes). Which fields mean what depends on `kind`.
///
/// | offset | field        | point / spot | directional | triangle   |
/// |--------|--------------|--------------|-------------|------------|
/// | 0      | `p0`         | position     | unused      | vertex 0   |
/// | 12     | `kind`       |              |             |            |
/// | 16     | `p1`         | direction    | direction   | vertex 1   |
/// | 28     | `instance`   | unused       | unused      | instance   |
/// | 32     | `p2`         | unused       | unused      | vertex 2   |
/// | 44     | `primitive`  | unused       | unused      | primitive  |
/// | 48     | `intensity`  | W/sr         | W/m²        | W/(sr·m²)  |
/// | 60     | `area`       | unused       | unused      | m²         |
/// | 64     | `cos_inner`  | spot only    | unused      | unused     |
/// | 68     | `cos_outer`  | spot only    | unused      | unused     |
/// | 72     | `_pad`       |              |             |            |
///
/// `direction` is the unit direction the light shines in.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// Position, or the triangle's first vertex.
    pub p0: [f32; 3],
    /// [`LIGHT_POINT`], [`LIGHT_SPOT`], [`LIGHT_DIRECTIONAL`] or [`LIGHT_TRIANGLE`].
    pub kind: u32,
    /// Direction the light shines in, or the triangle's second vertex.
    pub p1: [f32; 3],
    /// The triangle's instance (for its emissive texture).
    pub instance: u32,
    /// The triangle's third vertex.
    pub p2: [f32; 3],
    /// The triangle's index in its instance's mesh.
    pub primitive: u32,
    /// Intensity (W/sr), irradiance (W/m²) or radiance (W/(sr·m²)); see the table.
    pub intensity: [f32; 3],
    /// The triangle's world-space area.
    pub area: f32,
    /// Spot: cosine of the angle where the falloff starts.
    pub cos_inner: f32,
    /// Spot: cosine of the angle where the light ends.
    pub cos_outer: f32,
    /// Explicit padding.
    pub _pad: [u32; 2],
}

impl GpuLight {
    /// All zero: what an out-of-range light index reads as (a black point light).
    pub const ZERO: Self = Self {
        p0: [0.0; 3],
        kind: LIGHT_POINT,
        p1: [0.0; 3],
        instance: 0,
        p2: [0.0; 3],
        primitive: 0,
        intensity: [0.0; 3],
        area: 0.0,
        cos_inner: 0.0,
        cos_outer: 0.0,
        _pad: [0; 2],
    };

    /// A point light at `position` of intensity `intensity` (W/sr).
    pub fn point(position: Vec3, intensity: Vec3) -> Self {
        Self {
            p0: position.to_array(),
            intensity: intensity.to_array(),
            ..Self::ZERO
        }
    }

    /// A spot light shining along the unit `direction`, with glTF's cone angles (radians).
    pub fn spot(
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        inner_cone_angle: f32,
        outer_cone_angle: f32,
    ) -> Self {
        Self {
            kind: LIGHT_SPOT,
            p0: position.to_array(),
            p1: direction.to_array(),
            intensity: intensity.to_array(),
            cos_inner: crate::math::cos(inner_cone_angle),
            cos_outer: crate::math::cos(outer_cone_angle),
            ..Self::ZERO
        }
    }

    /// A directional light shining along the unit `direction` with irradiance `irradiance` (W/m²).
    pub fn directional(direction: Vec3, irradiance: Vec3) -> Self {
        Self {
            kind: LIGHT_DIRECTIONAL,
            p1: direction.to_array(),
            intensity: irradiance.to_array(),
            ..Self::ZERO
        }
    }

    /// Emissive triangle `primitive` of `instance` with world-space `vertices` and radiance
    /// `radiance`; the area is computed from the vertices.
    pub fn triangle(instance: u32, primitive: u32, vertices: [Vec3; 3], radiance: Vec3) -> Self {
        let [a, b, c] = vertices;
        Self {
            kind: LIGHT_TRIANGLE,
            p0: a.to_array(),
            p1: b.to_array(),
            p2: c.to_array(),
            instance,
            primitive,
            intensity: radiance.to_array(),
            area: 0.5 * (b - a).cross(c - a).length(),
            ..Self::ZERO
        }
    }
}

/// Uniform light selection: the index of the light that `u` in `[0, 1)` picks among `count`
/// (0 when `count` is 0; the caller checks the count first). Its probability is `1 / count`.
#[inline]
pub fn select_light(count: u32, u: f32) -> u32 {
    let last = if count > 0 { count - 1 } else { 0 };
    let i = to_u32_clamped(u * count as f32);
    if i > last { last } else { i }
}

/// A point sampled on an emissive triangle, seen from a shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleSample {
    /// The point on the triangle.
    pub point: Vec3,
    /// Barycentric weights of the second and third vertex (as in a hit record).
    pub barycentrics: Vec2,
    /// Unit direction from the shading point to `point`.
    pub direction: Vec3,
    /// Distance from the shading point to `point`.
    pub distance: f32,
    /// Solid-angle density of `direction` at the shading point (0 when the triangle is seen
    /// edge-on, is degenerate, or contains the shading point).
    pub pdf: f32,
}

/// Samples a point uniformly over the area of triangle `light` (`u` uniform in `[0, 1)²`), seen
/// from `from`, with the area density converted to solid angle.
pub fn sample_triangle_light(light: &GpuLight, from: Vec3, u: Vec2) -> TriangleSample {
    let b = sample_triangle(u);
    let (p0, p1, p2) = (
        Vec3::from_array(light.p0),
        Vec3::from_array(light.p1),
        Vec3::from_array(light.p2),
    );
    let point = p0 * b.x + p1 * b.y + p2 * b.z;
    let to = point - from;
    let distance_squared = to.length_squared();
    let distance = crate::math::sqrt(distance_squared);
    let direction = if distance > 0.0 {
        to / distance
    } else {
        Vec3::ZERO
    };
    let normal = (p1 - p0).cross(p2 - p0).normalize_or_zero();
    TriangleSample {
        point,
        barycentrics: Vec2::new(b.y, b.z),
        direction,
        distance,
        pdf: triangle_light_pdf(light.area, distance_squared, normal.dot(direction)),
    }
}

/// Solid-angle density of uniform area sampling of a triangle of area `area`, for a point at
/// `distance_squared` whose normal makes cosine `cos_light` with the direction (either side).
#[inline]
pub fn triangle_light_pdf(area: f32, distance_squared: f32, cos_light: f32) -> f32 {
    if area > 0.0 {
        area_to_solid_angle_pdf(1.0 / area, distance_squared, cos_light)
    } else {
        0.0
    }
}

/// What a punctual light delivers to a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PunctualIncidence {
    /// Unit direction from the point to the light.
    pub direction: Vec3,
    /// Distance to the light (infinite for a directional light).
    pub distance: f32,
    /// Irradiance on a surface facing the light, W/m²: `I / d²` (times the spot falloff), or a
    /// directional light's irradiance. Multiply by the cosine at the receiver.
    pub irradiance: Vec3,
}

/// The spot falloff of glTF's `KHR_lights_punctual`: 1 inside the inner cone, 0 outside the outer
/// one, and the square of the linear ramp in the cosine between them.
#[inline]
pub fn spot_falloff(cos_angle: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let scale = 1.0 / max(cos_inner - cos_outer, 1e-3);
    let t = saturate((cos_angle - cos_outer) * scale);
    t * t
}

/// Incident light at `point` from the punctual light `light` (point, spot or directional); a
/// triangle light gives none.
pub fn punctual_incidence(light: &GpuLight, point: Vec3) -> PunctualIncidence {
    let intensity = Vec3::from_array(light.intensity);
    let axis = Vec3::from_array(light.p1);
    if light.kind == LIGHT_DIRECTIONAL {
        return PunctualIncidence {
            direction: -axis,
            distance: f32::INFINITY,
            irradiance: intensity,
        };
    }
    let to = Vec3::from_array(light.p0) - point;
    let distance_squared = to.length_squared();
    let distance = crate::math::sqrt(distance_squared);
    let direction = if distance > 0.0 {
        to / distance
    } else {
        Vec3::ZERO
    };
    let falloff = if light.kind == LIGHT_SPOT {
        spot_falloff(-direction.dot(axis), light.cos_inner, light.cos_outer)
    } else if light.kind == LIGHT_POINT {
        1.0
    } else {
        0.0
    };
    let irradiance = if distance_squared > 0.0 {
        intensity * (falloff / distance_squared)
    } else {
        Vec3::ZERO
    };
    PunctualIncidence {
        direction,
        distance,
        irradiance,
    }
}

/// Veach's power heuristic (β = 2): the MIS weight of a sample drawn with density `pdf` when
/// `other_pdf` could also have drawn it. 0 when both are 0 or not finite.
#[inline]
pub fn power_heuristic(pdf: f32, other_pdf: f32) -> f32 {
    let a = pdf * pdf;
    let b = other_pdf * other_pdf;
    let w = a / (a + b);
    if w.is_finite() {
        clamp(w, 0.0, 1.0)
    } else {
        0.0
    }
}

/// Russian roulette: the probability that a path of `throughput` continues, its largest
/// component capped at 0.95 (so that no path runs for ever) and at least 0 (NaN gives 0).
#[inline]
pub fn russian_roulette_survival(throughput: Vec3) -> f32 {
    let m = max(max(throughput.x, throughput.y), throughput.z);
    if m > 0.0 { min(m, 0.95) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Random;
    use core::mem::{offset_of, size_of};

    #[test]
    fn layout() {
        assert_eq!(size_of::<GpuLight>(), 80);
        assert_eq!(offset_of!(GpuLight, p0), 0);
        assert_eq!(offset_of!(GpuLight, kind), 12);
        assert_eq!(offset_of!(GpuLight, p1), 16);
        assert_eq!(offset_of!(GpuLight, instance), 28);
        assert_eq!(offset_of!(GpuLight, p2), 32);
        assert_eq!(offset_of!(GpuLight, primitive), 44);
        assert_eq!(offset_of!(GpuLight, intensity), 48);
        assert_eq!(offset_of!(GpuLight, area), 60);
        assert_eq!(offset_of!(GpuLight, cos_inner), 64);
        assert_eq!(offset_of!(GpuLight, cos_outer), 68);
        assert_eq!(offset_of!(GpuLight, _pad), 72);
    }

    #[test]
    fn selection_is_uniform_and_in_range() {
        assert_eq!(select_light(0, 0.5), 0);
        assert_eq!(select_light(4, 0.0), 0);
        assert_eq!(select_light(4, 0.999_999_9), 3);
        assert_eq!(select_light(4, 1.0), 3);
        assert_eq!(select_light(4, f32::NAN), 0);
        let mut counts = [0u32; 5];
        let mut rng = Random::new(1, 0);
        for _ in 0..100_000 {
            counts[select_light(5, rng.next_f32()) as usize] += 1;
        }
        for c in counts {
            assert!((c as f32 / 20_000.0 - 1.0).abs() < 0.03, "{counts:?}");
        }
    }

    /// Integrating the cosine-weighted radiance of a triangle by light sampling gives the
    /// irradiance of a unit-radiance triangle: its projected solid angle, which for a small
    /// triangle far away is `area · cos / d²`.
    #[test]
    fn triangle_sampling_estimates_the_projected_solid_angle() {
        let light = GpuLight::triangle(
            0,
            0,
            [
                Vec3::new(-0.05, -0.05, 10.0),
                Vec3::new(0.05, -0.05, 10.0),
                Vec3::new(0.0, 0.05, 10.0),
            ],
            Vec3::ONE,
        );
        assert!((light.area - 0.005).abs() < 1e-7);
        let mut rng = Random::new(2, 0);
        let n = 20_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let s = sample_triangle_light(&light, Vec3::ZERO, rng.next_vec2());
            assert!(s.pdf > 0.0 && (s.direction.length() - 1.0).abs() < 1e-5);
            assert!((s.point.z - 10.0).abs() < 1e-5);
            sum += (s.direction.z / s.pdf) as f64;
        }
        let exact = 0.005 / 100.0;
        assert!(((sum / n as f64) - exact).abs() / exact < 1e-3);
        // Edge-on and degenerate triangles have no density.
        assert_eq!(triangle_light_pdf(1.0, 1.0, 0.0), 0.0);
        assert_eq!(triangle_light_pdf(0.0, 1.0, 1.0), 0.0);
    }

    #[test]
    fn punctual_lights_follow_the_inverse_square_law_and_the_cone() {
        let point = GpuLight::point(Vec3::new(0.0, 2.0, 0.0), Vec3::splat(8.0));
        let i = punctual_incidence(&point, Vec3::ZERO);
        assert_eq!(i.direction, Vec3::Y);
        assert_eq!(i.distance, 2.0);
        assert_eq!(i.irradiance, Vec3::splat(2.0));

        let spot = GpuLight::spot(Vec3::ZERO, Vec3::NEG_Y, Vec3::ONE, 0.2, 0.4);
        let at = |angle: f32| {
            punctual_incidence(&spot, Vec3::new(angle.sin(), -angle.cos(), 0.0)).irradiance
        };
        assert!((at(0.0).x - 1.0).abs() < 1e-6);
        assert!((at(0.19).x - 1.0).abs() < 1e-6);
        assert_eq!(at(0.41).x, 0.0);
        let mid = at(0.3).x;
        assert!(mid > 0.0 && mid < 1.0);
        assert_eq!(spot_falloff(1.0, 0.9, 0.8), 1.0);
        assert!((spot_falloff(0.85, 0.9, 0.8) - 0.25).abs() < 1e-5);

        let sun = GpuLight::directional(Vec3::NEG_Z, Vec3::splat(3.0));
        let s = punctual_incidence(&sun, Vec3::splat(5.0));
        assert_eq!(s.direction, Vec3::Z);
        assert_eq!(s.distance, f32::INFINITY);
        assert_eq!(s.irradiance, Vec3::splat(3.0));

        // A light at the point itself delivers nothing rather than infinity.
        assert_eq!(
            punctual_incidence(&point, point_position(&point)).irradiance,
            Vec3::ZERO
        );
    }

    fn point_position(l: &GpuLight) -> Vec3 {
        Vec3::from_array(l.p0)
    }

    #[test]
    fn mis_and_roulette() {
        assert_eq!(power_heuristic(1.0, 1.0), 0.5);
        assert!((power_heuristic(3.0, 1.0) - 0.9).abs() < 1e-6);
        assert!((power_heuristic(3.0, 1.0) + power_heuristic(1.0, 3.0) - 1.0).abs() < 1e-6);
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 0.0);
        assert_eq!(russian_roulette_survival(Vec3::new(0.1, 0.5, 0.2)), 0.5);
        assert_eq!(russian_roulette_survival(Vec3::splat(4.0)), 0.95);
        assert_eq!(russian_roulette_survival(Vec3::splat(f32::NAN)), 0.0);
        assert_eq!(russian_roulette_survival(Vec3::ZERO), 0.0);
    }
}
