//! Bit packings of the GI-1.0 buffers: IEEE half floats written out by hand (rust-gpu's own f16
//! helpers are GPU-only), 10:10:10 normals, 16:16 octahedral directions, gamma-2 10:10:10
//! albedo, seed pixels, reprojection scores and the fixed-point radiance that integer atomics
//! accumulate.
//!
//! Halves travel in the low 16 bits of a `u32`: 16-bit integers would need the SPIR-V `Int16`
//! capability.

use glam::{UVec2, Vec2, Vec3, Vec4};

use crate::math::{clamp, floor, min_u32, sqrt, to_u32_clamped};
use crate::octahedral::{octahedral_decode, octahedral_encode};

/// Largest finite half float.
pub const HALF_MAX: f32 = 65504.0;
/// Bits of [`HALF_MAX`].
pub const HALF_MAX_BITS: u32 = 0x7bff;
/// Bits of +∞ as a half.
pub const HALF_INFINITY_BITS: u32 = 0x7c00;

/// `f32` → IEEE binary16 bits, rounding to nearest even.
///
/// By input class:
/// - normal results: correctly rounded; ties go to the even mantissa;
/// - `|x| ≥ 65520` (the midpoint between 65504 and 2^16) and ±∞: ±∞ (`0x7c00`/`0xfc00`);
/// - `2^-25 < |x| < 2^-14`: half subnormals, correctly rounded (a carry yields the smallest normal);
/// - `|x| ≤ 2^-25` and `f32` subnormals: ±0 with the sign kept (2^-25 itself ties to even, i.e. 0);
/// - NaN: a quiet NaN with the sign and the top 9 payload bits kept (`0x7e00 | payload`).
#[inline]
pub fn f32_to_f16(x: f32) -> u32 {
    let bits = x.to_bits();
    let sign = (bits >> 16) & 0x8000;
    let exp = (bits >> 23) & 0xff;
    let man = bits & 0x007f_ffff;
    if exp == 0xff {
        return if man == 0 {
            sign | HALF_INFINITY_BITS
        } else {
            sign | 0x7e00 | (man >> 13)
        };
    }
    // Biased half exponent, kept unsigned: `exp + 15 - 127`.
    if exp >= 143 {
        return sign | HALF_INFINITY_BITS;
    }
    if exp >= 113 {
        let h = sign | ((exp - 112) << 10) | (man >> 13);
        let rest = man & 0x1fff;
        // Round to nearest even; a mantissa carry correctly bumps the exponent (up to ∞).
        let round_up = rest > 0x1000 || (rest == 0x1000 && (h & 1) != 0);
        return if round_up { h + 1 } else { h };
    }
    // Subnormal half: value = mantissa · 2^-24 with the implicit bit made explicit.
    let shift = 126 - exp;
    if shift > 24 {
        return sign;
    }
    let full = man | 0x0080_0000;
    let h = full >> shift;
    let rest = full & ((1 << shift) - 1);
    let half_way = 1 << (shift - 1);
    let round_up = rest > half_way || (rest == half_way && (h & 1) != 0);
    sign | if round_up { h + 1 } else { h }
}

/// IEEE binary16 bits (low 16 bits of `h`) → `f32`, exact. NaNs come back quiet (top mantissa bit
/// set) with their payload, like the hardware and the `half` crate.
#[inline]
pub fn f16_to_f32(h: u32) -> f32 {
    let sign = (h & 0x8000) << 16;
    let exp = (h >> 10) & 0x1f;
    let man = h & 0x03ff;
    if exp == 0 {
        // Zero or subnormal: man · 2^-24 is exact in f32.
        let magnitude = man as f32 * (1.0 / 16_777_216.0);
        return f32::from_bits(magnitude.to_bits() | sign);
    }
    if exp == 0x1f {
        let quiet = if man == 0 { 0 } else { 0x0040_0000 };
        return f32::from_bits(sign | 0x7f80_0000 | quiet | (man << 13));
    }
    f32::from_bits(sign | ((exp + 112) << 23) | (man << 13))
}

/// `f32` → half for radiance: like [`f32_to_f16`] but values beyond the half range (including ±∞)
/// saturate to ±65504 instead of becoming ∞, so one bright sample cannot poison a sum. NaN stays NaN.
#[inline]
pub fn pack_radiance_half(x: f32) -> u32 {
    if x.is_nan() {
        return f32_to_f16(x);
    }
    f32_to_f16(clamp(x, -HALF_MAX, HALF_MAX))
}

/// Two halves in a `u32`: `a` in the low 16 bits, `b` in the high (HLSL `f32tof16(a) | f32tof16(b) << 16`).
#[inline]
pub fn pack_half2(v: Vec2) -> u32 {
    f32_to_f16(v.x) | (f32_to_f16(v.y) << 16)
}

/// Inverse of [`pack_half2`].
#[inline]
pub fn unpack_half2(packed: u32) -> Vec2 {
    Vec2::new(f16_to_f32(packed & 0xffff), f16_to_f32(packed >> 16))
}

/// Four radiance halves (saturating, see [`pack_radiance_half`]) in a `uint2`: `(x | y<<16, z | w<<16)`.
#[inline]
pub fn pack_radiance_half4(v: Vec4) -> [u32; 2] {
    [
        pack_radiance_half(v.x) | (pack_radiance_half(v.y) << 16),
        pack_radiance_half(v.z) | (pack_radiance_half(v.w) << 16),
    ]
}

/// Inverse of [`pack_radiance_half4`].
#[inline]
pub fn unpack_half4(packed: [u32; 2]) -> Vec4 {
    let lo = unpack_half2(packed[0]);
    let hi = unpack_half2(packed[1]);
    Vec4::new(lo.x, lo.y, hi.x, hi.y)
}

/// Mantissa bits of the wide unsigned 16-bit float ([`pack_wide16`]).
pub const WIDE16_MANTISSA_BITS: u32 = 9;
/// Exponent bias of [`pack_wide16`]: its 7 exponent bits span `2^-62` to `2^64`.
pub const WIDE16_EXPONENT_BIAS: u32 = 63;
/// Smallest non-zero value of [`pack_wide16`], `2^-62` (about `2.2 · 10⁻¹⁹`): smaller values, `f32`
/// subnormals included, round to 0 or to it.
pub const WIDE16_MIN: f32 = f32::from_bits((1 + 127 - WIDE16_EXPONENT_BIAS) << 23);
/// Largest value of [`pack_wide16`], `(2 − 2^-9) · 2^64` (about `3.7 · 10¹⁹`): larger values and
/// +∞ saturate to it.
pub const WIDE16_MAX: f32 = f32::from_bits(
    ((127 + 127 - WIDE16_EXPONENT_BIAS) << 23) | (0x1ff << (23 - WIDE16_MANTISSA_BITS)),
);
/// Relative rounding error bound of [`pack_wide16`] inside its range: half a unit in the last of
/// 9 mantissa bits, `2^-10`.
pub const WIDE16_MAX_RELATIVE_ERROR: f32 = 1.0 / 1024.0;

/// A non-negative `f32` as a 16-bit float with 7 exponent and 9 mantissa bits (low 16 bits of the
/// result), rounded to nearest (ties away from zero). Half floats' 5-bit exponent ends at 65504,
/// below a 10⁶ emitter's reflected light; this one spans `2^-62` to `2^64` at 0.1 % precision,
/// radiance's whole range in half the bytes of an `f32`. Pure bit operations, so the CPU and
/// every GPU round alike. NaN, zero and negatives give 0, +∞ and values beyond the range
/// [`WIDE16_MAX`].
#[inline]
pub fn pack_wide16(x: f32) -> u32 {
    pack_wide16_dithered(x, 0.5)
}

/// [`pack_wide16`] rounded up with the probability `dither` leaves (uniform in `[0, 1)`: up with
/// the dropped fraction's probability), so that the stored value's expectation is `x` itself. A
/// running mean rounded to nearest every frame stops following a slow change once one frame's
/// step is below half a unit (by up to the history's length times 2^-10); dithered, it drifts
/// with it. `dither` 0.5 rounds to nearest.
#[inline]
pub fn pack_wide16_dithered(x: f32, dither: f32) -> u32 {
    if x.is_nan() || x <= 0.0 {
        return 0;
    }
    let drop = 23 - WIDE16_MANTISSA_BITS;
    let unit = (1u32 << drop) - 1;
    // Adding a share of a unit before truncating rounds; a mantissa carry bumps the exponent.
    // (A NaN dither converts to 0.)
    let rounded = x.to_bits() + min_u32((dither * (1u32 << drop) as f32) as u32, unit);
    let exponent = rounded >> 23;
    if exponent + WIDE16_EXPONENT_BIAS <= 127 {
        return 0;
    }
    let exponent = exponent + WIDE16_EXPONENT_BIAS - 127;
    if exponent > 127 {
        return 0xffff;
    }
    (exponent << WIDE16_MANTISSA_BITS) | ((rounded >> drop) & ((1 << WIDE16_MANTISSA_BITS) - 1))
}

/// Inverse of [`pack_wide16`] (low 16 bits of `w`), exact. Codes of exponent 0, which
/// [`pack_wide16`] never writes but 0 itself, read 0.
#[inline]
pub fn unpack_wide16(w: u32) -> f32 {
    let w = w & 0xffff;
    if w >> WIDE16_MANTISSA_BITS == 0 {
        return 0.0;
    }
    let exponent = (w >> WIDE16_MANTISSA_BITS) + 127 - WIDE16_EXPONENT_BIAS;
    let mantissa = w & ((1 << WIDE16_MANTISSA_BITS) - 1);
    f32::from_bits((exponent << 23) | (mantissa << (23 - WIDE16_MANTISSA_BITS)))
}

/// The dither with which a running mean stores `value` in frame `frame`
/// ([`pack_wide16_dithered`]), uniform in `[0, 1)`: a hash of the value's bits and the frame,
/// so that it changes from frame to frame while the same state still gives the same bits
/// (nothing keyed by a buffer slot, which can depend on the order of atomic inserts).
#[inline]
pub fn running_mean_dither(value: Vec4, frame: u32) -> f32 {
    let h = crate::hash::pcg_chain([
        value.x.to_bits(),
        value.y.to_bits(),
        value.z.to_bits(),
        value.w.to_bits(),
        frame,
    ]);
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Four non-negative values as [`pack_wide16`]s in two words: `(x | y << 16, z | w << 16)`.
#[inline]
pub fn pack_wide16x4(v: Vec4) -> [u32; 2] {
    pack_wide16x4_dithered(v, 0.5)
}

/// [`pack_wide16x4`] with [`pack_wide16_dithered`]'s rounding, one `dither` for all four.
#[inline]
pub fn pack_wide16x4_dithered(v: Vec4, dither: f32) -> [u32; 2] {
    [
        pack_wide16_dithered(v.x, dither) | (pack_wide16_dithered(v.y, dither) << 16),
        pack_wide16_dithered(v.z, dither) | (pack_wide16_dithered(v.w, dither) << 16),
    ]
}

/// Inverse of [`pack_wide16x4`].
#[inline]
pub fn unpack_wide16x4(packed: [u32; 2]) -> Vec4 {
    Vec4::new(
        unpack_wide16(packed[0]),
        unpack_wide16(packed[0] >> 16),
        unpack_wide16(packed[1]),
        unpack_wide16(packed[1] >> 16),
    )
}

/// `x` clamped to `[-1, 1]` (NaN → 0) as a `bits`-bit two's-complement snorm, rounded to the
/// nearest of `2^bits − 1` levels (off by at most half a level, `0.5 / (2^(bits−1) − 1)`).
#[inline]
fn snorm(x: f32, bits: u32) -> u32 {
    let max = ((1u32 << (bits - 1)) - 1) as f32;
    let x = if x.is_nan() { 0.0 } else { x };
    // Offset by `max` so the rounding works on non-negative values, then back to two's complement.
    let level = to_u32_clamped(floor(clamp(x, -1.0, 1.0) * max + max + 0.5));
    level.wrapping_sub(max as u32) & ((1u32 << bits) - 1)
}

/// Inverse of [`snorm`] for the low `bits` bits of `packed`.
#[inline]
fn unsnorm(packed: u32, bits: u32) -> f32 {
    let max = ((1u32 << (bits - 1)) - 1) as f32;
    // Sign-extend the field.
    let shift = 32 - bits;
    let v = ((packed << shift) as i32) >> shift;
    clamp(v as f32 / max, -1.0, 1.0)
}

/// Packs a normal as 10:10:10 snorm (x in bits 0–9, y 10–19, z 20–29; bits 30–31 zero).
/// Components are clamped to `[-1, 1]` (NaN → 0) and rounded to the nearest of 1023 levels, so each
/// is off by at most `0.5 / 511`.
#[inline]
pub fn pack_snorm10x3(n: Vec3) -> u32 {
    snorm(n.x, 10) | (snorm(n.y, 10) << 10) | (snorm(n.z, 10) << 20)
}

/// Inverse of [`pack_snorm10x3`] (not renormalised).
#[inline]
pub fn unpack_snorm10x3(packed: u32) -> Vec3 {
    Vec3::new(
        unsnorm(packed, 10),
        unsnorm(packed >> 10, 10),
        unsnorm(packed >> 20, 10),
    )
}

/// Packs a direction as its octahedral coordinates ([`octahedral_encode`]), each a 16-bit snorm
/// (x in bits 0–15, y in 16–31): a unit vector comes back within [`OCTAHEDRAL16_MAX_ERROR`]
/// radians. A zero or non-finite vector packs as +z, as the map takes it.
#[inline]
pub fn pack_octahedral16(dir: Vec3) -> u32 {
    let e = octahedral_encode(dir);
    snorm(e.x, 16) | (snorm(e.y, 16) << 16)
}

/// Inverse of [`pack_octahedral16`]: a unit vector.
#[inline]
pub fn unpack_octahedral16(packed: u32) -> Vec3 {
    octahedral_decode(Vec2::new(unsnorm(packed, 16), unsnorm(packed >> 16, 16)))
}

/// Largest angle, in radians, between a unit vector and its [`pack_octahedral16`] round trip:
/// half a step of 1/32767 in each coordinate, stretched at most √2 × 2 by the map.
pub const OCTAHEDRAL16_MAX_ERROR: f32 = 1e-4;

/// Largest 10-bit unorm level.
const UNORM10_MAX: f32 = 1023.0;

/// Packs a reflectance as 10:10:10 unorm of its square root (gamma 2; r in bits 0–9, g 10–19,
/// b 20–29), as the reference packs albedo: each channel clamped to `[0, 1]` (NaN → 0); 0 and 1
/// come back exactly, and `a` within `√a / 1023 + 1 / (4 · 1023²)` (0.11 % of 0.8, 1 % of 0.01),
/// rounded to the nearest level, so that the error averages out.
#[inline]
pub fn pack_albedo10x3(a: Vec3) -> u32 {
    gamma2_unorm10(a.x) | (gamma2_unorm10(a.y) << 10) | (gamma2_unorm10(a.z) << 20)
}

/// Inverse of [`pack_albedo10x3`].
#[inline]
pub fn unpack_albedo10x3(packed: u32) -> Vec3 {
    let channel = |bits: u32| {
        let s = (bits & 0x3ff) as f32 / UNORM10_MAX;
        s * s
    };
    Vec3::new(
        channel(packed),
        channel(packed >> 10),
        channel(packed >> 20),
    )
}

#[inline]
fn gamma2_unorm10(x: f32) -> u32 {
    let x = if x.is_nan() { 0.0 } else { clamp(x, 0.0, 1.0) };
    to_u32_clamped(floor(sqrt(x) * UNORM10_MAX + 0.5))
}

/// "No probe / no seed" marker of the probe mask and spawn buffers.
pub const SEED_NONE: u32 = 0xffff_ffff;
/// Largest seed coordinate; `0xffff` is left out so that no seed can equal [`SEED_NONE`].
pub const SEED_MAX_COORD: u32 = 0xfffe;

/// Seed pixel `(x << 16) | y`; coordinates are clamped to [`SEED_MAX_COORD`].
#[inline]
pub fn pack_seed(pixel: UVec2) -> u32 {
    (min_u32(pixel.x, SEED_MAX_COORD) << 16) | min_u32(pixel.y, SEED_MAX_COORD)
}

/// Inverse of [`pack_seed`]; [`SEED_NONE`] unpacks to `(0xffff, 0xffff)`, which callers test first.
#[inline]
pub fn unpack_seed(packed: u32) -> UVec2 {
    UVec2::new(packed >> 16, packed & 0xffff)
}

/// Reprojection winner key: half-float score in the high 16 bits, lane in the low 16.
///
/// Non-negative halves order like their bit patterns, so an atomic `min` on the key selects the
/// lowest score and, among equal scores, the lowest lane. Negative scores count as 0; NaN and
/// scores beyond the half range count as +∞ (the worst); lanes are masked to 16 bits.
#[inline]
pub fn pack_score_lane(score: f32, lane: u32) -> u32 {
    let key = if score.is_nan() {
        HALF_INFINITY_BITS
    } else if score > 0.0 {
        f32_to_f16(score)
    } else {
        0
    };
    (key << 16) | (lane & 0xffff)
}

/// Inverse of [`pack_score_lane`]: `(score, lane)`.
#[inline]
pub fn unpack_score_lane(packed: u32) -> (f32, u32) {
    (f16_to_f32(packed >> 16), packed & 0xffff)
}

/// Fixed-point scale of the screen-probe accumulators (`rgb` and hit distance `× 1e4`, shared memory).
pub const PROBE_RADIANCE_SCALE: f32 = 1e4;
/// Samples one probe cell may receive per frame: 64 traced rays plus 9 × 64 reprojected cells = 640,
/// rounded up.
pub const PROBE_ACCUM_SAMPLE_BUDGET: u32 = 1024;
/// Per-sample clamp of quantised probe radiance/hit distance: 419.4303 units (so probe hit distances
/// saturate at ~419 m; misses use 1e9 and saturate too).
pub const PROBE_MAX_QUANTIZED: u32 = max_quantized_per_sample(PROBE_ACCUM_SAMPLE_BUDGET);

/// Largest per-sample quantised value such that `budget` samples sum to at most `u32::MAX`.
pub const fn max_quantized_per_sample(budget: u32) -> u32 {
    // A budget of 0 behaves like 1.
    u32::MAX / if budget > 1 { budget } else { 1 }
}

/// How many samples of quantised value `q` a `u32` sum holds before it wraps (`u32::MAX` for 0).
pub const fn samples_before_wrap(q: u32) -> u32 {
    // q = 0 never wraps; dividing by 1 yields the same u32::MAX.
    u32::MAX / if q > 1 { q } else { 1 }
}

const _: () = assert!(samples_before_wrap(PROBE_MAX_QUANTIZED) >= PROBE_ACCUM_SAMPLE_BUDGET);

/// Quantises `x` to fixed point: `round(x · scale)` clamped to `[0, max_q]`; negatives and NaN give 0.
#[inline]
pub fn quantize(x: f32, scale: f32, max_q: u32) -> u32 {
    let q = to_u32_clamped(floor(x * scale + 0.5));
    if q < max_q { q } else { max_q }
}

/// Quantised probe radiance/hit-distance channel ([`PROBE_RADIANCE_SCALE`], clamped to
/// [`PROBE_MAX_QUANTIZED`]).
#[inline]
pub fn quantize_probe_radiance(x: f32) -> u32 {
    quantize(x, PROBE_RADIANCE_SCALE, PROBE_MAX_QUANTIZED)
}

/// Fixed point back to float.
#[inline]
pub fn dequantize(q: u32, scale: f32) -> f32 {
    q as f32 / scale
}

/// CPU model of one atomic add: `None` when the sum would wrap, which the GPU cannot detect.
#[inline]
pub fn accumulate_checked(sum: u32, q: u32) -> Option<u32> {
    sum.checked_add(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use half::f16;

    fn reference(x: f32) -> u32 {
        u32::from(f16::from_f32(x).to_bits())
    }

    fn check(x: f32) {
        let ours = f32_to_f16(x);
        let theirs = reference(x);
        assert_eq!(
            ours,
            theirs,
            "{x:e} ({:#010x}): {ours:#06x} vs {theirs:#06x}",
            x.to_bits()
        );
    }

    #[test]
    fn wide16_round_trips_every_code_and_rounds_to_nearest() {
        assert_eq!(pack_wide16(0.0), 0);
        assert_eq!(unpack_wide16(0), 0.0);
        assert_eq!(unpack_wide16(0x1ff), 0.0);
        let mut previous = 0.0f32;
        for w in (1 << WIDE16_MANTISSA_BITS)..=0xffffu32 {
            let v = unpack_wide16(w);
            assert!(
                v > previous && v.is_finite(),
                "{w:#06x}: {v:e} after {previous:e}"
            );
            assert_eq!(pack_wide16(v), w, "{w:#06x} = {v:e}");
            // Just below the midpoint to the next code: this code; just above: the next.
            if w < 0xffff {
                let next = unpack_wide16(w + 1);
                let mid = 0.5 * (v as f64 + next as f64);
                let below = f32::from_bits((mid as f32).to_bits() - 1);
                let above = f32::from_bits((mid as f32).to_bits() + 1);
                assert_eq!(pack_wide16(below), w, "{below:e}");
                assert_eq!(pack_wide16(above), w + 1, "{above:e}");
            }
            previous = v;
        }
        assert_eq!(unpack_wide16(1 << WIDE16_MANTISSA_BITS), WIDE16_MIN);
        assert_eq!(unpack_wide16(0xffff), WIDE16_MAX);
    }

    #[test]
    fn wide16_at_the_extremes() {
        let err = |x: f32| (unpack_wide16(pack_wide16(x)) - x).abs() / x;
        // 1e-6, 1, a half's largest, 10⁶ (a bright emitter), 10¹⁸: within 2^-10.
        for x in [1e-6, 0.3, 1.0, 6.5e4, 65504.0, 1e6, 3.3e7, 1e18] {
            assert!(err(x) <= WIDE16_MAX_RELATIVE_ERROR, "{x:e}: {}", err(x));
        }
        // Every f32 from 2^-62 to 2^64 on a log-spaced sweep.
        let mut x = WIDE16_MIN;
        while x < 1.8e19 {
            assert!(err(x) <= WIDE16_MAX_RELATIVE_ERROR, "{x:e}: {}", err(x));
            x *= 1.000_37;
        }
        // Denormals, tiny values, NaN, negatives: 0; +∞ and beyond the range: the largest.
        for x in [
            f32::from_bits(1),
            f32::MIN_POSITIVE,
            1e-20,
            -1.0,
            -0.0,
            f32::NAN,
            -f32::INFINITY,
        ] {
            assert_eq!(pack_wide16(x), 0, "{x:e}");
        }
        assert_eq!(pack_wide16(f32::INFINITY), 0xffff);
        assert_eq!(pack_wide16(f32::MAX), 0xffff);
        assert_eq!(pack_wide16(1e20), 0xffff);
        let v = Vec4::new(1e6, 2.5e-7, 0.0, 17.0);
        let back = unpack_wide16x4(pack_wide16x4(v));
        assert!(
            (back - v).abs().cmple(v * WIDE16_MAX_RELATIVE_ERROR).all(),
            "{back}"
        );
    }

    #[test]
    fn dithered_wide16_keeps_the_mean() {
        // 0.3 of the way between two codes: nearest rounding always goes down, dithered rounding
        // goes up in 30 % of the dithers, so its mean is the value.
        let lo = unpack_wide16(0x7e40);
        let hi = unpack_wide16(0x7e41);
        let x = lo + 0.3 * (hi - lo);
        assert_eq!(pack_wide16(x), 0x7e40);
        let n = 4096;
        let mean = (0..n)
            .map(|i| {
                f64::from(unpack_wide16(pack_wide16_dithered(
                    x,
                    (i as f32 + 0.5) / n as f32,
                )))
            })
            .sum::<f64>()
            / f64::from(n);
        assert!((mean / f64::from(x) - 1.0).abs() < 1e-6, "{mean} for {x}");
        // Every dither stays within one code; 0.5 is the nearest rounding; odd dithers are safe.
        for d in [0.0, 0.25, 0.5, 0.999_999, 1.0, 7.0, -1.0, f32::NAN] {
            let c = pack_wide16_dithered(x, d);
            assert!(c == 0x7e40 || c == 0x7e41, "{d}: {c:#x}");
        }
        assert_eq!(pack_wide16_dithered(x, 0.5), pack_wide16(x));
        assert_eq!(pack_wide16_dithered(f32::NAN, 0.9), 0);
    }

    #[test]
    fn half_to_float_matches_half_crate_on_all_values() {
        for h in 0..=0xffffu32 {
            let ours = f16_to_f32(h);
            let theirs = f16::from_bits(h as u16).to_f32();
            assert_eq!(ours.to_bits(), theirs.to_bits(), "{h:#06x}");
        }
    }

    #[test]
    fn float_to_half_matches_half_crate_on_rounding_boundaries() {
        for h in 0..0x7c00u32 {
            let lo = f16_to_f32(h);
            let hi = f16_to_f32(h + 1);
            // Exact midpoint (ties to even), its neighbours, and the endpoints, both signs.
            let mid = ((lo as f64 + hi as f64) / 2.0) as f32;
            assert_eq!(
                mid as f64,
                (lo as f64 + hi as f64) / 2.0,
                "midpoint must be exact"
            );
            for x in [lo, hi, mid, mid.next_down(), mid.next_up()] {
                check(x);
                check(-x);
            }
        }
    }

    #[test]
    fn float_to_half_matches_half_crate_on_a_sweep() {
        // ~10⁶ bit patterns spread over all of f32, including NaNs and subnormals.
        let mut bits = 0u32;
        loop {
            check(f32::from_bits(bits));
            match bits.checked_add(4099) {
                Some(b) => bits = b,
                None => break,
            }
        }
    }

    #[test]
    fn extreme_classes() {
        // Overflow threshold: 65520 is the midpoint to 2^16 and ties away to ∞ (odd mantissa).
        assert_eq!(f32_to_f16(65504.0), 0x7bff);
        assert_eq!(f32_to_f16(65519.996), 0x7bff);
        assert_eq!(f32_to_f16(65520.0), 0x7c00);
        assert_eq!(f32_to_f16(1e10), 0x7c00);
        assert_eq!(f32_to_f16(f32::MAX), 0x7c00);
        assert_eq!(f32_to_f16(-f32::MAX), 0xfc00);
        assert_eq!(f32_to_f16(f32::INFINITY), 0x7c00);
        assert_eq!(f32_to_f16(f32::NEG_INFINITY), 0xfc00);
        // Tiny: smallest subnormal 2^-24, half of it ties to 0, just above rounds up.
        assert_eq!(f32_to_f16(2f32.powi(-24)), 0x0001);
        assert_eq!(f32_to_f16(2f32.powi(-25)), 0x0000);
        assert_eq!(f32_to_f16(2f32.powi(-25).next_up()), 0x0001);
        assert_eq!(f32_to_f16(-1e-30), 0x8000);
        assert_eq!(f32_to_f16(f32::from_bits(1)), 0x0000);
        // Largest subnormal rounding up into the smallest normal.
        assert_eq!(f32_to_f16(2f32.powi(-14).next_down()), 0x0400);
        assert_eq!(f32_to_f16(-0.0), 0x8000);
        // NaN stays NaN (quiet), sign kept.
        let nan = f32_to_f16(f32::NAN);
        assert!(nan & 0x7c00 == 0x7c00 && nan & 0x03ff != 0);
        assert!(f16_to_f32(nan).is_nan());
        assert!(f16_to_f32(f32_to_f16(-f32::NAN)).is_sign_negative());
        // Radiance saturates instead.
        assert_eq!(pack_radiance_half(1e10), HALF_MAX_BITS);
        assert_eq!(pack_radiance_half(f32::INFINITY), HALF_MAX_BITS);
        assert_eq!(pack_radiance_half(65520.0), HALF_MAX_BITS);
        assert_eq!(pack_radiance_half(-1e10), 0x8000 | HALF_MAX_BITS);
        assert!(f16_to_f32(pack_radiance_half(f32::NAN)).is_nan());
        assert_eq!(pack_radiance_half(1.5), 0x3e00);
    }

    #[test]
    fn half_pairs() {
        let p = pack_half2(Vec2::new(1.0, -2.0));
        assert_eq!(p, 0x3c00 | (0xc000 << 16));
        assert_eq!(unpack_half2(p), Vec2::new(1.0, -2.0));
        let v = Vec4::new(0.5, 3.0, 1e6, 16.0);
        assert_eq!(
            unpack_half4(pack_radiance_half4(v)),
            Vec4::new(0.5, 3.0, HALF_MAX, 16.0)
        );
    }

    #[test]
    fn snorm_normals() {
        assert_eq!(
            pack_snorm10x3(Vec3::new(1.0, -1.0, 0.0)),
            0x1ff | (0x201 << 10)
        );
        let mut rng = crate::random::Random::new(5, 0);
        for _ in 0..100_000 {
            let n = crate::sampling::sample_uniform_sphere(rng.next_vec2());
            let r = unpack_snorm10x3(pack_snorm10x3(n));
            assert!(
                (r - n).abs().max_element() <= 0.5 / 511.0 + 1e-6,
                "{n} -> {r}"
            );
        }
        assert_eq!(
            unpack_snorm10x3(pack_snorm10x3(Vec3::new(5.0, -7.0, f32::NAN))),
            Vec3::new(1.0, -1.0, 0.0)
        );
        assert_eq!(pack_snorm10x3(Vec3::ONE) >> 30, 0);
    }

    #[test]
    fn seeds() {
        let s = pack_seed(UVec2::new(1919, 1079));
        assert_eq!(s, (1919 << 16) | 1079);
        assert_eq!(unpack_seed(s), UVec2::new(1919, 1079));
        assert_ne!(pack_seed(UVec2::splat(u32::MAX)), SEED_NONE);
        assert_eq!(unpack_seed(SEED_NONE), UVec2::splat(0xffff));
    }

    #[test]
    fn score_lane_keys_order_by_score_then_lane() {
        let scores = [0.0, 1e-6, 0.25, 0.5, 1.0, 3.0, 1000.0, 1e9];
        for w in scores.windows(2) {
            assert!(
                pack_score_lane(w[0], 63) < pack_score_lane(w[1], 0),
                "{w:?}"
            );
        }
        assert!(pack_score_lane(0.5, 3) < pack_score_lane(0.5, 4));
        assert_eq!(pack_score_lane(-1.0, 7), 7);
        assert_eq!(pack_score_lane(f32::NAN, 7), (HALF_INFINITY_BITS << 16) | 7);
        assert_eq!(unpack_score_lane(pack_score_lane(0.75, 42)), (0.75, 42));
    }

    #[test]
    fn fixed_point_budget_holds_and_overflow_is_detected() {
        assert_eq!(PROBE_MAX_QUANTIZED, 4_194_303);
        assert_eq!(quantize_probe_radiance(1e9), PROBE_MAX_QUANTIZED);
        assert_eq!(quantize_probe_radiance(-1.0), 0);
        assert_eq!(quantize_probe_radiance(f32::NAN), 0);
        assert_eq!(quantize_probe_radiance(f32::INFINITY), PROBE_MAX_QUANTIZED);
        assert_eq!(quantize_probe_radiance(0.12344), 1234);
        assert_eq!(quantize_probe_radiance(0.00015), 2);
        assert!(
            (dequantize(quantize_probe_radiance(2.5), PROBE_RADIANCE_SCALE) - 2.5).abs() < 1e-6
        );

        let (q, budget) = (quantize_probe_radiance(1e9), PROBE_ACCUM_SAMPLE_BUDGET);
        let mut sum = 0u32;
        for _ in 0..budget {
            sum = accumulate_checked(sum, q).expect("within budget");
        }
        // The documented limit itself: samples_before_wrap more samples are still fine...
        let more = samples_before_wrap(q) - budget;
        for _ in 0..more {
            sum = accumulate_checked(sum, q).expect("within samples_before_wrap");
        }
        // ...and one step beyond wraps, which the checked add reports.
        assert_eq!(accumulate_checked(sum, q), None);
        assert_eq!(samples_before_wrap(0), u32::MAX);
        assert_eq!(samples_before_wrap(1000), 4_294_967);
    }

    /// Directions round-trip within `OCTAHEDRAL16_MAX_ERROR`: the axes, the octahedron's folds,
    /// tiny and huge components, denormals; zero and NaN come back as +z.
    #[test]
    fn octahedral16_round_trips_at_the_extremes() {
        let mut dirs = vec![
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::ONE,
            -Vec3::ONE,
            Vec3::new(1.0, 1e-6, -1e-6),
            Vec3::new(1e-38, 1e-40, -1.0),
            Vec3::new(6.5e4, -1e6, 3.0),
            Vec3::new(1e-30, 1e-30, 1e-30),
        ];
        let mut rng = crate::random::Random::new(5, 0);
        for _ in 0..10_000 {
            dirs.push(crate::sampling::sample_uniform_sphere(rng.next_vec2()));
        }
        for d in dirs {
            let back = unpack_octahedral16(pack_octahedral16(d));
            assert!((back.length() - 1.0).abs() < 1e-6, "{d}: {back}");
            let (u64, b64) = (d.as_dvec3().normalize(), back.as_dvec3());
            let angle = u64.cross(b64).length().atan2(u64.dot(b64)) as f32;
            assert!(angle <= OCTAHEDRAL16_MAX_ERROR, "{d}: {back}, {angle} rad");
        }
        for d in [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::NAN, 1.0, 0.0)] {
            assert_eq!(unpack_octahedral16(pack_octahedral16(d)), Vec3::Z, "{d}");
        }
        assert_eq!(unpack_octahedral16(pack_octahedral16(-Vec3::Z)), -Vec3::Z);
    }

    /// Albedo round-trips within `√a / 1023 + 1 / (4 · 1023²)`: 0 and 1 exactly, 1e-6,
    /// denormals, values past 1 (clamped), 6.5e4 and 1e6 (clamped to 1), NaN (0), negative (0).
    #[test]
    fn albedo10x3_round_trips_at_the_extremes() {
        let bound = |a: f32| a.sqrt() / 1023.0 + 0.25 / (1023.0 * 1023.0);
        for a in [
            0.0, 1e-6, 1e-40, 0.01, 0.02, 0.18, 0.5, 0.8, 0.95, 0.999, 1.0,
        ] {
            let back = unpack_albedo10x3(pack_albedo10x3(Vec3::new(a, a * 0.5, 1.0 - a)));
            for (x, y) in [(a, back.x), (a * 0.5, back.y), (1.0 - a, back.z)] {
                assert!((x - y).abs() <= bound(x), "{x} -> {y}");
            }
        }
        let exact = unpack_albedo10x3(pack_albedo10x3(Vec3::new(0.0, 1.0, 0.25)));
        assert_eq!(exact, Vec3::new(0.0, 1.0, (512.0f32 / 1023.0).powi(2)));
        let clamped = unpack_albedo10x3(pack_albedo10x3(Vec3::new(6.5e4, 1e6, f32::INFINITY)));
        assert_eq!(clamped, Vec3::ONE);
        let nan = unpack_albedo10x3(pack_albedo10x3(Vec3::new(f32::NAN, -1.0, -1e-40)));
        assert_eq!(nan, Vec3::ZERO);
        // The 10-bit fields stay in place: bits 30–31 are zero.
        assert_eq!(pack_albedo10x3(Vec3::ONE) >> 30, 0);
        // Rounding is unbiased on average: the mean round trip of a ramp is the ramp's mean.
        let n = 100_000;
        let (mut sum, mut back) = (0.0f64, 0.0f64);
        for i in 0..n {
            let a = (i as f32 + 0.5) / n as f32;
            sum += f64::from(a);
            back += f64::from(unpack_albedo10x3(pack_albedo10x3(Vec3::splat(a))).x);
        }
        assert!((back / sum - 1.0).abs() < 1e-5, "{}", back / sum);
    }
}
