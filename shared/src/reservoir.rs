//! Streaming weighted reservoir sampling and resampled importance sampling (RIS), the core of the
//! world-space ReSTIR light reuse.
//!
//! Candidates `x` drawn from a source pdf `p` are streamed with weights `w = p̂(x) / p(x)`; the kept
//! sample `y` has unbiased contribution weight `W = w_sum / (M · p̂(y))`, so `f(y) · W` estimates
//! `∫ f` for any `f` that is zero wherever `p̂` is.

use crate::math::{min, positive_or_zero};

/// A weighted reservoir holding one sample (a light index).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reservoir {
    /// Selected candidate.
    pub sample: u32,
    /// Sum of the resampling weights seen so far.
    pub w_sum: f32,
    /// Number of candidates represented (`f32` because merged counts can be capped/fractional).
    pub m: f32,
    /// Unbiased contribution weight `W` of `sample`; valid after [`Reservoir::finalize`].
    pub ucw: f32,
}

impl Reservoir {
    /// A reservoir that has seen nothing.
    pub const EMPTY: Self = Self {
        sample: 0,
        w_sum: 0.0,
        m: 0.0,
        ucw: 0.0,
    };

    /// Streams one candidate with resampling weight `weight`; `u ∈ [0, 1)` decides replacement.
    /// Returns whether the candidate was selected. Negative, NaN or infinite weights count as 0
    /// (the candidate still counts towards `M`).
    #[inline]
    pub fn update(&mut self, candidate: u32, weight: f32, u: f32) -> bool {
        self.add(candidate, weight, 1.0, u)
    }

    /// Merges another finalised reservoir whose sample has target pdf `target_pdf` here, capping its
    /// count at `m_cap` (the temporal history clamp). Returns whether its sample was selected.
    #[inline]
    pub fn merge(&mut self, other: &Reservoir, target_pdf: f32, u: f32, m_cap: f32) -> bool {
        let m = min(other.m, m_cap);
        let m = if m > 0.0 { m } else { 0.0 };
        self.add(other.sample, target_pdf * other.ucw * m, m, u)
    }

    /// Computes `W = w_sum / (M · p̂(sample))`; 0 when `M`, `p̂` or `w_sum` is zero or invalid.
    #[inline]
    pub fn finalize(&mut self, target_pdf: f32) {
        let w = self.w_sum / (self.m * target_pdf);
        self.ucw = positive_or_zero(w);
    }

    #[inline]
    fn add(&mut self, candidate: u32, weight: f32, m: f32, u: f32) -> bool {
        let w = positive_or_zero(weight);
        self.w_sum += w;
        self.m += m;
        // P(select) = w / w_sum; `w > 0` keeps zero-weight candidates out even when u = 0.
        let selected = w > 0.0 && u * self.w_sum < w;
        if selected {
            self.sample = candidate;
        }
        selected
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Random;

    const K: usize = 16;

    /// Target function p̂ over K discrete items (unnormalised) and an integrand f that is not
    /// proportional to it.
    fn target(i: u32) -> f32 {
        1.0 + (i * i % 7) as f32
    }
    fn integrand(i: u32) -> f32 {
        0.5 + (i % 5) as f32 * target(i)
    }
    fn exact_sum() -> f64 {
        (0..K as u32).map(|i| integrand(i) as f64).sum()
    }

    /// RIS with `m` candidates from a source pdf that is uniform (`skewed == false`) or linear.
    fn ris(rng: &mut Random, m: u32, skewed: bool) -> Reservoir {
        let mut r = Reservoir::EMPTY;
        for _ in 0..m {
            let (x, p) = if skewed {
                // p(i) ∝ i + 1 by inverting the discrete CDF.
                let total = (K * (K + 1) / 2) as u32;
                let t = (rng.next_f32() * total as f32) as u32;
                let mut i = 0u32;
                let mut c = 1u32;
                while c <= t {
                    i += 1;
                    c += i + 1;
                }
                (i, (i + 1) as f32 / total as f32)
            } else {
                ((rng.next_f32() * K as f32) as u32, 1.0 / K as f32)
            };
            r.update(x, target(x) / p, rng.next_f32());
        }
        r.finalize(target(r.sample));
        r
    }

    /// Mean of `f(y) W` over `n` trials and its standard error.
    fn estimate(n: u32, mut trial: impl FnMut() -> Reservoir) -> (f64, f64) {
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let r = trial();
            let v = (integrand(r.sample) * r.ucw) as f64;
            s += v;
            s2 += v * v;
        }
        let mean = s / n as f64;
        let var = (s2 / n as f64 - mean * mean).max(0.0);
        (mean, (var / n as f64).sqrt())
    }

    #[test]
    fn streaming_selection_follows_the_weights() {
        // Streaming all K items once selects item i with probability w_i / Σw exactly.
        let weights: [f32; K] = core::array::from_fn(|i| target(i as u32));
        let total: f32 = weights.iter().sum();
        let mut rng = Random::new(2024, 0);
        let trials = 200_000;
        let mut counts = [0u32; K];
        for _ in 0..trials {
            let mut r = Reservoir::EMPTY;
            for (i, &w) in weights.iter().enumerate() {
                r.update(i as u32, w, rng.next_f32());
            }
            assert_eq!(r.m, K as f32);
            counts[r.sample as usize] += 1;
        }
        let chi2: f64 = (0..K)
            .map(|i| {
                let e = trials as f64 * (weights[i] / total) as f64;
                (counts[i] as f64 - e).powi(2) / e
            })
            .sum();
        // 15 degrees of freedom, p = 0.001.
        assert!(chi2 < 37.7, "chi2 = {chi2}");
    }

    #[test]
    fn zero_and_invalid_weights_are_never_selected() {
        let mut r = Reservoir::EMPTY;
        assert!(r.update(1, 1.0, 0.999));
        assert!(!r.update(2, 0.0, 0.0));
        assert!(!r.update(3, f32::NAN, 0.0));
        assert!(!r.update(4, -5.0, 0.0));
        assert!(!r.update(5, f32::INFINITY, 0.0));
        assert_eq!((r.sample, r.w_sum, r.m), (1, 1.0, 5.0));
        r.finalize(0.0);
        assert_eq!(r.ucw, 0.0);
        let mut e = Reservoir::EMPTY;
        e.finalize(1.0);
        assert_eq!(e.ucw, 0.0);
    }

    #[test]
    fn ris_estimator_is_unbiased() {
        let exact = exact_sum();
        for (m, skewed) in [(1, false), (4, false), (8, true)] {
            let mut rng = Random::new(77, m);
            let (mean, se) = estimate(400_000, || ris(&mut rng, m, skewed));
            assert!(
                (mean - exact).abs() < 5.0 * se,
                "M={m}: {mean} vs {exact} (σ {se})"
            );
        }
    }

    #[test]
    fn merging_keeps_the_estimator_unbiased() {
        let exact = exact_sum();
        for m_cap in [f32::MAX, 3.0] {
            let mut rng = Random::new(91, m_cap as u32);
            let (mean, se) = estimate(400_000, || {
                let a = ris(&mut rng, 4, false);
                let b = ris(&mut rng, 6, true);
                let mut r = Reservoir::EMPTY;
                r.merge(&a, target(a.sample), rng.next_f32(), m_cap);
                r.merge(&b, target(b.sample), rng.next_f32(), m_cap);
                r.finalize(target(r.sample));
                r
            });
            assert!(
                (mean - exact).abs() < 5.0 * se,
                "cap {m_cap}: {mean} vs {exact} (σ {se})"
            );
        }
    }

    #[test]
    fn merge_caps_m() {
        let other = Reservoir {
            sample: 9,
            w_sum: 100.0,
            m: 50.0,
            ucw: 2.0,
        };
        let mut r = Reservoir::EMPTY;
        assert!(r.merge(&other, 0.5, 0.5, 20.0));
        assert_eq!((r.sample, r.m, r.w_sum), (9, 20.0, 20.0));
    }
}
