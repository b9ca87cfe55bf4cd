//! Monte Carlo sampling: tangent frames, hemisphere/sphere/triangle sampling and pdf conversion.

use glam::{Vec2, Vec3};

use crate::math::{INV_PI, PI, abs, copysign, cos, max, safe_sqrt, sin, sqrt};

/// Orthonormal basis `(t, b)` with `t × b = n` for a unit `n`, branch-free
/// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"). Continuous except across
/// `n.z = ±0`, where it flips with the sign bit.
#[inline]
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = copysign(1.0, n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Rotates a tangent-space vector (+z = `n`) into the frame of [`orthonormal_basis`]`(n)`.
#[inline]
pub fn tangent_to_world(v: Vec3, n: Vec3) -> Vec3 {
    let (t, b) = orthonormal_basis(n);
    t * v.x + b * v.y + n * v.z
}

/// Rotates a world vector into the tangent space of [`orthonormal_basis`]`(n)`.
#[inline]
pub fn world_to_tangent(v: Vec3, n: Vec3) -> Vec3 {
    let (t, b) = orthonormal_basis(n);
    Vec3::new(v.dot(t), v.dot(b), v.dot(n))
}

/// Cosine-weighted direction on the +z hemisphere from `u ∈ [0, 1)²` (Malley's method).
#[inline]
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * cos(phi), r * sin(phi), safe_sqrt(1.0 - u.x))
}

/// Solid-angle pdf of [`sample_cosine_hemisphere`]: `cos θ / π`, 0 below the horizon.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    max(cos_theta, 0.0) * INV_PI
}

/// Uniform direction on the unit sphere from `u ∈ [0, 1)²`.
#[inline]
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = safe_sqrt(1.0 - z * z);
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * cos(phi), r * sin(phi), z)
}

/// Solid-angle pdf of [`sample_uniform_sphere`]: `1 / 4π`.
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform barycentrics `(b0, b1, b2)` on a triangle from `u ∈ [0, 1)²`
/// (`b0 = 1 − √u₀`, `b1 = u₁ √u₀`); the area pdf is `1 / area`.
#[inline]
pub fn sample_triangle(u: Vec2) -> Vec3 {
    let s = sqrt(u.x);
    let b0 = 1.0 - s;
    let b1 = u.y * s;
    Vec3::new(b0, b1, 1.0 - b0 - b1)
}

/// Converts an area pdf to a solid-angle pdf: `pdf_area · d² / |cos θ_light|`.
///
/// A grazing sample (`cos θ = 0`) has an infinite solid-angle density; it returns 0 instead, which
/// callers treat as "invalid sample, zero contribution". NaN inputs also give 0.
#[inline]
pub fn area_to_solid_angle_pdf(pdf_area: f32, distance_squared: f32, cos_theta: f32) -> f32 {
    let c = abs(cos_theta);
    let pdf = pdf_area * distance_squared / c;
    // `c > 0` rejects 0 and NaN; the finiteness check catches overflow and NaN in the others.
    if c > 0.0 && pdf.is_finite() && pdf >= 0.0 {
        pdf
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Random;

    #[test]
    fn basis_is_orthonormal() {
        let mut rng = Random::new(3, 0);
        let mut normals: Vec<Vec3> = (0..100_000)
            .map(|_| sample_uniform_sphere(rng.next_vec2()))
            .collect();
        normals.extend([
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(-0.0, -0.0, -1.0),
            Vec3::new(1.0, 0.0, -0.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(1e-7, 0.0, -1.0).normalize(),
        ]);
        for n in normals {
            let (t, b) = orthonormal_basis(n);
            assert!((t.length() - 1.0).abs() < 1e-5, "{n}");
            assert!((b.length() - 1.0).abs() < 1e-5, "{n}");
            assert!(t.dot(b).abs() < 1e-5 && t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5);
            assert!((t.cross(b) - n).length() < 1e-5, "right-handed for {n}");
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!((world_to_tangent(tangent_to_world(v, n), n) - v).length() < 1e-5);
        }
    }

    #[test]
    fn cosine_samples_have_the_right_mean() {
        // E[cos θ] under p = cos θ/π is 2/3; every sample lies on the upper unit hemisphere.
        let mut rng = Random::new(11, 0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let d = sample_cosine_hemisphere(rng.next_vec2());
            assert!(d.z >= 0.0 && (d.length() - 1.0).abs() < 1e-5);
            sum += d.z as f64;
        }
        assert!((sum / n as f64 - 2.0 / 3.0).abs() < 3e-3);
        assert_eq!(cosine_hemisphere_pdf(1.0), INV_PI);
        assert_eq!(cosine_hemisphere_pdf(-0.5), 0.0);
    }

    #[test]
    fn sphere_samples_estimate_the_sphere_area() {
        // ∫ z² dω = 4π/3, estimated with the uniform-sphere pdf.
        let mut rng = Random::new(12, 0);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let d = sample_uniform_sphere(rng.next_vec2());
            assert!((d.length() - 1.0).abs() < 1e-5);
            sum += (d.z * d.z / UNIFORM_SPHERE_PDF) as f64;
        }
        let est = sum / n as f64;
        let exact = 4.0 * std::f64::consts::PI / 3.0;
        assert!((est - exact).abs() / exact < 1e-2, "{est}");
    }

    #[test]
    fn triangle_samples_are_uniform() {
        // Barycentrics are valid and each has mean 1/3; the fraction with b0 > 1/2 is 1/4.
        let mut rng = Random::new(13, 0);
        let n = 200_000;
        let mut mean = Vec3::ZERO.as_dvec3();
        let mut corner = 0u32;
        for _ in 0..n {
            let b = sample_triangle(rng.next_vec2());
            assert!(b.min_element() >= -1e-6 && (b.element_sum() - 1.0).abs() < 1e-6);
            mean += b.as_dvec3();
            corner += u32::from(b.x > 0.5);
        }
        mean /= n as f64;
        assert!((mean - glam::DVec3::splat(1.0 / 3.0)).abs().max_element() < 3e-3);
        assert!((corner as f64 / n as f64 - 0.25).abs() < 3e-3);
    }

    #[test]
    fn area_pdf_conversion() {
        assert_eq!(area_to_solid_angle_pdf(0.5, 4.0, 0.5), 4.0);
        assert_eq!(area_to_solid_angle_pdf(0.5, 4.0, -0.5), 4.0);
        assert_eq!(area_to_solid_angle_pdf(0.5, 4.0, 0.0), 0.0);
        assert_eq!(area_to_solid_angle_pdf(0.5, 4.0, -0.0), 0.0);
        assert_eq!(area_to_solid_angle_pdf(0.5, 4.0, f32::NAN), 0.0);
        assert_eq!(area_to_solid_angle_pdf(f32::NAN, 4.0, 1.0), 0.0);
        assert_eq!(area_to_solid_angle_pdf(1e30, 1e30, 1.0), 0.0);
    }
}
