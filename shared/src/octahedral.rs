//! Direction ↔ square maps for probes: octahedral and hemi-octahedral (Cigolle et al. 2014,
//! "A Survey of Efficient Representations for Independent Unit Vectors") and the equal-area
//! hemisphere map of GI-1.0 v1.2 (Clarberg 2008, "Fast Equal-Area Mapping of the (Hemi)Sphere
//! using SIMD", as in Capsaicin's `mapToHemiOctahedron`).
//!
//! Encoders take unit vectors and return points of `[-1, 1]²`; decoders clamp their input to that
//! square and return unit vectors. Worst round-trip angular errors measured over 10⁶ directions plus
//! poles, seams and signed zeros (asserted by the tests):
//! - [`octahedral_encode`]/[`octahedral_decode`]: ≤ [`OCTAHEDRAL_MAX_ERROR`];
//! - [`hemi_octahedral_encode`]/[`hemi_octahedral_decode`]: ≤ [`HEMI_OCTAHEDRAL_MAX_ERROR`];
//! - [`equal_area_hemi_encode`]/[`equal_area_hemi_decode`]: ≤ [`EQUAL_AREA_MAX_ERROR`].
//!
//! These hold with `std` and with `libm` maths. On the GPU the (hemi-)octahedral maps only use
//! `+ − × ÷ √` and stay close to them; the equal-area map uses `atan`, `sin` and `cos`, which Vulkan
//! only bounds to 4096 ulp and 2^-11 absolute, so expect errors up to about 1e-3 rad there — far
//! below a probe cell (an 8 × 8 hemisphere cell spans about 0.2 rad).

use glam::{UVec2, Vec2, Vec3};

use crate::math::{
    abs, atan, clamp, cos, min, min_u32, safe_sqrt, sign_not_zero, sin, to_u32_clamped,
};

/// Bound on the octahedral round-trip error on the CPU, in radians (measured worst 2.9e-7).
pub const OCTAHEDRAL_MAX_ERROR: f32 = 4e-7;
/// Bound on the hemi-octahedral round-trip error on the CPU, in radians (measured worst 2.5e-7).
pub const HEMI_OCTAHEDRAL_MAX_ERROR: f32 = 4e-7;
/// Bound on the equal-area hemisphere round-trip error on the CPU, in radians (measured worst
/// 3.5e-7).
pub const EQUAL_AREA_MAX_ERROR: f32 = 5e-7;

const FRAC_PI_4: f32 = core::f32::consts::FRAC_PI_4;
const FRAC_2_PI: f32 = core::f32::consts::FRAC_2_PI;

#[inline]
fn clamp_to_square(e: Vec2) -> Vec2 {
    Vec2::new(clamp(e.x, -1.0, 1.0), clamp(e.y, -1.0, 1.0))
}

/// Octahedral map of the sphere onto `[-1, 1]²`; the lower hemisphere folds into the corners.
/// A zero or NaN vector maps to the centre (+z).
#[inline]
pub fn octahedral_encode(dir: Vec3) -> Vec2 {
    let l1 = abs(dir.x) + abs(dir.y) + abs(dir.z);
    // NaN fails `l1 > 0` too.
    if l1 > 0.0 {
        octahedral_fold(Vec2::new(dir.x, dir.y) / l1, dir.z)
    } else {
        Vec2::ZERO
    }
}

/// Folds the projection `p` of a direction with height `z` onto the square.
#[inline]
fn octahedral_fold(p: Vec2, z: f32) -> Vec2 {
    if z < 0.0 {
        Vec2::new(
            (1.0 - abs(p.y)) * sign_not_zero(p.x),
            (1.0 - abs(p.x)) * sign_not_zero(p.y),
        )
    } else {
        p
    }
}

/// Inverse of [`octahedral_encode`] (Stubbe's branch-free unfold).
#[inline]
pub fn octahedral_decode(e: Vec2) -> Vec3 {
    let e = clamp_to_square(e);
    let z = 1.0 - abs(e.x) - abs(e.y);
    let t = if z < 0.0 { -z } else { 0.0 };
    let x = if e.x >= 0.0 { e.x - t } else { e.x + t };
    let y = if e.y >= 0.0 { e.y - t } else { e.y + t };
    Vec3::new(x, y, z).normalize()
}

/// Hemi-octahedral map of the +z hemisphere onto `[-1, 1]²` (the octahedron's upper half rotated 45°
/// to fill the square). Directions below the horizon are mirrored (`z → |z|`); zero/NaN give +z.
#[inline]
pub fn hemi_octahedral_encode(dir: Vec3) -> Vec2 {
    let l1 = abs(dir.x) + abs(dir.y) + abs(dir.z);
    if l1 > 0.0 {
        let p = Vec2::new(dir.x, dir.y) / l1;
        Vec2::new(p.x + p.y, p.x - p.y)
    } else {
        Vec2::ZERO
    }
}

/// Inverse of [`hemi_octahedral_encode`]; always returns `z ≥ 0`.
#[inline]
pub fn hemi_octahedral_decode(e: Vec2) -> Vec3 {
    let e = clamp_to_square(e);
    let t = Vec2::new(e.x + e.y, e.x - e.y) * 0.5;
    Vec3::new(t.x, t.y, 1.0 - abs(t.x) - abs(t.y)).normalize()
}

/// Equal-area map of the +z hemisphere onto `[-1, 1]²` (Clarberg's map, rotated 45° as in
/// GI-1.0 v1.2): equal areas of the square cover equal solid angles, so every probe cell sees
/// `2π / N²` steradians. Directions below the horizon are mirrored (`z → |z|`).
#[inline]
pub fn equal_area_hemi_encode(dir: Vec3) -> Vec2 {
    let ax = abs(dir.x);
    let ay = abs(dir.y);
    // sqrt(1 - |z|) rewritten as sqrt((x² + y²) / (1 + |z|)): no cancellation near the pole.
    let radius = min(safe_sqrt((ax * ax + ay * ay) / (1.0 + abs(dir.z))), 1.0);
    let a = if ax > ay { ax } else { ay };
    let b = if ax > ay { ay } else { ax };
    let ratio = if a > 0.0 { b / a } else { 0.0 };
    let phi = atan(ratio) * FRAC_2_PI;
    let phi = if ax >= ay { phi } else { 1.0 - phi };
    let t = phi * radius;
    let s = radius - t;
    let st = Vec2::new(s * sign_not_zero(dir.x), t * sign_not_zero(dir.y));
    Vec2::new(st.x + st.y, st.x - st.y)
}

/// Inverse of [`equal_area_hemi_encode`]; always returns a unit vector with `z ≥ 0`.
#[inline]
pub fn equal_area_hemi_decode(e: Vec2) -> Vec3 {
    let e = clamp_to_square(e);
    let st = Vec2::new(e.x + e.y, e.x - e.y) * 0.5;
    let a = abs(st.x);
    let b = abs(st.y);
    // Inside the diamond |a| + |b| ≤ 1, so the radius is a + b.
    let radius = min(a + b, 1.0);
    let phi = if radius > 0.0 {
        FRAC_PI_4 * ((b - a) / radius + 1.0)
    } else {
        0.0
    };
    let r2 = radius * radius;
    let sin_theta = radius * safe_sqrt(2.0 - r2);
    Vec3::new(
        sin_theta * sign_not_zero(st.x) * cos(phi),
        sin_theta * sign_not_zero(st.y) * sin(phi),
        1.0 - r2,
    )
}

/// Centre of cell `cell` of an `n × n` map in `[0, 1]²`: `(cell + 0.5) / n` (`n = 0` acts as 1).
#[inline]
pub fn cell_center_uv(cell: UVec2, n: u32) -> Vec2 {
    let n = if n > 0 { n } else { 1 };
    (cell.as_vec2() + 0.5) / n as f32
}

/// Cell of an `n × n` map containing `uv ∈ [0, 1]²`; outside points and NaN clamp to the border.
#[inline]
pub fn uv_to_cell(uv: Vec2, n: u32) -> UVec2 {
    let last = if n > 0 { n - 1 } else { 0 };
    let scaled = uv * n as f32;
    UVec2::new(
        min_u32(to_u32_clamped(scaled.x), last),
        min_u32(to_u32_clamped(scaled.y), last),
    )
}

/// Direction (tangent space, +z = normal) through the centre of screen-probe cell `cell` of an
/// `n × n` probe, with the equal-area hemisphere map.
#[inline]
pub fn probe_cell_direction(cell: UVec2, n: u32) -> Vec3 {
    equal_area_hemi_decode(cell_center_uv(cell, n) * 2.0 - 1.0)
}

/// Screen-probe cell of an `n × n` probe that a tangent-space direction falls into.
#[inline]
pub fn probe_direction_cell(dir: Vec3, n: u32) -> UVec2 {
    uv_to_cell(equal_area_hemi_encode(dir) * 0.5 + 0.5, n)
}

/// Direction through the centre of cell `cell` of an `n × n` full-sphere octahedral map.
#[inline]
pub fn sphere_cell_direction(cell: UVec2, n: u32) -> Vec3 {
    octahedral_decode(cell_center_uv(cell, n) * 2.0 - 1.0)
}

/// Cell of an `n × n` full-sphere octahedral map that a direction falls into.
#[inline]
pub fn sphere_direction_cell(dir: Vec3, n: u32) -> UVec2 {
    uv_to_cell(octahedral_encode(dir) * 0.5 + 0.5, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Angle between two vectors, in f64 so the measurement adds no error of its own.
    fn angle(a: Vec3, b: Vec3) -> f64 {
        let a = a.as_dvec3().normalize();
        let b = b.as_dvec3().normalize();
        a.cross(b).length().atan2(a.dot(b))
    }

    /// 10⁶ Fibonacci-sphere directions plus poles, seams, diagonals and signed zeros.
    fn directions() -> Vec<Vec3> {
        let n = 1_000_000;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let mut v: Vec<Vec3> = (0..n)
            .map(|i| {
                let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i as f64;
                glam::DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3()
            })
            .collect();
        let s = std::f32::consts::FRAC_1_SQRT_2;
        for x in [-1.0, -s, -0.0, 0.0, s, 1.0] {
            for y in [-1.0, -s, -0.0, 0.0, s, 1.0] {
                for z in [-1.0, -s, -0.0, 0.0, s, 1.0] {
                    let d = Vec3::new(x, y, z);
                    if d.length() > 0.0 {
                        v.push(d.normalize());
                    }
                }
            }
        }
        // Near-pole and near-horizon directions where cancellation would hurt.
        for k in 1..30 {
            let e = 2f32.powi(-k);
            v.push(Vec3::new(e, 0.3 * e, 1.0).normalize());
            v.push(Vec3::new(-e, e, -1.0).normalize());
            v.push(Vec3::new(1.0, -0.7, e).normalize());
            v.push(Vec3::new(0.2, 1.0, -e).normalize());
        }
        v
    }

    fn worst_round_trip(
        dirs: &[Vec3],
        hemisphere: bool,
        enc: fn(Vec3) -> Vec2,
        dec: fn(Vec2) -> Vec3,
    ) -> f64 {
        let mut worst = 0.0f64;
        for &d in dirs {
            let d = if hemisphere { d.with_z(d.z.abs()) } else { d };
            let e = enc(d);
            assert!(e.x.abs() <= 1.0 && e.y.abs() <= 1.0, "{d} -> {e}");
            let r = dec(e);
            assert!((r.length() - 1.0).abs() < 1e-6, "{d} -> {r}");
            worst = worst.max(angle(d, r));
        }
        worst
    }

    #[test]
    fn octahedral_round_trip() {
        let w = worst_round_trip(&directions(), false, octahedral_encode, octahedral_decode);
        assert!(w <= OCTAHEDRAL_MAX_ERROR as f64, "{w}");
    }

    #[test]
    fn hemi_octahedral_round_trip() {
        let w = worst_round_trip(
            &directions(),
            true,
            hemi_octahedral_encode,
            hemi_octahedral_decode,
        );
        assert!(w <= HEMI_OCTAHEDRAL_MAX_ERROR as f64, "{w}");
    }

    #[test]
    fn equal_area_round_trip() {
        let w = worst_round_trip(
            &directions(),
            true,
            equal_area_hemi_encode,
            equal_area_hemi_decode,
        );
        assert!(w <= EQUAL_AREA_MAX_ERROR as f64, "{w}");
    }

    #[test]
    fn special_points() {
        assert_eq!(octahedral_encode(Vec3::Z), Vec2::ZERO);
        assert_eq!(octahedral_encode(-Vec3::Z).abs(), Vec2::ONE);
        assert_eq!(octahedral_decode(Vec2::ONE), -Vec3::Z);
        assert_eq!(octahedral_decode(Vec2::new(-1.0, 1.0)), -Vec3::Z);
        assert_eq!(octahedral_encode(Vec3::ZERO), Vec2::ZERO);
        assert_eq!(octahedral_encode(Vec3::NAN), Vec2::ZERO);
        assert_eq!(equal_area_hemi_encode(Vec3::Z), Vec2::ZERO);
        assert_eq!(equal_area_hemi_decode(Vec2::ZERO), Vec3::Z);
        assert_eq!(hemi_octahedral_decode(Vec2::ZERO), Vec3::Z);
        // Corners of the hemi maps lie on the horizon.
        for c in [
            Vec2::ONE,
            -Vec2::ONE,
            Vec2::new(1.0, -1.0),
            Vec2::new(-1.0, 1.0),
        ] {
            assert!(equal_area_hemi_decode(c).z.abs() < 1e-6);
            assert!(hemi_octahedral_decode(c).z.abs() < 1e-6);
        }
        // Out-of-square inputs clamp instead of producing NaN.
        assert!(octahedral_decode(Vec2::splat(7.0)).is_finite());
        assert!(equal_area_hemi_decode(Vec2::new(-3.0, 9.0)).is_finite());
        // Mirrored lower hemisphere.
        let d = Vec3::new(0.3, -0.4, -0.866).normalize();
        assert_eq!(
            equal_area_hemi_encode(d),
            equal_area_hemi_encode(d.with_z(-d.z))
        );
    }

    #[test]
    fn cells_round_trip() {
        for n in 1..=32 {
            for j in 0..n {
                for i in 0..n {
                    let c = UVec2::new(i, j);
                    assert_eq!(probe_direction_cell(probe_cell_direction(c, n), n), c);
                    assert_eq!(sphere_direction_cell(sphere_cell_direction(c, n), n), c);
                    assert!(probe_cell_direction(c, n).z >= 0.0);
                }
            }
        }
        assert_eq!(uv_to_cell(Vec2::new(f32::NAN, 2.0), 8), UVec2::new(0, 7));
        assert_eq!(
            cell_center_uv(UVec2::new(3, 0), 8),
            Vec2::new(0.4375, 0.0625)
        );
    }

    #[test]
    fn equal_area_cells_get_equal_sample_counts() {
        // Uniform hemisphere directions must fill the 8×8 probe cells evenly (χ², 63 dof, p = 0.001).
        let mut rng = crate::random::Random::new(7, 1);
        let mut counts = [0u32; 64];
        let n = 640_000;
        for _ in 0..n {
            let u = rng.next_vec2();
            let z = u.x;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            let c = probe_direction_cell(Vec3::new(r * phi.cos(), r * phi.sin(), z), 8);
            counts[(c.x + 8 * c.y) as usize] += 1;
        }
        let expected = n as f64 / 64.0;
        let chi2: f64 = counts
            .iter()
            .map(|&c| (c as f64 - expected).powi(2) / expected)
            .sum();
        assert!(chi2 < 103.4, "chi2 = {chi2}");
    }
}
