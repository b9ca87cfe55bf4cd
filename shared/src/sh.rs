//! Order-2 (9-coefficient) real spherical harmonics: screen-probe radiance is projected onto them
//! and per-pixel irradiance is read back with the cosine lobe convolved in (Ramamoorthi & Hanrahan
//! 2001, "An Efficient Representation for Irradiance Environment Maps").

use glam::Vec3;

use crate::math::PI;

/// Number of coefficients of an order-2 expansion.
pub const SH_COEFFICIENT_COUNT: usize = 9;
/// Clamped-cosine convolution weight of band 0: π.
pub const SH_A0: f32 = PI;
/// Clamped-cosine convolution weight of band 1: 2π/3.
pub const SH_A1: f32 = 2.0 * PI / 3.0;
/// Clamped-cosine convolution weight of band 2: π/4.
pub const SH_A2: f32 = PI / 4.0;

/// Convolution weight per coefficient (band of each index).
const BAND_WEIGHTS: [f32; SH_COEFFICIENT_COUNT] = [
    SH_A0, SH_A1, SH_A1, SH_A1, SH_A2, SH_A2, SH_A2, SH_A2, SH_A2,
];

/// The nine real SH basis functions at unit `dir`, ordered `(l, m)` = (0,0), (1,−1), (1,0), (1,1),
/// (2,−2), (2,−1), (2,0), (2,1), (2,2).
#[inline]
pub fn sh9_basis(dir: Vec3) -> [f32; SH_COEFFICIENT_COUNT] {
    let (x, y, z) = (dir.x, dir.y, dir.z);
    [
        0.282_094_8,
        0.488_602_5 * y,
        0.488_602_5 * z,
        0.488_602_5 * x,
        1.092_548_4 * x * y,
        1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z * z - 1.0),
        1.092_548_4 * x * z,
        0.546_274_2 * (x * x - y * y),
    ]
}

/// RGB radiance expanded in order-2 SH.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShL2Rgb {
    /// Coefficients in the order of [`sh9_basis`].
    pub coefficients: [Vec3; SH_COEFFICIENT_COUNT],
}

impl Default for ShL2Rgb {
    fn default() -> Self {
        Self::ZERO
    }
}

impl ShL2Rgb {
    /// All coefficients zero.
    pub const ZERO: Self = Self {
        coefficients: [Vec3::ZERO; SH_COEFFICIENT_COUNT],
    };

    /// Projection step: adds `radiance · Y(dir) · weight`, where `weight` is the sample's solid angle
    /// (or `1 / (pdf · sample count)` for Monte Carlo samples).
    #[inline]
    pub fn add_sample(&mut self, dir: Vec3, radiance: Vec3, weight: f32) {
        let basis = sh9_basis(dir);
        let mut i = 0;
        while i < SH_COEFFICIENT_COUNT {
            self.coefficients[i] += radiance * (basis[i] * weight);
            i += 1;
        }
    }

    /// Band-limited radiance towards `dir`.
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let basis = sh9_basis(dir);
        let mut sum = Vec3::ZERO;
        let mut i = 0;
        while i < SH_COEFFICIENT_COUNT {
            sum += self.coefficients[i] * basis[i];
            i += 1;
        }
        sum
    }

    /// Irradiance `∫ L(ω) max(n·ω, 0) dω` at a surface with unit normal `normal`, from the
    /// band-limited radiance. For radiance `max(ω·a, 0)` the result is within 0.0164 (0.79 % of the
    /// peak 2π/3) of the exact convolution; order 2 cannot do better.
    #[inline]
    pub fn irradiance(&self, normal: Vec3) -> Vec3 {
        self.integrate(&ShLobe::cosine(normal))
    }

    /// The radiance integrated against `lobe`: `Σ coefficient × weight`.
    #[inline]
    pub fn integrate(&self, lobe: &ShLobe) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let mut i = 0;
        while i < SH_COEFFICIENT_COUNT {
            sum += self.coefficients[i] * lobe.weights[i];
            i += 1;
        }
        sum
    }
}

/// A lobe SH radiance is integrated against ([`ShL2Rgb::integrate`]): its band weights times
/// the basis at its axis, made once and applied to every SH that is read through it (the up to
/// four probes of a pixel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShLobe {
    /// One weight per coefficient, in the order of [`sh9_basis`].
    pub weights: [f32; SH_COEFFICIENT_COUNT],
}

impl ShLobe {
    /// The clamped cosine around unit `normal`: [`ShL2Rgb::irradiance`].
    #[inline]
    pub fn cosine(normal: Vec3) -> Self {
        let basis = sh9_basis(normal);
        let mut weights = [0.0; SH_COEFFICIENT_COUNT];
        let mut i = 0;
        while i < SH_COEFFICIENT_COUNT {
            weights[i] = BAND_WEIGHTS[i] * basis[i];
            i += 1;
        }
        Self { weights }
    }

    /// The clamped cosine around unit `axis` limited to a cone whose half-angle has cosine
    /// `cos_half_angle` (in `[0, 1]`; [`cone_weights`]), times `scale`: `∫_cone L(ω) max(axis·ω,
    /// 0) dω`. A cosine of 0 and a scale of 1 is [`Self::cosine`]; screen-space GI's occlusion
    /// reads the probes through it (`crate::screen_space_gi`).
    #[inline]
    pub fn cone(axis: Vec3, cos_half_angle: f32, scale: f32) -> Self {
        let [a0, a1, a2] = cone_weights(cos_half_angle);
        let bands = [a0 * scale, a1 * scale, a2 * scale];
        let basis = sh9_basis(axis);
        let mut weights = [0.0; SH_COEFFICIENT_COUNT];
        let mut i = 0;
        while i < SH_COEFFICIENT_COUNT {
            let band = if i == 0 {
                bands[0]
            } else if i < 4 {
                bands[1]
            } else {
                bands[2]
            };
            weights[i] = band * basis[i];
            i += 1;
        }
        Self { weights }
    }
}

/// The band weights of the clamped cosine limited to a cone whose half-angle has cosine `c`
/// (clamped to `[0, 1]`), `2π ∫_c^1 t P_l(t) dt`: `π (1 − c²)`, `2π (1 − c³) / 3` and
/// `π (1/4 + c²/2 − 3c⁴/4)`; at `c = 0` the full lobe's [`SH_A0`], [`SH_A1`], [`SH_A2`].
#[inline]
pub fn cone_weights(c: f32) -> [f32; 3] {
    let c = c.clamp(0.0, 1.0);
    let c2 = c * c;
    [
        PI * (1.0 - c2),
        2.0 * PI * (1.0 - c2 * c) / 3.0,
        PI * (0.25 + 0.5 * c2 - 0.75 * c2 * c2),
    ]
}

/// The factor that makes [`ShLobe::cone`] exact for a probe's radiance of 1 over its
/// hemisphere (and 0 below), read through a cone of cosine `cos_half_angle` around an axis at
/// `cos_axis` from the hemisphere's normal. Order 2 cannot hold the hemisphere's edge: its
/// projection, `1/2 + (3/4) cos θ`, reads 1.25 at the pole. The full cosine lobe cancels that
/// (its irradiance, `A0/2 + (3/4) A1`, is exactly π), a narrow cone does not: it would read up
/// to a quarter too bright. The factor is the cone's exact answer, `A0` (the cone inside the
/// hemisphere), over the projection's, `A0/2 + (3/4) A1 cos_axis`; 1 where that is not positive.
#[inline]
pub fn hemisphere_cone_scale(cos_half_angle: f32, cos_axis: f32) -> f32 {
    let [a0, a1, _] = cone_weights(cos_half_angle);
    let projected = 0.5 * a0 + 0.75 * a1 * cos_axis;
    if projected > 0.0 && a0 > 0.0 {
        a0 / projected
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Random;
    use crate::sampling::sample_uniform_sphere;

    /// Projects `radiance(ω)` with a product rule: midpoints in z (uniform in z is uniform in solid
    /// angle) split at the equator, times uniform φ, which integrates these bands exactly in φ.
    /// Rows are projected with `add_sample` and summed in f64 so f32 accumulation error stays out.
    fn project(radiance: impl Fn(Vec3) -> Vec3) -> ShL2Rgb {
        let (nz, nphi) = (2000, 16);
        let weight = 4.0 * PI / (nz * nphi) as f32;
        let mut total = [glam::DVec3::ZERO; SH_COEFFICIENT_COUNT];
        for i in 0..nz {
            let z = -1.0 + 2.0 * (i as f64 + 0.5) / nz as f64;
            let r = (1.0 - z * z).sqrt();
            let mut row = ShL2Rgb::ZERO;
            for j in 0..nphi {
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / nphi as f64;
                let d = glam::DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3();
                row.add_sample(d, radiance(d), weight);
            }
            for (t, c) in total.iter_mut().zip(row.coefficients) {
                *t += c.as_dvec3();
            }
        }
        ShL2Rgb {
            coefficients: total.map(|t| t.as_vec3()),
        }
    }

    fn normals() -> Vec<Vec3> {
        let mut rng = Random::new(8, 0);
        let mut v: Vec<Vec3> = (0..2000)
            .map(|_| sample_uniform_sphere(rng.next_vec2()))
            .collect();
        v.extend([Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]);
        v
    }

    #[test]
    fn the_cone_lobe_integrates_band_limited_radiance_over_the_cone() {
        // A radiance within order 2 is projected exactly, so the cone's band weights must give
        // its cone integral to rounding, for any axis and half-angle.
        let a = Vec3::new(0.3, 0.5, 0.8).normalize();
        let radiance = |w: Vec3| {
            let l = 1.0 + 0.5 * w.dot(a) + 0.3 * w.x * w.y - 0.2 * (w.z * w.z - 0.3);
            Vec3::new(l, 2.0 * l, 0.5 * l)
        };
        let sh = project(radiance);
        for axis in [Vec3::Z, Vec3::new(0.6, -0.48, 0.64), -Vec3::X] {
            let (t, b) = axis.any_orthonormal_pair();
            for c in [0.0f32, 0.3, 0.7, 0.95] {
                // Midpoints in cos θ from c to 1 (uniform in solid angle) times uniform φ.
                let (nt, nphi) = (400, 64);
                let mut exact = glam::DVec3::ZERO;
                for i in 0..nt {
                    let z = c as f64 + (1.0 - c as f64) * (i as f64 + 0.5) / nt as f64;
                    let r = (1.0 - z * z).sqrt();
                    for j in 0..nphi {
                        let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / nphi as f64;
                        let w = (t * (r * phi.cos()) as f32)
                            + (b * (r * phi.sin()) as f32)
                            + axis * z as f32;
                        let d_omega =
                            (1.0 - c as f64) * 2.0 * std::f64::consts::PI / (nt * nphi) as f64;
                        exact += radiance(w).as_dvec3() * (z * d_omega);
                    }
                }
                let got = sh.integrate(&ShLobe::cone(axis, c, 1.0)).as_dvec3();
                assert!(
                    (got - exact).abs().max_element() < 2e-3 * exact.abs().max_element(),
                    "axis {axis} c {c}: {got} vs {exact}"
                );
            }
            assert_eq!(
                sh.integrate(&ShLobe::cone(axis, 0.0, 1.0)),
                sh.irradiance(axis)
            );
            assert_eq!(cone_weights(0.0), [SH_A0, SH_A1, SH_A2]);
            assert_eq!(sh.integrate(&ShLobe::cone(axis, 1.0, 1.0)), Vec3::ZERO);
        }
    }

    #[test]
    fn the_hemisphere_scale_makes_a_uniform_hemisphere_exact_through_any_cone() {
        // A probe that sees radiance 1 over its hemisphere around +z, projected as the probes
        // are (nothing below): through a cone inside the hemisphere the irradiance must be the
        // cone's cosine-weighted solid angle, π (1 − c²).
        let sh = project(|w| Vec3::splat(if w.z > 0.0 { 1.0 } else { 0.0 }));
        for (axis, c) in [
            (Vec3::Z, 0.9f32),
            (Vec3::Z, 0.5),
            (Vec3::new(0.3, 0.0, 0.954).normalize(), 0.8),
            (Vec3::new(0.0, -0.5, 0.866).normalize(), 0.9),
        ] {
            let exact = PI * (1.0 - c * c);
            let raw = sh.integrate(&ShLobe::cone(axis, c, 1.0)).x;
            let scaled = sh
                .integrate(&ShLobe::cone(axis, c, hemisphere_cone_scale(c, axis.z)))
                .x;
            assert!(
                (scaled - exact).abs() < 2e-3 * exact,
                "{axis} {c}: {scaled} vs {exact}"
            );
            // Unscaled, the projection's overshoot at the pole shows.
            assert!(raw > 1.05 * exact, "{axis} {c}: {raw} vs {exact}");
        }
        // The full lobe needs no scale.
        assert!((hemisphere_cone_scale(0.0, 1.0) - 1.0).abs() < 1e-6);
        assert_eq!(hemisphere_cone_scale(0.5, -1.0), 1.0);
    }

    #[test]
    fn basis_is_orthonormal() {
        // Monte Carlo Gram matrix with 10^6 uniform directions.
        let mut rng = Random::new(4, 0);
        let n = 1_000_000;
        let mut gram = [[0.0f64; 9]; 9];
        for _ in 0..n {
            let y = sh9_basis(sample_uniform_sphere(rng.next_vec2()));
            for i in 0..9 {
                for j in 0..9 {
                    gram[i][j] += (y[i] * y[j]) as f64;
                }
            }
        }
        for (i, row) in gram.iter().enumerate() {
            for (j, &g) in row.iter().enumerate() {
                let g = g * 4.0 * std::f64::consts::PI / n as f64;
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((g - expected).abs() < 0.02, "({i},{j}) = {g}");
            }
        }
    }

    #[test]
    fn constant_radiance_gives_pi_l_irradiance() {
        let l = Vec3::new(1.0, 0.5, 2.0);
        let sh = project(|_| l);
        for n in normals() {
            let e = sh.irradiance(n);
            let rel = ((e - PI * l) / (PI * l)).abs().max_element();
            assert!(rel < 1e-4, "{n}: {e}");
            assert!(((sh.radiance(n) - l) / l).abs().max_element() < 1e-4);
        }
    }

    #[test]
    fn clamped_cosine_lobe_matches_the_analytic_convolution() {
        // Radiance max(ω·z, 0). Exact irradiance at angle γ from z: (2/3)((π − γ) cos γ + sin γ).
        let sh = project(|d| Vec3::splat(d.z.max(0.0)));
        for n in normals() {
            let c = n.z.clamp(-1.0, 1.0) as f64;
            let g = c.acos();
            let pi = std::f64::consts::PI;
            let exact = (2.0 / 3.0) * ((pi - g) * c + g.sin());
            // Its order-2 truncation Σ_l A_l L_l Y_l0(n), L_l = 2π ∫₀¹ t Y_l0(t) dt, c = cos γ.
            let truncated = pi / 4.0 + pi / 3.0 * c + 5.0 * pi / 128.0 * (3.0 * c * c - 1.0);
            let e = sh.irradiance(n);
            assert!(
                (e.x as f64 - truncated).abs() < 1e-4 * 2.1,
                "{n}: {e} vs {truncated}"
            );
            assert!((e.x as f64 - exact).abs() < 0.0165, "{n}: {e} vs {exact}");
            assert_eq!(e.x, e.y);
        }
    }
}
