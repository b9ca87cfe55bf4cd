//! The equirectangular environment image: its mapping between directions and texels, and its
//! importance sampling by a piecewise-constant 2D distribution (a marginal distribution over rows,
//! a conditional one over the texels of each row), as in PBRT's `PiecewiseConstant2D`.
//!
//! # Mapping
//!
//! glTF's frame (+Y up): row 0 is straight up, the middle column looks along −Z, `u` grows toward
//! +X. A direction's texel is the one whose `[u, u + 1/w) × [v, v + 1/h)` holds
//! `u = 1/2 + atan2(x, −z) / 2π`, `v = acos(y) / π` (nearest texel, no filtering).
//!
//! # Distribution buffer
//!
//! `[f32]` of `(h + 1) + h · (w + 1)` entries: the marginal CDF over rows (`cdf[0] = 0`,
//! `cdf[h] = 1`), then for each row `y` its conditional CDF over columns at `(h + 1) + y · (w + 1)`.
//! The host builds it with weights `luminance × sin θ` (the texel's solid angle), so sampling
//! follows the radiance the image sends. A texel is sampled uniformly in `(u, v)`, which gives
//! the solid-angle density `p(texel) · w · h / (2π² sin θ)`.

use glam::{UVec2, Vec2, Vec3};

use crate::math::{
    INV_PI, PI, acos, atan2, clamp, cos, min_u32, positive_or_zero, sin, sqrt, to_u32_clamped,
};

/// Length of the distribution buffer of a `width × height` image.
pub const fn distribution_len(width: u32, height: u32) -> usize {
    (height as usize + 1) + height as usize * (width as usize + 1)
}

/// `(u, v)` in `[0, 1]²` of a unit direction.
#[inline]
pub fn direction_to_uv(direction: Vec3) -> Vec2 {
    Vec2::new(
        0.5 + atan2(direction.x, -direction.z) * (0.5 * INV_PI),
        acos(clamp(direction.y, -1.0, 1.0)) * INV_PI,
    )
}

/// The unit direction of `(u, v)` (inverse of [`direction_to_uv`]).
#[inline]
pub fn uv_to_direction(uv: Vec2) -> Vec3 {
    let phi = (uv.x - 0.5) * (2.0 * PI);
    let theta = uv.y * PI;
    let s = sin(theta);
    Vec3::new(s * sin(phi), cos(theta), -s * cos(phi))
}

/// The texel `(x, y)` that a unit direction sees in a `size` image.
#[inline]
pub fn texel_of(size: UVec2, direction: Vec3) -> UVec2 {
    let uv = direction_to_uv(direction);
    UVec2::new(
        min_u32(to_u32_clamped(uv.x * size.x as f32), size.x - 1),
        min_u32(to_u32_clamped(uv.y * size.y as f32), size.y - 1),
    )
}

/// Index of the bin of `cdf[first .. first + n + 1]` that holds `u`: the last `i < n` with
/// `cdf[first + i] <= u`, so that a bin of zero width is never chosen when `u < 1`.
#[inline]
fn find_bin(cdf: &[f32], first: usize, n: u32, u: f32) -> u32 {
    let mut lo = 0u32;
    let mut hi = n;
    while lo + 1 < hi {
        let mid = (lo + hi) / 2;
        let i = first + mid as usize;
        if i < cdf.len() && cdf[i] <= u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// `cdf[i + 1] − cdf[i]`, 0 out of range.
#[inline]
fn bin_mass(cdf: &[f32], i: usize) -> f32 {
    if i + 1 < cdf.len() {
        cdf[i + 1] - cdf[i]
    } else {
        0.0
    }
}

/// A direction drawn from the environment's distribution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentSample {
    /// Unit direction toward the environment.
    pub direction: Vec3,
    /// Its solid-angle density (0 when the sample is unusable: an empty distribution, a pole).
    pub pdf: f32,
}

/// Draws a direction from the distribution `cdf` of a `size` image (`u` uniform in `[0, 1)²`).
pub fn sample_environment(size: UVec2, cdf: &[f32], u: Vec2) -> EnvironmentSample {
    let none = EnvironmentSample {
        direction: Vec3::Y,
        pdf: 0.0,
    };
    if size.x == 0 || size.y == 0 || cdf.len() < distribution_len(size.x, size.y) {
        return none;
    }
    let y = find_bin(cdf, 0, size.y, u.y);
    let row_first = (size.y as usize + 1) + y as usize * (size.x as usize + 1);
    let x = find_bin(cdf, row_first, size.x, u.x);
    let p_row = bin_mass(cdf, y as usize);
    let p_col = bin_mass(cdf, row_first + x as usize);
    if !(p_row > 0.0 && p_col > 0.0) {
        return none;
    }
    // Where u falls inside the chosen bins, remapped to the texel: uniform within it.
    let fy = (u.y - cdf[y as usize]) / p_row;
    let fx = (u.x - cdf[row_first + x as usize]) / p_col;
    let uv = Vec2::new(
        (x as f32 + clamp(fx, 0.0, 1.0)) / size.x as f32,
        (y as f32 + clamp(fy, 0.0, 1.0)) / size.y as f32,
    );
    let direction = uv_to_direction(uv);
    EnvironmentSample {
        direction,
        pdf: texel_density(size, p_row * p_col, direction),
    }
}

/// Solid-angle density with which [`sample_environment`] draws the unit `direction`.
pub fn environment_pdf(size: UVec2, cdf: &[f32], direction: Vec3) -> f32 {
    if size.x == 0 || size.y == 0 || cdf.len() < distribution_len(size.x, size.y) {
        return 0.0;
    }
    let t = texel_of(size, direction);
    let row_first = (size.y as usize + 1) + t.y as usize * (size.x as usize + 1);
    let p = bin_mass(cdf, t.y as usize) * bin_mass(cdf, row_first + t.x as usize);
    texel_density(size, p, direction)
}

/// `p · w · h / (2π² sin θ)`: a texel's probability spread uniformly over its `(u, v)` area,
/// in solid angle; 0 at the poles, where `sin θ` vanishes.
#[inline]
fn texel_density(size: UVec2, p: f32, direction: Vec3) -> f32 {
    // From x and z, not 1 − y²: exact near the poles, where y rounds to ±1.
    let sin_theta = sqrt(direction.x * direction.x + direction.z * direction.z);
    let d = p * (size.x as f32 * size.y as f32) / (2.0 * PI * PI * sin_theta);
    positive_or_zero(d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Random;

    /// A distribution from per-texel weights, as the host builds it.
    fn distribution(size: UVec2, weight: impl Fn(u32, u32) -> f32) -> Vec<f32> {
        let (w, h) = (size.x, size.y);
        let mut rows = vec![0.0f64; h as usize];
        let mut cdf = vec![0.0f32; distribution_len(w, h)];
        for y in 0..h {
            let first = (h as usize + 1) + y as usize * (w as usize + 1);
            let mut sum = 0.0f64;
            for x in 0..w {
                sum += f64::from(weight(x, y));
                cdf[first + x as usize + 1] = sum as f32;
            }
            for x in 0..=w as usize {
                cdf[first + x] = if sum > 0.0 {
                    (f64::from(cdf[first + x]) / sum) as f32
                } else {
                    x as f32 / w as f32
                };
            }
            rows[y as usize] = sum;
        }
        let total: f64 = rows.iter().sum();
        let mut acc = 0.0;
        for y in 0..h as usize {
            acc += rows[y];
            cdf[y + 1] = (acc / total) as f32;
        }
        cdf
    }

    #[test]
    fn uv_round_trips() {
        let mut rng = Random::new(3, 0);
        for _ in 0..10_000 {
            let uv = Vec2::new(rng.next_f32(), 0.001 + 0.998 * rng.next_f32());
            let back = direction_to_uv(uv_to_direction(uv));
            assert!((back - uv).abs().max_element() < 1e-4, "{uv} {back}");
        }
        assert_eq!(
            texel_of(UVec2::new(4, 2), Vec3::new(0.0, 0.5, -1.0).normalize()),
            UVec2::new(2, 0)
        );
    }

    /// Sampling follows the weights, and the density it reports is the one `environment_pdf`
    /// gives for the same direction; the density integrates to one over the sphere.
    #[test]
    fn sampling_matches_its_density() {
        let size = UVec2::new(16, 8);
        let cdf = distribution(size, |x, y| {
            let theta = (y as f32 + 0.5) / 8.0 * PI;
            (1.0 + (x * 7 + y * 3) as f32 % 5.0) * sin(theta) * if x == 3 { 0.0 } else { 1.0 }
        });
        let mut rng = Random::new(4, 0);
        let n = 200_000;
        let mut counts = vec![0u32; 16 * 8];
        for _ in 0..n {
            let s = sample_environment(size, &cdf, rng.next_vec2());
            assert!(s.pdf > 0.0, "{s:?}");
            let pdf = environment_pdf(size, &cdf, s.direction);
            assert!((pdf - s.pdf).abs() <= 1e-3 * s.pdf, "{pdf} {}", s.pdf);
            let t = texel_of(size, s.direction);
            assert_ne!(t.x, 3, "a texel of weight 0 was sampled");
            counts[(t.y * 16 + t.x) as usize] += 1;
        }
        for y in 0..8 {
            let first = 9 + y * 17;
            for x in 0..16 {
                let p = (cdf[y + 1] - cdf[y]) * (cdf[first + x + 1] - cdf[first + x]);
                let got = counts[y * 16 + x] as f32 / n as f32;
                assert!(
                    (got - p).abs() <= 4.0 * (p / n as f32).sqrt() + 1e-6,
                    "{x},{y}"
                );
            }
        }
        // ∫ pdf dω = 1, by uniform sphere sampling.
        let mut sum = 0.0f64;
        let m = 400_000;
        for _ in 0..m {
            let d = crate::sampling::sample_uniform_sphere(rng.next_vec2());
            sum += f64::from(environment_pdf(size, &cdf, d));
        }
        let integral = sum / m as f64 * 4.0 * core::f64::consts::PI;
        assert!((integral - 1.0).abs() < 0.01, "{integral}");
    }

    #[test]
    fn empty_or_short_distributions_give_nothing() {
        let size = UVec2::new(4, 2);
        assert_eq!(
            sample_environment(size, &[0.0; 3], Vec2::splat(0.5)).pdf,
            0.0
        );
        assert_eq!(environment_pdf(size, &[], Vec3::Y), 0.0);
        assert_eq!(environment_pdf(UVec2::ZERO, &[1.0; 64], Vec3::Y), 0.0);
    }
}
