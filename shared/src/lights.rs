//! Lights for next-event estimation: punctual lights (glTF `KHR_lights_punctual` semantics),
//! emissive triangles and the environment image, all in one buffer of [`GpuLight`]s, with the
//! sampling and evaluation the path tracer needs on the CPU and the GPU.
//!
//! # Light selection
//!
//! In proportion to power: each light carries its selection probability
//! ([`GpuLight::select_pmf`]) and one column of a Walker/Vose alias table
//! ([`GpuLight::alias`], [`GpuLight::alias_threshold`]), built on the host, so that
//! [`select_light`] costs two uniforms and two reads whatever the light count. MIS needs the
//! selection probability of an emissive triangle that a BSDF-sampled ray hits: the host's
//! triangle→light table ([`light_of_triangle`]) maps (instance, primitive) to its light.
//!
//! # Conventions
//!
//! Sampling a triangle ignores which side faces the shading point; [`GpuLight::emit_sides`] says
//! which sides emit (the front face, or both for a double-sided material), and the path tracer
//! checks it against the material. Punctual lights ignore glTF's `range` (a culling hint; the
//! falloff is inverse-square without a window).

use bytemuck::{Pod, Zeroable};
use glam::{UVec2, Vec2, Vec3};

use crate::environment::{sample_environment, texel_of};
use crate::math::{PI, acos, clamp, cos, max, min, saturate, sin, sqrt, to_u32_clamped};
use crate::ray::{Ray, offset_ray_origin};
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
/// The environment image (see [`crate::environment`]); at most one per buffer, found by
/// `PathTracerParams::environment_light`.
pub const LIGHT_ENVIRONMENT: u32 = 4;

/// [`GpuLight::emit_sides`]: the side toward which `(p1 − p0) × (p2 − p0)` points emits.
pub const EMIT_FRONT: u32 = 1;
/// [`GpuLight::emit_sides`]: the other side emits.
pub const EMIT_BACK: u32 = 2;

/// Most lights the frame takes one by one: DirectLight sums up to this many punctual lights
/// exactly, one shadow ray each (beyond it the host sets
/// `crate::screen_probes::FLAG_SAMPLED_DIRECT` and one light is resampled:
/// `crate::primary_lighting::samples_direct_light`), and a secondary hit weighs up to this many
/// lights itself, without the light grid (`crate::light_grid::light_grid_needed`).
pub const EXACT_DIRECT_LIGHTS: u32 = 16;

/// Most light candidates one next-event estimate resamples (`PathTracerParams::light_candidates`).
pub const MAX_LIGHT_CANDIDATES: u32 = 64;

/// One light (96 bytes). Which fields mean what depends on `kind`.
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
/// | 72     | `select_pmf` | all kinds    |             |            |
/// | 76     | `alias`      | all kinds    |             |            |
/// | 80     | `alias_threshold` | all kinds |            |            |
/// | 84     | `emit_sides` | unused       | unused      | triangle   |
/// | 88     | `cluster`    | all kinds    |             |            |
/// | 92     | `cluster_cdf` | all kinds   |             |            |
///
/// `direction` is the unit direction the light shines in. The environment light uses only the
/// selection fields.
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
    /// Probability that [`select_light`] picks this light.
    pub select_pmf: f32,
    /// Alias-table column of this light's index: the light picked when the second uniform is at
    /// or above `alias_threshold`.
    pub alias: u32,
    /// Alias-table column: below this the column's own light is picked.
    pub alias_threshold: f32,
    /// Triangle: [`EMIT_FRONT`] and/or [`EMIT_BACK`].
    pub emit_sides: u32,
    /// Index of the light's cluster (`crate::light_clusters`), which the light grid weighs.
    pub cluster: u32,
    /// The light's cluster's probabilities, summed over its lights up to this one: the light
    /// takes the interval from its predecessor's value (0 for the first) to this one (1 for the
    /// last).
    pub cluster_cdf: f32,
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
        select_pmf: 0.0,
        alias: 0,
        alias_threshold: 0.0,
        emit_sides: 0,
        cluster: 0,
        cluster_cdf: 1.0,
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
    /// `radiance`, emitting toward `emit_sides` ([`EMIT_FRONT`], [`EMIT_BACK`]); the area is
    /// computed from the vertices.
    pub fn triangle(
        instance: u32,
        primitive: u32,
        vertices: [Vec3; 3],
        radiance: Vec3,
        emit_sides: u32,
    ) -> Self {
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
            emit_sides,
            ..Self::ZERO
        }
    }

    /// The environment image as a light: only its selection fields matter.
    pub const ENVIRONMENT: Self = Self {
        kind: LIGHT_ENVIRONMENT,
        ..Self::ZERO
    };

    /// Whether a triangle light emits toward `direction` (pointing away from the triangle), by
    /// its world-space winding and [`GpuLight::emit_sides`].
    #[inline]
    pub fn emits_toward(&self, direction: Vec3) -> bool {
        let (p0, p1, p2) = (
            Vec3::from_array(self.p0),
            Vec3::from_array(self.p1),
            Vec3::from_array(self.p2),
        );
        let c = (p1 - p0).cross(p2 - p0).dot(direction);
        (c > 0.0 && self.emit_sides & EMIT_FRONT != 0)
            || (c < 0.0 && self.emit_sides & EMIT_BACK != 0)
    }

    /// How many sides of a triangle light emit (0, 1 or 2), by [`GpuLight::emit_sides`]: its
    /// power counts each.
    #[inline]
    pub fn emitting_sides(&self) -> f32 {
        let front = (self.emit_sides & EMIT_FRONT != 0) as u32;
        let back = (self.emit_sides & EMIT_BACK != 0) as u32;
        (front + back) as f32
    }
}

/// The lights that next-event estimation samples: the light buffer, and the environment image
/// with its sampling CDF (both empty without one).
#[derive(Clone, Copy)]
pub struct LightSources<'a> {
    /// The light buffer.
    pub lights: &'a [GpuLight],
    /// The environment image's texels (RGBA32F).
    pub environment: &'a [[f32; 4]],
    /// The environment image's sampling CDF (`crate::environment`).
    pub environment_cdf: &'a [f32],
}

impl LightSources<'static> {
    /// No lights and no environment.
    pub const EMPTY: Self = Self {
        lights: &[],
        environment: &[],
        environment_cdf: &[],
    };
}

/// The lights as the passes that shade hits read them: the sources next-event estimation samples,
/// and the emissive triangles' table that weighs a hit emitter by MIS against them.
#[derive(Clone, Copy)]
pub struct SceneLights<'a> {
    /// The light buffer and the environment.
    pub sources: LightSources<'a>,
    /// Light index of each emissive triangle ([`light_of_triangle`]).
    pub light_table: &'a [u32],
}

impl SceneLights<'static> {
    /// No lights, no environment, no emissive triangles.
    pub const EMPTY: Self = Self {
        sources: LightSources::EMPTY,
        light_table: &[],
    };
}

/// Power-proportional light selection by the alias method: the index of the light that `u`
/// (uniform in `[0, 1)²`) picks among the first `count` of `lights`, with probability
/// [`GpuLight::select_pmf`]. 0 when `count` is 0 (the caller checks the count first); an
/// out-of-range alias reads as the column's own light.
#[inline]
pub fn select_light(lights: &[GpuLight], count: u32, u: Vec2) -> u32 {
    let count = if (count as usize) < lights.len() {
        count
    } else {
        lights.len() as u32
    };
    if count == 0 {
        return 0;
    }
    let i = to_u32_clamped(u.x * count as f32);
    let i = if i >= count { count - 1 } else { i };
    let column = &lights[i as usize];
    if u.y < column.alias_threshold || column.alias >= count {
        i
    } else {
        column.alias
    }
}

/// The light index of triangle `primitive` of `instance` in the triangle→light `table`, or
/// [`crate::scene_data::NONE`] when it is not a light (or the table does not know it).
///
/// Layout: `table[instance]` is the offset of the instance's run (one entry per triangle of its
/// mesh) or `NONE` for an instance without emissive triangles; `table[offset + primitive]` is
/// the light index or `NONE`.
#[inline]
pub fn light_of_triangle(table: &[u32], instance: u32, primitive: u32) -> u32 {
    let none = crate::scene_data::NONE;
    if (instance as usize) >= table.len() {
        return none;
    }
    let offset = table[instance as usize];
    if offset == none {
        return none;
    }
    let i = offset as usize + primitive as usize;
    if i < table.len() { table[i] } else { none }
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
    // Relative to p0, as hit points are: rounding then depends on the triangle's size, not on
    // how far from the origin it lies.
    let point = p0 + (p1 - p0) * b.y + (p2 - p0) * b.z;
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

/// Below this solid angle (steradians) [`sample_triangle_light_by_solid_angle`] samples a
/// triangle uniformly in area instead: the spherical construction's angle sum loses its digits
/// to cancellation on small triangles, where area sampling's `1 / r²` varies little anyway.
pub const SOLID_ANGLE_SAMPLING_MIN: f32 = 1e-2;

/// Samples a direction uniformly within the solid angle triangle `light` subtends at `from`
/// (`u` uniform in `[0, 1)²`; Arvo, "Stratified sampling of spherical triangles", 1995): the
/// density is `1 / Ω`, so a sample's `cos / pdf` is at most `Ω`, where uniform area sampling's
/// `cos · r⁻² · area` grows without bound as the point nears the triangle (a light sample in a
/// room's corner). Triangles below [`SOLID_ANGLE_SAMPLING_MIN`] and degenerate views fall back
/// to [`sample_triangle_light`], chosen by the geometry alone, so the estimate stays unbiased.
pub fn sample_triangle_light_by_solid_angle(
    light: &GpuLight,
    from: Vec3,
    u: Vec2,
) -> TriangleSample {
    let (p0, p1, p2) = (
        Vec3::from_array(light.p0),
        Vec3::from_array(light.p1),
        Vec3::from_array(light.p2),
    );
    // Most emissive triangles of a real scene are small and far: a bound settles them before any
    // angle is computed. Within radius `r` of their centroid, `d` away, they subtend at most
    // `2π r² / d²` (a cap's `2π (1 − cos)` ≤ `2π sin²`), so below the minimum so does `Ω`.
    let centroid = (p0 + p1 + p2) * (1.0 / 3.0);
    let r2 = max(
        (p0 - centroid).length_squared(),
        max(
            (p1 - centroid).length_squared(),
            (p2 - centroid).length_squared(),
        ),
    );
    if 2.0 * PI * r2 < SOLID_ANGLE_SAMPLING_MIN * (centroid - from).length_squared() {
        return sample_triangle_light(light, from, u);
    }
    let a = (p0 - from).normalize_or_zero();
    let b = (p1 - from).normalize_or_zero();
    let c = (p2 - from).normalize_or_zero();
    let n_ab = a.cross(b).normalize_or_zero();
    let n_bc = b.cross(c).normalize_or_zero();
    let n_ca = c.cross(a).normalize_or_zero();
    // The interior angles: between the great circles through each vertex.
    let angle = |x: Vec3, y: Vec3| acos(clamp(x.dot(y), -1.0, 1.0));
    let alpha = angle(n_ab, -n_ca);
    let beta = angle(n_bc, -n_ab);
    let gamma = angle(n_ca, -n_bc);
    let omega = alpha + beta + gamma - PI;
    let degenerate = n_ab == Vec3::ZERO || n_bc == Vec3::ZERO || n_ca == Vec3::ZERO;
    // Also false for NaN.
    let large = omega >= SOLID_ANGLE_SAMPLING_MIN;
    if degenerate || !large {
        return sample_triangle_light(light, from, u);
    }
    // The sub-triangle A B̂ Ĉ of area u.x · Ω: Ĉ on the arc from A to C.
    let sub = u.x * omega - alpha;
    let (s, t) = (sin(sub), cos(sub));
    let (cos_alpha, sin_alpha) = (cos(alpha), sin(alpha));
    let k1 = t - cos_alpha;
    let k2 = s + sin_alpha * a.dot(b);
    let q = clamp(
        ((k2 * t - k1 * s) * cos_alpha - k2) / ((k2 * s + k1 * t) * sin_alpha),
        -1.0,
        1.0,
    );
    let c_hat = a * q + (c - a * c.dot(a)).normalize_or_zero() * sqrt(max(1.0 - q * q, 0.0));
    // Then uniform in area along the arc from B to Ĉ.
    let z = clamp(1.0 - u.y * (1.0 - c_hat.dot(b)), -1.0, 1.0);
    let w = b * z + (c_hat - b * c_hat.dot(b)).normalize_or_zero() * sqrt(max(1.0 - z * z, 0.0));
    // Where the direction meets the triangle's plane, as barycentrics clamped inside it.
    let (e1, e2) = (p1 - p0, p2 - p0);
    let normal = e1.cross(e2);
    let along = (p0 - from).dot(normal) / w.dot(normal);
    let v = from + w * along - p0;
    let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d20, d21) = (v.dot(e1), v.dot(e2));
    let det = d00 * d11 - d01 * d01;
    let by = saturate((d11 * d20 - d01 * d21) / det);
    let bz = min(saturate((d00 * d21 - d01 * d20) / det), 1.0 - by);
    // Also false for NaN: a direction rounding left off the plane is no sample (pdf 0), not
    // one of the other technique, which would weigh part of the triangle twice.
    let meets = along > 0.0 && along.is_finite() && det > 0.0;
    // Relative to p0, as hit points are (see `sample_triangle_light`).
    let point = p0 + e1 * by + e2 * bz;
    let to = point - from;
    let distance = to.length();
    TriangleSample {
        point,
        barycentrics: Vec2::new(by, bz),
        direction: if distance > 0.0 {
            to / distance
        } else {
            Vec3::ZERO
        },
        distance,
        pdf: if meets { 1.0 / omega } else { 0.0 },
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

/// Radiance arriving from the sky along the unit `direction` (pointing away from the scene): the
/// `environment_size` image's texel when there is one, else the constant `sky`. Every pass that
/// lets a ray escape reads the sky through this one function.
#[inline]
pub fn sky_radiance(
    environment_size: [u32; 2],
    sky: [f32; 3],
    environment: &[[f32; 4]],
    direction: Vec3,
) -> Vec3 {
    let [w, h] = environment_size;
    if w == 0 || h == 0 {
        return Vec3::from_array(sky);
    }
    environment_radiance(UVec2::new(w, h), environment, direction)
}

/// Radiance of the environment image along the unit `direction` (pointing away from the scene):
/// its texel ([`crate::environment`] gives the mapping). `environment` holds the `size` image's
/// texels row by row (RGB, the fourth channel unused); a too-short buffer reads as black.
#[inline]
pub fn environment_radiance(size: UVec2, environment: &[[f32; 4]], direction: Vec3) -> Vec3 {
    let t = texel_of(size, direction);
    let i = t.y as usize * size.x as usize + t.x as usize;
    if i < environment.len() {
        let t = environment[i];
        Vec3::new(t[0], t[1], t[2])
    } else {
        Vec3::ZERO
    }
}

/// One sample of one light seen from a shading point: what next-event estimation needs before
/// the receiver's BSDF and the light's selection probability.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point toward the light.
    pub direction: Vec3,
    /// Radiance (triangle, environment; before emissive textures and multipliers), or irradiance
    /// on a surface facing the light (punctual lights).
    pub radiance: Vec3,
    /// Solid-angle density of `direction` given the light; 1 for punctual lights (a delta
    /// distribution: `radiance` is already an irradiance); 0 when there is no usable sample
    /// (a triangle seen edge-on or from a side that does not emit, an empty environment).
    pub pdf: f32,
    /// The shadow ray from the shading point to the sample (ends short of a triangle's surface).
    pub ray: Ray,
    /// Barycentrics of the point on a triangle light (for its emissive texture).
    pub barycentrics: Vec2,
}

impl LightSample {
    /// No sample: zero radiance and density, an empty shadow ray from `origin`.
    #[inline]
    pub fn none(origin: Vec3) -> Self {
        Self {
            direction: Vec3::ZERO,
            radiance: Vec3::ZERO,
            pdf: 0.0,
            ray: Ray {
                origin: origin.to_array(),
                t_min: 0.0,
                direction: [0.0; 3],
                t_max: 0.0,
            },
            barycentrics: Vec2::ZERO,
        }
    }
}

/// [`sample_light`] of a triangle light (`u` uniform in `[0, 1)²`): a point uniform in area, its
/// solid-angle density, and the shadow ray from `origin` to just off the light; no sample (pdf
/// 0, direction and barycentrics kept) when the triangle is seen edge-on or from a side that does
/// not emit.
#[inline]
pub fn sample_triangle_light_ray(light: &GpuLight, origin: Vec3, u: Vec2) -> LightSample {
    triangle_light_ray(light, origin, &sample_triangle_light(light, origin, u))
}

/// [`sample_triangle_light_ray`] with the point drawn uniformly in solid angle
/// ([`sample_triangle_light_by_solid_angle`]).
#[inline]
pub fn sample_triangle_light_ray_by_solid_angle(
    light: &GpuLight,
    origin: Vec3,
    u: Vec2,
) -> LightSample {
    triangle_light_ray(
        light,
        origin,
        &sample_triangle_light_by_solid_angle(light, origin, u),
    )
}

/// The light sample and shadow ray of triangle sample `t` of `light` seen from `origin`.
#[inline]
fn triangle_light_ray(light: &GpuLight, origin: Vec3, t: &TriangleSample) -> LightSample {
    let mut s = LightSample::none(origin);
    s.direction = t.direction;
    s.barycentrics = t.barycentrics;
    if t.pdf > 0.0 && light.emits_toward(-t.direction) {
        let (p0, p1, p2) = (
            Vec3::from_array(light.p0),
            Vec3::from_array(light.p1),
            Vec3::from_array(light.p2),
        );
        let (e1, e2) = (p1 - p0, p2 - p0);
        let mut n = e1.cross(e2).normalize_or_zero();
        if n.dot(t.direction) > 0.0 {
            n = -n;
        }
        // The shadow ray ends just off the light, on the shading point's side.
        let size = e1.abs().max(e2.abs()).max((p2 - p1).abs()).max_element();
        let end = offset_ray_origin(t.point, n, size);
        s.radiance = Vec3::from_array(light.intensity);
        s.pdf = t.pdf;
        s.ray.direction = (end - origin).to_array();
        s.ray.t_max = 1.0;
    }
    s
}

/// Samples `light` from the shading point `origin` (`u` uniform in `[0, 1)²`): a point on a
/// triangle (uniform in area), a direction of the environment (by its distribution `cdf` of a
/// `environment_size` image, radiance from `environment`), or a punctual light's incidence.
pub fn sample_light(
    light: &GpuLight,
    origin: Vec3,
    environment_size: UVec2,
    environment: &[[f32; 4]],
    environment_cdf: &[f32],
    u: Vec2,
) -> LightSample {
    let mut s = LightSample::none(origin);
    if light.kind == LIGHT_TRIANGLE {
        s = sample_triangle_light_ray(light, origin, u);
    } else if light.kind == LIGHT_ENVIRONMENT {
        let e = sample_environment(environment_size, environment_cdf, u);
        s.direction = e.direction;
        if e.pdf > 0.0 {
            s.radiance = environment_radiance(environment_size, environment, e.direction);
            s.pdf = e.pdf;
            s.ray.direction = e.direction.to_array();
            s.ray.t_max = f32::INFINITY;
        }
    } else {
        let incidence = punctual_incidence(light, origin);
        s.direction = incidence.direction;
        s.radiance = incidence.irradiance;
        s.pdf = 1.0;
        s.ray.direction = incidence.direction.to_array();
        s.ray.t_max = incidence.distance;
    }
    s
}

/// Veach's power heuristic (β = 2): the MIS weight of a sample drawn with density `pdf` when
/// `other_pdf` could also have drawn it. 0 when `pdf` is 0 or NaN; an infinite `pdf` (a
/// technique that cannot miss) against a finite other gets 1, and the reverse 0.
#[inline]
pub fn power_heuristic(pdf: f32, other_pdf: f32) -> f32 {
    if pdf.is_nan() || pdf <= 0.0 {
        return 0.0;
    }
    if other_pdf.is_nan() || other_pdf <= 0.0 {
        return 1.0;
    }
    // The ratio keeps squares of large densities from overflowing to ∞/∞.
    let r = other_pdf / pdf;
    let w = 1.0 / (1.0 + r * r);
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
        assert_eq!(size_of::<GpuLight>(), 96);
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
        assert_eq!(offset_of!(GpuLight, select_pmf), 72);
        assert_eq!(offset_of!(GpuLight, alias), 76);
        assert_eq!(offset_of!(GpuLight, alias_threshold), 80);
        assert_eq!(offset_of!(GpuLight, emit_sides), 84);
        assert_eq!(offset_of!(GpuLight, cluster), 88);
        assert_eq!(offset_of!(GpuLight, cluster_cdf), 92);
    }

    /// The alias table of probabilities (1/2, 1/4, 1/4), written by hand (the host builds them):
    /// columns 1 and 2 give half their mass to light 0.
    #[test]
    fn alias_selection_follows_the_table() {
        let column = |pmf: f32, alias: u32, threshold: f32| GpuLight {
            select_pmf: pmf,
            alias,
            alias_threshold: threshold,
            ..GpuLight::ZERO
        };
        let lights = [
            column(0.5, 0, 1.0),
            column(0.25, 0, 0.75),
            column(0.25, 0, 0.75),
        ];
        assert_eq!(select_light(&lights, 0, Vec2::splat(0.5)), 0);
        assert_eq!(select_light(&lights, 3, Vec2::new(0.999_999_9, 0.1)), 2);
        assert_eq!(select_light(&lights, 3, Vec2::new(1.0, 0.1)), 2);
        assert_eq!(select_light(&lights, 3, Vec2::new(0.5, 0.9)), 0);
        assert_eq!(select_light(&lights, 3, Vec2::splat(f32::NAN)), 0);
        // A count past the buffer is clamped to it.
        assert!(select_light(&lights, 9, Vec2::new(0.99, 0.1)) < 3);
        let mut counts = [0u32; 3];
        let mut rng = Random::new(1, 0);
        let n = 200_000;
        for _ in 0..n {
            counts[select_light(&lights, 3, rng.next_vec2()) as usize] += 1;
        }
        for (c, l) in counts.iter().zip(&lights) {
            let p = l.select_pmf;
            let got = *c as f32 / n as f32;
            assert!(
                (got - p).abs() < 4.0 * (p * (1.0 - p) / n as f32).sqrt(),
                "{counts:?}"
            );
        }
    }

    #[test]
    fn the_triangle_table_maps_instances_and_primitives_to_lights() {
        let none = crate::scene_data::NONE;
        // Instance 0 has no light; instance 1's mesh has three triangles, the last two lights.
        let table = [none, 2, none, 7, 8];
        assert_eq!(light_of_triangle(&table, 0, 0), none);
        assert_eq!(light_of_triangle(&table, 1, 0), none);
        assert_eq!(light_of_triangle(&table, 1, 1), 7);
        assert_eq!(light_of_triangle(&table, 1, 2), 8);
        assert_eq!(light_of_triangle(&table, 1, 3), none);
        assert_eq!(light_of_triangle(&table, 5, 0), none);
        assert_eq!(light_of_triangle(&[], 0, 0), none);
    }

    #[test]
    fn triangle_lights_emit_from_their_sides() {
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let front = GpuLight::triangle(0, 0, v, Vec3::ONE, EMIT_FRONT);
        let back = GpuLight::triangle(0, 0, v, Vec3::ONE, EMIT_BACK);
        let both = GpuLight::triangle(0, 0, v, Vec3::ONE, EMIT_FRONT | EMIT_BACK);
        assert!(front.emits_toward(Vec3::Z) && !front.emits_toward(Vec3::NEG_Z));
        assert!(!back.emits_toward(Vec3::Z) && back.emits_toward(Vec3::NEG_Z));
        assert!(both.emits_toward(Vec3::Z) && both.emits_toward(Vec3::NEG_Z));
        assert!(!both.emits_toward(Vec3::X));
    }

    /// Irradiance at the origin (normal +Z) from a unit-radiance polygon: Lambert's formula,
    /// `½ Σ θ_i (n · γ_i)`, in f64, independent of the sampling code.
    fn polygon_irradiance(vertices: &[Vec3]) -> f64 {
        let mut e = 0.0f64;
        for i in 0..vertices.len() {
            let a = vertices[i].as_dvec3().normalize();
            let b = vertices[(i + 1) % vertices.len()].as_dvec3().normalize();
            let theta = a.dot(b).clamp(-1.0, 1.0).acos();
            let gamma = a.cross(b).normalize();
            e += theta * gamma.z;
        }
        0.5 * e.abs()
    }

    /// Light sampling of a large, tilted triangle close to the receiver estimates its irradiance
    /// (the analytic polygon form factor). Swapping the receiver's and the light's cosines, or
    /// dropping the distance, would fail here.
    #[test]
    fn triangle_sampling_matches_the_polygon_form_factor() {
        let vertices = [
            Vec3::new(-0.8, -0.5, 0.3),
            Vec3::new(1.2, -0.2, 0.9),
            Vec3::new(-0.1, 1.1, 0.2),
        ];
        let light = GpuLight::triangle(0, 0, vertices, Vec3::ONE, EMIT_FRONT | EMIT_BACK);
        let mut rng = Random::new(7, 0);
        let n = 400_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let s = sample_triangle_light(&light, Vec3::ZERO, rng.next_vec2());
            let x = if s.pdf > 0.0 {
                f64::from(s.direction.z / s.pdf)
            } else {
                0.0
            };
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        let exact = polygon_irradiance(&vertices);
        assert!((mean - exact).abs() < 4.0 * se, "{mean} ± {se} vs {exact}");
        assert!(se < 0.01 * exact, "{se}");
    }

    /// The solid angle triangle `v` subtends at `from` (Van Oosterom and Strackee, 1983).
    fn solid_angle(v: [glam::DVec3; 3], from: glam::DVec3) -> f64 {
        let [a, b, c] = v.map(|p| (p - from).normalize());
        2.0 * a
            .dot(b.cross(c))
            .abs()
            .atan2(1.0 + a.dot(b) + b.dot(c) + c.dot(a))
    }

    /// Solid-angle sampling estimates the same form factor, for triangles large and small, near
    /// and far, with its density `1 / Ω` (Ω checked against Van Oosterom and Strackee's
    /// formula) and every sample's `cos / pdf` within `Ω`; a triangle seen from its own plane or
    /// below the minimum solid angle falls back to area sampling. A wrong interior angle, a swapped
    /// arc or a density off by the angle sum's `π` fails the mean.
    #[test]
    fn solid_angle_sampling_matches_the_polygon_form_factor() {
        // A corner's adjacent wall, 2 m across, seen from `d`: f32 rounding of its nearly
        // antipodal vertices biases the estimate by 0.7 % at 1 mm (0.1 % at 1 cm, within the
        // noise), the relative tolerance beside each.
        let wall = |d: f32| {
            [
                Vec3::new(d, -1.0, 0.0),
                Vec3::new(d, 1.0, 0.0),
                Vec3::new(d, 0.0, 2.0),
            ]
        };
        let cases = [
            // The large tilted triangle above and one just above the fallback's solid angle.
            (
                [
                    Vec3::new(-0.8, -0.5, 0.3),
                    Vec3::new(1.2, -0.2, 0.9),
                    Vec3::new(-0.1, 1.1, 0.2),
                ],
                0.0,
            ),
            (
                [
                    Vec3::new(-0.08, -0.08, 1.0),
                    Vec3::new(0.08, -0.08, 1.0),
                    Vec3::new(0.0, 0.1, 1.0),
                ],
                0.0,
            ),
            (wall(0.1), 0.0),
            (wall(0.01), 0.0),
            (wall(0.001), 0.01),
        ];
        for (vertices, rounding) in cases {
            let light = GpuLight::triangle(0, 0, vertices, Vec3::ONE, EMIT_FRONT | EMIT_BACK);
            let omega = solid_angle(vertices.map(|v| v.as_dvec3()), glam::DVec3::ZERO);
            let mut rng = Random::new(11, 0);
            let n = 200_000;
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let s = sample_triangle_light_by_solid_angle(&light, Vec3::ZERO, rng.next_vec2());
                assert!(
                    (f64::from(s.pdf) * omega - 1.0).abs() < 1e-3,
                    "{} {omega}",
                    s.pdf
                );
                let x = f64::from(s.direction.z.max(0.0) / s.pdf);
                assert!(x <= omega * 1.001, "{x} > {omega}");
                sum += x;
                sum2 += x * x;
            }
            let mean = sum / n as f64;
            let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
            let exact = polygon_irradiance(&vertices);
            assert!(
                (mean - exact).abs() < 4.0 * se + rounding * exact,
                "{mean} ± {se} vs {exact}"
            );
        }
        // The early bound (`2π r² / d²` about the centroid) never falls below the solid angle,
        // so it only skips work: random triangles seen from outside their bounding sphere.
        let mut rng = Random::new(13, 0);
        for _ in 0..10_000 {
            let v = [0; 3].map(|_| (rng.next_vec2().extend(rng.next_f32()) - 0.5).as_dvec3());
            let from = (rng.next_vec2().extend(rng.next_f32()) * 8.0 - 4.0).as_dvec3();
            let centroid = (v[0] + v[1] + v[2]) / 3.0;
            let r2 = v
                .iter()
                .map(|p| (*p - centroid).length_squared())
                .fold(0.0, f64::max);
            let d2 = (centroid - from).length_squared();
            if d2 <= r2 {
                continue;
            }
            let omega = solid_angle(v, from);
            assert!(
                omega <= 2.0 * core::f64::consts::PI * r2 / d2,
                "{omega} {r2} {d2}"
            );
        }
        // Seen from its own plane, and too small: area sampling's density.
        let edge_on = GpuLight::triangle(
            0,
            0,
            [Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
            Vec3::ONE,
            EMIT_FRONT,
        );
        let small = GpuLight::triangle(
            0,
            0,
            [
                Vec3::new(0.0, 0.0, 10.0),
                Vec3::new(0.1, 0.0, 10.0),
                Vec3::new(0.0, 0.1, 10.0),
            ],
            Vec3::ONE,
            EMIT_FRONT,
        );
        let u = Vec2::new(0.3, 0.6);
        for light in [edge_on, small] {
            assert_eq!(
                sample_triangle_light_by_solid_angle(&light, Vec3::ZERO, u),
                sample_triangle_light(&light, Vec3::ZERO, u)
            );
        }
    }

    /// Near a corner, area sampling's `cos / pdf` has a heavy tail (a room's adjacent wall seen
    /// from 1 mm: single samples hundreds of times the mean) and solid-angle sampling's none.
    #[test]
    fn solid_angle_sampling_has_no_corner_fireflies() {
        let vertices = [
            Vec3::new(0.001, -1.0, 0.0),
            Vec3::new(0.001, 1.0, 0.0),
            Vec3::new(0.001, 0.0, 2.0),
        ];
        let light = GpuLight::triangle(0, 0, vertices, Vec3::ONE, EMIT_FRONT | EMIT_BACK);
        let exact = polygon_irradiance(&vertices) as f32;
        let mut rng = Random::new(3, 0);
        let (mut area_max, mut solid_max) = (0.0f32, 0.0f32);
        for _ in 0..100_000 {
            let u = rng.next_vec2();
            let s = sample_triangle_light(&light, Vec3::ZERO, u);
            area_max = area_max.max(s.direction.z.max(0.0) / s.pdf);
            let s = sample_triangle_light_by_solid_angle(&light, Vec3::ZERO, u);
            solid_max = solid_max.max(s.direction.z.max(0.0) / s.pdf);
        }
        assert!(area_max > 100.0 * exact, "{area_max} vs {exact}");
        assert!(solid_max < 4.0 * exact, "{solid_max} vs {exact}");
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
            EMIT_FRONT,
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

    /// One sampling entry point for every kind: a triangle only from its emitting side, with a
    /// shadow ray that stops just short of it; punctual lights as delta samples; no environment
    /// without an image.
    #[test]
    fn light_samples_of_every_kind() {
        let v = [
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, 2.0, 1.0),
            Vec3::new(1.0, 2.0, 0.0),
        ];
        // (p1 − p0) × (p2 − p0) = +Y: the back faces down, toward the origin.
        let down = GpuLight::triangle(0, 0, v, Vec3::splat(3.0), EMIT_BACK);
        let up = GpuLight::triangle(0, 0, v, Vec3::splat(3.0), EMIT_FRONT);
        let u = Vec2::new(0.3, 0.6);
        let s = sample_light(&down, Vec3::ZERO, UVec2::ZERO, &[], &[], u);
        let t = sample_triangle_light(&down, Vec3::ZERO, u);
        assert_eq!(
            (s.direction, s.pdf, s.barycentrics),
            (t.direction, t.pdf, t.barycentrics)
        );
        assert_eq!(s.radiance, Vec3::splat(3.0));
        let end = Vec3::from_array(s.ray.direction);
        assert_eq!(s.ray.t_max, 1.0);
        assert!(end.y < 2.0 && end.y > 2.0 - 1e-5, "{end}");
        assert_eq!(
            sample_light(&up, Vec3::ZERO, UVec2::ZERO, &[], &[], u).pdf,
            0.0
        );

        let point = GpuLight::point(Vec3::new(0.0, 2.0, 0.0), Vec3::splat(8.0));
        let p = sample_light(&point, Vec3::ZERO, UVec2::ZERO, &[], &[], u);
        assert_eq!(
            (p.direction, p.radiance, p.pdf),
            (Vec3::Y, Vec3::splat(2.0), 1.0)
        );
        assert_eq!((p.ray.t_max, p.ray.direction), (2.0, [0.0, 1.0, 0.0]));

        let sky = sample_light(&GpuLight::ENVIRONMENT, Vec3::ZERO, UVec2::ZERO, &[], &[], u);
        assert_eq!((sky.pdf, sky.radiance), (0.0, Vec3::ZERO));
        // A 1 × 1 image: uniform over the sphere, its one texel's radiance.
        let cdf = [0.0, 1.0, 0.0, 1.0];
        let e = sample_light(
            &GpuLight::ENVIRONMENT,
            Vec3::ZERO,
            UVec2::ONE,
            &[[0.5; 4]],
            &cdf,
            u,
        );
        assert!(
            (e.pdf
                - 1.0
                    / (2.0
                        * core::f32::consts::PI
                        * core::f32::consts::PI
                        * Vec2::new(e.direction.x, e.direction.z).length()))
            .abs()
                < 1e-4
        );
        assert_eq!(e.radiance, Vec3::splat(0.5));
        assert_eq!(e.ray.t_max, f32::INFINITY);
        assert_eq!(environment_radiance(UVec2::ONE, &[], Vec3::Y), Vec3::ZERO);
    }

    #[test]
    fn mis_and_roulette() {
        assert_eq!(power_heuristic(1.0, 1.0), 0.5);
        assert!((power_heuristic(3.0, 1.0) - 0.9).abs() < 1e-6);
        assert!((power_heuristic(3.0, 1.0) + power_heuristic(1.0, 3.0) - 1.0).abs() < 1e-6);
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert_eq!(power_heuristic(1.0, f32::INFINITY), 0.0);
        assert_eq!(power_heuristic(f32::NAN, 1.0), 0.0);
        // Large densities do not overflow to ∞/∞.
        assert!((power_heuristic(3e30, 1e30) - 0.9).abs() < 1e-6);
        assert_eq!(russian_roulette_survival(Vec3::new(0.1, 0.5, 0.2)), 0.5);
        assert_eq!(russian_roulette_survival(Vec3::splat(4.0)), 0.95);
        assert_eq!(russian_roulette_survival(Vec3::splat(f32::NAN)), 0.0);
        assert_eq!(russian_roulette_survival(Vec3::ZERO), 0.0);
    }
}
