//! Rays and hit records, identical for the ray-query and the software-traversal kernels.

use bytemuck::{Pod, Zeroable};

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

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

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
