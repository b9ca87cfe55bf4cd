//! Random and low-discrepancy numbers: the PCG stream of `MakeRandom`, Halton jitter and a
//! per-pixel R2 sampler.

use glam::{UVec2, Vec2};

use crate::hash::{PCG_MULTIPLIER, pcg, pcg_chain, pcg_output};
use crate::math::{min_u32, to_u32_clamped, unorm24};

/// A PCG32 (RXS-M-XS) random stream.
///
/// [`Random::new`] seeds it exactly like Capsaicin's `MakeRandom(seed, frame)`. Capsaicin then
/// advances every stream with the hash increment `2891336453`; this stream advances with its own
/// odd increment `(frame << 1) | 1`, so frames are distinct full-period (2^32) PCG streams rather
/// than offsets into one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Random {
    /// LCG state.
    pub state: u32,
    /// Stream increment; always odd.
    pub inc: u32,
}

impl Random {
    /// `MakeRandom(seed, frame)`: `seed` decorrelates pixels, `frame` selects the stream.
    #[inline]
    pub fn new(seed: u32, frame: u32) -> Self {
        let inc = (frame << 1) | 1;
        Self {
            state: seed
                .wrapping_add(inc)
                .wrapping_mul(PCG_MULTIPLIER)
                .wrapping_add(inc),
            inc,
        }
    }

    /// Next 32 uniformly distributed bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULTIPLIER).wrapping_add(self.inc);
        pcg_output(old)
    }

    /// Uniform float in `[0, 1)` from the top 24 bits, so it is never rounded up to 1.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        unorm24(self.next_u32())
    }

    /// Two uniform floats in `[0, 1)`.
    #[inline]
    pub fn next_vec2(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }

    /// Uniform in `[lo, hi)` (for `lo < hi`), from [`Random::next_f32`].
    #[inline]
    pub fn next_in(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }
}

/// Radical inverse of `index` in `base` (van der Corput), in `[0, 1)`. Bases below 2 give 0.
#[inline]
pub fn radical_inverse(index: u32, base: u32) -> f32 {
    if base < 2 {
        return 0.0;
    }
    if base == 2 {
        return unorm24(index.reverse_bits());
    }
    let inv_base = 1.0 / base as f32;
    let mut scale = inv_base;
    let mut result = 0.0;
    let mut i = index;
    while i > 0 {
        result += (i % base) as f32 * scale;
        i /= base;
        scale *= inv_base;
    }
    // Summation rounding may reach 1.0 for indices just below a power of the base.
    crate::math::min(result, crate::math::ONE_MINUS_EPSILON)
}

/// Halton point `index` in bases 2 and 3.
#[inline]
pub fn halton23(index: u32) -> Vec2 {
    Vec2::new(radical_inverse(index, 2), radical_inverse(index, 3))
}

/// Probe-spawn jitter of GI-1.0: Halton(2,3) of `(frame & 0xFF) + 1` scaled to `size` pixels,
/// each component in `0..size` (0 when `size` is 0).
#[inline]
pub fn spawn_jitter(frame_index: u32, size: u32) -> UVec2 {
    let h = halton23((frame_index & 0xff) + 1) * size as f32;
    let last = if size > 0 { size - 1 } else { 0 };
    UVec2::new(
        min_u32(to_u32_clamped(h.x), last),
        min_u32(to_u32_clamped(h.y), last),
    )
}

/// `2^32 / g` and `2^32 / g²` for the plastic number `g` (Roberts' R2 sequence), in 0.32 fixed point
/// so `index * alpha` wraps exactly instead of losing bits in `f32`.
const R2_ALPHA: [u32; 2] = [0xc13f_a9a9, 0x91e1_0da6];
/// R2 starts at 0.5 rather than 0.
const R2_OFFSET: u32 = 0x8000_0000;

/// Sample `index` of the per-pixel low-discrepancy sequence: Roberts' R2 sequence, Cranley–Patterson
/// rotated by a hash of `pixel`.
///
/// Properties (tested): for every pixel, 1024 consecutive samples have star discrepancy below 0.01
/// (several times below independent uniform samples), and any `n` = 64, 256 or 1024 consecutive
/// samples put at most 2 points into each `1/n` stratum of either axis. Neighbouring pixels get
/// decorrelated shifts. The shift is added in 0.32 fixed point, so CPU and GPU produce identical bits.
#[inline]
pub fn pixel_sample(pixel: UVec2, index: u32) -> Vec2 {
    let rotation_x = pcg_chain([pixel.x, pixel.y]);
    let rotation_y = pcg(rotation_x);
    let x = index
        .wrapping_mul(R2_ALPHA[0])
        .wrapping_add(R2_OFFSET)
        .wrapping_add(rotation_x);
    let y = index
        .wrapping_mul(R2_ALPHA[1])
        .wrapping_add(R2_OFFSET)
        .wrapping_add(rotation_y);
    Vec2::new(unorm24(x), unorm24(y))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Star discrepancy estimated on a `g × g` grid of anchored boxes `[0,a)×[0,b)`.
    fn grid_star_discrepancy(points: &[Vec2], g: u32) -> f32 {
        let n = points.len() as f32;
        let mut worst = 0.0f32;
        for i in 1..=g {
            for j in 1..=g {
                let (a, b) = (i as f32 / g as f32, j as f32 / g as f32);
                let inside = points.iter().filter(|p| p.x < a && p.y < b).count() as f32;
                worst = worst.max((inside / n - a * b).abs());
            }
        }
        worst
    }

    #[test]
    fn stream_matches_make_random_seeding() {
        let r = Random::new(10, 3);
        assert_eq!(r.inc, 7);
        assert_eq!(r.state, 17u32.wrapping_mul(747_796_405).wrapping_add(7));
        // The first output permutes the seeded state; the state then advances by `inc`.
        let mut r = Random::new(0, 0);
        let s0 = r.state;
        assert_eq!(r.next_u32(), pcg_output(s0));
        assert_eq!(r.state, s0.wrapping_mul(747_796_405).wrapping_add(1));
    }

    #[test]
    fn floats_are_uniform_and_below_one() {
        let mut r = Random::new(1234, 5);
        let mut bins = [0u32; 16];
        let n = 160_000;
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            bins[(x * 16.0) as usize] += 1;
        }
        let expected = n as f64 / 16.0;
        let chi2: f64 = bins
            .iter()
            .map(|&b| (b as f64 - expected).powi(2) / expected)
            .sum();
        // 15 degrees of freedom, p = 0.001.
        assert!(chi2 < 37.7, "chi2 = {chi2}");
    }

    #[test]
    fn radical_inverse_values() {
        assert_eq!(radical_inverse(1, 2), 0.5);
        assert_eq!(radical_inverse(3, 2), 0.75);
        assert_eq!(radical_inverse(6, 2), 0.375);
        assert!((radical_inverse(1, 3) - 1.0 / 3.0).abs() < 1e-7);
        assert!((radical_inverse(5, 3) - 7.0 / 9.0).abs() < 1e-7);
        assert!((radical_inverse(7, 5) - 11.0 / 25.0).abs() < 1e-7); // 7 = "12" in base 5
        assert_eq!(radical_inverse(9, 1), 0.0);
        assert_eq!(radical_inverse(9, 0), 0.0);
        for i in [u32::MAX, u32::MAX - 1, 3u32.pow(20) - 1] {
            for b in [2, 3, 5, 7] {
                let v = radical_inverse(i, b);
                assert!((0.0..1.0).contains(&v), "{i} base {b}: {v}");
            }
        }
    }

    #[test]
    fn spawn_jitter_stays_in_the_tile() {
        for f in 0..600 {
            let j = spawn_jitter(f, 16);
            assert!(j.x < 16 && j.y < 16);
        }
        assert_eq!(spawn_jitter(0, 16), UVec2::new(8, 5)); // Halton(1) = (1/2, 1/3)
        assert_eq!(spawn_jitter(7, 0), UVec2::ZERO);
    }

    #[test]
    fn pixel_sampler_has_low_discrepancy() {
        let n = 1024;
        let mut rng = Random::new(99, 0);
        let random: Vec<Vec2> = (0..n).map(|_| rng.next_vec2()).collect();
        let d_random = grid_star_discrepancy(&random, 32);
        for pixel in [UVec2::new(0, 0), UVec2::new(17, 3), UVec2::new(1919, 1079)] {
            let pts: Vec<Vec2> = (0..n).map(|i| pixel_sample(pixel, i)).collect();
            assert!(
                pts.iter()
                    .all(|p| (0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y))
            );
            let d = grid_star_discrepancy(&pts, 32);
            assert!(d < 0.01, "pixel {pixel}: {d}");
            assert!(
                d * 3.0 < d_random,
                "pixel {pixel}: {d} vs random {d_random}"
            );
        }
    }

    #[test]
    fn pixel_sampler_projections_are_stratified() {
        // Any n consecutive samples (n = 64, 256, 1024) put at most 2 points in each 1/n stratum of
        // either axis, whatever the rotation; i.i.d. points typically pile up 4–5.
        for n in [64u32, 256, 1024] {
            for pixel in [UVec2::new(0, 0), UVec2::new(5, 9), UVec2::new(3000, 2000)] {
                for start in [0u32, 1000, 123_456_789] {
                    let mut bins = vec![[0u32; 2]; n as usize];
                    for i in 0..n {
                        let s = pixel_sample(pixel, start.wrapping_add(i));
                        bins[(s.x * n as f32) as usize][0] += 1;
                        bins[(s.y * n as f32) as usize][1] += 1;
                    }
                    let worst = bins.iter().flatten().max().copied().unwrap_or(0);
                    assert!(worst <= 2, "n {n} pixel {pixel} start {start}: {worst}");
                }
            }
        }
    }

    #[test]
    fn neighbouring_pixels_get_different_rotations() {
        let a = pixel_sample(UVec2::new(10, 10), 0);
        let b = pixel_sample(UVec2::new(11, 10), 0);
        let c = pixel_sample(UVec2::new(10, 11), 0);
        assert!(a.distance(b) > 1e-3 && a.distance(c) > 1e-3 && b.distance(c) > 1e-3);
    }
}
