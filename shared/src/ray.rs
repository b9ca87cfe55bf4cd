//! Rays and hit records, identical for the ray-query and the software-traversal kernels.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Units in the last place of the hit point's largest coordinate by which a ray leaves a
/// surface: the hit point, rounded once, lies at most `√3/2` ULP off the plane, and rounding the
/// offset point adds as much again, so any offset above `√3` ULP leaves the plane. Larger costs
/// accuracy far from the origin: at 1e5, where a ULP is 7.8 mm, 4 ULPs brightened the Cornell
/// box by 1.8% (the ray escapes contact shadows), 2 ULPs by 0.6%.
pub const OFFSET_POSITION_ULPS: f32 = 2.0;
/// Units in the last place of the triangle's size added to the offset: covers the rounding of
/// the next ray/triangle test, whose vertex differences are exact to within that size.
pub const OFFSET_SIZE_ULPS: f32 = 32.0;

/// A ray as kernels read it from a buffer (32 bytes, two 16-byte rows).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Ray {
    /// Origin.
    pub origin: [f32; 3],
    /// Hits closer than this are ignored.
    pub t_min: f32,
    /// Direction (need not be normalised; distances are in units of its length).
    pub direction: [f32; 3],
    /// Hits farther than this are ignored.
    pub t_max: f32,
}

impl Ray {
    /// Whether both tracing variants define a result for this ray: finite origin and direction,
    /// `0 <= t_min <= t_max` (`t_max` may be infinite). Ray queries leave anything else undefined,
    /// so every tracer reports a miss for it instead.
    pub fn is_traceable(&self) -> bool {
        let finite = |v: [f32; 3]| v[0].is_finite() && v[1].is_finite() && v[2].is_finite();
        finite(self.origin)
            && finite(self.direction)
            && self.t_min >= 0.0
            && self.t_min <= self.t_max
    }
}

/// The closest hit of a ray, as both traversal variants report it (32 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HitRecord {
    /// Distance along the ray, in units of the direction's length; [`HitRecord::MISS_T`] on a miss.
    pub t: f32,
    /// Instance index (custom index of the top-level instance); [`HitRecord::NONE`] on a miss.
    pub instance: u32,
    /// Triangle index within the instance's mesh; [`HitRecord::NONE`] on a miss.
    pub primitive: u32,
    /// 1 when the ray hit the triangle's front (counter-clockwise) face, else 0.
    pub front_face: u32,
    /// Barycentrics (u, v) of the hit: weights of the triangle's second and third vertex.
    pub barycentrics: [f32; 2],
    /// Explicit padding to 32 bytes.
    pub _pad: [u32; 2],
}

impl HitRecord {
    /// Instance and primitive of a miss.
    pub const NONE: u32 = u32::MAX;
    /// Distance of a miss.
    pub const MISS_T: f32 = f32::INFINITY;

    /// The record of a ray that hit nothing.
    pub const fn miss() -> Self {
        Self {
            t: Self::MISS_T,
            instance: Self::NONE,
            primitive: Self::NONE,
            front_face: 0,
            barycentrics: [0.0; 2],
            _pad: [0; 2],
        }
    }

    /// Whether the ray hit something.
    pub fn is_hit(&self) -> bool {
        self.primitive != Self::NONE
    }
}

/// The spacing of floats at `|x|` (the value of its last place): `2^(exponent − 23)`; the
/// smallest subnormal for 0 and subnormals, infinite for non-finite `x`.
#[inline]
pub fn ulp(x: f32) -> f32 {
    let power = f32::from_bits(x.to_bits() & 0x7f80_0000);
    let u = power * (1.0 / 8_388_608.0);
    if u > 0.0 { u } else { f32::from_bits(1) }
}

/// Where a ray leaving the surface at `p` toward the side of the unit normal `n` starts, for a
/// triangle whose largest edge coordinate is `size`.
///
/// After Wächter and Binder, "A Fast and Robust Method for Avoiding Self-Intersection" (Ray
/// Tracing Gems, ch. 6): an offset along the geometric normal counted in ULPs, so that it is as
/// small as the rounding allows at any scale. Unlike theirs, no absolute threshold near the
/// origin (their `1/32` assumes metre-sized scenes): the offset is
/// [`OFFSET_POSITION_ULPS`] ULPs of the point's largest coordinate, which bounds the rounding of
/// a hit point computed relative to a vertex, plus [`OFFSET_SIZE_ULPS`] ULPs of the triangle's
/// size, which bounds the rounding of the next watertight test (its vertex differences are
/// exact to within their own magnitude). The result does not depend on the scene's scale, and
/// only a few ULPs on the translation.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3, size: f32) -> Vec3 {
    let m = p.abs().max_element();
    let d = OFFSET_POSITION_ULPS * ulp(m) + OFFSET_SIZE_ULPS * ulp(size);
    p + n * d
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

    #[test]
    fn ulps() {
        assert_eq!(ulp(1.0), f32::EPSILON);
        assert_eq!(ulp(-1.5), f32::EPSILON);
        assert_eq!(ulp(1024.0), 1024.0 * f32::EPSILON);
        assert_eq!(ulp(0.0), f32::from_bits(1));
        assert_eq!(ulp(f32::INFINITY), f32::INFINITY);
    }

    /// The offset point is off the plane on the normal's side, by a distance that scales with
    /// the scene: the same relative offset at 1e-3, 1 and 1e3, and at most a few ULPs of a large
    /// translation.
    #[test]
    fn offsets_leave_the_plane_at_any_scale() {
        let n = Vec3::new(0.3, 0.8, -0.2).normalize();
        let mut relative = [0.0f32; 3];
        for (k, scale) in [1e-3f32, 1.0, 1e3].into_iter().enumerate() {
            let p = Vec3::new(0.7, -0.3, 0.45) * scale;
            let o = offset_ray_origin(p, n, 2.0 * scale);
            let d = (o - p).dot(n);
            assert!(d > 0.0);
            relative[k] = d / scale;
        }
        for r in relative {
            assert!((r / relative[1] - 1.0).abs() < 0.6, "{relative:?}");
        }
        let p = Vec3::new(1e5 + 0.25, 0.5, -0.75);
        let o = offset_ray_origin(p, n, 2.0);
        let d = (o - p).dot(n);
        assert!(d > ulp(1e5) && d < 4.0 * ulp(1e5), "{d}");
    }

    #[test]
    fn layouts() {
        assert_eq!(size_of::<Ray>(), 32);
        assert_eq!(offset_of!(Ray, origin), 0);
        assert_eq!(offset_of!(Ray, t_min), 12);
        assert_eq!(offset_of!(Ray, direction), 16);
        assert_eq!(offset_of!(Ray, t_max), 28);
        assert_eq!(size_of::<HitRecord>(), 32);
        assert_eq!(offset_of!(HitRecord, t), 0);
        assert_eq!(offset_of!(HitRecord, instance), 4);
        assert_eq!(offset_of!(HitRecord, primitive), 8);
        assert_eq!(offset_of!(HitRecord, front_face), 12);
        assert_eq!(offset_of!(HitRecord, barycentrics), 16);
        assert_eq!(offset_of!(HitRecord, _pad), 24);
    }

    #[test]
    fn traceable_rays() {
        let ray = Ray {
            origin: [0.0; 3],
            t_min: 0.0,
            direction: [0.0, 0.0, 1.0],
            t_max: f32::INFINITY,
        };
        assert!(ray.is_traceable());
        assert!(!Ray { t_min: -1.0, ..ray }.is_traceable());
        assert!(
            !Ray {
                t_min: 2.0,
                t_max: 1.0,
                ..ray
            }
            .is_traceable()
        );
        assert!(
            !Ray {
                t_max: f32::NAN,
                ..ray
            }
            .is_traceable()
        );
        assert!(
            !Ray {
                origin: [f32::NAN, 0.0, 0.0],
                ..ray
            }
            .is_traceable()
        );
        assert!(
            !Ray {
                direction: [f32::INFINITY, 0.0, 0.0],
                ..ray
            }
            .is_traceable()
        );
    }

    #[test]
    fn miss_is_not_a_hit() {
        assert!(!HitRecord::miss().is_hit());
        let mut h = HitRecord::miss();
        h.primitive = 0;
        assert!(h.is_hit());
    }
}
