//! Float helpers shared by the CPU and the GPU.
//!
//! Transcendental functions go through [`num_traits::Float`] so they resolve to `std` on the host
//! and to `libm` without it (rust-gpu lowers those `libm` calls to GLSL.std.450 instructions).
//! Float→int conversions are written out because an `as` cast saturates on the CPU but is
//! undefined on SPIR-V for NaN and out-of-range values.

use num_traits::Float;

/// π.
pub const PI: f32 = core::f32::consts::PI;
/// 1/π.
pub const INV_PI: f32 = core::f32::consts::FRAC_1_PI;
/// The largest `f32` strictly below 1; keeps `[0, 1)` samples away from 1.0.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// `floor(x)`.
#[inline]
pub fn floor(x: f32) -> f32 {
    Float::floor(x)
}

/// `ceil(x)`.
#[inline]
pub fn ceil(x: f32) -> f32 {
    Float::ceil(x)
}

/// `sqrt(x)`; NaN for negative `x`.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    Float::sqrt(x)
}

/// `sqrt(max(x, 0))`: for quantities that are non-negative up to rounding.
#[inline]
pub fn safe_sqrt(x: f32) -> f32 {
    Float::sqrt(max(x, 0.0))
}

/// `|x|`.
#[inline]
pub fn abs(x: f32) -> f32 {
    Float::abs(x)
}

/// `sin(x)`.
#[inline]
pub fn sin(x: f32) -> f32 {
    Float::sin(x)
}

/// `cos(x)`.
#[inline]
pub fn cos(x: f32) -> f32 {
    Float::cos(x)
}

/// `tan(x)`.
#[inline]
pub fn tan(x: f32) -> f32 {
    Float::tan(x)
}

/// `atan(x)`.
#[inline]
pub fn atan(x: f32) -> f32 {
    Float::atan(x)
}

/// Four-quadrant arctangent of `y / x`, in `[-π, π]`.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    Float::atan2(y, x)
}

/// Arccosine, in `[0, π]` for `x` in `[-1, 1]`.
#[inline]
pub fn acos(x: f32) -> f32 {
    Float::acos(x)
}

/// Smaller of `a` and `b`; returns `b` when either is NaN (SPIR-V `FMin` leaves NaN undefined).
#[inline]
pub fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// Larger of `a` and `b`; returns `b` when either is NaN.
#[inline]
pub fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// `x` if it is positive and finite, else 0: a weight, density or power that NaN, infinity or a
/// negative value must not poison.
#[inline]
pub fn positive_or_zero(x: f32) -> f32 {
    if x.is_finite() && x > 0.0 { x } else { 0.0 }
}

/// `x` clamped to `[lo, hi]`; NaN gives `lo`.
#[inline]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    // NaN fails `x >= lo` and lands on `lo`.
    if x >= lo {
        if x > hi { hi } else { x }
    } else {
        lo
    }
}

/// `x` clamped to `[0, 1]`; NaN gives 0.
#[inline]
pub fn saturate(x: f32) -> f32 {
    clamp(x, 0.0, 1.0)
}

/// `+1` or `-1` with the sign bit of `x` (so `-0.0` gives `-1`), unlike HLSL `sign`.
#[inline]
pub fn sign_not_zero(x: f32) -> f32 {
    copysign(1.0, x)
}

/// `|magnitude|` with the sign bit of `sign`.
#[inline]
pub fn copysign(magnitude: f32, sign: f32) -> f32 {
    f32::from_bits((magnitude.to_bits() & 0x7fff_ffff) | (sign.to_bits() & 0x8000_0000))
}

/// Smaller of two `u32`s without `Ord` (which needs `Int8` on SPIR-V).
#[inline]
pub fn min_u32(a: u32, b: u32) -> u32 {
    if a < b { a } else { b }
}

/// Larger of two `u32`s without `Ord`.
#[inline]
pub fn max_u32(a: u32, b: u32) -> u32 {
    if a > b { a } else { b }
}

/// Smaller of two `i32`s without `Ord`.
#[inline]
pub fn min_i32(a: i32, b: i32) -> i32 {
    if a < b { a } else { b }
}

/// Larger of two `i32`s without `Ord`.
#[inline]
pub fn max_i32(a: i32, b: i32) -> i32 {
    if a > b { a } else { b }
}

/// Truncates `x` toward zero into `u32`: NaN and negatives give 0, values at or above 2^32 give
/// `u32::MAX`. Identical on CPU and GPU.
#[inline]
pub fn to_u32_clamped(x: f32) -> u32 {
    // NaN fails `x > 0`; 2^32 is the first f32 that no longer fits.
    if x > 0.0 {
        if x >= 4_294_967_296.0 {
            u32::MAX
        } else {
            x as u32
        }
    } else {
        0
    }
}

/// Truncates `x` toward zero into `i32`: NaN gives 0, out-of-range values give `i32::MIN/MAX`.
#[inline]
pub fn to_i32_clamped(x: f32) -> i32 {
    if x.is_nan() {
        0
    } else if x >= 2_147_483_648.0 {
        i32::MAX
    } else if x < -2_147_483_648.0 {
        i32::MIN
    } else {
        x as i32
    }
}

/// `floor(x)` as an `i32`, clamped to `[lo, hi]`; NaN counts as 0 before clamping.
#[inline]
pub fn floor_to_i32_clamped(x: f32, lo: i32, hi: i32) -> i32 {
    min_i32(max_i32(to_i32_clamped(floor(x)), lo), hi)
}

/// Top 24 bits of `bits` as a float in `[0, 1)`: every result is exact and at most `1 - 2^-24`.
#[inline]
pub fn unorm24(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn float_to_int_conversions_are_defined_everywhere() {
        assert_eq!(to_u32_clamped(f32::NAN), 0);
        assert_eq!(to_u32_clamped(-1.0), 0);
        assert_eq!(to_u32_clamped(f32::NEG_INFINITY), 0);
        assert_eq!(to_u32_clamped(f32::INFINITY), u32::MAX);
        assert_eq!(to_u32_clamped(4_294_967_296.0), u32::MAX);
        assert_eq!(to_u32_clamped(4_294_967_040.0), 4_294_967_040);
        assert_eq!(to_u32_clamped(3.99), 3);
        assert_eq!(to_i32_clamped(f32::NAN), 0);
        assert_eq!(to_i32_clamped(f32::INFINITY), i32::MAX);
        assert_eq!(to_i32_clamped(f32::NEG_INFINITY), i32::MIN);
        assert_eq!(to_i32_clamped(-2_147_483_648.0), i32::MIN);
        assert_eq!(to_i32_clamped(-3.99), -3);
        assert_eq!(floor_to_i32_clamped(-3.5, -10, 10), -4);
        assert_eq!(floor_to_i32_clamped(1e30, -10, 10), 10);
        assert_eq!(floor_to_i32_clamped(f32::NAN, 2, 10), 2);
    }

    #[test]
    fn nan_aware_helpers() {
        assert_eq!(clamp(f32::NAN, 0.0, 1.0), 0.0);
        assert_eq!(saturate(2.0), 1.0);
        assert_eq!(min(f32::NAN, 1.0), 1.0);
        assert_eq!(max(f32::NAN, 1.0), 1.0);
        assert_eq!(sign_not_zero(-0.0), -1.0);
        assert_eq!(sign_not_zero(0.0), 1.0);
        assert_eq!(unorm24(u32::MAX), 1.0 - 1.0 / 16_777_216.0);
        assert!(unorm24(u32::MAX) < 1.0);
        assert_eq!(safe_sqrt(-1e-9), 0.0);
    }
}
